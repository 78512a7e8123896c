//! `mesopush batch merge DIR... --out DIR`: combines shard directories (or any batch
//! directories of the same batch) into one batch directory that `batch report` reads. Trial
//! logs stay where they are; the merged journal points at them by relative path. Refuses
//! directories of different batches, a trial finished in two of them, an input with final
//! records that do not count (lost, damaged, duplicated, foreign) and an input a `batch
//! run` is still writing (its lock). Idempotent: the output's marker (`merge.json`) is
//! written first and its journal last (each atomically), so a merge killed at any point is
//! completed by running it again, and a merge run twice finds its output complete and
//! writes nothing.

use super::engine::{MANIFEST, Manifest, TRIALS_DIR};
use super::journal::{JOURNAL, Record};
use super::lock::BatchLock;
use super::stats::Loaded;
use crate::Error;
use mesopush_core::fsx::write_atomic;
use mesopush_core::shard::Shard;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, BTreeSet};
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

/// The marker a merge writes first into its output, naming its inputs (relative to it): a
/// directory holding it is a merge's output, which a later merge of the same batch may
/// complete or bring up to date.
pub const MARKER: &str = "merge.json";

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Marker {
    format: String,
    inputs: Vec<String>,
}

/// How the merge left its output.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Outcome {
    /// Written (a new output, or one an interrupted merge left without its journal).
    Written,
    /// The output already held this very merge, byte for byte: nothing written.
    AlreadyComplete,
    /// The output held an earlier merge of the same batch whose inputs have progressed
    /// since: its journal was replaced.
    Updated,
}

/// What a merge did.
#[derive(Debug, Clone, PartialEq)]
pub struct Merged {
    /// Inputs merged.
    pub inputs: usize,
    /// Trials with a final record.
    pub trials: usize,
    /// Whether anything was written.
    pub outcome: Outcome,
}

/// Refuses an output that holds something other than an earlier merge of this batch;
/// returns the journal it holds (empty when none).
fn previous_output(out: &Path, manifest: &Manifest) -> Result<Vec<u8>, Error> {
    let journal = out.join(JOURNAL);
    let has_marker = out.join(MARKER).exists();
    if !has_marker && (journal.exists() || out.join(TRIALS_DIR).exists()) {
        return Err(Error::invalid(
            "merge",
            format!(
                "{} already holds a batch that `batch merge` did not write (no {MARKER}); \
                 choose a new --out",
                out.display()
            ),
        ));
    }
    if has_marker && out.join(MANIFEST).exists() && Manifest::load(out)? != *manifest {
        return Err(Error::invalid(
            "merge",
            format!("{} holds the merge of a different batch; choose a new --out", out.display()),
        ));
    }
    if !journal.exists() {
        return Ok(Vec::new());
    }
    std::fs::read(&journal).map_err(|e| Error::io(&journal, e))
}

/// Refuses an input with final records that do not count: merging them would only carry
/// the damage along.
fn check_input(dir: &Path, b: &Loaded) -> Result<(), Error> {
    let Some(f) = b.integrity.findings.first() else { return Ok(()) };
    Err(Error::invalid(
        "merge",
        format!(
            "{} has {} final record(s) that do not count (first: {} {}: {}); resume it with \
             `batch run` to run those trials again, or `batch report` it",
            dir.display(),
            b.integrity.findings.len(),
            f.trial_id,
            f.problem.as_str(),
            f.detail
        ),
    ))
}

/// One input's records as the merged journal holds them (directories made relative to
/// the output; `begin`, `voided` and voided records dropped).
fn rebase(b: &Loaded, rel: &Path) -> Vec<(u64, Record)> {
    let voided: BTreeSet<u64> = b
        .records
        .iter()
        .filter_map(|r| if let Record::Voided { record, .. } = r { Some(*record) } else { None })
        .collect();
    let join = |d: &str| rel.join(d).to_string_lossy().into_owned();
    let mut out = Vec::new();
    for (i, r) in b.records.iter().enumerate() {
        let item = match r.clone() {
            Record::Begin { .. } | Record::Voided { .. } => continue,
            Record::Trial(_) if voided.contains(&(i as u64)) => continue,
            Record::Discarded { index, attempt, renamed_to, found } => {
                (index, Record::Discarded { index, attempt, renamed_to: join(&renamed_to), found })
            }
            Record::Attempt(mut a) => {
                a.dir = join(&a.dir);
                (a.index, Record::Attempt(a))
            }
            Record::Trial(mut a) => {
                a.dir = join(&a.dir);
                (a.index, Record::Trial(a))
            }
        };
        out.push(item);
    }
    out
}

/// The inputs, read under their shared locks.
#[derive(Debug, Default)]
struct Gathered {
    manifest: Option<Manifest>,
    by_index: BTreeMap<u64, Vec<Record>>,
    owner: BTreeMap<u64, PathBuf>,
    inputs: Vec<String>,
    locks: Vec<Option<BatchLock>>,
}

fn gather(dirs: &[PathBuf], out: &Path) -> Result<Gathered, Error> {
    let canon_out = std::fs::canonicalize(out).map_err(|e| Error::io(out, e))?;
    let mut g = Gathered::default();
    for dir in dirs {
        if std::fs::canonicalize(dir).is_ok_and(|d| d == canon_out) {
            return Err(Error::invalid("merge", format!("--out {} is an input", out.display())));
        }
        g.locks.push(BatchLock::shared(dir)?);
        let b = Loaded::load(dir)?;
        check_input(dir, &b)?;
        let mut m = b.manifest.clone();
        m.shard = Shard::ALL;
        match &g.manifest {
            None => g.manifest = Some(m),
            Some(first) if *first != m => {
                return Err(Error::invalid(
                    "merge",
                    format!("{} is a different batch from {}", dir.display(), dirs[0].display()),
                ));
            }
            Some(_) => {}
        }
        let rel = relative(out, dir)?;
        g.inputs.push(rel.to_string_lossy().into_owned());
        for (index, r) in rebase(&b, &rel) {
            if let Record::Trial(a) = &r
                && let Some(prev) = g.owner.insert(index, dir.clone())
            {
                let (p, d) = (prev.display(), dir.display());
                let msg = format!("{} is finished in both {p} and {d}", a.trial_id);
                return Err(Error::invalid("merge", msg));
            }
            g.by_index.entry(index).or_default().push(r);
        }
    }
    Ok(g)
}

/// Merges `dirs` into `out`. Idempotent: re-run after a kill at any point it completes the
/// merge, or finds it complete and writes nothing ([`Outcome`]).
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<Merged, Error> {
    if dirs.is_empty() {
        return Err(Error::invalid("merge", "name at least one batch directory"));
    }
    let _lock = BatchLock::exclusive(out)?;
    let g = gather(dirs, out)?;
    let manifest = g.manifest.expect("at least one input");
    let previous = previous_output(out, &manifest)?;
    let mut journal = String::new();
    for r in g.by_index.values().flatten() {
        journal.push_str(&serde_json::to_string(r).expect("records serialise"));
        journal.push('\n');
    }
    let merged = |outcome| Merged { inputs: dirs.len(), trials: g.owner.len(), outcome };
    if previous == journal.as_bytes() && out.join(MANIFEST).exists() {
        return Ok(merged(Outcome::AlreadyComplete));
    }
    let marker = Marker { format: "mesopush-batch-merge".into(), inputs: g.inputs.clone() };
    let text = serde_json::to_string_pretty(&marker).expect("marker serialises");
    write_atomic(&out.join(MARKER), text.as_bytes())?;
    let text = serde_json::to_string_pretty(&manifest).expect("manifest serialises");
    write_atomic(&out.join(MANIFEST), text.as_bytes())?;
    write_atomic(&out.join(JOURNAL), journal.as_bytes())?;
    Ok(merged(if previous.is_empty() { Outcome::Written } else { Outcome::Updated }))
}
