//! Cause studies (`[causes]`): the scenario with one configured cause of error kept (or all, or
//! none) and scaled.

use super::{Cause, Scenario, ScenarioError, Validator};

impl Scenario {
    /// The scenario with its `[causes]` applied: the causes not kept switched off, the kept ones
    /// scaled; no `[causes]` section leaves it as it is.
    pub fn resolved(&self, file: &str) -> Result<Scenario, ScenarioError> {
        let mut s = self.clone();
        let Some(c) = s.causes.take() else {
            return Ok(s);
        };
        Validator { file }.non_negative("causes.scale", c.scale)?;
        let k = |cause: Cause| {
            if c.only == Cause::All || c.only == cause {
                c.scale
            } else {
                0.0
            }
        };
        let ks = k(Cause::Sensor);
        let kspec = k(Cause::Specimen);
        let n = &mut s.sensor.noise;
        for v in [
            &mut n.z_sigma_near_mm,
            &mut n.z_sigma_far_mm,
            &mut n.x_sigma_mm,
            &mut n.outlier_amplitude_mm,
        ] {
            *v *= ks;
        }
        // Each method section's own noise and specimen.
        if let Some(d) = &mut s.disk {
            d.scale_causes(ks, kspec);
        }
        if let Some(b) = &mut s.ball {
            b.scale_causes(ks, kspec);
        }
        if let Some(e) = &mut s.edge {
            e.scale_causes(ks, kspec);
        }
        s.specimen.scale_imperfection(kspec);
        if let Some(r) = &mut s.robot_error {
            r.repeatability_mm *= k(Cause::Repeatability);
            r.joint_noise_deg *= k(Cause::Encoder);
            r.link_error_mm *= k(Cause::Kinematic);
            r.joint_offset_error_deg *= k(Cause::Kinematic);
        }
        if let Some(v) = &mut s.vibration {
            v.amplitude_mm *= k(Cause::Vibration);
        }
        Ok(s)
    }
}
