//! Simulated experiments: planning reachable poses and producing the captures a real rig would.

pub mod ball;
pub mod disk;
pub mod disturb;
pub mod dynamics;
pub mod edge;
pub mod poses;

use crate::robot::{Robot, RobotError};
use crate::sensor::SensorModel;
use nalgebra::{Isometry3, Rotation3, Translation3, UnitQuaternion, Vector3};
use thiserror::Error;

/// The robot, the sensor and the true mounting between them.
#[derive(Debug, Clone)]
pub struct Rig {
    pub robot: Robot,
    pub sensor: SensorModel,
    /// The truth the calibration must recover.
    pub flange_to_sensor: Isometry3<f64>,
}

impl Rig {
    /// base_to_sensor for a flange (tool0) pose.
    pub fn base_to_sensor(&self, base_to_flange: &Isometry3<f64>) -> Isometry3<f64> {
        base_to_flange * self.flange_to_sensor
    }
}

#[derive(Debug, Error, Clone, PartialEq)]
pub enum PlanError {
    #[error(
        "scan {scan}: the flange pose at ({x_mm:.1}, {y_mm:.1}, {z_mm:.1}) mm is not reachable: {source}; move the specimen (its position_mm) or change the orientation"
    )]
    Unreachable {
        scan: usize,
        x_mm: f64,
        y_mm: f64,
        z_mm: f64,
        #[source]
        source: RobotError,
    },
    #[error("scan {scan}: {reason}")]
    BadScan { scan: usize, reason: String },
    #[error("group {group}: the laser plane is parallel to the edge")]
    ParallelToEdge { group: usize },
    #[error("an arc of {points} points has no circle")]
    NoCircle { points: usize },
}

/// base_to_flange from a rotation and a position.
pub fn flange_pose(r: &Rotation3<f64>, t: &Vector3<f64>) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::from(*t),
        UnitQuaternion::from_rotation_matrix(r),
    )
}

/// Check that the robot reaches a flange pose; the error names the scan and the position.
pub fn check_reachable(robot: &Robot, scan: usize, pose: &Isometry3<f64>) -> Result<(), PlanError> {
    robot.ik(pose, None).map(|_| ()).map_err(|source| {
        let t = pose.translation.vector * 1e3;
        PlanError::Unreachable {
            scan,
            x_mm: t.x,
            y_mm: t.y,
            z_mm: t.z,
            source,
        }
    })
}

/// Where a curve `c(s)` given in the sensor frame crosses the laser plane (sensor y = 0), by
/// Newton's method from `s0` with a central-difference slope: the feature of an imperfect
/// specimen (a warped rim, a bowed edge) near the perfect one's. None when it does not converge
/// (the plane nearly runs along the curve).
pub fn laser_plane_crossing(
    curve: impl Fn(f64) -> nalgebra::Point3<f64>,
    s0: f64,
) -> Option<nalgebra::Point3<f64>> {
    let h = 1e-6;
    let mut s = s0;
    for _ in 0..8 {
        let g = curve(s).y;
        let dg = (curve(s + h).y - curve(s - h).y) / (2.0 * h);
        if dg.abs() < 1e-15 {
            return None;
        }
        s -= g / dg;
    }
    let p = curve(s);
    (p.y.abs() < 1e-12).then_some(p)
}
