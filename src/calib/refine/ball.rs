//! The ball's refinement model: arc points against the sphere.
//!
//! Specimen parameters: the centre c (3). Residual per arc point: its z minus the sphere's z at its
//! x in the laser plane (the sensor's noise is in z), on the side of the sphere the point was on
//! at the start.

use super::{Model, Transform, skew};
use nalgebra::{DMatrix, DVector, Isometry3, Point3, Vector2, Vector3};

#[derive(Debug, Clone, PartialEq)]
pub struct BallModel {
    pub radius: f64,
    /// Arc points (sensor x, z) with the flange pose each was seen from.
    pub points: Vec<(Isometry3<f64>, Vector2<f64>)>,
}

impl BallModel {
    /// The centre in the sensor frame: s = R^T (F_R^T (c - F_t) - t).
    fn centre_in_sensor(x: &Transform, f: &Isometry3<f64>, c: &Vector3<f64>) -> Vector3<f64> {
        let fr = *f.rotation.to_rotation_matrix().matrix();
        let g = fr.transpose() * (c - f.translation.vector);
        x.rot.matrix().transpose() * (g - x.t)
    }
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
        self.points.len()
    }
    fn residuals_per_feature(&self) -> usize {
        1
    }

    fn labels(&self, x: &Transform, c: &Vector3<f64>) -> Vec<f64> {
        self.points
            .iter()
            .map(|(f, p)| {
                let s = x.rot.inverse() * (f.rotation.inverse() * (c - f.translation.vector) - x.t);
                if p.y >= s.z { 1.0 } else { -1.0 }
            })
            .collect()
    }

    fn eval(
        &self,
        x: &Transform,
        c: &Vector3<f64>,
        branch: &[f64],
        r: &mut DVector<f64>,
        mut j: Option<&mut DMatrix<f64>>,
    ) {
        let rmat = *x.rot.matrix();
        let radius = self.radius;
        for (i, (f, p)) in self.points.iter().enumerate() {
            let fr = *f.rotation.to_rotation_matrix().matrix();
            let s = Self::centre_in_sensor(x, f, c);
            let d = radius * radius - s.y * s.y - (p.x - s.x).powi(2);
            let sd = d.max(1e-12).sqrt();
            let b = branch.get(i).copied().unwrap_or(1.0);
            r[i] = p.y - (s.z + b * sd);
            if let Some(j) = j.as_deref_mut() {
                let dr_ds = Vector3::new(-b * (p.x - s.x) / sd, b * s.y / sd, -1.0);
                let dw = dr_ds.transpose() * skew(&s);
                let dt = -(dr_ds.transpose() * rmat.transpose());
                let dc = dr_ds.transpose() * rmat.transpose() * fr.transpose();
                for k in 0..3 {
                    j[(i, k)] = dw[k];
                    j[(i, 3 + k)] = dt[k];
                    j[(i, 6 + k)] = dc[k];
                }
            }
        }
    }

    fn step(&self, c: &Vector3<f64>, dx: &[f64]) -> Vector3<f64> {
        c + Vector3::new(dx[0], dx[1], dx[2])
    }

    fn centre(&self, c: &Vector3<f64>) -> Option<Point3<f64>> {
        Some(Point3::from(*c))
    }
}
