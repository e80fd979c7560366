//! Calibration methods, one file each: a `Problem` in, a `Solution` out (with residuals and a
//! status). Pure math: no I/O.

pub mod ball;
pub mod ball_any;
pub mod bar;
pub mod disk;
pub mod disk_any;
pub mod edge;
pub mod ellipse;
pub mod faces;
pub mod plane;
pub mod recast;
pub mod refine;

use nalgebra::{Isometry3, Matrix3, Rotation3, UnitQuaternion};
use thiserror::Error;

/// How far apart (deg) flange orientations a protocol wants equal may be: a real controller's
/// reported W, P, R jitter by 0.003-0.055 deg between "pure translations" (public data sets).
pub const ORIENTATION_TOLERANCE_DEG: f64 = 0.1;

/// The least a set of moves must leave a line, relative to its length (`line_spread`): a
/// protocol's "translate in two directions" with the second under 2 % of the first is collinear
/// within a robot's repeatability, whatever the numbers' precision.
pub const MIN_LINE_SPREAD: f64 = 0.02;

/// Raw points the fits of one calibration take at most, over all its profiles: past it every
/// profile's points are thinned evenly (`points_per_profile`), so the cost and memory of a
/// continuous scan's tens of thousands of profiles stay bounded. Thinning the 8.3 million face
/// points of 20,000 ray-cast disk profiles to it left disk-full 0.0005 deg / 0.0012 mm from the
/// truth (0.0003 deg / 0.0003 mm with every point, at twelve times the time and three times the
/// memory), far below what a robot reaches; captures of a few hundred profiles keep every point.
pub const POINT_BUDGET: usize = 250_000;

/// Fewest points per profile thinning keeps: a face's line needs its spread, not its count.
const MIN_POINTS_PER_PROFILE: usize = 16;

/// How many of each profile's points (at most `most`) fits over `profiles` profiles holding
/// `total` points in all keep: `most` while the total is within `POINT_BUDGET`, else the budget's
/// share per profile (at least `MIN_POINTS_PER_PROFILE`).
pub fn points_per_profile(total: usize, profiles: usize, most: usize) -> usize {
    if total <= POINT_BUDGET {
        return most;
    }
    most.min((POINT_BUDGET / profiles.max(1)).max(MIN_POINTS_PER_PROFILE))
}

/// The stride that keeps at most `keep` of `len` points, evenly.
pub fn stride_for(len: usize, keep: usize) -> usize {
    len.div_ceil(keep.max(1)).max(1)
}

/// How far a set of points leaves a line: the second singular value of the centred set over the
/// first, with the first and second (m, RMS about the centroid). 0 when all coincide.
pub fn line_spread(points: &[nalgebra::Vector3<f64>]) -> (f64, f64, f64) {
    let n = points.len().max(1) as f64;
    let mean = points.iter().sum::<nalgebra::Vector3<f64>>() / n;
    let mut cov = Matrix3::zeros();
    for p in points {
        let d = p - mean;
        cov += d * d.transpose() / n;
    }
    let mut ev: Vec<f64> = cov
        .symmetric_eigenvalues()
        .iter()
        .map(|v| v.max(0.0).sqrt())
        .collect();
    ev.sort_by(|a, b| b.total_cmp(a));
    let ratio = if ev[0] > 0.0 { ev[1] / ev[0] } else { 0.0 };
    (ratio, ev[0], ev[1])
}

/// The orientation a protocol's "one orientation" captures share: their chordal mean, or, when
/// one lies more than `tolerance_deg` from it (`ORIENTATION_TOLERANCE_DEG` unless the user says
/// otherwise), the farthest one's (index, angle in deg).
pub fn shared_orientation(
    rotations: &[Rotation3<f64>],
    tolerance_deg: f64,
) -> Result<Rotation3<f64>, (usize, f64)> {
    let first = rotations
        .first()
        .copied()
        .unwrap_or_else(Rotation3::identity);
    // Equal orientations (simulated protocols) keep the first exactly, not a rounded mean.
    if rotations
        .iter()
        .all(|r| (r.matrix() - first.matrix()).norm() <= 1e-12)
    {
        return Ok(first);
    }
    let sum: Matrix3<f64> = rotations.iter().map(|r| *r.matrix()).sum();
    let mean = crate::math::nearest_rotation(&sum);
    // The capture farthest from the mean is named: one turned far pulls the mean off the
    // others, and the first beyond the tolerance may be one of them.
    let (i, angle) = rotations
        .iter()
        .map(|r| mean.angle_to(r).to_degrees())
        .enumerate()
        .fold((0, 0.0), |w, (i, a)| if a > w.1 { (i, a) } else { w });
    if angle > tolerance_deg {
        return Err((i, angle));
    }
    Ok(mean)
}

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
        "scan {scan}: the chord ends do not trace an ellipse ({reason}): the scan saw too few \
         chords across the disk (profiles that missed it, chords clipped by the field of view), or \
         it moves parallel to the disk"
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
    #[error(
        "{method}: the poses cannot determine the transform (smallest singular value {ratio:.1e} of \
         the largest; weakest: {weakest}); {fix}"
    )]
    Unobservable {
        method: &'static str,
        ratio: f64,
        weakest: String,
        fix: String,
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

/// The rotation R minimising sum |R x_i - y_i|^2 from H = sum x_i y_i^T (Arun et al.: SVD with the
/// determinant guard against reflections). None when H has rank below 2 (the x_i all parallel).
pub fn rotation_from_correlation(h: &Matrix3<f64>) -> Option<nalgebra::Rotation3<f64>> {
    let svd = h.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    let mut sv = svd.singular_values;
    sv.as_mut_slice().sort_by(|a, b| b.total_cmp(a));
    if !(sv[1] > 1e-9 * sv[0]) {
        return None;
    }
    let v = v_t.transpose();
    let d = (v * u.transpose()).determinant().signum();
    Some(nalgebra::Rotation3::from_matrix_unchecked(
        v * Matrix3::from_diagonal(&nalgebra::Vector3::new(1.0, 1.0, d)) * u.transpose(),
    ))
}

/// T_sensor from captures of one fixed point (disk or ball centre) seen at q_i from flange poses
/// (R_i, T_i), given R_sensor: (R_i - R_i+1) T = R_i+1 R q_i+1 - R_i R q_i + T_i+1 - T_i over
/// consecutive captures (the disk paper's Eqs. 17-19), least squares. None when rank deficient.
pub fn translation_from_fixed_point(
    caps: &[(
        nalgebra::Rotation3<f64>,
        nalgebra::Vector3<f64>,
        nalgebra::Vector3<f64>,
    )],
    r_sensor: &nalgebra::Rotation3<f64>,
) -> Option<nalgebra::Vector3<f64>> {
    let n = caps.len();
    if n < 2 {
        return None;
    }
    let mut a = nalgebra::DMatrix::zeros(3 * (n - 1), 3);
    let mut b = nalgebra::DVector::zeros(3 * (n - 1));
    for i in 0..n - 1 {
        let ((r1, t1, q1), (r2, t2, q2)) = (&caps[i], &caps[i + 1]);
        a.fixed_view_mut::<3, 3>(3 * i, 0)
            .copy_from(&(r1.matrix() - r2.matrix()));
        b.fixed_rows_mut::<3>(3 * i)
            .copy_from(&(r2 * (r_sensor * q2) - r1 * (r_sensor * q1) + t2 - t1));
    }
    disk::solve_ls(&a, &b)
}
