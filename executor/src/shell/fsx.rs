//! The executor's one crash-safe file write (the plan store and the recorder both use it):
//! a synced temporary `<name>.tmp` beside the target, renamed over it, then the directory
//! synced — after a crash the file holds the old contents or the new, whole. The host has its
//! own (`mesopush_core::fsx`): the executor never depends on host crates.

use std::fs::{self, File};
use std::io;
use std::path::{Path, PathBuf};

/// The temporary a write to `path` goes through: `<name>.tmp` beside it.
pub fn tmp_path(path: &Path) -> PathBuf {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(".tmp");
    path.with_file_name(name)
}

/// Writes `path` atomically; `write` fills the temporary file (no buffer is allocated here).
pub fn write_atomic_with(
    path: &Path,
    write: impl FnOnce(&mut File) -> io::Result<()>,
) -> io::Result<()> {
    let tmp = tmp_path(path);
    let mut file = File::create(&tmp)?;
    write(&mut file)?;
    file.sync_all()?;
    drop(file);
    fs::rename(&tmp, path)?;
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty());
    File::open(dir.unwrap_or(Path::new(".")))?.sync_all()
}

/// Writes `bytes` to `path` atomically.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    use std::io::Write;
    write_atomic_with(path, |f| f.write_all(bytes))
}
