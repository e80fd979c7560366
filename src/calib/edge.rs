//! The straight-edge method (Xu et al., Sec. 2): within each rotation group the edge points give
//! a linear system in vec(R_s) built with Kronecker products (Eqs. 3-25), stacked over groups and
//! solved by least squares (Eq. 26), projected to the nearest rotation (Eq. 27); the edge direction
//! by PCA; then T_s from pairs of points in different groups (Eqs. 28-35).

use super::{CalibError, Status};
use nalgebra::{
    DMatrix, DVector, Isometry3, Matrix3, Rotation3, SMatrix, Translation3, UnitQuaternion,
    Vector2, Vector3,
};

const METHOD: &str = "edge";

/// One profile's edge point (x, z in the sensor frame) and the flange pose it was taken at.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EdgeCapture {
    pub r_tcp: Rotation3<f64>,
    pub t_tcp: Vector3<f64>,
    pub p_in_sensor: Vector2<f64>,
}

/// Captures grouped by flange rotation (each group: one rotation, several translations).
#[derive(Debug, Clone, PartialEq)]
pub struct EdgeProblem {
    pub groups: Vec<Vec<EdgeCapture>>,
    /// How far apart (deg) a group's orientations may be: `ORIENTATION_TOLERANCE_DEG` unless the
    /// user says otherwise.
    pub orientation_tolerance_deg: f64,
}

#[derive(Debug, Clone, PartialEq)]
pub struct EdgeSolution {
    pub flange_to_sensor: Isometry3<f64>,
    /// The edge in the base frame: a point on it and its unit direction u_b*.
    pub edge_point: Vector3<f64>,
    pub edge_direction: Vector3<f64>,
    /// Angle of each group's edge direction from u_b* (radians): Table 1's criterion.
    pub group_angle_dev: Vec<f64>,
    /// Distance of every reconstructed point from the fitted edge (metres): Table 2's criterion.
    pub point_distances: Vec<f64>,
    pub status: Status,
}

fn skew(a: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}

/// (a^T kron R): the 3x9 matrix with (a^T kron R) vec(X) = R X a for column-major vec.
fn kron_row(a: &Vector3<f64>, r: &Matrix3<f64>) -> SMatrix<f64, 3, 9> {
    let mut m = SMatrix::<f64, 3, 9>::zeros();
    for k in 0..3 {
        m.fixed_view_mut::<3, 3>(0, 3 * k).copy_from(&(r * a[k]));
    }
    m
}

fn p3(p: &Vector2<f64>) -> Vector3<f64> {
    Vector3::new(p.x, 0.0, p.y)
}

/// Principal axis of a set of points (unit vector) and their centroid.
pub fn principal_axis(pts: &[Vector3<f64>]) -> (Vector3<f64>, Vector3<f64>) {
    let c = pts.iter().sum::<Vector3<f64>>() / pts.len().max(1) as f64;
    let mut s = Matrix3::zeros();
    for p in pts {
        let d = p - c;
        s += d * d.transpose();
    }
    let e = s.symmetric_eigen();
    let k = e.eigenvalues.imax();
    (c, e.eigenvectors.column(k).into_owned())
}

/// Least squares of a tall system by Householder QR; None when rank deficient.
fn qr_solve(a: &DMatrix<f64>, b: &DVector<f64>) -> Option<DVector<f64>> {
    let n = a.ncols();
    let qr = a.clone().qr();
    let r = qr.r();
    let dmax = (0..n).map(|i| r[(i, i)].abs()).fold(0.0, f64::max);
    let dmin = (0..n)
        .map(|i| r[(i, i)].abs())
        .fold(f64::INFINITY, f64::min);
    if !(dmin > 1e-10 * dmax) {
        return None;
    }
    let qtb = qr.q().transpose() * b;
    r.solve_upper_triangular(&qtb)
}

/// Eqs. 3-27: R_s from all groups.
pub fn rotation(
    groups: &[Vec<EdgeCapture>],
    tolerance_deg: f64,
) -> Result<Rotation3<f64>, CalibError> {
    if groups.len() < 2 {
        return Err(CalibError::TooFewData {
            method: METHOD,
            what: "rotation groups",
            got: groups.len(),
            need: 2,
        });
    }
    let mut rows: Vec<SMatrix<f64, 3, 9>> = Vec::new();
    let mut rhs: Vec<Vector3<f64>> = Vec::new();
    for (g, caps) in groups.iter().enumerate() {
        if caps.len() < 3 {
            return Err(CalibError::TooFewData {
                method: METHOD,
                what: "translations in a rotation group",
                got: caps.len(),
                need: 3,
            });
        }
        let rotations: Vec<Rotation3<f64>> = caps.iter().map(|c| c.r_tcp).collect();
        let r0 = super::shared_orientation(&rotations, tolerance_deg).map_err(|(i, angle)| {
            CalibError::Degenerate {
                method: METHOD,
                what: format!(
                    "group {g}: capture {i} is {angle:.3} deg from the group's mean orientation \
                     (tolerance {} deg)",
                    tolerance_deg
                ),
                part: "rotation",
                fix: "keep the rotation fixed within a group, allow the controller's jitter \
                      (calibrate --orientation-tolerance-deg), or use edge-any-pose",
            }
        })?;
        let rb = *r0.matrix();
        let us: Vec<Vector3<f64>> = caps[1..]
            .iter()
            .map(|c| p3(&(c.p_in_sensor - caps[0].p_in_sensor)))
            .collect();
        let ut: Vec<Vector3<f64>> = caps[1..].iter().map(|c| c.t_tcp - caps[0].t_tcp).collect();
        let scale_t = ut.iter().map(|v| v.norm()).fold(0.0, f64::max);
        let tcps: Vec<Vector3<f64>> = caps.iter().map(|c| c.t_tcp).collect();
        let (ratio, length, width) = super::line_spread(&tcps);
        if scale_t == 0.0 || !(ratio >= super::MIN_LINE_SPREAD) {
            return Err(CalibError::Degenerate {
                method: METHOD,
                what: format!(
                    "the translations of group {g} are collinear: they leave their line by \
                     {:.3} mm RMS over {:.3} mm (ratio {ratio:.2e}, at least {} needed)",
                    width * 1e3,
                    length * 1e3,
                    super::MIN_LINE_SPREAD
                ),
                part: "rotation",
                fix: "move along a circular arc, not a straight line",
            });
        }
        // The edge is translation invariant: a move along it does not change the profile, so if the
        // group's moves lie in a plane containing the edge, the edge points fall on one line in the
        // profile and the group says nothing about the sensor's y axis.
        let scale_s = us.iter().map(|v| v.norm()).fold(0.0, f64::max);
        let spread = us
            .iter()
            .flat_map(|a| us.iter().map(move |b| (a.x * b.z - a.z * b.x).abs()))
            .fold(0.0, f64::max);
        if scale_s <= 1e-6 * scale_t || spread <= 1e-9 * scale_s * scale_s {
            return Err(CalibError::Degenerate {
                method: METHOD,
                what: format!(
                    "the edge points of group {g} lie on one line in the profile: its moves are parallel to the edge or lie in a plane containing it"
                ),
                part: "rotation",
                fix: "move across the edge along an arc (not along the edge line)",
            });
        }
        for i in 0..us.len() {
            for j in i + 1..us.len() {
                let b1 = kron_row(&us[i].cross(&us[j]), &rb);
                let b2 = kron_row(&us[i], &rb);
                let b3 = kron_row(&us[j], &rb);
                // Eq. 24: (A1 + A2 - A3) r_s = b_r with [a]x^T = -[a]x.
                rows.push(b1 - skew(&ut[j]) * b2 + skew(&ut[i]) * b3);
                rhs.push(-ut[i].cross(&ut[j]));
            }
        }
    }
    if 3 * rows.len() < 9 {
        return Err(CalibError::TooFewData {
            method: METHOD,
            what: "rotation equations (3 per pair of translations in a group)",
            got: 3 * rows.len(),
            need: 9,
        });
    }
    let mut a = DMatrix::zeros(3 * rows.len(), 9);
    let mut b = DVector::zeros(3 * rows.len());
    for (k, (r, v)) in rows.iter().zip(&rhs).enumerate() {
        a.fixed_view_mut::<3, 9>(3 * k, 0).copy_from(r);
        b.fixed_rows_mut::<3>(3 * k).copy_from(v);
    }
    let x = qr_solve(&a, &b).ok_or_else(|| CalibError::Degenerate {
        method: METHOD,
        what: "the stacked rotation equations are rank deficient".into(),
        part: "rotation",
        fix: "use more rotation groups tilted about different axes",
    })?;
    let m = Matrix3::from_column_slice(x.as_slice());
    Ok(crate::math::nearest_rotation(&m))
}

/// The whole method.
pub fn solve(p: &EdgeProblem) -> Result<EdgeSolution, CalibError> {
    let r_s = rotation(&p.groups, p.orientation_tolerance_deg)?;
    // Edge direction: PCA of each group's points (translation-free within a group), then of the
    // sign-aligned group directions.
    let dirs: Vec<Vector3<f64>> = p
        .groups
        .iter()
        .map(|caps| {
            let pts: Vec<Vector3<f64>> = caps
                .iter()
                .map(|c| c.r_tcp * (r_s * p3(&c.p_in_sensor)) + c.t_tcp)
                .collect();
            principal_axis(&pts).1
        })
        .collect();
    let d0 = dirs[0];
    let mut s = Matrix3::zeros();
    for d in &dirs {
        let d = if d.dot(&d0) < 0.0 { -d } else { *d };
        s += d * d.transpose();
    }
    let e = s.symmetric_eigen();
    let mut u = e.eigenvectors.column(e.eigenvalues.imax()).into_owned();
    if u.dot(&d0) < 0.0 {
        u = -u;
    }
    let group_angle_dev = dirs
        .iter()
        .map(|d| d.dot(&u).abs().min(1.0).acos())
        .collect();
    // Eqs. 28-35 over all pairs in different groups: [u]x^T C T_s = -(v x u), normal equations
    // accumulated, refined once on the residual.
    let all: Vec<(usize, &EdgeCapture)> = p
        .groups
        .iter()
        .enumerate()
        .flat_map(|(g, caps)| caps.iter().map(move |c| (g, c)))
        .collect();
    let ux_t = skew(&u).transpose();
    let world: Vec<Vector3<f64>> = all
        .iter()
        .map(|(_, c)| c.r_tcp * (r_s * p3(&c.p_in_sensor)) + c.t_tcp)
        .collect();
    // Summed over pairs in different groups without visiting them (O(n), not O(n^2): the
    // verdict solves this again for every re-cast and noise move): with a = [u]x^T dR and
    // b = u x dw, a^T a = dR^T S dR and a^T b = dR^T T dw, and over all pairs of n values
    // sum (x_j - x_i)^T M (y_j - y_i) = n sum x^T M y - (sum x)^T M (sum y); the pairs within a
    // group are taken out the same way. Centred first, so nothing cancels.
    let s_m = ux_t.transpose() * ux_t;
    let t_m = ux_t.transpose() * skew(&u);
    let n = all.len() as f64;
    let mean_r = all
        .iter()
        .map(|(_, c)| c.r_tcp.matrix())
        .sum::<Matrix3<f64>>()
        / n;
    let mean_w = world.iter().sum::<Vector3<f64>>() / n;
    let (mut ata, mut atb) = (Matrix3::zeros(), Vector3::zeros());
    let mut start = 0;
    while start < all.len() {
        let g = all[start].0;
        let end = start + all[start..].iter().take_while(|(h, _)| *h == g).count();
        let (mut sum_r, mut sum_w) = (Matrix3::zeros(), Vector3::zeros());
        let (mut rr, mut rw) = (Matrix3::zeros(), Vector3::zeros());
        for i in start..end {
            let r = all[i].1.r_tcp.matrix() - mean_r;
            let w = world[i] - mean_w;
            rr += r.transpose() * s_m * r;
            rw += r.transpose() * t_m * w;
            sum_r += r;
            sum_w += w;
        }
        let k = (end - start) as f64;
        // All pairs (the sums over every value are zero once centred), less this group's own.
        ata += rr * (n - k) + sum_r.transpose() * s_m * sum_r;
        atb += rw * (n - k) + sum_r.transpose() * t_m * sum_w;
        start = end;
    }
    let eig = ata.symmetric_eigenvalues();
    if !(eig.min() > 1e-18 * eig.max()) {
        return Err(CalibError::Degenerate {
            method: METHOD,
            what: "the translation equations are rank deficient".into(),
            part: "translation",
            fix: "use rotation groups tilted about at least two different axes",
        });
    }
    let chol = ata.cholesky().ok_or_else(|| CalibError::Degenerate {
        method: METHOD,
        what: "singular translation system".into(),
        part: "translation",
        fix: "use more varied rotations",
    })?;
    let mut t = chol.solve(&atb);
    t += chol.solve(&(atb - ata * t));
    let flange_to_sensor = Isometry3::from_parts(
        Translation3::from(t),
        UnitQuaternion::from_rotation_matrix(&r_s),
    );
    let pts: Vec<Vector3<f64>> = all
        .iter()
        .map(|(_, c)| {
            c.r_tcp * (flange_to_sensor * nalgebra::Point3::from(p3(&c.p_in_sensor))).coords
                + c.t_tcp
        })
        .collect();
    let (centroid, axis) = principal_axis(&pts);
    let point_distances = pts
        .iter()
        .map(|q| (q - centroid).cross(&axis).norm())
        .collect();
    Ok(EdgeSolution {
        flange_to_sensor,
        edge_point: centroid,
        edge_direction: u,
        group_angle_dev,
        point_distances,
        status: Status::ClosedForm,
    })
}
