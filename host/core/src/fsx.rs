//! Durable-filesystem helpers, the one set every host crate writes through: atomic writes
//! (the project's one implementation, `mesopush-fsx`, which the executor uses too: a synced
//! temporary renamed over the target, then the directory synced: a killed writer leaves the
//! old file or none, never half of one), synced writes, directory fsyncs, and renaming a
//! directory aside under a free name (never deleting it). Here they report the host's
//! error, naming the file.

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

/// Writes `bytes` to `path` crash-safely: a synced temporary beside it (`<name>.tmp`)
/// renamed over it, then the directory synced (`mesopush_fsx::write_atomic`).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), Error> {
    mesopush_fsx::write_atomic(path, bytes).map_err(|e| Error::io(path, e))
}

/// Writes `value` as JSON to `path` crash-safely ([`write_atomic`]).
pub fn write_json_atomic<T: serde::Serialize>(path: &Path, value: &T) -> Result<(), Error> {
    let text = serde_json::to_vec(value).map_err(|e| Error::parse(path, e))?;
    write_atomic(path, &text)
}

/// Reads a JSON file into `T`, naming the file in any error.
pub fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, Error> {
    let text = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    serde_json::from_slice(&text).map_err(|e| Error::parse(path, e))
}

/// Fsyncs a directory (so renames and new entries in it survive a crash).
pub fn sync_dir(dir: &Path) -> Result<(), Error> {
    mesopush_fsx::sync_dir(dir).map_err(|e| Error::io(dir, e))
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_write_replaces_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.json");
        write_json_atomic(&p, &vec![1, 2]).unwrap();
        write_json_atomic(&p, &vec![3]).unwrap();
        assert_eq!(read_json::<Vec<i32>>(&p).unwrap(), vec![3]);
        let names: Vec<_> =
            std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names, vec![std::ffi::OsString::from("a.json")]);
        let e = read_json::<Vec<i32>>(&dir.path().join("none.json")).unwrap_err().to_string();
        assert!(e.contains("none.json"), "{e}");
    }
}
