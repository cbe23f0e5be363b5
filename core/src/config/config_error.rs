//! [`ConfigError`]: what is wrong with a `pipeline.toml`.

use std::path::PathBuf;

/// A problem with a `pipeline.toml`: it cannot be read, it is not valid TOML for the schema, or a
/// value is out of range. The CLI exits with code 2 on any of these.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("{path}: cannot read the config file: {source}")]
    Read {
        /// The config file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file is not valid TOML, has an unknown key, a missing key or a value of the wrong type.
    #[error("{path}: key `{key}`: {message}")]
    Parse {
        /// The config file.
        path: PathBuf,
        /// Dotted path of the offending key (`scene.foo`), or `(top level)`.
        key: String,
        /// The parser's message, with line, column and the offending line.
        message: String,
    },
    /// A key has a value outside its allowed range, or keys contradict each other.
    #[error("{path}: {key} = {value}: {message}")]
    Invalid {
        /// The config file.
        path: PathBuf,
        /// Dotted path of the offending key.
        key: String,
        /// The offending value as written in TOML.
        value: String,
        /// What is wrong and what would be valid.
        message: String,
    },
}
