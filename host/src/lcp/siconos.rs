//! Reader for the dense Siconos LCP file format (`.dat`) of the peer test suite.
//!
//! Whitespace-separated: `n`, the storage type (`0` dense; `1` is Siconos's sparse-block
//! storage, which we refuse by name), `n n` twice, the `n × n` values of `M` in column-major
//! order, then the `n` values of `q`. Anything after `q` (comments, a stored solution) is
//! ignored, as Siconos does.

use std::path::Path;

use crate::Error;

/// A pure LCP read from a file: `M` stored row-major (converted from the file's column-major).
#[derive(Debug, Clone, PartialEq)]
pub struct SiconosLcp {
    /// Size.
    pub n: usize,
    /// `M`, `n × n`, row-major.
    pub m: Vec<f64>,
    /// `q`, length `n`.
    pub q: Vec<f64>,
}

impl SiconosLcp {
    /// The problem view for [`crate::lcp::LcpSolver::solve`] (`n_free = 0`).
    pub fn problem(&self) -> crate::lcp::MlcpProblem<'_> {
        crate::lcp::MlcpProblem { n_free: 0, n: self.n, m: &self.m, q: &self.q }
    }
}

/// Largest `n` accepted (keeps a corrupt header from asking for a huge allocation).
pub const MAX_N: usize = 4096;

/// Reads and parses a file.
pub fn read(path: &Path) -> Result<SiconosLcp, Error> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    parse(&text).map_err(|message| Error::Parse { path: path.to_path_buf(), message })
}

/// Parses the text of a file; the error message names what is wrong.
pub fn parse(text: &str) -> Result<SiconosLcp, String> {
    let mut tokens = text.split_whitespace();
    let mut int = |what: &str| -> Result<usize, String> {
        let t = tokens.next().ok_or_else(|| format!("file ends before {what}"))?;
        t.parse::<usize>()
            .map_err(|_| format!("{what}: expected a non-negative integer, found {t:?}"))
    };
    let n = int("n (the problem size)")?;
    if n == 0 || n > MAX_N {
        return Err(format!("n = {n} is out of range (1..={MAX_N})"));
    }
    let storage = int("the storage type")?;
    if storage != 0 {
        return Err(format!(
            "unsupported storage type {storage} (1 is Siconos sparse-block storage); \
             only dense storage (0) is supported"
        ));
    }
    for what in ["size0", "size1", "size0 (repeated)", "size1 (repeated)"] {
        let v = int(what)?;
        if v != n {
            return Err(format!("{what} = {v} does not match n = {n}"));
        }
    }
    let mut values = |count: usize, what: &str| -> Result<Vec<f64>, String> {
        let mut out = Vec::with_capacity(count);
        for k in 0..count {
            let t = tokens
                .next()
                .ok_or_else(|| format!("file ends after {k} of the {count} values of {what}"))?;
            let v: f64 = t
                .parse()
                .map_err(|_| format!("value {} of {what}: {t:?} is not a number", k + 1))?;
            if !v.is_finite() {
                return Err(format!("value {} of {what} is {t:?}, not finite", k + 1));
            }
            out.push(v);
        }
        Ok(out)
    };
    let cols = values(n * n, "M (column-major)")?;
    let q = values(n, "q")?;
    let mut m = vec![0.0; n * n];
    for j in 0..n {
        for i in 0..n {
            m[i * n + j] = cols[j * n + i];
        }
    }
    Ok(SiconosLcp { n, m, q })
}

#[cfg(test)]
mod tests {
    use super::parse;

    #[test]
    fn reads_column_major_and_ignores_trailing_comment() {
        let p = parse("2 0 2 2 2 2\n1 3\n2 4\n-1 -2\nsome remark 5").unwrap();
        assert_eq!(p.m, vec![1.0, 2.0, 3.0, 4.0]);
        assert_eq!(p.q, vec![-1.0, -2.0]);
    }

    #[test]
    fn names_what_is_wrong() {
        let e = parse("2 0 2 2 2 2 1 2 3").unwrap_err();
        assert!(e.contains("3 of the 4 values of M"), "{e}");
        let e = parse("2 0 2 2 2 2 1 2 3 4 nan 1").unwrap_err();
        assert!(e.contains("value 1 of q") && e.contains("not finite"), "{e}");
        let e = parse("2 1 2 2 1 1 1 2").unwrap_err();
        assert!(e.contains("sparse-block"), "{e}");
        let e = parse("2 0 3 2 2 2").unwrap_err();
        assert!(e.contains("size0 = 3"), "{e}");
        let e = parse("x").unwrap_err();
        assert!(e.contains("problem size"), "{e}");
        let e = parse("2 0 2 2 2 2 1 2 3 4 1 inf").unwrap_err();
        assert!(e.contains("value 2 of q"), "{e}");
    }
}
