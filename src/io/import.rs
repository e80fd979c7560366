//! `lasercal import`: a capture file from what a real rig records, a pose list (one row per
//! profile, in the controller's convention) and the profiles (one CSV per pose, or one long CSV).
//! Each pose becomes its own group (role `pose`): the any-pose estimators take them as they are.
//! The file is assembled as the capture format and read back through `captures::from_json`, so
//! an imported file means exactly what a written one does.

use crate::error::FormatError;
use crate::robot::Robot;
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use std::io::Read;

/// Most points one profile may hold (a profiler has at most a few thousand columns).
pub const MAX_POINTS: usize = 100_000;

fn field(file: &str, at: String, message: String) -> FormatError {
    FormatError::Field {
        file: file.to_string(),
        at,
        message,
    }
}

/// The 4x4 matrix columns a pose list may have instead (row-major, translation in mm).
const MATRIX: [&str; 16] = [
    "m00", "m01", "m02", "m03_mm", "m10", "m11", "m12", "m13_mm", "m20", "m21", "m22", "m23_mm",
    "m30", "m31", "m32", "m33",
];

/// A pose list: the scenario's conventions (`io::csv::pose_list`), plus what only recordings
/// carry: a quaternion in x, y, z, w order (ROS) and 4x4 matrices. Returns the convention's key
/// and the rows.
pub fn pose_rows(text: &str, file: &str) -> Result<(&'static str, Vec<Vec<f64>>), FormatError> {
    let header: Vec<String> = text
        .lines()
        .next()
        .unwrap_or("")
        .split(',')
        .map(|h| h.trim().to_ascii_lowercase())
        .collect();
    let own: Option<(&'static str, Vec<&str>)> =
        if header == ["x_mm", "y_mm", "z_mm", "qx", "qy", "qz", "qw"] {
            Some((
                "tcp_mm_xyzw",
                vec!["x_mm", "y_mm", "z_mm", "qx", "qy", "qz", "qw"],
            ))
        } else if header == MATRIX {
            Some(("matrix_mm", MATRIX.to_vec()))
        } else {
            None
        };
    let Some((key, cols)) = own else {
        return super::csv::pose_list(text.as_bytes(), file);
    };
    let mut rows = Vec::new();
    for (i, line) in text.lines().skip(1).enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        if rows.len() >= 10_000 {
            return Err(field(
                file,
                format!("line {}", i + 2),
                "more than 10000 poses".into(),
            ));
        }
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        if cells.len() != cols.len() {
            return Err(field(
                file,
                format!("line {}", i + 2),
                format!("{} cells; the header has {}", cells.len(), cols.len()),
            ));
        }
        let row = cells
            .iter()
            .zip(&cols)
            .map(|(c, name)| {
                c.parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| {
                        field(
                            file,
                            format!("line {}, {name}", i + 2),
                            format!("'{c}' is not a finite number"),
                        )
                    })
            })
            .collect::<Result<Vec<f64>, _>>()?;
        rows.push(row);
    }
    Ok((key, rows))
}

/// A pose list from a file or folder: a folder of HALCON pose files, a FANUC `.ls` program, ABB
/// RAPID robtargets, a JSON or text list of x y z w p r (`io::poses`), or a CSV whose header
/// names its convention (`pose_rows`). `text` is the file's text (None for a folder).
pub fn pose_list(
    path: &std::path::Path,
    text: Option<&str>,
) -> Result<super::poses::PoseList, FormatError> {
    let file = path.display().to_string();
    let Some(text) = text else {
        return super::poses::halcon_folder(path);
    };
    if let Some(format) = super::poses::detect(text) {
        return super::poses::read(text, &file, format);
    }
    let (key, rows) = pose_rows(text, &file)?;
    if rows.is_empty() {
        return Err(field(
            &file,
            "line 2".into(),
            "no pose under the header; give one row per profile".into(),
        ));
    }
    Ok(super::poses::PoseList {
        warnings: Vec::new(),
        key,
        at: (0..rows.len()).map(|i| format!("line {}", i + 2)).collect(),
        summary: format!("{} poses ({key})", rows.len()),
        rows,
    })
}

/// Flange poses from a pose list's rows (`io::csv::pose_list`, `pose_list`): the key says the
/// convention, `at` where each row came from; joint angles need the robot.
pub fn flange_poses(
    key: &str,
    rows: &[Vec<f64>],
    at: &[String],
    robot: Option<&Robot>,
    file: &str,
) -> Result<Vec<Isometry3<f64>>, FormatError> {
    rows.iter()
        .enumerate()
        .map(|(i, r)| {
            let at = at
                .get(i)
                .cloned()
                .unwrap_or_else(|| format!("line {}", i + 2));
            if key == "matrix_mm" {
                let m = nalgebra::Matrix3::from_fn(|a, b| r[4 * a + b]);
                let off = (m.transpose() * m - nalgebra::Matrix3::identity()).norm();
                let last = [r[12], r[13], r[14], r[15]];
                if !(off < 1e-4 && m.determinant() > 0.0) || last != [0.0, 0.0, 0.0, 1.0] {
                    return Err(field(
                        file,
                        at,
                        format!(
                            "not a rigid transform: the rotation block is {off:.2e} from \
                             orthonormal (det {:.6}), the last row {last:?} (want 0 0 0 1)",
                            m.determinant()
                        ),
                    ));
                }
                let rot = crate::calib::quat_from_matrix(&m);
                return Ok(Isometry3::from_parts(
                    Translation3::new(r[3] * 1e-3, r[7] * 1e-3, r[11] * 1e-3),
                    rot,
                ));
            }
            let t = Translation3::new(r[0] * 1e-3, r[1] * 1e-3, r[2] * 1e-3);
            let deg = |k: usize| r[k].to_radians();
            let quaternion = |w: f64, x: f64, y: f64, z: f64| {
                let q = nalgebra::Quaternion::new(w, x, y, z);
                if (q.norm() - 1.0).abs() < 1e-3 {
                    Ok(UnitQuaternion::from_quaternion(q))
                } else {
                    Err(field(
                        file,
                        at.clone(),
                        format!(
                            "the quaternion (w {w}, x {x}, y {y}, z {z}) has length {:.6}, not 1",
                            q.norm()
                        ),
                    ))
                }
            };
            let q = match key {
                "tcp_mm_xyzw" => quaternion(r[6], r[3], r[4], r[5])?,
                "tcp_mm_wxyz" => quaternion(r[3], r[4], r[5], r[6])?,
                // FANUC / Yaskawa W, P, R: R = Rz(R) Ry(P) Rx(W).
                "tcp_mm_wpr_deg" => UnitQuaternion::from_euler_angles(deg(3), deg(4), deg(5)),
                // KUKA A, B, C: R = Rz(A) Ry(B) Rx(C).
                "tcp_mm_abc_deg" => UnitQuaternion::from_euler_angles(deg(5), deg(4), deg(3)),
                // UR rotation vector.
                "tcp_mm_rotvec_rad" => {
                    UnitQuaternion::from_scaled_axis(Vector3::new(r[3], r[4], r[5]))
                }
                "joints_deg" => {
                    let robot = robot.ok_or_else(|| {
                        field(
                            file,
                            "header".into(),
                            "joint angles need the robot: give --robot (irb120, irb2600 or a \
                             URDF)"
                                .into(),
                        )
                    })?;
                    let q: [f64; 6] = std::array::from_fn(|k| r[k].to_radians());
                    if !robot.within_limits(&q, 1e-9) {
                        return Err(field(
                            file,
                            at,
                            format!("joints {:?} deg lie outside the robot's limits", &r[..6]),
                        ));
                    }
                    return Ok(robot.fk(&q));
                }
                other => {
                    return Err(field(
                        file,
                        "header".into(),
                        format!("{other}: not a pose convention import knows"),
                    ));
                }
            };
            Ok(Isometry3::from_parts(t, q))
        })
        .collect()
}

/// One profile's points (x, z in mm, sensor frame) from a CSV with columns `x_mm` and `z_mm`
/// (others ignored; an empty cell is a column without a point).
fn points<R: Read>(
    reader: R,
    file: &str,
    pose_column: bool,
) -> Result<Vec<(usize, Option<[f64; 2]>)>, FormatError> {
    let mut r = ::csv::ReaderBuilder::new()
        .trim(::csv::Trim::All)
        .flexible(true)
        .from_reader(reader);
    let header = r
        .headers()
        .map_err(|e| field(file, "header".into(), e.to_string()))?
        .clone();
    let col = |name: &str| {
        header
            .iter()
            .position(|h| h.eq_ignore_ascii_case(name))
            .ok_or_else(|| {
                field(
                    file,
                    "header".into(),
                    format!(
                        "no {name} column (the header is: {}); a profile CSV has x_mm and z_mm{}",
                        header.iter().collect::<Vec<_>>().join(","),
                        if pose_column {
                            ", and a pose column (0-based row of the pose list)"
                        } else {
                            ""
                        }
                    ),
                )
            })
    };
    let (cx, cz) = (col("x_mm")?, col("z_mm")?);
    let cp = if pose_column {
        Some(col("pose")?)
    } else {
        None
    };
    let mut out = Vec::new();
    for (i, rec) in r.records().enumerate() {
        let line = i + 2;
        let rec = rec.map_err(|e| field(file, format!("line {line}"), e.to_string()))?;
        if out.len() >= MAX_POINTS * 1000 {
            return Err(field(
                file,
                format!("line {line}"),
                "too many points for one import".into(),
            ));
        }
        let num = |c: usize, name: &str| -> Result<Option<f64>, FormatError> {
            let v = rec.get(c).unwrap_or("");
            if v.is_empty() || v.eq_ignore_ascii_case("nan") {
                return Ok(None);
            }
            v.parse::<f64>()
                .ok()
                .filter(|x| x.is_finite() && x.abs() < 1e5)
                .map(Some)
                .ok_or_else(|| {
                    field(
                        file,
                        format!("line {line}, {name}"),
                        format!("'{v}' is not a number of mm (|x| < 100000)"),
                    )
                })
        };
        let pose = match cp {
            Some(c) => {
                let v = rec.get(c).unwrap_or("");
                v.parse::<usize>().map_err(|_| {
                    field(
                        file,
                        format!("line {line}, pose"),
                        format!("'{v}' is not a pose index"),
                    )
                })?
            }
            None => 0,
        };
        let p = match (num(cx, "x_mm")?, num(cz, "z_mm")?) {
            (Some(x), Some(z)) => Some([x, z]),
            _ => None,
        };
        out.push((pose, p));
    }
    Ok(out)
}

/// Profile points from an NPY array of float64: shape (n, 2) x_mm, z_mm, or with a pose column
/// (n, 3) pose, x_mm, z_mm; NaN where a column has no point.
fn npy_points<R: Read>(
    reader: R,
    file: &str,
    pose_column: bool,
) -> Result<Vec<(usize, Option<[f64; 2]>)>, FormatError> {
    let bad = |m: String| field(file, "npy".into(), m);
    let npy = npyz::NpyFile::new(reader).map_err(|e| bad(e.to_string()))?;
    let width = if pose_column { 3 } else { 2 };
    let shape = npy.shape().to_vec();
    if shape.len() != 2 || shape[1] != width as u64 || shape[0] > (MAX_POINTS * 1000) as u64 {
        return Err(bad(format!(
            "shape {shape:?}: want (n, {width}) ({}x_mm, z_mm)",
            if pose_column { "pose, " } else { "" }
        )));
    }
    if npy.order() != npyz::Order::C {
        return Err(bad("Fortran order: save the array in C order".into()));
    }
    let v: Vec<f64> = npy
        .into_vec()
        .map_err(|e| bad(format!("{e} (the array must hold float64)")))?;
    v.chunks(width)
        .enumerate()
        .map(|(i, r)| {
            let (pose, x, z) = if pose_column {
                (r[0], r[1], r[2])
            } else {
                (0.0, r[0], r[1])
            };
            if !(pose >= 0.0 && pose.fract() == 0.0 && pose < 1e7) {
                return Err(bad(format!("row {i}: pose {pose} is not a pose index")));
            }
            let p = (x.is_finite() && z.is_finite() && x.abs() < 1e5 && z.abs() < 1e5)
                .then_some([x, z]);
            Ok((pose as usize, p))
        })
        .collect()
}

fn any_points<R: Read>(
    mut reader: R,
    file: &str,
    pose_column: bool,
    missing: Option<f64>,
) -> Result<Vec<(usize, Option<[f64; 2]>)>, FormatError> {
    let lower = file.to_ascii_lowercase();
    // A profile file of text: a 100,000-point profile in YAML is about 6 MB.
    let text = |r: &mut R| -> Result<String, FormatError> {
        const MAX: u64 = 64 << 20;
        let mut s = String::new();
        r.take(MAX + 1)
            .read_to_string(&mut s)
            .map_err(|e| field(file, "the file".into(), e.to_string()))?;
        if s.len() as u64 > MAX {
            return Err(field(
                file,
                "the file".into(),
                "over 64 MB: not one profile".into(),
            ));
        }
        Ok(s)
    };
    let per_pose = |p: Vec<Option<[f64; 2]>>| p.into_iter().map(|p| (0, p)).collect();
    let mut pts: Vec<(usize, Option<[f64; 2]>)> = if lower.ends_with(".npy") {
        npy_points(reader, file, pose_column)?
    } else if lower.ends_with(".yml") || lower.ends_with(".yaml") {
        per_pose(super::poses::opencv_profile(&text(&mut reader)?, file)?)
    } else if lower.ends_with(".txt") {
        per_pose(super::poses::two_row_profile(&text(&mut reader)?, file)?)
    } else {
        points(reader, file, pose_column)?
    };
    if !pose_column && pts.len() > MAX_POINTS {
        return Err(field(
            file,
            "the file".into(),
            format!("{} points; one profile has at most {MAX_POINTS}", pts.len()),
        ));
    }
    // A stated sentinel for no point (a profiler's 0 or -999 in z).
    if let Some(m) = missing {
        for p in &mut pts {
            if p.1.is_some_and(|[_, z]| z == m) {
                p.1 = None;
            }
        }
    }
    for (i, p) in pts.iter().enumerate() {
        if let Some([x, z]) = p.1
            && !(x.abs() < 1e5 && z.abs() < 1e5)
        {
            return Err(field(
                file,
                format!("point {i}"),
                format!(
                    "({x}, {z}) is no point in mm (|x|, |z| < 100000); a sentinel for no point \
                     is stated with --missing-z-mm"
                ),
            ));
        }
    }
    Ok(pts)
}

/// Where the profiles are: one file per pose (a folder's CSV, NPY, OpenCV YAML or two-row text
/// files, in natural name order) or one long CSV or NPY with a `pose` column.
pub enum ProfileSource<'a> {
    PerPose(Vec<(String, Box<dyn Read + 'a>)>),
    Long(String, Box<dyn Read + 'a>),
}

/// Scanning on the move: the pose list is the controller's log (`pose_times`, one per row) and
/// the profiles carry their own time stamps (`profile_times`, one per profile, on the
/// profiler's clock; `offset_s` puts them on the controller's).
pub struct Timing {
    pub pose_times: Vec<f64>,
    pub profile_times: Vec<f64>,
    pub offset_s: Option<f64>,
}

/// A pose log whose first column is `t_s`: the times, and the rest of the CSV (a pose list in
/// one of the conventions `pose_rows` reads).
pub fn split_times(text: &str, file: &str) -> Result<(Vec<f64>, String), FormatError> {
    let mut lines = text.lines();
    let header = lines.next().unwrap_or("");
    let Some((first, rest)) = header.split_once(',') else {
        return Err(field(
            file,
            "header".into(),
            format!("'{header}': a pose log starts with a t_s column, then the pose's columns"),
        ));
    };
    if first.trim().to_ascii_lowercase() != "t_s" {
        return Err(field(
            file,
            "header".into(),
            format!(
                "'{first}': with --profile-times the pose list is the controller's log, its \
                 first column t_s (seconds) and then the pose's columns (x_mm,y_mm,z_mm,qw,...)"
            ),
        ));
    }
    let (mut times, mut out) = (Vec::new(), format!("{rest}\n"));
    for (i, line) in lines.enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let (t, pose) = line.split_once(',').unwrap_or((line, ""));
        let t = t.trim();
        times.push(seconds(t, file, i + 2)?);
        out += pose;
        out += "\n";
    }
    Ok((times, out))
}

/// A `t_s` cell on CSV line `line`: a finite number of seconds.
fn seconds(cell: &str, file: &str, line: usize) -> Result<f64, FormatError> {
    cell.parse::<f64>()
        .ok()
        .filter(|x| x.is_finite())
        .ok_or_else(|| {
            field(
                file,
                format!("line {line}, t_s"),
                format!("'{cell}' is not a finite number of seconds"),
            )
        })
}

/// Profile time stamps: a CSV with a `t_s` column, one row per profile in the profiles' order.
pub fn profile_times<R: Read>(reader: R, file: &str) -> Result<Vec<f64>, FormatError> {
    let mut r = ::csv::ReaderBuilder::new()
        .trim(::csv::Trim::All)
        .from_reader(reader);
    let headers = r
        .headers()
        .map_err(|e| field(file, "header".into(), e.to_string()))?
        .clone();
    let Some(col) = headers.iter().position(|h| h.eq_ignore_ascii_case("t_s")) else {
        return Err(field(
            file,
            "header".into(),
            format!(
                "no t_s column among {:?}: give each profile's time stamp (seconds) in a t_s \
                 column, one row per profile in the profiles' order",
                headers.iter().collect::<Vec<_>>()
            ),
        ));
    };
    let mut times = Vec::new();
    for (i, rec) in r.records().enumerate() {
        let rec = rec.map_err(|e| field(file, format!("line {}", i + 2), e.to_string()))?;
        let cell = rec.get(col).unwrap_or("");
        if times.len() >= 10_000_000 {
            return Err(field(
                file,
                format!("line {}", i + 2),
                "more than 10 million profiles".into(),
            ));
        }
        times.push(seconds(cell, file, i + 2)?);
    }
    Ok(times)
}

/// A position (mm) and a quaternion (w, x, y, z) as the capture file writes a flange pose.
fn pose_json(f: &Isometry3<f64>) -> ([f64; 3], [f64; 4]) {
    let t = f.translation.vector * 1e3;
    let q = f.rotation;
    ([t.x, t.y, t.z], [q.w, q.i, q.j, q.k])
}

/// The capture file's `pose_stream`: the log's poses with their times.
fn pose_stream(
    t: &Timing,
    poses: &[Isometry3<f64>],
    file: &str,
) -> Result<serde_json::Value, FormatError> {
    if t.pose_times.len() != poses.len() {
        return Err(field(
            file,
            "t_s".into(),
            format!("{} times for {} poses", t.pose_times.len(), poses.len()),
        ));
    }
    Ok(t.pose_times
        .iter()
        .zip(poses)
        .map(|(s, f)| {
            let (p, q) = pose_json(f);
            serde_json::json!({"t_s": s, "tcp_position_mm": p, "tcp_quaternion_wxyz": q})
        })
        .collect())
}

/// What the capture file says besides the data.
pub struct Header<'a> {
    pub method: &'a str,
    /// A preset's name, or a declared sensor: the record a capture file's `sensor` holds
    /// (docs/sensors.md).
    pub sensor: serde_json::Value,
    pub specimen: &'a str,
    pub radius_mm: Option<f64>,
    pub feature_sigma_mm: Option<f64>,
    /// The sensor's z noise (mm, one standard deviation) as its data sheet states it.
    pub z_sigma_mm: Option<f64>,
    /// The robot's pose accuracy (mm) for the verdict (docs/verdict.md).
    pub robot_accuracy_mm: Option<f64>,
    /// The robot's repeatability (mm, one sd per axis of each pose's own error).
    pub robot_repeatability_mm: Option<f64>,
    /// The arm (a built-in name or a URDF path) and its kinematic error (mm per joint origin
    /// axis, deg per joint zero), as a capture file states them (docs/captures.md).
    pub robot: Option<&'a str>,
    /// Each pose's joint values (deg) where the pose list gave them.
    pub joints_deg: Option<&'a [Vec<f64>]>,
    pub link_error_mm: Option<f64>,
    pub joint_offset_error_deg: Option<f64>,
    /// The z value (mm) the profiler writes where a column has no point (0, -999, ...), besides
    /// NaN and empty cells.
    pub missing_z_mm: Option<f64>,
}

/// Assemble a capture file (JSON text) and check it by reading it back; errors name the file,
/// line and field.
pub fn capture_file(
    h: &Header,
    poses_file: &str,
    poses: &[Isometry3<f64>],
    profiles: ProfileSource,
    timing: Option<&Timing>,
) -> Result<String, FormatError> {
    // One profile per pose, or with a log one per time stamp.
    let count = timing.map_or(poses.len(), |t| t.profile_times.len());
    let mut per_pose: Vec<Vec<Option<[f64; 2]>>> = vec![Vec::new(); count];
    let profiles_missing = h.missing_z_mm;
    match profiles {
        ProfileSource::PerPose(files) => {
            if files.len() != count {
                return Err(field(
                    poses_file,
                    "rows".into(),
                    match timing {
                        None => format!(
                            "{} poses but {} profile files: one profile CSV per pose, in the \
                             pose list's order",
                            poses.len(),
                            files.len()
                        ),
                        Some(_) => format!(
                            "{count} profile time stamps but {} profile files: one time stamp \
                             per profile file, in the files' order",
                            files.len()
                        ),
                    },
                ));
            }
            for (i, (name, r)) in files.into_iter().enumerate() {
                per_pose[i] = any_points(r, &name, false, profiles_missing)?
                    .into_iter()
                    .map(|p| p.1)
                    .collect();
            }
        }
        ProfileSource::Long(name, r) => {
            for (pose, p) in any_points(r, &name, true, profiles_missing)? {
                let slot = per_pose.get_mut(pose).ok_or_else(|| {
                    field(
                        &name,
                        "pose".into(),
                        format!(
                            "pose {pose} does not exist: there are {count} profiles (0-based; \
                             one per pose, or per time stamp with --profile-times)"
                        ),
                    )
                })?;
                slot.push(p);
            }
        }
    }
    let profiles: Vec<serde_json::Value> = per_pose
        .iter()
        .enumerate()
        .map(|(i, pts)| match timing {
            Some(t) => serde_json::json!({
                "group": i,
                "t_s": t.profile_times[i],
                "points_mm": pts,
            }),
            None => {
                let (t, q) = pose_json(&poses[i]);
                let mut rec = serde_json::json!({
                    "group": i,
                    "tcp_position_mm": t,
                    "tcp_quaternion_wxyz": q,
                    "points_mm": pts,
                });
                if let Some(j) = h.joints_deg.and_then(|j| j.get(i)) {
                    rec["joints_deg"] = serde_json::json!(&j[..6]);
                }
                rec
            }
        })
        .collect();
    let groups: Vec<serde_json::Value> = (0..count)
        .map(|i| serde_json::json!({ "id": i, "role": "pose" }))
        .collect();
    let mut doc = serde_json::json!({
        "format": super::captures::FORMAT,
        "version": super::captures::VERSION,
        "method": h.method,
        "sensor": h.sensor.clone(),
        "specimen": { "kind": h.specimen },
        "groups": groups,
        "profiles": profiles,
    });
    if let Some(r) = h.radius_mm {
        doc["specimen"]["radius_mm"] = serde_json::json!(r);
    }
    if let Some(t) = timing {
        doc["pose_stream"] = pose_stream(t, poses, poses_file)?;
        if let Some(o) = t.offset_s {
            doc["profile_clock_offset_s"] = serde_json::json!(o);
        }
    }
    if let Some(z) = h.z_sigma_mm {
        doc["sensor_noise"] = serde_json::json!({
            "z_sigma_near_mm": z, "z_sigma_far_mm": z, "x_sigma_mm": 0.0,
            "dark_noise_factor": 1.0, "z_quantum_mm": 0.0,
        });
    }
    if let Some(s) = h.feature_sigma_mm {
        doc["feature_sigma_mm"] = serde_json::json!(s);
    }
    stated_robot(&mut doc, h);
    let text = serde_json::to_string_pretty(&doc)
        .map_err(|e| field(poses_file, "json".into(), e.to_string()))?;
    super::captures::from_json(&text, "the imported capture file")?;
    Ok(text)
}

/// The robot's accuracy, the arm and its kinematic error where the header states them.
fn stated_robot(doc: &mut serde_json::Value, h: &Header) {
    let fields = [
        (
            "robot_accuracy_mm",
            h.robot_accuracy_mm.map(serde_json::Value::from),
        ),
        (
            "robot_repeatability_mm",
            h.robot_repeatability_mm.map(serde_json::Value::from),
        ),
        ("robot", h.robot.map(serde_json::Value::from)),
        (
            "link_error_mm",
            h.link_error_mm.map(serde_json::Value::from),
        ),
        (
            "joint_offset_error_deg",
            h.joint_offset_error_deg.map(serde_json::Value::from),
        ),
    ];
    for (key, value) in fields {
        if let Some(v) = value {
            doc[key] = v;
        }
    }
}
