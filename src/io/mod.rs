//! Everything that touches files or formats: CSV rows, capture files, plots, reports and (feature
//! `rerun`) Rerun recordings. The library's math never does I/O; these adapters do.

pub mod captures;
pub mod csv;
pub mod export;
pub mod plot;
pub mod report;
#[cfg(feature = "rerun")]
pub mod rerun;

pub use crate::error::FormatError;

use crate::error::Error;
use std::io::Write;
use std::path::Path;

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
