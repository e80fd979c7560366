//! One helper family for the checks deserialisation cannot make: errors that name the file, the
//! key, the value and the fix.

use super::ScenarioError;
use std::fmt::Display;

/// The longest size a scenario may give (mm): 100 m, beyond any cell a robot works in; sizes
/// set how much is sampled, so they are bounded before anything is allocated.
pub const MAX_LENGTH_MM: f64 = 100_000.0;
/// Trials per grid point (and for `check`): beyond this a run would not end in a working day.
pub const MAX_TRIALS: usize = 10_000_000;

/// Makes `ScenarioError::BadValue`s for one file.
#[derive(Debug, Clone, Copy)]
pub struct Validator<'a> {
    pub file: &'a str,
}

impl Validator<'_> {
    pub fn bad(&self, key: &str, value: impl Display, reason: impl Into<String>) -> ScenarioError {
        ScenarioError::BadValue {
            file: self.file.into(),
            key: key.into(),
            value: value.to_string(),
            reason: reason.into(),
        }
    }

    /// A method's own section, which the method needs.
    pub fn section<'a, T>(
        &self,
        section: Option<&'a T>,
        kind: crate::id::Kind,
    ) -> Result<&'a T, ScenarioError> {
        let article = if kind.name().starts_with(['a', 'e', 'i', 'o', 'u']) {
            "an"
        } else {
            "a"
        };
        section.ok_or_else(|| {
            self.bad(
                kind.name(),
                "(missing)",
                format!("the {kind} method needs {article} [{kind}] section"),
            )
        })
    }

    /// A finite number >= 0.
    pub fn non_negative(&self, key: &str, v: f64) -> Result<(), ScenarioError> {
        if v >= 0.0 && v.is_finite() {
            Ok(())
        } else {
            Err(self.bad(key, v, "must be a finite number >= 0"))
        }
    }

    /// A positive finite length in mm, at most `MAX_LENGTH_MM`; returns it in metres.
    pub fn length(&self, key: &str, mm: f64) -> Result<f64, ScenarioError> {
        if mm > 0.0 && mm <= MAX_LENGTH_MM {
            Ok(mm * 1e-3)
        } else {
            Err(self.bad(
                key,
                mm,
                format!("must be a positive length of at most {MAX_LENGTH_MM} mm"),
            ))
        }
    }

    /// A value in [0, 1].
    pub fn probability_like(&self, key: &str, v: f64, reason: &str) -> Result<(), ScenarioError> {
        if (0.0..=1.0).contains(&v) {
            Ok(())
        } else {
            Err(self.bad(key, v, reason))
        }
    }

    /// A value in the closed interval [lo, hi] (not NaN), else `reason`.
    pub fn within(
        &self,
        key: &str,
        v: f64,
        (lo, hi): (f64, f64),
        reason: &str,
    ) -> Result<(), ScenarioError> {
        if (lo..=hi).contains(&v) {
            Ok(())
        } else {
            Err(self.bad(key, v, reason))
        }
    }

    /// A value in the open interval (lo, hi).
    pub fn open_interval(&self, key: &str, v: f64, lo: f64, hi: f64) -> Result<(), ScenarioError> {
        if v > lo && v < hi {
            Ok(())
        } else {
            Err(self.bad(key, v, format!("must be in ({lo}, {hi})")))
        }
    }

    /// A count of at least `min`.
    pub fn at_least(
        &self,
        key: &str,
        n: usize,
        min: usize,
        reason: &str,
    ) -> Result<(), ScenarioError> {
        if n >= min {
            Ok(())
        } else {
            Err(self.bad(key, n, reason))
        }
    }

    /// Exactly one of two alternative keys given (`what` says what they give).
    pub fn one_of(
        &self,
        a: (&str, bool),
        b: (&str, bool),
        what: &str,
    ) -> Result<(), ScenarioError> {
        let short = |k: &str| k.rsplit('.').next().unwrap_or(k).to_string();
        let (sa, sb) = (short(a.0), short(b.0));
        match (a.1, b.1) {
            (true, true) => Err(self.bad(b.0, "..", format!("give {sa} or {sb}, not both"))),
            (false, false) => {
                Err(self.bad(a.0, "(missing)", format!("give {what} as {sa} or {sb}")))
            }
            _ => Ok(()),
        }
    }
}
