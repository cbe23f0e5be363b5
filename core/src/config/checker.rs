//! The checks of single values that every table's validation shares, each failing with a
//! [`ConfigError::Invalid`] that names the file, the key and the value.

use std::path::Path;

use super::ConfigError;

/// Builds [`ConfigError::Invalid`] errors for one config file.
pub(super) struct Checker<'a> {
    /// The config file.
    pub(super) path: &'a Path,
}

impl Checker<'_> {
    pub(super) fn invalid(&self, key: &str, value: &str, message: &str) -> ConfigError {
        ConfigError::Invalid {
            path: self.path.to_path_buf(),
            key: key.to_string(),
            value: value.to_string(),
            message: message.to_string(),
        }
    }

    pub(super) fn that(
        &self,
        ok: bool,
        key: &str,
        value: &str,
        message: impl FnOnce() -> String,
    ) -> Result<(), ConfigError> {
        if ok { Ok(()) } else { Err(self.invalid(key, value, &message())) }
    }

    pub(super) fn positive(&self, key: &str, value: f64, unit: &str) -> Result<(), ConfigError> {
        self.that(value.is_finite() && value > 0.0, key, &value.to_string(), || {
            format!("must be a finite number greater than 0 ({unit})")
        })
    }

    pub(super) fn non_negative(&self, key: &str, value: f64, unit: &str) -> Result<(), ConfigError> {
        self.that(value.is_finite() && value >= 0.0, key, &value.to_string(), || {
            format!("must be a finite number, 0 or more ({unit})")
        })
    }

    /// `value` lies in `range` (NaN never does): "must be `what` from LO to HI".
    pub(super) fn within(
        &self,
        key: &str,
        value: f64,
        range: std::ops::RangeInclusive<f64>,
        what: &str,
    ) -> Result<(), ConfigError> {
        self.that(range.contains(&value), key, &value.to_string(), || {
            format!("must be {what} from {} to {}", range.start(), range.end())
        })
    }

    pub(super) fn finite(&self, key: &str, value: f64) -> Result<(), ConfigError> {
        self.that(value.is_finite(), key, &value.to_string(), || "must be a finite number".to_string())
    }

    pub(super) fn direction(&self, key: &str, values: &[f64; 3]) -> Result<(), ConfigError> {
        let ok = values.iter().all(|v| v.is_finite()) && values.iter().any(|v| *v != 0.0);
        self.that(ok, key, &format!("{values:?}"), || "must be a finite, non-zero vector".to_string())
    }

    pub(super) fn unit_colour(&self, key: &str, values: &[f64; 3]) -> Result<(), ConfigError> {
        let ok = values.iter().all(|v| v.is_finite() && (0.0..=1.0).contains(v));
        self.that(ok, key, &format!("{values:?}"), || "every entry must be between 0 and 1".to_string())
    }

    pub(super) fn positive_array(&self, key: &str, values: &[f64; 3]) -> Result<(), ConfigError> {
        let ok = values.iter().all(|v| v.is_finite() && *v > 0.0);
        self.that(ok, key, &format!("{values:?}"), || {
            "every entry must be a finite number greater than 0 (metres)".to_string()
        })
    }

    pub(super) fn finite_array(&self, key: &str, values: &[f64; 3]) -> Result<(), ConfigError> {
        let ok = values.iter().all(|v| v.is_finite());
        self.that(ok, key, &format!("{values:?}"), || "every entry must be a finite number".to_string())
    }
}
