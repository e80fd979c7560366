//! The straight edge's refinement model: edge points against the line.
//!
//! Specimen parameters: a point p on the line moved across it, p <- p + Q y e1 + Q z e2 (2), and the
//! direction d = Q x, Q <- Q exp([0, d2, d3]) (2). Residuals per edge point q: its offset from the
//! line across it, (Q y).(q - p) and (Q z).(q - p).

use super::{Model, Transform, exp, frame_with, transform_columns};
use nalgebra::{DMatrix, DVector, Isometry3, Point3, Rotation3, Vector2, Vector3};

#[derive(Debug, Clone, PartialEq)]
pub struct EdgeModel {
    /// Edge points (sensor x, z) with the flange pose each was seen from.
    pub points: Vec<(Isometry3<f64>, Vector2<f64>)>,
}

/// A point on the edge and its frame (direction = q x).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EdgeLine {
    pub point: Vector3<f64>,
    pub q: Rotation3<f64>,
}

impl EdgeLine {
    pub fn new(point: Point3<f64>, dir: &Vector3<f64>) -> EdgeLine {
        EdgeLine {
            point: point.coords,
            q: frame_with(dir, 0),
        }
    }

    pub fn direction(&self) -> Vector3<f64> {
        self.q * Vector3::x()
    }
}

impl Model for EdgeModel {
    type Specimen = EdgeLine;

    fn name(&self) -> &'static str {
        "edge refinement"
    }
    fn n_specimen_params(&self) -> usize {
        4
    }
    fn n_features(&self) -> usize {
        self.points.len()
    }
    fn residuals_per_feature(&self) -> usize {
        2
    }

    fn residual_flanges(&self) -> Vec<&Isometry3<f64>> {
        self.points.iter().flat_map(|(f, _)| [f, f]).collect()
    }

    fn map_poses(&self, to: &mut dyn FnMut(&Isometry3<f64>) -> Isometry3<f64>) -> EdgeModel {
        EdgeModel {
            points: super::moved(&self.points, to),
        }
    }

    fn without_poses(&self, drop: &dyn Fn(&Isometry3<f64>) -> bool) -> EdgeModel {
        EdgeModel {
            points: super::kept(&self.points, drop),
        }
    }

    fn eval(
        &self,
        x: &Transform,
        s: &EdgeLine,
        _labels: &[f64],
        r: &mut DVector<f64>,
        mut j: Option<&mut DMatrix<f64>>,
    ) {
        let d = s.q * Vector3::x();
        let (e1, e2) = (s.q * Vector3::y(), s.q * Vector3::z());
        for (i, (f, p)) in self.points.iter().enumerate() {
            let (qb, dq_dw, dq_dt) = x.point_in_base(f, p, j.is_some());
            let v = qb - s.point;
            let dv = d.dot(&v);
            r[2 * i] = e1.dot(&v);
            r[2 * i + 1] = e2.dot(&v);
            if let Some(j) = j.as_deref_mut() {
                for (k, e, dd) in [(2 * i, e1, [0.0, -dv]), (2 * i + 1, e2, [dv, 0.0])] {
                    transform_columns(j, k, &e, &dq_dw, &dq_dt);
                    j[(k, 6)] = if k % 2 == 0 { -1.0 } else { 0.0 };
                    j[(k, 7)] = if k % 2 == 0 { 0.0 } else { -1.0 };
                    j[(k, 8)] = dd[0];
                    j[(k, 9)] = dd[1];
                }
            }
        }
    }

    fn step(&self, s: &EdgeLine, dx: &[f64]) -> EdgeLine {
        EdgeLine {
            point: s.point + s.q * Vector3::new(0.0, dx[0], dx[1]),
            q: s.q * exp(&Vector3::new(0.0, dx[2], dx[3])),
        }
    }
}
