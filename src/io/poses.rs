//! Pose lists in the controllers' and vision libraries' own files, for `lasercal import`: FANUC
//! `.ls` programs (`P[n]{ GP1: UF, UT, X = .. mm, .., R = .. deg }`), ABB RAPID `robtarget`
//! declarations, JSON or plain-text lists of x y z w p r, and HALCON pose files (one `.dat` per
//! pose). Each is read into the rows of one of the CSV pose lists' conventions
//! (`io::import::flange_poses` turns them into flange poses), with a label per row for messages
//! and a line saying what was read.
//!
//! Written by hand: these are small line formats no maintained crate reads.

use crate::error::FormatError;
use std::path::Path;

/// A pose list read from a file: the convention's key (`tcp_mm_wpr_deg`, `tcp_mm_wxyz`,
/// `joints_deg`, `matrix_mm`), one row per pose, where each row came from, and what was read.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseList {
    pub key: &'static str,
    pub rows: Vec<Vec<f64>>,
    pub at: Vec<String>,
    pub summary: String,
    /// What the file holds that the poses leave out and may spoil them (a FANUC program's
    /// extended axes moving between poses), for the user to check.
    pub warnings: Vec<String>,
}

/// At most this many poses in one list.
const MAX_POSES: usize = 10_000;

fn field(file: &str, at: impl Into<String>, message: impl Into<String>) -> FormatError {
    FormatError::Field {
        file: file.to_string(),
        at: at.into(),
        message: message.into(),
    }
}

fn number(file: &str, at: &str, name: &str, text: &str) -> Result<f64, FormatError> {
    text.trim()
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| {
            field(
                file,
                at,
                format!("{name} '{}' is not a finite number", text.trim()),
            )
        })
}

/// The format a pose file's text is in, when it is one of these (None: a CSV pose list).
pub fn detect(text: &str) -> Option<&'static str> {
    let t = text.trim_start();
    if t.starts_with('[') || t.starts_with('{') {
        Some("json")
    } else if text.contains("/POS") || (text.contains("P[") && text.contains("GP1")) {
        Some("fanuc")
    } else if text.to_ascii_lowercase().contains("robtarget") {
        Some("rapid")
    } else if halcon_like(text) {
        Some("halcon")
    } else if t
        .lines()
        .find(|l| !l.trim().is_empty() && !l.trim_start().starts_with('#'))
        .is_some_and(|l| {
            l.split(|c: char| c.is_whitespace() || c == ',')
                .find(|s| !s.is_empty())
                .is_some_and(|s| s.parse::<f64>().is_ok())
        })
    {
        Some("text")
    } else {
        None
    }
}

fn halcon_like(text: &str) -> bool {
    let starts = |c: &str| {
        text.lines()
            .any(|l| l.trim_start().starts_with(c) && !l.trim_start().starts_with('#'))
    };
    starts("f ") && starts("r ") && starts("t ")
}

/// Reads a pose file in the format `detect` found.
pub fn read(text: &str, file: &str, format: &str) -> Result<PoseList, FormatError> {
    let list = match format {
        "json" => json(text, file)?,
        "fanuc" => fanuc(text, file)?,
        "rapid" => rapid(text, file)?,
        "halcon" => {
            let row = halcon(text, file)?;
            PoseList {
                warnings: Vec::new(),
                key: "matrix_mm",
                rows: vec![row],
                at: vec!["pose".into()],
                summary: "a HALCON pose file".into(),
            }
        }
        _ => text_list(text, file)?,
    };
    if list.rows.is_empty() {
        return Err(field(
            file,
            "the whole file",
            "no pose in it; give one pose per profile",
        ));
    }
    if list.rows.len() > MAX_POSES {
        return Err(field(
            file,
            "the whole file",
            format!("{} poses; at most {MAX_POSES}", list.rows.len()),
        ));
    }
    Ok(list)
}

/// A folder of HALCON pose files (`*.dat`, one pose each, in natural name order: `pose_2`
/// before `pose_10`).
pub fn halcon_folder(dir: &Path) -> Result<PoseList, FormatError> {
    let name = dir.display().to_string();
    let mut files: Vec<std::path::PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| field(&name, "the folder", format!("cannot list it: {e}")))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x.eq_ignore_ascii_case("dat")))
        .collect();
    files.sort_by(|a, b| natural_cmp(&a.to_string_lossy(), &b.to_string_lossy()));
    if files.is_empty() {
        return Err(field(
            &name,
            "the folder",
            "no .dat file in it; give a folder of HALCON pose files (one per pose) or a pose list",
        ));
    }
    if files.len() > MAX_POSES {
        return Err(field(
            &name,
            "the folder",
            format!("{} pose files; at most {MAX_POSES}", files.len()),
        ));
    }
    let mut rows = Vec::new();
    let mut at = Vec::new();
    for f in &files {
        let fname = f.display().to_string();
        let meta = std::fs::metadata(f).map_err(|e| field(&fname, "the file", e.to_string()))?;
        if meta.len() > 1 << 20 {
            return Err(field(
                &fname,
                "the file",
                "over 1 MB: not a HALCON pose file",
            ));
        }
        let text =
            std::fs::read_to_string(f).map_err(|e| field(&fname, "the file", e.to_string()))?;
        rows.push(halcon(&text, &fname)?);
        at.push(fname);
    }
    Ok(PoseList {
        warnings: Vec::new(),
        key: "matrix_mm",
        summary: format!(
            "{} HALCON pose files (f 0: R = Rx Ry Rz; f 2: Rz Ry Rx; f 4: Rodriguez; t in m)",
            rows.len()
        ),
        rows,
        at,
    })
}

/// Orders names with their digit runs compared as numbers.
pub fn natural_cmp(a: &str, b: &str) -> std::cmp::Ordering {
    fn chunks(s: &str) -> Vec<(bool, String)> {
        let mut out: Vec<(bool, String)> = Vec::new();
        for c in s.chars() {
            let d = c.is_ascii_digit();
            match out.last_mut() {
                Some((kind, run)) if *kind == d => run.push(c),
                _ => out.push((d, c.to_string())),
            }
        }
        out
    }
    let (ca, cb) = (chunks(a), chunks(b));
    for (x, y) in ca.iter().zip(&cb) {
        let o = match (x.0, y.0) {
            (true, true) => {
                let (tx, ty) = (x.1.trim_start_matches('0'), y.1.trim_start_matches('0'));
                tx.len().cmp(&ty.len()).then_with(|| tx.cmp(ty))
            }
            _ => x.1.cmp(&y.1),
        };
        if o != std::cmp::Ordering::Equal {
            return o;
        }
    }
    ca.len().cmp(&cb.len()).then_with(|| a.cmp(b))
}

/// `[[x, y, z, w, p, r], ...]`, or an object whose one list-valued key holds it
/// (`{"RobPoses": [...]}`): mm and deg, FANUC's W, P, R (R = Rz(r) Ry(p) Rx(w)).
fn json(text: &str, file: &str) -> Result<PoseList, FormatError> {
    let bad = |e: serde_json::Error| {
        field(
            file,
            format!("line {}, column {}", e.line(), e.column()),
            format!("not a JSON list of [x, y, z, w, p, r] lists: {e}"),
        )
    };
    let value: serde_json::Value = serde_json::from_str(text).map_err(bad)?;
    let list = match value {
        serde_json::Value::Object(map) => {
            let lists: Vec<(String, serde_json::Value)> =
                map.into_iter().filter(|(_, v)| v.is_array()).collect();
            match <[_; 1]>::try_from(lists) {
                Ok([(_, v)]) => v,
                Err(lists) => {
                    return Err(field(
                        file,
                        "the object",
                        format!(
                            "{} list-valued keys ({}): want one key holding the [x, y, z, w, p, \
                             r] lists",
                            lists.len(),
                            lists
                                .iter()
                                .map(|l| l.0.as_str())
                                .collect::<Vec<_>>()
                                .join(", ")
                        ),
                    ));
                }
            }
        }
        v => v,
    };
    let rows: Vec<Vec<f64>> = serde_json::from_value(list).map_err(bad)?;
    for (i, r) in rows.iter().enumerate() {
        if r.len() != 6 {
            return Err(field(
                file,
                format!("pose {}", i + 1),
                format!(
                    "{} numbers; give [x_mm, y_mm, z_mm, w_deg, p_deg, r_deg]",
                    r.len()
                ),
            ));
        }
    }
    Ok(PoseList {
        warnings: Vec::new(),
        key: "tcp_mm_wpr_deg",
        at: (1..=rows.len()).map(|i| format!("pose {i}")).collect(),
        summary: format!(
            "{} poses from a JSON list, read as x, y, z mm and FANUC W, P, R deg \
             (R = Rz(r) Ry(p) Rx(w))",
            rows.len()
        ),
        rows,
    })
}

/// Lines of six numbers (spaces or commas), `#` comments: x y z w p r as in `json`.
fn text_list(text: &str, file: &str) -> Result<PoseList, FormatError> {
    let (mut rows, mut at) = (Vec::new(), Vec::new());
    for (i, line) in text.lines().enumerate() {
        let l = line.split('#').next().unwrap_or("").trim();
        if l.is_empty() {
            continue;
        }
        let here = format!("line {}", i + 1);
        let cells: Vec<&str> = l
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|s| !s.is_empty())
            .collect();
        if cells.len() != 6 {
            return Err(field(
                file,
                here,
                format!(
                    "{} values; give x_mm y_mm z_mm w_deg p_deg r_deg per line (or a CSV with \
                     a header naming its convention)",
                    cells.len()
                ),
            ));
        }
        let row = cells
            .iter()
            .zip(["x", "y", "z", "w", "p", "r"])
            .map(|(c, n)| number(file, &here, n, c))
            .collect::<Result<Vec<f64>, _>>()?;
        rows.push(row);
        at.push(here);
    }
    Ok(PoseList {
        warnings: Vec::new(),
        key: "tcp_mm_wpr_deg",
        summary: format!(
            "{} poses from a text list, read as x, y, z mm and FANUC W, P, R deg \
             (R = Rz(r) Ry(p) Rx(w))",
            rows.len()
        ),
        rows,
        at,
    })
}

/// The 1-based line of byte offset `pos` in `text`.
fn line_of(text: &str, pos: usize) -> usize {
    text[..pos.min(text.len())].matches('\n').count() + 1
}

/// Each extended axis of a FANUC program's group 2: its unit, and its least and greatest value
/// with the pose that holds it.
#[derive(Default)]
struct Extended(std::collections::BTreeMap<String, (&'static str, (f64, String), (f64, String))>);

impl Extended {
    /// The axes' values in one `P[n]{ ... }` block's body.
    fn note(&mut self, body: &str, label: &str) {
        let Some(g) = body.find("GP2") else {
            return;
        };
        for piece in body[g + 3..].split([',', '\n', '\r', '\t']) {
            let Some((name, value)) = piece.trim().split_once('=') else {
                continue;
            };
            let unit = if value.contains("mm") { "mm" } else { "deg" };
            let v = value
                .trim()
                .trim_end_matches("deg")
                .trim_end_matches("mm")
                .trim();
            if let Ok(v) = v.parse::<f64>()
                && v.is_finite()
            {
                let at = || (v, label.to_string());
                let e = self
                    .0
                    .entry(name.trim().to_ascii_uppercase())
                    .or_insert_with(|| (unit, at(), at()));
                if v < e.1.0 {
                    e.1 = at();
                }
                if v > e.2.0 {
                    e.2 = at();
                }
            }
        }
    }

    /// An extended axis that moves between poses moves the robot or the part (a track, a
    /// positioner) in a way the group 1 poses do not hold. FANUC prints three decimals: a change
    /// of more than one in the last is a move.
    fn warnings(&self, file: &str) -> Vec<String> {
        self.0
            .iter()
            .filter(|(_, (_, lo, hi))| hi.0 - lo.0 > 1.5e-3)
            .map(|(name, (unit, lo, hi))| {
                format!(
                    "{file}: group 2's {name} moves between poses, {:.3} {unit} ({}) to {:.3} \
                     {unit} ({}); lasercal reads group 1 only. If that axis carries the robot or \
                     the specimen (a track, a positioner), the poses do not place the sensor in \
                     one frame and the calibration will not fit: keep it still while \
                     calibrating, or give poses in a frame that includes it",
                    lo.0, lo.1, hi.0, hi.1
                )
            })
            .collect()
    }
}

/// FANUC `.ls`: every `P[n]{ ... };` block's group 1, Cartesian (X..R) or joints (J1..J6). The
/// user and tool frame numbers are reported; poses in different frames are refused.
fn fanuc(text: &str, file: &str) -> Result<PoseList, FormatError> {
    let (mut rows, mut at) = (Vec::new(), Vec::new());
    let mut frames: Option<(String, String)> = None;
    let mut joints: Option<bool> = None;
    let mut extended = Extended::default();
    let mut from = 0;
    while let Some(k) = text[from..].find("P[") {
        let start = from + k;
        let here = format!("line {}", line_of(text, start));
        let label_end = text[start..]
            .find(']')
            .map(|e| start + e)
            .ok_or_else(|| field(file, &here, "P[ without its closing ]"))?;
        let label = &text[start..=label_end];
        let open = text[label_end..].find('{').map(|o| label_end + o);
        // `P[n]` inside an instruction (L P[1] 100mm/sec FINE) has no block after it.
        let Some(open) = open.filter(|&o| text[label_end + 1..o].trim().is_empty()) else {
            from = label_end + 1;
            continue;
        };
        let close = text[open..]
            .find('}')
            .map(|c| open + c)
            .ok_or_else(|| field(file, &here, format!("{label}: block not closed with }}")))?;
        let body = &text[open + 1..close];
        // Group 1 only; other groups are extended axes, kept to see whether they move.
        extended.note(body, label);
        let gp1 = match body.find("GP1") {
            Some(g) => {
                let rest = &body[g + 3..];
                match rest.find("GP2") {
                    Some(e) => &rest[..e],
                    None => rest,
                }
            }
            None => body,
        };
        let mut values: Vec<(String, String)> = Vec::new();
        for piece in gp1.split([',', '\n', '\r', '\t']) {
            let piece = piece.trim().trim_start_matches(':').trim();
            if let Some((name, value)) = piece.split_once('=').or_else(|| piece.split_once(':')) {
                values.push((name.trim().to_ascii_uppercase(), value.trim().to_string()));
            }
        }
        let get = |n: &str| values.iter().find(|(k, _)| k == n).map(|(_, v)| v.clone());
        let strip = |v: String| {
            v.trim_end_matches("deg")
                .trim_end_matches("mm")
                .trim()
                .to_string()
        };
        let uf = get("UF").unwrap_or_else(|| "?".into());
        let ut = get("UT").unwrap_or_else(|| "?".into());
        match &frames {
            None => frames = Some((uf.clone(), ut.clone())),
            Some((f0, t0)) if *f0 != uf || *t0 != ut => {
                return Err(field(
                    file,
                    &here,
                    format!(
                        "{label} is in user frame {uf}, tool frame {ut}; the first pose in user \
                         frame {f0}, tool frame {t0}: give every pose in one frame"
                    ),
                ));
            }
            _ => {}
        }
        let cart = ["X", "Y", "Z", "W", "P", "R"];
        let joint = ["J1", "J2", "J3", "J4", "J5", "J6"];
        let is_joint = get("X").is_none() && get("J1").is_some();
        if *joints.get_or_insert(is_joint) != is_joint {
            return Err(field(
                file,
                &here,
                format!("{label}: joints and Cartesian poses mixed; give one kind"),
            ));
        }
        let names = if is_joint { joint } else { cart };
        let row = names
            .iter()
            .map(|n| {
                let v = get(n).ok_or_else(|| {
                    field(file, &here, format!("{label}: no {n} = value in group 1"))
                })?;
                number(file, &here, &format!("{label} {n}"), &strip(v))
            })
            .collect::<Result<Vec<f64>, _>>()?;
        rows.push(row);
        at.push(format!("{here} ({label})"));
        from = close + 1;
    }
    let (uf, ut) = frames.unwrap_or_default();
    let kind = if joints == Some(true) {
        "joint positions"
    } else {
        "positions (x, y, z mm; W, P, R deg: R = Rz(r) Ry(p) Rx(w))"
    };
    let warnings = extended.warnings(file);
    Ok(PoseList {
        warnings,
        key: if joints == Some(true) {
            "joints_deg"
        } else {
            "tcp_mm_wpr_deg"
        },
        summary: format!(
            "{} FANUC {kind} in user frame {uf}, tool frame {ut} (lasercal takes them as the \
             flange's pose in the robot's base: with a user or tool frame other than 0, the \
             result is the transform from that tool frame)",
            rows.len()
        ),
        rows,
        at,
    })
}

/// ABB RAPID: every `robtarget name := [[x, y, z], [q1, q2, q3, q4], ...]` (mm; q1 = w).
fn rapid(text: &str, file: &str) -> Result<PoseList, FormatError> {
    let (mut rows, mut at) = (Vec::new(), Vec::new());
    let lower = text.to_ascii_lowercase();
    let mut from = 0;
    while let Some(k) = lower[from..].find("robtarget") {
        let start = from + k;
        let here = format!("line {}", line_of(text, start));
        from = start + "robtarget".len();
        let Some(assign) = text[from..].find(":=").map(|a| from + a) else {
            continue;
        };
        let name = text[from..assign].trim().to_string();
        // Only a declaration (`robtarget p10 := [...]`), not a parameter or a type name.
        if name.is_empty() || name.contains(|c: char| c == ';' || c == '\n' || c == '(') {
            continue;
        }
        let rest = &text[assign + 2..];
        let end = rest.find(';').unwrap_or(rest.len());
        let value = &rest[..end];
        // The first two bracketed groups: translation and quaternion.
        let groups: Vec<&str> = value
            .split('[')
            .filter_map(|s| s.split(']').next())
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .take(2)
            .collect();
        let parse = |s: &str, n: usize, what: &str| -> Result<Vec<f64>, FormatError> {
            let v = s
                .split(',')
                .map(|c| number(file, &here, &format!("{name} {what}"), c))
                .collect::<Result<Vec<f64>, _>>()?;
            if v.len() != n {
                return Err(field(
                    file,
                    &here,
                    format!("{name}: {what} has {} values, want {n}", v.len()),
                ));
            }
            Ok(v)
        };
        if groups.len() < 2 {
            return Err(field(
                file,
                &here,
                format!("{name}: want [[x, y, z], [q1, q2, q3, q4], ...]"),
            ));
        }
        let mut row = parse(groups[0], 3, "trans")?;
        row.extend(parse(groups[1], 4, "rot")?);
        rows.push(row);
        at.push(format!("{here} ({name})"));
        from = assign + 2 + end;
    }
    Ok(PoseList {
        warnings: Vec::new(),
        key: "tcp_mm_wxyz",
        summary: format!(
            "{} ABB RAPID robtargets (x, y, z mm; q1..q4 = w, x, y, z)",
            rows.len()
        ),
        rows,
        at,
    })
}

/// One HALCON pose file (`write_pose`): `f 0` (R p + T, R = Rx(a) Ry(b) Rz(g), a point's
/// transform), `f 2` (R = Rz(g) Ry(b) Rx(a)) or `f 4` (a Rodriguez vector), `r a b g` in degrees,
/// `t x y z` in metres. Returns a 4x4 row (translation mm).
fn halcon(text: &str, file: &str) -> Result<Vec<f64>, FormatError> {
    let (mut f, mut r, mut t) = (None, None, None);
    for (i, line) in text.lines().enumerate() {
        let l = line.trim();
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        let here = format!("line {}", i + 1);
        let mut parts = l.split_whitespace();
        let tag = parts.next().unwrap_or("");
        let vals: Vec<&str> = parts.collect();
        let three = |what: &str| -> Result<[f64; 3], FormatError> {
            if vals.len() != 3 {
                return Err(field(
                    file,
                    &here,
                    format!("'{tag}' has {} values, want 3 ({what})", vals.len()),
                ));
            }
            Ok([
                number(file, &here, tag, vals[0])?,
                number(file, &here, tag, vals[1])?,
                number(file, &here, tag, vals[2])?,
            ])
        };
        match tag {
            "f" => f = Some((vals.join(" "), here)),
            "r" => r = Some(three("rotation angles, deg")?),
            "t" => t = Some(three("translation, m")?),
            _ => {}
        }
    }
    let (Some((f, fat)), Some(r), Some(t)) = (f, r, t) else {
        return Err(field(
            file,
            "the file",
            "not a HALCON pose file: want the lines 'f 0' (or 2, 4), 'r a b g' (deg) and 't x y z' \
             (m)",
        ));
    };
    use nalgebra::{Rotation3, Vector3};
    let about = |axis: usize, deg: f64| {
        let mut v = Vector3::zeros();
        v[axis] = deg.to_radians();
        Rotation3::from_scaled_axis(v)
    };
    let rot = match f.as_str() {
        // 'gba': R = Rx(a) Ry(b) Rz(g).
        "0" => about(0, r[0]) * about(1, r[1]) * about(2, r[2]),
        // 'abg': R = Rz(g) Ry(b) Rx(a).
        "2" => about(2, r[2]) * about(1, r[1]) * about(0, r[0]),
        // 'rodriguez': r = tan(angle / 2) times the unit axis.
        "4" => {
            let v = Vector3::from(r);
            let n = v.norm();
            if n == 0.0 {
                Rotation3::identity()
            } else {
                Rotation3::from_scaled_axis(v / n * (2.0 * n.atan()))
            }
        }
        _ => {
            return Err(field(
                file,
                fat,
                format!(
                    "pose type {f}: lasercal reads types 0, 2 and 4 (R p + T of a point, with \
                     'gba', 'abg' or 'rodriguez' angles); convert the pose with \
                     convert_pose_type first"
                ),
            ));
        }
    };
    let m = rot.matrix();
    Ok(vec![
        m[(0, 0)],
        m[(0, 1)],
        m[(0, 2)],
        t[0] * 1e3,
        m[(1, 0)],
        m[(1, 1)],
        m[(1, 2)],
        t[1] * 1e3,
        m[(2, 0)],
        m[(2, 1)],
        m[(2, 2)],
        t[2] * 1e3,
        0.0,
        0.0,
        0.0,
        1.0,
    ])
}

/// One profile's points (x, z mm, sensor frame; None: no point) from an OpenCV `FileStorage`
/// YAML file: a `!!opencv-matrix` of (x, y, z) or (x, z) per point (`cols` times the channels of
/// `dt`), or a list of `[x, y, z]` / `[x, z]` entries. With several (an extracted feature point
/// beside the profile), the one with the most points is the profile. y must be 0 (a profile,
/// not a point cloud).
pub fn opencv_profile(text: &str, file: &str) -> Result<Vec<Option<[f64; 2]>>, FormatError> {
    // Candidates: (key, width, values).
    let mut found: Vec<(String, usize, Vec<f64>)> = Vec::new();
    let lines: Vec<&str> = text.lines().filter(|l| !l.starts_with('%')).collect();
    let mut i = 0;
    let mut key = String::new();
    while i < lines.len() {
        let l = lines[i].trim();
        if let Some((k, rest)) = l.split_once(':')
            && !k.trim().starts_with('-')
            && !k.contains('[')
        {
            let (k, rest) = (k.trim(), rest.trim());
            // A new entry's name (the matrix's or the list's).
            if (rest.starts_with("!!opencv-matrix") || rest.is_empty())
                && !matches!(k, "rows" | "cols" | "dt" | "data")
            {
                key = k.to_string();
            }
            if k == "data" {
                // The matrix this data belongs to: its rows, cols and dt just above.
                let (mut cols, mut channels) = (0usize, 1usize);
                for back in lines[..i].iter().rev().take(4) {
                    let b = back.trim();
                    if let Some(v) = b.strip_prefix("cols:") {
                        cols = v.trim().parse().unwrap_or(0);
                    } else if let Some(v) = b.strip_prefix("dt:") {
                        let v = v.trim().trim_matches('"');
                        channels = v.trim_end_matches(char::is_alphabetic).parse().unwrap_or(1);
                    }
                }
                let body = joined(&lines, &mut i, rest, |b| b.contains(']'));
                let values = numbers(&body, file, i + 1)?;
                found.push((key.clone(), cols * channels, values));
            } else if rest.starts_with('[') && !rest[1..].trim_start().starts_with('[') {
                // A flat list: x, y, z per point when every second of three is 0, else x, z.
                let body = joined(&lines, &mut i, rest, |b| b.contains(']'));
                let values = numbers(&body, file, i + 1)?;
                let triples = values.len() % 3 == 0
                    && values
                        .iter()
                        .skip(1)
                        .step_by(3)
                        .all(|y| *y == 0.0 || y.is_nan());
                found.push((k.to_string(), if triples { 3 } else { 2 }, values));
            } else if rest.starts_with("[[") || rest.starts_with("[ [") {
                let body = joined(&lines, &mut i, rest, |b| b.trim_end().ends_with("]]"));
                let rows: Vec<Vec<f64>> = body
                    .trim()
                    .trim_start_matches('[')
                    .trim_end_matches(']')
                    .split(']')
                    .map(|r| numbers(r, file, i + 1))
                    .collect::<Result<Vec<_>, _>>()?
                    .into_iter()
                    .filter(|r| !r.is_empty())
                    .collect();
                push_rows(&mut found, k, rows, file, i + 1)?;
            } else if rest.is_empty() {
                // A block list of `- [x, y, z]` entries.
                let mut rows = Vec::new();
                while i + 1 < lines.len() && lines[i + 1].trim().starts_with('-') {
                    i += 1;
                    rows.push(numbers(
                        lines[i].trim().trim_start_matches('-'),
                        file,
                        i + 1,
                    )?);
                }
                if !rows.is_empty() {
                    push_rows(&mut found, k, rows, file, i + 1)?;
                }
            }
        }
        i += 1;
    }
    let Some((key, width, values)) = found.into_iter().max_by_key(|f| f.2.len()) else {
        return Err(field(
            file,
            "the whole file",
            "no profile in it: want an !!opencv-matrix of (x, 0, z) per point or a list of \
             [x, 0, z] entries",
        ));
    };
    if !(width == 2 || width == 3) || values.len() % width != 0 {
        return Err(field(
            file,
            key,
            format!(
                "{} values of width {width}: want (x, 0, z) or (x, z) per point",
                values.len()
            ),
        ));
    }
    values
        .chunks(width)
        .enumerate()
        .map(|(k, p)| {
            let (x, z) = (p[0], p[width - 1]);
            if width == 3 && p[1].is_finite() && p[1].abs() > 1e-6 {
                return Err(field(
                    file,
                    format!("{key}, point {k}"),
                    format!(
                        "y = {}: a profile's points have y = 0 (x, 0, z); this looks like a \
                         point cloud",
                        p[1]
                    ),
                ));
            }
            Ok((x.is_finite() && z.is_finite()).then_some([x, z]))
        })
        .collect()
}

/// `rest` and the lines after line `i` joined until `done` holds of the whole (a flow list
/// spread over lines); `i` is left on the last line taken.
fn joined(lines: &[&str], i: &mut usize, rest: &str, done: impl Fn(&str) -> bool) -> String {
    let mut body = rest.to_string();
    while !done(&body) && *i + 1 < lines.len() {
        *i += 1;
        body.push(' ');
        body.push_str(lines[*i].trim());
    }
    body
}

fn push_rows(
    found: &mut Vec<(String, usize, Vec<f64>)>,
    key: &str,
    rows: Vec<Vec<f64>>,
    file: &str,
    line: usize,
) -> Result<(), FormatError> {
    let width = rows.first().map_or(0, Vec::len);
    if rows.iter().any(|r| r.len() != width) {
        return Err(field(
            file,
            format!("line {line}, {key}"),
            "entries of different lengths: want [x, 0, z] or [x, z] each",
        ));
    }
    found.push((key.to_string(), width, rows.concat()));
    Ok(())
}

/// The numbers of a bracketed list (commas or spaces; `.nan`, `nan` for no value).
fn numbers(s: &str, file: &str, line: usize) -> Result<Vec<f64>, FormatError> {
    s.split(|c: char| c == ',' || c == '[' || c == ']' || c.is_whitespace())
        .filter(|t| !t.is_empty())
        .map(|t| {
            let lower = t.to_ascii_lowercase();
            if matches!(lower.as_str(), ".nan" | "nan" | "-nan") {
                return Ok(f64::NAN);
            }
            t.parse::<f64>().map_err(|_| {
                field(
                    file,
                    format!("line {line}"),
                    format!("'{t}' is not a number"),
                )
            })
        })
        .collect()
}

/// One profile's points from two lines of text: the x values, then the z values (mm; spaces,
/// tabs or commas), as many of each.
pub fn two_row_profile(text: &str, file: &str) -> Result<Vec<Option<[f64; 2]>>, FormatError> {
    let rows: Vec<(usize, &str)> = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'))
        .collect();
    if rows.len() != 2 {
        return Err(field(
            file,
            "the whole file",
            format!(
                "{} lines of values: a two-row profile has the x values on one line and the z \
                 values on the next",
                rows.len()
            ),
        ));
    }
    let x = numbers(rows[0].1, file, rows[0].0 + 1)?;
    let z = numbers(rows[1].1, file, rows[1].0 + 1)?;
    if x.len() != z.len() {
        return Err(field(
            file,
            format!("line {}", rows[1].0 + 1),
            format!("{} z values for {} x values", z.len(), x.len()),
        ));
    }
    Ok(x.iter()
        .zip(&z)
        .map(|(x, z)| (x.is_finite() && z.is_finite()).then_some([*x, *z]))
        .collect())
}
