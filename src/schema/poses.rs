//! A free pose set, as written in a scenario (`[ball.poses]`, `[plane.poses]`): generated around
//! the specimen from the scenario's seed, or listed as flange poses or joint angles. What the
//! any-pose estimators take instead of a paper's protocol.

use super::{ScenarioError, Validator};
use crate::sim::poses::PoseSource;
use serde::Deserialize;

#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PoseSet {
    /// Generate this many poses around the specimen...
    #[serde(default)]
    pub count: Option<usize>,
    /// ...with the laser tilted from the specimen's normal (straight down for a ball) by an angle
    /// drawn in [min, max] deg, turned at random about the normal and about its own axis...
    #[serde(default = "d_tilt")]
    pub tilt_deg: [f64; 2],
    /// ...and the aim moved up to this far (mm) across the laser line.
    #[serde(default = "d_spread")]
    pub spread_mm: f64,
    /// Or list the flange (tool0) poses: [x_mm, y_mm, z_mm, qw, qx, qy, qz] each (ABB order).
    #[serde(default)]
    pub tcp_mm_wxyz: Vec<[f64; 7]>,
    /// Or list the joint angles (deg) of each pose.
    #[serde(default)]
    pub joints_deg: Vec<[f64; 6]>,
}

fn d_tilt() -> [f64; 2] {
    [10.0, 30.0]
}
fn d_spread() -> f64 {
    20.0
}

impl PoseSet {
    /// Exactly one way, its values in range; `key` is the section's key (e.g. `plane.poses`) and
    /// `min` the fewest poses the method takes.
    pub fn source(
        &self,
        key: &str,
        min: usize,
        v: &Validator,
    ) -> Result<PoseSource, ScenarioError> {
        let given = [
            self.count.is_some(),
            !self.tcp_mm_wxyz.is_empty(),
            !self.joints_deg.is_empty(),
        ];
        if given.iter().filter(|g| **g).count() != 1 {
            return Err(v.bad(
                key,
                "..",
                "give exactly one of count (generated poses), tcp_mm_wxyz or joints_deg",
            ));
        }
        let n = self
            .count
            .unwrap_or(self.tcp_mm_wxyz.len() + self.joints_deg.len());
        if n < min || n > 10_000 {
            return Err(v.bad(
                &format!("{key}.count"),
                n,
                format!("give {min} to 10000 poses, each at its own orientation"),
            ));
        }
        if let Some(count) = self.count {
            let [lo, hi] = self.tilt_deg;
            if !(lo >= 0.0 && hi >= lo && hi < 75.0) {
                return Err(v.bad(
                    &format!("{key}.tilt_deg"),
                    format!("{:?}", self.tilt_deg),
                    "give [min, max] with 0 <= min <= max < 75 (deg from the normal)",
                ));
            }
            v.non_negative(&format!("{key}.spread_mm"), self.spread_mm)?;
            return Ok(PoseSource::Generate {
                count,
                tilt: (lo.to_radians(), hi.to_radians()),
                spread: self.spread_mm * 1e-3,
            });
        }
        if !self.tcp_mm_wxyz.is_empty() {
            let mut out = Vec::with_capacity(self.tcp_mm_wxyz.len());
            for (i, p) in self.tcp_mm_wxyz.iter().enumerate() {
                let q = [p[3], p[4], p[5], p[6]];
                let norm = q.iter().map(|x| x * x).sum::<f64>().sqrt();
                if p.iter().any(|x| !x.is_finite()) || (norm - 1.0).abs() > 1e-3 {
                    return Err(v.bad(
                        &format!("{key}.tcp_mm_wxyz[{i}]"),
                        format!("{p:?}"),
                        "give [x_mm, y_mm, z_mm, qw, qx, qy, qz], finite, with a unit quaternion",
                    ));
                }
                out.push(([p[0] * 1e-3, p[1] * 1e-3, p[2] * 1e-3], q.map(|x| x / norm)));
            }
            return Ok(PoseSource::Tcp(out));
        }
        let mut out = Vec::with_capacity(self.joints_deg.len());
        for (i, q) in self.joints_deg.iter().enumerate() {
            if q.iter().any(|x| !x.is_finite()) {
                return Err(v.bad(
                    &format!("{key}.joints_deg[{i}]"),
                    format!("{q:?}"),
                    "joint angles must be finite",
                ));
            }
            out.push(q.map(f64::to_radians));
        }
        Ok(PoseSource::Joints(out))
    }
}
