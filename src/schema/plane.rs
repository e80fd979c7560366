//! `[plane]`: the plane method's data collection, as written in a scenario: free poses looking at
//! the table's face, generated from the scenario's seed. The method (`method::plane`) validates and
//! plans it.

use serde::Deserialize;

#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Section {
    /// How many poses (each at its own orientation, one profile each).
    #[serde(default = "d_poses")]
    pub poses: usize,
    /// The laser's tilt from the plane's normal, drawn uniformly in [min, max] (deg); the turn
    /// about the normal and about the laser's own axis are drawn over a full turn.
    #[serde(default = "d_tilt")]
    pub tilt_deg: [f64; 2],
    /// Where on the table the poses aim (base frame x, y, mm): the middle of the sensor's range
    /// lands within `spread_mm` of it.
    pub aim_mm: [f64; 2],
    #[serde(default = "d_spread")]
    pub spread_mm: f64,
}

fn d_poses() -> usize {
    24
}
fn d_tilt() -> [f64; 2] {
    [10.0, 30.0]
}
fn d_spread() -> f64 {
    40.0
}
