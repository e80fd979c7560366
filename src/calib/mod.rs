//! Calibration methods, one file each: a `Problem` in, a `Solution` out (with residuals and a
//! status). Pure math: no I/O.

pub mod ball;
pub mod disk;
pub mod edge;
pub mod ellipse;

use nalgebra::{Isometry3, Matrix3, UnitQuaternion};
use thiserror::Error;

/// How a solver finished. A closed-form method is `ClosedForm`; an iterative one says whether it
/// converged (not converging is a result to report, not an error).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    ClosedForm,
    Converged { iterations: usize },
    NotConverged { iterations: usize },
}

#[derive(Debug, Error, Clone, PartialEq)]
pub enum CalibError {
    #[error("{method}: {got} {what} given, at least {need} are needed; collect more")]
    TooFewData {
        method: &'static str,
        what: &'static str,
        got: usize,
        need: usize,
    },
    #[error(
        "scan {scan}: the chord ends do not trace an ellipse ({reason}); is the scan direction parallel to the disk?"
    )]
    NotAnEllipse { scan: usize, reason: String },
    #[error(
        "scan {scan}: the scan direction is {angle_deg:.2} deg from the disk plane; it must be neither \
         parallel nor perpendicular to the disk (disk paper Eq. 2): tilt the motion"
    )]
    ScanParallelToDisk { scan: usize, angle_deg: f64 },
    #[error(
        "scan {scan}: the scan direction is {angle_deg:.2} deg from the disk normal; it must be neither \
         parallel nor perpendicular to the disk (disk paper Eq. 2): tilt the motion"
    )]
    ScanPerpendicularToDisk { scan: usize, angle_deg: f64 },
    #[error("{method}: {what}; the data cannot determine the {part}: {fix}")]
    Degenerate {
        method: &'static str,
        what: String,
        part: &'static str,
        fix: &'static str,
    },
}

/// Errors of an estimate against the truth.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct PoseError {
    pub rotation_error_deg: f64,
    pub translation_error_mm: f64,
    /// |R_est - R_true|_F.
    pub frobenius_rotation: f64,
}

impl PoseError {
    pub fn between(est: &Isometry3<f64>, truth: &Isometry3<f64>) -> PoseError {
        let r_e = est.rotation.to_rotation_matrix().into_inner();
        let r_t = truth.rotation.to_rotation_matrix().into_inner();
        PoseError {
            rotation_error_deg: est.rotation.angle_to(&truth.rotation).to_degrees(),
            translation_error_mm: (est.translation.vector - truth.translation.vector).norm() * 1e3,
            frobenius_rotation: (r_e - r_t).norm(),
        }
    }
}

/// A rotation from a matrix known to be (nearly) orthonormal.
pub fn quat_from_matrix(m: &Matrix3<f64>) -> UnitQuaternion<f64> {
    UnitQuaternion::from_rotation_matrix(&crate::math::nearest_rotation(m))
}
