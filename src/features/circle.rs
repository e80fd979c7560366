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
    // Rows (d_x, d_y, 1) against |d|^2, summed as scalars (the outer product's bits).
    let (mut xx, mut xy, mut yy, mut sx, mut sy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    let (mut bx, mut by, mut bb) = (0.0, 0.0, 0.0);
    for p in pts {
        let d = p - m;
        let q = d.x * d.x + d.y * d.y;
        xx += d.x * d.x;
        xy += d.x * d.y;
        yy += d.y * d.y;
        sx += d.x * 1.0;
        sy += d.y * 1.0;
        bx += d.x * q;
        by += d.y * q;
        bb += 1.0 * q;
    }
    let ata = Matrix3::new(xx, xy, sx, xy, yy, sy, sx, sy, pts.len() as f64);
    let sol = ata.lu().solve(&Vector3::new(bx, by, bb))?;
    let mut c = Vector2::new(sol.x / 2.0, sol.y / 2.0);
    let r2 = sol.z + c.norm_squared();
    if !r2.is_finite() || r2 <= 0.0 {
        return None;
    }
    let mut r = r2.sqrt();
    // Gauss-Newton on f_i = |p_i - c| - r, with J_i = (-d_x / n, -d_y / n, -1): J^T J's five
    // distinct sums and J^T f kept as scalars (the same products and sums as the 3 x 3 outer
    // product, the same bits, without its nine).
    // The sum of squared residuals at the last iteration's start: its step is below 1e-12 of
    // the radius, so it is the final fit's to far better than its digits (no pass of its own).
    let mut ss = 0.0;
    for _ in 0..50 {
        let (mut xx, mut xy, mut yy, mut sx, mut sy) = (0.0, 0.0, 0.0, 0.0, 0.0);
        let (mut fx, mut fy, mut ff) = (0.0, 0.0, 0.0);
        ss = 0.0;
        for p in pts {
            let d = (p - m) - c;
            let n = d.norm();
            if n == 0.0 {
                return None;
            }
            let f = n - r;
            let (jx, jy) = (-d.x / n, -d.y / n);
            xx += jx * jx;
            xy += jx * jy;
            yy += jy * jy;
            sx += jx * -1.0;
            sy += jy * -1.0;
            fx += jx * f;
            fy += jy * f;
            ff += -1.0 * f;
            ss += f * f;
        }
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
