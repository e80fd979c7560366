//! Free pose sets (issue 14): generated around a specimen, or listed, and checked against the
//! robot. The any-pose estimators' data collection instead of a paper's protocol.

use super::{PlanError, Rig, check_reachable};
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use rand::RngExt;

/// Which way a pose set is given, checked.
#[derive(Debug, Clone, PartialEq)]
pub enum PoseSource {
    Generate {
        count: usize,
        tilt: (f64, f64),
        spread: f64,
        /// Pose i turned i / count of a full turn about the normal (else at random).
        circle: bool,
    },
    /// Flange poses: position (m) and unit quaternion (w, x, y, z).
    Tcp(Vec<([f64; 3], [f64; 4])>),
    /// Joint angles (rad).
    Joints(Vec<[f64; 6]>),
}

/// Where generated poses look: a point of the specimen, its normal on the sensor's side, and how
/// far from the laser plane the point may lie (0 for a plane; up to 0.7 R for a ball, so that
/// the plane cuts an arc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aim {
    pub point: Point3<f64>,
    pub normal: Vector3<f64>,
    pub off_plane: f64,
    /// An edge's direction the laser plane must cross at 30 deg or more.
    pub crossing: Option<Vector3<f64>>,
    /// The direction across the edge the sensor's x must point along (a ridge's or groove's
    /// faces then come in one order along every profile: `calib::faces`).
    pub sense: Option<Vector3<f64>>,
}

impl Aim {
    /// Whether a flange pose's laser plane crosses `crossing` steeply enough.
    fn crosses(&self, rig: &Rig, base_to_flange: &Isometry3<f64>) -> bool {
        let sensor = (base_to_flange * rig.flange_to_sensor).rotation;
        self.crossing.is_none_or(|d| {
            let y = sensor * Vector3::y();
            y.dot(&d).abs() >= 0.5 * d.norm()
        }) && self
            .sense
            .is_none_or(|a| (sensor * Vector3::x()).dot(&a) > 0.0)
    }
}

/// The flange poses of a pose set: generated (each drawn until the robot reaches it, at most a
/// hundred times), or listed (flange poses the robot must reach; joint angles within limits).
pub fn poses(
    rig: &Rig,
    aim: &Aim,
    source: &PoseSource,
    rng: &mut crate::rng::Rng,
) -> Result<Vec<Isometry3<f64>>, PlanError> {
    match source {
        PoseSource::Generate {
            count,
            tilt,
            spread,
            circle,
        } => (0..*count)
            .map(|i| {
                let mut last = String::new();
                let azimuth = circle.then(|| std::f64::consts::TAU * i as f64 / *count as f64);
                for _ in 0..100 {
                    let f = draw(rig, aim, *tilt, *spread, azimuth, rng);
                    if !aim.crosses(rig, &f) {
                        last = "the laser plane crossed the edge at under 30 deg".into();
                        continue;
                    }
                    match check_reachable(&rig.robot, i, &f) {
                        Ok(()) => return Ok(f),
                        Err(e) => last = e.to_string(),
                    }
                }
                Err(PlanError::BadScan {
                    scan: i,
                    reason: format!(
                        "100 draws failed (last: {last}); aim nearer the robot or narrow the tilts"
                    ),
                })
            })
            .collect(),
        PoseSource::Tcp(list) => list
            .iter()
            .enumerate()
            .map(|(i, (p, q))| {
                let f = Isometry3::from_parts(
                    Translation3::new(p[0], p[1], p[2]),
                    UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
                        q[0], q[1], q[2], q[3],
                    )),
                );
                check_reachable(&rig.robot, i, &f).map(|()| f)
            })
            .collect(),
        PoseSource::Joints(list) => list
            .iter()
            .enumerate()
            .map(|(i, q)| {
                if !rig.robot.within_limits(q, 1e-9) {
                    return Err(PlanError::BadScan {
                        scan: i,
                        reason: format!(
                            "joints {:?} deg lie outside the robot's limits",
                            q.map(f64::to_degrees)
                        ),
                    });
                }
                Ok(rig.robot.fk(q))
            })
            .collect(),
    }
}

/// One generated pose: the laser tilted from -normal by an angle in `tilt`, turned about the
/// normal by `azimuth` (None: at random) and at random about its own axis; the aim point at a
/// random depth within the middle 70 % of the range, up to `spread` along the laser line and
/// `off_plane` across it.
fn draw(
    rig: &Rig,
    aim: &Aim,
    tilt: (f64, f64),
    spread: f64,
    azimuth: Option<f64>,
    g: &mut crate::rng::Rng,
) -> Isometry3<f64> {
    let s = &rig.sensor;
    let mut u = || g.random::<f64>();
    let theta = tilt.0 + (tilt.1 - tilt.0) * u();
    // Drawn either way, so a circle's other draws are a random set's.
    let drawn = std::f64::consts::TAU * u();
    let (azimuth, roll) = (azimuth.unwrap_or(drawn), std::f64::consts::TAU * u());
    let to_normal =
        UnitQuaternion::rotation_between(&Vector3::z(), &aim.normal).unwrap_or_else(|| {
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
        });
    let ray = to_normal
        * -Vector3::new(
            theta.sin() * azimuth.cos(),
            theta.sin() * azimuth.sin(),
            theta.cos(),
        );
    // The laser travels along the sensor's z times dir_z.
    let rot =
        UnitQuaternion::rotation_between(&Vector3::z(), &(ray * s.dir_z)).unwrap_or_else(|| {
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
        }) * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), roll);
    let depth = 0.5 * (s.depth_near + s.depth_far)
        + 0.35 * (s.depth_far - s.depth_near) * (2.0 * u() - 1.0);
    let target = Vector3::new(
        spread * (2.0 * u() - 1.0),
        aim.off_plane * (2.0 * u() - 1.0),
        s.apex_z + s.dir_z * depth,
    );
    let base_to_sensor =
        Isometry3::from_parts(Translation3::from(aim.point.coords - rot * target), rot);
    base_to_sensor * rig.flange_to_sensor.inverse()
}

/// Scanning on the move through a free pose set: the arm passes each pose in turn without
/// stopping, the profile taken as it passes, and the controller logs its poses while the
/// profiler time-stamps the profiles `clock_offset` (s) late.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Passing {
    /// The flange's speed (m/s) through each pose, toward the next (away from the one before
    /// for the last); the turn to the next pose spread over the same move.
    pub speed: f64,
    pub clock_offset: f64,
    /// Whether the estimators estimate the offset (`captures::Timing::estimate_offset`).
    pub estimate: bool,
}

/// The controller's log rate while passing (Hz).
const PASS_LOG_HZ: f64 = 250.0;

impl Passing {
    /// Captures taken at their profiles' poses as they pass (each at its pose's time) made as a
    /// moving cell records them: each profile at the log's pose at its stamp, the log and the
    /// stamps kept. Through each pose the flange moves at a steady velocity and turn rate (a
    /// straight line and a turn about one axis, which the log's interpolation reproduces
    /// exactly), logged from `0.05 s + |offset|` before it to as long after.
    pub fn apply(&self, caps: &mut crate::captures::Captures) {
        let poses: Vec<Isometry3<f64>> = caps.profiles.iter().map(|p| p.base_to_flange).collect();
        let n = poses.len();
        if n < 2 || !(self.speed > 0.0) {
            return;
        }
        let half = 0.05 + self.clock_offset.abs();
        let (mut stream, mut times) = (Vec::new(), Vec::with_capacity(n));
        let mut t = half;
        for i in 0..n {
            let (from, to) = if i + 1 < n { (i, i + 1) } else { (i - 1, i) };
            let step = poses[to].translation.vector - poses[from].translation.vector;
            let duration = (step.norm() / self.speed).max(1e-3);
            let velocity = step / duration;
            let turn =
                (poses[from].rotation.inverse() * poses[to].rotation).scaled_axis() / duration;
            let at = |u: f64| {
                Isometry3::from_parts(
                    Translation3::from(poses[i].translation.vector + velocity * u),
                    poses[i].rotation * UnitQuaternion::from_scaled_axis(turn * u),
                )
            };
            let samples = (2.0 * half * PASS_LOG_HZ).ceil() as usize;
            for k in 0..=samples {
                let u = -half + k as f64 / PASS_LOG_HZ;
                stream.push((t + u, at(u)));
            }
            times.push(t);
            // The next pass's log starts after this one's ends.
            t += (samples as f64 / PASS_LOG_HZ + 0.01).max(duration);
        }
        let stamps: Vec<f64> = times.iter().map(|t| t + self.clock_offset).collect();
        for (p, s) in caps.profiles.iter_mut().zip(&stamps) {
            if let Some(f) = crate::math::pose_at(&stream, *s) {
                p.base_to_flange = f;
            }
        }
        caps.timing = Some(crate::captures::Timing {
            stream,
            stamps,
            offset_s: 0.0,
            estimate_offset: self.estimate,
            estimate_drift: false,
        });
    }
}
