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
    points: Vec<GridPoint>,
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
        // The key path (`causes.only`) in front of the parser's line, column and expectation.
        let de = toml::de::Deserializer::parse(text).map_err(syntax)?;
        let mut scenario: Scenario =
            serde_path_to_error::deserialize(de).map_err(|e| ScenarioError::Syntax {
                file: file.to_string(),
                message: format!("{}: {}", e.path(), e.inner().to_string().trim()),
            })?;
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
            points: Vec::new(),
        };
        sf.scenario.validate(file)?;
        sf.points = sf.make_grid()?;
        if sf.scenario.sweep.is_some() {
            for p in &sf.points {
                p.scenario.validate(file)?;
            }
        }
        Ok(sf)
    }

    /// The sweep grid's points (one point, the base scenario, when there is no sweep), validated.
    pub fn grid(&self) -> &[GridPoint] {
        &self.points
    }
}
