//! `[edge]`: the straight-edge method's data collection (Xu et al.), as written in a scenario.
//! The method (`method::edge`) validates and plans it.

use super::{Source, SpecimenSection};
use serde::Deserialize;

/// `[edge]`: the straight-edge method's data collection.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Section {
    /// Exact edge points plus Gaussian noise, or ray-cast profiles.
    #[serde(default)]
    pub source: Source,
    /// Gaussian noise on the edge point's x and z, mm (analytic).
    #[serde(default)]
    pub sigma_mm: f64,
    /// The paper's protocol (left out with `[edge.poses]`): rotation groups, translations per
    /// group along an arc, the groups' largest tilt.
    #[serde(default)]
    pub rotations: usize,
    /// Translations per rotation group, along an arc.
    #[serde(default)]
    pub translations: usize,
    /// The rotation groups' largest tilt from the nominal view, deg.
    #[serde(default)]
    pub tilt_deg: f64,
    /// Radius of the translations' arc, mm.
    #[serde(default)]
    pub arc_radius_mm: f64,
    /// The arc's span, deg.
    #[serde(default)]
    pub arc_span_deg: f64,
    /// Angle of the arc's chord from the edge toward the open side: 0 moves along the edge (the
    /// profile never changes), 90 straight across it (the points do not spread along the edge).
    #[serde(default = "d_heading")]
    pub arc_heading_deg: f64,
    /// Sensor z at which the laser line crosses the edge (default: the range centre).
    #[serde(default)]
    pub edge_z_mm: Option<f64>,
    /// The edge specimen, when the scenario's [specimen] is another specimen.
    #[serde(default)]
    pub specimen: Option<SpecimenSection>,
    /// The edge paper's Table 3 check with a precision ball.
    #[serde(default)]
    pub validation: Option<Validation>,
    /// Free poses instead of the protocol (for edge-any-pose): each crosses the edge at 30 deg or
    /// more, the crossings spread along it.
    #[serde(default)]
    pub poses: Option<super::poses::PoseSet>,
}

/// `[edge.validation]`: the edge paper's Table 3 check.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Validation {
    /// The check ball's radius, mm.
    pub ball_radius_mm: f64,
    /// The check ball's centre in the base frame, mm.
    pub position_mm: [f64; 3],
    /// Rotation groups of the check scan.
    #[serde(default = "d_ten")]
    pub groups: usize,
    /// Translations per group of the check scan.
    #[serde(default = "d_six")]
    pub translations: usize,
    /// Noise on the check scan's arc points, mm (analytic).
    #[serde(default)]
    pub sigma_mm: f64,
}

fn d_heading() -> f64 {
    45.0
}
fn d_ten() -> usize {
    10
}
fn d_six() -> usize {
    6
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
