//! A free pose set, as written in a scenario (`[ball.poses]`, `[plane.poses]`): generated around
//! the specimen from the scenario's seed, or listed as flange poses or joint angles. What the
//! any-pose estimators take instead of a paper's protocol.

use super::{ScenarioError, Validator};
use crate::sim::poses::PoseSource;
use nalgebra::{UnitQuaternion, Vector3};
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
    /// ...and the aim moved up to this far (mm) across the laser line...
    #[serde(default = "d_spread")]
    pub spread_mm: f64,
    /// ...the turns about the normal drawn at random (`random`), or evenly spaced around it
    /// (`circle`: a real plane set's 48 poses around a circular pattern).
    #[serde(default)]
    pub pattern: Pattern,
    /// Or list the flange (tool0) poses: [x_mm, y_mm, z_mm, qw, qx, qy, qz] each (ABB order).
    #[serde(default)]
    pub tcp_mm_wxyz: Vec<[f64; 7]>,
    /// Or in FANUC / Yaskawa terms: [x_mm, y_mm, z_mm, w_deg, p_deg, r_deg], rotations about the
    /// fixed x, y, z axes in that order (R = Rz(r) Ry(p) Rx(w)).
    #[serde(default)]
    pub tcp_mm_wpr_deg: Vec<[f64; 6]>,
    /// Or in KUKA terms: [x_mm, y_mm, z_mm, a_deg, b_deg, c_deg] (R = Rz(a) Ry(b) Rx(c)).
    #[serde(default)]
    pub tcp_mm_abc_deg: Vec<[f64; 6]>,
    /// Or in Universal Robots terms: [x_mm, y_mm, z_mm, rx, ry, rz], a rotation vector in rad.
    #[serde(default)]
    pub tcp_mm_rotvec_rad: Vec<[f64; 6]>,
    /// Or list the joint angles (deg) of each pose.
    #[serde(default)]
    pub joints_deg: Vec<[f64; 6]>,
    /// Scanning on the move: the arm passes each pose in turn at this speed, mm/s, toward the
    /// next, the profile taken as it passes (0: stop and go, each profile at rest).
    #[serde(default)]
    pub scan_speed_mm_s: f64,
    /// How late the profiler's time stamps are against the controller's clock, ms (negative:
    /// early); with scan_speed_mm_s.
    #[serde(default)]
    pub clock_offset_ms: f64,
    /// Whether the refined, full-profile and any-pose estimators estimate the clock offset with
    /// the transform (true) or take the stamps as they are (false).
    #[serde(default = "yes")]
    pub estimate_clock_offset: bool,
}

fn yes() -> bool {
    true
}

/// How generated poses turn about the specimen's normal.
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum Pattern {
    #[default]
    Random,
    Circle,
}

/// A controller convention's rotation as a unit quaternion (w, x, y, z).
fn quaternion(convention: Convention, r: [f64; 3]) -> [f64; 4] {
    let q = match convention {
        Convention::Wpr => UnitQuaternion::from_euler_angles(
            r[0].to_radians(),
            r[1].to_radians(),
            r[2].to_radians(),
        ),
        Convention::Abc => UnitQuaternion::from_euler_angles(
            r[2].to_radians(),
            r[1].to_radians(),
            r[0].to_radians(),
        ),
        Convention::RotVec => UnitQuaternion::from_scaled_axis(Vector3::from(r)),
    };
    [q.w, q.i, q.j, q.k]
}

#[derive(Clone, Copy)]
enum Convention {
    Wpr,
    Abc,
    RotVec,
}

fn d_tilt() -> [f64; 2] {
    [10.0, 30.0]
}
fn d_spread() -> f64 {
    20.0
}

impl PoseSet {
    /// Scanning on the move through the poses, when a speed is given (`key`: the section's key).
    pub fn passing(
        &self,
        key: &str,
        v: &Validator,
    ) -> Result<Option<crate::sim::poses::Passing>, ScenarioError> {
        if !(self.scan_speed_mm_s >= 0.0 && self.scan_speed_mm_s <= 10_000.0) {
            return Err(v.bad(
                &format!("{key}.scan_speed_mm_s"),
                self.scan_speed_mm_s,
                "must be in [0, 10000] mm/s (0: stop and go)",
            ));
        }
        if !(self.clock_offset_ms.abs() <= 1000.0) {
            return Err(v.bad(
                &format!("{key}.clock_offset_ms"),
                self.clock_offset_ms,
                "must be within +-1000 ms (a profiler's latency is milliseconds)",
            ));
        }
        if self.scan_speed_mm_s == 0.0 {
            if self.clock_offset_ms != 0.0 {
                return Err(v.bad(
                    &format!("{key}.clock_offset_ms"),
                    self.clock_offset_ms,
                    "a clock offset acts on poses passed on the move: give scan_speed_mm_s too",
                ));
            }
            return Ok(None);
        }
        Ok(Some(crate::sim::poses::Passing {
            speed: self.scan_speed_mm_s * 1e-3,
            clock_offset: self.clock_offset_ms * 1e-3,
            estimate: self.estimate_clock_offset,
        }))
    }

    /// Exactly one way, its values in range; `key` is the section's key (e.g. `plane.poses`) and
    /// `min` the fewest poses the method takes.
    pub fn source(
        &self,
        key: &str,
        min: usize,
        v: &Validator,
    ) -> Result<PoseSource, ScenarioError> {
        let euler = [
            ("tcp_mm_wpr_deg", &self.tcp_mm_wpr_deg, Convention::Wpr),
            ("tcp_mm_abc_deg", &self.tcp_mm_abc_deg, Convention::Abc),
            (
                "tcp_mm_rotvec_rad",
                &self.tcp_mm_rotvec_rad,
                Convention::RotVec,
            ),
        ];
        let given = [
            self.count.is_some(),
            !self.tcp_mm_wxyz.is_empty(),
            !self.joints_deg.is_empty(),
        ]
        .into_iter()
        .chain(euler.iter().map(|e| !e.1.is_empty()));
        if given.filter(|g| *g).count() != 1 {
            return Err(v.bad(
                key,
                "..",
                "give exactly one of count (generated poses), tcp_mm_wxyz, tcp_mm_wpr_deg, \
                 tcp_mm_abc_deg, tcp_mm_rotvec_rad or joints_deg",
            ));
        }
        let n = self.count.unwrap_or(
            self.tcp_mm_wxyz.len()
                + self.joints_deg.len()
                + euler.iter().map(|e| e.1.len()).sum::<usize>(),
        );
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
                circle: self.pattern == Pattern::Circle,
            });
        }
        if self.pattern != Pattern::Random {
            return Err(v.bad(
                &format!("{key}.pattern"),
                "circle",
                "a pattern shapes generated poses only: give count, or leave pattern out",
            ));
        }
        if let Some((name, list, convention)) = euler.iter().find(|e| !e.1.is_empty()) {
            let mut out = Vec::with_capacity(list.len());
            for (i, p) in list.iter().enumerate() {
                if p.iter().any(|x| !x.is_finite()) {
                    return Err(v.bad(
                        &format!("{key}.{name}[{i}]"),
                        format!("{p:?}"),
                        "every value must be finite",
                    ));
                }
                out.push((
                    [p[0] * 1e-3, p[1] * 1e-3, p[2] * 1e-3],
                    quaternion(*convention, [p[3], p[4], p[5]]),
                ));
            }
            return Ok(PoseSource::Tcp(out));
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
