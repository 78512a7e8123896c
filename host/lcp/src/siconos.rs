//! Reader for the dense Siconos LCP and MLCP file formats (`.dat`) of the peer test suite.
//!
//! LCP: whitespace-separated `n`, the storage type (`0` dense; `1` is Siconos's sparse-block
//! storage, which we refuse by name), `n n` twice, the `n × n` values of `M` in column-major
//! order, then the `n` values of `q`. Anything after `q` (comments, a stored solution) is
//! ignored, as Siconos does.
//!
//! MLCP (`mixedLinearComplementarity_newFromFile`): two flags (M given; A–D given), `n`
//! (equalities) and `m` (complementarity rows), the row blocks (`blocksRows` up to `n + m`,
//! then one is-complementarity flag per block), then `M` as a dense NumericsMatrix
//! (storage `0`, sizes, sizes again, values column-major) and `q`. The A–D copy that follows
//! is ignored. We read files whose equality rows come first and whose `M` is square.

use std::path::{Path, PathBuf};

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
    /// The problem view for [`crate::LcpSolver::solve`] (`n_free = 0`).
    pub fn problem(&self) -> crate::MlcpProblem<'_> {
        crate::MlcpProblem { n_free: 0, n: self.n, m: &self.m, q: &self.q }
    }
}

/// Largest `n` accepted (keeps a corrupt header from asking for a huge allocation).
pub const MAX_N: usize = 4096;

fn read_text(path: &Path) -> Result<String, Error> {
    std::fs::read_to_string(path)
        .map_err(|e| Error::Io { path: path.to_path_buf(), message: e.to_string() })
}

/// A text error placed in its file.
fn at(path: &Path, e: Error) -> Error {
    match e {
        Error::Format { message, .. } => Error::Format { path: path.to_path_buf(), message },
        other => other,
    }
}

/// A format error without a file (parsing text).
fn format_error(message: String) -> Error {
    Error::Format { path: PathBuf::new(), message }
}

/// Reads and parses a file.
pub fn read(path: &Path) -> Result<SiconosLcp, Error> {
    parse(&read_text(path)?).map_err(|e| at(path, e))
}

/// Parses the text of an LCP file; the error names what is wrong.
pub fn parse(text: &str) -> Result<SiconosLcp, Error> {
    parse_lcp_text(text).map_err(format_error)
}

fn parse_lcp_text(text: &str) -> Result<SiconosLcp, String> {
    let mut tok = Tokens(text.split_whitespace());
    let n = tok.int("n (the problem size)")?;
    if n == 0 || n > MAX_N {
        return Err(format!("n = {n} is out of range (1..={MAX_N})"));
    }
    let (m, q) = tok.dense_matrix_and_q(n)?;
    Ok(SiconosLcp { n, m, q })
}

/// A mixed LCP read from a file: the first `n_free` rows are equalities, `M` row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct SiconosMlcp {
    /// Number of equality rows (free variables), first.
    pub n_free: usize,
    /// Total size.
    pub n: usize,
    /// `M`, `n × n`, row-major.
    pub m: Vec<f64>,
    /// `q`, length `n`.
    pub q: Vec<f64>,
}

impl SiconosMlcp {
    /// The problem view for [`crate::LcpSolver::solve`].
    pub fn problem(&self) -> crate::MlcpProblem<'_> {
        crate::MlcpProblem { n_free: self.n_free, n: self.n, m: &self.m, q: &self.q }
    }
}

/// Reads and parses an MLCP file.
pub fn read_mlcp(path: &Path) -> Result<SiconosMlcp, Error> {
    parse_mlcp(&read_text(path)?).map_err(|e| at(path, e))
}

/// Parses the text of an MLCP file; the error message names what is wrong.
pub fn parse_mlcp(text: &str) -> Result<SiconosMlcp, Error> {
    parse_mlcp_text(text).map_err(format_error)
}

fn parse_mlcp_text(text: &str) -> Result<SiconosMlcp, String> {
    let mut tok = Tokens(text.split_whitespace());
    let has_m = tok.int("the first storage flag (M given)")?;
    let _has_abcd = tok.int("the second storage flag (A, B, C, D given)")?;
    let n_free = tok.int("n (equality rows)")?;
    let n_comp = tok.int("m (complementarity rows)")?;
    let n = n_free + n_comp;
    if n == 0 || n > MAX_N {
        return Err(format!("n + m = {n} is out of range (1..={MAX_N})"));
    }
    if has_m != 1 {
        return Err("files without the M matrix (first flag 0) are not supported".into());
    }
    let mut rows = vec![tok.int("blocksRows[0]")?];
    while *rows.last().unwrap_or(&n) < n {
        if rows.len() > n {
            return Err(format!("blocksRows never reaches n + m = {n}"));
        }
        rows.push(tok.int("blocksRows")?);
    }
    for k in 0..rows.len() - 1 {
        let comp = tok.int("blocksIsComp")? != 0;
        if comp != (rows[k] >= n_free) || rows[k] > rows[k + 1] {
            return Err(format!(
                "block {k} (rows {}..{}) is {}: only equality rows first, then \
                 complementarity rows, are supported",
                rows[k],
                rows[k + 1],
                if comp { "complementarity" } else { "equality" }
            ));
        }
    }
    let (m, q) = tok.dense_matrix_and_q(n)?;
    Ok(SiconosMlcp { n_free, n, m, q })
}

/// The whitespace-separated tokens of a file, read with messages that name what was expected.
struct Tokens<'a>(std::str::SplitWhitespace<'a>);

impl Tokens<'_> {
    fn int(&mut self, what: &str) -> Result<usize, String> {
        let t = self.0.next().ok_or_else(|| format!("file ends before {what}"))?;
        t.parse::<usize>()
            .map_err(|_| format!("{what}: expected a non-negative integer, found {t:?}"))
    }

    fn values(&mut self, count: usize, what: &str) -> Result<Vec<f64>, String> {
        let mut out = Vec::with_capacity(count);
        for k in 0..count {
            let t = self
                .0
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
    }

    /// A dense NumericsMatrix (storage type, sizes twice, column-major values) that must be
    /// `n × n`, then `q`; returns `M` row-major.
    fn dense_matrix_and_q(&mut self, n: usize) -> Result<(Vec<f64>, Vec<f64>), String> {
        let storage = self.int("the storage type")?;
        if storage != 0 {
            return Err(format!(
                "unsupported storage type {storage} (1 is Siconos sparse-block storage); \
                 only dense storage (0) is supported"
            ));
        }
        for what in ["size0", "size1", "size0 (repeated)", "size1 (repeated)"] {
            let v = self.int(what)?;
            if v != n {
                return Err(format!("{what} = {v} does not match n = {n} (M must be square)"));
            }
        }
        let cols = self.values(n * n, "M (column-major)")?;
        let q = self.values(n, "q")?;
        let mut m = vec![0.0; n * n];
        for j in 0..n {
            for i in 0..n {
                m[i * n + j] = cols[j * n + i];
            }
        }
        Ok((m, q))
    }
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
    fn reads_an_mlcp_with_equalities_first_and_refuses_other_layouts() {
        let text = "1 1 1 2  0 1 3  0 1  0 3 3 3 3  1 0 0 2 1 0 0 1.5 1  -1 1 -3  9 9";
        let p = super::parse_mlcp(text).unwrap();
        assert_eq!((p.n_free, p.n), (1, 3));
        assert_eq!(p.m, vec![1.0, 2.0, 0.0, 0.0, 1.0, 1.5, 0.0, 0.0, 1.0]);
        assert_eq!(p.q, vec![-1.0, 1.0, -3.0]);
        let e = super::parse_mlcp("1 1 1 2  0 1 3  1 0  0 3 3 3 3").unwrap_err().to_string();
        assert!(e.contains("only equality rows first"), "{e}");
        let e = super::parse_mlcp("1 1 1 1  0 1 2  0 1  0 3 2 3 2").unwrap_err().to_string();
        assert!(e.contains("must be square"), "{e}");
        let e = super::parse_mlcp("0 1 1 1").unwrap_err().to_string();
        assert!(e.contains("without the M matrix"), "{e}");
    }

    #[test]
    fn names_what_is_wrong() {
        let e = parse("2 0 2 2 2 2 1 2 3").unwrap_err().to_string();
        assert!(e.contains("3 of the 4 values of M"), "{e}");
        let e = parse("2 0 2 2 2 2 1 2 3 4 nan 1").unwrap_err().to_string();
        assert!(e.contains("value 1 of q") && e.contains("not finite"), "{e}");
        let e = parse("2 1 2 2 1 1 1 2").unwrap_err().to_string();
        assert!(e.contains("sparse-block"), "{e}");
        let e = parse("2 0 3 2 2 2").unwrap_err().to_string();
        assert!(e.contains("size0 = 3"), "{e}");
        let e = parse("x").unwrap_err().to_string();
        assert!(e.contains("problem size"), "{e}");
        let e = parse("2 0 2 2 2 2 1 2 3 4 1 inf").unwrap_err().to_string();
        assert!(e.contains("value 2 of q"), "{e}");
    }
}
