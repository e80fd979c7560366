//! Numerically stable direct least-squares ellipse fit (Halir & Flusser 1998, refining Fitzgibbon,
//! Pilu & Fisher: the disk paper's ref. [21]), on centred and scaled data.

use nalgebra::{Matrix3, Vector2, Vector3};

/// A fitted ellipse A x^2 + B x y + C y^2 + D x + E y + F = 0, stored in normalised coordinates
/// (p - mean) / scale for conditioning; every query answers in the caller's coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ellipse {
    pub conic: [f64; 6],
    pub mean: Vector2<f64>,
    pub scale: f64,
}

#[derive(Debug, Clone, PartialEq)]
pub enum EllipseFitError {
    TooFewPoints(usize),
    /// The best conic is not an ellipse (degenerate or hyperbolic data).
    NotAnEllipse(String),
}

/// Eigenvector of a 3x3 matrix for eigenvalue `l`: the largest cross product of two rows of M - l I.
fn eigvec(m: &Matrix3<f64>, l: f64) -> Vector3<f64> {
    let a = m - Matrix3::identity() * l;
    let (r0, r1, r2) = (
        a.row(0).transpose(),
        a.row(1).transpose(),
        a.row(2).transpose(),
    );
    let c = [r0.cross(&r1), r0.cross(&r2), r1.cross(&r2)];
    let best = c
        .iter()
        .max_by(|x, y| x.norm_squared().total_cmp(&y.norm_squared()))
        .copied()
        .unwrap_or_default();
    let n = best.norm();
    if n > 0.0 { best / n } else { best }
}

/// Real roots of the monic cubic x^3 + a x^2 + b x + c.
fn cubic_real_roots(a: f64, b: f64, c: f64) -> Vec<f64> {
    let q = (a * a - 3.0 * b) / 9.0;
    let r = (2.0 * a * a * a - 9.0 * a * b + 27.0 * c) / 54.0;
    let mut roots = if r * r < q * q * q {
        let th = (r / (q * q * q).sqrt()).clamp(-1.0, 1.0).acos();
        let s = -2.0 * q.sqrt();
        let tau = std::f64::consts::TAU;
        vec![
            s * (th / 3.0).cos() - a / 3.0,
            s * ((th + tau) / 3.0).cos() - a / 3.0,
            s * ((th - tau) / 3.0).cos() - a / 3.0,
        ]
    } else {
        let big_a = -r.signum() * (r.abs() + (r * r - q * q * q).sqrt()).cbrt();
        let big_b = if big_a != 0.0 { q / big_a } else { 0.0 };
        vec![big_a + big_b - a / 3.0]
    };
    // One Newton polish each.
    for x in &mut roots {
        let f = ((*x + a) * *x + b) * *x + c;
        let df = (3.0 * *x + 2.0 * a) * *x + b;
        if df != 0.0 {
            *x -= f / df;
        }
    }
    roots
}

impl Ellipse {
    /// Fit to at least 5 points.
    pub fn fit(pts: &[Vector2<f64>]) -> Result<Ellipse, EllipseFitError> {
        if pts.len() < 5 {
            return Err(EllipseFitError::TooFewPoints(pts.len()));
        }
        let n = pts.len() as f64;
        let mean = pts.iter().sum::<Vector2<f64>>() / n;
        let scale = (pts.iter().map(|p| (p - mean).norm_squared()).sum::<f64>() / n).sqrt();
        if !(scale > 0.0) {
            return Err(EllipseFitError::NotAnEllipse("all points coincide".into()));
        }
        // The scatter matrices' distinct entries only (S1 and S3 symmetric, S3's corner the
        // count): the same sums, in the same order, as the full outer products.
        let (mut s1, mut s2, mut s3) = ([0.0; 6], [0.0; 9], [0.0; 5]);
        for p in pts {
            let q = (p - mean) / scale;
            let d1 = [q.x * q.x, q.x * q.y, q.y * q.y];
            let d2 = [q.x, q.y, 1.0];
            for (k, (i, j)) in [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)]
                .iter()
                .enumerate()
            {
                s1[k] += d1[*i] * d1[*j];
            }
            for i in 0..3 {
                for j in 0..3 {
                    s2[3 * i + j] += d1[i] * d2[j];
                }
            }
            for (k, (i, j)) in [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2)].iter().enumerate() {
                s3[k] += d2[*i] * d2[*j];
            }
        }
        let s1 = Matrix3::new(
            s1[0], s1[1], s1[2], s1[1], s1[3], s1[4], s1[2], s1[4], s1[5],
        );
        let s2 = Matrix3::from_row_slice(&s2);
        let s3 = Matrix3::new(s3[0], s3[1], s3[2], s3[1], s3[3], s3[4], s3[2], s3[4], n);
        let s3_inv = s3
            .try_inverse()
            .ok_or_else(|| EllipseFitError::NotAnEllipse("collinear points".into()))?;
        let t = -s3_inv * s2.transpose();
        let m = s1 + s2 * t;
        // Premultiply by the inverse of the constraint matrix C1 = [[0,0,2],[0,-1,0],[2,0,0]].
        let m = Matrix3::from_rows(&[m.row(2) / 2.0, -m.row(1), m.row(0) / 2.0]);
        // Characteristic polynomial of m: x^3 - tr x^2 + (sum of principal minors) x - det.
        let tr = m.trace();
        let minors = m[(0, 0)] * m[(1, 1)] - m[(0, 1)] * m[(1, 0)] + m[(0, 0)] * m[(2, 2)]
            - m[(0, 2)] * m[(2, 0)]
            + m[(1, 1)] * m[(2, 2)]
            - m[(1, 2)] * m[(2, 1)];
        let roots = cubic_real_roots(-tr, minors, -m.determinant());
        let mut best: Option<(f64, Vector3<f64>)> = None;
        for l in roots {
            let v = eigvec(&m, l);
            let cond = 4.0 * v[0] * v[2] - v[1] * v[1];
            if cond > 0.0 && best.is_none_or(|(c, _)| cond > c) {
                best = Some((cond, v));
            }
        }
        let (_, a1) = best.ok_or_else(|| {
            EllipseFitError::NotAnEllipse(
                "no elliptic eigenvector: the chords do not trace an ellipse".into(),
            )
        })?;
        let a2 = t * a1;
        let conic = [a1[0], a1[1], a1[2], a2[0], a2[1], a2[2]];
        let e = Ellipse { conic, mean, scale };
        if !conic.iter().all(|c| c.is_finite()) {
            return Err(EllipseFitError::NotAnEllipse("non-finite conic".into()));
        }
        Ok(e)
    }

    fn to_user(&self, q: Vector2<f64>) -> Vector2<f64> {
        self.mean + q * self.scale
    }

    /// Centre of the ellipse.
    pub fn centre(&self) -> Option<Vector2<f64>> {
        let [a, b, c, d, e, _] = self.conic;
        let det = 4.0 * a * c - b * b;
        if det.abs() < 1e-300 {
            return None;
        }
        Some(self.to_user(Vector2::new(
            (b * e - 2.0 * c * d) / det,
            (b * d - 2.0 * a * e) / det,
        )))
    }

    /// The two points whose tangent is parallel to the x axis (lowest y first).
    pub fn horizontal_tangent_points(&self) -> Option<[Vector2<f64>; 2]> {
        let [a, b, c, d, e, f] = self.conic;
        if a.abs() < 1e-300 {
            return None;
        }
        // On dF/dx = 0: x = -(B y + D) / (2A); substituting gives a quadratic in y.
        let qa = b * b - 4.0 * a * c;
        let qb = 2.0 * b * d - 4.0 * a * e;
        let qc = d * d - 4.0 * a * f;
        let disc = qb * qb - 4.0 * qa * qc;
        if qa == 0.0 || disc < 0.0 {
            return None;
        }
        let sq = disc.sqrt();
        let qq = -0.5 * (qb + qb.signum() * sq);
        let (mut y1, mut y2) = (qq / qa, if qq != 0.0 { qc / qq } else { -qb / (2.0 * qa) });
        if y1 > y2 {
            std::mem::swap(&mut y1, &mut y2);
        }
        let x = |y: f64| -(b * y + d) / (2.0 * a);
        Some([
            self.to_user(Vector2::new(x(y1), y1)),
            self.to_user(Vector2::new(x(y2), y2)),
        ])
    }

    /// Algebraic residual of a point (0 on the ellipse), in normalised units.
    pub fn residual(&self, p: &Vector2<f64>) -> f64 {
        let q = (p - self.mean) / self.scale;
        let [a, b, c, d, e, f] = self.conic;
        let norm = (a * a + b * b + c * c).sqrt();
        (a * q.x * q.x + b * q.x * q.y + c * q.y * q.y + d * q.x + e * q.y + f) / norm
    }
}
