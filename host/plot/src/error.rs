//! The plot crate's one error: a figure that could not be drawn or written.

use plotters::drawing::DrawingAreaErrorKind;
use std::path::PathBuf;

/// Everything drawing a figure can fail with.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The file name's extension names no backend we have.
    #[error("{path}: figures are written as .png or .svg")]
    UnsupportedFormat {
        /// The figure's path.
        path: PathBuf,
    },
    /// Drawing failed (font, backend, file); inside a draw function the path is not known
    /// yet, so [`crate::save()`] adds it.
    #[error("{}{message}", path.as_ref().map(|p| format!("{}: ", p.display())).unwrap_or_default())]
    Draw {
        /// The figure's path, once known.
        path: Option<PathBuf>,
        /// What the backend said.
        message: String,
    },
}

impl<E: std::error::Error + Send + Sync> From<DrawingAreaErrorKind<E>> for Error {
    fn from(e: DrawingAreaErrorKind<E>) -> Self {
        Error::Draw { path: None, message: e.to_string() }
    }
}

impl Error {
    /// The error with the figure's path filled in (draw functions do not know it).
    pub fn at(self, figure: &std::path::Path) -> Self {
        match self {
            Error::Draw { path: None, message } => {
                Error::Draw { path: Some(figure.to_path_buf()), message }
            }
            other => other,
        }
    }
}
