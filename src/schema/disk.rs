//! `[disk]`: the disk method's data collection (Chen et al. 2018, Sec. III-A), as written in a
//! scenario (mm, degrees, radians as named). The method (`method::disk`) validates and plans it.

use super::Source;
use serde::Deserialize;

/// `[disk]`: the disk method's data collection.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Section {
    /// m: profiles (chords) per scan (the paper's protocol; left out with `[disk.poses]`).
    #[serde(default)]
    pub chords: usize,
    /// How much of the disk a scan sweeps (Fig. 4).
    #[serde(default)]
    pub coverage: CoverageKey,
    /// Fraction of the disk's extent across the laser plane that a scan sweeps.
    #[serde(default = "d_span")]
    pub span_fraction: f64,
    /// Analytic chords + Eq. 52 noise, or the sensor model + feature extraction.
    #[serde(default)]
    pub source: Source,
    /// Eq. 52: Gaussian noise along each chord, mm (analytic source).
    #[serde(default)]
    pub sigma_mm: f64,
    /// Eq. 2: least angle between the move and the disk plane or normal.
    #[serde(default = "d_min_angle")]
    pub min_angle_deg: f64,
    /// R_tcp,i as (rx, ry, rz) radians, R = Rz Ry Rx (the disk paper's tables).
    #[serde(default)]
    pub orientations_rpy_rad: Vec<[f64; 3]>,
    /// Optional TCP positions where the laser plane crosses the disk centre (mm).
    #[serde(default)]
    pub centre_tcp_mm: Option<Vec<[f64; 3]>>,
    /// Move directions in the base frame (the disk paper's D_i^b)...
    #[serde(default)]
    pub directions_in_base: Option<Vec<[f64; 3]>>,
    /// ...or the move directions in the sensor frame (D_i^i); one list or the other, one entry per
    /// orientation.
    #[serde(default)]
    pub directions_in_sensor: Option<Vec<[f64; 3]>>,
    /// Free poses instead of the protocol (for disk-any-pose): one profile each, aimed within the
    /// disk.
    #[serde(default)]
    pub poses: Option<super::poses::PoseSet>,
    /// Scanning on the move: the speed of each scan's straight move, mm/s (0: stop and go, each
    /// profile taken at rest).
    #[serde(default)]
    pub scan_speed_mm_s: f64,
    /// How late the profiler's time stamps are against the controller's clock, ms (negative:
    /// early). Each profile is paired with the controller's pose at its stamp, so while the arm
    /// moves its recorded pose lies speed x offset ahead along the move of where it was taken.
    #[serde(default)]
    pub clock_offset_ms: f64,
    /// Scanning on the move: how fast the profiler's clock runs against the controller's, ppm
    /// (crystal drift: a profile stamped u s into the capture was taken clock_offset_ms plus
    /// u x this x 1e-6 s before u).
    #[serde(default)]
    pub clock_drift_ppm: f64,
    /// Scanning on the move: the standard deviation of each stamp's own error, ms (the
    /// profiler's and the network's jitter; drawn per profile from the trial's seed).
    #[serde(default)]
    pub clock_jitter_ms: f64,
    /// Scanning on the move: the profiler's exposure, ms. A stamp marks the exposure's start and
    /// the profile is the image over the exposure: on a steady move, the profile at its middle,
    /// half the exposure after the stamp.
    #[serde(default)]
    pub exposure_ms: f64,
    /// Scanning on the move: whether the refined, full-profile and any-pose estimators estimate
    /// the clock offset with the transform (true) or take the stamps as they are (false).
    #[serde(default = "yes")]
    pub estimate_clock_offset: bool,
    /// Scanning on the move: whether they also estimate the clock's drift (with the offset).
    #[serde(default)]
    pub estimate_clock_drift: bool,
    /// Scanning on the move: each scan's move starts and ends at rest, speeding up and braking
    /// at this acceleration, mm/s^2 (0: at the scan speed throughout, from before the first
    /// profile to after the last).
    #[serde(default)]
    pub scan_accel_mm_s2: f64,
    /// The rate the controller logs poses at, Hz (0: only each move's start and end, as a
    /// controller that reports waypoints; the profiles are then placed on a straight line in
    /// time between them).
    #[serde(default = "pose_log_hz")]
    pub pose_log_hz: f64,
}

fn pose_log_hz() -> f64 {
    250.0
}

fn yes() -> bool {
    true
}

fn d_span() -> f64 {
    0.9
}
fn d_min_angle() -> f64 {
    5.0
}

/// `coverage` in a scenario.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "lowercase")]
pub enum CoverageKey {
    #[default]
    Whole,
    Half,
}

impl Section {
    /// Cause studies: scale the section's own sensor noise.
    pub fn scale_causes(&mut self, sensor: f64, _specimen: f64) {
        self.sigma_mm *= sensor;
    }
}
