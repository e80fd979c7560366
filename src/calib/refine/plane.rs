//! The plane's refinement model: every profile point against the plane.
//!
//! Specimen parameters: the plane's frame Q (normal n = Q z), Q <- Q exp([a, b, 0]) (2), and its
//! offset d along n (1). Residual per point q (base frame): its signed distance n.q - d, which is
//! along the surface normal.

use super::{Model, Transform, exp, frame_with, transform_columns};
use nalgebra::{DMatrix, DVector, Isometry3, Rotation3, Vector2, Vector3};

#[derive(Debug, Clone, PartialEq)]
pub struct PlaneModel {
    /// Profile points (sensor x, z) on the plane, with the flange pose each was seen from.
    pub points: Vec<(Isometry3<f64>, Vector2<f64>)>,
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
            points: self.points.iter().map(|(f, p)| (to(f), *p)).collect(),
        }
    }

    fn without_poses(&self, drop: &dyn Fn(&Isometry3<f64>) -> bool) -> PlaneModel {
        PlaneModel {
            points: self
                .points
                .iter()
                .filter(|(f, _)| !drop(f))
                .copied()
                .collect(),
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
            r[i] = n.dot(&qb) - s.offset;
            if let Some(j) = j.as_deref_mut() {
                transform_columns(j, i, &n, &dq_dw, &dq_dt);
                // n(a, b) = Q exp([a, b, 0]) z: dn/da = -Q y, dn/db = Q x.
                j[(i, 6)] = -e2.dot(&qb);
                j[(i, 7)] = e1.dot(&qb);
                j[(i, 8)] = -1.0;
            }
        }
    }

    fn step(&self, s: &Plane, dx: &[f64]) -> Plane {
        Plane {
            frame: s.frame * exp(&Vector3::new(dx[0], dx[1], 0.0)),
            offset: s.offset + dx[2],
        }
    }
}
