//! The ball-based two-step method the disk paper compares against (Sec. IV-A and V-D): the ball
//! centre in the sensor frame from each arc's circle, R_sensor from captures sharing one
//! orientation, then T_sensor from captures at other orientations.

use super::{CalibError, Status};
use crate::features::Circle;
use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};

const METHOD: &str = "ball";

/// One capture: the flange pose and the ball centre seen in the sensor frame (q^i).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BallCapture {
    pub r_tcp: Rotation3<f64>,
    pub t_tcp: Vector3<f64>,
    pub q_in_sensor: Vector3<f64>,
}

/// q^i from an arc's circle (Sec. IV-A): (c_x, s sqrt(r_b^2 - r_d^2), c_z). A circle larger than the
/// ball (noise near a great circle) is taken as the great circle.
pub fn centre_from_arc(circle: &Circle, ball_radius: f64, s: f64) -> Vector3<f64> {
    let h2 = (ball_radius * ball_radius - circle.radius * circle.radius).max(0.0);
    Vector3::new(circle.centre.x, s * h2.sqrt(), circle.centre.y)
}

#[derive(Debug, Clone, PartialEq)]
pub struct BallProblem {
    /// Captures sharing one orientation, translated (at least 4): they give R_sensor.
    pub rotation_set: Vec<BallCapture>,
    /// Captures at different orientations (at least 3): they give T_sensor.
    pub translation_set: Vec<BallCapture>,
    /// How far apart (deg) the rotation set's orientations may be: `ORIENTATION_TOLERANCE_DEG`
    /// unless the user says otherwise.
    pub orientation_tolerance_deg: f64,
}

#[derive(Debug, Clone, PartialEq)]
pub struct BallSolution {
    pub flange_to_sensor: Isometry3<f64>,
    /// Ball centre from each translation-set capture, their mean, and the largest deviation (Eq. 56).
    pub centres_in_base: Vec<Vector3<f64>>,
    pub centre_in_base: Vector3<f64>,
    pub spread: f64,
    pub status: Status,
}

/// R_sensor from captures at one orientation: R_sensor (q^i - q-bar) = -R^-1 (T_i - T-bar), solved
/// by SVD with the reflection guard.
pub fn rotation_from_translations(
    set: &[BallCapture],
    tolerance_deg: f64,
) -> Result<Rotation3<f64>, CalibError> {
    if set.len() < 4 {
        return Err(CalibError::TooFewData {
            method: METHOD,
            what: "captures at the rotation orientation",
            got: set.len(),
            need: 4,
        });
    }
    let rotations: Vec<Rotation3<f64>> = set.iter().map(|c| c.r_tcp).collect();
    let r0 = super::shared_orientation(&rotations, tolerance_deg).map_err(|(i, angle)| {
        CalibError::Degenerate {
            method: METHOD,
            what: format!(
                "rotation-set capture {i} is {angle:.3} deg from the set's mean orientation \
                 (tolerance {} deg)",
                tolerance_deg
            ),
            part: "rotation",
            fix: "take the rotation set by translating the flange only, allow the controller's \
                  jitter (calibrate --orientation-tolerance-deg), or use ball-any-pose",
        }
    })?;
    let moves: Vec<Vector3<f64>> = set.iter().map(|c| c.t_tcp).collect();
    let (ratio, length, width) = super::line_spread(&moves);
    if !(ratio >= super::MIN_LINE_SPREAD) {
        return Err(CalibError::Degenerate {
            method: METHOD,
            what: format!(
                "the rotation-set translations are collinear: they leave their line by {:.3} mm \
                 RMS over {:.3} mm (ratio {ratio:.2e}, at least {} needed)",
                width * 1e3,
                length * 1e3,
                super::MIN_LINE_SPREAD
            ),
            part: "rotation",
            fix: "translate in at least two directions",
        });
    }
    let n = set.len() as f64;
    let qm = set.iter().map(|c| c.q_in_sensor).sum::<Vector3<f64>>() / n;
    let tm = set.iter().map(|c| c.t_tcp).sum::<Vector3<f64>>() / n;
    let inv = r0.inverse();
    let mut h = Matrix3::zeros();
    for c in set {
        h += (c.q_in_sensor - qm) * (-(inv * (c.t_tcp - tm))).transpose();
    }
    super::rotation_from_correlation(&h).ok_or_else(|| CalibError::Degenerate {
        method: METHOD,
        what: "the rotation-set translations are collinear".into(),
        part: "rotation",
        fix: "translate in at least two directions",
    })
}

/// T_sensor given R_sensor: (R_i - R_j) T = R_j R q^j - R_i R q^i + T_j - T_i over consecutive
/// captures (as the disk paper's Eq. 17), least squares.
pub fn translation_given_rotation(
    set: &[BallCapture],
    r_sensor: &Rotation3<f64>,
) -> Result<Vector3<f64>, CalibError> {
    let n = set.len();
    if n < 3 {
        return Err(CalibError::TooFewData {
            method: METHOD,
            what: "captures at different orientations",
            got: n,
            need: 3,
        });
    }
    let caps: Vec<_> = set
        .iter()
        .map(|c| (c.r_tcp, c.t_tcp, c.q_in_sensor))
        .collect();
    super::translation_from_fixed_point(&caps, r_sensor).ok_or_else(|| CalibError::Degenerate {
        method: METHOD,
        what: "the translation-set orientations differ only by rotations about one axis".into(),
        part: "translation",
        fix: "use orientations tilted about at least two different axes",
    })
}

pub fn solve(p: &BallProblem) -> Result<BallSolution, CalibError> {
    let r = rotation_from_translations(&p.rotation_set, p.orientation_tolerance_deg)?;
    let t = translation_given_rotation(&p.translation_set, &r)?;
    let flange_to_sensor = Isometry3::from_parts(
        Translation3::from(t),
        UnitQuaternion::from_rotation_matrix(&r),
    );
    let centres: Vec<Vector3<f64>> = p
        .translation_set
        .iter()
        .map(|c| {
            c.r_tcp * (flange_to_sensor * nalgebra::Point3::from(c.q_in_sensor)).coords + c.t_tcp
        })
        .collect();
    let mean = centres.iter().sum::<Vector3<f64>>() / centres.len() as f64;
    let spread = centres
        .iter()
        .map(|c| (c - mean).norm())
        .fold(0.0, f64::max);
    Ok(BallSolution {
        flange_to_sensor,
        centres_in_base: centres,
        centre_in_base: mean,
        spread,
        status: Status::ClosedForm,
    })
}
