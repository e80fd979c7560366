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
    /// The scenario's name (the default output folder is out/NAME).
    pub name: String,
    /// One line saying what the scenario studies.
    #[serde(default)]
    pub description: String,
    /// The seed every random draw derives from.
    #[serde(default = "d_seed")]
    pub seed: u64,
    /// The methods to run, e.g. disk, ball-refined, edge-any-pose.
    #[serde(default = "d_methods")]
    pub methods: Vec<MethodId>,
    /// The robot ([robot]).
    pub robot: RobotSection,
    /// The sensor and its true mounting ([sensor]).
    pub sensor: SensorSection,
    /// The specimen and where it stands ([specimen]).
    pub specimen: SpecimenSection,
    /// The table under the specimen ([table]).
    #[serde(default)]
    pub table: Option<TableSection>,
    // The methods' own sections (one line per specimen method).
    /// The disk method's data collection ([disk]).
    #[serde(default)]
    pub disk: Option<disk::Section>,
    /// The ball method's data collection ([ball]).
    #[serde(default)]
    pub ball: Option<ball::Section>,
    /// The edge method's data collection ([edge]).
    #[serde(default)]
    pub edge: Option<edge::Section>,
    /// The plane method's data collection ([plane]).
    #[serde(default)]
    pub plane: Option<plane::Section>,
    /// The robot's pose error ([robot_error]).
    #[serde(default)]
    pub robot_error: Option<RobotErrorSection>,
    /// The arm's vibration ([vibration]).
    #[serde(default)]
    pub vibration: Option<VibrationSection>,
    /// The arm's dynamics ([dynamics]).
    #[serde(default)]
    pub dynamics: Option<DynamicsSection>,
    /// The specimen placed anew each trial ([placement]).
    #[serde(default)]
    pub placement: Option<PlacementSection>,
    /// Which physical causes of error to keep, and their scale ([causes]).
    #[serde(default)]
    pub causes: Option<CausesSection>,
    /// The sweep: trials, grid and plot ([sweep]).
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
