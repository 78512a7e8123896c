//! Finding trial directories: a path given on a command line is a trial directory (it holds
//! `trial.json`) or a directory of them, nested up to [`MAX_DEPTH`] levels (a batch's
//! `trials/`, an importer's `<set-up>/<start>/<run>/`). A directory with a trial's data
//! (probe.csv or pose.csv) but no `trial.json` is an error naming it, never skipped: a
//! result computed on fewer trials than given would look like one computed on all.

use crate::Error;
use std::path::{Path, PathBuf};

/// How deep below a given path trial directories are looked for.
pub const MAX_DEPTH: usize = 4;

/// The trial directories in or under `paths`, each path's in sorted order; a path with none
/// is an error naming it.
pub fn trial_dirs(paths: &[PathBuf]) -> Result<Vec<PathBuf>, Error> {
    let mut out = Vec::new();
    for p in paths {
        let before = out.len();
        collect(p, 0, &mut out)?;
        if out.len() == before {
            return Err(Error::invalid(
                "trial directory",
                format!(
                    "{}: no trial.json in it or in its subdirectories (up to {MAX_DEPTH} levels)",
                    p.display()
                ),
            ));
        }
    }
    Ok(out)
}

fn collect(dir: &Path, depth: usize, out: &mut Vec<PathBuf>) -> Result<(), Error> {
    if dir.join(crate::files::META).is_file() {
        out.push(dir.to_path_buf());
        return Ok(());
    }
    if let Some(part) =
        [crate::files::PROBE, crate::files::POSE].iter().find(|f| dir.join(f).is_file())
    {
        return Err(Error::invalid(
            "trial directory",
            format!(
                "{}: holds {part} but no {} (a trial directory must have both; not skipped)",
                dir.display(),
                crate::files::META
            ),
        ));
    }
    if depth == MAX_DEPTH {
        return Ok(());
    }
    let rd = std::fs::read_dir(dir).map_err(|cause| Error::Io { path: dir.into(), cause })?;
    let mut subs: Vec<PathBuf> =
        rd.filter_map(|e| e.ok().map(|e| e.path())).filter(|d| d.is_dir()).collect();
    subs.sort();
    for s in subs {
        collect(&s, depth + 1, out)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nested_trials_are_found_in_order_and_an_empty_path_is_named() {
        let tmp = tempfile::tempdir().unwrap();
        for d in ["b/run-2", "b/run-1", "a"] {
            let dir = tmp.path().join(d);
            std::fs::create_dir_all(&dir).unwrap();
            std::fs::write(dir.join("trial.json"), "{}").unwrap();
        }
        std::fs::create_dir_all(tmp.path().join("empty")).unwrap();
        let found = trial_dirs(&[tmp.path().to_path_buf()]).unwrap();
        let names: Vec<_> =
            found.iter().map(|p| p.strip_prefix(tmp.path()).unwrap().to_owned()).collect();
        assert_eq!(names, ["a", "b/run-1", "b/run-2"].map(PathBuf::from));
        let err = trial_dirs(&[tmp.path().join("empty")]).unwrap_err().to_string();
        assert!(err.contains("empty") && err.contains("no trial.json"), "{err}");
        let headless = tmp.path().join("b/run-3");
        std::fs::create_dir_all(&headless).unwrap();
        std::fs::write(headless.join("pose.csv"), "").unwrap();
        let err = trial_dirs(&[tmp.path().to_path_buf()]).unwrap_err().to_string();
        assert!(err.contains("run-3") && err.contains("no trial.json"), "{err}");
    }
}
