//! Two faces' refinement model: a ridge's, a V groove's or a step's two planes, every profile point
//! against the face it lies on. The line where the faces meet is theirs.
//!
//! Specimen parameters per face k (2 x 3): its frame Q_k (normal n_k = Q_k z), Q_k <- Q_k exp([a,
//! b, 0]), and its offset d_k along n_k. Residual per point q (base frame) on face k: n_k.q - d_k.

use super::plane::Plane;
use super::{Model, Transform, exp};
use nalgebra::{DMatrix, DVector, Isometry3, Vector2, Vector3};

#[derive(Debug, Clone, PartialEq)]
pub struct FacesModel {
    /// Profile points (sensor x, z), the flange pose each was seen from and its face (0 or 1).
    pub points: Vec<(Isometry3<f64>, Vector2<f64>, usize)>,
}

impl Model for FacesModel {
    type Specimen = [Plane; 2];

    fn name(&self) -> &'static str {
        "two faces' refinement"
    }
    fn n_specimen_params(&self) -> usize {
        6
    }
    fn n_features(&self) -> usize {
        self.points.len()
    }
    fn residuals_per_feature(&self) -> usize {
        1
    }

    fn residual_flanges(&self) -> Vec<&Isometry3<f64>> {
        self.points.iter().map(|(f, _, _)| f).collect()
    }

    fn map_poses(&self, to: &mut dyn FnMut(&Isometry3<f64>) -> Isometry3<f64>) -> FacesModel {
        FacesModel {
            points: self
                .points
                .iter()
                .map(|(f, p, k)| (to(f), *p, *k))
                .collect(),
        }
    }

    fn without_poses(&self, drop: &dyn Fn(&Isometry3<f64>) -> bool) -> FacesModel {
        FacesModel {
            points: self
                .points
                .iter()
                .filter(|(f, _, _)| !drop(f))
                .copied()
                .collect(),
        }
    }

    fn eval(
        &self,
        x: &Transform,
        s: &[Plane; 2],
        _labels: &[f64],
        r: &mut DVector<f64>,
        mut j: Option<&mut DMatrix<f64>>,
    ) {
        let mut seer = x.seer();
        let n = s.map(|p| p.normal());
        let e = s.map(|p| (p.frame * Vector3::x(), p.frame * Vector3::y()));
        for (i, (f, p, k)) in self.points.iter().enumerate() {
            let (qb, dq_dw, dq_dt) = seer.point(f, p, j.is_some());
            // Along the depth (`AlongDepth`): the distance across biased the faces' fit.
            let a = n[*k].dot(&qb) - s[*k].offset;
            let depth = seer.along_depth(f, &n[*k], j.is_some());
            r[i] = a * depth.scale;
            if let Some(j) = j.as_deref_mut() {
                depth.transform_columns(j, i, &n[*k], &dq_dw, &dq_dt, a);
                // As `refine::plane`: dn/da = -Q y, dn/db = Q x; the other face's columns 0.
                let c = 6 + 3 * k;
                j[(i, c)] = depth.column(-e[*k].1.dot(&qb), a, &-e[*k].1);
                j[(i, c + 1)] = depth.column(e[*k].0.dot(&qb), a, &e[*k].0);
                j[(i, c + 2)] = -depth.scale;
                let o = 6 + 3 * (1 - k);
                for c in o..o + 3 {
                    j[(i, c)] = 0.0;
                }
            }
        }
    }

    fn step(&self, s: &[Plane; 2], dx: &[f64]) -> [Plane; 2] {
        [0, 1].map(|k| Plane {
            frame: s[k].frame * exp(&Vector3::new(dx[3 * k], dx[3 * k + 1], 0.0)),
            offset: s[k].offset + dx[3 * k + 2],
        })
    }
}
