//! docs/reference/scenario.md, generated from the schema that validates scenario files: each
//! section's keys, types, units, defaults and meanings come from the schema structs' fields and
//! their doc comments (`src/schema/`), and the keys are checked against what the parser itself
//! accepts. The test fails when the file is stale, when a key lacks a description, or when a
//! number's unit is neither in its name nor in its description. `LASERCAL_BLESS=1 cargo test
//! --test reference` rewrites the file.

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
    spec("", "mod.rs", "Scenario", "chen2018-disk.toml"),
    spec("robot", "sections.rs", "RobotSection", "chen2018-disk.toml"),
    spec(
        "sensor",
        "sections.rs",
        "SensorSection",
        "chen2018-disk.toml",
    ),
    spec(
        "sensor.noise",
        "sections.rs",
        "NoiseSection",
        "ball-free.toml",
    ),
    spec("sensor.geometry", "sensor.rs", "GeometrySection", ""),
    spec(
        "specimen",
        "sections.rs",
        "SpecimenSection",
        "chen2018-disk.toml",
    ),
    spec("table", "sections.rs", "TableSection", "chen2018-disk.toml"),
    spec("disk", "disk.rs", "Section", "chen2018-disk.toml"),
    spec("ball", "ball.rs", "Section", "chen2018-ball.toml"),
    spec("edge", "edge.rs", "Section", "xu2021-edge.toml"),
    spec(
        "edge.validation",
        "edge.rs",
        "Validation",
        "xu2021-rotations.toml",
    ),
    spec("plane", "plane.rs", "Section", "plane-8-poses.toml"),
    spec("plane.poses", "poses.rs", "PoseSet", "plane-8-poses.toml"),
    spec(
        "robot_error",
        "sections.rs",
        "RobotErrorSection",
        "disk-robot-error.toml",
    ),
    spec(
        "vibration",
        "sections.rs",
        "VibrationSection",
        "disk-robot-error.toml",
    ),
    spec("dynamics", "sections.rs", "DynamicsSection", ""),
    spec(
        "causes",
        "sections.rs",
        "CausesSection",
        "ridge-16-poses.toml",
    ),
    spec(
        "sweep",
        "sections.rs",
        "SweepSection",
        "chen2018-fig15.toml",
    ),
    spec(
        "sweep.plot",
        "sections.rs",
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

/// The fields of `strukt` in `src/schema/FILE`, with their doc comments and serde defaults.
fn fields(file: &str, strukt: &str) -> Vec<Field> {
    let text = std::fs::read_to_string(format!("{}/src/schema/{file}", root())).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let start = lines
        .iter()
        .position(|l| {
            let t = l.trim_start();
            t.starts_with(&format!("pub struct {strukt} "))
                || t.starts_with(&format!("struct {strukt} "))
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
        } else if let Some((name, ty)) = t.trim_start_matches("pub ").split_once(": ") {
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
        .unwrap_or_else(|| panic!("[{}]: the probe key was accepted", section.path))
        .to_string();
    // "expected `a`", "expected `a` or `b`", "expected one of `a`, `b`, ...".
    let list = e
        .split("zzz_unknown_key`, expected ")
        .nth(1)
        .unwrap_or_else(|| panic!("[{}]: {e}", section.path));
    Some(
        list.lines()
            .next()
            .unwrap_or("")
            .split('`')
            .skip(1)
            .step_by(2)
            .map(str::to_string)
            .collect(),
    )
}

fn generate() -> String {
    let mut s = String::from(
        "# Scenario file reference\n\nGenerated from the schema that reads scenario files \
         (`src/schema/`) by `tests/reference.rs`, which fails when this file is stale, when a \
         key has no description or when a number's unit is neither in its name nor in its \
         description; `LASERCAL_BLESS=1 cargo test --test reference` rewrites it. Lengths are \
         mm and angles deg or rad as each name says; unknown keys are errors. Worked examples: \
         [the guide](../guide/scenarios.md) and `scenarios/`. The pose sets of `[disk.poses]`, \
         `[ball.poses]` and `[edge.poses]` take the keys of `[plane.poses]`; `[ball.specimen]` \
         and `[edge.specimen]` those of `[specimen]`.\n",
    );
    for section in SECTIONS {
        let title = if section.path.is_empty() {
            "top level".to_string()
        } else {
            format!("[{}]", section.path)
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

#[test]
fn the_scenario_reference_is_current_and_complete() {
    let mut problems = Vec::new();
    for section in SECTIONS {
        let fields = fields(section.file, section.strukt);
        let names: BTreeSet<String> = fields.iter().map(|f| f.name.clone()).collect();
        if let Some(keys) = accepted(section) {
            if keys != names {
                problems.push(format!(
                    "[{}]: the parser takes {keys:?}, the reference lists {names:?}",
                    section.path
                ));
            }
        }
        for f in &fields {
            if f.doc.is_empty() {
                problems.push(format!("[{}] {}: no description", section.path, f.name));
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
            ];
            let doc = f.doc.to_lowercase();
            if number && unit_of(&f.name).is_empty() && !words.iter().any(|w| doc.contains(w)) {
                problems.push(format!(
                    "[{}] {}: a number with no unit in its name or description",
                    section.path, f.name
                ));
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    let path = format!("{}/docs/reference/scenario.md", root());
    let text = generate();
    if std::env::var_os("LASERCAL_BLESS").is_some() {
        std::fs::create_dir_all(format!("{}/docs/reference", root())).unwrap();
        std::fs::write(&path, &text).unwrap();
    }
    let on_disk = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        on_disk == text,
        "docs/reference/scenario.md is stale: LASERCAL_BLESS=1 cargo test --test reference"
    );
}
