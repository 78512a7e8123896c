//! The one way every crate writes a figure: a [`Figure`] drawn on whichever backend the
//! path's extension names (`.png` bitmap, `.svg` vector).

use crate::Error;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// What a draw function returns; plotters' errors convert with `?`.
pub type DrawResult = Result<(), Error>;

/// A figure that can draw itself on any plotters backend.
pub trait Figure {
    /// Draws the whole figure on `area` (and presents it).
    fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static;
}

/// Draws `fig` at `size` pixels to `path` (`.png` or `.svg`); errors name the path.
pub fn save(fig: &impl Figure, path: &Path, size: (u32, u32)) -> Result<(), Error> {
    crate::font::register().map_err(|e| e.at(path))?;
    let res = match path.extension().and_then(|e| e.to_str()) {
        Some("svg") => fig.draw(&SVGBackend::new(path, size).into_drawing_area()),
        Some("png") => fig.draw(&BitMapBackend::new(path, size).into_drawing_area()),
        _ => return Err(Error::UnsupportedFormat { path: path.to_path_buf() }),
    };
    res.map_err(|e| e.at(path))
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Blank;
    impl Figure for Blank {
        fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> DrawResult
        where
            DB::ErrorType: 'static,
        {
            area.fill(&WHITE)?;
            area.present()?;
            Ok(())
        }
    }

    #[test]
    fn backend_follows_the_extension_and_errors_name_the_path() {
        let dir = tempfile::tempdir().unwrap();
        save(&Blank, &dir.path().join("a.svg"), (40, 30)).unwrap();
        save(&Blank, &dir.path().join("a.png"), (40, 30)).unwrap();
        assert!(std::fs::read_to_string(dir.path().join("a.svg")).unwrap().contains("<svg"));
        let e = save(&Blank, &dir.path().join("a.jpg"), (40, 30)).unwrap_err().to_string();
        assert!(e.contains("a.jpg") && e.contains(".png"), "{e}");
        let e = save(&Blank, &dir.path().join("none/a.png"), (40, 30)).unwrap_err().to_string();
        assert!(e.contains("none/a.png"), "{e}");
    }
}
