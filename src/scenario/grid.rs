//! Sweep grids: the Cartesian product of `[sweep.grid]`'s value lists, each point a scenario of
//! its own (the base scenario's raw table with the point's dotted keys overridden).

use super::{Scenario, ScenarioError, ScenarioFile};

/// Most grid points a sweep may have.
pub const MAX_GRID_POINTS: usize = 1_000_000;

/// One grid point: the (key, value) overrides and the scenario they give.
#[derive(Debug, Clone)]
pub struct GridPoint {
    pub index: usize,
    pub values: Vec<(String, toml::Value)>,
    pub scenario: Scenario,
}

impl ScenarioFile {
    fn bad(&self, key: &str, v: &toml::Value, reason: &str) -> ScenarioError {
        ScenarioError::BadValue {
            file: self.file.clone(),
            key: key.into(),
            value: v.to_string(),
            reason: reason.into(),
        }
    }

    /// The grid's axes: each key with its values, in file order.
    fn axes(&self, grid: &toml::Table) -> Result<Vec<(String, Vec<toml::Value>)>, ScenarioError> {
        let mut axes = Vec::new();
        for (k, v) in grid {
            let key = format!("sweep.grid.\"{k}\"");
            let vals = match v {
                toml::Value::Array(a) if !a.is_empty() => a.clone(),
                _ => return Err(self.bad(&key, v, "give a non-empty list of values")),
            };
            if k.starts_with("sweep") {
                return Err(self.bad(&key, v, "the sweep cannot sweep itself"));
            }
            axes.push((k.clone(), vals));
        }
        Ok(axes)
    }

    /// How many points the grid has (1 without a sweep); refused beyond `MAX_GRID_POINTS`
    /// before anything is built.
    pub fn grid_len(&self) -> Result<usize, ScenarioError> {
        let Some(sweep) = &self.scenario.sweep else {
            return Ok(1);
        };
        let axes = self.axes(&sweep.grid)?;
        let total = axes
            .iter()
            .try_fold(1usize, |acc, a| acc.checked_mul(a.1.len()))
            .filter(|t| *t <= MAX_GRID_POINTS);
        total.ok_or_else(|| {
            self.bad(
                "sweep.grid",
                &toml::Value::String(
                    axes.iter()
                        .map(|a| format!("{} x {}", a.0, a.1.len()))
                        .collect::<Vec<_>>()
                        .join(", "),
                ),
                &format!("more than {MAX_GRID_POINTS} grid points; split the sweep"),
            )
        })
    }

    /// Grid point `index`, deserialised (the base scenario when there is no sweep). The last
    /// axis varies fastest. Built on demand: a sweep holds one point at a time.
    pub fn point(&self, index: usize) -> Result<GridPoint, ScenarioError> {
        let Some(sweep) = &self.scenario.sweep else {
            return Ok(GridPoint {
                index: 0,
                values: vec![],
                scenario: self.scenario.clone(),
            });
        };
        let axes = self.axes(&sweep.grid)?;
        let mut rem = index;
        let mut picks = vec![0; axes.len()];
        for (i, a) in axes.iter().enumerate().rev() {
            picks[i] = rem % a.1.len();
            rem /= a.1.len();
        }
        let mut table = self.raw.clone();
        let mut values = Vec::with_capacity(axes.len());
        for (i, (k, vals)) in axes.iter().enumerate() {
            let v = vals[picks[i]].clone();
            let slot = set_dotted(&mut table, k).ok_or_else(|| {
                self.bad(
                    &format!("sweep.grid.\"{k}\""),
                    &v,
                    "this key does not name a scenario value",
                )
            })?;
            *slot = v.clone();
            values.push((k.clone(), v));
        }
        let scenario: Scenario =
            toml::Value::Table(table)
                .try_into()
                .map_err(|e: toml::de::Error| ScenarioError::BadValue {
                    file: self.file.clone(),
                    key: join(values.iter().map(|(k, _)| k.clone())),
                    value: join(values.iter().map(|(_, v)| v.to_string())),
                    reason: e.to_string().trim().to_string(),
                })?;
        Ok(GridPoint {
            index,
            values,
            scenario,
        })
    }
}

fn join(items: impl Iterator<Item = String>) -> String {
    items.collect::<Vec<_>>().join(", ")
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
