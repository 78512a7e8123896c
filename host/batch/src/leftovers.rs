//! What an interrupted run leaves in `trials/` and how a resume sets it aside, closing the
//! window between renaming a directory and journalling it.
//!
//! An unfinished trial's attempt directory (half-written, or even finished but without a
//! final record) is renamed `<dir>.discarded-K` and run again from scratch. The `discarded`
//! record is journalled (fsynced) *before* the rename, naming the target, so a kill
//! between the two leaves a record whose target does not exist yet and the directory under
//! its old name: the next resume completes that rename without a second record. Batch
//! directories written before this order, and directories renamed by hand, can hold a
//! `*.discarded-K` directory no record mentions: a resume journals it as found.

use super::check;
use super::journal::{Journal, Record};
use super::spec::{TRIALS_DIR, attempt_dir};
use crate::Error;
use mesopush_core::fsx;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The tag of a set-aside directory: `trial-000007-a1.discarded-2`.
pub const TAG: &str = "discarded";

/// Renames `from` to `to` and fsyncs the parent directory.
fn rename_synced(from: &Path, to: &Path) -> Result<(), Error> {
    std::fs::rename(from, to).map_err(|e| Error::io(from, e))?;
    if let Some(parent) = to.parent() {
        fsx::sync_dir(parent)?;
    }
    Ok(())
}

/// `<dir>.discarded-K` with the first K naming nothing.
fn free_name(dir: &Path) -> PathBuf {
    let name = dir.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    (1u32..)
        .map(|k| dir.with_file_name(format!("{name}.{TAG}-{k}")))
        .find(|t| !t.exists())
        .expect("a free name exists")
}

/// `trial-000007-a1.discarded-2` → (7, 1).
fn parse_set_aside(name: &str) -> Option<(u64, u32)> {
    let (base, k) = name.rsplit_once(&format!(".{TAG}-"))?;
    k.parse::<u32>().ok()?;
    let (trial, attempt) = base.rsplit_once("-a")?;
    let index = trial.strip_prefix("trial-")?.parse().ok()?;
    Some((index, attempt.parse().ok()?))
}

/// What the journal says about set-aside directories.
#[derive(Debug, Default)]
struct Known {
    /// Every `renamed_to` of a `discarded` record.
    targets: BTreeSet<String>,
    /// (index, attempt) → the last `renamed_to` recorded for it.
    last: BTreeMap<(u64, u32), String>,
}

fn known(records: &[Record]) -> Known {
    let mut k = Known::default();
    for r in records {
        if let Record::Discarded { index, attempt, renamed_to, .. } = r {
            k.targets.insert(renamed_to.clone());
            k.last.insert((*index, *attempt), renamed_to.clone());
        }
    }
    k
}

/// Journals every `*.discarded-K` directory under `trials/` that no record mentions.
fn journal_unrecorded(out: &Path, k: &Known, journal: &mut Journal) -> Result<u64, Error> {
    let trials = out.join(TRIALS_DIR);
    let Ok(rd) = std::fs::read_dir(&trials) else { return Ok(0) };
    let mut names: Vec<String> =
        rd.filter_map(|e| Some(e.ok()?.file_name().to_string_lossy().into_owned())).collect();
    names.sort();
    let mut n = 0;
    for name in names {
        let rel = format!("{TRIALS_DIR}/{name}");
        let Some((index, attempt)) = parse_set_aside(&name) else { continue };
        if k.targets.contains(&rel) {
            continue;
        }
        let found =
            format!("{} (renamed, found unjournalled)", check::state_of(&trials.join(&name)));
        journal.append(&Record::Discarded { index, attempt, renamed_to: rel, found })?;
        n += 1;
    }
    Ok(n)
}

/// Sets aside every attempt directory of the unfinished trials `todo` (index → first
/// attempt to run) that an interrupted run left, completing renames a kill cut short and
/// journalling set-aside directories no record mentions. Returns directories set aside.
pub fn set_aside(
    out: &Path,
    todo: &BTreeMap<u64, u32>,
    max_attempts: u32,
    records: &[Record],
    journal: &mut Journal,
) -> Result<u64, Error> {
    let k = known(records);
    let mut n = journal_unrecorded(out, &k, journal)?;
    for (&index, &first) in todo {
        for attempt in first..=max_attempts {
            let dir = out.join(attempt_dir(index, attempt));
            if !dir.exists() {
                continue;
            }
            if let Some(target) = k.last.get(&(index, attempt)).map(|t| out.join(t))
                && !target.exists()
            {
                // journalled, then killed before the rename: finish it
                rename_synced(&dir, &target)?;
                n += 1;
                continue;
            }
            let found = check::state_of(&dir);
            let to = free_name(&dir);
            let renamed_to = to.strip_prefix(out).unwrap_or(&to).to_string_lossy().into_owned();
            journal.append(&Record::Discarded { index, attempt, renamed_to, found })?;
            rename_synced(&dir, &to)?;
            n += 1;
        }
    }
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_aside_names_parse() {
        assert_eq!(parse_set_aside("trial-000007-a1.discarded-2"), Some((7, 1)));
        assert_eq!(parse_set_aside("trial-000007-a1"), None);
        assert_eq!(parse_set_aside("notes.discarded-x"), None);
    }
}
