//! The one shape of a run split into shards: shard `I/N` owns the items whose index is
//! `≡ I (mod N)` — trials of a batch, Monte Carlo samples of a robustness run, candidates of an
//! identification sweep — so each shard is one task of an existing scheduler (a Slurm job
//! array, GNU parallel) and the merge is the union. [`ShardFile`] is the file every sharded
//! computation writes: the run's key, the shard, and `(index, item)` pairs; [`merge`] refuses
//! files of another run, a shard count that disagrees, a shard given twice or missing, and any
//! index missing, duplicated or in the wrong shard — naming the file — so a merged result is
//! never silently partial.

use crate::Error;
use crate::fsx::{read_json, write_json_atomic};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// A shard: trials whose index ≡ `index` mod `count`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// This shard, 0-based.
    pub index: u64,
    /// Number of shards.
    pub count: u64,
}

impl Shard {
    /// The whole batch.
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// Parses `I/N` (0 ≤ I < N).
    pub fn parse(text: &str) -> Result<Self, Error> {
        let err = || Error::ShardSpec { text: text.to_string() };
        let (i, n) = text.split_once('/').ok_or_else(err)?;
        let (index, count) =
            (i.trim().parse().map_err(|_| err())?, n.trim().parse().map_err(|_| err())?);
        if count == 0 || index >= count {
            return Err(err());
        }
        Ok(Self { index, count })
    }

    /// Whether trial `i` belongs to this shard.
    pub fn owns(&self, i: u64) -> bool {
        i % self.count == self.index
    }

    /// Checks that `shards` (each with the file it came from) are every one of the same
    /// split's `N` shards exactly once; errors name the file (`what`: the merge's name).
    pub fn check_set<'p>(
        what: &'static str,
        shards: impl IntoIterator<Item = (&'p Path, Shard)>,
    ) -> Result<(), Error> {
        let mut seen: Vec<bool> = Vec::new();
        for (p, s) in shards {
            let bad =
                |m: String| Error::ShardSet { what, message: format!("{}: {m}", p.display()) };
            if seen.is_empty() {
                seen = vec![false; s.count as usize];
            }
            let count = seen.len();
            if s.count as usize != count {
                return Err(bad(format!("shard {}/{} among shards of {count}", s.index, s.count)));
            }
            if std::mem::replace(&mut seen[s.index as usize], true) {
                return Err(bad(format!("shard {}/{count} given twice", s.index)));
            }
        }
        let count = seen.len();
        let missing: Vec<String> =
            (0..count).filter(|&i| !seen[i]).map(|i| format!("{i}/{count}")).collect();
        if !missing.is_empty() {
            return Err(Error::ShardSet {
                what,
                message: format!("missing shards {}", missing.join(", ")),
            });
        }
        Ok(())
    }

    /// Directory name for a shard's output (`shard-03-of-16`).
    pub fn dir_name(&self) -> String {
        let w = self.count.to_string().len().max(2);
        format!("shard-{:0w$}-of-{:0w$}", self.index, self.count)
    }
}

/// One shard's share of a sharded computation, as written to disk: the run's `key` (all
/// that makes two shards parts of one run), which `shard`, and its `(index, item)` pairs in
/// index order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShardFile<K, T> {
    /// The file format's version (the caller's constant).
    pub format: u32,
    /// What makes two shards parts of the same run.
    pub key: K,
    /// Which shard.
    pub shard: Shard,
    /// `(index, item)`, index order.
    pub items: Vec<(u64, T)>,
}

impl<K: Serialize + DeserializeOwned, T: Serialize + DeserializeOwned> ShardFile<K, T> {
    /// Writes the file atomically.
    pub fn write(&self, path: &Path) -> Result<(), Error> {
        write_json_atomic(path, self)
    }

    /// Reads a file, refusing another format version.
    pub fn read(path: &Path, format: u32) -> Result<Self, Error> {
        let f: Self = read_json(path)?;
        if f.format != format {
            return Err(Error::ShardSet {
                what: "shard file",
                message: format!(
                    "{}: format {} (this program reads format {format})",
                    path.display(),
                    f.format
                ),
            });
        }
        Ok(f)
    }
}

/// Merges shard files of one run of `total` items: every file's key must equal the first's,
/// the shards must be all `N` exactly once, and every index `0..total` must appear exactly
/// once, in the shard that owns it. Returns the key and the items in index order.
pub fn merge<K: PartialEq, T>(
    what: &'static str,
    files: Vec<(PathBuf, ShardFile<K, T>)>,
    total: impl Fn(&K) -> u64,
) -> Result<(K, Vec<T>), Error> {
    let bad =
        |p: &Path, m: String| Error::ShardSet { what, message: format!("{}: {m}", p.display()) };
    Shard::check_set(what, files.iter().map(|(p, f)| (p.as_path(), f.shard)))?;
    let mut files = files.into_iter();
    let (p0, first) =
        files.next().ok_or(Error::ShardSet { what, message: "no shard files".into() })?;
    let n = total(&first.key);
    let mut slots: Vec<Option<T>> = (0..n).map(|_| None).collect();
    let mut place = |p: &Path, shard: Shard, items: Vec<(u64, T)>| -> Result<(), Error> {
        for (i, item) in items {
            if i >= n {
                return Err(bad(p, format!("item {i} beyond the run's {n}")));
            }
            if !shard.owns(i) {
                return Err(bad(
                    p,
                    format!("item {i} does not belong to shard {}/{}", shard.index, shard.count),
                ));
            }
            if slots[i as usize].replace(item).is_some() {
                return Err(bad(p, format!("item {i} given twice")));
            }
        }
        Ok(())
    };
    place(&p0, first.shard, first.items)?;
    for (p, f) in files {
        if f.key != first.key {
            return Err(bad(&p, format!("belongs to another run than {}", p0.display())));
        }
        place(&p, f.shard, f.items)?;
    }
    let missing: Vec<u64> = (0..n).filter(|&i| slots[i as usize].is_none()).take(10).collect();
    if !missing.is_empty() {
        return Err(Error::ShardSet {
            what,
            message: format!("items missing from every shard: {missing:?}"),
        });
    }
    Ok((first.key, slots.into_iter().flatten().collect()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shard_parses_and_partitions() {
        let s = Shard::parse("2/4").unwrap();
        assert!(s.owns(2) && s.owns(6) && !s.owns(3));
        assert_eq!(s.dir_name(), "shard-02-of-04");
        for bad in ["4/4", "1", "a/2", "1/0", "-1/3"] {
            let e = Shard::parse(bad).unwrap_err().to_string();
            assert!(e.contains(bad) && e.contains("I/N"), "{e}");
        }
    }

    fn file(index: u64, count: u64, key: u32, items: &[u64]) -> (PathBuf, ShardFile<u32, u64>) {
        let shard = Shard { index, count };
        let items = items.iter().map(|&i| (i, 10 * i)).collect();
        (PathBuf::from(format!("s{index}")), ShardFile { format: 1, key, shard, items })
    }

    #[test]
    fn merge_is_the_union_in_index_order() {
        let files = vec![file(1, 2, 7, &[1, 3]), file(0, 2, 7, &[0, 2, 4])];
        let (key, items) = merge("test", files, |_| 5).unwrap();
        assert_eq!((key, items), (7, vec![0, 10, 20, 30, 40]));
    }

    #[test]
    fn merge_refuses_partial_foreign_and_misplaced_shards() {
        let cases = [
            (vec![file(0, 2, 7, &[0, 2, 4])], "missing shards 1/2"),
            (vec![file(0, 2, 7, &[0, 2, 4]), file(1, 2, 8, &[1, 3])], "another run"),
            (vec![file(0, 2, 7, &[0, 2]), file(1, 2, 7, &[1, 3])], "missing from every shard"),
            (vec![file(0, 2, 7, &[0, 2, 4]), file(1, 2, 7, &[1, 3, 2])], "does not belong"),
            (vec![file(0, 2, 7, &[0, 2, 4, 4]), file(1, 2, 7, &[1, 3])], "twice"),
            (vec![file(0, 2, 7, &[0, 2, 4]), file(0, 2, 7, &[0, 2, 4])], "given twice"),
        ];
        for (files, want) in cases {
            let e = merge("test", files, |_| 5).unwrap_err().to_string();
            assert!(e.contains(want), "{e} (wanted {want})");
        }
    }
}
