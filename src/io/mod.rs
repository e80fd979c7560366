//! Everything that touches files or formats: CSV rows, capture files, plots, reports and (feature
//! `rerun`) Rerun recordings. The library's math never does I/O; these adapters do.

pub mod captures;
pub mod csv;
pub mod export;
pub mod import;
pub mod plot;
pub mod points_file;
pub mod poses;
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

/// The temporary name a file is written under until it is complete (same folder, so the rename
/// is atomic): a reader never sees half a file, and an interrupted write leaves the old one.
pub fn partial_path(path: &Path) -> std::path::PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.partial"))
}

/// A file being written under its partial name; `commit` flushes the writer `create` returned
/// and renames the file into place.
pub struct Pending {
    path: std::path::PathBuf,
    tmp: std::path::PathBuf,
}

impl Pending {
    pub fn create(path: &Path) -> Result<(Pending, std::io::BufWriter<std::fs::File>), Error> {
        let tmp = partial_path(path);
        let w = create(&tmp)?;
        Ok((
            Pending {
                path: path.to_path_buf(),
                tmp,
            },
            w,
        ))
    }

    /// Flush, sync and rename into place; on failure the partial file is removed and the error
    /// names the final path.
    pub fn commit(self, writer: std::io::BufWriter<std::fs::File>) -> Result<(), Error> {
        let done = writer
            .into_inner()
            .map_err(|e| e.into_error())
            .and_then(|f| f.sync_all())
            .and_then(|_| std::fs::rename(&self.tmp, &self.path));
        done.map_err(|e| {
            let _ = std::fs::remove_file(&self.tmp);
            Error::io(&self.path, "write", e)
        })
    }
}

/// Write a whole file (under its partial name, then renamed into place).
pub fn write(path: &Path, bytes: &[u8]) -> Result<(), Error> {
    let (p, mut w) = Pending::create(path)?;
    if let Err(e) = w.write_all(bytes) {
        let _ = std::fs::remove_file(&p.tmp);
        return Err(Error::io(path, "write", e));
    }
    p.commit(w)
}
