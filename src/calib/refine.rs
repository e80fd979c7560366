//! Joint nonlinear refinement (beyond both papers): flange_to_sensor and the specimen's unknown pose
//! estimated together from every raw feature at once, by Levenberg-Marquardt from the closed-form
//! solution, with analytic Jacobians, an optional Huber loss, a covariance of the six transform
//! parameters, and an observability check that refuses a pose set which cannot fix them.
//!
//! Parameters: the rotation as a right increment, R <- R exp([w]) (w in the sensor frame, rad), the
//! translation t in the flange frame (m), then the specimen's:
//! - disk: centre c (3) and normal n = Q z, Q <- Q exp([d1, d2, 0]) (2);
//! - ball: centre c (3);
//! - edge: a point p on the line moved across it, p <- p + Q y e1 + Q z e2 (2), and the direction
//!   d = Q x, Q <- Q exp([0, d2, d3]) (2).
//!
//! Residuals (metres), a profile point p_s = (x, 0, z) seen from flange pose F at q = F (R p_s + t):
//! - disk chord end: distance from the disk plane n.(q - c), and from the rim |w| - r with
//!   w = (q - c) - (n.(q - c)) n;
//! - ball arc point: its z minus the sphere's z at its x in the laser plane (the sensor's noise is
//!   in z);
//! - edge point: its offset from the line across it, (Q y).(q - p) and (Q z).(q - p).

use super::{CalibError, Status};
use nalgebra::{
    DMatrix, DVector, Isometry3, Matrix3, Matrix6, Point3, Rotation3, Translation3, UnitQuaternion,
    Vector2, Vector3, Vector6,
};

/// What the refinement fits: the raw features with the flange pose each was taken from.
#[derive(Debug, Clone, PartialEq)]
pub enum Data {
    /// Disk chord ends, in the laser plane (sensor x, z), and the disk radius.
    Disk {
        radius: f64,
        ends: Vec<(Isometry3<f64>, Vector2<f64>)>,
    },
    /// Ball arc points (sensor x, z) and the ball radius.
    Ball {
        radius: f64,
        points: Vec<(Isometry3<f64>, Vector2<f64>)>,
    },
    /// Edge points (sensor x, z).
    Edge {
        points: Vec<(Isometry3<f64>, Vector2<f64>)>,
    },
}

/// The specimen's pose, as estimated with the transform.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SpecimenEstimate {
    Disk {
        centre: Point3<f64>,
        normal: Vector3<f64>,
    },
    Ball {
        centre: Point3<f64>,
    },
    Edge {
        point: Point3<f64>,
        dir: Vector3<f64>,
    },
}

/// Loss on the residuals.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Loss {
    Squared,
    /// Huber: quadratic within `k` robust standard deviations (1.4826 MAD of the starting
    /// residuals), linear beyond, so outliers pull with a bounded force.
    Huber {
        k: f64,
    },
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    pub loss: Loss,
    pub max_iterations: usize,
}

impl Default for Options {
    fn default() -> Options {
        Options {
            loss: Loss::Squared,
            max_iterations: 100,
        }
    }
}

/// How well a pose set constrains the six transform parameters: singular values of the
/// Jacobian's transform block once the specimen's parameters are eliminated (rotations expressed
/// as the displacement they cause 100 mm away, so all six are in metres), largest first.
#[derive(Debug, Clone, PartialEq)]
pub struct Observability {
    pub singular_values: [f64; 6],
    /// Largest over smallest singular value.
    pub condition: f64,
    /// The least determined combination, in words (e.g. "rotation about the sensor's z axis").
    pub weakest: String,
    /// Its unit vector over (rx, ry, rz, tx, ty, tz).
    pub weakest_direction: [f64; 6],
}

#[derive(Debug, Clone, PartialEq)]
pub struct Refined {
    pub flange_to_sensor: Isometry3<f64>,
    pub specimen: SpecimenEstimate,
    pub status: Status,
    /// Cost (half the sum of squared, or Huber, residuals) at the start and the end.
    pub initial_cost: f64,
    pub cost: f64,
    pub residual_rms: f64,
    /// Covariance of (rotation increment rad in the sensor frame, translation m in the flange
    /// frame) at the optimum: the residual-scaled (sandwich) estimate, valid for unequal noise.
    pub covariance: Matrix6<f64>,
    /// Standard deviations from it: rotation about the sensor x, y, z (deg) and translation along
    /// the flange x, y, z (mm).
    pub sd_rotation_deg: Vector3<f64>,
    pub sd_translation_mm: Vector3<f64>,
    pub observability: Observability,
}

/// Characteristic length that puts rotations and translations on one scale (m).
const LEVER: f64 = 0.1;
/// Below this ratio of smallest to largest singular value a pose set is refused.
const MIN_SINGULAR_RATIO: f64 = 1e-7;

#[derive(Debug, Clone, Copy)]
struct State {
    rot: Rotation3<f64>,
    t: Vector3<f64>,
    /// Disk centre, ball centre or edge point (base frame).
    a: Vector3<f64>,
    /// Disk or edge orientation: normal = q z, edge direction = q x.
    q: Rotation3<f64>,
}

/// A^T B for tall A, B of the same shape whose product is symmetric (J^T W J): dot products of
/// contiguous columns, the upper triangle mirrored (nalgebra's generic tr_mul was most of the
/// refinement's time).
fn ata(a: &DMatrix<f64>, b: &DMatrix<f64>) -> DMatrix<f64> {
    let (n, p) = a.shape();
    let (sa, sb) = (a.as_slice(), b.as_slice());
    let mut out = DMatrix::zeros(p, p);
    for c in 0..p {
        let ca = &sa[c * n..(c + 1) * n];
        for d in c..p {
            let cb = &sb[d * n..(d + 1) * n];
            let v = dot(ca, cb);
            out[(c, d)] = v;
            out[(d, c)] = v;
        }
    }
    out
}

/// A^T r by contiguous column dot products.
fn atb(a: &DMatrix<f64>, r: &DVector<f64>) -> DVector<f64> {
    let n = a.nrows();
    let (sa, sr) = (a.as_slice(), r.as_slice());
    DVector::from_fn(a.ncols(), |c, _| dot(&sa[c * n..(c + 1) * n], sr))
}

/// Dot product with eight independent partial sums (lets the compiler vectorise it).
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut acc = [0.0; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let tail: f64 = ca
        .remainder()
        .iter()
        .zip(cb.remainder())
        .map(|(x, y)| x * y)
        .sum();
    for (x, y) in ca.zip(cb) {
        for k in 0..8 {
            acc[k] += x[k] * y[k];
        }
    }
    acc.iter().sum::<f64>() + tail
}

fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

fn exp(w: &Vector3<f64>) -> Rotation3<f64> {
    Rotation3::from_scaled_axis(*w)
}

/// A rotation whose `axis` column (0 = x, 2 = z) is `v`.
fn frame_with(v: &Vector3<f64>, axis: usize) -> Rotation3<f64> {
    let v = v.normalize();
    let from = if axis == 0 {
        Vector3::x()
    } else {
        Vector3::z()
    };
    Rotation3::rotation_between(&from, &v)
        .unwrap_or_else(|| Rotation3::from_axis_angle(&Vector3::y_axis(), std::f64::consts::PI))
}

impl Data {
    fn n_params(&self) -> usize {
        match self {
            Data::Disk { .. } => 11,
            Data::Ball { .. } => 9,
            Data::Edge { .. } => 10,
        }
    }

    fn len(&self) -> usize {
        match self {
            Data::Disk { ends, .. } => ends.len(),
            Data::Ball { points, .. } | Data::Edge { points } => points.len(),
        }
    }

    fn n_residuals(&self) -> usize {
        match self {
            Data::Disk { ends, .. } => 2 * ends.len(),
            Data::Ball { points, .. } => points.len(),
            Data::Edge { points } => 2 * points.len(),
        }
    }

    fn method(&self) -> &'static str {
        match self {
            Data::Disk { .. } => "disk refinement",
            Data::Ball { .. } => "ball refinement",
            Data::Edge { .. } => "edge refinement",
        }
    }

    /// Residuals, and with `jac` their Jacobian, at `st`. `branch` holds the ball points' side
    /// of the sphere (fixed at the start so the residual is smooth).
    fn eval(&self, st: &State, branch: &[f64], jac: bool) -> (DVector<f64>, DMatrix<f64>) {
        let n = self.n_residuals();
        let mut r = DVector::zeros(n);
        let mut j = if jac {
            DMatrix::zeros(n, self.n_params())
        } else {
            DMatrix::zeros(0, 0)
        };
        let rmat = *st.rot.matrix();
        // q = F (R p + t): dq/dw = -F_R R [p]x, dq/dt = F_R.
        let point = |f: &Isometry3<f64>, p: &Vector2<f64>| {
            let ps = Vector3::new(p.x, 0.0, p.y);
            let fr = *f.rotation.to_rotation_matrix().matrix();
            let frr = fr * rmat;
            let q = frr * ps + fr * st.t + f.translation.vector;
            if !jac {
                return (q, Matrix3::zeros(), fr);
            }
            (q, -frr * skew(&ps), fr)
        };
        match self {
            Data::Disk { radius, ends } => {
                let nrm = st.q * Vector3::z();
                let (dn1, dn2) = (-(st.q * Vector3::y()), st.q * Vector3::x());
                for (i, (f, p)) in ends.iter().enumerate() {
                    let (qb, dq_dw, dq_dt) = point(f, p);
                    let v = qb - st.a;
                    let h = nrm.dot(&v);
                    let w = v - nrm * h;
                    let wn = w.norm();
                    r[2 * i] = h;
                    r[2 * i + 1] = wn - radius;
                    if jac {
                        let wh = if wn > 0.0 { w / wn } else { Vector3::zeros() };
                        for (k, g, dd) in [
                            (2 * i, nrm, [v.dot(&dn1), v.dot(&dn2)]),
                            (2 * i + 1, wh, [-h * wh.dot(&dn1), -h * wh.dot(&dn2)]),
                        ] {
                            let gw = g.transpose() * dq_dw;
                            let gt = g.transpose() * dq_dt;
                            for c in 0..3 {
                                j[(k, c)] = gw[c];
                                j[(k, 3 + c)] = gt[c];
                                j[(k, 6 + c)] = -g[c];
                            }
                            j[(k, 9)] = dd[0];
                            j[(k, 10)] = dd[1];
                        }
                    }
                }
            }
            Data::Ball { radius, points } => {
                // The centre in the sensor frame: s = R^T (F_R^T (c - F_t) - t).
                for (i, (f, p)) in points.iter().enumerate() {
                    let fr = *f.rotation.to_rotation_matrix().matrix();
                    let g = fr.transpose() * (st.a - f.translation.vector);
                    let s = rmat.transpose() * (g - st.t);
                    let d = radius * radius - s.y * s.y - (p.x - s.x).powi(2);
                    let sd = d.max(1e-12).sqrt();
                    let b = branch.get(i).copied().unwrap_or(1.0);
                    r[i] = p.y - (s.z + b * sd);
                    if jac {
                        let dr_ds = Vector3::new(-b * (p.x - s.x) / sd, b * s.y / sd, -1.0);
                        let dw = dr_ds.transpose() * skew(&s);
                        let dt = -(dr_ds.transpose() * rmat.transpose());
                        let dc = dr_ds.transpose() * rmat.transpose() * fr.transpose();
                        for c in 0..3 {
                            j[(i, c)] = dw[c];
                            j[(i, 3 + c)] = dt[c];
                            j[(i, 6 + c)] = dc[c];
                        }
                    }
                }
            }
            Data::Edge { points } => {
                let d = st.q * Vector3::x();
                let (e1, e2) = (st.q * Vector3::y(), st.q * Vector3::z());
                for (i, (f, p)) in points.iter().enumerate() {
                    let (qb, dq_dw, dq_dt) = point(f, p);
                    let v = qb - st.a;
                    let dv = d.dot(&v);
                    r[2 * i] = e1.dot(&v);
                    r[2 * i + 1] = e2.dot(&v);
                    if jac {
                        for (k, e, dd) in [(2 * i, e1, [0.0, -dv]), (2 * i + 1, e2, [dv, 0.0])] {
                            let gw = e.transpose() * dq_dw;
                            let gt = e.transpose() * dq_dt;
                            for c in 0..3 {
                                j[(k, c)] = gw[c];
                                j[(k, 3 + c)] = gt[c];
                            }
                            j[(k, 6)] = if k % 2 == 0 { -1.0 } else { 0.0 };
                            j[(k, 7)] = if k % 2 == 0 { 0.0 } else { -1.0 };
                            j[(k, 8)] = dd[0];
                            j[(k, 9)] = dd[1];
                        }
                    }
                }
            }
        }
        (r, j)
    }

    fn apply(&self, st: &State, dx: &DVector<f64>) -> State {
        let w = Vector3::new(dx[0], dx[1], dx[2]);
        let mut out = State {
            rot: st.rot * exp(&w),
            t: st.t + Vector3::new(dx[3], dx[4], dx[5]),
            ..*st
        };
        match self {
            Data::Disk { .. } => {
                out.a = st.a + Vector3::new(dx[6], dx[7], dx[8]);
                out.q = st.q * exp(&Vector3::new(dx[9], dx[10], 0.0));
            }
            Data::Ball { .. } => out.a = st.a + Vector3::new(dx[6], dx[7], dx[8]),
            Data::Edge { .. } => {
                out.a = st.a + st.q * Vector3::new(0.0, dx[6], dx[7]);
                out.q = st.q * exp(&Vector3::new(0.0, dx[8], dx[9]));
            }
        }
        out
    }
}

/// The residuals and Jacobian at a transform and specimen estimate (for tests and tools).
pub fn residuals_and_jacobian(
    data: &Data,
    flange_to_sensor: &Isometry3<f64>,
    specimen: &SpecimenEstimate,
) -> (DVector<f64>, DMatrix<f64>) {
    let st = state(flange_to_sensor, specimen);
    data.eval(&st, &branches(data, &st), true)
}

/// The residuals after a parameter step `dx` (the parametrisation in the module docs).
pub fn residuals_after_step(
    data: &Data,
    flange_to_sensor: &Isometry3<f64>,
    specimen: &SpecimenEstimate,
    dx: &DVector<f64>,
) -> DVector<f64> {
    let st = state(flange_to_sensor, specimen);
    let b = branches(data, &st);
    data.eval(&data.apply(&st, dx), &b, false).0
}

fn state(x: &Isometry3<f64>, s: &SpecimenEstimate) -> State {
    let (a, q) = match *s {
        SpecimenEstimate::Disk { centre, normal } => (centre.coords, frame_with(&normal, 2)),
        SpecimenEstimate::Ball { centre } => (centre.coords, Rotation3::identity()),
        SpecimenEstimate::Edge { point, dir } => (point.coords, frame_with(&dir, 0)),
    };
    State {
        rot: x.rotation.to_rotation_matrix(),
        t: x.translation.vector,
        a,
        q,
    }
}

fn branches(data: &Data, st: &State) -> Vec<f64> {
    match data {
        Data::Ball { points, .. } => points
            .iter()
            .map(|(f, p)| {
                let s = st.rot.inverse()
                    * (f.rotation.inverse() * (st.a - f.translation.vector) - st.t);
                if p.y >= s.z { 1.0 } else { -1.0 }
            })
            .collect(),
        _ => Vec::new(),
    }
}

fn estimate(data: &Data, st: &State) -> (Isometry3<f64>, SpecimenEstimate) {
    let x = Isometry3::from_parts(
        Translation3::from(st.t),
        UnitQuaternion::from_rotation_matrix(&st.rot),
    );
    let s = match data {
        Data::Disk { .. } => SpecimenEstimate::Disk {
            centre: Point3::from(st.a),
            normal: st.q * Vector3::z(),
        },
        Data::Ball { .. } => SpecimenEstimate::Ball {
            centre: Point3::from(st.a),
        },
        Data::Edge { .. } => SpecimenEstimate::Edge {
            point: Point3::from(st.a),
            dir: st.q * Vector3::x(),
        },
    };
    (x, s)
}

fn robust_weights(r: &DVector<f64>, loss: Loss, scale: f64) -> DVector<f64> {
    match loss {
        Loss::Squared => DVector::from_element(r.len(), 1.0),
        Loss::Huber { k } => r.map(|v| {
            let c = k * scale;
            if v.abs() <= c { 1.0 } else { c / v.abs() }
        }),
    }
}

fn cost_of(r: &DVector<f64>, loss: Loss, scale: f64) -> f64 {
    match loss {
        Loss::Squared => 0.5 * r.norm_squared(),
        Loss::Huber { k } => {
            let c = k * scale;
            r.iter()
                .map(|v| {
                    if v.abs() <= c {
                        0.5 * v * v
                    } else {
                        c * (v.abs() - 0.5 * c)
                    }
                })
                .sum()
        }
    }
}

/// Observability of the transform at an estimate: see `Observability`.
pub fn observability(
    data: &Data,
    flange_to_sensor: &Isometry3<f64>,
    specimen: &SpecimenEstimate,
) -> Observability {
    observability_of(&residuals_and_jacobian(data, flange_to_sensor, specimen).1)
}

fn observability_of(j: &DMatrix<f64>) -> Observability {
    // Rotations as displacements LEVER away: scale their rows and columns of J^T J.
    let mut a = ata(j, j);
    let p = a.nrows();
    for c in 0..3 {
        a.row_mut(c).scale_mut(1.0 / LEVER);
        a.column_mut(c).scale_mut(1.0 / LEVER);
    }
    let axx = a.view((0, 0), (6, 6)).into_owned();
    let axs = a.view((0, 6), (6, p - 6)).into_owned();
    let ass = a.view((6, 6), (p - 6, p - 6)).into_owned();
    // Eliminate the specimen (Schur complement); a singular specimen block leaves its null space.
    let schur = match ass.clone().pseudo_inverse(1e-14 * ass.norm().max(1e-300)) {
        Ok(inv) => axx - &axs * inv * axs.transpose(),
        Err(_) => axx,
    };
    let eig = nalgebra::SymmetricEigen::new(Matrix6::from_fn(|r, c| schur[(r, c)]));
    let mut idx: Vec<usize> = (0..6).collect();
    idx.sort_by(|&x, &y| eig.eigenvalues[y].total_cmp(&eig.eigenvalues[x]));
    let sv: [f64; 6] = std::array::from_fn(|i| eig.eigenvalues[idx[i]].max(0.0).sqrt());
    let weakest_v: Vector6<f64> = eig.eigenvectors.column(idx[5]).into_owned();
    let k = weakest_v.iamax();
    let axis = ["x", "y", "z"][k % 3];
    let weakest = if k < 3 {
        format!("rotation about the sensor's {axis} axis")
    } else {
        format!("translation along the flange's {axis} axis")
    };
    let sign = if weakest_v[k] < 0.0 { -1.0 } else { 1.0 };
    Observability {
        singular_values: sv,
        condition: if sv[5] > 0.0 {
            sv[0] / sv[5]
        } else {
            f64::INFINITY
        },
        weakest,
        weakest_direction: std::array::from_fn(|i| weakest_v[i] * sign),
    }
}

fn motion_missing(weakest: &str) -> String {
    if weakest.starts_with("rotation") {
        format!(
            "the poses do not turn the sensor enough to fix its {weakest}: add captures with the \
             flange rotated differently (tilt it about more than one axis)"
        )
    } else {
        format!(
            "the poses cannot separate the {weakest} from the specimen's position: add captures \
             from more varied flange orientations"
        )
    }
}

fn n_per_feature(data: &Data) -> usize {
    match data {
        Data::Ball { .. } => 1,
        _ => 2,
    }
}

/// Refine a closed-form estimate over all raw features. Refuses a pose set that cannot determine
/// the transform (typed error naming the missing motion); "did not converge" is a status.
pub fn refine(
    data: &Data,
    flange_to_sensor: &Isometry3<f64>,
    specimen: &SpecimenEstimate,
    opts: &Options,
) -> Result<Refined, CalibError> {
    let p = data.n_params();
    let n = data.n_residuals();
    if n < p + 1 {
        return Err(CalibError::TooFewData {
            method: data.method(),
            what: "features",
            got: data.len(),
            need: (p + 1).div_ceil(n_per_feature(data)),
        });
    }
    let mut st = state(flange_to_sensor, specimen);
    let branch = branches(data, &st);
    let (r0, j0) = data.eval(&st, &branch, true);
    let obs = observability_of(&j0);
    if !(obs.singular_values[5] > MIN_SINGULAR_RATIO * obs.singular_values[0]) {
        return Err(CalibError::Unobservable {
            method: data.method(),
            ratio: obs.singular_values[5] / obs.singular_values[0].max(1e-300),
            weakest: obs.weakest.clone(),
            fix: motion_missing(&obs.weakest),
        });
    }
    // Robust scale from the starting residuals (MAD).
    let scale = {
        let mut a: Vec<f64> = r0.iter().map(|v| v.abs()).collect();
        a.sort_by(f64::total_cmp);
        (1.4826 * a[a.len() / 2]).max(1e-12)
    };
    let initial_cost = cost_of(&r0, opts.loss, scale);
    let mut cost = initial_cost;
    let mut lambda = 1e-4;
    let mut status = Status::NotConverged {
        iterations: opts.max_iterations,
    };
    let mut it = 0;
    // The residuals and Jacobian at the current state (the first ones computed above).
    let mut at = Some((r0, j0));
    let mut last_j = None;
    while it < opts.max_iterations {
        it += 1;
        let (r, j) = at.take().unwrap_or_else(|| data.eval(&st, &branch, true));
        // Weighted normal equations J^T W J, J^T W r (column dot products: tr_mul).
        let (a, g) = if opts.loss == Loss::Squared {
            (ata(&j, &j), atb(&j, &r))
        } else {
            let w = robust_weights(&r, opts.loss, scale);
            let mut jw = j.clone();
            for mut col in jw.column_iter_mut() {
                col.component_mul_assign(&w);
            }
            (ata(&j, &jw), atb(&jw, &r))
        };
        if g.amax() <= 1e-15 * (1.0 + cost) {
            status = Status::Converged { iterations: it };
            break;
        }
        let mut improved = false;
        while lambda < 1e16 {
            let mut m = a.clone();
            for d in 0..p {
                m[(d, d)] += lambda * a[(d, d)].max(1e-300);
            }
            let Some(ch) = m.cholesky() else {
                lambda *= 10.0;
                continue;
            };
            let dx = -ch.solve(&g);
            let trial = data.apply(&st, &dx);
            let c = cost_of(&data.eval(&trial, &branch, false).0, opts.loss, scale);
            if c < cost {
                let gain = cost - c;
                st = trial;
                cost = c;
                lambda = (lambda / 3.0).max(1e-12);
                improved = true;
                if gain <= 1e-12 * cost || dx.amax() < 1e-13 {
                    status = Status::Converged { iterations: it };
                }
                break;
            }
            lambda *= 4.0;
        }
        if !improved {
            // No step lowers the cost: at the minimum to machine precision.
            status = Status::Converged { iterations: it };
        }
        last_j = Some(j);
        if matches!(status, Status::Converged { .. }) {
            break;
        }
    }
    // The covariance at the optimum: fresh residuals; the last Jacobian, computed at most one
    // (converged, hence negligible) step away.
    let (r, _) = data.eval(&st, &branch, false);
    let j = match last_j {
        Some(j) => j,
        None => data.eval(&st, &branch, true).1,
    };
    let cov = covariance(&r, &j);
    let (x, s) = estimate(data, &st);
    let sd = |i: usize| cov[(i, i)].max(0.0).sqrt();
    Ok(Refined {
        flange_to_sensor: x,
        specimen: s,
        status,
        initial_cost,
        cost,
        residual_rms: (r.norm_squared() / n as f64).sqrt(),
        covariance: cov,
        sd_rotation_deg: Vector3::new(sd(0), sd(1), sd(2)).map(f64::to_degrees),
        sd_translation_mm: Vector3::new(sd(3), sd(4), sd(5)) * 1e3,
        observability: obs,
    })
}

/// The transform block of the sandwich covariance A^-1 (sum J_i^T r_i^2 J_i) A^-1 (A = J^T J),
/// with the small-sample factor N / (N - p): consistent when residuals have unequal variances (a
/// chord end's distance from the rim is noisier than its distance from the disk plane).
fn covariance(r: &DVector<f64>, j: &DMatrix<f64>) -> Matrix6<f64> {
    let (n, p) = (j.nrows(), j.ncols());
    let a = ata(j, j);
    let Some(inv) = a.clone().try_inverse() else {
        return Matrix6::from_element(f64::INFINITY);
    };
    let mut jr = j.clone();
    for mut col in jr.column_iter_mut() {
        col.component_mul_assign(r);
    }
    let b = ata(&jr, &jr);
    let full = &inv * b * &inv * (n as f64 / (n - p) as f64);
    Matrix6::from_fn(|r, c| full[(r, c)])
}
