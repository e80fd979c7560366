//! The scenario file's sections that every method shares (the methods' own sections are
//! `schema::<kind>`). Lengths in mm and angles in the unit their name says, as the user writes
//! them; `build` converts to SI once.

use super::{ScenarioError, Validator};
use crate::scene::{FormTolerance, Specimen, SpecimenKind, SpecimenType};
use serde::Deserialize;

fn d_true() -> bool {
    true
}
fn d_reflectance() -> f64 {
    0.3
}

/// Where a method's features come from.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "lowercase")]
pub enum Source {
    /// Exact features from the analytic geometry plus the paper's noise model.
    #[default]
    Analytic,
    /// Profiles ray-cast through the sensor model, features extracted from them.
    Raycast,
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
    /// A preset by name (`gocator-2340`, `vlm350`, ...)...
    #[serde(default)]
    pub preset: Option<String>,
    /// ...or the sensor's geometry (docs/sensors.md).
    #[serde(default)]
    pub geometry: Option<super::sensor::GeometrySection>,
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
    /// The sensor's noise ([sensor.noise]); none when left out.
    #[serde(default)]
    pub noise: NoiseSection,
}

#[derive(Debug, Clone, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct NoiseSection {
    /// Gaussian z noise (one standard deviation, mm) at the near end of the range; it grows
    /// linearly to z_sigma_far_mm at the far end.
    #[serde(default)]
    pub z_sigma_near_mm: f64,
    /// Gaussian z noise (one standard deviation, mm) at the far end of the range.
    #[serde(default)]
    pub z_sigma_far_mm: f64,
    /// Gaussian noise along the laser line (x), one standard deviation, mm.
    #[serde(default)]
    pub x_sigma_mm: f64,
    /// Probability (0..1) that a point is missing.
    #[serde(default)]
    pub dropout: f64,
    /// Probability (0..1) of an outlier on a specular surface (the ball).
    #[serde(default)]
    pub outlier_rate: f64,
    /// The outliers' spread, one standard deviation, mm.
    #[serde(default)]
    pub outlier_amplitude_mm: f64,
    /// Intensity (0..1) below which a point counts as dark.
    #[serde(default)]
    pub dark_threshold: f64,
    /// A dark point's noise as a multiple of the normal noise.
    #[serde(default)]
    pub dark_noise_factor: f64,
    /// Probability (0..1) that a dark point is missing.
    #[serde(default)]
    pub dark_dropout: f64,
}

#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SpecimenSection {
    /// The specimen: disk-cylinder, disk-paper, ball, parallel-bar, scale, knife-blade, ridge,
    /// v-groove, fillet or step.
    pub kind: SpecimenType,
    /// The specimen frame's origin in the base frame, mm (each kind's frame:
    /// docs/guide/scenarios.md).
    pub position_mm: [f64; 3],
    /// Orientation (rx, ry, rz) degrees, R = Rz Ry Rx; for a disk its z axis is the normal.
    #[serde(default)]
    pub rpy_deg: [f64; 3],
    /// A disk's or ball's radius, mm.
    pub radius_mm: Option<f64>,
    /// A disk's cylinder, a bar's height, a ridge's or groove's depth or a step's riser, mm.
    pub height_mm: Option<f64>,
    /// Half the side of a disk-paper's black square, mm.
    pub paper_half_mm: Option<f64>,
    /// The ball's post radius, mm.
    pub post_radius_mm: Option<f64>,
    /// The ball's post height below the ball, mm.
    pub post_height_mm: Option<f64>,
    /// An edge specimen's length along its line, mm.
    pub length_mm: Option<f64>,
    /// An edge specimen's width across its line (a fillet's face length from the corner), mm.
    pub width_mm: Option<f64>,
    /// A scale's or knife blade's thickness, mm.
    pub thickness_mm: Option<f64>,
    /// A knife blade's bevel width, mm.
    pub bevel_mm: Option<f64>,
    /// Diffuse reflectance 0..1 (what the profile's intensity reports).
    pub reflectance: Option<f64>,
    /// Specimen imperfection: standard deviation of the true disk or ball radius around the nominal
    /// one (drawn per trial; the calibration is told the nominal radius).
    pub radius_tolerance_mm: Option<f64>,
    /// Form tolerances, peak-to-valley (the form error's orientation is drawn per trial): disk
    /// flatness (a saddle warp), ball sphericity (an ellipsoid), edge straightness (a bow).
    pub flatness_mm: Option<f64>,
    /// A ball's form error (an ellipsoid), peak to valley, mm.
    pub sphericity_mm: Option<f64>,
    /// An edge specimen's line bowed by this much, peak to valley, mm.
    pub straightness_mm: Option<f64>,
    /// Radius to which a parallel bar's or scale's edge is rounded (ray-cast sources only).
    pub edge_radius_mm: Option<f64>,
}

impl SpecimenSection {
    /// The form tolerances, metres.
    pub fn form(&self) -> FormTolerance {
        FormTolerance {
            flatness: self.flatness_mm.unwrap_or(0.0) * 1e-3,
            sphericity: self.sphericity_mm.unwrap_or(0.0) * 1e-3,
            straightness: self.straightness_mm.unwrap_or(0.0) * 1e-3,
        }
    }

    pub fn scale_imperfection(&mut self, k: f64) {
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

    /// The specimen this section describes (SI units), its values checked; `key` prefixes the
    /// keys in errors ("specimen", "ball.specimen").
    pub fn kind_checked(&self, key: &str, v: &Validator) -> Result<SpecimenKind, ScenarioError> {
        let k = |name: &str| format!("{key}.{name}");
        let need = |name: &str, value: Option<f64>| -> Result<f64, ScenarioError> {
            match value {
                Some(x) => v.length(&k(name), x),
                None => Err(v.bad(
                    &k(name),
                    "(missing)",
                    format!("a {} needs {name}", self.kind),
                )),
            }
        };
        let opt = |value: Option<f64>, default_mm: f64, name: &str| {
            need(name, Some(value.unwrap_or(default_mm)))
        };
        let kind = match self.kind {
            SpecimenType::DiskCylinder => SpecimenKind::DiskOnCylinder {
                radius: need("radius_mm", self.radius_mm)?,
                height: opt(self.height_mm, 20.0, "height_mm")?,
            },
            SpecimenType::DiskPaper => SpecimenKind::DiskOnPaper {
                radius: need("radius_mm", self.radius_mm)?,
                paper_half: opt(self.paper_half_mm, 150.0, "paper_half_mm")?,
            },
            SpecimenType::Ball => SpecimenKind::BallOnPost {
                radius: need("radius_mm", self.radius_mm)?,
                post_radius: opt(self.post_radius_mm, 8.0, "post_radius_mm")?,
                post_height: opt(self.post_height_mm, 80.0, "post_height_mm")?,
            },
            SpecimenType::ParallelBar => SpecimenKind::ParallelBar {
                length: opt(self.length_mm, 150.0, "length_mm")?,
                width: opt(self.width_mm, 25.0, "width_mm")?,
                height: opt(self.height_mm, 12.0, "height_mm")?,
            },
            SpecimenType::Scale => SpecimenKind::Scale {
                length: opt(self.length_mm, 300.0, "length_mm")?,
                width: opt(self.width_mm, 30.0, "width_mm")?,
                thickness: opt(self.thickness_mm, 1.0, "thickness_mm")?,
            },
            SpecimenType::KnifeBlade => SpecimenKind::KnifeBlade {
                length: opt(self.length_mm, 125.0, "length_mm")?,
                width: opt(self.width_mm, 18.0, "width_mm")?,
                thickness: opt(self.thickness_mm, 0.6, "thickness_mm")?,
                bevel: opt(self.bevel_mm, 1.0, "bevel_mm")?,
            },
            SpecimenType::Ridge => SpecimenKind::Ridge {
                length: opt(self.length_mm, 150.0, "length_mm")?,
                width: opt(self.width_mm, 40.0, "width_mm")?,
                height: opt(self.height_mm, 15.0, "height_mm")?,
            },
            SpecimenType::VGroove => SpecimenKind::VGroove {
                length: opt(self.length_mm, 150.0, "length_mm")?,
                width: opt(self.width_mm, 40.0, "width_mm")?,
                height: opt(self.height_mm, 15.0, "height_mm")?,
            },
            SpecimenType::Step => SpecimenKind::Step {
                // Long enough that an oblique profile does not run off its end (line-targets.md).
                length: opt(self.length_mm, 300.0, "length_mm")?,
                width: opt(self.width_mm, 40.0, "width_mm")?,
                height: opt(self.height_mm, 10.0, "height_mm")?,
            },
            SpecimenType::Fillet => SpecimenKind::Fillet {
                length: opt(self.length_mm, 150.0, "length_mm")?,
                width: opt(self.width_mm, 40.0, "width_mm")?,
            },
            SpecimenType::Plane => {
                return Err(v.bad(
                    &k("kind"),
                    "\"plane\"",
                    "the plane method's plane is the table's face: give [table] height_mm and \
                     [plane], and place another specimen here (or none is needed)",
                ));
            }
        };
        if let Some(t) = self.radius_tolerance_mm {
            v.non_negative(&k("radius_tolerance_mm"), t)?;
        }
        let is_edge = Specimen::new(kind.clone()).is_edge();
        let rounded = matches!(
            kind,
            SpecimenKind::ParallelBar { .. } | SpecimenKind::Scale { .. }
        );
        for (field, value, allowed, applies) in [
            (
                "flatness_mm",
                self.flatness_mm,
                kind.is_disk() || rounded,
                "a disk or a plate (parallel-bar, scale)",
            ),
            (
                "sphericity_mm",
                self.sphericity_mm,
                matches!(kind, SpecimenKind::BallOnPost { .. }),
                "a ball",
            ),
            (
                "straightness_mm",
                self.straightness_mm,
                is_edge,
                "an edge specimen",
            ),
            (
                "edge_radius_mm",
                self.edge_radius_mm,
                rounded,
                "a parallel bar or a scale",
            ),
        ] {
            let Some(value) = value else { continue };
            v.non_negative(&k(field), value)?;
            if !allowed {
                return Err(v.bad(
                    &k(field),
                    value,
                    format!("applies to {applies}, not to {}", self.kind),
                ));
            }
        }
        if let (Some(f), Some(s)) = (self.flatness_mm, self.straightness_mm)
            && f > 0.0
            && s > 0.0
        {
            return Err(v.bad(
                &k("flatness_mm"),
                f,
                "a plate takes one form error at a time: give flatness_mm or straightness_mm",
            ));
        }
        if let Some(r) = self.reflectance {
            v.probability_like(&k("reflectance"), r, "must be in 0..1")?;
        }
        Ok(kind)
    }
}

#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TableSection {
    /// The table's height (z) in the base frame, mm.
    pub height_mm: f64,
    /// The table's diffuse reflectance, 0..1.
    #[serde(default = "d_reflectance")]
    pub reflectance: f64,
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
    /// Systematic joint zero offsets per trial, one standard deviation, deg.
    #[serde(default)]
    pub joint_offset_error_deg: f64,
}

/// The specimen placed anew for each trial: slid on the table by an offset drawn per trial.
#[derive(Debug, Clone, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct PlacementSection {
    /// Largest slide along the base's x and y, mm: each trial's offset is uniform within plus or
    /// minus this per axis (from the trial's seed), so the scans meet the sensor's columns at
    /// another phase each trial, as placements of a real specimen do.
    pub jitter_mm: f64,
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
    /// Servo damping gain, 1/s.
    #[serde(default = "d_damping")]
    pub damping: f64,
    /// Joint speed as a fraction of the axis limits.
    #[serde(default = "d_speed")]
    pub speed_fraction: f64,
    /// The dynamics' time step, ms.
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
    /// Lower end of the vibration's frequency band, Hz.
    pub band_low_hz: f64,
    /// Upper end of the vibration's frequency band, Hz.
    pub band_high_hz: f64,
    /// The rate at which profiles are taken (the Gocator: about 170 Hz).
    pub profile_rate_hz: f64,
}

/// A physical cause of error a scenario can keep alone (`[causes] only`).
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum Cause {
    All,
    None,
    /// Sensor noise.
    Sensor,
    Repeatability,
    /// Joint (encoder) noise.
    Encoder,
    /// Link-length and joint-offset error.
    Kinematic,
    Vibration,
    /// Radius tolerance and form error.
    Specimen,
}

impl std::str::FromStr for Cause {
    type Err = toml::de::Error;
    /// A cause by its scenario name (`"vibration"`).
    fn from_str(s: &str) -> Result<Cause, toml::de::Error> {
        toml::Value::String(s.to_string()).try_into()
    }
}

/// The causes that can be kept alone, by name.
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
    /// Keep this cause alone: all, none, sensor, repeatability, encoder, kinematic, vibration or
    /// specimen.
    #[serde(default = "d_all")]
    pub only: Cause,
    /// Multiplies the magnitude of every cause kept (1 = as configured).
    #[serde(default = "d_scale")]
    pub scale: f64,
}

fn d_all() -> Cause {
    Cause::All
}
fn d_scale() -> f64 {
    1.0
}

#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SweepSection {
    /// Trials per grid point.
    pub trials: usize,
    /// Dotted scenario keys and the values each takes; the sweep runs their Cartesian product.
    pub grid: toml::Table,
    /// "independent" (the default): each grid point's trials draw their own numbers; "common":
    /// trial t draws the same numbers at every point (common random numbers: differences between
    /// points are sharper, but every point's estimate errs alike).
    #[serde(default)]
    pub draws: Draws,
    /// What plot.svg and plot.png draw ([sweep.plot]).
    #[serde(default)]
    pub plot: Option<PlotSection>,
}

/// How a sweep's grid points share their random draws (`[sweep] draws`).
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum Draws {
    Common,
    #[default]
    Independent,
}

#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PlotSection {
    /// Grid key on the x axis.
    pub x: String,
    /// Grid key that makes one curve per value.
    #[serde(default)]
    pub series: Option<String>,
    /// Summary column on the y axis, e.g. centre_error_mm_std.
    pub y: String,
    /// A logarithmic x axis.
    #[serde(default)]
    pub log_x: bool,
    /// A logarithmic y axis.
    #[serde(default)]
    pub log_y: bool,
    /// The plot's title (default: the scenario's name and the keys).
    #[serde(default)]
    pub title: Option<String>,
    /// The paper figure or table the sweep reproduces: its published points are overlaid.
    #[serde(default)]
    pub paper: Option<PaperFigure>,
}

/// Published results a plot can overlay (`crate::papers`).
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum PaperFigure {
    /// Chen et al. 2018, Fig. 15: disk-centre error std vs chords, per sigma (points quoted in the
    /// text).
    Chen2018Fig15,
    /// Xu et al., Table 1: mean edge-direction deviation vs rotations, per specimen.
    Xu2021Table1,
}
