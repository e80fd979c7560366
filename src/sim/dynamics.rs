//! Arm dynamics with rapier: the arm as a multibody built from the URDF (masses and inertias; the
//! IRB 2600's are estimates), each joint driven by a position servo (rapier's PD joint motor, with
//! the stiffness acting as the joint's servo stiffness), moved along a joint trajectory that keeps
//! to the axis speed limits, then left to settle while the sensor samples at its profile rate.

use crate::robot::{Joints, Robot};
use nalgebra::{Isometry3, Point3, Vector3};
use rapier3d_f64::prelude::*;

/// Servo gains of every joint (rapier's acceleration-based motor: stiffness in 1/s^2, damping in
/// 1/s, so the response does not depend on the link inertia).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoGains {
    pub stiffness: f64,
    pub damping: f64,
}

impl Default for ServoGains {
    /// A stiff, slightly underdamped servo: natural frequency 100 rad/s (16 Hz), damping ratio 0.2,
    /// so a stop leaves a visible ringing, as the papers describe.
    fn default() -> Self {
        ServoGains {
            stiffness: 1.0e4,
            damping: 40.0,
        }
    }
}

/// What a move and its settling did to the TCP.
#[derive(Debug, Clone, PartialEq)]
pub struct MoveReport {
    /// tool0 sampled at the profile rate while settling.
    pub samples: Vec<Isometry3<f64>>,
    /// Largest and RMS distance of the sampled tool0 positions from the commanded one (metres).
    pub peak_deviation: f64,
    pub rms_deviation: f64,
    /// Simulated seconds.
    pub simulated: f64,
}

pub struct ArmDynamics {
    pipeline: PhysicsPipeline,
    params: IntegrationParameters,
    islands: IslandManager,
    broad: DefaultBroadPhase,
    narrow: NarrowPhase,
    bodies: RigidBodySet,
    colliders: ColliderSet,
    impulse: ImpulseJointSet,
    multibody: MultibodyJointSet,
    ccd: CCDSolver,
    joints: Vec<MultibodyJointHandle>,
    last: RigidBodyHandle,
    last_to_tool0: Isometry3<f64>,
    gains: ServoGains,
    gravity: Vector3<f64>,
    target: Joints,
    robot: Robot,
}

/// An arm the dynamic model cannot simulate.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum DynamicsError {
    #[error("time step {dt_s} s: use 0 < dt <= 0.01 s")]
    TimeStep { dt_s: f64 },
    #[error("{urdf}: joint origins with a rotation are not supported by the dynamic model yet")]
    RotatedJointOrigin { urdf: String },
    #[error("joint '{joint}' could not join the multibody")]
    Multibody { joint: String },
}

impl ArmDynamics {
    /// Build the multibody at joint angles zero with gravity along -z (base frame).
    pub fn new(robot: &Robot, gains: ServoGains, dt: f64) -> Result<ArmDynamics, DynamicsError> {
        if !(dt > 0.0 && dt <= 0.01) {
            return Err(DynamicsError::TimeStep { dt_s: dt });
        }
        if robot
            .joints
            .iter()
            .any(|j| j.prev_to_joint.rotation.angle() > 1e-12)
        {
            return Err(DynamicsError::RotatedJointOrigin {
                urdf: robot.source.to_string(),
            });
        }
        let mut bodies = RigidBodySet::new();
        let mut multibody = MultibodyJointSet::new();
        let frames = robot.joint_frames(&[0.0; 6]);
        let base = bodies.insert(RigidBodyBuilder::fixed().build());
        let mut parent = base;
        let mut joints = Vec::new();
        for (k, j) in robot.joints.iter().enumerate() {
            // The child link of joint k: the link right after it (after_joints == k + 1, no offset).
            let link = robot.links.iter().find(|l| {
                l.after_joints == k + 1
                    && l.offset.translation.vector.norm() == 0.0
                    && l.offset.rotation.angle() == 0.0
            });
            let (mass, com, inertia) = match link.and_then(|l| l.inertial.as_ref()) {
                Some(i) if i.mass_kg > 0.0 => (
                    i.mass_kg,
                    i.link_to_com.translation.vector,
                    Vector3::new(
                        i.inertia[0].max(1e-6),
                        i.inertia[1].max(1e-6),
                        i.inertia[2].max(1e-6),
                    ),
                ),
                _ => (0.01, Vector3::zeros(), Vector3::repeat(1e-6)),
            };
            let child = bodies.insert(
                RigidBodyBuilder::dynamic()
                    .pose(frames[k + 1])
                    .additional_mass_properties(MassProperties::new(
                        Point3::from(com),
                        mass,
                        inertia,
                    ))
                    .build(),
            );
            let joint = RevoluteJointBuilder::new(j.axis)
                .local_anchor1(Point3::from(j.prev_to_joint.translation.vector))
                .local_anchor2(Point3::origin())
                .motor_position(0.0, gains.stiffness, gains.damping);
            let h = multibody
                .insert(parent, child, joint, true)
                .ok_or_else(|| DynamicsError::Multibody {
                    joint: j.name.clone(),
                })?;
            joints.push(h);
            parent = child;
        }
        Ok(ArmDynamics {
            pipeline: PhysicsPipeline::new(),
            params: IntegrationParameters {
                dt,
                ..Default::default()
            },
            islands: IslandManager::new(),
            broad: DefaultBroadPhase::new(),
            narrow: NarrowPhase::new(),
            bodies,
            colliders: ColliderSet::new(),
            impulse: ImpulseJointSet::new(),
            multibody,
            ccd: CCDSolver::new(),
            joints,
            last: parent,
            last_to_tool0: robot.last_to_tool0,
            gains,
            gravity: Vector3::new(0.0, 0.0, -9.81),
            target: [0.0; 6],
            robot: robot.clone(),
        })
    }

    fn set_targets(&mut self, q: &Joints) {
        for (h, &v) in self.joints.iter().zip(q) {
            if let Some((mb, id)) = self.multibody.get_mut(*h)
                && let Some(link) = mb.link_mut(id)
            {
                link.joint.data.set_motor_position(
                    JointAxis::AngX,
                    v,
                    self.gains.stiffness,
                    self.gains.damping,
                );
            }
        }
        self.target = *q;
    }

    fn step(&mut self) {
        self.pipeline.step(
            &self.gravity,
            &self.params,
            &mut self.islands,
            &mut self.broad,
            &mut self.narrow,
            &mut self.bodies,
            &mut self.colliders,
            &mut self.impulse,
            &mut self.multibody,
            &mut self.ccd,
            &(),
            &(),
        );
    }

    /// The simulated tool0 pose.
    pub fn tool0(&self) -> Isometry3<f64> {
        self.bodies
            .get(self.last)
            .map(|b| b.position() * self.last_to_tool0)
            .unwrap_or_else(Isometry3::identity)
    }

    /// Move to `q` along a straight joint-space path at the axis speed limits (scaled by
    /// `speed_fraction`), then settle for `settle_s` seconds sampling tool0 every 1/`rate_hz`.
    pub fn move_to(
        &mut self,
        q: &Joints,
        speed_fraction: f64,
        settle_s: f64,
        rate_hz: f64,
    ) -> MoveReport {
        let dt = self.params.dt;
        let from = self.target;
        let speeds = self.robot.max_speed();
        let duration = (0..6)
            .map(|i| (q[i] - from[i]).abs() / (speeds[i] * speed_fraction.clamp(1e-3, 1.0)))
            .fold(0.0, f64::max);
        let steps = (duration / dt).ceil() as usize;
        for s in 1..=steps {
            let f = s as f64 / steps as f64;
            let t: Joints = std::array::from_fn(|i| from[i] + (q[i] - from[i]) * f);
            self.set_targets(&t);
            self.step();
        }
        self.set_targets(q);
        let nominal = self.robot.fk(q).translation.vector;
        let settle_steps = (settle_s / dt).ceil() as usize;
        let every = ((1.0 / (rate_hz * dt)).round().min(1e9) as usize).max(1);
        let mut samples = Vec::new();
        for s in 0..settle_steps {
            self.step();
            if s % every == 0 {
                samples.push(self.tool0());
            }
        }
        let dev: Vec<f64> = samples
            .iter()
            .map(|p| (p.translation.vector - nominal).norm())
            .collect();
        let peak = dev.iter().fold(0.0, |m: f64, d| m.max(*d));
        let rms = (dev.iter().map(|d| d * d).sum::<f64>() / dev.len().max(1) as f64).sqrt();
        MoveReport {
            samples,
            peak_deviation: peak,
            rms_deviation: rms,
            simulated: (steps + settle_steps) as f64 * dt,
        }
    }
}
