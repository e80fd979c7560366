//! Physical causes of error between the commanded flange pose (what the controller reports and the
//! calibration sees) and the pose the sensor really has: robot pose error (ISO 9283 repeatability,
//! joint encoder noise, a systematic kinematic error) and arm vibration (a seeded, band-limited
//! random TCP perturbation). Every cause is off by default; off, the actual pose is the commanded
//! one exactly.

use crate::rng::Rng;
use crate::rng::gauss;
use crate::robot::{Joints, Robot};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use rand::RngExt;

/// Robot pose error (metres, radians).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RobotError {
    /// ISO 9283 position repeatability RP: each pose lands off by an isotropic Gaussian whose
    /// 3-sigma distance radius is RP (sigma per axis = RP / (3 sqrt 3)).
    pub repeatability: f64,
    /// Standard deviation of each joint's encoder reading error, per pose.
    pub joint_noise: f64,
    /// Systematic kinematic error drawn once per trial: the standard deviation of each joint
    /// origin's offset (a link-length error) and of each joint's zero offset.
    pub link_error: f64,
    pub joint_offset_error: f64,
}

/// Cheap vibration model: per axis, a sum of sinusoids with random frequencies in a band and random
/// phases, scaled to an RMS amplitude, sampled at the profile rate.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Vibration {
    pub amplitude_rms: f64,
    pub band_low_hz: f64,
    pub band_high_hz: f64,
    pub profile_rate_hz: f64,
}

impl RobotError {
    pub fn is_off(&self) -> bool {
        *self == RobotError::default()
    }

    /// About one standard deviation of a measured point's offset along one direction that this
    /// error makes (metres): the repeatability's per-axis sigma, each joint's link-length error
    /// (per axis), and each joint's angle errors acting over half the arm's reach (the sum of
    /// its link lengths). An allowance for
    /// the verdict's residual test, not a model of the arm.
    pub fn point_sd(&self, robot: &Robot) -> f64 {
        self.common_sd(robot).hypot(self.own_sd(robot))
    }

    /// The part of `point_sd` the trial's one draw of the arm makes (its link-length and
    /// joint-zero errors): common to the poses, in a pattern their configurations set.
    pub fn common_sd(&self, robot: &Robot) -> f64 {
        crate::captures::point_sd_of(robot, self.link_error, self.joint_offset_error)
    }

    /// The part each pose draws alone (the repeatability, the encoder noise).
    pub fn own_sd(&self, robot: &Robot) -> f64 {
        let rp = self.repeatability / (3.0 * 3f64.sqrt());
        rp.hypot(crate::captures::point_sd_of(robot, 0.0, self.joint_noise))
    }
}

impl Vibration {
    pub fn is_off(&self) -> bool {
        !(self.amplitude_rms > 0.0)
    }
}

/// The dynamic arm of a trial: every capture is taken after moving there and settling.
pub struct Dynamic {
    pub arm: crate::sim::dynamics::ArmDynamics,
    pub settle_s: f64,
    pub speed_fraction: f64,
}

/// The disturbance of one trial: the robot that really moves and the vibration signal.
pub struct Disturbance {
    /// Optional rapier arm: when set, the pose is where the simulated arm is after the move and
    /// the settle time (the static robot error then only adds repeatability).
    pub dynamic: Option<Dynamic>,
    err: RobotError,
    actual: Option<Robot>,
    vib: Vibration,
    /// Per axis: (frequency Hz, phase) of each sinusoid.
    waves: [[(f64, f64); 8]; 3],
    q_prev: Option<Joints>,
    rng: Rng,
    /// The trial's specimen placement as an offset of every pose (base frame, m): the specimen
    /// slid by minus this on the table (`with_placement`).
    placement: Vector3<f64>,
}

impl Disturbance {
    /// Draw the trial's systematic error and vibration signal from `rng`.
    pub fn new(robot: &Robot, err: RobotError, vib: Vibration, mut rng: Rng) -> Disturbance {
        let actual = (!err.is_off()).then(|| {
            let mut r = robot.clone();
            for j in &mut r.joints {
                if err.link_error > 0.0 {
                    let d = Vector3::new(gauss(&mut rng), gauss(&mut rng), gauss(&mut rng))
                        * err.link_error;
                    j.prev_to_joint = Isometry3::from_parts(
                        Translation3::from(j.prev_to_joint.translation.vector + d),
                        j.prev_to_joint.rotation,
                    );
                }
                if err.joint_offset_error > 0.0 {
                    let off = gauss(&mut rng) * err.joint_offset_error;
                    j.prev_to_joint *= UnitQuaternion::from_axis_angle(&j.axis, off);
                }
            }
            r
        });
        let mut waves = [[(0.0, 0.0); 8]; 3];
        for axis in &mut waves {
            for w in axis.iter_mut() {
                *w = (
                    rng.random_range(
                        vib.band_low_hz.min(vib.band_high_hz)
                            ..=vib.band_high_hz.max(vib.band_low_hz),
                    ),
                    rng.random_range(0.0..std::f64::consts::TAU),
                );
            }
        }
        Disturbance {
            dynamic: None,
            err,
            actual,
            vib,
            waves,
            q_prev: None,
            rng,
            placement: Vector3::zeros(),
        }
    }

    /// The same with the specimen slid by `-offset` (base x, y; m) on the table for the whole
    /// trial, as every pose moved by `offset`: the calibration, which estimates where the
    /// specimen stands, sees the same rig with the specimen elsewhere, and each scan meets the
    /// sensor's columns at another phase.
    pub fn with_placement(mut self, offset: Vector3<f64>) -> Disturbance {
        self.placement = offset;
        self
    }

    /// True when no cause is switched on.
    pub fn is_off(&self) -> bool {
        self.err.is_off()
            && self.vib.is_off()
            && self.dynamic.is_none()
            && self.placement == Vector3::zeros()
    }

    /// The vibration offset at profile `k` (metres, base frame).
    pub fn vibration_at(&self, k: usize) -> Vector3<f64> {
        if self.vib.is_off() || !(self.vib.profile_rate_hz > 0.0) {
            return Vector3::zeros();
        }
        let t = k as f64 / self.vib.profile_rate_hz;
        // Eight unit sinusoids have RMS 2 (= sqrt(8 / 2)); scale to the requested RMS.
        let scale = self.vib.amplitude_rms / 2.0;
        Vector3::from_fn(|a, _| {
            self.waves[a]
                .iter()
                .map(|(f, ph)| (std::f64::consts::TAU * f * t + ph).sin())
                .sum::<f64>()
                * scale
        })
    }

    /// The flange pose the robot really reaches when commanded `nominal` (profile `k` of the trial).
    pub fn actual(&mut self, robot: &Robot, nominal: &Isometry3<f64>, k: usize) -> Isometry3<f64> {
        if self.is_off() {
            return *nominal;
        }
        // The controller solves IK on the nominal model, from where the arm last was, and drives
        // the joints there.
        // (Vibration alone needs no joints.)
        let q = if self.dynamic.is_some() || !self.err.is_off() {
            robot
                .ik_nearest(nominal, &self.q_prev.unwrap_or([0.0; 6]))
                .ok()
        } else {
            None
        };
        if q.is_some() {
            self.q_prev = q;
        }
        let mut pose = *nominal;
        match (&mut self.dynamic, q) {
            // The simulated arm moves there and settles.
            (Some(dy), Some(q)) => {
                dy.arm.move_to(&q, dy.speed_fraction, dy.settle_s, 1e9);
                pose = dy.arm.tool0();
            }
            // The static model: encoder noise on the joints, the perturbed robot's kinematics.
            (None, Some(mut q)) if !self.err.is_off() => {
                for v in &mut q {
                    *v += gauss(&mut self.rng) * self.err.joint_noise;
                }
                pose = self.actual.as_ref().unwrap_or(robot).fk(&q);
            }
            _ => {}
        }
        if !self.err.is_off() {
            let sigma = self.err.repeatability / (3.0 * 3f64.sqrt());
            let d = Vector3::new(
                gauss(&mut self.rng),
                gauss(&mut self.rng),
                gauss(&mut self.rng),
            ) * sigma;
            pose = Isometry3::from_parts(
                Translation3::from(pose.translation.vector + d),
                pose.rotation,
            );
        }
        let v = self.vibration_at(k) + self.placement;
        Isometry3::from_parts(
            Translation3::from(pose.translation.vector + v),
            pose.rotation,
        )
    }
}
