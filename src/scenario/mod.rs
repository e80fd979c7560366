//! Scenario files: reading them (the schema is `crate::schema`, re-exported here), their sweep
//! grid (`grid`), validating every point once with each method's own checks (`validate`), and
//! building the experiment with every method's plan (`build`). Unknown keys and bad values are
//! errors that name the file, the key and the value.

mod build;
mod grid;
mod validate;

pub use crate::schema::*;
pub use build::Setup;
pub use grid::GridPoint;

/// A scenario file: the parsed scenario, its raw table (for grid overrides) and its grid points,
/// each deserialised and validated once.
#[derive(Debug, Clone)]
pub struct ScenarioFile {
    pub file: String,
    pub raw: toml::Table,
    pub scenario: Scenario,
    /// The grid's size (its points are built on demand: `point`).
    points: usize,
}

/// `[<section>.poses] csv = "file.csv"` (relative to the scenario's folder): the file's pose list
/// put in the table under the key its header names (`io::csv::pose_list`). True if any was.
fn pose_csvs(
    raw: &mut toml::Table,
    file: &str,
    dir: Option<&std::path::Path>,
) -> Result<bool, ScenarioError> {
    let mut any = false;
    for section in ["ball", "plane", "edge", "disk"] {
        let Some(toml::Value::Table(poses)) = raw
            .get_mut(section)
            .and_then(|s| s.as_table_mut())
            .and_then(|s| s.get_mut("poses"))
        else {
            continue;
        };
        let Some(csv) = poses.remove("csv") else {
            continue;
        };
        let key = format!("{section}.poses.csv");
        let bad = |value: String, reason: String| ScenarioError::BadValue {
            file: file.to_string(),
            key: key.clone(),
            value,
            reason,
        };
        let name = csv
            .as_str()
            .ok_or_else(|| bad(csv.to_string(), "give a file name".into()))?;
        let path = dir.unwrap_or(std::path::Path::new(".")).join(name);
        let f = std::fs::File::open(&path).map_err(|e| {
            bad(
                format!("\"{name}\""),
                format!("cannot read {}: {e}", path.display()),
            )
        })?;
        let (list, rows) = crate::io::csv::pose_list(f, &path.display().to_string())
            .map_err(|e| bad(format!("\"{name}\""), e.to_string()))?;
        if poses.contains_key(list) {
            return Err(bad(
                format!("\"{name}\""),
                format!("[{section}.poses] also gives {list}: give the poses once"),
            ));
        }
        let rows = rows
            .into_iter()
            .map(|r| toml::Value::Array(r.into_iter().map(toml::Value::Float).collect()))
            .collect();
        poses.insert(list.into(), toml::Value::Array(rows));
        any = true;
    }
    Ok(any)
}

impl ScenarioFile {
    /// Read and validate a scenario file (every grid point too).
    pub fn load(path: &std::path::Path) -> Result<ScenarioFile, ScenarioError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| ScenarioError::Io {
            file: file.clone(),
            message: e.to_string(),
        })?;
        ScenarioFile::from_text(&text, &file, path.parent())
    }

    /// Parse scenario text; `file` names it in errors.
    pub fn parse(text: &str, file: &str) -> Result<ScenarioFile, ScenarioError> {
        ScenarioFile::from_text(text, file, None)
    }

    /// A relative URDF path is resolved against `dir` (the scenario's folder).
    fn from_text(
        text: &str,
        file: &str,
        dir: Option<&std::path::Path>,
    ) -> Result<ScenarioFile, ScenarioError> {
        let syntax = |e: toml::de::Error| ScenarioError::Syntax {
            file: file.to_string(),
            message: e.to_string().trim().to_string(),
        };
        let mut raw: toml::Table = text.parse().map_err(syntax)?;
        // TOML has `nan` and `inf`; no key of a scenario means either: refused by name here, so
        // that no validation can miss one.
        if let Some((key, v)) = non_finite(&raw, "") {
            return Err(ScenarioError::BadValue {
                file: file.to_string(),
                key,
                value: v.to_string(),
                reason:
                    "not a finite number (nan and inf mean nothing in a scenario); give the number"
                        .into(),
            });
        }
        let path_error = |path: String, message: String| ScenarioError::Syntax {
            file: file.to_string(),
            message: format!("{path}: {}", message.trim()),
        };
        // The key path (`causes.only`) in front of the parser's line, column and expectation;
        // with a pose list read from CSV into the table, from the table (no line numbers then).
        let mut scenario: Scenario = if pose_csvs(&mut raw, file, dir)? {
            serde_path_to_error::deserialize(toml::Value::Table(raw.clone()))
                .map_err(|e| path_error(e.path().to_string(), e.inner().to_string()))?
        } else {
            let de = toml::de::Deserializer::parse(text).map_err(syntax)?;
            serde_path_to_error::deserialize(de)
                .map_err(|e| path_error(e.path().to_string(), e.inner().to_string()))?
        };
        let r = &scenario.robot.name;
        if r.ends_with(".urdf")
            && !std::path::Path::new(r).is_absolute()
            && let Some(dir) = dir
        {
            let p = dir.join(r).display().to_string();
            scenario.robot.name = p.clone();
            if let Some(toml::Value::Table(t)) = raw.get_mut("robot") {
                t.insert("name".into(), toml::Value::String(p));
            }
        }
        let mut sf = ScenarioFile {
            file: file.to_string(),
            raw,
            scenario,
            points: 0,
        };
        sf.scenario.validate(file)?;
        sf.points = sf.grid_len()?;
        // Every point validated now (a bad value fails before the sweep starts), one at a time.
        if sf.scenario.sweep.is_some() {
            for i in 0..sf.points {
                sf.point(i)?.scenario.validate(file)?;
            }
        }
        Ok(sf)
    }

    /// How many grid points (1 without a sweep); each is `point(i)`, validated at load.
    pub fn n_points(&self) -> usize {
        self.points
    }

    /// The grid's points in order, built one at a time.
    pub fn points(&self) -> impl Iterator<Item = Result<GridPoint, ScenarioError>> + '_ {
        (0..self.points).map(|i| self.point(i))
    }
}

/// The first value in a TOML tree that is NaN or infinite, with its key path (`a.b[2]`).
fn non_finite(t: &toml::Table, prefix: &str) -> Option<(String, f64)> {
    fn walk(v: &toml::Value, path: String) -> Option<(String, f64)> {
        match v {
            toml::Value::Float(f) if !f.is_finite() => Some((path, *f)),
            toml::Value::Table(t) => non_finite(t, &path),
            toml::Value::Array(a) => a
                .iter()
                .enumerate()
                .find_map(|(i, x)| walk(x, format!("{path}[{i}]"))),
            _ => None,
        }
    }
    t.iter().find_map(|(k, v)| {
        let path = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        walk(v, path)
    })
}
