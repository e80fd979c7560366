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

    fn bow_rows(
        &self,
        x: &Transform,
        s: &EdgeLine,
        length: Option<f64>,
    ) -> Option<[DVector<f64>; 2]> {
        // The bow pv (1/2 - 4 u^2 / L^2) (u from the edge's middle, `scene::form`) less its
        // affine part, which the line's parameters take: -4 pv (u - mean)^2 / L^2 about the
        // points' mean, whatever the middle.
        let d = s.q * Vector3::x();
        let along: Vec<f64> = self
            .points
            .iter()
            .map(|(f, p)| d.dot(&(x.point_in_base(f, p, false).0 - s.point)))
            .collect();
        let n = along.len() as f64;
        let mean = along.iter().sum::<f64>() / n;
        let (lo, hi) = along
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &u| {
                (a.min(u), b.max(u))
            });
        let span = length.unwrap_or(hi - lo);
        if !(span > 0.0 && span.is_finite()) {
            return None;
        }
        let w = |u: f64| -4.0 * (u - mean).powi(2) / (span * span);
        let mut across = [
            DVector::zeros(2 * along.len()),
            DVector::zeros(2 * along.len()),
        ];
        for (i, &u) in along.iter().enumerate() {
            across[0][2 * i] = w(u);
            across[1][2 * i + 1] = w(u);
        }
        Some(across)
    }

    fn step(&self, s: &EdgeLine, dx: &[f64]) -> EdgeLine {
        EdgeLine {
            point: s.point + s.q * Vector3::new(0.0, dx[0], dx[1]),
            q: s.q * exp(&Vector3::new(0.0, dx[2], dx[3])),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::refine::{Options, Problem, Refinable, refine};
    use nalgebra::UnitQuaternion;

    /// Exact points of an edge 0.3 m long bowed by 10 um toward each direction across it, seen
    /// from 30 tilted poses along its middle 0.24 m: refitted, the result moves by `bow_shift`
    /// times 10 um (to 2 %), and not at all without the bow.
    #[test]
    fn the_bow_shift_is_the_refits_move() {
        let x = Isometry3::new(
            Vector3::new(0.042, -0.018, 0.160),
            Vector3::new(0.01, -0.02, 1.54),
        );
        let (length, pv) = (0.3, 1e-5);
        let line = EdgeLine::new(
            Point3::new(1.05, 0.15, 0.30),
            &Vector3::new(0.866, 0.5, 0.0),
        );
        let d = line.direction();
        // Straight down at the edge, y along it, tilted per pose; the edge seen at varied
        // depths (at one depth a turn about the sensor's x and a move along its y look alike).
        let down = Rotation3::from_basis_unchecked(&[d.cross(&-Vector3::z()), d, -Vector3::z()]);
        let poses: Vec<Isometry3<f64>> = (0..30)
            .map(|k| {
                let a = k as f64 * 2.399;
                let tilt = UnitQuaternion::from_scaled_axis(Vector3::new(
                    0.5 * a.cos(),
                    0.35 * a.sin(),
                    0.6 * (0.7 * a).sin(),
                ));
                let turn = UnitQuaternion::from_rotation_matrix(&down) * tilt;
                let u = 0.12 * (1.3 * a).sin();
                let at = line.point + u * d;
                let sensor = Isometry3::from_parts(
                    (at - turn * Vector3::new(0.01 * a.cos(), 0.0, 0.2 + 0.03 * (0.9 * a).sin()))
                        .into(),
                    turn,
                );
                sensor * x.inverse()
            })
            .collect();
        // Each pose's point on the edge bowed by pv (1/2 - 4 u^2 / L^2) toward `across`.
        let points = |across: Vector3<f64>| -> Vec<(Isometry3<f64>, Vector2<f64>)> {
            poses
                .iter()
                .map(|f| {
                    let s = f * x;
                    let n = s.rotation * Vector3::y();
                    let curve = |u: f64| {
                        line.point + u * d + pv * (0.5 - 4.0 * u * u / (length * length)) * across
                    };
                    let mut u = n.dot(&(s.translation.vector - line.point)) / n.dot(&d);
                    for _ in 0..8 {
                        let slope = n.dot(&(d - pv * 8.0 * u / (length * length) * across));
                        u -= n.dot(&(curve(u) - s.translation.vector)) / slope;
                    }
                    let p = s.inverse_transform_point(&Point3::from(curve(u)));
                    assert!(p.y.abs() < 1e-12 && u.abs() < 0.14, "{p} {u}");
                    (*f, Vector2::new(p.x, p.z))
                })
                .collect()
        };
        let opts = Options::default();
        let straight = EdgeModel {
            points: points(Vector3::zeros()),
        };
        let (at, _) = refine(&straight, &x, &line, &opts).unwrap();
        let moved = (at.flange_to_sensor.translation.vector - x.translation.vector).norm();
        assert!(moved < 1e-9, "exact data: {moved}");
        let shifts = Problem {
            model: straight,
            specimen: line,
        }
        .bow_shift(&x, Some(length))
        .unwrap();
        for (k, across) in [line.q * Vector3::y(), line.q * Vector3::z()]
            .into_iter()
            .enumerate()
        {
            let bowed = EdgeModel {
                points: points(across),
            };
            let (off, _) = refine(&bowed, &x, &line, &opts).unwrap();
            let seen_r = (x.rotation.inverse() * off.flange_to_sensor.rotation).scaled_axis();
            let seen_t = off.flange_to_sensor.translation.vector - x.translation.vector;
            let shift = shifts[k] * pv;
            let (sr, st) = (
                shift.fixed_rows::<3>(0).norm(),
                shift.fixed_rows::<3>(3).norm(),
            );
            assert!(st > 1e-7 && sr > 1e-7, "direction {k}: {shift}");
            for i in 0..3 {
                assert!(
                    (seen_r[i] - shift[i]).abs() < 0.02 * sr,
                    "{k}: rotation {i}"
                );
                assert!(
                    (seen_t[i] - shift[3 + i]).abs() < 0.02 * st,
                    "{k}: translation {i}"
                );
            }
        }
    }
}
