//! A scenario's full check: the shared sections (`schema`) and each method's own section (the
//! method's `validate`).

use super::{Scenario, ScenarioError, Validator};
use crate::method::method;

impl Scenario {
    /// Check every value deserialisation cannot, with the `[causes]` applied.
    pub fn validate(&self, file: &str) -> Result<(), ScenarioError> {
        if self.causes.is_some() {
            return self.resolved(file)?.validate(file);
        }
        let v = Validator { file };
        self.validate_common(&v)?;
        for kind in self.kinds() {
            method(kind).validate(self, &v)?;
        }
        Ok(())
    }
}
