//! The disk's refinement model: chord ends against the disk's plane and rim.
//!
//! Specimen parameters: centre c (3) and normal n = Q z, Q <- Q exp([d1, d2, 0]) (2). Residuals per
//! chord end q: its distance from the plane n.(q - c), and from the rim |w| - r with
//! w = (q - c) - (n.(q - c)) n. Full profile (issue 14): every face point's distance from the
//! plane too (along the normal), after the chord ends, and every point of the cylinder's wall seen
//! below the rim: its distance from the wall, |w| - r (along the wall's normal). Ends and wall
//! points may carry weights (residual and Jacobian row scaled): their spread differs from the
//! face points'.

use super::{Model, Transform, exp, frame_with, transform_columns};
use nalgebra::{DMatrix, DVector, Isometry3, Matrix3, Point3, Rotation3, Vector2, Vector3};

#[derive(Debug, Clone, PartialEq)]
pub struct DiskModel {
    pub radius: f64,
    /// Chord ends (sensor x, z) with the flange pose each was seen from.
    pub ends: Vec<(Isometry3<f64>, Vector2<f64>)>,
    /// Points of the disk's face (full profile; empty for the chord-end refinement).
    pub face: Vec<(Isometry3<f64>, Vector2<f64>)>,
    /// Where the rim lies on a face's line, between two points (any-pose; empty otherwise): no
    /// residual while the rim passes between them, else the nearer one's distance from the rim
    /// (censored, as `refine::bar`'s edges).
    pub rims: Vec<(Isometry3<f64>, Vector2<f64>, Vector2<f64>)>,
    /// Each end's weight on its distance from the rim (empty: all 1).
    pub end_weights: Vec<f64>,
    /// Points of the cylinder's wall (a disk on a cylinder of its radius; full profile), each
    /// with its weight.
    pub walls: Vec<(Isometry3<f64>, Vector2<f64>, f64)>,
}

/// The disk's centre and orientation (normal = q z).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiskPose {
    pub centre: Vector3<f64>,
    pub q: Rotation3<f64>,
}

impl DiskPose {
    pub fn new(centre: Point3<f64>, normal: &Vector3<f64>) -> DiskPose {
        DiskPose {
            centre: centre.coords,
            q: frame_with(normal, 2),
        }
    }

    pub fn normal(&self) -> Vector3<f64> {
        self.q * Vector3::z()
    }
}

/// A base-frame point with its derivatives (`Transform::point_in_base`).
type Seen = (Vector3<f64>, Matrix3<f64>, Matrix3<f64>);

/// The disk's plane and axis at the current estimate, with the normal's derivatives.
struct Geometry {
    centre: Vector3<f64>,
    n: Vector3<f64>,
    dn: [Vector3<f64>; 2],
}

impl Geometry {
    fn of(s: &DiskPose) -> Geometry {
        Geometry {
            centre: s.centre,
            n: s.q * Vector3::z(),
            dn: [-(s.q * Vector3::y()), s.q * Vector3::x()],
        }
    }

    /// Height above the plane and the in-plane offset from the axis.
    fn split(&self, q: &Vector3<f64>) -> (Vector3<f64>, f64, Vector3<f64>) {
        let v = q - self.centre;
        let h = self.n.dot(&v);
        (v, h, v - self.n * h)
    }

    /// Distance from the axis less the radius.
    fn past_rim(&self, radius: f64, q: &Vector3<f64>) -> f64 {
        self.split(q).2.norm() - radius
    }

    /// Row k: the point's distance from the plane.
    fn plane_row(&self, r: &mut DVector<f64>, j: Option<&mut DMatrix<f64>>, k: usize, p: &Seen) {
        let (v, h, _) = self.split(&p.0);
        r[k] = h;
        if let Some(j) = j {
            transform_columns(j, k, &self.n, &p.1, &p.2);
            for c in 0..3 {
                j[(k, 6 + c)] = -self.n[c];
            }
            j[(k, 9)] = v.dot(&self.dn[0]);
            j[(k, 10)] = v.dot(&self.dn[1]);
        }
    }

    /// Row k: the point's distance from the axis less the radius, times `weight`.
    fn rim_row(
        &self,
        radius: f64,
        r: &mut DVector<f64>,
        j: Option<&mut DMatrix<f64>>,
        k: usize,
        p: &Seen,
        weight: f64,
    ) {
        let (_, h, w) = self.split(&p.0);
        let wn = w.norm();
        r[k] = weight * (wn - radius);
        if let Some(j) = j {
            let g = if wn > 0.0 {
                (w / wn) * weight
            } else {
                Vector3::zeros()
            };
            transform_columns(j, k, &g, &p.1, &p.2);
            for c in 0..3 {
                j[(k, 6 + c)] = -g[c];
            }
            j[(k, 9)] = -h * g.dot(&self.dn[0]);
            j[(k, 10)] = -h * g.dot(&self.dn[1]);
        }
    }
}

impl Model for DiskModel {
    type Specimen = DiskPose;

    fn name(&self) -> &'static str {
        "disk refinement"
    }
    fn n_specimen_params(&self) -> usize {
        5
    }
    fn n_features(&self) -> usize {
        self.ends.len()
    }
    fn residuals_per_feature(&self) -> usize {
        2
    }
    fn n_residuals(&self) -> usize {
        2 * self.ends.len() + self.face.len() + self.rims.len() + self.walls.len()
    }

    fn residual_flanges(&self) -> Vec<&Isometry3<f64>> {
        let ends = self.ends.iter().flat_map(|(f, _)| [f, f]);
        let face = self.face.iter().map(|(f, _)| f);
        let rims = self.rims.iter().map(|(f, _, _)| f);
        let walls = self.walls.iter().map(|(f, _, _)| f);
        ends.chain(face).chain(rims).chain(walls).collect()
    }

    fn map_poses(&self, to: &mut dyn FnMut(&Isometry3<f64>) -> Isometry3<f64>) -> DiskModel {
        DiskModel {
            radius: self.radius,
            ends: self.ends.iter().map(|(f, p)| (to(f), *p)).collect(),
            end_weights: self.end_weights.clone(),
            face: self.face.iter().map(|(f, p)| (to(f), *p)).collect(),
            rims: self.rims.iter().map(|(f, a, b)| (to(f), *a, *b)).collect(),
            walls: self.walls.iter().map(|(f, p, w)| (to(f), *p, *w)).collect(),
        }
    }

    fn map_poses_into(
        &self,
        to: &mut dyn FnMut(&Isometry3<f64>) -> Isometry3<f64>,
        into: &mut DiskModel,
    ) {
        let same = into.ends.len() == self.ends.len()
            && into.face.len() == self.face.len()
            && into.rims.len() == self.rims.len()
            && into.walls.len() == self.walls.len();
        if !same {
            *into = self.map_poses(to);
            return;
        }
        for (o, (f, _)) in into.ends.iter_mut().zip(&self.ends) {
            o.0 = to(f);
        }
        for (o, (f, _)) in into.face.iter_mut().zip(&self.face) {
            o.0 = to(f);
        }
        for (o, (f, _, _)) in into.rims.iter_mut().zip(&self.rims) {
            o.0 = to(f);
        }
        for (o, (f, _, _)) in into.walls.iter_mut().zip(&self.walls) {
            o.0 = to(f);
        }
    }

    fn without_poses(&self, drop: &dyn Fn(&Isometry3<f64>) -> bool) -> DiskModel {
        let kept_ends: Vec<usize> = (0..self.ends.len())
            .filter(|&i| !drop(&self.ends[i].0))
            .collect();
        DiskModel {
            radius: self.radius,
            ends: kept_ends.iter().map(|&i| self.ends[i]).collect(),
            end_weights: if self.end_weights.is_empty() {
                Vec::new()
            } else {
                kept_ends.iter().map(|&i| self.end_weights[i]).collect()
            },
            face: self
                .face
                .iter()
                .filter(|(f, _)| !drop(f))
                .copied()
                .collect(),
            rims: self
                .rims
                .iter()
                .filter(|(f, _, _)| !drop(f))
                .copied()
                .collect(),
            walls: self
                .walls
                .iter()
                .filter(|(f, _, _)| !drop(f))
                .copied()
                .collect(),
        }
    }

    fn eval(
        &self,
        x: &Transform,
        s: &DiskPose,
        _labels: &[f64],
        r: &mut DVector<f64>,
        mut j: Option<&mut DMatrix<f64>>,
    ) {
        let mut seer = x.seer();
        let disk = Geometry::of(s);
        for (i, (f, p)) in self.ends.iter().enumerate() {
            let weight = self.end_weights.get(i).copied().unwrap_or(1.0);
            let point = seer.point(f, p, j.is_some());
            disk.plane_row(r, j.as_deref_mut(), 2 * i, &point);
            disk.rim_row(self.radius, r, j.as_deref_mut(), 2 * i + 1, &point, weight);
        }
        let base = 2 * self.ends.len();
        for (i, (f, p)) in self.face.iter().enumerate() {
            let point = seer.point(f, p, j.is_some());
            disk.plane_row(r, j.as_deref_mut(), base + i, &point);
        }
        let base = base + self.face.len();
        for (i, (f, a, b)) in self.rims.iter().enumerate() {
            let k = base + i;
            let ra = disk.past_rim(self.radius, &seer.point(f, a, false).0);
            let rb = disk.past_rim(self.radius, &seer.point(f, b, false).0);
            if ra * rb <= 0.0 {
                r[k] = 0.0;
                continue;
            }
            let p = if ra.abs() <= rb.abs() { a } else { b };
            let point = seer.point(f, p, j.is_some());
            disk.rim_row(self.radius, r, j.as_deref_mut(), k, &point, 1.0);
        }
        let base = base + self.rims.len();
        for (i, (f, p, weight)) in self.walls.iter().enumerate() {
            let point = seer.point(f, p, j.is_some());
            disk.rim_row(self.radius, r, j.as_deref_mut(), base + i, &point, *weight);
        }
    }

    fn step(&self, s: &DiskPose, dx: &[f64]) -> DiskPose {
        DiskPose {
            centre: s.centre + Vector3::new(dx[0], dx[1], dx[2]),
            q: s.q * exp(&Vector3::new(dx[3], dx[4], 0.0)),
        }
    }

    fn centre(&self, s: &DiskPose) -> Option<Point3<f64>> {
        Some(Point3::from(s.centre))
    }
}
