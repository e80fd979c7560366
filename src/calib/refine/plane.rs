//! The plane's refinement model: every profile point against the plane.
//!
//! Specimen parameters: the plane's frame Q (normal n = Q z), Q <- Q exp([a, b, 0]) (2), and its
//! offset d along n (1). Residual per point q (base frame): its signed distance n.q - d, which is
//! along the surface normal.

use super::{AlongDepth, Model, Options, Refined, Transform, exp, frame_with, skew};
use nalgebra::{DMatrix, DVector, Isometry3, Matrix3, Rotation3, SymmetricEigen, Vector2, Vector3};

#[derive(Debug, Clone, PartialEq)]
pub struct PlaneModel {
    /// Profile points (sensor x, z) on the plane, with the flange pose each was seen from.
    pub points: Vec<(Isometry3<f64>, Vector2<f64>)>,
    /// Each point's distance across the plane rather than along the depth (`AlongDepth`): the
    /// plane's solver until its last step (`calib::plane::solve`). From a start that missed (a
    /// bar's wall taken for its face, on one of 20 exact rigs) the fit along the depth moved the
    /// start where the bar's own fit no longer recovered (5.9 deg off).
    pub across: bool,
}

/// A plane {q : n.q = d}, n = q_frame z.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    pub frame: Rotation3<f64>,
    pub offset: f64,
}

impl Plane {
    pub fn new(normal: &Vector3<f64>, offset: f64) -> Plane {
        Plane {
            frame: frame_with(normal, 2),
            offset,
        }
    }

    pub fn normal(&self) -> Vector3<f64> {
        self.frame * Vector3::z()
    }
}

impl Model for PlaneModel {
    type Specimen = Plane;

    fn name(&self) -> &'static str {
        "plane refinement"
    }
    fn n_specimen_params(&self) -> usize {
        3
    }
    fn n_features(&self) -> usize {
        self.points.len()
    }
    fn residuals_per_feature(&self) -> usize {
        1
    }

    fn residual_flanges(&self) -> Vec<&Isometry3<f64>> {
        self.points.iter().map(|(f, _)| f).collect()
    }

    fn map_poses(&self, to: &mut dyn FnMut(&Isometry3<f64>) -> Isometry3<f64>) -> PlaneModel {
        PlaneModel {
            points: super::moved(&self.points, to),
            across: self.across,
        }
    }

    fn without_poses(&self, drop: &dyn Fn(&Isometry3<f64>) -> bool) -> PlaneModel {
        PlaneModel {
            points: super::kept(&self.points, drop),
            across: self.across,
        }
    }

    fn eval(
        &self,
        x: &Transform,
        s: &Plane,
        _labels: &[f64],
        r: &mut DVector<f64>,
        mut j: Option<&mut DMatrix<f64>>,
    ) {
        let mut seer = x.seer();
        let n = s.normal();
        let (e1, e2) = (s.frame * Vector3::x(), s.frame * Vector3::y());
        for (i, (f, p)) in self.points.iter().enumerate() {
            let (qb, dq_dw, dq_dt) = seer.point(f, p, j.is_some());
            // Along the depth (`AlongDepth`): the distance across is biased under z noise.
            let a = n.dot(&qb) - s.offset;
            let depth = if self.across {
                AlongDepth::ACROSS
            } else {
                seer.along_depth(f, &n, j.is_some())
            };
            r[i] = a * depth.scale;
            if let Some(j) = j.as_deref_mut() {
                depth.transform_columns(j, i, &n, &dq_dw, &dq_dt, a);
                // n(a, b) = Q exp([a, b, 0]) z: dn/da = -Q y, dn/db = Q x.
                j[(i, 6)] = depth.column(-e2.dot(&qb), a, &-e2);
                j[(i, 7)] = depth.column(e1.dot(&qb), a, &e1);
                j[(i, 8)] = -depth.scale;
            }
        }
    }

    fn step(&self, s: &Plane, dx: &[f64]) -> Plane {
        s.stepped(dx)
    }

    fn reduced_fit(
        &self,
        x: &Isometry3<f64>,
        s: &Plane,
        opts: &Options,
    ) -> Option<(Refined, Plane)> {
        let m = self.moments();
        // Worth it where the poses hold many points each (a profile's hundreds: three rows).
        if 2 * m.rows.len() >= self.points.len() {
            return None;
        }
        super::refine_rows(&m, x, s, opts).ok()
    }
}

impl Plane {
    fn stepped(&self, dx: &[f64]) -> Plane {
        Plane {
            frame: self.frame * exp(&Vector3::new(dx[0], dx[1], 0.0)),
            offset: self.offset + dx[2],
        }
    }
}

impl PlaneModel {
    /// Each run of points from one pose by its moments (`Moments`).
    pub fn moments(&self) -> Moments {
        Moments {
            rows: moment_rows(&self.points),
            across: self.across,
        }
    }
}

/// Each run of `points` from one pose by at most three rows v = (x, z, c) with sum v v^T equal to
/// the run's sum u u^T, u = (x, z, 1) (`Moments`).
pub fn moment_rows(
    points: &[(Isometry3<f64>, Vector2<f64>)],
) -> Vec<(Isometry3<f64>, Vector3<f64>)> {
    weighted_moment_rows(points, |_| 1.0)
}

/// `moment_rows` of the points weighted by `weight` (of a point's index): sum v v^T equal to
/// the run's sum w u u^T (a robust fit's weights, fixed for one of its rounds).
pub fn weighted_moment_rows(
    points: &[(Isometry3<f64>, Vector2<f64>)],
    weight: impl Fn(usize) -> f64,
) -> Vec<(Isometry3<f64>, Vector3<f64>)> {
    let mut rows = Vec::new();
    let mut i = 0;
    while i < points.len() {
        let f = points[i].0;
        let mut sum = Matrix3::zeros();
        let mut k = i;
        while k < points.len() && points[k].0 == f {
            let p = points[k].1;
            let u = Vector3::new(p.x, p.y, 1.0);
            sum += u * u.transpose() * weight(k);
            k += 1;
        }
        let e = SymmetricEigen::new(sum);
        for c in 0..3 {
            let l = e.eigenvalues[c];
            if l > 0.0 {
                rows.push((f, e.eigenvectors.column(c) * l.sqrt()));
            }
        }
        i = k;
    }
    rows
}

/// A moment row v = (x, z, c) seen from the flange pose `f`: `Transform::point_in_base` of the
/// point (x, z) with the constant terms scaled by c, and its derivatives (zero without `jac`).
pub fn row_in_base(
    x: &Transform,
    f: &Isometry3<f64>,
    v: &Vector3<f64>,
    jac: bool,
) -> (Vector3<f64>, Matrix3<f64>, Matrix3<f64>) {
    let (ps, c) = (Vector3::new(v.x, 0.0, v.y), v.z);
    let fr = *f.rotation.to_rotation_matrix().matrix();
    let frr = fr * x.rot.matrix();
    let q = frr * ps + (fr * x.t + f.translation.vector) * c;
    if !jac {
        return (q, Matrix3::zeros(), Matrix3::zeros());
    }
    (q, -frr * skew(&ps), fr * c)
}

/// The plane's points grouped by pose. A point's row (residual and Jacobian) is linear in
/// u = (x, z, 1), so a pose's rows add up to normal equations in the moments S = sum u u^T alone;
/// three rows v = sqrt(l) e (S's eigenvalues l and eigenvectors e; sum v v^T = S) have the same,
/// whatever the number of points. A row v = (x, z, c) is the point (x, z) with the pose's and
/// the plane's constant terms scaled by c. Its least-squares optimum is the points' own; its
/// residuals' spread and the verdict's sums are not (they need the points).
#[derive(Debug, Clone, PartialEq)]
pub struct Moments {
    rows: Vec<(Isometry3<f64>, Vector3<f64>)>,
    across: bool,
}

impl Model for Moments {
    type Specimen = Plane;

    fn name(&self) -> &'static str {
        "plane refinement"
    }
    fn n_specimen_params(&self) -> usize {
        3
    }
    fn n_features(&self) -> usize {
        self.rows.len()
    }
    fn residuals_per_feature(&self) -> usize {
        1
    }

    fn residual_flanges(&self) -> Vec<&Isometry3<f64>> {
        self.rows.iter().map(|(f, _)| f).collect()
    }

    fn map_poses(&self, to: &mut dyn FnMut(&Isometry3<f64>) -> Isometry3<f64>) -> Moments {
        Moments {
            rows: super::moved(&self.rows, to),
            across: self.across,
        }
    }

    fn without_poses(&self, drop: &dyn Fn(&Isometry3<f64>) -> bool) -> Moments {
        Moments {
            rows: super::kept(&self.rows, drop),
            across: self.across,
        }
    }

    fn eval(
        &self,
        x: &Transform,
        s: &Plane,
        _labels: &[f64],
        r: &mut DVector<f64>,
        mut j: Option<&mut DMatrix<f64>>,
    ) {
        let n = s.normal();
        let (e1, e2) = (s.frame * Vector3::x(), s.frame * Vector3::y());
        for (i, (f, v)) in self.rows.iter().enumerate() {
            let c = v.z;
            let (qb, dq_dw, dq_dt) = row_in_base(x, f, v, j.is_some());
            let a = n.dot(&qb) - s.offset * c;
            // One scale per pose: the rows still sum to the points' normal equations.
            let depth = if self.across {
                AlongDepth::ACROSS
            } else {
                AlongDepth::new(x, f, &n, j.is_some())
            };
            r[i] = a * depth.scale;
            if let Some(j) = j.as_deref_mut() {
                depth.transform_columns(j, i, &n, &dq_dw, &dq_dt, a);
                j[(i, 6)] = depth.column(-e2.dot(&qb), a, &-e2);
                j[(i, 7)] = depth.column(e1.dot(&qb), a, &e1);
                j[(i, 8)] = -c * depth.scale;
            }
        }
    }

    fn step(&self, s: &Plane, dx: &[f64]) -> Plane {
        s.stepped(dx)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::refine::{Loss, Status, eval, refine, refine_rows};

    /// Profiles of the plane z = 0.01 from 12 poses, 200 points each, with z noise `noise` (m).
    fn model(noise: f64) -> (PlaneModel, Isometry3<f64>, Plane) {
        let x = Isometry3::new(
            Vector3::new(0.006, 0.054, 0.364),
            Vector3::new(3.1, -0.02, 0.1),
        );
        let plane = Plane::new(&Vector3::z(), 0.01);
        let t = Transform::from_isometry(&x);
        let mut points = Vec::new();
        for k in 0..12 {
            let a = k as f64;
            let f = Isometry3::new(
                Vector3::new(-0.3 + 0.01 * a, -0.3, 0.45),
                Vector3::new(0.25 * (0.7 * a).sin(), 0.25 * (1.3 * a).cos(), 0.4 * a),
            );
            // On the laser plane's line across the plane: z solved from x, then noise.
            for i in 0..200 {
                let px = -0.05 + 0.1 * i as f64 / 199.0;
                let at = |z: f64| t.point_in_base(&f, &Vector2::new(px, z), false).0.z - 0.01;
                let (a0, a1) = (at(0.0), at(1.0));
                let z = -a0 / (a1 - a0) + noise * (7.0 * i as f64 + a).sin();
                points.push((f, Vector2::new(px, z)));
            }
        }
        (
            PlaneModel {
                points,
                across: false,
            },
            x,
            plane,
        )
    }

    /// Under z noise the distances across the plane pull the fit (their noise, sigma |n . z|,
    /// shrinks as the fit turns the plane toward the depth); along the depth they do not. Twelve
    /// tilted views, 200 points each, z noise 0.5 mm (large, so that the pull shows in 200
    /// draws): the mean error over the draws, per axis, in units of its standard error.
    #[test]
    fn distances_along_the_depth_leave_no_pull_from_z_noise() {
        let (exact, x, plane) = model(0.0);
        let draws = 200;
        let mut errs = [Vec::new(), Vec::new()];
        for d in 0..draws {
            let mut g = crate::testkit::rng(40_000 + d);
            let mut noisy = exact.clone();
            for (_, p) in &mut noisy.points {
                p.y += 0.5e-3 * crate::rng::gauss(&mut g);
            }
            for (k, across) in [true, false].into_iter().enumerate() {
                let m = PlaneModel {
                    across,
                    ..noisy.clone()
                };
                let (r, _) = refine(&m, &x, &plane, &Options::default()).unwrap();
                let w = (x.rotation.inverse() * r.flange_to_sensor.rotation).scaled_axis();
                let t = r.flange_to_sensor.translation.vector - x.translation.vector;
                errs[k].push([w.x, w.y, w.z, t.x, t.y, t.z]);
            }
        }
        // The largest |mean| / standard error over the six axes.
        let worst = |e: &[[f64; 6]]| {
            (0..6)
                .map(|i| {
                    let n = e.len() as f64;
                    let mean = e.iter().map(|v| v[i]).sum::<f64>() / n;
                    let sd =
                        (e.iter().map(|v| (v[i] - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
                    mean.abs() / (sd / n.sqrt())
                })
                .fold(0.0, f64::max)
        };
        let (across, along) = (worst(&errs[0]), worst(&errs[1]));
        eprintln!("worst mean: across {across:.1}, along {along:.1} standard errors");
        assert!(
            across > 5.0,
            "across: worst mean {across:.1} standard errors"
        );
        assert!(
            along < 3.5,
            "along the depth: worst mean {along:.1} standard errors"
        );
    }

    #[test]
    fn a_poses_moments_have_its_points_normal_equations() {
        let (m, x, plane) = model(1e-4);
        let reduced = m.moments();
        assert_eq!(reduced.rows.len(), 36);
        let off = Transform::from_isometry(
            &(x * Isometry3::new(
                Vector3::new(1e-3, -2e-3, 1e-3),
                Vector3::new(0.01, 0.0, -0.02),
            )),
        );
        let s = plane.stepped(&[0.01, -0.02, 1e-3]);
        let (r, j) = eval(&m, &off, &s, &[], true);
        let (rm, jm) = eval(&reduced, &off, &s, &[], true);
        // The moments' rows' residuals cancel more (S's eigen-decomposition is exact to its
        // largest eigenvalue's rounding): the cost agrees to 1e-10, the optimum the same.
        crate::calib::refine::testing::same_normal_equations((&j, &r, None), (&jm, &rm), 1e-12);
    }

    #[test]
    fn refining_over_the_moments_finds_the_points_optimum() {
        for noise in [0.0, 1e-4] {
            optimum_with_noise(noise);
        }
    }

    fn optimum_with_noise(noise: f64) {
        let (m, x, plane) = model(noise);
        let start = x * Isometry3::new(
            Vector3::new(2e-3, -1e-3, 3e-3),
            Vector3::new(0.02, -0.01, 0.03),
        );
        let opts = Options {
            loss: Loss::Squared,
            max_iterations: 100,
        };
        let (rows, _) = refine_rows(&m, &start, &plane, &opts).unwrap();
        let (via, _) = refine(&m, &start, &plane, &opts).unwrap();
        assert!(matches!(via.status, Status::Converged { .. }));
        // Both converged: within the refinement's own tolerance of each other (a gain under
        // 1e-12 of the cost stops either; along the depth the cost is less nearly quadratic and
        // the two stopped 6e-9 rad apart at z noise 0.1 mm), and exact on exact points.
        let d = rows.flange_to_sensor.inverse() * via.flange_to_sensor;
        assert!(
            d.translation.vector.norm() < 1e-8 && d.rotation.angle() < 2e-8,
            "{d}"
        );
        if noise == 0.0 {
            let e = x.inverse() * via.flange_to_sensor;
            assert!(
                e.translation.vector.norm() < 1e-9 && e.rotation.angle() < 1e-9,
                "{e}"
            );
        }
        assert!((rows.residual_rms - via.residual_rms).abs() <= 1e-9 * rows.residual_rms + 1e-15);
        assert_eq!(rows.n_residuals, via.n_residuals);
        assert!((rows.initial_cost - via.initial_cost).abs() <= 1e-10 * rows.initial_cost);
    }

    /// A plane model that counts its evaluations without a Jacobian (the steps tried) and
    /// scales their residuals by 1 + 1e-13: a rounding difference between the two evaluations
    /// (the full rows' against a reduced model's) that makes every step from the optimum fail.
    #[derive(Clone, Debug)]
    struct Counted(PlaneModel, std::sync::Arc<std::sync::atomic::AtomicUsize>);

    impl Model for Counted {
        type Specimen = Plane;
        fn name(&self) -> &'static str {
            self.0.name()
        }
        fn n_specimen_params(&self) -> usize {
            self.0.n_specimen_params()
        }
        fn n_features(&self) -> usize {
            self.0.n_features()
        }
        fn residuals_per_feature(&self) -> usize {
            self.0.residuals_per_feature()
        }
        fn eval(
            &self,
            x: &Transform,
            s: &Plane,
            labels: &[f64],
            r: &mut DVector<f64>,
            j: Option<&mut DMatrix<f64>>,
        ) {
            let tried = j.is_none();
            self.0.eval(x, s, labels, r, j);
            if tried {
                self.1.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                *r *= 1.0 + 1e-13;
            }
        }
        fn step(&self, s: &Plane, dx: &[f64]) -> Plane {
            self.0.step(s, dx)
        }
        fn without_poses(&self, drop: &dyn Fn(&Isometry3<f64>) -> bool) -> Counted {
            Counted(self.0.without_poses(drop), self.1.clone())
        }
        fn map_poses(&self, to: &mut dyn FnMut(&Isometry3<f64>) -> Isometry3<f64>) -> Counted {
            Counted(self.0.map_poses(to), self.1.clone())
        }
    }

    #[test]
    fn a_fit_started_at_its_optimum_stops_without_a_search() {
        let (m, x, plane) = model(1e-4);
        let opts = Options {
            loss: Loss::Squared,
            max_iterations: 100,
        };
        let (best, s) = refine(&m, &x, &plane, &opts).unwrap();
        let evals = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
        let counted = Counted(m, evals.clone());
        let (again, _) = refine_rows(&counted, &best.flange_to_sensor, &s, &opts).unwrap();
        // One step tried and the residuals at the end; raising lambda to 1e16 after the failed
        // step, as the fit did, evaluated every point 33 times more for nothing.
        let n = evals.load(std::sync::atomic::Ordering::Relaxed);
        assert!(n <= 3, "{n} evaluations");
        assert!(matches!(again.status, Status::Converged { iterations: 1 }));
        assert_eq!(again.flange_to_sensor, best.flange_to_sensor);
    }
}
