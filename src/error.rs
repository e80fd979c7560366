//! The crate's one error type. Each module keeps its own typed enum (`ScenarioError`,
//! `CalibError`, `FeatureError`, ...) whose variants carry the offending values; `Error` gathers
//! them with their sources, so the binary and the per-trial CSV column see one type. Messages name
//! the file, field and value and say how to fix it.

use crate::calib::CalibError;
use crate::captures::CaptureError;
use crate::features::FeatureError;
use crate::robot::RobotError;
use crate::schema::ScenarioError;
use crate::sensor::SensorError;
use crate::sim::PlanError;
use crate::sim::dynamics::DynamicsError;
use std::path::PathBuf;
use std::sync::Arc;
use thiserror::Error;

#[derive(Debug, Error, Clone)]
#[non_exhaustive]
pub enum Error {
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    #[error(transparent)]
    Calib(#[from] CalibError),
    #[error(transparent)]
    Feature(#[from] FeatureError),
    #[error(transparent)]
    Captures(#[from] CaptureError),
    #[error(transparent)]
    Robot(#[from] RobotError),
    #[error(transparent)]
    Plan(#[from] PlanError),
    #[error(transparent)]
    Sensor(#[from] SensorError),
    #[error(transparent)]
    Dynamics(#[from] DynamicsError),
    #[error(transparent)]
    Format(#[from] FormatError),
    /// A trial asked for a method the scenario does not plan.
    #[error("the scenario has no {method} plan")]
    NoPlan { method: crate::id::Kind },
    /// A file could not be read or written.
    #[error("{}: cannot {action}: {source}", path.display())]
    Io {
        path: PathBuf,
        action: &'static str,
        #[source]
        source: Arc<std::io::Error>,
    },
}

/// Errors compare by value; an I/O error by its path, action and kind.
impl PartialEq for Error {
    fn eq(&self, other: &Error) -> bool {
        use Error::*;
        match (self, other) {
            (Scenario(a), Scenario(b)) => a == b,
            (Calib(a), Calib(b)) => a == b,
            (Feature(a), Feature(b)) => a == b,
            (Captures(a), Captures(b)) => a == b,
            (Robot(a), Robot(b)) => a == b,
            (Plan(a), Plan(b)) => a == b,
            (Sensor(a), Sensor(b)) => a == b,
            (Dynamics(a), Dynamics(b)) => a == b,
            (Format(a), Format(b)) => a == b,
            (NoPlan { method: a }, NoPlan { method: b }) => a == b,
            (
                Io {
                    path: p1,
                    action: a1,
                    source: s1,
                },
                Io {
                    path: p2,
                    action: a2,
                    source: s2,
                },
            ) => p1 == p2 && a1 == a2 && s1.kind() == s2.kind(),
            _ => false,
        }
    }
}

impl Error {
    /// An I/O error on `path` while doing `action` ("create", "write", "read", ...).
    pub fn io(path: impl Into<PathBuf>, action: &'static str, source: std::io::Error) -> Error {
        Error::Io {
            path: path.into(),
            action,
            source: Arc::new(source),
        }
    }
}

/// A file in one of lasercal's formats (capture file, trials.csv, sweep record) that does not say
/// what it must, or an output that cannot be rendered.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum FormatError {
    /// A record or field that is wrong: `at` names it (`profiles[3].tcp_position_mm`, `line 7`).
    #[error("{file}: {at}: {message}")]
    Field {
        file: String,
        at: String,
        message: String,
    },
    /// The file does not parse at all.
    #[error("{file}: not a valid {what}: {message}")]
    Invalid {
        file: String,
        what: &'static str,
        message: String,
    },
    /// A plot or recording that could not be made.
    #[error("{what}: {message}")]
    Render { what: String, message: String },
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
