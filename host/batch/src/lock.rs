//! The batch directory's lock, `batch.lock`: one process at a time may run (or merge into)
//! a batch directory. Two `batch run` on one `--out` (a Slurm requeue while the first task
//! still runs, a cron job firing twice) used to interleave their journals; now the second
//! fails at once, naming the holder. The lock is a kernel `flock(2)` on the file, so it
//! belongs to the open file, not to the file's existence: a process killed by SIGKILL, an
//! OOM kill or a power cut holds nothing afterwards and the next run resumes without any
//! stale-lock cleanup. The file's content only says who holds it (pid, host, start time,
//! command); it is rewritten by each holder and never trusted for the locking itself.

use crate::Error;
use rustix::fs::{FlockOperation, flock};
use serde::{Deserialize, Serialize};
use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, Write};
use std::path::{Path, PathBuf};

/// The lock file's name inside a batch directory.
pub const LOCK: &str = "batch.lock";

/// Who holds a batch directory's lock (the lock file's content).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Holder {
    /// Process id.
    pub pid: u32,
    /// Host name (`uname -n`).
    pub host: String,
    /// When it took the lock, UTC (`2026-11-26T06:40:00Z`).
    pub started_utc: String,
    /// Its command line.
    pub command: String,
}

impl Holder {
    /// This process, now.
    pub fn this_process() -> Self {
        let now = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_secs());
        Self {
            pid: std::process::id(),
            host: rustix::system::uname().nodename().to_string_lossy().into_owned(),
            started_utc: utc_text(now),
            command: std::env::args().collect::<Vec<_>>().join(" "),
        }
    }

    /// `pid 123 on host h since 2026-…Z (command: …)`.
    pub fn describe(&self) -> String {
        format!(
            "pid {} on host {} since {} (command: {})",
            self.pid, self.host, self.started_utc, self.command
        )
    }
}

/// Seconds since 1970 as `YYYY-MM-DDTHH:MM:SSZ` (proleptic Gregorian, UTC).
pub fn utc_text(secs: u64) -> String {
    let (days, rem) = (secs / 86_400, secs % 86_400);
    // Howard Hinnant's civil_from_days, shifted to an era starting 0000-03-01.
    let z = days as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    let (h, m, s) = (rem / 3600, rem % 3600 / 60, rem % 60);
    format!("{year:04}-{month:02}-{day:02}T{h:02}:{m:02}:{s:02}Z")
}

/// A held lock; released when dropped or when the process ends, however it ends.
#[derive(Debug)]
pub struct BatchLock {
    path: PathBuf,
    _file: File,
}

fn read_holder(file: &mut File) -> String {
    let mut text = String::new();
    let _ = file.rewind().and_then(|()| file.read_to_string(&mut text));
    match serde_json::from_str::<Holder>(&text) {
        Ok(h) => h.describe(),
        Err(_) => "a process that has not yet recorded itself".into(),
    }
}

fn locked(path: &Path, holder: String) -> Error {
    Error::Locked { path: path.to_path_buf(), holder }
}

impl BatchLock {
    /// Takes `dir`'s lock exclusively (creating `dir` and the lock file), or fails at once
    /// with [`Error::Locked`] naming the holder. Records this process as the holder.
    pub fn exclusive(dir: &Path) -> Result<Self, Error> {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        let path = dir.join(LOCK);
        let mut file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(&path)
            .map_err(|e| Error::io(&path, e))?;
        if flock(&file, FlockOperation::NonBlockingLockExclusive).is_err() {
            return Err(locked(dir, read_holder(&mut file)));
        }
        let text = serde_json::to_string(&Holder::this_process()).expect("holder serialises");
        file.set_len(0)
            .and_then(|()| file.rewind())
            .and_then(|()| file.write_all(text.as_bytes()))
            .and_then(|()| file.sync_data())
            .map_err(|e| Error::io(&path, e))?;
        Ok(Self { path, _file: file })
    }

    /// Takes `dir`'s lock shared (for reading a batch directory that must not change while
    /// it is read: the inputs of a merge), or fails at once with [`Error::Locked`] naming
    /// the process running it. A directory without a lock file was never locked: `None`.
    pub fn shared(dir: &Path) -> Result<Option<Self>, Error> {
        let path = dir.join(LOCK);
        let mut file = match File::open(&path) {
            Ok(f) => f,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(Error::io(&path, e)),
        };
        if flock(&file, FlockOperation::NonBlockingLockShared).is_err() {
            return Err(locked(dir, read_holder(&mut file)));
        }
        Ok(Some(Self { path, _file: file }))
    }

    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utc_text_matches_known_dates() {
        assert_eq!(utc_text(0), "1970-01-01T00:00:00Z");
        assert_eq!(utc_text(951_782_400), "2000-02-29T00:00:00Z");
        assert_eq!(utc_text(1_795_651_200 + 3_723), "2026-11-26T01:02:03Z");
    }

    #[test]
    fn a_second_exclusive_lock_is_refused_naming_the_holder_and_freed_on_drop() {
        let tmp = tempfile::tempdir().unwrap();
        let first = BatchLock::exclusive(tmp.path()).unwrap();
        let e = BatchLock::exclusive(tmp.path()).unwrap_err().to_string();
        assert!(e.contains(&format!("pid {}", std::process::id())), "{e}");
        let e = BatchLock::shared(tmp.path()).unwrap_err().to_string();
        assert!(e.contains("in use"), "{e}");
        drop(first);
        let shared = BatchLock::shared(tmp.path()).unwrap();
        assert!(shared.is_some());
        assert!(BatchLock::exclusive(tmp.path()).is_err(), "a shared holder blocks a run");
        drop(shared);
        BatchLock::exclusive(tmp.path()).unwrap();
        assert!(BatchLock::shared(&tmp.path().join("none")).unwrap().is_none());
    }
}
