//! Building the experiment a scenario describes: the common rig and scene (`schema::Common`), the
//! disturbances, and each method's plan. Values become SI here, once.

use super::{DynamicsSection, Scenario, ScenarioError, Validator};
use crate::error::Error;
use crate::method::{Kind, Plan, method};
use crate::scene::{Scene, Specimen};
use crate::sim::Rig;
use crate::sim::disturb::{RobotError, Vibration};
use nalgebra::Isometry3;
use std::sync::Arc;

/// The experiment a scenario describes, built once and shared by its trials.
#[derive(Debug, Clone)]
pub struct Setup {
    pub rig: Rig,
    pub scene: Scene,
    pub specimen: Specimen,
    pub base_to_specimen: Isometry3<f64>,
    /// The plan of each specimen method the scenario uses.
    pub plans: Vec<(Kind, Arc<dyn Plan>)>,
    pub robot_error: RobotError,
    pub vibration: Vibration,
    pub dynamics: Option<DynamicsSection>,
    /// Largest slide of the specimen per trial along base x and y (m; `[placement]`).
    pub placement_jitter: f64,
}

impl Setup {
    /// The plan of a specimen method.
    pub fn plan(&self, kind: Kind) -> Result<&dyn Plan, Error> {
        self.plans
            .iter()
            .find(|(k, _)| *k == kind)
            .map(|(_, p)| p.as_ref())
            .ok_or(Error::NoPlan { method: kind })
    }
}

impl Scenario {
    /// Build the rig, scene and every method's plan (checking reachability). The scenario is
    /// taken as validated (`ScenarioFile` validates every grid point once).
    pub fn build(&self, file: &str) -> Result<Setup, ScenarioError> {
        if self.causes.is_some() {
            return self.resolved(file)?.build(file);
        }
        let v = Validator { file };
        let common = self.common(file)?;
        let plans = self
            .kinds()
            .map(|k| Ok((k, Arc::from(method(k).plan(self, &common, &v)?))))
            .collect::<Result<Vec<_>, ScenarioError>>()?;
        let re = self.robot_error.clone().unwrap_or_default();
        let robot_error = RobotError {
            repeatability: re.repeatability_mm * 1e-3,
            joint_noise: re.joint_noise_deg.to_radians(),
            link_error: re.link_error_mm * 1e-3,
            joint_offset_error: re.joint_offset_error_deg.to_radians(),
        };
        let vibration = self
            .vibration
            .as_ref()
            .map(|vib| Vibration {
                amplitude_rms: vib.amplitude_mm * 1e-3,
                band_low_hz: vib.band_low_hz,
                band_high_hz: vib.band_high_hz,
                profile_rate_hz: vib.profile_rate_hz,
            })
            .unwrap_or_default();
        Ok(Setup {
            rig: common.rig,
            scene: common.scene,
            specimen: common.specimen,
            base_to_specimen: common.base_to_specimen,
            plans,
            robot_error,
            vibration,
            dynamics: self.dynamics.clone(),
            placement_jitter: self.placement.as_ref().map_or(0.0, |p| p.jitter_mm * 1e-3),
        })
    }
}
