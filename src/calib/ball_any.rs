//! The ball from any poses: no rotation or translation groups, no hand-given side of the laser
//! plane, no starting guess. Each profile's arc gives the section circle (centre q, radius r) in the
//! laser plane; the ball centre in the sensor frame is then s = (q_x, sigma h, q_z) with
//! h = sqrt(R^2 - r^2) and sigma = +-1 unknown. Every pose satisfies
//!
//!   R_i (R s_i + t) + t_i = c                                            (1)
//!
//! (R_i, t_i: base_to_flange; R, t: flange_to_sensor; c: the centre in the base frame).
//!
//! 1. Global start: for rotations R spread over SO(3), (t, c) solve (1) in least squares. Its
//!    normal matrix does not depend on R, so it is factored once. The sides sigma_i start
//!    neutral (h taken as 0), then each pose takes the side its residual prefers, twice.
//! 2. Linear refinement: with the sides fixed, (1) is linear in (R as 9 numbers, t, c). It is
//!    solved from the best few starts, and R is projected onto SO(3). Noise-free data with the
//!    right sides give the truth here. The sides are re-inferred from the prediction
//!    sign((R^T (R_i^T (c - t_i) - t))_y) until they settle.
//! 3. Joint refinement over every arc point against the sphere (`refine::ball`: residuals along
//!    the normal, no side labels), which also reports the observability and refuses pose sets
//!    that cannot fix the transform.

use super::CalibError;
use super::refine::{Options, Problem, Refinable, Refined, ball::BallModel};
use crate::math::nearest_rotation;
use nalgebra::{DMatrix, DVector, Isometry3, Matrix3, Matrix6, Point3, Rotation3, Translation3};
use nalgebra::{UnitQuaternion, Vector2, Vector3, Vector6};

const METHOD: &str = "ball (any poses)";

/// One profile's view of the ball: the flange pose, the arc's circle in the laser plane (sensor x,
/// z), and the arc's points.
#[derive(Debug, Clone, PartialEq)]
pub struct ArcView {
    pub base_to_flange: Isometry3<f64>,
    pub circle_centre: Vector2<f64>,
    pub circle_radius: f64,
    pub points: crate::captures::SharedPoints,
}

#[derive(Debug, Clone)]
pub struct AnyPose {
    pub flange_to_sensor: Isometry3<f64>,
    pub centre_in_base: Point3<f64>,
    /// The side of the laser plane the ball centre lies on, per view (+1: the sensor's +y), as
    /// the data say.
    pub sides: Vec<f64>,
    /// The joint refinement from the start (its status, covariance and observability).
    pub refined: Refined,
    /// The refinement problem (for tools that refine again or inspect residuals).
    pub problem: Problem<BallModel>,
}

/// A candidate (R, t, c) and its cost: the sum over views of |residual of (1)|^2 (m^2).
#[derive(Debug, Clone, Copy)]
struct Candidate {
    r: Matrix3<f64>,
    t: Vector3<f64>,
    c: Vector3<f64>,
    cost: f64,
}

pub fn solve(views: &[ArcView], radius: f64) -> Result<AnyPose, CalibError> {
    if views.len() < 3 {
        return Err(CalibError::TooFewData {
            method: METHOD,
            what: "profiles with an arc",
            got: views.len(),
            need: 3,
        });
    }
    let h: Vec<f64> = views
        .iter()
        .map(|v| {
            (radius * radius - v.circle_radius * v.circle_radius)
                .max(0.0)
                .sqrt()
        })
        .collect();
    let normal = NormalEquations::new(views);
    let mut starts: Vec<Candidate> = rotation_grid()
        .map(|r| normal.best_sides(views, &h, &r))
        .collect();
    starts.sort_by(|a, b| a.cost.total_cmp(&b.cost));
    let mut model = BallModel::new(radius);
    let total = views.iter().map(|v| v.points.len()).sum();
    let keep = super::points_per_profile(total, views.len(), usize::MAX);
    for v in views {
        let stride = super::stride_for(v.points.len(), keep);
        if stride == 1 {
            model.add_shared(&v.base_to_flange, v.points.clone());
        } else {
            model.add(&v.base_to_flange, v.points.iter().step_by(stride).copied());
        }
    }
    // The best few distinct starts: a wrong one that fits (1) nearly as well is refined too, and
    // the joint refinement's cost decides.
    let mut tried: Vec<&Candidate> = Vec::new();
    for s in &starts {
        if tried.len() == 3 {
            break;
        }
        if !tried.iter().any(|t| angle_between(&t.r, &s.r) < 0.35) {
            tried.push(s);
        }
    }
    // Refined side by side (independent; read back in order, the same on any number of threads).
    use rayon::prelude::*;
    let refined: Vec<_> = tried
        .par_iter()
        .map(|s| {
            let cand = linear(views, &h, &normal, **s);
            let x = Isometry3::from_parts(
                Translation3::from(cand.t),
                UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(cand.r)),
            );
            let problem = Problem {
                model: model.clone(),
                specimen: cand.c,
            };
            problem.refine(&x, &Options::default()).map(|r| (cand, r))
        })
        .collect();
    let mut best: Option<AnyPose> = None;
    for r in refined {
        let (cand, refined) = r?;
        // Another start must end clearly lower to win: starts that reach one minimum end equal to
        // rounding, and the first (the best fit of (1)) is kept, so the result does not flip
        // with the last digits of the data.
        if best
            .as_ref()
            .is_none_or(|b| refined.cost < b.refined.cost * (1.0 - 1e-9))
        {
            let c = refined.centre.map_or(cand.c, |p| p.coords);
            let x = refined.flange_to_sensor;
            best = Some(AnyPose {
                flange_to_sensor: x,
                centre_in_base: Point3::from(c),
                sides: sides_of(views, &x, &c),
                refined,
                problem: Problem {
                    model: model.clone(),
                    specimen: c,
                },
            });
        }
    }
    best.ok_or(CalibError::TooFewData {
        method: METHOD,
        what: "starts",
        got: 0,
        need: 1,
    })
}

/// The ball centre's side of the laser plane in each view, predicted by (X, c).
fn sides_of(views: &[ArcView], x: &Isometry3<f64>, c: &Vector3<f64>) -> Vec<f64> {
    views
        .iter()
        .map(|v| {
            let s = (v.base_to_flange * x).inverse_transform_point(&Point3::from(*c));
            if s.y >= 0.0 { 1.0 } else { -1.0 }
        })
        .collect()
}

fn angle_between(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
    let cos = ((a.transpose() * b).trace() - 1.0) / 2.0;
    cos.clamp(-1.0, 1.0).acos()
}

/// Rotations spread over SO(3): the sensor's z axis on 300 Fibonacci-sphere directions, each with
/// 24 turns about it (at most about 10 deg from any rotation).
fn rotation_grid() -> impl Iterator<Item = Matrix3<f64>> {
    let n = 300;
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n).flat_map(move |i| {
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
        let rho = (1.0 - z * z).sqrt();
        let phi = golden * i as f64;
        let axis = Vector3::new(rho * phi.cos(), rho * phi.sin(), z);
        let helper = if axis.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let e1 = helper.cross(&axis).normalize();
        let e2 = axis.cross(&e1);
        (0..24).map(move |k| {
            let a = k as f64 * std::f64::consts::TAU / 24.0;
            let x = e1 * a.cos() + e2 * a.sin();
            let y = axis.cross(&x);
            Matrix3::from_columns(&[x, y, axis])
        })
    })
}

/// The least-squares (t, c) of (1) for a given R: the normal matrix [N I, -sum R_i^T; -sum R_i,
/// N I] depends only on the poses, so its (pseudo-)inverse is computed once.
struct NormalEquations {
    inverse: Matrix6<f64>,
}

impl NormalEquations {
    fn new(views: &[ArcView]) -> NormalEquations {
        let n = views.len() as f64;
        let sum_r: Matrix3<f64> = views
            .iter()
            .map(|v| *v.base_to_flange.rotation.to_rotation_matrix().matrix())
            .sum();
        let mut a = Matrix6::zeros();
        a.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(Matrix3::identity() * n));
        a.fixed_view_mut::<3, 3>(3, 3)
            .copy_from(&(Matrix3::identity() * n));
        a.fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&(-sum_r.transpose()));
        a.fixed_view_mut::<3, 3>(3, 0).copy_from(&(-sum_r));
        // Pure translations leave (t, c) singular (t + c is all they fix): the minimum-norm
        // solution is a start, and the joint refinement refuses such a pose set.
        let inverse = a
            .pseudo_inverse(1e-12 * a.norm())
            .unwrap_or_else(|_| Matrix6::zeros());
        NormalEquations { inverse }
    }

    /// (t, c) for rotation `r` and sensor-frame centres `s`.
    fn solve(&self, views: &[ArcView], r: &Matrix3<f64>, s: &[Vector3<f64>]) -> Candidate {
        let mut rhs = Vector6::zeros();
        for (v, si) in views.iter().zip(s) {
            let ri = v.base_to_flange.rotation.to_rotation_matrix();
            let b = -v.base_to_flange.translation.vector - ri * (r * si);
            let top = ri.inverse() * b;
            rhs[0] += top.x;
            rhs[1] += top.y;
            rhs[2] += top.z;
            rhs[3] -= b.x;
            rhs[4] -= b.y;
            rhs[5] -= b.z;
        }
        let x = self.inverse * rhs;
        let (t, c) = (
            x.fixed_rows::<3>(0).into_owned(),
            x.fixed_rows::<3>(3).into_owned(),
        );
        let cost = views
            .iter()
            .zip(s)
            .map(|(v, si)| residual(v, r, &t, &c, si).norm_squared())
            .sum();
        Candidate { r: *r, t, c, cost }
    }

    /// For rotation `r`: sides neutral first, then each view's side by its residual, twice.
    fn best_sides(&self, views: &[ArcView], h: &[f64], r: &Matrix3<f64>) -> Candidate {
        let centre = |v: &ArcView, y: f64| Vector3::new(v.circle_centre.x, y, v.circle_centre.y);
        let mut s: Vec<Vector3<f64>> = views.iter().map(|v| centre(v, 0.0)).collect();
        let mut cand = self.solve(views, r, &s);
        for _ in 0..2 {
            for ((v, si), hi) in views.iter().zip(s.iter_mut()).zip(h) {
                let (p, m) = (centre(v, *hi), centre(v, -*hi));
                *si = if residual(v, r, &cand.t, &cand.c, &p).norm_squared()
                    <= residual(v, r, &cand.t, &cand.c, &m).norm_squared()
                {
                    p
                } else {
                    m
                };
            }
            cand = self.solve(views, r, &s);
        }
        cand
    }
}

/// The residual of (1) for one view.
fn residual(
    v: &ArcView,
    r: &Matrix3<f64>,
    t: &Vector3<f64>,
    c: &Vector3<f64>,
    s: &Vector3<f64>,
) -> Vector3<f64> {
    v.base_to_flange.rotation * (r * s + t) + v.base_to_flange.translation.vector - c
}

/// Step 2: with the sides predicted by `start`, (1) is linear in (R, t, c); R is projected onto
/// SO(3) and (t, c) solved again, until the sides settle. Needs five views (15 unknowns);
/// with fewer, the start is returned.
fn linear(views: &[ArcView], h: &[f64], normal: &NormalEquations, start: Candidate) -> Candidate {
    if views.len() < 5 {
        return start;
    }
    let mut cand = start;
    let mut sides: Vec<f64> = Vec::new();
    for _ in 0..5 {
        let now: Vec<f64> = views
            .iter()
            .map(|v| {
                let ri = v.base_to_flange.rotation;
                let s = cand.r.transpose()
                    * (ri.inverse() * (cand.c - v.base_to_flange.translation.vector) - cand.t);
                if s.y >= 0.0 { 1.0 } else { -1.0 }
            })
            .collect();
        if now == sides {
            break;
        }
        sides = now;
        let s: Vec<Vector3<f64>> = views
            .iter()
            .zip(h)
            .zip(&sides)
            .map(|((v, hi), side)| Vector3::new(v.circle_centre.x, side * hi, v.circle_centre.y))
            .collect();
        let m = views.len();
        let mut a = DMatrix::zeros(3 * m, 15);
        let mut b = DVector::zeros(3 * m);
        for (i, (v, si)) in views.iter().zip(&s).enumerate() {
            let ri = *v.base_to_flange.rotation.to_rotation_matrix().matrix();
            for k in 0..3 {
                // R s = sum_k s_k R[:, k]: columns 3k..3k+3 of vec(R) (column-major).
                a.view_mut((3 * i, 3 * k), (3, 3)).copy_from(&(ri * si[k]));
            }
            a.view_mut((3 * i, 9), (3, 3)).copy_from(&ri);
            a.view_mut((3 * i, 12), (3, 3))
                .copy_from(&(-Matrix3::<f64>::identity()));
            b.rows_mut(3 * i, 3)
                .copy_from(&(-v.base_to_flange.translation.vector));
        }
        let Ok(x) = a.svd(true, true).solve(&b, 1e-12) else {
            break;
        };
        let r = nearest_rotation(&Matrix3::from_iterator(x.rows(0, 9).iter().copied()));
        let next = normal.solve(views, r.matrix(), &s);
        if !next.cost.is_finite() {
            break;
        }
        cand = next;
    }
    cand
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_grid_is_rotations_and_covers_so3() {
        let grid: Vec<Matrix3<f64>> = rotation_grid().collect();
        assert_eq!(grid.len(), 7200);
        for r in &grid {
            assert!((r.transpose() * r - Matrix3::identity()).norm() < 1e-12);
            assert!((r.determinant() - 1.0).abs() < 1e-12);
        }
        // Any rotation lies within about 10 deg of a grid rotation.
        let mut rng = crate::rng::stream(7, &[]);
        for _ in 0..50 {
            let q = UnitQuaternion::from_scaled_axis(Vector3::new(
                crate::rng::gauss(&mut rng),
                crate::rng::gauss(&mut rng),
                crate::rng::gauss(&mut rng),
            ));
            let m = *q.to_rotation_matrix().matrix();
            let nearest = grid
                .iter()
                .map(|g| angle_between(g, &m))
                .fold(f64::INFINITY, f64::min);
            assert!(nearest.to_degrees() < 12.0, "{}", nearest.to_degrees());
        }
    }
}
