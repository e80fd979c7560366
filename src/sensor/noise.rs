//! Sensor noise: every model off by default, every draw from the caller's seeded stream.

use super::{ProfilePoint, SensorModel};
use crate::rng::gauss;
use nalgebra::Point3;
use rand::RngExt;

/// Noise of a triangulation profiler (metres, probabilities 0..1).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct NoiseModel {
    /// Gaussian z noise standard deviation at the near end of the range...
    pub z_sigma_near: f64,
    /// ...and at the far end (linear in depth between them).
    pub z_sigma_far: f64,
    /// Gaussian x jitter standard deviation.
    pub x_sigma: f64,
    /// Probability that a point is dropped.
    pub dropout: f64,
    /// Probability that a point on a specular surface is an outlier...
    pub outlier_rate: f64,
    /// ...displaced along z uniformly within +- this amplitude.
    pub outlier_amplitude: f64,
    /// Below this intensity a surface is dark: its noise is multiplied by `dark_noise_factor` and its
    /// dropout raised by `dark_dropout`.
    pub dark_threshold: f64,
    pub dark_noise_factor: f64,
    pub dark_dropout: f64,
}

impl NoiseModel {
    /// True when no model is switched on.
    pub fn is_off(&self) -> bool {
        *self == NoiseModel::default()
    }

    /// z standard deviation at a depth (linear between the ends of the range).
    pub fn z_sigma_at(&self, sensor: &SensorModel, depth: f64) -> f64 {
        let span = sensor.depth_far - sensor.depth_near;
        let f = if span > 0.0 {
            ((depth - sensor.depth_near) / span).clamp(0.0, 1.0)
        } else {
            0.0
        };
        self.z_sigma_near + f * (self.z_sigma_far - self.z_sigma_near)
    }

    /// Apply the noise to one exact point; None when it drops out.
    pub(crate) fn apply(
        &self,
        sensor: &SensorModel,
        p: Point3<f64>,
        intensity: f64,
        specular: bool,
        r: &mut crate::rng::Rng,
    ) -> Option<ProfilePoint> {
        // A fixed number of draws per point keeps streams aligned whatever the outcome.
        let (u_drop, u_out, u_amp): (f64, f64, f64) = (r.random(), r.random(), r.random());
        let (gz, gx) = (gauss(r), gauss(r));
        let dark = intensity < self.dark_threshold;
        let dropout = self.dropout + if dark { self.dark_dropout } else { 0.0 };
        if u_drop < dropout {
            return None;
        }
        let factor = if dark && self.dark_noise_factor > 0.0 {
            self.dark_noise_factor
        } else {
            1.0
        };
        let mut z = p.z + gz * self.z_sigma_at(sensor, sensor.depth(&p)) * factor;
        let x = p.x + gx * self.x_sigma * factor;
        if specular && u_out < self.outlier_rate {
            z += (2.0 * u_amp - 1.0) * self.outlier_amplitude;
        }
        Some(ProfilePoint { x, z, intensity })
    }
}
