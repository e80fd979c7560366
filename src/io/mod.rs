//! Everything that touches files or formats: CSV rows, capture files, plots, reports and (feature
//! `rerun`) Rerun recordings. The library's math never does I/O; these adapters do.

pub mod captures;
pub mod csv;
pub mod plot;
pub mod report;
#[cfg(feature = "rerun")]
pub mod rerun;

use crate::error::Error;
use std::io::Write;
use std::path::Path;
use thiserror::Error;

/// A file in one of lasercal's formats (capture file, trials.csv, sweep record) that does not say
/// what it must, or an output that cannot be rendered.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum FormatError {
    /// A record or field that is wrong: `at` names it (`profiles[3].tcp_position_mm`, `line 7`).
    #[error("{file}: {at}: {message}")]
    Field {
        file: String,
        at: String,
        message: String,
    },
    /// The file does not parse at all.
    #[error("{file}: not a valid {what}: {message}")]
    Invalid {
        file: String,
        what: &'static str,
        message: String,
    },
    /// A plot or recording that could not be made.
    #[error("{what}: {message}")]
    Render { what: String, message: String },
}

/// Create (truncate) a file for writing, creating its folder; the error names the path.
pub fn create(path: &Path) -> Result<std::io::BufWriter<std::fs::File>, Error> {
    if let Some(dir) = path.parent()
        && !dir.as_os_str().is_empty()
    {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, "create the folder", e))?;
    }
    let f = std::fs::File::create(path).map_err(|e| Error::io(path, "create", e))?;
    Ok(std::io::BufWriter::new(f))
}

/// Write a whole file.
pub fn write(path: &Path, bytes: &[u8]) -> Result<(), Error> {
    let mut w = create(path)?;
    w.write_all(bytes)
        .and_then(|_| w.flush())
        .map_err(|e| Error::io(path, "write", e))
}
