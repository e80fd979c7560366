//! The ball's refinement model: arc points against the sphere.
//!
//! Specimen parameters: the centre c (3). Residual per arc point: the z offset the sensor's
//! noise makes, from the point to the sphere on its own side of the centre, where the sphere's
//! normal at that column is at least `NZ_DEPTH` from the laser's plane; nearer the silhouette,
//! its distance along the sphere's normal (|p - s| - R, s the centre in the sensor frame)
//! divided by its |n_z| (at least `NZ_MIN`). The depth residual of the first versions needed a branch label per
//! point and, taken up to the silhouette, was ill-conditioned at an arc's ends, where the
//! sphere's z changes fast with x: refinements stalled at their iteration limit (issue 14).
//! The normal distance over |n_z| everywhere, which followed, is biased outward at high noise
//! (`residual`).

use super::{Model, Sums, Transform, skew};
use crate::captures::SharedPoints;
use nalgebra::{DMatrix, DVector, Isometry3, Matrix3, Point3, Vector2, Vector3};

/// The least |n_z| a point's residual is divided by (about 73 deg from the sensor's z).
const NZ_MIN: f64 = 0.3;
/// From this |n_z| of the sphere's normal at a point's column the residual is the depth alone
/// (`residual`); from `NZ_BLEND` to it, a smooth step from the normal distance to the depth.
const NZ_DEPTH: f64 = 0.3;
const NZ_BLEND: f64 = 0.15;

#[derive(Debug, Clone, PartialEq)]
pub struct BallModel {
    pub radius: f64,
    /// The flange poses the arcs were seen from.
    poses: Vec<Isometry3<f64>>,
    /// The arcs (sensor x, z) with the index of their pose, shared with the captures they came
    /// from: a Fig. 17 trial holds hundreds of thousands of points, and a copy per point (with
    /// its pose index) was 24 bytes each on top of the captures' 16.
    arcs: Vec<(u32, SharedPoints)>,
    /// Points before each arc: where a part of the rows starts.
    starts: Vec<usize>,
    n: usize,
}

impl Model for BallModel {
    type Specimen = Vector3<f64>;

    fn name(&self) -> &'static str {
        "ball refinement"
    }
    fn n_specimen_params(&self) -> usize {
        3
    }
    fn n_features(&self) -> usize {
        self.n
    }
    fn residuals_per_feature(&self) -> usize {
        1
    }

    fn residual_flanges(&self) -> Vec<&Isometry3<f64>> {
        self.arcs
            .iter()
            .flat_map(|(k, a)| std::iter::repeat_n(&self.poses[*k as usize], a.len()))
            .collect()
    }

    fn radius(&self) -> Option<f64> {
        Some(self.radius)
    }

    fn with_radius(&self, radius: f64) -> Option<BallModel> {
        Some(BallModel {
            radius,
            ..self.clone()
        })
    }

    /// By arc, as `clusters` numbers them.
    fn orientation_groups(&self) -> Vec<u32> {
        let flanges = self.arc_flanges();
        let p = 6 + self.n_specimen_params();
        if super::honest::pose_directions(super::honest::orientations(flanges.iter().copied()), p)
            == 0
        {
            return Vec::new();
        }
        let clusters = self.arc_clusters();
        let g = clusters.iter().map(|&c| c as usize + 1).max().unwrap_or(0);
        super::honest::orientation_groups(&flanges, &clusters, g)
    }

    /// Numbered per arc, not per point: neither a pose per point nor a table sized by them.
    fn clusters(&self) -> Vec<u32> {
        let mut out = Vec::with_capacity(self.n);
        for ((_, a), id) in self.arcs.iter().zip(self.arc_clusters()) {
            out.extend(std::iter::repeat_n(id, a.len()));
        }
        out
    }

    fn map_poses(&self, to: &mut dyn FnMut(&Isometry3<f64>) -> Isometry3<f64>) -> BallModel {
        BallModel {
            poses: self.poses.iter().map(|f| to(f)).collect(),
            ..self.clone()
        }
    }

    fn without_poses(&self, drop: &dyn Fn(&Isometry3<f64>) -> bool) -> BallModel {
        let mut kept = BallModel::new(self.radius);
        for (k, a) in &self.arcs {
            let f = &self.poses[*k as usize];
            if !drop(f) {
                kept.add_shared(f, a.clone());
            }
        }
        kept
    }

    fn eval(
        &self,
        x: &Transform,
        c: &Vector3<f64>,
        _branch: &[f64],
        r: &mut DVector<f64>,
        j: Option<&mut DMatrix<f64>>,
    ) {
        self.rows(x, c, 0..self.n, r, j);
    }

    fn eval_part(
        &self,
        x: &Transform,
        c: &Vector3<f64>,
        _branch: &[f64],
        part: std::ops::Range<usize>,
        r: &mut DVector<f64>,
        j: &mut DMatrix<f64>,
    ) -> bool {
        self.rows(x, c, part, r, Some(j));
        true
    }

    /// Per arc, not per row: a point's row is d^T A with d its residual's gradient in the
    /// sensor-frame centre and A = [skew(s), -R^T, R^T F_R^T] the arc's own 3 x 9, so the rows'
    /// sums are A^T (sum d d^T) A and A^T (sum d r): three columns per point instead of nine.
    /// Clustered per arc's pose (`arc_clusters`), not through a number per point.
    fn sums(&self, x: &Transform, c: &Vector3<f64>) -> Option<Sums> {
        const P: usize = 9;
        let clusters = self.arc_clusters();
        let g = clusters.iter().map(|&c| c as usize + 1).max().unwrap_or(0);
        let clustered = self.n > 0;
        let gram_clusters = clustered && g <= super::honest::MAX_JACKKNIFE;
        let mut sums = Sums {
            ata: DMatrix::zeros(P, P),
            atr: DVector::zeros(P),
            meat: DMatrix::zeros(P, P),
            scores: DMatrix::zeros(if clustered { g } else { 0 }, P),
            grams: DMatrix::zeros(P, if gram_clusters { P * g } else { 0 }),
            rss: 0.0,
            n: self.n,
        };
        let rmat = *x.rot.matrix();
        for ((k, arc), &cl) in self.arcs.iter().zip(&clusters) {
            let f = &self.poses[*k as usize];
            let fr = *f.rotation.to_rotation_matrix().matrix();
            let s = Self::centre_in_sensor(x, f, c);
            let (dd, rrdd, dr, rr) = arc_sums(arc, &s, self.radius);
            sums.rss += rr;
            let mut a = nalgebra::SMatrix::<f64, 3, P>::zeros();
            a.fixed_view_mut::<3, 3>(0, 0).copy_from(&skew(&s));
            a.fixed_view_mut::<3, 3>(0, 3)
                .copy_from(&(-rmat.transpose()));
            a.fixed_view_mut::<3, 3>(0, 6)
                .copy_from(&(rmat.transpose() * fr.transpose()));
            let gram = a.transpose() * dd * a;
            let score = a.transpose() * dr;
            sums.ata += &gram;
            sums.meat += a.transpose() * rrdd * a;
            sums.atr += &score;
            if clustered {
                let cl = cl as usize;
                let mut row = sums.scores.row_mut(cl);
                row += score.transpose();
                if gram_clusters {
                    let mut block = sums.grams.columns_mut(P * cl, P);
                    block += &gram;
                }
            }
        }
        Some(sums)
    }

    fn step(&self, c: &Vector3<f64>, dx: &[f64]) -> Vector3<f64> {
        c + Vector3::new(dx[0], dx[1], dx[2])
    }

    fn centre(&self, c: &Vector3<f64>) -> Option<Point3<f64>> {
        Some(Point3::from(*c))
    }
}

impl BallModel {
    pub fn new(radius: f64) -> BallModel {
        BallModel {
            radius,
            poses: Vec::new(),
            arcs: Vec::new(),
            starts: Vec::new(),
            n: 0,
        }
    }

    /// Adds arc points seen from the flange pose `f`.
    pub fn add(&mut self, f: &Isometry3<f64>, points: impl IntoIterator<Item = Vector2<f64>>) {
        self.add_shared(f, points.into_iter().collect());
    }

    /// Adds an arc seen from the flange pose `f`, shared (not copied).
    pub fn add_shared(&mut self, f: &Isometry3<f64>, points: SharedPoints) {
        if points.is_empty() {
            return;
        }
        if self.poses.last() != Some(f) {
            self.poses.push(*f);
        }
        self.arcs.push(((self.poses.len() - 1) as u32, points));
        self.starts.push(self.n);
        self.n += self.arcs[self.arcs.len() - 1].1.len();
    }

    /// Each arc's cluster: arcs seen from one flange pose share a number (`honest::clusters`).
    fn arc_clusters(&self) -> Vec<u32> {
        super::honest::clusters(&self.arc_flanges(), self.arcs.len())
    }

    fn arc_flanges(&self) -> Vec<&Isometry3<f64>> {
        (self.arcs.iter())
            .map(|(k, _)| &self.poses[*k as usize])
            .collect()
    }

    /// The centre in the sensor frame: s = R^T (F_R^T (c - F_t) - t).
    fn centre_in_sensor(x: &Transform, f: &Isometry3<f64>, c: &Vector3<f64>) -> Vector3<f64> {
        let fr = *f.rotation.to_rotation_matrix().matrix();
        let g = fr.transpose() * (c - f.translation.vector);
        x.rot.matrix().transpose() * (g - x.t)
    }

    /// Rows 0.. of `r` (and `j`) for the points `part` (in the order added).
    fn rows(
        &self,
        x: &Transform,
        c: &Vector3<f64>,
        part: std::ops::Range<usize>,
        r: &mut DVector<f64>,
        mut j: Option<&mut DMatrix<f64>>,
    ) {
        let rmat = *x.rot.matrix();
        let first = self
            .starts
            .partition_point(|&s| s <= part.start)
            .saturating_sub(1);
        let mut i = 0;
        for ((k, arc), &start) in self.arcs[first..].iter().zip(&self.starts[first..]) {
            if start >= part.end {
                break;
            }
            let from = part.start.saturating_sub(start);
            let to = (part.end - start).min(arc.len());
            if from >= to {
                continue;
            }
            // An arc's points share their flange pose: its rotation matrix and the centre in
            // the sensor frame are computed once per arc.
            let f = &self.poses[*k as usize];
            let fr = *f.rotation.to_rotation_matrix().matrix();
            let s = Self::centre_in_sensor(x, f, c);
            for p in &arc[from..to] {
                self.row(i, p, (&rmat, &fr, &s), r, j.as_deref_mut());
                i += 1;
            }
        }
    }

    /// Row `i`: the point `p` seen from the pose of rotation `fr` with the centre at `s` in the
    /// sensor frame, the transform's rotation `rmat`.
    fn row(
        &self,
        i: usize,
        p: &Vector2<f64>,
        (rmat, fr, s): (&Matrix3<f64>, &Matrix3<f64>, &Vector3<f64>),
        r: &mut DVector<f64>,
        j: Option<&mut DMatrix<f64>>,
    ) {
        let (ri, dr_ds) = residual(self.radius, p, s);
        r[i] = ri;
        if let Some(j) = j {
            let dw = dr_ds.transpose() * skew(s);
            let u = dr_ds.transpose() * rmat.transpose();
            let dt = -u;
            let dc = u * fr.transpose();
            for k in 0..3 {
                j[(i, k)] = dw[k];
                j[(i, 3 + k)] = dt[k];
                j[(i, 6 + k)] = dc[k];
            }
        }
    }
}

/// The residual of the point `p` against the sphere centred at `s` (sensor frame), and its
/// gradient in `s`.
///
/// Where the sphere's normal at the point's column is at least `NZ_DEPTH` from the sensor's
/// plane, the residual is the z offset itself: the depth from the point to the sphere's surface
/// on its own side of the centre (the sign of the point's z against the centre's picks the
/// side, the point's own label: no branch needs stating). The normal distance over |n_z| is
/// that offset to first order only: its second-order term, s^2 (1 - n_z^2) / (2 R n_z) for z
/// noise s, made every point look outward, which moved the fit by about its own standard
/// deviation at 0.9 mm of noise and 200 arcs (Fig. 17's corner; 80.5 % covered there). Nearer
/// the silhouette, where the depth changes fast with the column, the normal distance over
/// |n_z| holds (issue 14), and from `NZ_BLEND` to `NZ_DEPTH` a smooth step joins the two.
fn residual(radius: f64, p: &Vector2<f64>, s: &Vector3<f64>) -> (f64, Vector3<f64>) {
    let v = Vector3::new(p.x, 0.0, p.y) - s;
    let q = radius * radius - v.x * v.x - s.y * s.y;
    let floor = NZ_BLEND * radius;
    if q <= floor * floor {
        return normal_residual(radius, &v);
    }
    // r = b (z - s_z) - h with h = sqrt(R^2 - (x - s_x)^2 - s_y^2), b the point's side;
    // dh / ds = (v_x, -s_y, 0) / h.
    let h = q.sqrt();
    let b = if v.z < 0.0 { -1.0 } else { 1.0 };
    let inv_h = 1.0 / h;
    let dh = Vector3::new(v.x * inv_h, -s.y * inv_h, 0.0);
    let depth = (b * v.z - h, Vector3::new(0.0, 0.0, -b) - dh);
    let t = (h / radius - NZ_BLEND) / (NZ_DEPTH - NZ_BLEND);
    if t >= 1.0 {
        return depth;
    }
    // Between the two, a smooth step (Perlin's, flat to its second derivative at both ends):
    // the residual, its gradient and their finite differences stay continuous as a point's
    // column crosses. (Both residuals everywhere without branches, for the SIMD lanes of
    // `arc_sums`, was no faster.)
    let (rn, dn) = normal_residual(radius, &v);
    let a = t * t * t * (10.0 + t * (6.0 * t - 15.0));
    let da = dh * (30.0 * t * t * (1.0 - t) * (1.0 - t) / (radius * (NZ_DEPTH - NZ_BLEND)));
    (
        a * depth.0 + (1.0 - a) * rn,
        depth.1 * a + dn * (1.0 - a) + da * (depth.0 - rn),
    )
}

/// The distance of the point `p - s = v` from the sphere along its normal over |n_z| (at least
/// `NZ_MIN`), and its gradient in `s`.
fn normal_residual(radius: f64, v: &Vector3<f64>) -> (f64, Vector3<f64>) {
    let dist = v.norm().max(1e-12);
    let g = dist - radius;
    // The noise is in z: a distance g along the normal is a z offset g / |n_z|, so divide
    // by |n_z| (the z residual's weight, to first order) but no more than 1 / NZ_MIN, which
    // keeps an arc's ends from dominating.
    // Two reciprocals rather than a dozen divisions (the arcs' sums are most of a ball
    // trial's verdict, and a vector unit divides slowly).
    let inv_dist = 1.0 / dist;
    let u = v * inv_dist;
    let nz = u.z.abs();
    let w = nz.max(NZ_MIN);
    let inv_w = 1.0 / w;
    // d g / d v = u; d w / d v = sign(v_z) (e_z - u_z u) / |v| above the floor; v = p - s,
    // so d r / d s = -(d g / d v / w - g d w / d v / w^2).
    let dw = if nz > NZ_MIN {
        (Vector3::z() - u * u.z) * (inv_dist * v.z.signum())
    } else {
        Vector3::zeros()
    };
    let r = g * inv_w;
    (r, -(u - dw * r) * inv_w)
}

/// An arc's sums at the centre `s` (sensor frame): d d^T, r^2 d d^T, d r and r^2, d the
/// residual's gradient in `s` (`BallModel::sums`).
#[multiversion::multiversion(targets("x86_64+avx512f", "x86_64+avx2"))]
fn arc_sums(
    arc: &[Vector2<f64>],
    s: &Vector3<f64>,
    radius: f64,
) -> (Matrix3<f64>, Matrix3<f64>, Vector3<f64>, f64) {
    // d d^T's six distinct entries, the same times r^2, d r, r^2.
    let t = crate::math::lane_sums(arc, |p| {
        let (r, d) = residual(radius, p, s);
        let rr = r * r;
        let outer = [
            d.x * d.x,
            d.x * d.y,
            d.x * d.z,
            d.y * d.y,
            d.y * d.z,
            d.z * d.z,
        ];
        let mut t = [0.0; 16];
        for k in 0..6 {
            t[k] = outer[k];
            t[6 + k] = outer[k] * rr;
        }
        t[12..15].copy_from_slice(&[d.x * r, d.y * r, d.z * r]);
        t[15] = rr;
        t
    });
    let sym = |o: usize| {
        let [xx, xy, xz, yy, yz, zz] = [t[o], t[o + 1], t[o + 2], t[o + 3], t[o + 4], t[o + 5]];
        Matrix3::new(xx, xy, xz, xy, yy, yz, xz, yz, zz)
    };
    (sym(0), sym(6), Vector3::new(t[12], t[13], t[14]), t[15])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Arcs seen from five poses, two of them again later (one cluster each), at a transform
    /// and centre off the points' own (non-zero residuals).
    fn model() -> (BallModel, Transform, Vector3<f64>) {
        let x = Transform {
            rot: nalgebra::Rotation3::from_euler_angles(3.0, -0.1, 2.0),
            t: Vector3::new(0.006, 0.054, 0.364),
        };
        let c = Vector3::new(-0.315, -0.304, 0.150);
        let mut m = BallModel::new(0.0695);
        for k in 0..7 {
            let f = Isometry3::new(
                Vector3::new(-0.3 + 0.01 * (k % 5) as f64, -0.3, 0.56),
                Vector3::new(3.08 + 0.02 * (k % 5) as f64, -0.25, -2.6),
            );
            let pts = (0..23 + 5 * k).map(|i| {
                let a = -1.0 + 2.0 * i as f64 / (22 + 5 * k) as f64;
                Vector2::new(
                    0.05 * a,
                    0.2 + 0.04 * (1.0 - a * a).sqrt() + 1e-4 * (i as f64).sin(),
                )
            });
            m.add(&f, pts);
        }
        let off = Transform {
            rot: x.rot * nalgebra::Rotation3::from_euler_angles(1e-3, -2e-3, 5e-4),
            t: x.t + Vector3::new(1e-4, -2e-4, 3e-4),
        };
        (m, off, c + Vector3::new(2e-4, 0.0, -1e-4))
    }

    /// At the true centre, a point's residual under z noise averages zero where the depth
    /// residual holds (the sphere's normal 0.5-0.95 from the laser's plane), while the normal
    /// distance over |n_z| averages s^2 (1 - n_z^2) / (2 R n_z) outward: 2 mm of noise on the
    /// 69.5 mm ball, 100,000 draws a column, the mean within 4 standard errors of zero and the
    /// former residual's mean within 4 of its bias (itself over 4 standard errors below 0.9).
    #[test]
    fn the_depth_residual_is_unbiased_under_z_noise() {
        let (radius, sigma): (f64, f64) = (0.0695, 2e-3);
        let s = Vector3::new(0.004, 0.01, 0.25);
        let rho = (radius * radius - s.y * s.y).sqrt();
        let mut g = crate::rng::stream(41, &[1]);
        for nz in [0.5, 0.6, 0.95] {
            // The column where the sphere's normal has this z, on the side facing the sensor.
            let h = nz * radius;
            let x = s.x + (rho * rho - h * h).sqrt();
            let n = 100_000;
            let (mut depth, mut normal) = (0.0, 0.0);
            for _ in 0..n {
                let p = Vector2::new(x, s.z - h + sigma * crate::rng::gauss(&mut g));
                depth += residual(radius, &p, &s).0;
                let v = Vector3::new(p.x, 0.0, p.y) - s;
                normal += (v.norm() - radius) / (v.z.abs() / v.norm());
            }
            let (depth, normal) = (depth / n as f64, normal / n as f64);
            let se = sigma / (n as f64).sqrt();
            // The depth residual's sign: positive toward the centre on the facing side.
            let bias = -sigma * sigma * (1.0 - nz * nz) / (2.0 * radius * nz);
            assert!(
                depth.abs() < 4.0 * se,
                "n_z {nz}: depth residual mean {depth:e}"
            );
            assert!(bias.abs() > 4.0 * se || nz > 0.9, "n_z {nz}: bias {bias:e}");
            assert!(
                (normal - bias).abs() < 4.0 * se,
                "n_z {nz}: normal residual mean {normal:e} against {bias:e}"
            );
        }
    }

    /// Exact arcs of a ball of radius 69.5 mm from 8 poses: the model, the true transform and
    /// centre, the radius.
    fn eight_poses() -> (BallModel, Isometry3<f64>, Vector3<f64>, f64) {
        ball_poses(8)
    }

    /// `eight_poses`' ring with `n` poses.
    fn ball_poses(n: usize) -> (BallModel, Isometry3<f64>, Vector3<f64>, f64) {
        let x = Isometry3::new(
            Vector3::new(0.006, 0.054, 0.364),
            Vector3::new(0.02, -0.01, 1.5),
        );
        let (c, radius) = (Vector3::new(-0.315, -0.304, 0.150), 0.0695);
        let mut m = BallModel::new(radius);
        for k in 0..n {
            let a = k as f64 * std::f64::consts::TAU / n as f64;
            // The sensor 0.2 m above the ball, looking down, its plane within 25 mm of the
            // centre; the flange where that puts it.
            let turn = nalgebra::UnitQuaternion::from_scaled_axis(Vector3::z() * 0.3 * a)
                * nalgebra::UnitQuaternion::from_scaled_axis(Vector3::new(
                    std::f64::consts::PI + 0.1 * a.sin(),
                    0.1 * a.cos(),
                    0.0,
                ));
            let sensor = Isometry3::from_parts(
                (c + Vector3::new(0.01 * a.cos(), 0.01 * a.sin(), 0.2)).into(),
                turn,
            );
            let f = sensor * x.inverse();
            // The laser plane (sensor y = 0) in the base frame: the ball's section there.
            let s = f * x;
            let d = c - s.translation.vector;
            let (ex, ey, ez) = (
                s.rotation * Vector3::x(),
                s.rotation * Vector3::y(),
                s.rotation * Vector3::z(),
            );
            let rho = (radius * radius - d.dot(&ey).powi(2)).sqrt();
            assert!(rho > 0.03, "pose {k}: the plane misses the ball ({rho})");
            let (cx, cz) = (d.dot(&ex), d.dot(&ez));
            m.add(
                &f,
                (0..40).map(|i| {
                    let t = std::f64::consts::PI * (1.2 + 0.6 * i as f64 / 39.0);
                    Vector2::new(cx + rho * t.cos(), cz - rho * t.sin().abs())
                }),
            );
        }
        (m, x, c, radius)
    }

    /// Exact arcs of a ball from 8 poses: refitted with the radius 2 um off, the result moves
    /// by `radius_shift` times 2 um (to 1 %), and not at all with the stated radius.
    #[test]
    fn the_radius_shift_is_the_refits_move() {
        use super::super::{Options, Problem, Refinable, refine};
        let (m, x, c, radius) = eight_poses();
        let opts = Options::default();
        let (at, _) = refine(&m, &x, &c, &opts).unwrap();
        let moved = (at.flange_to_sensor.translation.vector - x.translation.vector).norm();
        assert!(moved < 1e-9, "exact data: {moved}");
        let h = 2e-6;
        let (off, _) = refine(&m.with_radius(radius + h).unwrap(), &x, &c, &opts).unwrap();
        let seen_r = (x.rotation.inverse() * off.flange_to_sensor.rotation).scaled_axis();
        let seen_t = off.flange_to_sensor.translation.vector - x.translation.vector;
        let shift = Problem {
            model: m,
            specimen: c,
        }
        .radius_shift(&x)
        .unwrap()
            * h;
        for i in 0..3 {
            let scale = shift.fixed_rows::<3>(0).norm();
            assert!((seen_r[i] - shift[i]).abs() < 0.01 * scale, "rotation {i}");
            let scale = shift.fixed_rows::<3>(3).norm();
            assert!(
                (seen_t[i] - shift[3 + i]).abs() < 0.01 * scale,
                "translation {i}"
            );
        }
        assert!(shift.fixed_rows::<3>(3).norm() > 1e-7);
    }

    /// The same poses moved by two errors' twists (one the same at every pose, one growing
    /// with the pose's height and turn): refitted, the result moves by `pose_shift` times the
    /// error (to 1 %).
    #[test]
    fn the_pose_shift_is_the_refits_move() {
        use super::super::{Options, Problem, Refinable, refine};
        use nalgebra::Vector6;
        let (m, x, c, _) = eight_poses();
        let twists = |f: &Isometry3<f64>| {
            let a = f.rotation.scaled_axis();
            Some(vec![
                Vector6::new(0.0, 0.0, 0.0, 0.3, -0.2, 1.0),
                Vector6::new(0.4 * a.z, 0.1, -0.3, 5.0 * f.translation.z, 0.2 * a.x, -0.5),
            ])
        };
        let moved = Problem {
            model: m.clone(),
            specimen: c,
        }
        .pose_shift(&x, &twists, &[&twists], false)
        .unwrap();
        let shifts = moved.shifts;
        // The same twists as another configuration: the per-pose sums give the same moves.
        assert_eq!(moved.others.len(), 1);
        for (a, b) in moved.others[0].iter().zip(&shifts) {
            assert!((a - b).norm() <= 1e-9 * b.norm().max(1e-12), "{a} {b}");
        }
        let opts = Options::default();
        let h = 1e-5;
        for (e, shift) in shifts.iter().enumerate() {
            let moved = m.map_poses(&mut |f| {
                let t = twists(f).unwrap()[e] * h;
                f * Isometry3::new(
                    t.fixed_rows::<3>(3).into_owned(),
                    t.fixed_rows::<3>(0).into(),
                )
            });
            let (off, _) = refine(&moved, &x, &c, &opts).unwrap();
            let seen_r = (x.rotation.inverse() * off.flange_to_sensor.rotation).scaled_axis();
            let seen_t = off.flange_to_sensor.translation.vector - x.translation.vector;
            let want = shift * h;
            // A block can be exactly still (a translation alike at every pose turns nothing).
            let floor = 1e-4 * want.norm();
            let (sr, st) = (
                want.fixed_rows::<3>(0).norm().max(floor),
                want.fixed_rows::<3>(3).norm().max(floor),
            );
            assert!(
                want.fixed_rows::<3>(3).norm() > 1e-8,
                "error {e}: no shift {want}"
            );
            for i in 0..3 {
                assert!(
                    (seen_r[i] - want[i]).abs() < 0.01 * sr,
                    "error {e}, rotation {i}: {} vs {} (scale {sr})",
                    seen_r[i],
                    want[i]
                );
                assert!(
                    (seen_t[i] - want[3 + i]).abs() < 0.01 * st,
                    "error {e}, translation {i}"
                );
            }
        }
        // A pose the twists do not know: no answer rather than a wrong one.
        let none = Problem {
            model: m,
            specimen: c,
        }
        .pose_shift(&x, &|_| None, &[], false);
        assert!(none.is_none());
    }

    /// Each pose's step under an error's twists, from `pose_shift`'s sums over the six unit
    /// twists, is the clustering's from the residuals' own change (central differences at
    /// h = 1e-6; to 1e-5 of the largest step, the first error's to 1e-5 of the fit's move):
    /// with the leverage corrected (12 poses) and beyond `MAX_JACKKNIFE` (70, the CR1 steps).
    #[test]
    fn the_pose_shifts_steps_are_the_clusterings_of_the_residuals_change() {
        use super::super::{Normal, Problem, Refinable, ata, eval, honest::Clustering};
        use nalgebra::Vector6;
        let twists = |f: &Isometry3<f64>| {
            let a = f.rotation.scaled_axis();
            Some(vec![
                Vector6::new(0.0, 0.0, 0.0, 0.3, -0.2, 1.0),
                Vector6::new(0.4 * a.z, 0.1, -0.3, 5.0 * f.translation.z, 0.2 * a.x, -0.5),
            ])
        };
        for n in [12, 70] {
            let (m, x, c, _) = ball_poses(n);
            let moved = Problem {
                model: m.clone(),
                specimen: c,
            }
            .pose_shift(&x, &twists, &[], false)
            .unwrap();
            let t = Transform::from_isometry(&x);
            let labels = m.labels(&t, &c);
            let (_, j) = eval(&m, &t, &c, &labels, true);
            let a = ata(&j);
            let normal = Normal::of(&a);
            let inv = normal.inverse().unwrap();
            let clustering = Clustering::of(&j, m.clusters(), &a, inv, &normal.used).unwrap();
            assert_eq!(
                clustering.corrected,
                n <= super::super::honest::MAX_JACKKNIFE
            );
            let steps = moved
                .steps
                .as_ref()
                .expect("the poses measure every direction");
            assert_eq!(steps.len(), 2);
            let h = 1e-6;
            for (e, got) in steps.iter().enumerate() {
                let shifted = |h: f64| {
                    let moved = m.map_poses(&mut |f| {
                        let tw = twists(f).unwrap()[e] * h;
                        f * Isometry3::new(
                            tw.fixed_rows::<3>(3).into_owned(),
                            tw.fixed_rows::<3>(0).into(),
                        )
                    });
                    eval(&moved, &t, &c, &labels, false).0
                };
                let dr = (shifted(h) - shifted(-h)) / (2.0 * h);
                let jtg = j.tr_mul(&dr);
                let d = -(inv * DVector::from_fn(normal.used.len(), |i, _| jtg[normal.used[i]]));
                let want = clustering.steps(&j, &dr, &d).unwrap();
                assert_eq!(got.len(), n);
                // Scaled by the fit's move too: the first error, a translation alike at every
                // pose in its own frame, is the mounting's and moves no pose's step.
                let fit = Vector6::from_fn(|i, _| d[i]);
                let largest = want.iter().map(|s| s.norm()).fold(0.0, f64::max);
                let scale = if e == 0 {
                    largest.max(fit.norm())
                } else {
                    assert!(largest > 1e-3 * fit.norm(), "{n} poses: no step");
                    largest
                };
                for (g, w) in got.iter().zip(&want) {
                    assert!(
                        (g - w).norm() <= 1e-5 * scale,
                        "{n} poses, error {e}: {} of {scale}",
                        (g - w).norm()
                    );
                }
                // The fit's own move, from the same sums.
                assert!((moved.shifts[e] - fit).norm() <= 1e-5 * fit.norm());
            }
        }
    }

    #[test]
    fn per_arc_sums_equal_the_rows_sums() {
        let (m, x, c) = model();
        let clusters = m.clusters();
        let g = clusters.iter().map(|&k| k as usize + 1).max().unwrap();
        let fast = Model::sums(&m, &x, &c).unwrap();
        let (r, j) = super::super::eval(&m, &x, &c, &[], true);
        let rows = Sums::of(&r, &j, &clusters, g);
        assert!(g == 5 && fast.grams.ncols() == 9 * g);
        super::super::testing::same_sums(&fast, &rows);
    }
}
