//! The checksum of a final trial directory, recorded in its journal record so that `batch
//! report` and a resume can tell a trial log that is still what was recorded from one that
//! was deleted, truncated or changed since.
//!
//! Definition (docs/batch.md, "Checksums"): walk the directory recursively; take every
//! entry's path relative to the directory (`/`-separated), sorted bytewise; feed a CRC-64/XZ
//! (ECMA-182 polynomial, reflected, init and xorout all ones) for each entry with: a type
//! byte (`f` file, `d` directory, `l` symbolic link), the path bytes, a zero byte, then for a
//! file its length as u64 little-endian and its bytes, for a link its target. The record
//! keeps the CRC with the number of files and their total bytes (so a report can say
//! "truncated: 3 files, 2 104 bytes recorded, 1 980 now").
//!
//! Why CRC-64: the threat is accidents (a disk, a clean-up script, a half-copied archive, a
//! second writer), not an adversary; a 64-bit CRC misses a random change with probability
//! 2⁻⁶⁴ and every burst of up to 64 bits, runs at memory speed, and the `crc` crate is
//! already the protocol's checksum crate, so nothing new is built.

use crate::Error;
use crc::{CRC_64_XZ, Crc, Digest};
use serde::{Deserialize, Serialize};
use std::path::Path;

const CRC64: Crc<u64> = Crc::<u64>::new(&CRC_64_XZ);

/// What a final record says about its trial directory.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum DirChecksum {
    /// The directory's checksum.
    Tree {
        /// Regular files in it (recursively).
        files: u64,
        /// Their total length, bytes.
        bytes: u64,
        /// CRC-64/XZ over the entries, 16 hex digits.
        crc64: String,
    },
    /// No directory was written (a runner that failed before writing a log).
    Absent,
    /// A runner abandoned after its budget may still be writing into it: not verifiable
    /// (whether it existed when the record was written is kept).
    Unsettled {
        /// Whether the directory existed when the record was written.
        present: bool,
    },
}

fn walk(root: &Path, rel: &str, entries: &mut Vec<(String, char)>) -> Result<(), Error> {
    let dir = if rel.is_empty() { root.to_path_buf() } else { root.join(rel) };
    for e in std::fs::read_dir(&dir).map_err(|e| Error::io(&dir, e))? {
        let e = e.map_err(|e| Error::io(&dir, e))?;
        let name = e.file_name().to_string_lossy().into_owned();
        let path = if rel.is_empty() { name } else { format!("{rel}/{name}") };
        let ty = e.file_type().map_err(|err| Error::io(e.path(), err))?;
        if ty.is_dir() {
            entries.push((path.clone(), 'd'));
            walk(root, &path, entries)?;
        } else if ty.is_symlink() {
            entries.push((path, 'l'));
        } else {
            entries.push((path, 'f'));
        }
    }
    Ok(())
}

fn feed_entry(
    d: &mut Digest<'_, u64>,
    root: &Path,
    path: &str,
    ty: char,
) -> Result<Option<u64>, Error> {
    d.update(&[ty as u8]);
    d.update(path.as_bytes());
    d.update(&[0]);
    let abs = root.join(path);
    match ty {
        'f' => {
            let bytes = std::fs::read(&abs).map_err(|e| Error::io(&abs, e))?;
            d.update(&(bytes.len() as u64).to_le_bytes());
            d.update(&bytes);
            Ok(Some(bytes.len() as u64))
        }
        'l' => {
            let target = std::fs::read_link(&abs).map_err(|e| Error::io(&abs, e))?;
            d.update(target.to_string_lossy().as_bytes());
            Ok(None)
        }
        _ => Ok(None),
    }
}

/// The checksum of the directory `dir` ([`DirChecksum::Absent`] when it does not exist).
pub fn of_dir(dir: &Path) -> Result<DirChecksum, Error> {
    if !dir.exists() {
        return Ok(DirChecksum::Absent);
    }
    let mut entries = Vec::new();
    walk(dir, "", &mut entries)?;
    entries.sort_unstable_by(|a, b| a.0.as_bytes().cmp(b.0.as_bytes()));
    let mut d = CRC64.digest();
    let (mut files, mut bytes) = (0, 0);
    for (path, ty) in &entries {
        if let Some(n) = feed_entry(&mut d, dir, path, *ty)? {
            files += 1;
            bytes += n;
        }
    }
    Ok(DirChecksum::Tree { files, bytes, crc64: format!("{:016x}", d.finalize()) })
}

impl DirChecksum {
    /// `3 files, 2104 bytes, crc64 …` / `no directory` / `unsettled`.
    pub fn describe(&self) -> String {
        match self {
            DirChecksum::Tree { files, bytes, crc64 } => {
                format!("{files} files, {bytes} bytes, crc64 {crc64}")
            }
            DirChecksum::Absent => "no directory".into(),
            DirChecksum::Unsettled { .. } => "unsettled (written by an abandoned runner)".into(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The CRC is the catalogue's CRC-64/XZ (check value of "123456789"), so the documented
    /// definition can be recomputed by any tool that has it.
    #[test]
    fn crc_is_crc64_xz() {
        assert_eq!(CRC64.checksum(b"123456789"), 0x995d_c9bb_df19_39fa);
    }

    #[test]
    fn any_change_truncation_rename_or_addition_changes_the_checksum() {
        let tmp = tempfile::tempdir().unwrap();
        let d = tmp.path().join("t");
        assert_eq!(of_dir(&d).unwrap(), DirChecksum::Absent);
        std::fs::create_dir_all(d.join("sub")).unwrap();
        std::fs::write(d.join("a.csv"), b"x,y\n1,2\n").unwrap();
        std::fs::write(d.join("sub/b.json"), b"{}").unwrap();
        let base = of_dir(&d).unwrap();
        let DirChecksum::Tree { files, bytes, .. } = &base else { panic!("{base:?}") };
        assert_eq!((*files, *bytes), (2, 10));
        assert_eq!(of_dir(&d).unwrap(), base, "deterministic");
        let changes: [&dyn Fn(); 3] = [
            &|| std::fs::write(d.join("a.csv"), b"x,y\n1,3\n").unwrap(),
            &|| std::fs::write(d.join("a.csv"), b"x,y\n1,2").unwrap(),
            &|| std::fs::write(d.join("c"), b"").unwrap(),
        ];
        for (i, change) in changes.iter().enumerate() {
            change();
            assert_ne!(of_dir(&d).unwrap(), base, "change {i} unseen");
            std::fs::write(d.join("a.csv"), b"x,y\n1,2\n").unwrap();
            let _ = std::fs::remove_file(d.join("c"));
            assert_eq!(of_dir(&d).unwrap(), base);
        }
        std::fs::rename(d.join("sub/b.json"), d.join("sub/c.json")).unwrap();
        assert_ne!(of_dir(&d).unwrap(), base, "a renamed file is a change");
    }
}
