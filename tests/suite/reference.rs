//! docs/reference/scenario.md and docs/reference/captures.md, generated from the schemas that
//! read scenario and capture files: each section's keys, types, units, defaults and meanings come
//! from the reading structs' fields and their doc comments (`src/schema/`, `src/io/captures.rs`),
//! and the keys are checked against what the parsers themselves accept. The test fails when a
//! file is stale, when a key lacks a description, or when a number's unit is neither in its name
//! nor in its description. `LASERCAL_BLESS=1 cargo test --test suite reference::` rewrites the files.

use std::collections::BTreeSet;

/// A section of the scenario file: its TOML path, the struct that reads it, a scenario that has
/// (or may get) it for asking the parser which keys it takes.
struct SectionSpec {
    path: &'static str,
    file: &'static str,
    strukt: &'static str,
    base: &'static str,
}

const SECTIONS: &[SectionSpec] = &[
    spec("", "schema/mod.rs", "Scenario", "chen2018-disk.toml"),
    spec(
        "robot",
        "schema/sections.rs",
        "RobotSection",
        "chen2018-disk.toml",
    ),
    spec(
        "sensor",
        "schema/sections.rs",
        "SensorSection",
        "chen2018-disk.toml",
    ),
    spec(
        "sensor.noise",
        "schema/sections.rs",
        "NoiseSection",
        "ball-free.toml",
    ),
    spec("sensor.geometry", "schema/sensor.rs", "GeometrySection", ""),
    spec(
        "specimen",
        "schema/sections.rs",
        "SpecimenSection",
        "chen2018-disk.toml",
    ),
    spec(
        "table",
        "schema/sections.rs",
        "TableSection",
        "chen2018-disk.toml",
    ),
    spec("disk", "schema/disk.rs", "Section", "chen2018-disk.toml"),
    spec("ball", "schema/ball.rs", "Section", "chen2018-ball.toml"),
    spec("edge", "schema/edge.rs", "Section", "xu2021-edge.toml"),
    spec(
        "edge.validation",
        "schema/edge.rs",
        "Validation",
        "xu2021-rotations.toml",
    ),
    spec("plane", "schema/plane.rs", "Section", "plane-8-poses.toml"),
    spec(
        "plane.poses",
        "schema/poses.rs",
        "PoseSet",
        "plane-8-poses.toml",
    ),
    spec(
        "robot_error",
        "schema/sections.rs",
        "RobotErrorSection",
        "disk-robot-error.toml",
    ),
    spec(
        "vibration",
        "schema/sections.rs",
        "VibrationSection",
        "disk-robot-error.toml",
    ),
    spec("dynamics", "schema/sections.rs", "DynamicsSection", ""),
    spec(
        "causes",
        "schema/sections.rs",
        "CausesSection",
        "ridge-16-poses.toml",
    ),
    spec(
        "sweep",
        "schema/sections.rs",
        "SweepSection",
        "chen2018-fig15.toml",
    ),
    spec(
        "sweep.plot",
        "schema/sections.rs",
        "PlotSection",
        "chen2018-fig15.toml",
    ),
];

const fn spec(
    path: &'static str,
    file: &'static str,
    strukt: &'static str,
    base: &'static str,
) -> SectionSpec {
    SectionSpec {
        path,
        file,
        strukt,
        base,
    }
}

/// One field as the source declares it.
struct Field {
    name: String,
    ty: String,
    doc: String,
    default: String,
}

fn root() -> &'static str {
    env!("CARGO_MANIFEST_DIR")
}

/// The fields of `strukt` in `src/FILE`, with their doc comments and serde defaults.
fn fields(file: &str, strukt: &str) -> Vec<Field> {
    let text = std::fs::read_to_string(format!("{}/src/{file}", root())).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let start = lines
        .iter()
        .position(|l| {
            let t = l.trim_start();
            t.starts_with(&format!("pub struct {strukt} "))
                || t.starts_with(&format!("struct {strukt} "))
                || t.starts_with(&format!("pub(crate) struct {strukt} "))
        })
        .unwrap_or_else(|| panic!("no struct {strukt} in {file}"));
    let mut out = Vec::new();
    let (mut doc, mut default): (Vec<String>, Option<String>) = (Vec::new(), None);
    for l in &lines[start + 1..] {
        let t = l.trim();
        if t.starts_with('}') {
            break;
        }
        if let Some(d) = t.strip_prefix("///") {
            doc.push(d.trim().to_string());
        } else if t.starts_with("#[serde(") {
            if let Some(f) = t.split("default = \"").nth(1) {
                let f = f.split('"').next().unwrap();
                default = Some(default_fn(&text, f));
            } else if t.contains("default") {
                default = Some(String::new());
            }
        } else if t.starts_with("//") || t.is_empty() || t.starts_with("#[") {
        } else if let Some((name, ty)) = t
            .trim_start_matches("pub(crate) ")
            .trim_start_matches("pub ")
            .split_once(": ")
        {
            let ty = ty.trim_end_matches(',').to_string();
            let default = match default.take() {
                Some(d) if !d.is_empty() => d,
                Some(_) => type_default(&ty),
                None if ty.starts_with("Option<") => "none".into(),
                None => "required".into(),
            };
            out.push(Field {
                name: name.to_string(),
                ty,
                doc: std::mem::take(&mut doc).join(" "),
                default,
            });
        }
    }
    out
}

/// The value a `fn d_x() -> T { value }` returns, as written.
fn default_fn(text: &str, f: &str) -> String {
    let at = text
        .find(&format!("fn {f}()"))
        .unwrap_or_else(|| panic!("no fn {f}"));
    let body = &text[at..];
    let open = body.find('{').unwrap();
    let close = body.find('}').unwrap();
    tidy(body[open + 1..close].trim())
}

/// A Rust default as a scenario file would write it.
fn tidy(v: &str) -> String {
    if v == "vec![MethodId::new(Kind::Disk, Estimator::ClosedForm)]" {
        return "[\"disk\"]".into();
    }
    let v = v.trim_end_matches(".into()");
    match v.rsplit_once("::") {
        Some((_, variant)) if v.chars().next().is_some_and(char::is_uppercase) => {
            format!("\"{}\"", kebab(variant))
        }
        _ => v.to_string(),
    }
}

/// `EqualTan` -> `equal-tan` (serde's kebab-case; a one-word variant is lowercase either way).
fn kebab(variant: &str) -> String {
    let mut out = String::new();
    for (i, c) in variant.chars().enumerate() {
        if c.is_uppercase() && i > 0 {
            out.push('-');
        }
        out.extend(c.to_lowercase());
    }
    out
}

/// The variant an enum marks `#[default]`, as a scenario file names it.
fn enum_default(ty: &str) -> Option<String> {
    let name = ty.rsplit("::").next()?;
    for dir in ["src/schema", "src/scene", "src/sensor", "src/features"] {
        for e in std::fs::read_dir(format!("{}/{dir}", root())).ok()? {
            let text = std::fs::read_to_string(e.ok()?.path()).unwrap_or_default();
            let Some(at) = text.find(&format!("enum {name} {{")) else {
                continue;
            };
            let body = &text[at..];
            let body = &body[..body.find("\n}").unwrap_or(body.len())];
            let after = body.split("#[default]").nth(1)?;
            let variant = after.trim_start().split([',', ' ', '\n']).next()?;
            return Some(format!("\"{}\"", kebab(variant)));
        }
    }
    None
}

fn type_default(ty: &str) -> String {
    match ty {
        "f64" | "usize" | "u64" | "u32" => "0".into(),
        "bool" => "false".into(),
        "String" => "\"\"".into(),
        t if t.starts_with("Option<") => "none".into(),
        t if t.starts_with("Vec<") => "[]".into(),
        t if t.starts_with('[') => "zeros".into(),
        t if t.ends_with("Section") => "its keys' defaults".into(),
        t => enum_default(t).unwrap_or_else(|| "see meaning".into()),
    }
}

/// What a key's value looks like, in words.
fn kind_of(ty: &str) -> String {
    let inner = ty
        .strip_prefix("Option<")
        .and_then(|t| t.strip_suffix('>'))
        .unwrap_or(ty);
    match inner {
        "f64" => "number".into(),
        "usize" | "u64" | "u32" => "integer".into(),
        "bool" => "true / false".into(),
        "String" => "text".into(),
        "toml::Table" => "table".into(),
        t if t.starts_with("Vec<[f64; ") => format!("list of [{} numbers]", &t[10..t.len() - 2]),
        t if t.starts_with("Vec<") => "list".into(),
        "[[f64; 3]; 3]" => "3 x 3 numbers".into(),
        "[[f64; 4]; 4]" => "4 x 4 numbers".into(),
        "SensorV1" => "name or object".into(),
        t if t.ends_with("V1") => "object".into(),
        "[[f64; 2]; 2]" => "2 x 2 numbers".into(),
        t if t.starts_with("[f64; ") => format!("{} numbers", &t[6..t.len() - 1]),
        t if t.contains("Section") || t.contains("PoseSet") || t.contains("Validation") => {
            "table".into()
        }
        _ => "name".into(),
    }
}

/// The unit a key's name states.
fn unit_of(name: &str) -> &'static str {
    for (suffix, unit) in [
        ("_mm", "mm"),
        ("_deg", "deg"),
        ("_rad", "rad"),
        ("_ms", "ms"),
        ("_hz", "Hz"),
        ("_s", "s"),
    ] {
        if name.ends_with(suffix) {
            return unit;
        }
    }
    ""
}

/// The keys the parser accepts in `section` (its "expected one of" list for an unknown key).
fn accepted(section: &SectionSpec) -> Option<BTreeSet<String>> {
    if section.base.is_empty() {
        return None;
    }
    let text = std::fs::read_to_string(format!("{}/scenarios/{}", root(), section.base)).unwrap();
    let probe = "zzz_unknown_key = 1\n";
    let text = if section.path.is_empty() {
        format!("{probe}{text}")
    } else {
        let header = format!("[{}]\n", section.path);
        match text.find(&header) {
            Some(k) => format!("{}{header}{probe}{}", &text[..k], &text[k + header.len()..]),
            None => format!("{text}\n{header}{probe}"),
        }
    };
    let e = lasercal::scenario::ScenarioFile::parse(&text, "probe.toml")
        .err()
        .map(|e| e.to_string());
    Some(expected_keys(e, section.path))
}

/// The keys a parser's error for the probe key says it expected: "expected `a`", "expected `a`
/// or `b`", "expected one of `a`, `b`, ...". `error` is None when the probe was accepted.
fn expected_keys(error: Option<String>, section: &str) -> BTreeSet<String> {
    let e = error.unwrap_or_else(|| panic!("{section}: the probe key was accepted"));
    let list = e
        .split("zzz_unknown_key`, expected ")
        .nth(1)
        .unwrap_or_else(|| panic!("{section}: {e}"));
    list.lines()
        .next()
        .unwrap_or("")
        .split('`')
        .skip(1)
        .step_by(2)
        .map(str::to_string)
        .collect()
}

/// One table per section: key, value, unit, default, meaning.
fn tables(sections: &[SectionSpec], top: &str, toml: bool) -> String {
    let mut s = String::new();
    for section in sections {
        let title = match (section.path.is_empty(), toml) {
            (true, _) => top.to_string(),
            (false, true) => format!("[{}]", section.path),
            (false, false) => format!("`{}`", section.path),
        };
        s += &format!(
            "\n## {title}\n\n| key | value | unit | default | meaning |\n|---|---|---|---|---|\n"
        );
        for f in fields(section.file, section.strukt) {
            s += &format!(
                "| `{}` | {} | {} | {} | {} |\n",
                f.name,
                kind_of(&f.ty),
                unit_of(&f.name),
                f.default.replace('|', "\\|"),
                f.doc.replace('|', "\\|")
            );
        }
    }
    s
}

fn generate() -> String {
    String::from(
        "# Scenario file reference\n\nGenerated from the schema that reads scenario files \
         (`src/schema/`) by `tests/suite/reference.rs`, which fails when this file is stale, when a \
         key has no description or when a number's unit is neither in its name nor in its \
         description; `LASERCAL_BLESS=1 cargo test --test suite reference::` rewrites it. Lengths are \
         mm and angles deg or rad as each name says; unknown keys are errors. Worked examples: \
         [the guide](../guide/scenarios.md) and `scenarios/`. The pose sets of `[disk.poses]`, \
         `[ball.poses]` and `[edge.poses]` take the keys of `[plane.poses]`; `[ball.specimen]` \
         and `[edge.specimen]` those of `[specimen]`.\n",
    ) + &tables(SECTIONS, "top level", true)
}

/// The capture file's objects (JSON), as `io::captures` reads them.
const CAPTURE_SECTIONS: &[SectionSpec] = &[
    spec("", "io/captures.rs", "FileV1", "file"),
    spec("sensor.points_only", "io/captures.rs", "PointsOnlyV1", ""),
    spec("sensor_noise", "io/captures.rs", "NoiseV1", "sensor_noise"),
    spec("specimen", "io/captures.rs", "SpecimenV1", "specimen"),
    spec("groups[]", "io/captures.rs", "GroupV1", "groups"),
    spec("profiles[]", "io/captures.rs", "ProfileV1", "profiles"),
    spec("profiles[].circle_mm", "io/captures.rs", "CircleV1", ""),
];

/// The keys `from_json` accepts in one object of a simulated capture file (its "expected one
/// of" list for an unknown key).
fn accepted_in_captures(
    section: &SectionSpec,
    doc: &serde_json::Value,
) -> Option<BTreeSet<String>> {
    let mut doc = doc.clone();
    let target = match section.base {
        "" => return None,
        "file" => &mut doc,
        "groups" => &mut doc["groups"][0],
        "profiles" => &mut doc["profiles"][0],
        key => &mut doc[key],
    };
    target
        .as_object_mut()
        .unwrap_or_else(|| panic!("{}: not an object in the probe file", section.path))
        .insert("zzz_unknown_key".into(), serde_json::json!(1));
    let e = lasercal::io::captures::from_json(&doc.to_string(), "probe.json")
        .err()
        .map(|e| e.to_string());
    Some(expected_keys(e, section.path))
}

fn generate_captures() -> String {
    String::from(
        "# Capture file reference\n\nGenerated from the structs that read capture files \
         (`src/io/captures.rs`) by `tests/suite/reference.rs`, as `scenario.md` is. A capture file is \
         JSON; positions are mm in the base frame (flange poses) or the sensor frame (profile \
         points). How the fields work together, with an example: [captures.md](../captures.md). \
         `sensor` is a preset's name, a declared geometry (the keys of a scenario's \
         `[sensor.geometry]`, [scenario.md](scenario.md)), `\"points-only\"` or an object with \
         `points_only`.\n",
    ) + &tables(CAPTURE_SECTIONS, "the file", false)
}

/// Each section's problems: keys the parser takes that the struct scan missed (or the reverse),
/// keys without a description, numbers without a unit.
fn check(
    sections: &[SectionSpec],
    accepted: &dyn Fn(&SectionSpec) -> Option<BTreeSet<String>>,
    problems: &mut Vec<String>,
) {
    for section in sections {
        let fields = fields(section.file, section.strukt);
        let names: BTreeSet<String> = fields.iter().map(|f| f.name.clone()).collect();
        if let Some(keys) = accepted(section) {
            if keys != names {
                problems.push(format!(
                    "{}: the parser takes {keys:?}, the reference lists {names:?}",
                    section.path
                ));
            }
        }
        for f in &fields {
            if f.doc.is_empty() {
                problems.push(format!("{} {}: no description", section.path, f.name));
            }
            // A number with no unit in its name says in its description what it is measured in.
            let number = kind_of(&f.ty).contains("number");
            let words = [
                "fraction",
                "factor",
                "probability",
                "0..1",
                "multiple",
                "radians",
                "degrees",
                "mm",
                "1/s",
                "gain",
                "seed",
                "multiplies",
                "matrix",
                "direction",
                "quaternion",
                "+1 or -1",
            ];
            let doc = f.doc.to_lowercase();
            if number && unit_of(&f.name).is_empty() && !words.iter().any(|w| doc.contains(w)) {
                problems.push(format!(
                    "{} {}: a number with no unit in its name or description",
                    section.path, f.name
                ));
            }
        }
    }
}

/// `text` is what `docs/reference/NAME` holds (rewritten first under LASERCAL_BLESS).
fn assert_current(name: &str, text: &str) {
    let path = format!("{}/docs/reference/{name}", root());
    if std::env::var_os("LASERCAL_BLESS").is_some() {
        std::fs::create_dir_all(format!("{}/docs/reference", root())).unwrap();
        std::fs::write(&path, text).unwrap();
    }
    let on_disk = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        on_disk == text,
        "docs/reference/{name} is stale: LASERCAL_BLESS=1 cargo test --test suite reference::"
    );
}

#[test]
fn the_references_are_current_and_complete() {
    let mut problems = Vec::new();
    check(SECTIONS, &accepted, &mut problems);
    // A simulated capture file of raw ball profiles, for asking the capture parser.
    let sf = lasercal::scenario::ScenarioFile::load(std::path::Path::new(&format!(
        "{}/scenarios/ball-free.toml",
        root()
    )))
    .unwrap();
    let setup = sf.scenario.build(&sf.file).unwrap();
    let kind = sf.scenario.methods[0].kind;
    let caps = lasercal::trial::trial_captures(&setup, kind, 1, 0)
        .0
        .unwrap();
    let doc: serde_json::Value =
        serde_json::from_str(&lasercal::io::captures::to_json(&caps, &setup.rig.sensor)).unwrap();
    check(
        CAPTURE_SECTIONS,
        &|s| accepted_in_captures(s, &doc),
        &mut problems,
    );
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    assert_current("scenario.md", &generate());
    assert_current("captures.md", &generate_captures());
}
