//! Scenario files (TOML): robot, sensor and true mounting, specimen and its pose, data-collection
//! plans, noise, methods, sweep grid, trials and seed. Unknown keys and bad values are errors that
//! name the file, the key and the value.
//!
//! `schema` holds the shared sections (each method's own section lives in its `method` module),
//! `grid` the sweep's points, `validate` the checks, `causes` the cause studies, `build` the rig,
//! scene and plans.

mod build;
mod causes;
mod grid;
mod schema;
mod validate;

pub use build::{Common, Setup, place_specimen};
pub use grid::GridPoint;
pub use schema::*;
pub use validate::Validator;

use crate::method::{Kind, MethodId};
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
    vec![MethodId::new(
        Kind::Disk,
        crate::method::Estimator::ClosedForm,
    )]
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
    pub disk: Option<crate::method::disk::Section>,
    #[serde(default)]
    pub ball: Option<crate::method::ball::Section>,
    #[serde(default)]
    pub edge: Option<crate::method::edge::Section>,
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

/// A scenario file: the parsed scenario, its raw table (for grid overrides) and its grid points,
/// each deserialised and validated once.
#[derive(Debug, Clone)]
pub struct ScenarioFile {
    pub file: String,
    pub raw: toml::Table,
    pub scenario: Scenario,
    points: Vec<GridPoint>,
}

impl ScenarioFile {
    /// Read and validate a scenario file (every grid point too).
    pub fn load(path: &std::path::Path) -> Result<ScenarioFile, ScenarioError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| ScenarioError::Io {
            file: file.clone(),
            message: e.to_string(),
        })?;
        ScenarioFile::from_text(&text, &file, path.parent())
    }

    /// Parse scenario text; `file` names it in errors.
    pub fn parse(text: &str, file: &str) -> Result<ScenarioFile, ScenarioError> {
        ScenarioFile::from_text(text, file, None)
    }

    /// A relative URDF path is resolved against `dir` (the scenario's folder).
    fn from_text(
        text: &str,
        file: &str,
        dir: Option<&std::path::Path>,
    ) -> Result<ScenarioFile, ScenarioError> {
        let syntax = |e: toml::de::Error| ScenarioError::Syntax {
            file: file.to_string(),
            message: e.to_string().trim().to_string(),
        };
        let mut raw: toml::Table = text.parse().map_err(syntax)?;
        // The key path (`causes.only`) in front of the parser's line, column and expectation.
        let de = toml::de::Deserializer::parse(text).map_err(syntax)?;
        let mut scenario: Scenario =
            serde_path_to_error::deserialize(de).map_err(|e| ScenarioError::Syntax {
                file: file.to_string(),
                message: format!("{}: {}", e.path(), e.inner().to_string().trim()),
            })?;
        let r = &scenario.robot.name;
        if r.ends_with(".urdf")
            && !std::path::Path::new(r).is_absolute()
            && let Some(dir) = dir
        {
            let p = dir.join(r).display().to_string();
            scenario.robot.name = p.clone();
            if let Some(toml::Value::Table(t)) = raw.get_mut("robot") {
                t.insert("name".into(), toml::Value::String(p));
            }
        }
        let mut sf = ScenarioFile {
            file: file.to_string(),
            raw,
            scenario,
            points: Vec::new(),
        };
        sf.scenario.validate(file)?;
        sf.points = sf.make_grid()?;
        if sf.scenario.sweep.is_some() {
            for p in &sf.points {
                p.scenario.validate(file)?;
            }
        }
        Ok(sf)
    }

    /// The sweep grid's points (one point, the base scenario, when there is no sweep), validated.
    pub fn grid(&self) -> &[GridPoint] {
        &self.points
    }
}
