//! Circle fit in the profile plane: algebraic (Kasa) start, then Gauss-Newton on the geometric
//! distances. Exact points give the exact circle.

use nalgebra::{Matrix3, Vector2, Vector3};

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Circle {
    pub centre: Vector2<f64>,
    pub radius: f64,
    /// RMS of the geometric residuals.
    pub rms: f64,
}

/// Fit a circle to at least 3 points; None for degenerate (collinear) input.
pub fn fit_circle(pts: &[Vector2<f64>]) -> Option<Circle> {
    if pts.len() < 3 {
        return None;
    }
    // Centre the data for conditioning.
    let m = pts.iter().sum::<Vector2<f64>>() / pts.len() as f64;
    // Rows (d_x, d_y, 1) against |d|^2.
    let [xx, xy, yy, sx, sy, bx, by, bb] = kasa_sums(pts, m);
    let ata = Matrix3::new(xx, xy, sx, xy, yy, sy, sx, sy, pts.len() as f64);
    let sol = ata.lu().solve(&Vector3::new(bx, by, bb))?;
    let mut c = Vector2::new(sol.x / 2.0, sol.y / 2.0);
    let r2 = sol.z + c.norm_squared();
    if !r2.is_finite() || r2 <= 0.0 {
        return None;
    }
    let mut r = r2.sqrt();
    // Gauss-Newton on f_i = |p_i - c| - r, with J_i = (-d_x / n, -d_y / n, -1).
    // The sum of squared residuals at the last iteration's start: its step is below 1e-12 of
    // the radius, so it is the final fit's to far better than its digits (no pass of its own).
    let mut ss = 0.0;
    for _ in 0..50 {
        let [xx, xy, yy, sx, sy, fx, fy, ff, s] = gauss_newton_sums(pts, m, c, r);
        // A point on the centre (n = 0) made its row NaN.
        if !(xx + yy + s).is_finite() {
            return None;
        }
        ss = s;
        let k = pts.len() as f64;
        let jtj = Matrix3::new(xx, xy, sx, xy, yy, sy, sx, sy, k);
        let jtf = Vector3::new(fx, fy, ff);
        let step = jtj.lu().solve(&(-jtf))?;
        c += Vector2::new(step.x, step.y);
        r += step.z;
        // Gauss-Newton gains digits many at a time here (its rate is of the order of the noise
        // over the radius): the step after one under 1e-12 of the radius is far smaller still.
        if step.norm() < 1e-12 * (1.0 + r) {
            break;
        }
    }
    Some(Circle {
        centre: c + m,
        radius: r.abs(),
        rms: (ss / pts.len() as f64).sqrt(),
    })
}

/// The algebraic fit's sums about the mean `m`: d_x^2, d_x d_y, d_y^2, d_x, d_y, d_x |d|^2,
/// d_y |d|^2, |d|^2.
#[multiversion::multiversion(targets("x86_64+avx512f", "x86_64+avx2"))]
fn kasa_sums(pts: &[Vector2<f64>], m: Vector2<f64>) -> [f64; 8] {
    crate::math::lane_sums(pts, |p| {
        let (x, y) = (p.x - m.x, p.y - m.y);
        let q = x * x + y * y;
        [x * x, x * y, y * y, x, y, x * q, y * q, q]
    })
}

/// Gauss-Newton's sums at centre `c` (from the mean `m`) and radius `r`: J^T J's five distinct
/// sums (j_x^2, j_x j_y, j_y^2, -j_x, -j_y), J^T f (j_x f, j_y f, -f) and f^2.
#[multiversion::multiversion(targets("x86_64+avx512f", "x86_64+avx2"))]
fn gauss_newton_sums(pts: &[Vector2<f64>], m: Vector2<f64>, c: Vector2<f64>, r: f64) -> [f64; 9] {
    crate::math::lane_sums(pts, |p| {
        let (x, y) = ((p.x - m.x) - c.x, (p.y - m.y) - c.y);
        let n = (x * x + y * y).sqrt();
        let f = n - r;
        let inv = -1.0 / n;
        let (jx, jy) = (x * inv, y * inv);
        [
            jx * jx,
            jx * jy,
            jy * jy,
            -jx,
            -jy,
            jx * f,
            jy * f,
            -f,
            f * f,
        ]
    })
}

/// A sphere fitted to 3D points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    pub centre: nalgebra::Vector3<f64>,
    pub radius: f64,
    pub rms: f64,
}

/// Sphere fit: algebraic start, then Gauss-Newton on the geometric distances. None for fewer than 4
/// points or a degenerate (coplanar) set.
pub fn fit_sphere(pts: &[nalgebra::Vector3<f64>]) -> Option<Sphere> {
    use nalgebra::{Matrix4, Vector4};
    if pts.len() < 4 {
        return None;
    }
    let m = pts.iter().sum::<nalgebra::Vector3<f64>>() / pts.len() as f64;
    let (mut ata, mut atb) = (Matrix4::zeros(), Vector4::zeros());
    for p in pts {
        let d = p - m;
        let row = Vector4::new(d.x, d.y, d.z, 1.0);
        ata += row * row.transpose();
        atb += row * d.norm_squared();
    }
    let s = ata.lu().solve(&atb)?;
    let mut c = nalgebra::Vector3::new(s.x, s.y, s.z) / 2.0;
    let r2 = s.w + c.norm_squared();
    if !(r2 > 0.0) {
        return None;
    }
    let mut r = r2.sqrt();
    for _ in 0..50 {
        let (mut jtj, mut jtf) = (Matrix4::zeros(), Vector4::zeros());
        for p in pts {
            let d = (p - m) - c;
            let n = d.norm();
            if n == 0.0 {
                return None;
            }
            let j = Vector4::new(-d.x / n, -d.y / n, -d.z / n, -1.0);
            jtj += j * j.transpose();
            jtf += j * (n - r);
        }
        let step = jtj.lu().solve(&(-jtf))?;
        c += nalgebra::Vector3::new(step.x, step.y, step.z);
        r += step.w;
        if step.norm() < 1e-15 * (1.0 + r) {
            break;
        }
    }
    let ss: f64 = pts.iter().map(|p| ((p - m - c).norm() - r).powi(2)).sum();
    Some(Sphere {
        centre: c + m,
        radius: r.abs(),
        rms: (ss / pts.len() as f64).sqrt(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points on an arc of the circle (cx, cy, r) from angle a0 to a1, with `noise` times a
    /// fixed pattern added to the radius.
    fn arc(
        n: usize,
        (cx, cy, r): (f64, f64, f64),
        (a0, a1): (f64, f64),
        noise: f64,
    ) -> Vec<Vector2<f64>> {
        (0..n)
            .map(|i| {
                let a = a0 + (a1 - a0) * i as f64 / (n - 1) as f64;
                let rr = r + noise * ((i * 7919 % 13) as f64 - 6.0) / 6.0;
                Vector2::new(cx + rr * a.cos(), cy + rr * a.sin())
            })
            .collect()
    }

    #[test]
    fn exact_points_give_the_exact_circle_whatever_their_count() {
        // Counts below, at and past a whole group of lanes.
        for n in [3, 5, 8, 9, 17, 1003] {
            let truth = (0.012, 0.31, 0.0695);
            let c = fit_circle(&arc(n, truth, (-2.4, -0.7), 0.0)).unwrap();
            assert!(
                (c.centre - Vector2::new(truth.0, truth.1)).norm() < 1e-13,
                "{n}: {c:?}"
            );
            assert!((c.radius - truth.2).abs() < 1e-13, "{n}: {c:?}");
            assert!(c.rms < 1e-13, "{n}: {c:?}");
        }
    }

    #[test]
    fn noisy_points_give_the_least_squares_circle_and_its_rms() {
        let pts = arc(1001, (-0.05, 0.4, 0.0695), (-2.0, -1.1), 1e-4);
        let c = fit_circle(&pts).unwrap();
        // At the geometric fit's optimum J^T f = 0: one more Gauss-Newton step, summed
        // plainly point by point, goes nowhere.
        let (mut jtj, mut g, mut ss) = (Matrix3::zeros(), Vector3::zeros(), 0.0);
        for p in &pts {
            let d = p - c.centre;
            let f = d.norm() - c.radius;
            let j = Vector3::new(-d.x / d.norm(), -d.y / d.norm(), -1.0);
            jtj += j * j.transpose();
            g += j * f;
            ss += f * f;
        }
        let step = jtj.lu().solve(&g).unwrap();
        assert!(step.norm() < 1e-14, "step {step:?}");
        let rms = (ss / pts.len() as f64).sqrt();
        assert!(
            rms > 1e-5 && (c.rms - rms).abs() < 1e-9 * rms,
            "{} vs {rms}",
            c.rms
        );
    }

    #[test]
    fn too_few_or_collinear_points_give_none() {
        let line: Vec<Vector2<f64>> = (0..20)
            .map(|i| Vector2::new(i as f64, 2.0 * i as f64))
            .collect();
        assert!(fit_circle(&line).is_none());
        assert!(fit_circle(&line[..2]).is_none());
    }
}
