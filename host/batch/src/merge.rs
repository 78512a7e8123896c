//! `mesopush batch merge DIR... --out DIR`: combines shard directories (or any batch
//! directories of the same batch) into one batch directory that `batch report` reads. Trial
//! logs stay where they are; the merged journal points at them by relative path. Refuses
//! directories of different batches and a trial finished in two of them.

use super::engine::{MANIFEST, Manifest};
use super::journal::{JOURNAL, Record};
use super::stats::Loaded;
use crate::Error;
use mesopush_core::fsx::write_atomic;
use mesopush_core::shard::Shard;
use std::collections::BTreeMap;
use std::path::{Component, Path, PathBuf};

/// `to` relative to `from` (both made absolute), e.g. `../shard-00-of-04/trials/x`.
fn relative(from: &Path, to: &Path) -> Result<PathBuf, Error> {
    let from = std::fs::canonicalize(from).map_err(|e| Error::io(from, e))?;
    let to = std::fs::canonicalize(to).map_err(|e| Error::io(to, e))?;
    let (f, t): (Vec<Component<'_>>, Vec<Component<'_>>) =
        (from.components().collect(), to.components().collect());
    let common = f.iter().zip(&t).take_while(|(a, b)| a == b).count();
    let mut out = PathBuf::new();
    for _ in common..f.len() {
        out.push("..");
    }
    for c in &t[common..] {
        out.push(c.as_os_str());
    }
    Ok(out)
}

/// What a merge did.
#[derive(Debug, Clone, PartialEq)]
pub struct Merged {
    /// Inputs merged.
    pub inputs: usize,
    /// Trials with a final record.
    pub trials: usize,
}

/// Merges `dirs` into `out`.
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<Merged, Error> {
    if dirs.is_empty() {
        return Err(Error::invalid("merge", "name at least one batch directory"));
    }
    if out.join(JOURNAL).exists() {
        return Err(Error::invalid(
            "merge",
            format!("{} already holds a batch; choose a new --out", out.display()),
        ));
    }
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let mut manifest: Option<Manifest> = None;
    let mut by_index: BTreeMap<u64, Vec<Record>> = BTreeMap::new();
    let mut owner: BTreeMap<u64, PathBuf> = BTreeMap::new();
    for dir in dirs {
        let b = Loaded::load(dir)?;
        let mut m = b.manifest.clone();
        m.shard = Shard::ALL;
        match &manifest {
            None => manifest = Some(m),
            Some(first) if *first != m => {
                return Err(Error::invalid(
                    "merge",
                    format!("{} is a different batch from {}", dir.display(), dirs[0].display()),
                ));
            }
            Some(_) => {}
        }
        let rel = relative(out, dir)?;
        for r in b.records {
            let (index, r) = match r {
                Record::Begin { .. } => continue,
                Record::Discarded { index, attempt, renamed_to, found } => {
                    let renamed_to = rel.join(renamed_to).to_string_lossy().into_owned();
                    (index, Record::Discarded { index, attempt, renamed_to, found })
                }
                Record::Attempt(mut a) => {
                    a.dir = rel.join(&a.dir).to_string_lossy().into_owned();
                    (a.index, Record::Attempt(a))
                }
                Record::Trial(mut a) => {
                    if let Some(prev) = owner.insert(a.index, dir.clone()) {
                        return Err(Error::invalid(
                            "merge",
                            format!(
                                "{} is finished in both {} and {}",
                                a.trial_id,
                                prev.display(),
                                dir.display()
                            ),
                        ));
                    }
                    a.dir = rel.join(&a.dir).to_string_lossy().into_owned();
                    (a.index, Record::Trial(a))
                }
            };
            by_index.entry(index).or_default().push(r);
        }
    }
    let manifest = manifest.expect("at least one input");
    let text = serde_json::to_string_pretty(&manifest).expect("manifest serialises");
    write_atomic(&out.join(MANIFEST), text.as_bytes())?;
    let mut journal = String::new();
    for r in by_index.values().flatten() {
        journal.push_str(&serde_json::to_string(r).expect("records serialise"));
        journal.push('\n');
    }
    write_atomic(&out.join(JOURNAL), journal.as_bytes())?;
    Ok(Merged { inputs: dirs.len(), trials: owner.len() })
}
