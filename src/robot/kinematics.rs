//! Forward kinematics (f64, exact up to rounding).

use super::{Joints, Robot, RobotError};
use nalgebra::{Isometry3, UnitQuaternion};

impl Robot {
    /// Frames after 0..=6 actuated joints: `frames[k]` is the pose, in the base frame, of the child
    /// link of joint k (`frames[0]` is the root link, the identity).
    pub fn joint_frames(&self, q: &Joints) -> [Isometry3<f64>; 7] {
        let mut out = [Isometry3::identity(); 7];
        for (k, (j, &v)) in self.joints.iter().zip(q).enumerate() {
            out[k + 1] = out[k] * j.prev_to_joint * UnitQuaternion::from_axis_angle(&j.axis, v);
        }
        out
    }

    /// `base_to_tool0` for joint values `q` (radians).
    pub fn fk(&self, q: &Joints) -> Isometry3<f64> {
        let mut t = Isometry3::identity();
        for (j, &v) in self.joints.iter().zip(q) {
            t = t * j.prev_to_joint * UnitQuaternion::from_axis_angle(&j.axis, v);
        }
        t * self.last_to_tool0
    }

    /// `base_to_link` for any link of the chain.
    pub fn fk_link(&self, q: &Joints, link: &str) -> Result<Isometry3<f64>, RobotError> {
        let l =
            self.links
                .iter()
                .find(|l| l.name == link)
                .ok_or_else(|| RobotError::UnknownLink {
                    robot: self.name.clone(),
                    link: link.to_string(),
                })?;
        Ok(self.joint_frames(q)[l.after_joints] * l.offset)
    }

    /// `base_to_link` for every link, in chain order.
    pub fn link_poses(&self, q: &Joints) -> Vec<Isometry3<f64>> {
        let frames = self.joint_frames(q);
        self.links
            .iter()
            .map(|l| frames[l.after_joints] * l.offset)
            .collect()
    }
}

/// Kinematic error parameters per actuated joint in `Robot::error_twists`: the joint origin's
/// offset along the three axes of the frame it is stated in (a link-length error, m), then the
/// joint's zero offset (rad). The simulator's `sim::disturb::RobotError` draws the same.
pub const ERRORS_PER_JOINT: usize = 4;

impl Robot {
    /// How the flange moves at joint values `q` per unit of each kinematic error parameter
    /// (`ERRORS_PER_JOINT` per joint, joint 1 first): a twist in the flange's own frame,
    /// [rotation (rad); translation (m)], such that the flange reached is
    /// `fk(q) * exp(twist * error)` to first order. Exact first derivatives, no differencing.
    pub fn error_twists(&self, q: &Joints) -> Vec<nalgebra::Vector6<f64>> {
        let frames = self.joint_frames(q);
        let tool = self.fk(q);
        let to_flange = tool.rotation.inverse();
        let mut out = Vec::with_capacity(self.joints.len() * ERRORS_PER_JOINT);
        for (k, j) in self.joints.iter().enumerate() {
            let at_joint = frames[k] * j.prev_to_joint;
            // A shift of the joint's origin, stated in its parent's frame, moves every later
            // frame by the same vector.
            for axis in 0..3 {
                let d = frames[k].rotation * nalgebra::Vector3::ith(axis, 1.0);
                out.push(stack(&nalgebra::Vector3::zeros(), &(to_flange * d)));
            }
            // A zero offset turns everything after the joint about its axis.
            let w = at_joint.rotation * j.axis.into_inner();
            let v = w.cross(&(tool.translation.vector - at_joint.translation.vector));
            out.push(stack(&(to_flange * w), &(to_flange * v)));
        }
        out
    }
}

fn stack(a: &nalgebra::Vector3<f64>, b: &nalgebra::Vector3<f64>) -> nalgebra::Vector6<f64> {
    nalgebra::Vector6::new(a.x, a.y, a.z, b.x, b.y, b.z)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each twist is the derivative of the flange pose under the error the simulator draws.
    #[test]
    fn error_twists_are_the_derivatives_of_the_perturbed_arm() {
        let robot = Robot::resolve("irb120").unwrap();
        let q = [0.3, -0.4, 0.5, 0.7, -0.6, 1.1];
        let nominal = robot.fk(&q);
        let twists = robot.error_twists(&q);
        assert_eq!(twists.len(), 6 * ERRORS_PER_JOINT);
        let h = 1e-7;
        for (k, t) in twists.iter().enumerate() {
            let mut r = robot.clone();
            let j = &mut r.joints[k / ERRORS_PER_JOINT];
            match k % ERRORS_PER_JOINT {
                3 => j.prev_to_joint *= UnitQuaternion::from_axis_angle(&j.axis, h),
                a => {
                    j.prev_to_joint.translation.vector += nalgebra::Vector3::ith(a, h);
                }
            }
            let d = nominal.inverse() * r.fk(&q);
            let got = stack(&d.rotation.scaled_axis(), &d.translation.vector) / h;
            assert!(
                (got - t).norm() < 1e-6 * t.norm().max(1.0),
                "{k}: {got} vs {t}"
            );
        }
    }
}
