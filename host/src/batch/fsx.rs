//! Small durable-filesystem helpers for the batch directory: synced writes, directory
//! fsyncs, and renaming a directory aside under a free name (never deleting it).

use crate::Error;
use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Writes `bytes` to a new file and fsyncs it and its directory.
pub fn write_synced(path: &Path, bytes: &[u8]) -> Result<(), Error> {
    let mut f = File::create(path).map_err(|e| Error::io(path, e))?;
    f.write_all(bytes).and_then(|()| f.sync_all()).map_err(|e| Error::io(path, e))?;
    if let Some(dir) = path.parent() {
        sync_dir(dir)?;
    }
    Ok(())
}

/// Writes `value` as JSON to `path` crash-safely: a synced temporary file renamed over it
/// (a killed writer leaves the old file or none, never half of one).
pub fn write_json_atomic<T: serde::Serialize>(path: &Path, value: &T) -> Result<(), Error> {
    let text = serde_json::to_vec(value)
        .map_err(|e| Error::Parse { path: path.into(), message: e.to_string() })?;
    let tmp = path.with_extension("json.tmp");
    write_synced(&tmp, &text)?;
    std::fs::rename(&tmp, path).map_err(|e| Error::io(path, e))?;
    path.parent().map_or(Ok(()), sync_dir)
}

/// Reads a JSON file into `T`, naming the file in any error.
pub fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, Error> {
    let text = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    serde_json::from_slice(&text)
        .map_err(|e| Error::Parse { path: path.into(), message: e.to_string() })
}

/// Fsyncs a directory (so renames and new entries in it survive a crash).
pub fn sync_dir(dir: &Path) -> Result<(), Error> {
    let dir = if dir.as_os_str().is_empty() { Path::new(".") } else { dir };
    File::open(dir).and_then(|d| d.sync_all()).map_err(|e| Error::io(dir, e))
}

/// Renames `dir` to `<dir>.<tag>-K` with the first free K; returns the new path.
pub fn rename_aside(dir: &Path, tag: &str) -> Result<PathBuf, Error> {
    let name = dir.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let mut k = 1u32;
    let target = loop {
        let t = dir.with_file_name(format!("{name}.{tag}-{k}"));
        if !t.exists() {
            break t;
        }
        k += 1;
    };
    std::fs::rename(dir, &target).map_err(|e| Error::io(dir, e))?;
    if let Some(parent) = dir.parent() {
        sync_dir(parent)?;
    }
    Ok(target)
}
