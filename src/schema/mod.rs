//! The scenario file's schema (TOML): robot, sensor and true mounting, specimen and its pose,
//! table, each method's data-collection section, noise, robot error, vibration, dynamics, cause
//! studies and the sweep grid, as the user writes them (lengths in mm, angles as named); the checks
//! of the shared sections (`Validator`, one helper family); cause studies; and the common rig and
//! scene in SI units. No method logic: `method` validates and plans its own section, `scenario`
//! reads files and builds the experiment.

pub mod ball;
mod causes;
mod checks;
mod common;
pub mod disk;
pub mod edge;
pub mod plane;
pub mod poses;
mod sections;
pub mod sensor;
pub mod validator;

pub use common::{Common, place_specimen};
pub use sections::*;
pub use validator::Validator;

use crate::id::{Estimator, Kind, MethodId};
use serde::Deserialize;
use thiserror::Error;

#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum ScenarioError {
    #[error("{file}: cannot read: {message}")]
    Io { file: String, message: String },
    #[error("{file}: {message}")]
    Syntax { file: String, message: String },
    #[error("{file}: {key} = {value}: {reason}")]
    BadValue {
        file: String,
        key: String,
        value: String,
        reason: String,
    },
}

fn d_seed() -> u64 {
    1
}
fn d_methods() -> Vec<MethodId> {
    vec![MethodId::new(Kind::Disk, Estimator::ClosedForm)]
}

#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    pub name: String,
    #[serde(default)]
    pub description: String,
    #[serde(default = "d_seed")]
    pub seed: u64,
    #[serde(default = "d_methods")]
    pub methods: Vec<MethodId>,
    pub robot: RobotSection,
    pub sensor: SensorSection,
    pub specimen: SpecimenSection,
    #[serde(default)]
    pub table: Option<TableSection>,
    // The methods' own sections (one line per specimen method).
    #[serde(default)]
    pub disk: Option<disk::Section>,
    #[serde(default)]
    pub ball: Option<ball::Section>,
    #[serde(default)]
    pub edge: Option<edge::Section>,
    #[serde(default)]
    pub plane: Option<plane::Section>,
    #[serde(default)]
    pub robot_error: Option<RobotErrorSection>,
    #[serde(default)]
    pub vibration: Option<VibrationSection>,
    #[serde(default)]
    pub dynamics: Option<DynamicsSection>,
    #[serde(default)]
    pub causes: Option<CausesSection>,
    #[serde(default)]
    pub sweep: Option<SweepSection>,
}

impl Scenario {
    /// The specimen methods the scenario's methods use, each once, in `Kind::ALL` order.
    pub fn kinds(&self) -> impl Iterator<Item = Kind> + '_ {
        Kind::ALL
            .into_iter()
            .filter(|k| self.methods.iter().any(|m| m.kind == *k))
    }
}
