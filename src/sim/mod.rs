//! Simulated experiments: planning reachable poses and producing the captures a real rig would.

pub mod ball;
pub mod disk;
pub mod disturb;
pub mod dynamics;
pub mod edge;

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
        "scan {scan}: the flange pose at ({x_mm:.1}, {y_mm:.1}, {z_mm:.1}) mm is not reachable: {source}; move the specimen or change the orientation"
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
