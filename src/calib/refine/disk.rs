//! The disk's refinement model: chord ends against the disk's plane and rim.
//!
//! Specimen parameters: centre c (3) and normal n = Q z, Q <- Q exp([d1, d2, 0]) (2). Residuals per
//! chord end q: its distance from the plane n.(q - c), and from the rim |w| - r with
//! w = (q - c) - (n.(q - c)) n. Full profile (issue 14): every face point's distance from the
//! plane too (along the normal), after the chord ends.

use super::{Model, Transform, exp, frame_with, transform_columns};
use nalgebra::{DMatrix, DVector, Isometry3, Point3, Rotation3, Vector2, Vector3};

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
        2 * self.ends.len() + self.face.len() + self.rims.len()
    }

    fn eval(
        &self,
        x: &Transform,
        s: &DiskPose,
        _labels: &[f64],
        r: &mut DVector<f64>,
        mut j: Option<&mut DMatrix<f64>>,
    ) {
        let nrm = s.q * Vector3::z();
        let (dn1, dn2) = (-(s.q * Vector3::y()), s.q * Vector3::x());
        for (i, (f, p)) in self.ends.iter().enumerate() {
            let (qb, dq_dw, dq_dt) = x.point_in_base(f, p, j.is_some());
            let v = qb - s.centre;
            let h = nrm.dot(&v);
            let w = v - nrm * h;
            let wn = w.norm();
            r[2 * i] = h;
            r[2 * i + 1] = wn - self.radius;
            if let Some(j) = j.as_deref_mut() {
                let wh = if wn > 0.0 { w / wn } else { Vector3::zeros() };
                for (k, g, dd) in [
                    (2 * i, nrm, [v.dot(&dn1), v.dot(&dn2)]),
                    (2 * i + 1, wh, [-h * wh.dot(&dn1), -h * wh.dot(&dn2)]),
                ] {
                    transform_columns(j, k, &g, &dq_dw, &dq_dt);
                    for c in 0..3 {
                        j[(k, 6 + c)] = -g[c];
                    }
                    j[(k, 9)] = dd[0];
                    j[(k, 10)] = dd[1];
                }
            }
        }
        let base = 2 * self.ends.len();
        for (i, (f, p)) in self.face.iter().enumerate() {
            let k = base + i;
            let (qb, dq_dw, dq_dt) = x.point_in_base(f, p, j.is_some());
            let v = qb - s.centre;
            r[k] = nrm.dot(&v);
            if let Some(j) = j.as_deref_mut() {
                transform_columns(j, k, &nrm, &dq_dw, &dq_dt);
                for c in 0..3 {
                    j[(k, 6 + c)] = -nrm[c];
                }
                j[(k, 9)] = v.dot(&dn1);
                j[(k, 10)] = v.dot(&dn2);
            }
        }
        let base = base + self.face.len();
        let rim_of = |qb: &Vector3<f64>| {
            let v = qb - s.centre;
            let h = nrm.dot(&v);
            let w = v - nrm * h;
            (w.norm() - self.radius, h, w)
        };
        for (i, (f, a, b)) in self.rims.iter().enumerate() {
            let k = base + i;
            let ra = rim_of(&x.point_in_base(f, a, false).0).0;
            let rb = rim_of(&x.point_in_base(f, b, false).0).0;
            if ra * rb <= 0.0 {
                r[k] = 0.0;
                continue;
            }
            let p = if ra.abs() <= rb.abs() { a } else { b };
            let (qb, dq_dw, dq_dt) = x.point_in_base(f, p, j.is_some());
            let (res, h, w) = rim_of(&qb);
            r[k] = res;
            if let Some(j) = j.as_deref_mut() {
                let wn = w.norm();
                let wh = if wn > 0.0 { w / wn } else { Vector3::zeros() };
                transform_columns(j, k, &wh, &dq_dw, &dq_dt);
                for c in 0..3 {
                    j[(k, 6 + c)] = -wh[c];
                }
                j[(k, 9)] = -h * wh.dot(&dn1);
                j[(k, 10)] = -h * wh.dot(&dn2);
            }
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
