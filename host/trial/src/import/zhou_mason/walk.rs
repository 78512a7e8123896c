//! Finding the run files under a folder: the data root, one set-up folder, one start folder
//! (or one run file). Runs are `log*.txt` files, found at any depth, in path order.

use crate::Error;
use std::path::{Path, PathBuf};

fn is_run_file(p: &Path) -> bool {
    p.file_name()
        .and_then(|n| n.to_str())
        .is_some_and(|n| n.starts_with("log") && n.ends_with(".txt"))
}

fn walk(dir: &Path, out: &mut Vec<PathBuf>) -> Result<(), Error> {
    let entries = std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))?;
    for entry in entries {
        let path = entry.map_err(|e| Error::io(dir, e))?.path();
        if path.is_dir() {
            walk(&path, out)?;
        } else if is_run_file(&path) {
            out.push(path);
        }
    }
    Ok(())
}

/// Every run file under `root` (or `root` itself when it is one), sorted; refuses a path
/// that holds none.
pub fn run_files(root: &Path) -> Result<Vec<PathBuf>, Error> {
    if !root.exists() {
        return Err(Error::invalid(
            "zhou-mason data",
            format!("{} does not exist", root.display()),
        ));
    }
    let mut out = Vec::new();
    if root.is_file() {
        if is_run_file(root) {
            out.push(root.to_path_buf());
        }
    } else {
        walk(root, &mut out)?;
    }
    if out.is_empty() {
        return Err(Error::invalid(
            "zhou-mason data",
            format!(
                "no run file (log*.txt) in {}; give the data root, a set-up folder or a start folder",
                root.display()
            ),
        ));
    }
    out.sort();
    Ok(out)
}
