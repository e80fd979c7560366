//! `[plane]`: the plane method's data collection, as written in a scenario: free poses looking at
//! the table's face (`[plane.poses]`: generated from the scenario's seed, or listed). The method
//! (`method::plane`) validates and plans it.

use super::poses::PoseSet;
use serde::Deserialize;

#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Section {
    /// Where on the table generated poses aim (base frame x, y, mm).
    #[serde(default)]
    pub aim_mm: [f64; 2],
    /// The poses ([plane.poses]: generated or listed).
    pub poses: PoseSet,
}
