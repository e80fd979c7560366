//! `[ball]`: the ball two-step method's data collection (Chen et al. 2018, Sec. IV-A, V-D), as
//! written in a scenario. The method (`method::ball`) validates and plans it.

use super::{Source, SpecimenSection};
use serde::Deserialize;

/// `[ball]`: the ball two-step method's data collection.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Section {
    /// Exact arcs sampled every x_step_mm with Gaussian z noise, or ray-cast profiles.
    #[serde(default)]
    pub source: Source,
    /// Gaussian noise on each arc point's z, mm (analytic).
    #[serde(default)]
    pub sigma_mm: f64,
    /// Spacing of the analytic arc points along x, mm.
    #[serde(default = "d_step")]
    pub x_step_mm: f64,
    /// m: arcs per translation-set capture (averaged).
    #[serde(default = "d_one")]
    pub arcs: usize,
    /// Flange positions of the rotation set (one shared orientation, at least 4).
    #[serde(default)]
    pub rotation_tcp_mm: Vec<[f64; 3]>,
    /// That orientation, (rx, ry, rz) radians, R = Rz Ry Rx.
    #[serde(default)]
    pub rotation_rpy_rad: [f64; 3],
    /// Flange positions and orientations of the translation set (at least 3).
    #[serde(default)]
    pub translation_tcp_mm: Vec<[f64; 3]>,
    /// The translation set's orientations, (rx, ry, rz) radians each, R = Rz Ry Rx.
    #[serde(default)]
    pub translation_rpy_rad: Vec<[f64; 3]>,
    /// Free poses instead of the protocol (`ball-any-pose` only): `[ball.poses]`.
    #[serde(default)]
    pub poses: Option<super::poses::PoseSet>,
    /// The ball, when the scenario's [specimen] is another specimen.
    #[serde(default)]
    pub specimen: Option<SpecimenSection>,
}

fn d_step() -> f64 {
    0.1
}
fn d_one() -> usize {
    1
}

impl Section {
    /// Cause studies: scale the section's own sensor noise and specimen imperfection.
    pub fn scale_causes(&mut self, sensor: f64, specimen: f64) {
        self.sigma_mm *= sensor;
        if let Some(sp) = &mut self.specimen {
            sp.scale_imperfection(specimen);
        }
    }
}
