//! Names of the methods: the vocabulary scenarios, capture files, CSV rows and the command line
//! share. What each method does lives in `method`.

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
    /// A flat plate or the table face, from any poses (beyond both papers).
    Plane,
}

impl Kind {
    pub const ALL: [Kind; 4] = [Kind::Disk, Kind::Ball, Kind::Edge, Kind::Plane];

    /// The estimators this specimen has (the any-pose estimator only where one is written).
    pub fn estimators(self) -> &'static [Estimator] {
        match self {
            Kind::Ball => &[
                Estimator::ClosedForm,
                Estimator::Refined,
                Estimator::AnyPose,
            ],
            Kind::Disk => &[
                Estimator::ClosedForm,
                Estimator::Refined,
                Estimator::FullProfile,
                Estimator::AnyPose,
            ],
            Kind::Edge => &[
                Estimator::ClosedForm,
                Estimator::Refined,
                Estimator::FullProfile,
                Estimator::AnyPose,
            ],
            // No paper closed form: the any-pose estimator is the plane's method.
            Kind::Plane => &[Estimator::AnyPose],
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Kind::Disk => "disk",
            Kind::Ball => "ball",
            Kind::Edge => "edge",
            Kind::Plane => "plane",
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
    /// From any poses that see the specimen: no groups, no protocol, no labels, no start.
    AnyPose,
    /// The joint refinement over every profile point on the specimen's surfaces, not only the
    /// features.
    FullProfile,
}

impl Estimator {
    pub const ALL: [Estimator; 4] = [
        Estimator::ClosedForm,
        Estimator::Refined,
        Estimator::AnyPose,
        Estimator::FullProfile,
    ];

    fn suffix(self) -> &'static str {
        match self {
            Estimator::ClosedForm => "",
            Estimator::Refined => "-refined",
            Estimator::AnyPose => "-any-pose",
            Estimator::FullProfile => "-full",
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
            .flat_map(|k| k.estimators().iter().map(move |&e| MethodId::new(k, e)))
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
