//! The capture file (JSON, version 1): the format adapter between `Captures` and the disk. Units
//! at the edge are the papers' (mm); inside, metres. Documented in docs/captures.md.

use super::FormatError;
use crate::captures::{CaptureProfile, Captures, Group, Judging, ProfileData, Role};
use crate::features::{Circle, EdgeSense};
use crate::method::{Kind, method};
use crate::scene::SpecimenType;
use crate::schema::sensor::{GeometrySection, ZAxis};
use crate::sensor::{Profile, ProfilePoint, SensorModel};
use nalgebra::{Isometry3, Matrix3, Quaternion, Translation3, UnitQuaternion, Vector2, Vector3};
use serde::{Deserialize, Serialize};
use std::path::Path;

pub const FORMAT: &str = "lasercal-captures";
pub const VERSION: u32 = 1;

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileV1 {
    /// Always "lasercal-captures".
    format: String,
    /// The format version: 1.
    version: u32,
    /// The specimen method the captures are for: disk, ball, edge or plane.
    method: String,
    /// The sensor: a preset's name, its declared geometry, `"points-only"` or
    /// `{"points_only": {"z_axis": ...}}`; left out, a sensor known only by its points.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    sensor: Option<SensorV1>,
    /// The sensor's noise figures (mm); left out, the noise is measured from the raw profiles.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    sensor_noise: Option<NoiseV1>,
    /// The specimen's kind and, for a disk or ball, its radius.
    specimen: SpecimenV1,
    /// Edge: whether the profiles cross the edge falling (off the face) or rising; inferred when
    /// left out.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    edge_sense: Option<EdgeSense>,
    /// The true mounting (4x4 row-major, mm) when known (a simulation): the errors against it are
    /// printed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    truth_flange_to_sensor_mm: Option<[[f64; 4]; 4]>,
    /// The mounting as drawn (4x4, mm): a result far from it is suspect (a mirrored sensor).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    nominal_flange_to_sensor_mm: Option<[[f64; 4]; 4]>,
    /// How far apart (deg) a protocol's "one orientation" captures may be (default 0.1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    orientation_tolerance_deg: Option<f64>,
    /// The noise (mm, one standard deviation) of the features a file gives as such (chords,
    /// circles' arc points, edge points); the verdict's residual test needs it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    feature_sigma_mm: Option<f64>,
    /// The verdict's tolerance on the 95 % error bound (deg, mm; defaults 0.5 and 0.5).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    tolerance_deg: Option<f64>,
    /// The verdict's tolerance on the translation's 95 % error bound, mm (default 0.5).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    tolerance_mm: Option<f64>,
    /// The robot's pose accuracy (mm, one standard deviation of a point's offset) the residual
    /// test allows beside the sensor noise (default 0.5).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    robot_accuracy_mm: Option<f64>,
    /// The robot's repeatability (mm, one standard deviation per axis of each pose's own error,
    /// about ISO 9283's RP / 3.6; default 0): the residual test allows it with the accuracy,
    /// and the bound takes it as independent from pose to pose.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    robot_repeatability_mm: Option<f64>,
    /// The arm that took the poses: irb120, irb2600 or a URDF file's path (relative to this
    /// file). Named, every pose is checked to be within its reach; with `link_error_mm` or
    /// `joint_offset_error_deg` the verdict's bound carries the arm's kinematic error through
    /// each pose's joint configuration (docs/verdict.md).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    robot: Option<String>,
    /// One standard deviation of each joint origin's offset along each axis (a link-length
    /// error), mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    link_error_mm: Option<f64>,
    /// One standard deviation of each joint's zero, deg.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    joint_offset_error_deg: Option<f64>,
    /// The raw profiles' points in a compressed array beside this file (`io::points_file`),
    /// each profile naming its row.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    points_file: Option<String>,
    /// The controller's log of flange poses while the arm moved (scanning on the move): each
    /// profile then gives its time `t_s` instead of a pose, and its flange pose is interpolated
    /// between the two logged poses around that time (linear in position, spherical in rotation).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pose_stream: Option<Vec<PoseSampleV1>>,
    /// Seconds to add to a profile's `t_s` to put it on the pose stream's clock (the profiler's
    /// latency against the controller's; default 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    profile_clock_offset_s: Option<f64>,
    /// With a pose_stream: estimate the offset's error with the transform (default true), or hold
    /// the stated offset (false).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    estimate_clock_offset: Option<bool>,
    /// With estimate_clock_offset: estimate a drift of the profiler's clock too (s per s;
    /// default false).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    estimate_clock_drift: Option<bool>,
    /// The capture groups (scans, rotation sets, poses), each with its role and sign.
    groups: Vec<GroupV1>,
    /// One record per profile: its group, the flange pose and the profile or its feature.
    profiles: Vec<ProfileV1>,
}

/// The sensor: a preset's name, its geometry, or only the frame its points are in
/// (docs/sensors.md).
#[derive(Serialize, Deserialize)]
#[serde(untagged)]
enum SensorV1 {
    Preset(String),
    PointsOnly { points_only: PointsOnlyV1 },
    Geometry(GeometrySection),
}

/// The name that stands for a sensor known only by its points.
pub const POINTS_ONLY: &str = "points-only";

/// A sensor known only by its points: which way its z axis points, when the file says.
#[derive(Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct PointsOnlyV1 {
    /// Which way the sensor's z axis points: away or toward (needed for a disk's or an edge's raw
    /// profiles).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    z_axis: Option<ZAxis>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct NoiseV1 {
    /// Gaussian z noise at the near end of the range, one standard deviation, mm.
    z_sigma_near_mm: f64,
    /// Gaussian z noise at the far end of the range, mm.
    z_sigma_far_mm: f64,
    /// Gaussian noise along the laser line, mm.
    x_sigma_mm: f64,
    /// A dark point's noise as a multiple of the normal noise.
    #[serde(default)]
    dark_noise_factor: f64,
    /// 0: continuous z.
    z_quantum_mm: f64,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct SpecimenV1 {
    /// The specimen: disk-cylinder, disk-paper, ball, parallel-bar, scale, knife-blade, ridge,
    /// v-groove, fillet, step or plane.
    kind: SpecimenType,
    /// A disk's or ball's radius, mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    radius_mm: Option<f64>,
    /// One standard deviation of the true radius about `radius_mm` (a certificate's standard
    /// uncertainty), mm; left out: the radius is taken as exact.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    radius_tolerance_mm: Option<f64>,
    /// A straight edge's straightness tolerance, mm peak to valley over `edge_length_mm`; left
    /// out: the edge is taken as straight.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    straightness_mm: Option<f64>,
    /// The length the straightness applies to, mm; left out: the span the profiles see.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    edge_length_mm: Option<f64>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct GroupV1 {
    /// The group's number, which profiles name.
    id: usize,
    /// scan (disk), rotation or translation (ball), rotation-group (edge), or pose (one profile
    /// each).
    role: Role,
    /// The group sign s_i (+1 or -1; 0 or left out: not recorded, inferred where the data tell
    /// it).
    #[serde(default)]
    sign: f64,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct CircleV1 {
    /// The arc circle's centre (x, z) in the sensor frame, mm.
    centre: [f64; 2],
    /// The arc circle's radius, mm.
    radius: f64,
}

/// One logged flange pose with its time on the controller's clock.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct PoseSampleV1 {
    /// The time the pose was logged, s (any origin; strictly increasing along the stream).
    t_s: f64,
    /// The flange (tool0) position in the base frame, mm.
    tcp_position_mm: [f64; 3],
    /// The flange orientation as a unit quaternion (w, x, y, z).
    tcp_quaternion_wxyz: [f64; 4],
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ProfileV1 {
    /// The id of the group the profile belongs to.
    group: usize,
    /// The flange (tool0) position in the base frame, mm (left out: `t_s` with a pose stream).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    tcp_position_mm: Option<[f64; 3]>,
    /// The flange orientation as a unit quaternion (w, x, y, z) (left out: `t_s` with a pose
    /// stream).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    tcp_quaternion_wxyz: Option<[f64; 4]>,
    /// The profile's time stamp on the profiler's clock, s: its flange pose is interpolated from
    /// the file's `pose_stream` at `t_s + profile_clock_offset_s`, in place of the tcp fields.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    t_s: Option<f64>,
    /// The raw profile: one [x, z] per sensor column in the sensor frame (mm), null where the
    /// sensor saw nothing.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    points_mm: Option<Vec<Option<[f64; 2]>>>,
    /// Each entry's intensity (0..1), null where there is no point.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    intensity: Option<Vec<Option<f64>>>,
    /// The sensor column of each entry of points_mm, when the list is not one entry per column.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    columns: Option<Vec<usize>>,
    /// The arm's joint values at this pose (deg, joint 1 first) as the controller logged
    /// them: with `robot`, the configuration the kinematic error is carried through (else the
    /// inverse kinematics' nearest solution, and the verdict weighs the arm's other
    /// configurations too, saying when one would move the result by more than 1.25 times as
    /// much) and checked against the pose.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    joints_deg: Option<[f64; 6]>,
    /// The row of `points_file` holding this profile's points and intensities, in place of
    /// points_mm and intensity.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    points_row: Option<usize>,
    /// How many entries of that row are this profile's, when fewer than the row's width.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    points_len: Option<usize>,
    /// Disk: the chord's two ends [[x, z], [x, z]] in the sensor frame, mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    chord_mm: Option<[[f64; 2]; 2]>,
    /// Ball: the arc circle fitted in the sensor frame.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    circle_mm: Option<CircleV1>,
    /// Ball: the arc's points [[x, z], ...] in the sensor frame, mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    arc_mm: Option<Vec<[f64; 2]>>,
    /// Edge: the edge point [x, z] in the sensor frame, mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    edge_point_mm: Option<[f64; 2]>,
}

/// A pose log as the capture file's `pose_stream` records.
fn stream_records(t: &crate::captures::Timing) -> Vec<PoseSampleV1> {
    t.stream
        .iter()
        .map(|(s, f)| {
            let p = f.translation.vector * 1e3;
            PoseSampleV1 {
                t_s: *s,
                tcp_position_mm: [p.x, p.y, p.z],
                tcp_quaternion_wxyz: crate::math::quat_wxyz(&f.rotation),
            }
        })
        .collect()
}

/// Serialise captures (with the sensor model whose noise tuned the feature extraction).
pub fn to_json(c: &Captures, sensor: &SensorModel) -> String {
    // The log and the stamps, when every profile has one.
    let timing = c
        .timing
        .as_ref()
        .filter(|t| t.stamps.len() == c.profiles.len() && t.stream.len() >= 2);
    let v2 = |v: &Vector2<f64>| [v.x * 1e3, v.y * 1e3];
    let n = &sensor.noise;
    let file = FileV1 {
        format: FORMAT.into(),
        version: VERSION,
        method: c.method.to_string(),
        orientation_tolerance_deg: (c.orientation_tolerance_deg
            != crate::calib::ORIENTATION_TOLERANCE_DEG)
            .then_some(c.orientation_tolerance_deg),
        feature_sigma_mm: c.feature_sigma.map(|s| s * 1e3),
        tolerance_deg: (c.judging.tolerance_deg != Judging::DEFAULT_TOLERANCE_DEG)
            .then_some(c.judging.tolerance_deg),
        tolerance_mm: (c.judging.tolerance_mm != Judging::DEFAULT_TOLERANCE_MM)
            .then_some(c.judging.tolerance_mm),
        robot_accuracy_mm: Some(c.judging.robot_accuracy * 1e3),
        robot_repeatability_mm: (c.judging.robot_repeatability > 0.0)
            .then_some(c.judging.robot_repeatability * 1e3),
        robot: c.kinematic.as_ref().map(|k| k.robot_name.clone()),
        link_error_mm: c
            .kinematic
            .as_ref()
            .filter(|k| k.errors_stated)
            .map(|k| k.link_sd * 1e3),
        joint_offset_error_deg: c
            .kinematic
            .as_ref()
            .filter(|k| k.errors_stated)
            .map(|k| k.joint_zero_sd.to_degrees()),
        sensor: Some(if sensor.points_only {
            SensorV1::PointsOnly {
                points_only: PointsOnlyV1 {
                    z_axis: Some(if sensor.dir_z > 0.0 {
                        ZAxis::Away
                    } else {
                        ZAxis::Toward
                    }),
                },
            }
        } else if sensor.is_preset() {
            SensorV1::Preset(sensor.name.clone())
        } else {
            SensorV1::Geometry(GeometrySection::from_geometry(&sensor.geometry()))
        }),
        sensor_noise: Some(NoiseV1 {
            z_sigma_near_mm: n.z_sigma_near * 1e3,
            z_sigma_far_mm: n.z_sigma_far * 1e3,
            x_sigma_mm: n.x_sigma * 1e3,
            dark_noise_factor: n.dark_noise_factor,
            z_quantum_mm: sensor.z_quantum.unwrap_or(0.0) * 1e3,
        }),
        specimen: SpecimenV1 {
            kind: c.specimen_kind,
            radius_mm: c.specimen_radius.map(|r| r * 1e3),
            radius_tolerance_mm: (c.judging.radius_tolerance > 0.0)
                .then_some(c.judging.radius_tolerance * 1e3),
            straightness_mm: (c.judging.straightness > 0.0).then_some(c.judging.straightness * 1e3),
            edge_length_mm: c
                .judging
                .edge_length
                .filter(|_| c.judging.straightness > 0.0)
                .map(|l| l * 1e3),
        },
        edge_sense: c.edge_sense,
        truth_flange_to_sensor_mm: c.truth.as_ref().map(crate::math::pose_to_rows_mm),
        nominal_flange_to_sensor_mm: c.judging.nominal.as_ref().map(crate::math::pose_to_rows_mm),
        points_file: None,
        pose_stream: timing.map(stream_records),
        profile_clock_offset_s: timing.map(|t| t.offset_s).filter(|o| *o != 0.0),
        estimate_clock_offset: timing.and_then(|t| (!t.estimate_offset).then_some(false)),
        estimate_clock_drift: timing.and_then(|t| t.estimate_drift.then_some(true)),
        groups: c
            .groups
            .iter()
            .map(|g| GroupV1 {
                id: g.id,
                role: g.role,
                sign: g.sign,
            })
            .collect(),
        profiles: c
            .profiles
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let t = p.base_to_flange.translation.vector * 1e3;
                // Placed by time: the stamp stands for the pose (which the log gives back).
                let stamp = timing.map(|t| t.stamps[i]);
                let mut rec = ProfileV1 {
                    group: p.group,
                    tcp_position_mm: stamp.is_none().then_some([t.x, t.y, t.z]),
                    tcp_quaternion_wxyz: stamp
                        .is_none()
                        .then(|| crate::math::quat_wxyz(&p.base_to_flange.rotation)),
                    t_s: stamp,
                    points_mm: None,
                    intensity: None,
                    columns: None,
                    joints_deg: c
                        .kinematic
                        .as_ref()
                        .and_then(|k| k.joints_given(&p.base_to_flange))
                        .map(|q| q.map(f64::to_degrees)),
                    points_row: None,
                    points_len: None,
                    chord_mm: None,
                    circle_mm: None,
                    arc_mm: None,
                    edge_point_mm: None,
                };
                match &p.data {
                    ProfileData::Raw(prof) => {
                        rec.points_mm = Some(
                            prof.points
                                .iter()
                                .map(|q| q.map(|q| [q.x * 1e3, q.z * 1e3]))
                                .collect(),
                        );
                        rec.intensity =
                            Some(prof.points.iter().map(|q| q.map(|q| q.intensity)).collect());
                    }
                    ProfileData::Chord { a, b } => rec.chord_mm = Some([v2(a), v2(b)]),
                    ProfileData::Circle(ci) => {
                        rec.circle_mm = Some(CircleV1 {
                            centre: v2(&ci.centre),
                            radius: ci.radius * 1e3,
                        })
                    }
                    ProfileData::Arc(a) => rec.arc_mm = Some(a.iter().map(v2).collect()),
                    ProfileData::EdgePoint(q) => rec.edge_point_mm = Some(v2(q)),
                }
                rec
            })
            .collect(),
    };
    serde_json::to_string(&file).unwrap_or_default()
}

fn err(file: &str, at: &str, msg: impl std::fmt::Display) -> FormatError {
    FormatError::Field {
        file: file.to_string(),
        at: at.to_string(),
        message: msg.to_string(),
    }
}

/// Parse a capture file; errors name the file, the record and the field. Returns the captures and
/// the sensor model to extract features with (the preset, with the file's noise figures).
///
/// A file whose points are in a `points_file` is read with `read`, which knows its folder.
pub fn from_json(text: &str, file: &str) -> Result<(Captures, SensorModel), FormatError> {
    let f = parse(text, file)?;
    if let Some(p) = &f.points_file {
        return Err(err(
            file,
            "points_file",
            format!(
                "'{p}': read the file from disk (lasercal::io::captures::read) so its points file can be found beside it"
            ),
        ));
    }
    from_file(f, file)
}

/// Read a capture file from disk, with its points file when it has one (`write_compact`).
pub fn read(path: &Path) -> Result<(Captures, SensorModel), crate::error::Error> {
    let name = path.display().to_string();
    let text =
        std::fs::read_to_string(path).map_err(|e| crate::error::Error::io(path, "read", e))?;
    let mut f = parse(&text, &name)?;
    if let Some(p) = f.points_file.clone() {
        let dir = path.parent().unwrap_or(Path::new(""));
        inflate(&mut f, &dir.join(&p), &name)?;
    }
    Ok(from_file(f, &name)?)
}

fn parse(text: &str, file: &str) -> Result<FileV1, FormatError> {
    serde_json::from_str(text).map_err(|e| FormatError::Invalid {
        file: file.to_string(),
        what: "capture file",
        message: e.to_string(),
    })
}

/// Fill each profile that names a row of the points file with that row's points.
fn inflate(f: &mut FileV1, points: &Path, file: &str) -> Result<(), FormatError> {
    let pname = points.display().to_string();
    let rows_needed = f
        .profiles
        .iter()
        .filter_map(|p| p.points_row)
        .max()
        .map_or(0, |r| r + 1);
    let reader = std::fs::File::open(points).map_err(|e| {
        err(
            file,
            "points_file",
            format!("{pname} cannot be read ({e}): keep it beside the capture file, under the name the file gives"),
        )
    })?;
    let (mut rows, width) =
        super::points_file::decode(std::io::BufReader::new(reader), &pname, rows_needed)?;
    let mut taken = vec![false; rows.len()];
    for (i, p) in f.profiles.iter_mut().enumerate() {
        let Some(r) = p.points_row else { continue };
        if std::mem::replace(&mut taken[r], true) {
            return Err(err(
                file,
                &format!("profiles[{i}].points_row"),
                format!("{r}: another profile names this row; each profile has its own"),
            ));
        }
        if p.points_mm.is_some() || p.intensity.is_some() {
            return Err(err(
                file,
                &format!("profiles[{i}]"),
                "give points_row or points_mm and intensity, not both",
            ));
        }
        let len = p.points_len.unwrap_or(width);
        if len > width {
            return Err(err(
                file,
                &format!("profiles[{i}].points_len"),
                format!("{len}: the rows of {pname} hold {width} entries"),
            ));
        }
        let mut row = std::mem::take(&mut rows[r]);
        row.truncate(len);
        p.intensity = Some(row.iter().map(|e| e.1).collect());
        p.points_mm = Some(row.into_iter().map(|e| e.0).collect());
    }
    Ok(())
}

/// The compact form of a capture file's text: its raw profiles' points moved into an array
/// (`io::points_file`) that is to be written as `points_name` beside it. Returns the new text and
/// the array's bytes (None: the file has no raw profiles, and its text is unchanged).
pub fn compact(
    text: &str,
    file: &str,
    points_name: &str,
) -> Result<(String, Option<Vec<u8>>), FormatError> {
    let mut f = parse(text, file)?;
    let mut rows = Vec::new();
    for p in f.profiles.iter_mut() {
        let Some(points) = p.points_mm.take() else {
            continue;
        };
        let intensity = p.intensity.take().unwrap_or_default();
        p.points_row = Some(rows.len());
        rows.push(
            points
                .into_iter()
                .enumerate()
                .map(|(j, q)| (q, intensity.get(j).copied().flatten()))
                .collect::<super::points_file::Row>(),
        );
    }
    if rows.is_empty() {
        return Ok((text.to_string(), None));
    }
    let width = rows.iter().map(Vec::len).max().unwrap_or(0);
    for (p, row) in f
        .profiles
        .iter_mut()
        .filter(|p| p.points_row.is_some())
        .zip(&rows)
    {
        p.points_len = (row.len() < width).then_some(row.len());
    }
    f.points_file = Some(points_name.to_string());
    let bytes = super::points_file::encode(&rows)?;
    Ok((serde_json::to_string(&f).unwrap_or_default(), Some(bytes)))
}

/// The name of the points file written beside capture file `path` (`NAME.points.npy.gz`).
pub fn points_file_name(path: &Path) -> String {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "captures".into());
    format!("{stem}.points.npy.gz")
}

/// Write capture file text to `path`; `compact`: its raw profiles' points go into a compressed
/// array beside it (`points_file_name`) and the JSON names it.
pub fn write(path: &Path, text: &str, compact_points: bool) -> Result<(), crate::error::Error> {
    if !compact_points {
        return super::write(path, text.as_bytes());
    }
    let name = points_file_name(path);
    let (json, bytes) = compact(text, &path.display().to_string(), &name)?;
    if let Some(b) = bytes {
        super::write(&path.with_file_name(&name), &b)?;
    }
    super::write(path, json.as_bytes())
}

fn from_file(mut f: FileV1, file: &str) -> Result<(Captures, SensorModel), FormatError> {
    if f.format != FORMAT {
        return Err(err(
            file,
            "format",
            format!("'{}' is not '{FORMAT}'", f.format),
        ));
    }
    if f.version != VERSION {
        return Err(err(
            file,
            "version",
            format!(
                "{} is not supported (this lasercal reads version {VERSION})",
                f.version
            ),
        ));
    }
    let kind: Kind = f
        .method
        .parse()
        .map_err(|e: crate::method::UnknownMethod| err(file, "method", e))?;
    let radius = radius_of(&f, kind, file)?;
    let sensor = match sensor_of(&f, kind, radius, file)? {
        s if s.points_only => s,
        s => with_measured_grid(s, &f),
    };
    let truth = f
        .truth_flange_to_sensor_mm
        .map(|m| transform_of(&m, file, "truth_flange_to_sensor_mm"))
        .transpose()?;
    let tolerance = match f.orientation_tolerance_deg {
        None => crate::calib::ORIENTATION_TOLERANCE_DEG,
        Some(t) => orientation_tolerance(t, file, "orientation_tolerance_deg")?,
    };
    let feature_sigma = match f.feature_sigma_mm {
        None => None,
        Some(s) if s.is_finite() && s >= 0.0 && s <= 1000.0 => Some(s * 1e-3),
        Some(s) => {
            return Err(err(
                file,
                "feature_sigma_mm",
                format!("{s}: the features' noise must be a number of mm from 0 to 1000"),
            ));
        }
    };
    let groups = groups_of(&f, kind, file)?;
    let clock = Clock::of(&f, file)?;
    // The fastest the flange moved at a profile placed by its time stamp (the verdict's note).
    let scan_speed = f
        .profiles
        .iter()
        .filter_map(|p| p.t_s)
        .filter_map(|t| clock.speed_at(t + clock.offset_s))
        .reduce(f64::max);
    let judging = Judging {
        scan_speed,
        ..judging_of(&f, file)?
    };
    // Kept (for a file written back) when every profile was placed by time.
    let stamps: Option<Vec<f64>> = f.profiles.iter().map(|p| p.t_s).collect();
    let timing = stamps
        .filter(|s| !s.is_empty() && clock.stream.len() >= 2)
        .map(|stamps| crate::captures::Timing {
            stream: clock.stream.clone(),
            stamps,
            offset_s: clock.offset_s,
            estimate_offset: f.estimate_clock_offset.unwrap_or(true),
            estimate_drift: f.estimate_clock_drift.unwrap_or(false),
        });
    let joints: Vec<Option<crate::robot::Joints>> = f
        .profiles
        .iter()
        .map(|p| p.joints_deg.map(|j| j.map(f64::to_radians)))
        .collect();
    // Each record dropped once converted: a continuous scan's points are not held twice.
    let profiles = std::mem::take(&mut f.profiles)
        .into_iter()
        .enumerate()
        .map(|(i, p)| profile_of(&p, i, &groups, &sensor, &clock, file))
        .collect::<Result<Vec<_>, _>>()?;
    let sensor = with_measured_noise(sensor, &profiles, f.sensor_noise.is_some());
    let kinematic = kinematic_of(
        &Stated {
            robot: f.robot.as_deref(),
            link_error_mm: f.link_error_mm,
            joint_offset_error_deg: f.joint_offset_error_deg,
            flags: false,
        },
        profiles.iter().map(|p| &p.base_to_flange).zip(joints),
        file,
        Path::new(file).parent(),
    )?;
    Ok((
        Captures {
            orientation_tolerance_deg: tolerance,
            feature_sigma,
            judging,
            timing,
            kinematic,
            method: kind,
            sensor: sensor.name.clone(),
            specimen_kind: f.specimen.kind,
            specimen_radius: radius,
            edge_sense: f.edge_sense,
            truth,
            groups,
            profiles,
        },
        sensor,
    ))
}

/// The preset, the declared geometry or the points-only sensor, with the file's noise figures.
fn sensor_of(
    f: &FileV1,
    kind: Kind,
    radius: Option<f64>,
    file: &str,
) -> Result<SensorModel, FormatError> {
    let mut sensor = match &f.sensor {
        None => points_only(f, kind, radius, None, file)?,
        Some(SensorV1::Preset(name)) if name == POINTS_ONLY => {
            points_only(f, kind, radius, None, file)?
        }
        Some(SensorV1::PointsOnly { points_only: p }) => {
            points_only(f, kind, radius, p.z_axis, file)?
        }
        Some(SensorV1::Preset(name)) => {
            SensorModel::preset(name).map_err(|e| err(file, "sensor", e))?
        }
        Some(SensorV1::Geometry(g)) => {
            let g = g.to_geometry().map_err(|(field, value, reason)| {
                err(
                    file,
                    &format!("sensor.{field}"),
                    format!("{value}: {reason}"),
                )
            })?;
            SensorModel::from_geometry(g).map_err(|e| err(file, "sensor", e))?
        }
    };
    if let Some(n) = &f.sensor_noise {
        for (k, v) in [
            ("z_sigma_near_mm", n.z_sigma_near_mm),
            ("z_sigma_far_mm", n.z_sigma_far_mm),
            ("x_sigma_mm", n.x_sigma_mm),
            ("z_quantum_mm", n.z_quantum_mm),
        ] {
            if !(v >= 0.0 && v.is_finite()) {
                return Err(err(
                    file,
                    &format!("sensor_noise.{k}"),
                    format!("{v} must be a finite number >= 0"),
                ));
            }
        }
        sensor.noise.z_sigma_near = n.z_sigma_near_mm * 1e-3;
        sensor.noise.z_sigma_far = n.z_sigma_far_mm * 1e-3;
        sensor.noise.x_sigma = n.x_sigma_mm * 1e-3;
        sensor.noise.dark_noise_factor = n.dark_noise_factor;
        sensor.z_quantum = (n.z_quantum_mm > 0.0).then_some(n.z_quantum_mm * 1e-3);
    }
    Ok(sensor)
}

/// The sensor a file that names none stands for: known by its points (`SensorModel::points_only`).
/// Its z axis as the file states it; else, for the ball, read from the arcs (the sensor sees the
/// ball's near side); a disk's or an edge's raw profiles need it stated (their features are
/// where a profile drops away from the sensor); a plane's fit does not depend on it.
fn points_only(
    f: &FileV1,
    kind: Kind,
    radius: Option<f64>,
    z_axis: Option<ZAxis>,
    file: &str,
) -> Result<SensorModel, FormatError> {
    let field = "sensor.points_only.z_axis";
    let mm = |q: &[f64; 2]| Some([q[0] * 1e-3, q[1] * 1e-3]);
    let mut raw = Vec::new();
    let mut points = Vec::new();
    for (i, p) in f.profiles.iter().enumerate() {
        if p.columns.is_some() {
            return Err(err(
                file,
                &format!("profiles[{i}].columns"),
                "columns number a named sensor's rays; a sensor known only by its points has \
                 none: drop `columns`, or name the sensor (`sensor`, docs/sensors.md)",
            ));
        }
        let pts: Vec<Option<[f64; 2]>> =
            match (&p.points_mm, p.chord_mm, &p.arc_mm, p.edge_point_mm) {
                (Some(v), ..) => v.iter().map(|q| q.as_ref().and_then(mm)).collect(),
                (_, Some(c), ..) => c.iter().map(mm).collect(),
                (_, _, Some(a), _) => a.iter().map(mm).collect(),
                (_, _, _, Some(e)) => vec![mm(&e)],
                _ => p
                    .circle_mm
                    .iter()
                    .flat_map(|c| {
                        [-1.0, 1.0].map(|s| mm(&[c.centre[0] + s * c.radius, c.centre[1]]))
                    })
                    .collect(),
            };
        if p.points_mm.is_some() {
            raw.push(pts.clone());
        }
        points.push(pts);
    }
    let stated = z_axis.map(|z| match z {
        ZAxis::Away => 1.0,
        ZAxis::Toward => -1.0,
    });
    let inferred = || {
        let r = radius?;
        let profiles: Vec<Profile> = raw
            .iter()
            .map(|pts: &Vec<Option<[f64; 2]>>| {
                let mut v: Vec<[f64; 2]> = pts.iter().flatten().copied().collect();
                v.sort_by(|a, b| a[0].total_cmp(&b[0]));
                Profile {
                    points: v
                        .iter()
                        .map(|q| {
                            Some(ProfilePoint {
                                x: q[0],
                                z: q[1],
                                intensity: 1.0,
                            })
                        })
                        .collect(),
                }
            })
            .collect();
        crate::features::view_direction_from_arcs(&profiles, r)
    };
    let dir_z = match (stated, kind) {
        (Some(d), _) => d,
        (None, Kind::Ball) => inferred().unwrap_or(-1.0),
        (None, Kind::Disk | Kind::Edge) if !raw.is_empty() => {
            return Err(err(
                file,
                field,
                format!(
                    "not given: the {kind}'s features lie where a profile drops away from the \
                     sensor, so a sensor known only by its points must say which way its z axis \
                     points: \"away\" (z grows away from the sensor, a distance) or \"toward\" \
                     (a height, as a Gocator's); or name the sensor (docs/sensors.md)"
                ),
            ));
        }
        (None, _) => -1.0,
    };
    let mut s = SensorModel::points_only(&points, dir_z).map_err(|e| err(file, "profiles", e))?;
    if stated.is_none() {
        s.name
            .push_str(if kind == Kind::Ball && inferred().is_some() {
                " (z read from the ball's arcs)"
            } else {
                " (z axis not stated)"
            });
    }
    Ok(s)
}

/// A sensor known only by its points, with no noise stated in the file: its noise is the
/// profiles' own (`features::measured_noise`), for the extraction and the verdict alike.
fn with_measured_noise(
    mut sensor: SensorModel,
    profiles: &[CaptureProfile],
    stated: bool,
) -> SensorModel {
    if !sensor.points_only || stated {
        return sensor;
    }
    let raw = profiles.iter().filter_map(|p| match &p.data {
        ProfileData::Raw(r) => Some(r),
        _ => None,
    });
    if let Some(n) = crate::features::measured_noise(raw) {
        sensor.noise.z_sigma_near = n;
        sensor.noise.z_sigma_far = n;
        sensor
            .name
            .push_str(&format!("; noise {:.4} mm measured", n * 1e3));
    }
    sensor
}

/// Profiles whose points lie on none of the declared sensor's rays but on one uniform x grid (a
/// profiler's resampled output) are read on that grid: its pitch and offset are measured from the
/// points, and the sensor becomes the declared one resampled onto it (its name says so). Otherwise
/// the sensor is returned unchanged, and points off its rays are errors later.
fn with_measured_grid(sensor: SensorModel, f: &FileV1) -> SensorModel {
    if sensor.resampling().is_some() {
        return sensor;
    }
    // Raw profiles that are not one entry per column and give no columns: those placed by ray.
    let placed: Vec<&Vec<Option<[f64; 2]>>> = f
        .profiles
        .iter()
        .filter(|p| p.columns.is_none())
        .filter_map(|p| p.points_mm.as_ref())
        .filter(|pts| pts.len() != sensor.columns)
        .collect();
    let on_rays = |q: &[f64; 2]| {
        sensor
            .column_of(q[0] * 1e-3, q[1] * 1e-3)
            .is_some_and(|k| (k - k.round()).abs() <= 0.25)
    };
    if placed.iter().all(|pts| pts.iter().flatten().all(on_rays)) {
        return sensor;
    }
    let xs: Vec<Vec<f64>> = placed
        .iter()
        .map(|pts| pts.iter().flatten().map(|q| q[0] * 1e-3).collect())
        .collect();
    let Some(grid) = crate::sensor::uniform_grid(&xs) else {
        return sensor;
    };
    let mut g = sensor.geometry();
    g.name = format!(
        "{} resampled to x = {:.6} + m {:.6} mm (measured from the profiles)",
        g.name,
        grid.offset * 1e3,
        grid.pitch * 1e3
    );
    g.resample = Some(grid);
    match SensorModel::from_geometry(g) {
        Ok(mut m) => {
            m.noise = sensor.noise;
            m.z_quantum = sensor.z_quantum;
            m
        }
        Err(_) => sensor,
    }
}

/// The specimen's radius (metres), required by the methods that need it.
fn radius_of(f: &FileV1, kind: Kind, file: &str) -> Result<Option<f64>, FormatError> {
    match f.specimen.radius_mm {
        Some(r) if r > 0.0 && r.is_finite() => Ok(Some(r * 1e-3)),
        Some(r) => Err(err(
            file,
            "specimen.radius_mm",
            format!("{r} must be a positive length"),
        )),
        None if method(kind).needs_radius() => Err(err(
            file,
            "specimen.radius_mm",
            format!("missing: the {kind} method needs it"),
        )),
        None => Ok(None),
    }
}

fn groups_of(f: &FileV1, kind: Kind, file: &str) -> Result<Vec<Group>, FormatError> {
    let mut groups: Vec<Group> = Vec::new();
    for (i, g) in f.groups.iter().enumerate() {
        // 0 (or no sign) is "not recorded": the any-pose estimator infers it; the closed form
        // then says it needs it.
        let inferable = kind
            .estimators()
            .contains(&crate::method::Estimator::AnyPose);
        let unrecorded_ok = inferable && g.sign == 0.0;
        if method(kind).uses_group_signs() && g.sign != 1.0 && g.sign != -1.0 && !unrecorded_ok {
            return Err(err(
                file,
                &format!("groups[{i}].sign"),
                if inferable {
                    format!(
                        "{}: the {kind} method's s_i is 1 or -1 (leave it out when not recorded: \
                         {kind}-any-pose infers it)",
                        g.sign
                    )
                } else {
                    format!("{}: the {kind} method needs s_i = 1 or -1", g.sign)
                },
            ));
        }
        if groups.iter().any(|x| x.id == g.id) {
            return Err(err(
                file,
                &format!("groups[{i}].id"),
                format!("{} is used twice", g.id),
            ));
        }
        groups.push(Group {
            id: g.id,
            role: g.role,
            sign: g.sign,
        });
    }
    Ok(groups)
}

/// The file's pose stream (sorted, checked) and the profiles' clock offset: what places a
/// profile given by its time.
struct Clock {
    stream: Vec<(f64, Isometry3<f64>)>,
    offset_s: f64,
}

impl Clock {
    fn of(f: &FileV1, file: &str) -> Result<Clock, FormatError> {
        let offset_s = f.profile_clock_offset_s.unwrap_or(0.0);
        if !offset_s.is_finite() {
            return Err(err(
                file,
                "profile_clock_offset_s",
                format!("{offset_s} is not a number of seconds"),
            ));
        }
        if f.estimate_clock_drift == Some(true) && f.estimate_clock_offset == Some(false) {
            return Err(err(
                file,
                "estimate_clock_drift",
                "true with estimate_clock_offset false: a drift is estimated with the offset; \
                 set estimate_clock_offset true or leave the drift out",
            ));
        }
        let Some(samples) = &f.pose_stream else {
            let given = [
                ("estimate_clock_offset", f.estimate_clock_offset.is_some()),
                ("estimate_clock_drift", f.estimate_clock_drift.is_some()),
            ];
            if let Some((field, _)) = given.iter().find(|(_, g)| *g) {
                return Err(err(
                    file,
                    field,
                    "given without a pose_stream: the profiles' clock is estimated only for \
                     profiles placed by their time stamps (t_s) on a pose_stream; add the pose \
                     log or leave the field out",
                ));
            }
            return Ok(Clock {
                stream: Vec::new(),
                offset_s,
            });
        };
        if samples.len() < 2 {
            return Err(err(
                file,
                "pose_stream",
                format!(
                    "{} samples: interpolating needs at least two (the poses before and after \
                     each profile)",
                    samples.len()
                ),
            ));
        }
        let mut stream = Vec::with_capacity(samples.len());
        for (k, s) in samples.iter().enumerate() {
            let at = |field: &str| format!("pose_stream[{k}].{field}");
            let pose = flange_pose(s.tcp_position_mm, s.tcp_quaternion_wxyz, &at, file)?;
            let previous = stream.last().map(|(t, _): &(f64, _)| *t);
            if !s.t_s.is_finite() || previous.is_some_and(|t| s.t_s <= t) {
                return Err(err(
                    file,
                    &at("t_s"),
                    format!(
                        "{}: the stream's times must be finite and strictly increasing (the \
                         sample before is at {} s); sort the log by time and drop repeated \
                         samples",
                        s.t_s,
                        previous.map_or("-".to_string(), |t| t.to_string())
                    ),
                ));
            }
            stream.push((s.t_s, pose));
        }
        Ok(Clock { stream, offset_s })
    }
}

impl Clock {
    /// The flange's speed (m/s) between the two logged poses around controller time `t`; at a
    /// logged pose's own time the slower of the two segments it joins (a scan's last pose joins
    /// the move to the next scan).
    fn speed_at(&self, t: f64) -> Option<f64> {
        let segment = |k: usize| {
            let (a, b) = (self.stream.get(k.checked_sub(1)?)?, self.stream.get(k)?);
            Some((b.1.translation.vector - a.1.translation.vector).norm() / (b.0 - a.0))
        };
        let k = self.stream.partition_point(|(s, _)| *s <= t);
        if k > 0 && self.stream[k - 1].0 == t {
            return match (segment(k - 1), segment(k)) {
                (Some(x), Some(y)) => Some(x.min(y)),
                (x, y) => x.or(y),
            };
        }
        segment(k)
    }
}

/// A flange pose from a record's position (mm) and unit quaternion (w, x, y, z), checked.
fn flange_pose(
    t: [f64; 3],
    q: [f64; 4],
    at: &dyn Fn(&str) -> String,
    file: &str,
) -> Result<Isometry3<f64>, FormatError> {
    let quat = Quaternion::new(q[0], q[1], q[2], q[3]);
    if !((quat.norm() - 1.0).abs() <= 1e-3) {
        return Err(err(
            file,
            &at("tcp_quaternion_wxyz"),
            format!("{q:?} is not a unit quaternion (norm {:.6})", quat.norm()),
        ));
    }
    if t.iter().any(|x| !x.is_finite()) {
        return Err(err(
            file,
            &at("tcp_position_mm"),
            format!("{t:?} is not finite"),
        ));
    }
    Ok(Isometry3::from_parts(
        Translation3::from(Vector3::from(t) * 1e-3),
        UnitQuaternion::from_quaternion(quat),
    ))
}

/// Profile record `i`'s flange pose: its own, or the pose stream's at its time.
fn profile_pose(
    p: &ProfileV1,
    at: &dyn Fn(&str) -> String,
    clock: &Clock,
    file: &str,
) -> Result<Isometry3<f64>, FormatError> {
    match (p.tcp_position_mm, p.tcp_quaternion_wxyz, p.t_s) {
        (Some(t), Some(q), None) => flange_pose(t, q, at, file),
        (None, None, Some(t_s)) => {
            let (Some(first), Some(last)) = (clock.stream.first(), clock.stream.last()) else {
                return Err(err(
                    file,
                    &at("t_s"),
                    format!(
                        "{t_s}: a profile given by its time needs the file's pose_stream (the \
                         controller's logged poses); add it, or give the profile's \
                         tcp_position_mm and tcp_quaternion_wxyz"
                    ),
                ));
            };
            let t = t_s + clock.offset_s;
            crate::math::pose_at(&clock.stream, t).ok_or_else(|| {
                err(
                    file,
                    &at("t_s"),
                    format!(
                        "{t_s} (+ profile_clock_offset_s {} = {t} s on the controller's clock) is \
                         outside the pose stream's {} .. {} s: start logging poses before the \
                         scan and stop after it, or check the clock offset",
                        clock.offset_s, first.0, last.0
                    ),
                )
            })
        }
        (None, None, None) => Err(err(
            file,
            &at("tcp_position_mm"),
            "missing: give the flange pose (tcp_position_mm and tcp_quaternion_wxyz) or the \
             profile's time t_s with a pose_stream",
        )),
        (_, _, Some(_)) => Err(err(
            file,
            &at("t_s"),
            "given with a tcp pose: give the pose or the time (with a pose_stream), not both",
        )),
        (Some(_), None, None) => Err(err(
            file,
            &at("tcp_quaternion_wxyz"),
            "missing beside tcp_position_mm: give both",
        )),
        (None, Some(_), None) => Err(err(
            file,
            &at("tcp_position_mm"),
            "missing beside tcp_quaternion_wxyz: give both",
        )),
    }
}

/// Profile record `i`: its flange pose and its one data field.
fn profile_of(
    p: &ProfileV1,
    i: usize,
    groups: &[Group],
    sensor: &SensorModel,
    clock: &Clock,
    file: &str,
) -> Result<CaptureProfile, FormatError> {
    let at = |k: &str| format!("profiles[{i}].{k}");
    if !groups.iter().any(|g| g.id == p.group) {
        return Err(err(
            file,
            &at("group"),
            format!("{} is not among the groups", p.group),
        ));
    }
    let base_to_flange = profile_pose(p, &at, clock, file)?;
    let v = |a: [f64; 2]| Vector2::new(a[0] * 1e-3, a[1] * 1e-3);
    let data = match (
        &p.points_mm,
        p.chord_mm,
        &p.circle_mm,
        &p.arc_mm,
        p.edge_point_mm,
    ) {
        (Some(pts), None, None, None, None) => raw_profile(pts, p, sensor, &at, file)?,
        (None, Some(c), None, None, None) => ProfileData::Chord {
            a: v(c[0]),
            b: v(c[1]),
        },
        (None, None, Some(c), None, None) => ProfileData::Circle(Circle {
            centre: v(c.centre),
            radius: c.radius * 1e-3,
            rms: 0.0,
        }),
        (None, None, None, Some(a), None) => ProfileData::Arc(a.iter().map(|q| v(*q)).collect()),
        (None, None, None, None, Some(e)) => ProfileData::EdgePoint(v(e)),
        _ => {
            return Err(err(
                file,
                &format!("profiles[{i}]"),
                "give exactly one of points_mm, chord_mm, circle_mm, arc_mm, edge_point_mm",
            ));
        }
    };
    Ok(CaptureProfile {
        group: p.group,
        base_to_flange,
        data,
    })
}

/// A raw profile: one entry per sensor column (null where the sensor saw nothing); or any number of
/// points with their columns given in `columns`; or any number of points that lie on the declared
/// sensor's rays, each placed on its ray's column.
fn raw_profile(
    pts: &[Option<[f64; 2]>],
    p: &ProfileV1,
    sensor: &SensorModel,
    at: &dyn Fn(&str) -> String,
    file: &str,
) -> Result<ProfileData, FormatError> {
    let inten = p.intensity.as_ref();
    if let Some(iv) = inten
        && iv.len() != pts.len()
    {
        return Err(err(
            file,
            &at("intensity"),
            format!("{} entries, points_mm has {}", iv.len(), pts.len()),
        ));
    }
    let point = |j: usize| {
        pts[j].map(|q| ProfilePoint {
            x: q[0] * 1e-3,
            z: q[1] * 1e-3,
            intensity: inten.and_then(|iv| iv[j]).unwrap_or(1.0),
        })
    };
    if sensor.points_only {
        // On a grid: each point in its slot; else in its place in the list.
        return Ok(ProfileData::Raw(if sensor.resampling().is_some() {
            points_in_slots(pts, sensor, &point)
        } else {
            let mut points: Vec<Option<ProfilePoint>> = (0..pts.len()).map(point).collect();
            points.resize(sensor.columns, None);
            Profile { points }
        }));
    }
    if p.columns.is_none() && pts.len() == sensor.columns {
        return Ok(ProfileData::Raw(Profile {
            points: (0..pts.len()).map(point).collect(),
        }));
    }
    let columns = match &p.columns {
        Some(c) if c.len() != pts.len() => {
            return Err(err(
                file,
                &at("columns"),
                format!("{} entries, points_mm has {}", c.len(), pts.len()),
            ));
        }
        Some(c) => c.iter().map(|&k| Some(k)).collect(),
        None => columns_on_rays(pts, sensor, at, file)?,
    };
    let mut points = vec![None; sensor.columns];
    let mut last: Option<usize> = None;
    for (j, k) in columns.into_iter().enumerate() {
        let Some(k) = k else { continue };
        if k >= sensor.columns || last.is_some_and(|l| k <= l) {
            return Err(err(
                file,
                &at("columns"),
                format!(
                    "column {k} at entry {j}: columns must increase and stay below the {}'s {}",
                    sensor.name, sensor.columns
                ),
            ));
        }
        last = Some(k);
        points[k] = point(j);
    }
    Ok(ProfileData::Raw(Profile { points }))
}

/// A profile of a sensor known only by its points: the points in x order, each in its slot of the
/// sensor's grid (`sensor::slots`).
fn points_in_slots(
    pts: &[Option<[f64; 2]>],
    sensor: &SensorModel,
    point: &dyn Fn(usize) -> Option<ProfilePoint>,
) -> Profile {
    let mut order: Vec<usize> = (0..pts.len()).filter(|&j| pts[j].is_some()).collect();
    order.sort_by(|&a, &b| {
        pts[a]
            .map(|q| q[0])
            .partial_cmp(&pts[b].map(|q| q[0]))
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    let mut points = vec![None; sensor.columns];
    let Some(grid) = sensor.resampling() else {
        return Profile { points };
    };
    let xs: Vec<f64> = order
        .iter()
        .filter_map(|&j| pts[j].map(|q| q[0] * 1e-3))
        .collect();
    // The column of the grid's slot 0 (an integer: `SensorModel::column_of` on a slot's x).
    let zero = sensor.column_of(grid.offset, 0.0).unwrap_or(0.0).round() as i64;
    for (&j, k) in order.iter().zip(crate::sensor::slots(&xs, &grid)) {
        if let Some(c) = usize::try_from(k + zero).ok().filter(|c| *c < points.len()) {
            points[c] = point(j);
        }
    }
    Profile { points }
}

/// The column of each point on the declared sensor's rays (None for a missing point); an error when
/// a point lies between rays: the file must then give the columns, or the sensor its geometry.
fn columns_on_rays(
    pts: &[Option<[f64; 2]>],
    sensor: &SensorModel,
    at: &dyn Fn(&str) -> String,
    file: &str,
) -> Result<Vec<Option<usize>>, FormatError> {
    pts.iter()
        .enumerate()
        .map(|(j, q)| {
            let Some(q) = q else { return Ok(None) };
            let k = sensor.column_of(q[0] * 1e-3, q[1] * 1e-3);
            match k {
                Some(k) if (k - k.round()).abs() <= 0.25 && k.round() >= 0.0 => {
                    Ok(Some(k.round() as usize))
                }
                _ => Err(err(
                    file,
                    &at(&format!("points_mm[{j}]")),
                    format!(
                        "({}, {}) mm lies on none of the {}'s {} rays ({} entries given): give each \
                         point's column in `columns`, or declare the sensor's geometry \
                         (docs/sensors.md); the points lie on no uniform x grid either",
                        q[0],
                        q[1],
                        sensor.name,
                        sensor.columns,
                        pts.len()
                    ),
                )),
            }
        })
        .collect()
}

/// A 4x4 row-major transform in mm: its 3x3 block must be a rotation (to 1e-2: a matrix printed
/// with two decimals passes, and is replaced by the nearest rotation), its last row 0 0 0 1.
pub(crate) fn transform_of(
    m: &[[f64; 4]; 4],
    file: &str,
    at: &str,
) -> Result<Isometry3<f64>, FormatError> {
    let r = Matrix3::from_fn(|i, j| m[i][j]);
    let finite = m.iter().flatten().all(|v| v.is_finite());
    let orthonormal = (r.transpose() * r - Matrix3::identity()).abs().max() < 1e-2;
    let last = m[3] == [0.0, 0.0, 0.0, 1.0];
    if !(finite && orthonormal && last && r.determinant() > 0.0) {
        return Err(err(
            file,
            at,
            format!(
                "{m:?}: give a rigid transform, 4 rows of 4 (mm), its upper-left 3x3 a rotation \
                 matrix (orthonormal, determinant +1) and its last row [0, 0, 0, 1]"
            ),
        ));
    }
    Ok(Isometry3::from_parts(
        Translation3::new(m[0][3] * 1e-3, m[1][3] * 1e-3, m[2][3] * 1e-3),
        UnitQuaternion::from_rotation_matrix(&crate::math::nearest_rotation(&r)),
    ))
}

/// The verdict's settings a file states, checked; the defaults for the rest.
fn judging_of(f: &FileV1, file: &str) -> Result<Judging, FormatError> {
    let d = Judging::default();
    let or =
        |v: Option<f64>, at: &str, default: f64| v.map_or(Ok(default), |v| tolerance(v, file, at));
    Ok(Judging {
        tolerance_deg: or(f.tolerance_deg, "tolerance_deg", d.tolerance_deg)?,
        tolerance_mm: or(f.tolerance_mm, "tolerance_mm", d.tolerance_mm)?,
        robot_accuracy: match f.robot_accuracy_mm {
            None => d.robot_accuracy,
            Some(a) => robot_accuracy(a, file, "robot_accuracy_mm")?,
        },
        robot_repeatability: match f.robot_repeatability_mm {
            None => d.robot_repeatability,
            Some(r) => robot_repeatability(r, file, "robot_repeatability_mm")?,
        },
        nominal: f
            .nominal_flange_to_sensor_mm
            .map(|m| transform_of(&m, file, "nominal_flange_to_sensor_mm"))
            .transpose()?,
        scan_speed: None,
        radius_tolerance: match f.specimen.radius_tolerance_mm {
            None => 0.0,
            Some(t) => radius_tolerance(
                t,
                f.specimen.radius_mm,
                file,
                "specimen.radius_tolerance_mm",
            )?,
        },
        straightness: match f.specimen.straightness_mm {
            None => 0.0,
            Some(t)
                if matches!(
                    f.specimen.kind,
                    SpecimenType::DiskCylinder
                        | SpecimenType::DiskPaper
                        | SpecimenType::Ball
                        | SpecimenType::Plane
                ) =>
            {
                return Err(err(
                    file,
                    "specimen.straightness_mm",
                    format!(
                        "{t}: a straightness tolerance is a straight edge's; this specimen has \
                         none: leave it out (a disk's or ball's radius tolerance is \
                         radius_tolerance_mm)"
                    ),
                ));
            }
            Some(t) => straightness(t, file, "specimen.straightness_mm")?,
        },
        edge_length: f
            .specimen
            .edge_length_mm
            .map(|l| {
                metres_from_mm(l, 1e5, file, "specimen.edge_length_mm", || {
                    "give the length the straightness tolerance applies to in mm, above 0 \
                     (at most 100 m); leave it out for the span the profiles see"
                        .to_string()
                })
                .and_then(|m| {
                    if m > 0.0 {
                        Ok(m)
                    } else {
                        Err(err(
                            file,
                            "specimen.edge_length_mm",
                            format!("{l}: the length must be above 0 mm"),
                        ))
                    }
                })
            })
            .transpose()?,
    })
}

/// A straight edge's straightness tolerance (mm in, metres out), checked: peak to valley, from
/// 0 to 1 mm.
pub fn straightness(mm: f64, file: &str, at: &str) -> Result<f64, FormatError> {
    metres_from_mm(mm, 1.0, file, at, || {
        "give the edge's straightness tolerance in mm, peak to valley (the most it bows \
         across itself over its length), from 0 to 1; leave it out for an edge taken as straight"
            .to_string()
    })
}

/// A specimen's radius tolerance (mm in, metres out), checked: one standard deviation, from 0
/// to a tenth of the radius (`radius_mm`, when stated).
pub fn radius_tolerance(
    mm: f64,
    radius_mm: Option<f64>,
    file: &str,
    at: &str,
) -> Result<f64, FormatError> {
    let most = radius_mm
        .filter(|r| r.is_finite() && *r > 0.0)
        .map_or(10.0, |r| r / 10.0);
    metres_from_mm(mm, most, file, at, || {
        format!(
            "give one standard deviation of the specimen's true radius about the stated one in \
             mm (a certificate's standard uncertainty), from 0 to {most} (a tenth of the \
             radius); leave it out for a radius taken as exact"
        )
    })
}

/// `mm` in metres where it is finite and from 0 to `most`; else an error naming the file, the
/// field and the value, with `hint` saying what to give.
fn metres_from_mm(
    mm: f64,
    most: f64,
    file: &str,
    at: &str,
    hint: impl FnOnce() -> String,
) -> Result<f64, FormatError> {
    if mm.is_finite() && (0.0..=most).contains(&mm) {
        Ok(mm * 1e-3)
    } else {
        Err(err(file, at, format!("{mm}: {}", hint())))
    }
}

/// A tolerance on the verdict's 95 % bound (deg or mm), checked.
pub fn tolerance(v: f64, file: &str, at: &str) -> Result<f64, FormatError> {
    if v.is_finite() && v > 0.0 && v <= 1000.0 {
        Ok(v)
    } else {
        Err(err(
            file,
            at,
            format!(
                "{v}: give the largest acceptable 95 % error bound, above 0 and at most 1000 \
                 (defaults: 0.5 deg, 0.5 mm)"
            ),
        ))
    }
}

/// An arm and its kinematic error as a file or the command line states them
/// (`kinematic_of`).
#[derive(Debug, Clone, Copy, Default)]
pub struct Stated<'a> {
    pub robot: Option<&'a str>,
    pub link_error_mm: Option<f64>,
    pub joint_offset_error_deg: Option<f64>,
    /// Name the command line's flags in errors rather than the file's fields.
    pub flags: bool,
}

/// The arm that took `poses` and its kinematic error, checked: the errors' ranges, the arm's
/// name or URDF (a relative path from `dir`) and every pose within its reach. `at` names the
/// fields in errors (the file's names; the command line's flags say theirs in `file`).
pub fn kinematic_of<'a>(
    s: &Stated,
    poses: impl IntoIterator<Item = (&'a Isometry3<f64>, Option<crate::robot::Joints>)>,
    file: &str,
    dir: Option<&Path>,
) -> Result<Option<crate::captures::Kinematic>, FormatError> {
    let name_of = |field: &'static str, flag: &'static str| if s.flags { flag } else { field };
    let (robot_at, link_at, zero_at) = (
        name_of("robot", "--robot"),
        name_of("link_error_mm", "--link-error-mm"),
        name_of("joint_offset_error_deg", "--joint-offset-error-deg"),
    );
    let link = match s.link_error_mm {
        None => 0.0,
        Some(v) => metres_from_mm(v, 10.0, file, link_at, || {
            "give one standard deviation of each joint origin's offset in mm, from 0 to 10".into()
        })?,
    };
    let zero = match s.joint_offset_error_deg {
        None => 0.0,
        Some(v) if v.is_finite() && (0.0..=1.0).contains(&v) => v.to_radians(),
        Some(v) => {
            return Err(err(
                file,
                zero_at,
                format!(
                    "{v}: give one standard deviation of each joint's zero in deg, from 0 to 1"
                ),
            ));
        }
    };
    let poses: Vec<_> = poses.into_iter().collect();
    let Some(name) = s.robot else {
        if let Some(i) = poses.iter().position(|p| p.1.is_some()) {
            return Err(err(
                file,
                &format!("profiles[{i}].joints_deg"),
                format!(
                    "joint values need the arm they belong to; give the arm ({robot_at}: \
                     irb120, irb2600 or a URDF file's path), or leave them out"
                ),
            ));
        }
        if s.link_error_mm.is_some() || s.joint_offset_error_deg.is_some() {
            return Err(err(
                file,
                "robot",
                "missing: a kinematic error needs the arm it belongs to; give the arm (irb120, \
                 irb2600 or a URDF file's path, relative to the capture file)",
            ));
        }
        return Ok(None);
    };
    let path = match dir {
        Some(d) if name.ends_with(".urdf") && Path::new(name).is_relative() => {
            let joined = d.join(name);
            if joined.exists() {
                joined.display().to_string()
            } else {
                name.to_string()
            }
        }
        _ => name.to_string(),
    };
    let robot = crate::robot::Robot::resolve(&path).map_err(|e| err(file, robot_at, e))?;
    // Logged joint values must put the flange where the record says (within a controller's
    // own calibrated model of the arm: 1 mm, 0.1 deg).
    for (i, (f, q)) in poses.iter().enumerate() {
        let Some(q) = q else { continue };
        let at = robot.fk(q);
        let (mm, deg) = (
            (at.translation.vector - f.translation.vector).norm() * 1e3,
            at.rotation.angle_to(&f.rotation).to_degrees(),
        );
        if !(mm <= 1.0 && deg <= 0.1) {
            return Err(err(
                file,
                &format!("profiles[{i}].joints_deg"),
                format!(
                    "{:.3?}: {name} puts the flange {mm:.3} mm / {deg:.3} deg from the record's \
                     pose (at most 1 mm / 0.1 deg): check the arm, the joint order and units \
                     (deg), and that the joints and the pose are the same record's",
                    q.map(f64::to_degrees)
                ),
            ));
        }
    }
    crate::captures::Kinematic::new(
        name.to_string(),
        std::sync::Arc::new(robot),
        link,
        zero,
        poses,
    )
    .map(|mut k| {
        // A stated 0 (a calibrated arm) is a statement; an arm named alone is not.
        k.errors_stated = s.link_error_mm.is_some() || s.joint_offset_error_deg.is_some();
        Some(k)
    })
    .map_err(|(i, e)| {
        err(
            file,
            &format!("profiles[{i}]"),
            format!(
                "its flange pose is out of reach of {name} ({e}): the poses must be this arm's \
                 flange (tool0) in its base frame; check {robot_at}, or leave it out"
            ),
        )
    })
}

/// A robot's pose accuracy (mm in, metres out), checked.
pub fn robot_accuracy(mm: f64, file: &str, at: &str) -> Result<f64, FormatError> {
    metres_from_mm(mm, 100.0, file, at, || {
        "give one standard deviation of the robot's pose error at the specimen in mm, from 0 to \
         100 (default 0.5; 0 for a simulated rig without robot error)"
            .into()
    })
}

/// A robot's repeatability (mm in, metres out), checked.
pub fn robot_repeatability(mm: f64, file: &str, at: &str) -> Result<f64, FormatError> {
    metres_from_mm(mm, 100.0, file, at, || {
        "give one standard deviation per axis of each pose's own error in mm, from 0 to 100 \
         (default 0; a data sheet's pose repeatability RP is about 3.6 times it)"
            .into()
    })
}

/// A user's orientation tolerance (deg), checked: finite, above 0 and at most 5 (beyond, "one
/// orientation" means nothing the protocols rely on).
pub fn orientation_tolerance(deg: f64, file: &str, at: &str) -> Result<f64, FormatError> {
    if deg.is_finite() && deg > 0.0 && deg <= 5.0 {
        Ok(deg)
    } else {
        Err(err(
            file,
            at,
            format!(
                "{deg}: give the tolerance in deg, above 0 and at most 5 (a controller's jitter is \
             0.003-0.055 deg; the default is 0.1)"
            ),
        ))
    }
}
