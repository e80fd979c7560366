//! Calibration methods as typed values. A method is a specimen method (`Kind`: disk, ball, edge)
//! plus an estimator variant (the paper's closed form, or the joint refinement). Each specimen
//! method is one module implementing `Method`: its scenario section and validation, its plan and
//! simulation, its features from captures, its closed-form solve and refinement model. The generic
//! code (trial runner, capture calibrator, sweeps, Rerun, `scan`) drives them through the trait;
//! `method()` below is the one place that dispatches over them.

pub mod ball;
pub mod disk;
pub mod edge;

use crate::calib::refine::Refined;
use crate::captures::{Calibration, Captures};
use crate::error::Error;
use crate::scenario::{Scenario, ScenarioError, Validator};
use crate::scene::Scene;
use crate::sensor::SensorModel;
use crate::sim::Rig;
use nalgebra::{Isometry3, Point3};
use std::fmt;
use std::str::FromStr;

/// A specimen method: what is calibrated against.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Kind {
    /// Planar disk of arbitrary orientation (Chen et al. 2018).
    Disk,
    /// Ball two-step method (Chen et al. 2018, Sec. IV-A).
    Ball,
    /// Straight edge (Xu et al.).
    Edge,
}

impl Kind {
    pub const ALL: [Kind; 3] = [Kind::Disk, Kind::Ball, Kind::Edge];

    pub fn name(self) -> &'static str {
        match self {
            Kind::Disk => "disk",
            Kind::Ball => "ball",
            Kind::Edge => "edge",
        }
    }
}

impl fmt::Display for Kind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Kind {
    type Err = UnknownMethod;
    fn from_str(s: &str) -> Result<Kind, UnknownMethod> {
        Kind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| UnknownMethod {
                name: s.to_string(),
                known: Kind::ALL.map(Kind::name).join(", "),
            })
    }
}

/// How the transform is estimated from a specimen method's captures.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Estimator {
    /// The paper's closed form, as published.
    ClosedForm,
    /// Joint Levenberg-Marquardt refinement of the closed form over every raw feature.
    Refined,
}

impl Estimator {
    pub const ALL: [Estimator; 2] = [Estimator::ClosedForm, Estimator::Refined];

    fn suffix(self) -> &'static str {
        match self {
            Estimator::ClosedForm => "",
            Estimator::Refined => "-refined",
        }
    }
}

/// A method as named in scenarios, CSV files and on the command line: `disk`, `disk-refined`, ...
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct MethodId {
    pub kind: Kind,
    pub estimator: Estimator,
}

impl MethodId {
    pub const fn new(kind: Kind, estimator: Estimator) -> MethodId {
        MethodId { kind, estimator }
    }

    /// Every method, specimen by specimen.
    pub fn all() -> impl Iterator<Item = MethodId> {
        Kind::ALL
            .into_iter()
            .flat_map(|k| Estimator::ALL.map(move |e| MethodId::new(k, e)))
    }
}

impl fmt::Display for MethodId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}{}", self.kind.name(), self.estimator.suffix())
    }
}

/// A method name that names no method.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("unknown method \"{name}\"; known: {known}")]
pub struct UnknownMethod {
    pub name: String,
    pub known: String,
}

impl FromStr for MethodId {
    type Err = UnknownMethod;
    fn from_str(s: &str) -> Result<MethodId, UnknownMethod> {
        MethodId::all()
            .find(|m| m.to_string() == s)
            .ok_or_else(|| UnknownMethod {
                name: s.to_string(),
                known: MethodId::all()
                    .map(|m| m.to_string())
                    .collect::<Vec<_>>()
                    .join(", "),
            })
    }
}

impl serde::Serialize for MethodId {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

impl<'de> serde::Deserialize<'de> for MethodId {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<MethodId, D::Error> {
        let s = String::deserialize(d)?;
        s.parse().map_err(serde::de::Error::custom)
    }
}

impl serde::Serialize for Kind {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

impl<'de> serde::Deserialize<'de> for Kind {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Kind, D::Error> {
        let s = String::deserialize(d)?;
        s.parse().map_err(serde::de::Error::custom)
    }
}

/// What a specimen method's simulation draws from: the trial's streams and the disturbed robot.
pub struct Sim<'a> {
    /// Sensor and feature noise.
    pub rng: &'a mut crate::rng::Rng,
    /// The robot that really moves (pose error, vibration, dynamics).
    pub disturbance: &'a mut crate::sim::disturb::Disturbance,
    /// The specimen's imperfection.
    pub specimen_rng: &'a mut crate::rng::Rng,
    /// The true radius's draw, in standard deviations (taken first from `specimen_rng`).
    pub radius_z: f64,
}

/// One specimen method: what the generic code needs of it.
pub trait Method: Sync {
    fn kind(&self) -> Kind;

    /// Check the method's scenario section (called when a scenario uses the method).
    fn validate(&self, sc: &Scenario, v: &Validator) -> Result<(), ScenarioError>;

    /// Plan the method's data collection on the scenario's rig, checking reachability (once per
    /// grid point).
    fn plan(
        &self,
        sc: &Scenario,
        common: &crate::scenario::Common,
        v: &Validator,
    ) -> Result<Box<dyn Plan>, ScenarioError>;

    /// Extract the features from the captures and solve in closed form (the paper's method).
    fn calibrate(&self, caps: &Captures, sensor: &SensorModel) -> Result<Calibration, Error>;

    /// Scale the method's own sensor noise and specimen imperfection (cause studies).
    fn scale_causes(&self, sc: &mut Scenario, sensor: f64, specimen: f64);

    /// Whether a capture file must give the specimen's radius.
    fn needs_radius(&self) -> bool;

    /// Whether a capture file's groups carry the sign s_i (+1 or -1).
    fn uses_group_signs(&self) -> bool;
}

/// A specimen method's plan on one rig: shared by every trial of a grid point.
pub trait Plan: Send + Sync + fmt::Debug {
    /// The concrete plan (for tools and tests that need the method's own data).
    fn as_any(&self) -> &dyn std::any::Any;

    /// The scene the method's captures see (its own specimen, the table).
    fn scene(&self) -> &Scene;

    /// A flange pose in the middle of the first planned scan (`lasercal scan`'s default).
    fn first_flange_pose(&self) -> Isometry3<f64>;

    /// The captures of one trial (features for the analytic sources, profiles for ray-cast ones).
    fn simulate(&self, rig: &Rig, sim: &mut Sim) -> Result<Captures, Error>;

    /// The true specimen centre, for the centre error (disk and ball).
    fn true_centre(&self) -> Option<Point3<f64>>;

    /// Figures that need the truth beyond the transform (the edge paper's Table 3 ball radius),
    /// drawn from `validation_seed`'s stream.
    fn truth_checks(
        &self,
        rig: &Rig,
        estimate: &Isometry3<f64>,
        validation_seed: u64,
    ) -> crate::metrics::Metrics;
}

/// The one dispatch over the specimen methods.
pub fn method(kind: Kind) -> &'static dyn Method {
    match kind {
        Kind::Disk => &disk::Disk,
        Kind::Ball => &ball::Ball,
        Kind::Edge => &edge::Edge,
    }
}

/// Run an estimator on captures: the closed form, then (for `Refined`) the joint refinement from
/// it, whose estimate and specimen centre replace the closed form's.
pub fn estimate(
    id: MethodId,
    caps: &Captures,
    sensor: &SensorModel,
) -> Result<(Calibration, Option<Refined>), Error> {
    let mut cal = method(id.kind).calibrate(caps, sensor)?;
    match id.estimator {
        Estimator::ClosedForm => Ok((cal, None)),
        Estimator::Refined => {
            let r = cal.refine(&Default::default())?;
            cal.flange_to_sensor = r.flange_to_sensor;
            cal.status = r.status;
            if let Some(c) = r.centre {
                cal.centre_in_base = Some(c.coords);
            }
            Ok((cal, Some(r)))
        }
    }
}
