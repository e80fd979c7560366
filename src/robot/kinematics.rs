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
