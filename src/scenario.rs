//! Scenario files (TOML): robot, sensor and true mounting, specimen and its pose, data-collection
//! plan, noise, methods, sweep grid, trials and seed. Unknown keys and bad values are errors that
//! name the file, the key and the value.

use crate::math::{pose_from_xyz_rpy, rot_zyx};
use crate::robot::Robot;
use crate::scene::{Scene, Specimen, SpecimenKind, Table};
use crate::sensor::{NoiseModel, SensorModel};
use crate::sim::Rig;
use crate::sim::ball::{BallPlan, BallTarget, Pose as BallPose};
use crate::sim::disk::{Coverage, Direction, DiskPlanSpec, DiskScanPlan, DiskTarget, ScanRequest};
use crate::sim::edge::{EdgeGroupPlan, EdgePlanSpec, EdgeTarget};
use nalgebra::{Isometry3, Matrix3, Translation3, UnitQuaternion, Vector3};
use serde::Deserialize;
use thiserror::Error;

#[derive(Debug, Error, Clone, PartialEq)]
pub enum ScenarioError {
    #[error("{file}: cannot read: {message}")]
    Io { file: String, message: String },
    #[error("{file}: {message}")]
    Syntax { file: String, message: String },
    #[error("{file}: {key} = {value}: {reason}")]
    BadValue {
        file: String,
        key: String,
        value: String,
        reason: String,
    },
}

fn d_true() -> bool {
    true
}
fn d_seed() -> u64 {
    1
}
fn d_span() -> f64 {
    0.9
}
fn d_min_angle() -> f64 {
    5.0
}
fn d_reflectance() -> f64 {
    0.3
}
fn d_coverage() -> String {
    "whole".into()
}
fn d_source() -> String {
    "analytic".into()
}
fn d_methods() -> Vec<String> {
    vec!["disk".into()]
}

#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    pub name: String,
    #[serde(default)]
    pub description: String,
    #[serde(default = "d_seed")]
    pub seed: u64,
    #[serde(default = "d_methods")]
    pub methods: Vec<String>,
    pub robot: RobotSection,
    pub sensor: SensorSection,
    pub specimen: SpecimenSection,
    #[serde(default)]
    pub table: Option<TableSection>,
    #[serde(default)]
    pub disk: Option<DiskSection>,
    #[serde(default)]
    pub ball: Option<BallSection>,
    #[serde(default)]
    pub edge: Option<EdgeSection>,
    #[serde(default)]
    pub robot_error: Option<RobotErrorSection>,
    #[serde(default)]
    pub vibration: Option<VibrationSection>,
    #[serde(default)]
    pub dynamics: Option<DynamicsSection>,
    #[serde(default)]
    pub causes: Option<CausesSection>,
    #[serde(default)]
    pub sweep: Option<SweepSection>,
}

/// The physical causes of error a scenario can switch on, by name (`[causes] only`).
pub const CAUSES: &[&str] = &[
    "sensor",
    "repeatability",
    "encoder",
    "kinematic",
    "vibration",
    "specimen",
];

/// Cause studies: keep one of the configured causes of error (or all) and scale its magnitude, so
/// that a sweep over `causes.only` and `causes.scale` shows each cause alone and all combined.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CausesSection {
    /// "all", "none", or one of CAUSES: sensor (sensor noise), repeatability, encoder (joint
    /// noise), kinematic (link-length and joint-offset error), vibration, specimen (radius
    /// tolerance and form error).
    #[serde(default = "d_all")]
    pub only: String,
    /// Multiplies the magnitude of every cause kept (1 = as configured).
    #[serde(default = "d_scale")]
    pub scale: f64,
}

fn d_all() -> String {
    "all".into()
}
fn d_scale() -> f64 {
    1.0
}

/// Robot pose error applied to the robot that moves (the calibration sees the commanded poses).
#[derive(Debug, Clone, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct RobotErrorSection {
    /// ISO 9283 position repeatability (IRB 120: 0.01 mm, IRB 2600: 0.04 mm).
    #[serde(default)]
    pub repeatability_mm: f64,
    /// Encoder noise per joint and pose (standard deviation).
    #[serde(default)]
    pub joint_noise_deg: f64,
    /// Systematic kinematic error per trial: joint origin offsets and joint zero offsets (std).
    #[serde(default)]
    pub link_error_mm: f64,
    #[serde(default)]
    pub joint_offset_error_deg: f64,
}

/// Arm dynamics (rapier): each capture is taken after moving there and settling.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DynamicsSection {
    /// Time the robot waits after each move before the profile (the edge paper's delays).
    pub settle_ms: f64,
    /// Servo gains (acceleration-based: 1/s^2 and 1/s).
    #[serde(default = "d_stiffness")]
    pub stiffness: f64,
    #[serde(default = "d_damping")]
    pub damping: f64,
    /// Joint speed as a fraction of the axis limits.
    #[serde(default = "d_speed")]
    pub speed_fraction: f64,
    #[serde(default = "d_dt")]
    pub dt_ms: f64,
}

fn d_stiffness() -> f64 {
    1.0e4
}
fn d_damping() -> f64 {
    40.0
}
fn d_speed() -> f64 {
    0.5
}
fn d_dt() -> f64 {
    1.0
}

/// Cheap arm-vibration model: a band-limited random TCP perturbation.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct VibrationSection {
    /// RMS of the TCP displacement per axis.
    pub amplitude_mm: f64,
    pub band_low_hz: f64,
    pub band_high_hz: f64,
    /// The rate at which profiles are taken (the Gocator: about 170 Hz).
    pub profile_rate_hz: f64,
}

fn d_step() -> f64 {
    0.1
}
fn d_one() -> usize {
    1
}

/// The ball two-step method's data collection.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BallSection {
    /// "analytic" (exact arcs sampled every x_step_mm, Gaussian z noise) or "raycast".
    #[serde(default = "d_source")]
    pub source: String,
    /// Gaussian noise on each arc point's z, mm (analytic).
    #[serde(default)]
    pub sigma_mm: f64,
    #[serde(default = "d_step")]
    pub x_step_mm: f64,
    /// m: arcs per translation-set capture (averaged).
    #[serde(default = "d_one")]
    pub arcs: usize,
    /// Flange positions of the rotation set (one shared orientation, at least 4).
    pub rotation_tcp_mm: Vec<[f64; 3]>,
    /// That orientation, (rx, ry, rz) radians, R = Rz Ry Rx.
    pub rotation_rpy_rad: [f64; 3],
    /// Flange positions and orientations of the translation set (at least 3).
    pub translation_tcp_mm: Vec<[f64; 3]>,
    pub translation_rpy_rad: Vec<[f64; 3]>,
    /// The ball, when the scenario's [specimen] is another specimen.
    #[serde(default)]
    pub specimen: Option<SpecimenSection>,
}

/// The straight-edge method's data collection.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct EdgeSection {
    /// "analytic" (exact edge points plus Gaussian noise) or "raycast".
    #[serde(default = "d_source")]
    pub source: String,
    /// Gaussian noise on the edge point's x and z, mm (analytic).
    #[serde(default)]
    pub sigma_mm: f64,
    pub rotations: usize,
    pub translations: usize,
    pub tilt_deg: f64,
    pub arc_radius_mm: f64,
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
    pub validation: Option<EdgeValidation>,
}

#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct EdgeValidation {
    pub ball_radius_mm: f64,
    pub position_mm: [f64; 3],
    #[serde(default = "d_ten")]
    pub groups: usize,
    #[serde(default = "d_six")]
    pub translations: usize,
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

#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RobotSection {
    /// irb120, irb2600 or a path to a .urdf (relative to the scenario file).
    pub name: String,
}

#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SensorSection {
    pub preset: String,
    /// The true flange_to_sensor translation (mm).
    pub mount_position_mm: [f64; 3],
    /// The true flange_to_sensor rotation as a row-major matrix (made orthonormal)...
    #[serde(default)]
    pub mount_rotation: Option<[[f64; 3]; 3]>,
    /// ...or as (rx, ry, rz) degrees, R = Rz Ry Rx.
    #[serde(default)]
    pub mount_rpy_deg: Option<[f64; 3]>,
    /// Quantise z as the real sensor does.
    #[serde(default = "d_true")]
    pub quantise: bool,
    #[serde(default)]
    pub noise: NoiseSection,
}

#[derive(Debug, Clone, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct NoiseSection {
    #[serde(default)]
    pub z_sigma_near_mm: f64,
    #[serde(default)]
    pub z_sigma_far_mm: f64,
    #[serde(default)]
    pub x_sigma_mm: f64,
    #[serde(default)]
    pub dropout: f64,
    #[serde(default)]
    pub outlier_rate: f64,
    #[serde(default)]
    pub outlier_amplitude_mm: f64,
    #[serde(default)]
    pub dark_threshold: f64,
    #[serde(default)]
    pub dark_noise_factor: f64,
    #[serde(default)]
    pub dark_dropout: f64,
}

#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SpecimenSection {
    /// disk-cylinder, disk-paper, ball, parallel-bar, scale, knife-blade.
    pub kind: String,
    pub position_mm: [f64; 3],
    /// Orientation (rx, ry, rz) degrees, R = Rz Ry Rx; for a disk its z axis is the normal.
    #[serde(default)]
    pub rpy_deg: [f64; 3],
    pub radius_mm: Option<f64>,
    pub height_mm: Option<f64>,
    pub paper_half_mm: Option<f64>,
    pub post_radius_mm: Option<f64>,
    pub post_height_mm: Option<f64>,
    pub length_mm: Option<f64>,
    pub width_mm: Option<f64>,
    pub thickness_mm: Option<f64>,
    pub bevel_mm: Option<f64>,
    pub reflectance: Option<f64>,
    /// Specimen imperfection: standard deviation of the true disk or ball radius around the nominal
    /// one (drawn per trial; the calibration is told the nominal radius).
    pub radius_tolerance_mm: Option<f64>,
    /// Form tolerances, peak-to-valley (the form error's orientation is drawn per trial): disk
    /// flatness (a saddle warp), ball sphericity (an ellipsoid), edge straightness (a bow).
    pub flatness_mm: Option<f64>,
    pub sphericity_mm: Option<f64>,
    pub straightness_mm: Option<f64>,
    /// Radius to which a parallel bar's or scale's edge is rounded (ray-cast sources only).
    pub edge_radius_mm: Option<f64>,
}

impl SpecimenSection {
    /// The form tolerances, metres.
    pub fn form(&self) -> crate::scene::FormTolerance {
        crate::scene::FormTolerance {
            flatness: self.flatness_mm.unwrap_or(0.0) * 1e-3,
            sphericity: self.sphericity_mm.unwrap_or(0.0) * 1e-3,
            straightness: self.straightness_mm.unwrap_or(0.0) * 1e-3,
        }
    }

    fn scale_imperfection(&mut self, k: f64) {
        for v in [
            &mut self.radius_tolerance_mm,
            &mut self.flatness_mm,
            &mut self.sphericity_mm,
            &mut self.straightness_mm,
            &mut self.edge_radius_mm,
        ]
        .into_iter()
        .flatten()
        {
            *v *= k;
        }
    }
}

#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TableSection {
    pub height_mm: f64,
    #[serde(default = "d_reflectance")]
    pub reflectance: f64,
}

#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DiskSection {
    /// m: profiles (chords) per scan.
    pub chords: usize,
    /// "whole" or "half" (Fig. 4).
    #[serde(default = "d_coverage")]
    pub coverage: String,
    #[serde(default = "d_span")]
    pub span_fraction: f64,
    /// "analytic" (exact chords + Eq. 52 noise) or "raycast" (sensor model + feature extraction).
    #[serde(default = "d_source")]
    pub source: String,
    /// Eq. 52: Gaussian noise along each chord, mm (analytic source).
    #[serde(default)]
    pub sigma_mm: f64,
    /// Eq. 2: least angle between the move and the disk plane or normal.
    #[serde(default = "d_min_angle")]
    pub min_angle_deg: f64,
    /// R_tcp,i as (rx, ry, rz) radians, R = Rz Ry Rx (the disk paper's tables).
    pub orientations_rpy_rad: Vec<[f64; 3]>,
    /// Optional TCP positions where the laser plane crosses the disk centre (mm).
    #[serde(default)]
    pub centre_tcp_mm: Option<Vec<[f64; 3]>>,
    /// Move directions in the base frame (the disk paper's D_i^b)...
    #[serde(default)]
    pub directions_in_base: Option<Vec<[f64; 3]>>,
    /// ...or in the sensor frame (D_i^i); one list or the other, one entry per orientation.
    #[serde(default)]
    pub directions_in_sensor: Option<Vec<[f64; 3]>>,
}

#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SweepSection {
    pub trials: usize,
    /// Dotted scenario keys and the values each takes; the sweep runs their Cartesian product.
    pub grid: toml::Table,
    #[serde(default)]
    pub plot: Option<PlotSection>,
}

#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PlotSection {
    /// Grid key on the x axis.
    pub x: String,
    /// Grid key that makes one curve per value.
    #[serde(default)]
    pub series: Option<String>,
    /// Summary column on the y axis, e.g. centre_error_std_mm.
    pub y: String,
    #[serde(default)]
    pub log_x: bool,
    #[serde(default)]
    pub log_y: bool,
    #[serde(default)]
    pub title: Option<String>,
}

/// A scenario file: the parsed scenario plus its raw table, for grid overrides.
#[derive(Debug, Clone)]
pub struct ScenarioFile {
    pub file: String,
    pub raw: toml::Table,
    pub scenario: Scenario,
}

/// One grid point: the (key, value) overrides and the scenario they give.
#[derive(Debug, Clone)]
pub struct GridPoint {
    pub index: usize,
    pub values: Vec<(String, toml::Value)>,
    pub scenario: Scenario,
}

impl ScenarioFile {
    /// Read and validate a scenario file (every grid point too).
    pub fn load(path: &std::path::Path) -> Result<ScenarioFile, ScenarioError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| ScenarioError::Io {
            file: file.clone(),
            message: e.to_string(),
        })?;
        let mut s = ScenarioFile::parse(&text, &file)?;
        // Resolve a relative URDF path against the scenario's folder.
        let r = &s.scenario.robot.name;
        if r.ends_with(".urdf")
            && !std::path::Path::new(r).is_absolute()
            && let Some(dir) = path.parent()
        {
            let p = dir.join(r).display().to_string();
            s.scenario.robot.name = p.clone();
            if let Some(toml::Value::Table(t)) = s.raw.get_mut("robot") {
                t.insert("name".into(), toml::Value::String(p));
            }
        }
        Ok(s)
    }

    /// Parse scenario text; `file` names it in errors.
    pub fn parse(text: &str, file: &str) -> Result<ScenarioFile, ScenarioError> {
        let raw: toml::Table =
            text.parse()
                .map_err(|e: toml::de::Error| ScenarioError::Syntax {
                    file: file.to_string(),
                    message: e.to_string().trim().to_string(),
                })?;
        let scenario: Scenario = toml::from_str(text).map_err(|e| ScenarioError::Syntax {
            file: file.to_string(),
            message: e.to_string().trim().to_string(),
        })?;
        let sf = ScenarioFile {
            file: file.to_string(),
            raw,
            scenario,
        };
        sf.scenario.validate(file)?;
        for p in sf.grid()? {
            p.scenario.validate(file)?;
        }
        Ok(sf)
    }

    /// The sweep grid's points (one point, the base scenario, when there is no sweep).
    pub fn grid(&self) -> Result<Vec<GridPoint>, ScenarioError> {
        let Some(sweep) = &self.scenario.sweep else {
            return Ok(vec![GridPoint {
                index: 0,
                values: vec![],
                scenario: self.scenario.clone(),
            }]);
        };
        let mut axes: Vec<(String, Vec<toml::Value>)> = Vec::new();
        for (k, v) in &sweep.grid {
            let vals = match v {
                toml::Value::Array(a) if !a.is_empty() => a.clone(),
                _ => {
                    return Err(self.bad(
                        &format!("sweep.grid.\"{k}\""),
                        v,
                        "give a non-empty list of values",
                    ));
                }
            };
            if k.starts_with("sweep") {
                return Err(self.bad(
                    &format!("sweep.grid.\"{k}\""),
                    v,
                    "the sweep cannot sweep itself",
                ));
            }
            axes.push((k.clone(), vals));
        }
        let total: usize = axes.iter().map(|a| a.1.len()).product();
        let mut out = Vec::with_capacity(total);
        for index in 0..total {
            let mut rem = index;
            let mut values = Vec::new();
            // Last axis varies fastest.
            let mut picks = vec![0; axes.len()];
            for (i, a) in axes.iter().enumerate().rev() {
                picks[i] = rem % a.1.len();
                rem /= a.1.len();
            }
            let mut table = self.raw.clone();
            for (i, (k, vals)) in axes.iter().enumerate() {
                let v = vals[picks[i]].clone();
                set_dotted(&mut table, k)
                    .map(|slot| *slot = v.clone())
                    .ok_or_else(|| {
                        self.bad(
                            &format!("sweep.grid.\"{k}\""),
                            &v,
                            "this key does not name a scenario value",
                        )
                    })?;
                values.push((k.clone(), v));
            }
            let scenario: Scenario =
                toml::Value::Table(table)
                    .try_into()
                    .map_err(|e: toml::de::Error| ScenarioError::BadValue {
                        file: self.file.clone(),
                        key: values
                            .iter()
                            .map(|(k, _)| k.as_str())
                            .collect::<Vec<_>>()
                            .join(", "),
                        value: values
                            .iter()
                            .map(|(_, v)| v.to_string())
                            .collect::<Vec<_>>()
                            .join(", "),
                        reason: e.to_string().trim().to_string(),
                    })?;
            out.push(GridPoint {
                index,
                values,
                scenario,
            });
        }
        Ok(out)
    }

    fn bad(&self, key: &str, v: &toml::Value, reason: &str) -> ScenarioError {
        ScenarioError::BadValue {
            file: self.file.clone(),
            key: key.into(),
            value: v.to_string(),
            reason: reason.into(),
        }
    }
}

/// The slot a dotted key names, creating the last table entry if absent (validation happens when the
/// table is deserialised with unknown keys denied).
fn set_dotted<'a>(table: &'a mut toml::Table, key: &str) -> Option<&'a mut toml::Value> {
    let parts: Vec<&str> = key.split('.').collect();
    let (last, path) = parts.split_last()?;
    let mut t = table;
    for p in path {
        t = match t.get_mut(*p)? {
            toml::Value::Table(inner) => inner,
            _ => return None,
        };
    }
    Some(
        t.entry(last.to_string())
            .or_insert(toml::Value::Boolean(false)),
    )
}

fn bad(
    file: &str,
    key: &str,
    value: impl std::fmt::Display,
    reason: impl Into<String>,
) -> ScenarioError {
    ScenarioError::BadValue {
        file: file.into(),
        key: key.into(),
        value: value.to_string(),
        reason: reason.into(),
    }
}

/// The experiment a scenario describes, built once and shared by its trials.
#[derive(Debug, Clone)]
pub struct Setup {
    pub rig: Rig,
    pub scene: Scene,
    pub specimen: Specimen,
    pub base_to_specimen: Isometry3<f64>,
    pub disk: Option<DiskSetup>,
    pub ball: Option<BallSetup>,
    pub edge: Option<EdgeSetup>,
    pub robot_error: crate::sim::disturb::RobotError,
    pub vibration: crate::sim::disturb::Vibration,
    pub dynamics: Option<DynamicsSection>,
}

#[derive(Debug, Clone)]
pub struct BallSetup {
    pub target: BallTarget,
    pub plan: BallPlan,
    pub scene: Scene,
    pub raycast: bool,
    /// z noise on arc points and the arc sampling step (analytic), metres.
    pub sigma: f64,
    pub x_step: f64,
    /// Standard deviation of the true radius (metres).
    pub radius_tolerance: f64,
    /// Form tolerances of the specimen.
    pub form: crate::scene::FormTolerance,
}

#[derive(Debug, Clone)]
pub struct EdgeSetup {
    pub target: EdgeTarget,
    pub plans: Vec<EdgeGroupPlan>,
    pub scene: Scene,
    pub raycast: bool,
    /// Noise on the edge point's x and z (analytic), metres.
    pub sigma: f64,
    /// Table 3 check: ball, groups, translations, z noise.
    pub validation: Option<(BallTarget, usize, usize, f64)>,
    /// Form tolerance of the edge (straightness).
    pub form: crate::scene::FormTolerance,
}

#[derive(Debug, Clone)]
pub struct DiskSetup {
    pub target: DiskTarget,
    pub plans: Vec<DiskScanPlan>,
    pub raycast: bool,
    /// Eq. 52 sigma, metres.
    pub sigma: f64,
    pub min_angle: f64,
    /// Standard deviation of the true radius (metres).
    pub radius_tolerance: f64,
    /// Form tolerances of the specimen.
    pub form: crate::scene::FormTolerance,
}

pub const METHODS: &[&str] = &[
    "disk",
    "ball",
    "edge",
    "disk-refined",
    "ball-refined",
    "edge-refined",
];

/// The closed-form method a method name builds on ("edge-refined" -> "edge").
pub fn base_method(method: &str) -> &str {
    method.strip_suffix("-refined").unwrap_or(method)
}

impl Scenario {
    /// Check values that deserialisation cannot.
    pub fn validate(&self, file: &str) -> Result<(), ScenarioError> {
        if self.causes.is_some() {
            return self.resolved(file)?.validate(file);
        }
        if self.methods.is_empty() {
            return Err(bad(file, "methods", "[]", "name at least one method"));
        }
        for m in &self.methods {
            if !METHODS.contains(&m.as_str()) {
                return Err(bad(
                    file,
                    "methods",
                    format!("\"{m}\""),
                    format!("unknown method; known: {}", METHODS.join(", ")),
                ));
            }
        }
        SensorModel::preset(&self.sensor.preset).map_err(|e| {
            bad(
                file,
                "sensor.preset",
                format!("\"{}\"", self.sensor.preset),
                e.to_string(),
            )
        })?;
        match (&self.sensor.mount_rotation, &self.sensor.mount_rpy_deg) {
            (Some(_), Some(_)) => {
                return Err(bad(
                    file,
                    "sensor.mount_rpy_deg",
                    "..",
                    "give mount_rotation or mount_rpy_deg, not both",
                ));
            }
            (None, None) => {
                return Err(bad(
                    file,
                    "sensor.mount_rotation",
                    "(missing)",
                    "give the true mounting rotation as mount_rotation or mount_rpy_deg",
                ));
            }
            (Some(m), None) => {
                let r = Matrix3::from_fn(|i, j| m[i][j]);
                let dev = (r.transpose() * r - Matrix3::identity()).norm();
                if !dev.is_finite() || dev > 0.05 || r.determinant() <= 0.0 {
                    return Err(bad(
                        file,
                        "sensor.mount_rotation",
                        format!("{m:?}"),
                        "not close to a rotation matrix (rows must be orthonormal, determinant +1)",
                    ));
                }
            }
            _ => {}
        }
        let n = &self.sensor.noise;
        for (k, v) in [
            ("z_sigma_near_mm", n.z_sigma_near_mm),
            ("z_sigma_far_mm", n.z_sigma_far_mm),
            ("x_sigma_mm", n.x_sigma_mm),
            ("outlier_amplitude_mm", n.outlier_amplitude_mm),
            ("dark_noise_factor", n.dark_noise_factor),
        ] {
            if !(v >= 0.0 && v.is_finite()) {
                return Err(bad(
                    file,
                    &format!("sensor.noise.{k}"),
                    v,
                    "must be a finite number >= 0",
                ));
            }
        }
        for (k, v) in [
            ("dropout", n.dropout),
            ("outlier_rate", n.outlier_rate),
            ("dark_threshold", n.dark_threshold),
            ("dark_dropout", n.dark_dropout),
        ] {
            if !(0.0..=1.0).contains(&v) {
                return Err(bad(
                    file,
                    &format!("sensor.noise.{k}"),
                    v,
                    "must be a probability in 0..1",
                ));
            }
        }
        self.specimen_kind(file)?;
        if let Some(t) = &self.table {
            if !(0.0..=1.0).contains(&t.reflectance) {
                return Err(bad(
                    file,
                    "table.reflectance",
                    t.reflectance,
                    "must be in 0..1",
                ));
            }
        }
        if self.methods.iter().any(|m| base_method(m) == "disk") {
            let d = self.disk.as_ref().ok_or_else(|| {
                bad(
                    file,
                    "disk",
                    "(missing)",
                    "the disk method needs a [disk] section",
                )
            })?;
            if !self.specimen_kind(file)?.is_disk_kind() {
                return Err(bad(
                    file,
                    "specimen.kind",
                    format!("\"{}\"", self.specimen.kind),
                    "the disk method needs disk-cylinder or disk-paper",
                ));
            }
            if d.chords < 3 {
                return Err(bad(
                    file,
                    "disk.chords",
                    d.chords,
                    "at least 3 chords per scan are needed for the ellipse fit",
                ));
            }
            if d.orientations_rpy_rad.len() < 4 {
                return Err(bad(
                    file,
                    "disk.orientations_rpy_rad",
                    format!("{} orientations", d.orientations_rpy_rad.len()),
                    "the disk method needs at least 4 sensing data",
                ));
            }
            if !["whole", "half"].contains(&d.coverage.as_str()) {
                return Err(bad(
                    file,
                    "disk.coverage",
                    format!("\"{}\"", d.coverage),
                    "use \"whole\" or \"half\"",
                ));
            }
            if !["analytic", "raycast"].contains(&d.source.as_str()) {
                return Err(bad(
                    file,
                    "disk.source",
                    format!("\"{}\"", d.source),
                    "use \"analytic\" or \"raycast\"",
                ));
            }
            if !(d.span_fraction > 0.0 && d.span_fraction < 1.0) {
                return Err(bad(
                    file,
                    "disk.span_fraction",
                    d.span_fraction,
                    "must be in (0, 1)",
                ));
            }
            if !(d.sigma_mm >= 0.0 && d.sigma_mm.is_finite()) {
                return Err(bad(
                    file,
                    "disk.sigma_mm",
                    d.sigma_mm,
                    "must be a finite number >= 0",
                ));
            }
            if !(d.min_angle_deg >= 0.0 && d.min_angle_deg < 45.0) {
                return Err(bad(
                    file,
                    "disk.min_angle_deg",
                    d.min_angle_deg,
                    "must be in [0, 45)",
                ));
            }
            match (&d.directions_in_base, &d.directions_in_sensor) {
                (Some(_), Some(_)) => {
                    return Err(bad(
                        file,
                        "disk.directions_in_sensor",
                        "..",
                        "give directions_in_base or directions_in_sensor, not both",
                    ));
                }
                (None, None) => {
                    return Err(bad(
                        file,
                        "disk.directions_in_base",
                        "(missing)",
                        "give the move direction of each scan as directions_in_base or directions_in_sensor",
                    ));
                }
                _ => {}
            }
            for (k, list) in [
                ("disk.centre_tcp_mm", &d.centre_tcp_mm),
                ("disk.directions_in_base", &d.directions_in_base),
                ("disk.directions_in_sensor", &d.directions_in_sensor),
            ] {
                if let Some(l) = list
                    && l.len() != d.orientations_rpy_rad.len()
                {
                    return Err(bad(
                        file,
                        k,
                        format!("{} entries", l.len()),
                        format!(
                            "give one per orientation ({})",
                            d.orientations_rpy_rad.len()
                        ),
                    ));
                }
            }
        }
        if self.methods.iter().any(|m| base_method(m) == "ball") {
            let b = self.ball.as_ref().ok_or_else(|| {
                bad(
                    file,
                    "ball",
                    "(missing)",
                    "the ball method needs a [ball] section",
                )
            })?;
            let kind = match &b.specimen {
                Some(sp) => specimen_kind_of(sp, "ball.specimen", file)?,
                None => self.specimen_kind(file)?,
            };
            if !matches!(kind, SpecimenKind::BallOnPost { .. }) {
                return Err(bad(
                    file,
                    "specimen.kind",
                    format!("\"{}\"", self.specimen.kind),
                    "the ball method needs a ball (here or in [ball.specimen])",
                ));
            }
            if b.rotation_tcp_mm.len() < 4 {
                return Err(bad(
                    file,
                    "ball.rotation_tcp_mm",
                    format!("{} positions", b.rotation_tcp_mm.len()),
                    "R_sensor needs at least 4 captures at one orientation",
                ));
            }
            if b.translation_tcp_mm.len() < 3
                || b.translation_tcp_mm.len() != b.translation_rpy_rad.len()
            {
                return Err(bad(
                    file,
                    "ball.translation_tcp_mm",
                    format!(
                        "{} positions, {} orientations",
                        b.translation_tcp_mm.len(),
                        b.translation_rpy_rad.len()
                    ),
                    "T_sensor needs at least 3 captures, one orientation each",
                ));
            }
            if !["analytic", "raycast"].contains(&b.source.as_str()) {
                return Err(bad(
                    file,
                    "ball.source",
                    format!("\"{}\"", b.source),
                    "use \"analytic\" or \"raycast\"",
                ));
            }
            if !(b.sigma_mm >= 0.0 && b.sigma_mm.is_finite()) {
                return Err(bad(
                    file,
                    "ball.sigma_mm",
                    b.sigma_mm,
                    "must be a finite number >= 0",
                ));
            }
            if !(b.x_step_mm > 0.0) || b.arcs == 0 {
                return Err(bad(
                    file,
                    "ball.x_step_mm",
                    b.x_step_mm,
                    "x_step_mm must be > 0 and arcs >= 1",
                ));
            }
        }
        if self.methods.iter().any(|m| base_method(m) == "edge") {
            let e = self.edge.as_ref().ok_or_else(|| {
                bad(
                    file,
                    "edge",
                    "(missing)",
                    "the edge method needs an [edge] section",
                )
            })?;
            if let Some(sp) = &e.specimen {
                specimen_kind_of(sp, "edge.specimen", file)?;
            }
            if e.rotations < 2 {
                return Err(bad(
                    file,
                    "edge.rotations",
                    e.rotations,
                    "at least 2 rotation groups",
                ));
            }
            if e.translations < 3 {
                return Err(bad(
                    file,
                    "edge.translations",
                    e.translations,
                    "at least 3 translations per group",
                ));
            }
            if !(e.arc_radius_mm > 0.0 && e.arc_span_deg > 0.0 && e.arc_span_deg < 180.0) {
                return Err(bad(
                    file,
                    "edge.arc_span_deg",
                    e.arc_span_deg,
                    "the arc needs a radius > 0 and a span in (0, 180) deg: a straight line makes the rotation equations degenerate",
                ));
            }
            if !(e.arc_heading_deg > 0.0 && e.arc_heading_deg < 90.0) {
                return Err(bad(
                    file,
                    "edge.arc_heading_deg",
                    e.arc_heading_deg,
                    "must be in (0, 90): along the edge the profile never changes, straight across it the points do not spread along the edge",
                ));
            }
            if !(e.tilt_deg > 0.0 && e.tilt_deg <= 45.0) {
                return Err(bad(file, "edge.tilt_deg", e.tilt_deg, "must be in (0, 45]"));
            }
            if !["analytic", "raycast"].contains(&e.source.as_str()) {
                return Err(bad(
                    file,
                    "edge.source",
                    format!("\"{}\"", e.source),
                    "use \"analytic\" or \"raycast\"",
                ));
            }
            if !(e.sigma_mm >= 0.0 && e.sigma_mm.is_finite()) {
                return Err(bad(
                    file,
                    "edge.sigma_mm",
                    e.sigma_mm,
                    "must be a finite number >= 0",
                ));
            }
        }
        if let Some(r) = &self.robot_error {
            for (k, v) in [
                ("repeatability_mm", r.repeatability_mm),
                ("joint_noise_deg", r.joint_noise_deg),
                ("link_error_mm", r.link_error_mm),
                ("joint_offset_error_deg", r.joint_offset_error_deg),
            ] {
                if !(v >= 0.0 && v.is_finite()) {
                    return Err(bad(
                        file,
                        &format!("robot_error.{k}"),
                        v,
                        "must be a finite number >= 0",
                    ));
                }
            }
        }
        if let Some(d) = &self.dynamics {
            if !(d.settle_ms >= 0.0 && d.settle_ms.is_finite()) {
                return Err(bad(
                    file,
                    "dynamics.settle_ms",
                    d.settle_ms,
                    "must be a finite number >= 0",
                ));
            }
            if !(d.stiffness > 0.0 && d.damping >= 0.0) {
                return Err(bad(
                    file,
                    "dynamics.stiffness",
                    d.stiffness,
                    "give stiffness > 0 and damping >= 0",
                ));
            }
            if !(d.speed_fraction > 0.0 && d.speed_fraction <= 1.0) {
                return Err(bad(
                    file,
                    "dynamics.speed_fraction",
                    d.speed_fraction,
                    "must be in (0, 1]",
                ));
            }
            if !(d.dt_ms > 0.0 && d.dt_ms <= 10.0) {
                return Err(bad(file, "dynamics.dt_ms", d.dt_ms, "must be in (0, 10]"));
            }
        }
        if let Some(v) = &self.vibration {
            if !(v.amplitude_mm >= 0.0 && v.amplitude_mm.is_finite()) {
                return Err(bad(
                    file,
                    "vibration.amplitude_mm",
                    v.amplitude_mm,
                    "must be a finite number >= 0",
                ));
            }
            if !(v.band_low_hz > 0.0 && v.band_high_hz >= v.band_low_hz) {
                return Err(bad(
                    file,
                    "vibration.band_high_hz",
                    v.band_high_hz,
                    "give 0 < band_low_hz <= band_high_hz",
                ));
            }
            if !(v.profile_rate_hz > 0.0) {
                return Err(bad(
                    file,
                    "vibration.profile_rate_hz",
                    v.profile_rate_hz,
                    "must be > 0",
                ));
            }
        }
        if let Some(s) = &self.sweep {
            if s.trials == 0 {
                return Err(bad(file, "sweep.trials", 0, "at least one trial"));
            }
            if let Some(p) = &s.plot {
                for k in std::iter::once(&p.x).chain(p.series.iter()) {
                    if !s.grid.contains_key(k) {
                        return Err(bad(
                            file,
                            "sweep.plot",
                            format!("\"{k}\""),
                            "not a key of sweep.grid",
                        ));
                    }
                }
            }
        }
        Ok(())
    }

    /// The specimen this scenario describes.
    pub fn specimen_kind(&self, file: &str) -> Result<SpecimenKind, ScenarioError> {
        specimen_kind_of(&self.specimen, "specimen", file)
    }
}

/// The specimen a specimen section describes; `key` prefixes the keys in errors.
pub fn specimen_kind_of(
    s: &SpecimenSection,
    key: &str,
    file: &str,
) -> Result<SpecimenKind, ScenarioError> {
    {
        let need = |name: &str, v: Option<f64>| -> Result<f64, ScenarioError> {
            match v {
                Some(x) if x > 0.0 && x.is_finite() => Ok(x * 1e-3),
                Some(x) => Err(bad(
                    file,
                    &format!("{key}.{name}"),
                    x,
                    "must be a positive length",
                )),
                None => Err(bad(
                    file,
                    &format!("{key}.{name}"),
                    "(missing)",
                    format!("a {} needs {name}", s.kind),
                )),
            }
        };
        let opt = |v: Option<f64>, default_mm: f64, name: &str| -> Result<f64, ScenarioError> {
            need(name, Some(v.unwrap_or(default_mm)))
        };
        let kind = match s.kind.as_str() {
            "disk-cylinder" => SpecimenKind::DiskOnCylinder {
                radius: need("radius_mm", s.radius_mm)?,
                height: opt(s.height_mm, 20.0, "height_mm")?,
            },
            "disk-paper" => SpecimenKind::DiskOnPaper {
                radius: need("radius_mm", s.radius_mm)?,
                paper_half: opt(s.paper_half_mm, 150.0, "paper_half_mm")?,
            },
            "ball" => SpecimenKind::BallOnPost {
                radius: need("radius_mm", s.radius_mm)?,
                post_radius: opt(s.post_radius_mm, 8.0, "post_radius_mm")?,
                post_height: opt(s.post_height_mm, 80.0, "post_height_mm")?,
            },
            "parallel-bar" => SpecimenKind::ParallelBar {
                length: opt(s.length_mm, 150.0, "length_mm")?,
                width: opt(s.width_mm, 25.0, "width_mm")?,
                height: opt(s.height_mm, 12.0, "height_mm")?,
            },
            "scale" => SpecimenKind::Scale {
                length: opt(s.length_mm, 300.0, "length_mm")?,
                width: opt(s.width_mm, 30.0, "width_mm")?,
                thickness: opt(s.thickness_mm, 1.0, "thickness_mm")?,
            },
            "knife-blade" => SpecimenKind::KnifeBlade {
                length: opt(s.length_mm, 125.0, "length_mm")?,
                width: opt(s.width_mm, 18.0, "width_mm")?,
                thickness: opt(s.thickness_mm, 0.6, "thickness_mm")?,
                bevel: opt(s.bevel_mm, 1.0, "bevel_mm")?,
            },
            other => {
                return Err(bad(
                    file,
                    &format!("{key}.kind"),
                    format!("\"{other}\""),
                    "use disk-cylinder, disk-paper, ball, parallel-bar, scale or knife-blade",
                ));
            }
        };
        if let Some(t) = s.radius_tolerance_mm
            && !(t >= 0.0 && t.is_finite())
        {
            return Err(bad(
                file,
                &format!("{key}.radius_tolerance_mm"),
                t,
                "must be a finite number >= 0",
            ));
        }
        let allowed = |field: &str| match field {
            "flatness_mm" => kind.is_disk_kind(),
            "sphericity_mm" => matches!(kind, SpecimenKind::BallOnPost { .. }),
            "straightness_mm" => Specimen::new(kind.clone()).is_edge(),
            _ => matches!(
                kind,
                SpecimenKind::ParallelBar { .. } | SpecimenKind::Scale { .. }
            ),
        };
        for (field, v, applies) in [
            ("flatness_mm", s.flatness_mm, "a disk"),
            ("sphericity_mm", s.sphericity_mm, "a ball"),
            ("straightness_mm", s.straightness_mm, "an edge specimen"),
            (
                "edge_radius_mm",
                s.edge_radius_mm,
                "a parallel bar or a scale",
            ),
        ] {
            let Some(v) = v else { continue };
            if !(v >= 0.0 && v.is_finite()) {
                return Err(bad(
                    file,
                    &format!("{key}.{field}"),
                    v,
                    "must be a finite number >= 0",
                ));
            }
            if !allowed(field) {
                return Err(bad(
                    file,
                    &format!("{key}.{field}"),
                    v,
                    format!("applies to {applies}, not to {}", s.kind),
                ));
            }
        }
        if let Some(r) = s.reflectance
            && !(0.0..=1.0).contains(&r)
        {
            return Err(bad(
                file,
                &format!("{key}.reflectance"),
                r,
                "must be in 0..1",
            ));
        }
        Ok(kind)
    }
}

/// A specimen section's specimen and its pose.
pub fn place_specimen(
    s: &SpecimenSection,
    key: &str,
    file: &str,
) -> Result<(Specimen, Isometry3<f64>), ScenarioError> {
    let mut specimen = Specimen::new(specimen_kind_of(s, key, file)?);
    if let Some(r) = s.reflectance {
        specimen.reflectance = r;
    }
    specimen.edge_radius = s.edge_radius_mm.unwrap_or(0.0) * 1e-3;
    let pose = pose_from_xyz_rpy(
        [
            s.position_mm[0] * 1e-3,
            s.position_mm[1] * 1e-3,
            s.position_mm[2] * 1e-3,
        ],
        [
            s.rpy_deg[0].to_radians(),
            s.rpy_deg[1].to_radians(),
            s.rpy_deg[2].to_radians(),
        ],
    );
    Ok((specimen, pose))
}

impl Scenario {
    /// The true flange_to_sensor.
    pub fn mount(&self) -> Isometry3<f64> {
        let t = Vector3::from(self.sensor.mount_position_mm) * 1e-3;
        let rot = match (&self.sensor.mount_rotation, &self.sensor.mount_rpy_deg) {
            (Some(m), _) => UnitQuaternion::from_rotation_matrix(&crate::math::nearest_rotation(
                &Matrix3::from_fn(|i, j| m[i][j]),
            )),
            (None, Some(r)) => UnitQuaternion::from_euler_angles(
                r[0].to_radians(),
                r[1].to_radians(),
                r[2].to_radians(),
            ),
            (None, None) => UnitQuaternion::identity(),
        };
        Isometry3::from_parts(Translation3::from(t), rot)
    }

    /// The rig and the scene of the top-level specimen (and table), without any method's plan: what
    /// `lasercal scan` needs.
    pub fn rig_and_scene(&self, file: &str) -> Result<(Rig, Scene), ScenarioError> {
        let robot = Robot::resolve(&self.robot.name).map_err(|e| {
            bad(
                file,
                "robot.name",
                format!("\"{}\"", self.robot.name),
                e.to_string(),
            )
        })?;
        let mut sensor = SensorModel::preset(&self.sensor.preset)
            .map_err(|e| bad(file, "sensor.preset", &self.sensor.preset, e.to_string()))?;
        if !self.sensor.quantise {
            sensor.z_quantum = None;
        }
        let n = &self.sensor.noise;
        sensor.noise = NoiseModel {
            z_sigma_near: n.z_sigma_near_mm * 1e-3,
            z_sigma_far: n.z_sigma_far_mm * 1e-3,
            x_sigma: n.x_sigma_mm * 1e-3,
            dropout: n.dropout,
            outlier_rate: n.outlier_rate,
            outlier_amplitude: n.outlier_amplitude_mm * 1e-3,
            dark_threshold: n.dark_threshold,
            dark_noise_factor: n.dark_noise_factor,
            dark_dropout: n.dark_dropout,
        };
        let (specimen, pose) = place_specimen(&self.specimen, "specimen", file)?;
        let mut scene = Scene::new(self.table.as_ref().map(|t| Table {
            height_m: t.height_mm * 1e-3,
            reflectance: t.reflectance,
        }));
        scene.add(&specimen, pose);
        Ok((
            Rig {
                robot,
                sensor,
                flange_to_sensor: self.mount(),
            },
            scene,
        ))
    }

    /// The scenario with its `[causes]` applied: the causes not kept switched off, the kept ones
    /// scaled; no `[causes]` section leaves it as it is.
    pub fn resolved(&self, file: &str) -> Result<Scenario, ScenarioError> {
        let mut s = self.clone();
        let Some(c) = s.causes.take() else {
            return Ok(s);
        };
        if c.only != "all" && c.only != "none" && !CAUSES.contains(&c.only.as_str()) {
            return Err(bad(
                file,
                "causes.only",
                format!("\"{}\"", c.only),
                format!("use all, none or one of {}", CAUSES.join(", ")),
            ));
        }
        if !(c.scale >= 0.0 && c.scale.is_finite()) {
            return Err(bad(
                file,
                "causes.scale",
                c.scale,
                "must be a finite number >= 0",
            ));
        }
        let k = |cause: &str| {
            if c.only == "all" || c.only == cause {
                c.scale
            } else {
                0.0
            }
        };
        let ks = k("sensor");
        let n = &mut s.sensor.noise;
        for v in [
            &mut n.z_sigma_near_mm,
            &mut n.z_sigma_far_mm,
            &mut n.x_sigma_mm,
            &mut n.outlier_amplitude_mm,
        ] {
            *v *= ks;
        }
        if let Some(d) = &mut s.disk {
            d.sigma_mm *= ks;
        }
        if let Some(b) = &mut s.ball {
            b.sigma_mm *= ks;
            if let Some(sp) = &mut b.specimen {
                sp.scale_imperfection(k("specimen"));
            }
        }
        if let Some(e) = &mut s.edge {
            e.sigma_mm *= ks;
            if let Some(sp) = &mut e.specimen {
                sp.scale_imperfection(k("specimen"));
            }
        }
        s.specimen.scale_imperfection(k("specimen"));
        if let Some(r) = &mut s.robot_error {
            r.repeatability_mm *= k("repeatability");
            r.joint_noise_deg *= k("encoder");
            r.link_error_mm *= k("kinematic");
            r.joint_offset_error_deg *= k("kinematic");
        }
        if let Some(v) = &mut s.vibration {
            v.amplitude_mm *= k("vibration");
        }
        Ok(s)
    }

    /// Build the rig, scene and plans (checking reachability).
    pub fn build(&self, file: &str) -> Result<Setup, ScenarioError> {
        if self.causes.is_some() {
            return self.resolved(file)?.build(file);
        }
        self.validate(file)?;
        let (rig, _) = self.rig_and_scene(file)?;
        let (specimen, base_to_specimen) = place_specimen(&self.specimen, "specimen", file)?;
        let table = self.table.as_ref().map(|t| Table {
            height_m: t.height_mm * 1e-3,
            reflectance: t.reflectance,
        });
        let mut scene = Scene::new(table);
        scene.add(&specimen, base_to_specimen);
        // A method with its own specimen gets a scene of its own (same table).
        let own = |sec: &Option<SpecimenSection>,
                   key: &str|
         -> Result<(Specimen, Isometry3<f64>, Scene), ScenarioError> {
            match sec {
                Some(sp) => {
                    let (spec, pose) = place_specimen(sp, key, file)?;
                    let mut sc = Scene::new(table);
                    sc.add(&spec, pose);
                    Ok((spec, pose, sc))
                }
                None => Ok((specimen.clone(), base_to_specimen, scene.clone())),
            }
        };
        let disk = match (&self.disk, specimen.disk_radius()) {
            (Some(d), Some(radius)) if self.methods.iter().any(|m| base_method(m) == "disk") => {
                let target = DiskTarget::from_pose(&base_to_specimen, radius);
                let scans = d
                    .orientations_rpy_rad
                    .iter()
                    .enumerate()
                    .map(|(i, r)| ScanRequest {
                        r_tcp: rot_zyx(r[0], r[1], r[2]),
                        centre_tcp: d.centre_tcp_mm.as_ref().map(|c| Vector3::from(c[i]) * 1e-3),
                        direction: match (&d.directions_in_base, &d.directions_in_sensor) {
                            (Some(b), _) => Direction::InBase(Vector3::from(b[i])),
                            (None, Some(s)) => Direction::InSensor(Vector3::from(s[i])),
                            (None, None) => Direction::InSensor(Vector3::y()),
                        },
                    })
                    .collect();
                let spec = DiskPlanSpec {
                    scans,
                    coverage: if d.coverage == "half" {
                        Coverage::Half
                    } else {
                        Coverage::Whole
                    },
                    span_fraction: d.span_fraction,
                    m: d.chords,
                    min_angle: d.min_angle_deg.to_radians(),
                };
                let plans = crate::sim::disk::plan(&rig, &target, &spec)
                    .map_err(|e| bad(file, "disk.orientations_rpy_rad", "..", e.to_string()))?;
                Some(DiskSetup {
                    target,
                    plans,
                    raycast: d.source == "raycast",
                    sigma: d.sigma_mm * 1e-3,
                    min_angle: d.min_angle_deg.to_radians(),
                    radius_tolerance: self.specimen.radius_tolerance_mm.unwrap_or(0.0) * 1e-3,
                    form: self.specimen.form(),
                })
            }
            _ => None,
        };
        let ball = match &self.ball {
            Some(b) if self.methods.iter().any(|m| base_method(m) == "ball") => {
                let (spec, pose, sc) = own(&b.specimen, "ball.specimen")?;
                let radius = spec.ball_radius().ok_or_else(|| {
                    bad(
                        file,
                        "ball.specimen.kind",
                        spec.name(),
                        "the ball method needs a ball specimen",
                    )
                })?;
                let target = BallTarget {
                    centre: pose * nalgebra::Point3::origin(),
                    radius,
                };
                let rr = b.rotation_rpy_rad;
                let plan = BallPlan {
                    rotation_set: b
                        .rotation_tcp_mm
                        .iter()
                        .map(|t| BallPose {
                            r_tcp: rot_zyx(rr[0], rr[1], rr[2]),
                            t_tcp: Vector3::from(*t) * 1e-3,
                        })
                        .collect(),
                    translation_set: b
                        .translation_tcp_mm
                        .iter()
                        .zip(&b.translation_rpy_rad)
                        .map(|(t, r)| BallPose {
                            r_tcp: rot_zyx(r[0], r[1], r[2]),
                            t_tcp: Vector3::from(*t) * 1e-3,
                        })
                        .collect(),
                    arcs: b.arcs,
                };
                crate::sim::ball::check(&rig, &target, &plan)
                    .map_err(|e| bad(file, "ball.rotation_tcp_mm", "..", e.to_string()))?;
                Some(BallSetup {
                    target,
                    plan,
                    scene: sc,
                    raycast: b.source == "raycast",
                    sigma: b.sigma_mm * 1e-3,
                    x_step: b.x_step_mm * 1e-3,
                    radius_tolerance: b
                        .specimen
                        .as_ref()
                        .unwrap_or(&self.specimen)
                        .radius_tolerance_mm
                        .unwrap_or(0.0)
                        * 1e-3,
                    form: b.specimen.as_ref().unwrap_or(&self.specimen).form(),
                })
            }
            _ => None,
        };
        let edge = match &self.edge {
            Some(e) if self.methods.iter().any(|m| base_method(m) == "edge") => {
                let (spec, pose, sc) = own(&e.specimen, "edge.specimen")?;
                if !spec.is_edge() {
                    return Err(bad(
                        file,
                        "edge.specimen.kind",
                        spec.name(),
                        "the edge method needs parallel-bar, scale or knife-blade",
                    ));
                }
                let target =
                    EdgeTarget::from_pose(&pose, spec.edge_length().unwrap_or(f64::INFINITY));
                let espec = EdgePlanSpec {
                    rotations: e.rotations,
                    translations: e.translations,
                    tilt: e.tilt_deg.to_radians(),
                    arc_radius: e.arc_radius_mm * 1e-3,
                    arc_span: e.arc_span_deg.to_radians(),
                    arc_heading: e.arc_heading_deg.to_radians(),
                    edge_z: e
                        .edge_z_mm
                        .map(|z| z * 1e-3)
                        .unwrap_or(rig.sensor.range_centre().z),
                };
                let plans = crate::sim::edge::plan(&rig, &target, &espec)
                    .map_err(|er| bad(file, "edge", "..", er.to_string()))?;
                let validation = e.validation.as_ref().map(|v| {
                    let c = Vector3::from(v.position_mm) * 1e-3;
                    (
                        BallTarget {
                            centre: nalgebra::Point3::from(c),
                            radius: v.ball_radius_mm * 1e-3,
                        },
                        v.groups,
                        v.translations,
                        v.sigma_mm * 1e-3,
                    )
                });
                if e.source != "raycast" && spec.edge_radius > 0.0 {
                    return Err(bad(
                        file,
                        "edge.specimen.edge_radius_mm",
                        spec.edge_radius * 1e3,
                        "a rounded edge needs edge.source = \"raycast\": where the profile's \
                         corner lands on the round depends on the profile, which only the \
                         ray-cast sensor sees",
                    ));
                }
                Some(EdgeSetup {
                    target,
                    plans,
                    scene: sc,
                    raycast: e.source == "raycast",
                    sigma: e.sigma_mm * 1e-3,
                    validation,
                    form: e.specimen.as_ref().unwrap_or(&self.specimen).form(),
                })
            }
            _ => None,
        };
        let re = self.robot_error.clone().unwrap_or_default();
        let robot_error = crate::sim::disturb::RobotError {
            repeatability: re.repeatability_mm * 1e-3,
            joint_noise: re.joint_noise_deg.to_radians(),
            link_error: re.link_error_mm * 1e-3,
            joint_offset_error: re.joint_offset_error_deg.to_radians(),
        };
        let vibration = self
            .vibration
            .as_ref()
            .map(|v| crate::sim::disturb::Vibration {
                amplitude_rms: v.amplitude_mm * 1e-3,
                band_low_hz: v.band_low_hz,
                band_high_hz: v.band_high_hz,
                profile_rate_hz: v.profile_rate_hz,
            })
            .unwrap_or_default();
        Ok(Setup {
            rig,
            scene,
            specimen,
            base_to_specimen,
            disk,
            ball,
            edge,
            robot_error,
            vibration,
            dynamics: self.dynamics.clone(),
        })
    }
}

impl SpecimenKind {
    fn is_disk_kind(&self) -> bool {
        matches!(
            self,
            SpecimenKind::DiskOnCylinder { .. } | SpecimenKind::DiskOnPaper { .. }
        )
    }
}
