//! The disk method (Chen et al. 2018, Sec. III-B/C): chords -> projected ellipse -> sensing data
//! -> R_sensor by SVD, T_sensor by least squares.

use super::ellipse::{Ellipse, EllipseFitError};
use super::{CalibError, Status};
use nalgebra::{
    DMatrix, DVector, Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector2, Vector3,
};

pub const METHOD: &str = "disk";

/// One chord (Eq. 4): its ends (x, z) in the sensor frame, and where along the scan it was taken
/// (`u` = 0 at T-bar, 1 at T-tilde; the paper's (j-1)/(m-1)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiskChord {
    pub u: f64,
    pub a: Vector2<f64>,
    pub b: Vector2<f64>,
}

/// One scan (one sensing datum to be): a fixed flange orientation, the straight TCP move from
/// T-bar to T-tilde (base frame, metres), the sign s_i (Eq. 3) and the chords seen on the way.
#[derive(Debug, Clone, PartialEq)]
pub struct DiskScan {
    /// R_tcp,i: rotation of base_to_flange.
    pub r_tcp: Rotation3<f64>,
    /// T-bar.
    pub t_start: Vector3<f64>,
    /// T-tilde.
    pub t_end: Vector3<f64>,
    /// s_i: +1 when the move follows the sensor's +y, -1 otherwise.
    pub s: f64,
    pub chords: Vec<DiskChord>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct DiskProblem {
    /// r_c, metres.
    pub radius: f64,
    pub scans: Vec<DiskScan>,
    /// Reject scans whose direction is closer than this to the disk plane or normal (radians).
    pub min_scan_angle: f64,
}

impl DiskProblem {
    pub fn new(radius: f64, scans: Vec<DiskScan>) -> DiskProblem {
        DiskProblem {
            radius,
            scans,
            min_scan_angle: 1f64.to_radians(),
        }
    }
}

/// A sensing datum {T_tcp,i, R_tcp,i, q^i, D_i^i, D_i^b} (Eqs. 10-13).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensingDatum {
    pub r_tcp: Rotation3<f64>,
    pub t_tcp: Vector3<f64>,
    pub q_in_sensor: Vector3<f64>,
    pub d_in_sensor: Vector3<f64>,
    pub d_in_base: Vector3<f64>,
    /// alpha_i (Eq. 9), radians; NaN when the datum came from a table.
    pub alpha: f64,
    /// RMS algebraic residual of the chord ends on the fitted ellipse.
    pub ellipse_rms: f64,
}

#[derive(Debug, Clone, PartialEq)]
pub struct DiskSolution {
    pub flange_to_sensor: Isometry3<f64>,
    pub sensing: Vec<SensingDatum>,
    /// q_i^b for each datum and their mean (Eq. 20).
    pub centres_in_base: Vec<Vector3<f64>>,
    pub centre_in_base: Vector3<f64>,
    /// max_k |q^b - q_k^b| (Sec. III-D), metres.
    pub accuracy: f64,
    /// RMS of |R_sensor D_i^i - R_tcp,i^-1 D_i^b| over the data (Eq. 45 residual).
    pub rotation_residual: f64,
    pub status: Status,
}

fn rot_y(phi: f64) -> Rotation3<f64> {
    Rotation3::from_axis_angle(&Vector3::y_axis(), phi)
}

/// A point (x, z) of the laser plane in the frame R_theta.
fn in_frame(r_theta: &Rotation3<f64>, p: &Vector2<f64>) -> Vector2<f64> {
    let v = r_theta * Vector3::new(p.x, 0.0, p.y);
    Vector2::new(v.x, v.z)
}

/// R_theta (a rotation about y making x-bar parallel to the mean chord direction c_i), the chord
/// ends in that frame, and the ellipse through them.
fn chord_frame_ellipse(
    scan_index: usize,
    scan: &DiskScan,
) -> Result<(Rotation3<f64>, Vec<Vector2<f64>>, Ellipse), CalibError> {
    let m = scan.chords.len();
    let c = scan
        .chords
        .iter()
        .map(|ch| ch.b - ch.a)
        .sum::<Vector2<f64>>()
        / m as f64;
    let r_theta = rot_y(c.y.atan2(c.x));
    let mut pts = Vec::with_capacity(2 * m);
    for ch in &scan.chords {
        pts.extend([in_frame(&r_theta, &ch.a), in_frame(&r_theta, &ch.b)]);
    }
    let ell = Ellipse::fit(&pts).map_err(|e| CalibError::NotAnEllipse {
        scan: scan_index,
        reason: match e {
            EllipseFitError::TooFewPoints(n) => format!("{n} points"),
            EllipseFitError::NotAnEllipse(s) => s,
        },
    })?;
    Ok((r_theta, pts, ell))
}

/// Eq. 2: the move `d` must be neither parallel nor perpendicular to the disk (normal `n`).
fn check_move_angle(
    scan_index: usize,
    d: &Vector3<f64>,
    n: &Vector3<f64>,
    min_angle: f64,
) -> Result<(), CalibError> {
    let to_plane = (d.dot(n).abs() / d.norm()).clamp(0.0, 1.0).asin();
    if to_plane < min_angle {
        return Err(CalibError::ScanParallelToDisk {
            scan: scan_index,
            angle_deg: to_plane.to_degrees(),
        });
    }
    if std::f64::consts::FRAC_PI_2 - to_plane < min_angle {
        return Err(CalibError::ScanPerpendicularToDisk {
            scan: scan_index,
            angle_deg: (std::f64::consts::FRAC_PI_2 - to_plane).to_degrees(),
        });
    }
    Ok(())
}

/// Sensing data calculation for one scan (Sec. III-B).
pub fn sensing_datum(
    scan_index: usize,
    scan: &DiskScan,
    radius: f64,
    min_angle: f64,
) -> Result<SensingDatum, CalibError> {
    let m = scan.chords.len();
    if m < 3 {
        return Err(CalibError::TooFewData {
            method: METHOD,
            what: "chords in a scan",
            got: m,
            need: 3,
        });
    }
    let (r_theta, pts, ell) = chord_frame_ellipse(scan_index, scan)?;
    let to_r = |p: &Vector2<f64>| in_frame(&r_theta, p);
    let not_ellipse = |what: &str| CalibError::NotAnEllipse {
        scan: scan_index,
        reason: what.to_string(),
    };
    let e3 = ell.centre().ok_or_else(|| not_ellipse("no centre"))?;
    let [t_lo, t_hi] = ell
        .horizontal_tangent_points()
        .ok_or_else(|| not_ellipse("no horizontal tangents"))?;
    // e4, e5: where the diameter e1e2 meets the first and the last chord (horizontal in this frame).
    let first = scan
        .chords
        .iter()
        .min_by(|a, b| a.u.total_cmp(&b.u))
        .ok_or_else(|| not_ellipse("no chords"))?;
    let last = scan
        .chords
        .iter()
        .max_by(|a, b| a.u.total_cmp(&b.u))
        .ok_or_else(|| not_ellipse("no chords"))?;
    if last.u - first.u <= 0.0 {
        return Err(CalibError::TooFewData {
            method: METHOD,
            what: "distinct chord positions in a scan",
            got: 1,
            need: 3,
        });
    }
    let level = |ch: &DiskChord| 0.5 * (to_r(&ch.a).y + to_r(&ch.b).y);
    let on_diameter = |z: f64| t_lo + (t_hi - t_lo) * ((z - t_lo.y) / (t_hi.y - t_lo.y));
    let e4 = on_diameter(level(first));
    let e5 = on_diameter(level(last));
    // e1 -> e2 points the same way as e4 -> e5.
    let (e1, e2) = if (t_hi - t_lo).dot(&(e5 - e4)) >= 0.0 {
        (t_lo, t_hi)
    } else {
        (t_hi, t_lo)
    };
    // Eqs. 7-8, with T-bar/T-tilde generalised to the first and last chord actually seen.
    let t_first = scan.t_start + (scan.t_end - scan.t_start) * first.u;
    let t_last = scan.t_start + (scan.t_end - scan.t_start) * last.u;
    let d45 = e4 - e5;
    let eta = |e: &Vector2<f64>| (e - e5).dot(&d45) / d45.norm_squared();
    let t_at = |e: &Vector2<f64>| t_first * eta(e) + t_last * (1.0 - eta(e));
    let (t1, t2, t3) = (t_at(&e1), t_at(&e2), t_at(&e3));
    // Eq. 9.
    let r = radius;
    let den = 4.0 * r * (e1.y - e2.y);
    let num = (t1 - t2).norm_squared() - (e1 - e2).norm_squared() - 4.0 * r * r;
    // A flat ellipse: the chords seen lie at one depth. That is what the data show (a draw that
    // lost chords, or a move parallel to the disk, which the move-angle check catches apart), not
    // the move's angle, which is not measured here.
    if den.abs() < 1e-12 * r * r {
        return Err(not_ellipse(&format!(
            "its tangent points lie at one depth: {m} chords seen, over {:.0} % of the scan",
            100.0 * (last.u - first.u)
        )));
    }
    let alpha = (num / den).clamp(-1.0, 1.0).acos();
    // Eq. 12 in the rotated frame, then back.
    let s = scan.s;
    let d_r = Vector3::new(
        e1.x - e2.x,
        2.0 * r * s * alpha.sin(),
        e1.y - e2.y + 2.0 * r * alpha.cos(),
    );
    // The disk normal in this frame is perpendicular to x-bar and to q_2 - q_1 = 2 r (0, s sin a,
    // cos a).
    let n_r = Vector3::new(0.0, -alpha.cos(), s * alpha.sin());
    check_move_angle(scan_index, &d_r, &n_r, min_angle)?;
    let inv = r_theta.inverse();
    let rms = (pts.iter().map(|p| ell.residual(p).powi(2)).sum::<f64>() / pts.len() as f64).sqrt();
    Ok(SensingDatum {
        r_tcp: scan.r_tcp,
        t_tcp: t3,
        q_in_sensor: inv * Vector3::new(e3.x, 0.0, e3.y),
        d_in_sensor: inv * d_r,
        d_in_base: t2 - t1,
        alpha,
        ellipse_rms: rms,
    })
}

/// Transformation solution (Sec. III-C): R_sensor by SVD with a reflection guard (Eqs. 14-16),
/// T_sensor by least squares (Eqs. 17-19). Returns flange_to_sensor and the Eq. 45 RMS residual.
pub fn transformation_solution(data: &[SensingDatum]) -> Result<(Isometry3<f64>, f64), CalibError> {
    let n = data.len();
    if n < 4 {
        return Err(CalibError::TooFewData {
            method: METHOD,
            what: "sensing data",
            got: n,
            need: 4,
        });
    }
    // H = X Y^T with X = [D_i^i], Y = [R_tcp,i^-1 D_i^b].
    let mut h = Matrix3::zeros();
    for d in data {
        h += d.d_in_sensor * (d.r_tcp.inverse() * d.d_in_base).transpose();
    }
    // Eqs. 15-16 with the reflection guard.
    let r_sensor = super::rotation_from_correlation(&h).ok_or_else(|| CalibError::Degenerate {
        method: METHOD,
        what: "all TCP offsets D_i are parallel".into(),
        part: "rotation",
        fix: "scan in directions that differ between sensing data",
    })?;
    let resid = (data
        .iter()
        .map(|d| (r_sensor * d.d_in_sensor - d.r_tcp.inverse() * d.d_in_base).norm_squared())
        .sum::<f64>()
        / n as f64)
        .sqrt();
    // M T = N stacked over consecutive pairs (Eqs. 17-19).
    let caps: Vec<_> = data
        .iter()
        .map(|d| (d.r_tcp, d.t_tcp, d.q_in_sensor))
        .collect();
    let t_sensor = super::translation_from_fixed_point(&caps, &r_sensor).ok_or_else(|| {
        CalibError::Degenerate {
            method: METHOD,
            what: "the flange orientations differ only by rotations about one axis (or not at all)"
                .into(),
            part: "translation",
            fix: "use orientations tilted about at least two different axes",
        }
    })?;
    let iso = Isometry3::from_parts(
        Translation3::from(t_sensor),
        UnitQuaternion::from_rotation_matrix(&r_sensor),
    );
    Ok((iso, resid))
}

/// Least squares for a tall n x 3 system: the normal equations of Eq. 19 (3 x 3), refined once on
/// the residual; None when the system is rank deficient.
pub(crate) fn solve_ls(a: &DMatrix<f64>, b: &DVector<f64>) -> Option<Vector3<f64>> {
    let ata: Matrix3<f64> = (a.transpose() * a).fixed_view::<3, 3>(0, 0).into_owned();
    let eig = ata.symmetric_eigenvalues();
    let (lo, hi) = (eig.min(), eig.max());
    if !(lo > 1e-18 * hi) || !(hi > 0.0) {
        return None;
    }
    let chol = ata.cholesky()?;
    let atb =
        |r: &DVector<f64>| -> Vector3<f64> { (a.transpose() * r).fixed_rows::<3>(0).into_owned() };
    let mut x = chol.solve(&atb(b));
    // One step of iterative refinement recovers the digits the normal equations lose.
    let r = b - a * DVector::from_column_slice(x.as_slice());
    x += chol.solve(&atb(&r));
    Some(x)
}

/// Disk centre from each datum (Eq. 1 with the estimate) and the Sec. III-D accuracy.
pub fn centres(
    data: &[SensingDatum],
    flange_to_sensor: &Isometry3<f64>,
) -> (Vec<Vector3<f64>>, Vector3<f64>, f64) {
    let c: Vec<Vector3<f64>> = data
        .iter()
        .map(|d| {
            d.r_tcp * (flange_to_sensor * nalgebra::Point3::from(d.q_in_sensor)).coords + d.t_tcp
        })
        .collect();
    let mean = c.iter().sum::<Vector3<f64>>() / c.len().max(1) as f64;
    let acc = c.iter().map(|x| (x - mean).norm()).fold(0.0, f64::max);
    (c, mean, acc)
}

/// The whole method: sensing data from every scan, then the transformation solution.
pub fn solve(problem: &DiskProblem) -> Result<DiskSolution, CalibError> {
    if problem.scans.len() < 4 {
        return Err(CalibError::TooFewData {
            method: METHOD,
            what: "scans (sensing data)",
            got: problem.scans.len(),
            need: 4,
        });
    }
    let sensing = problem
        .scans
        .iter()
        .enumerate()
        .map(|(i, s)| sensing_datum(i, s, problem.radius, problem.min_scan_angle))
        .collect::<Result<Vec<_>, _>>()?;
    let (flange_to_sensor, rotation_residual) = transformation_solution(&sensing)?;
    let (centres_in_base, centre_in_base, accuracy) = centres(&sensing, &flange_to_sensor);
    Ok(DiskSolution {
        flange_to_sensor,
        sensing,
        centres_in_base,
        centre_in_base,
        accuracy,
        rotation_residual,
        status: Status::ClosedForm,
    })
}
