//! Checks that deserialisation cannot make: one helper family (`Validator`) whose errors name the
//! file, the key, the value and the fix, and the checks of the common sections. Each method checks
//! its own section (`Method::validate`).

use super::{Scenario, ScenarioError};
use crate::method::method;
use crate::sensor::SensorModel;
use nalgebra::Matrix3;
use std::fmt::Display;

/// Makes `ScenarioError::BadValue`s for one file.
#[derive(Debug, Clone, Copy)]
pub struct Validator<'a> {
    pub file: &'a str,
}

impl Validator<'_> {
    pub fn bad(&self, key: &str, value: impl Display, reason: impl Into<String>) -> ScenarioError {
        ScenarioError::BadValue {
            file: self.file.into(),
            key: key.into(),
            value: value.to_string(),
            reason: reason.into(),
        }
    }

    /// A finite number >= 0.
    pub fn non_negative(&self, key: &str, v: f64) -> Result<(), ScenarioError> {
        if v >= 0.0 && v.is_finite() {
            Ok(())
        } else {
            Err(self.bad(key, v, "must be a finite number >= 0"))
        }
    }

    /// A positive finite length in mm; returns it in metres.
    pub fn length(&self, key: &str, mm: f64) -> Result<f64, ScenarioError> {
        if mm > 0.0 && mm.is_finite() {
            Ok(mm * 1e-3)
        } else {
            Err(self.bad(key, mm, "must be a positive length"))
        }
    }

    /// A value in [0, 1].
    pub fn probability_like(&self, key: &str, v: f64, reason: &str) -> Result<(), ScenarioError> {
        if (0.0..=1.0).contains(&v) {
            Ok(())
        } else {
            Err(self.bad(key, v, reason))
        }
    }

    /// A value in the open interval (lo, hi).
    pub fn open_interval(&self, key: &str, v: f64, lo: f64, hi: f64) -> Result<(), ScenarioError> {
        if v > lo && v < hi {
            Ok(())
        } else {
            Err(self.bad(key, v, format!("must be in ({lo}, {hi})")))
        }
    }

    /// A count of at least `min`.
    pub fn at_least(
        &self,
        key: &str,
        n: usize,
        min: usize,
        reason: &str,
    ) -> Result<(), ScenarioError> {
        if n >= min {
            Ok(())
        } else {
            Err(self.bad(key, n, reason))
        }
    }

    /// Exactly one of two alternative keys given (`what` says what they give).
    pub fn one_of(
        &self,
        a: (&str, bool),
        b: (&str, bool),
        what: &str,
    ) -> Result<(), ScenarioError> {
        let short = |k: &str| k.rsplit('.').next().unwrap_or(k).to_string();
        let (sa, sb) = (short(a.0), short(b.0));
        match (a.1, b.1) {
            (true, true) => Err(self.bad(b.0, "..", format!("give {sa} or {sb}, not both"))),
            (false, false) => {
                Err(self.bad(a.0, "(missing)", format!("give {what} as {sa} or {sb}")))
            }
            _ => Ok(()),
        }
    }
}

impl Scenario {
    /// Check values that deserialisation cannot: the common sections here, each method's own
    /// section by the method.
    pub fn validate(&self, file: &str) -> Result<(), ScenarioError> {
        if self.causes.is_some() {
            return self.resolved(file)?.validate(file);
        }
        let v = Validator { file };
        if self.methods.is_empty() {
            return Err(v.bad("methods", "[]", "name at least one method"));
        }
        self.validate_sensor(&v)?;
        self.specimen_kind(&v)?;
        if let Some(t) = &self.table {
            v.probability_like("table.reflectance", t.reflectance, "must be in 0..1")?;
        }
        for kind in self.kinds() {
            method(kind).validate(self, &v)?;
        }
        self.validate_disturbances(&v)?;
        self.validate_sweep(&v)
    }

    fn validate_sensor(&self, v: &Validator) -> Result<(), ScenarioError> {
        SensorModel::preset(&self.sensor.preset).map_err(|e| {
            v.bad(
                "sensor.preset",
                format!("\"{}\"", self.sensor.preset),
                e.to_string(),
            )
        })?;
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
        if s.trials == 0 {
            return Err(v.bad("sweep.trials", 0, "at least one trial"));
        }
        if let Some(p) = &s.plot {
            for k in std::iter::once(&p.x).chain(p.series.iter()) {
                if !s.grid.contains_key(k) {
                    return Err(v.bad("sweep.plot", format!("\"{k}\""), "not a key of sweep.grid"));
                }
            }
        }
        Ok(())
    }
}
