//! The shared sections' checks.

use super::{Scenario, ScenarioError, Validator};
use nalgebra::Matrix3;

impl Scenario {
    /// Check the shared sections' values that deserialisation cannot (the methods check their
    /// own sections: `scenario`'s `Scenario::validate` runs both).
    pub fn validate_common(&self, v: &Validator) -> Result<(), ScenarioError> {
        if self.methods.is_empty() {
            return Err(v.bad("methods", "[]", "name at least one method"));
        }
        self.validate_sensor(v)?;
        self.specimen_kind(v)?;
        if let Some(t) = &self.table {
            v.probability_like("table.reflectance", t.reflectance, "must be in 0..1")?;
        }
        self.validate_disturbances(v)?;
        self.validate_sweep(v)
    }

    fn validate_sensor(&self, v: &Validator) -> Result<(), ScenarioError> {
        self.sensor_geometry(v)?;
        v.one_of(
            (
                "sensor.mount_rotation",
                self.sensor.mount_rotation.is_some(),
            ),
            ("sensor.mount_rpy_deg", self.sensor.mount_rpy_deg.is_some()),
            "the true mounting rotation",
        )?;
        if let Some(m) = &self.sensor.mount_rotation {
            let r = Matrix3::from_fn(|i, j| m[i][j]);
            let dev = (r.transpose() * r - Matrix3::identity()).norm();
            if !dev.is_finite() || dev > 0.05 || r.determinant() <= 0.0 {
                return Err(v.bad(
                    "sensor.mount_rotation",
                    format!("{m:?}"),
                    "not close to a rotation matrix (rows must be orthonormal, determinant +1)",
                ));
            }
        }
        let n = &self.sensor.noise;
        for (k, x) in [
            ("z_sigma_near_mm", n.z_sigma_near_mm),
            ("z_sigma_far_mm", n.z_sigma_far_mm),
            ("x_sigma_mm", n.x_sigma_mm),
            ("outlier_amplitude_mm", n.outlier_amplitude_mm),
            ("dark_noise_factor", n.dark_noise_factor),
        ] {
            v.non_negative(&format!("sensor.noise.{k}"), x)?;
        }
        for (k, x) in [
            ("dropout", n.dropout),
            ("outlier_rate", n.outlier_rate),
            ("dark_threshold", n.dark_threshold),
            ("dark_dropout", n.dark_dropout),
        ] {
            v.probability_like(
                &format!("sensor.noise.{k}"),
                x,
                "must be a probability in 0..1",
            )?;
        }
        Ok(())
    }

    fn validate_disturbances(&self, v: &Validator) -> Result<(), ScenarioError> {
        if let Some(p) = &self.placement {
            v.non_negative("placement.jitter_mm", p.jitter_mm)?;
            // A slide of a few columns changes the phase; one of centimetres moves the specimen
            // out of the plan's views.
            if p.jitter_mm > 20.0 {
                return Err(v.bad(
                    "placement.jitter_mm",
                    p.jitter_mm,
                    "at most 20 mm: the plan's poses are laid out for the specimen where it stands; \
                     move it with specimen.position_mm instead",
                ));
            }
        }
        if let Some(r) = &self.robot_error {
            for (k, x) in [
                ("repeatability_mm", r.repeatability_mm),
                ("joint_noise_deg", r.joint_noise_deg),
                ("link_error_mm", r.link_error_mm),
                ("joint_offset_error_deg", r.joint_offset_error_deg),
            ] {
                v.non_negative(&format!("robot_error.{k}"), x)?;
            }
        }
        if let Some(d) = &self.dynamics {
            v.non_negative("dynamics.settle_ms", d.settle_ms)?;
            if !(d.stiffness > 0.0 && d.damping >= 0.0) {
                return Err(v.bad(
                    "dynamics.stiffness",
                    d.stiffness,
                    "give stiffness > 0 and damping >= 0",
                ));
            }
            if !(d.speed_fraction > 0.0 && d.speed_fraction <= 1.0) {
                return Err(v.bad(
                    "dynamics.speed_fraction",
                    d.speed_fraction,
                    "must be in (0, 1]",
                ));
            }
            if !(d.dt_ms > 0.0 && d.dt_ms <= 10.0) {
                return Err(v.bad("dynamics.dt_ms", d.dt_ms, "must be in (0, 10]"));
            }
        }
        if let Some(vib) = &self.vibration {
            v.non_negative("vibration.amplitude_mm", vib.amplitude_mm)?;
            if !(vib.band_low_hz > 0.0 && vib.band_high_hz >= vib.band_low_hz) {
                return Err(v.bad(
                    "vibration.band_high_hz",
                    vib.band_high_hz,
                    "give 0 < band_low_hz <= band_high_hz",
                ));
            }
            if !(vib.profile_rate_hz > 0.0) {
                return Err(v.bad(
                    "vibration.profile_rate_hz",
                    vib.profile_rate_hz,
                    "must be > 0",
                ));
            }
        }
        Ok(())
    }

    fn validate_sweep(&self, v: &Validator) -> Result<(), ScenarioError> {
        let Some(s) = &self.sweep else {
            return Ok(());
        };
        if s.trials == 0 || s.trials > super::validator::MAX_TRIALS {
            return Err(v.bad(
                "sweep.trials",
                s.trials,
                format!("from 1 to {} trials", super::validator::MAX_TRIALS),
            ));
        }
        if let Some(p) = &s.plot {
            for k in std::iter::once(&p.x).chain(p.series.iter()) {
                if !s.grid.contains_key(k) {
                    return Err(v.bad("sweep.plot", format!("\"{k}\""), "not a key of sweep.grid"));
                }
            }
            // The x axis is a number line: a key that takes names would plot nothing.
            let numeric = |x: &toml::Value| x.is_integer() || x.is_float();
            if let Some(toml::Value::Array(values)) = s.grid.get(&p.x)
                && !values.iter().all(numeric)
            {
                return Err(v.bad(
                    "sweep.plot.x",
                    format!("\"{}\"", p.x),
                    "takes names, not numbers: put a numeric key on x and this one in series (or \
                     leave [sweep.plot] out and read summary.csv)",
                ));
            }
        }
        Ok(())
    }
}
