//! A legend drawn in its own band under a figure, never over the data: the fixture figures
//! fill their whole plotting area with walls, peg outlines and probe marks, and plotters'
//! own legend box, placed inside the plotting area, hid parts of them (issue 22).

use crate::DrawResult;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// How a legend entry is marked.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Mark {
    /// A line segment of this colour and width (px).
    Line(RGBAColor, u32),
    /// A filled box.
    Box(RGBAColor),
    /// A filled triangle (probe tips).
    Triangle(RGBAColor),
    /// A filled dot.
    Dot(RGBAColor),
    /// A cross (failures).
    Cross(RGBAColor),
}

/// One legend entry: its mark and its words.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    /// The mark.
    pub mark: Mark,
    /// The words.
    pub text: String,
}

impl Entry {
    /// An entry.
    pub fn new(mark: Mark, text: impl Into<String>) -> Self {
        Self { mark, text: text.into() }
    }
}

/// Height of one legend row, px.
pub const ROW_PX: u32 = 22;
/// Entries per legend row.
pub const COLUMNS: usize = 2;

/// Height of the band that holds `entries` legend entries, px (with a margin below).
pub fn band_px(entries: usize) -> u32 {
    let rows = entries.div_ceil(COLUMNS) as u32;
    rows * ROW_PX + 8
}

/// Draws `entries` in `band`, [`COLUMNS`] per row, left to right then down, framed.
pub fn draw_legend<DB: DrawingBackend>(
    band: &DrawingArea<DB, Shift>,
    entries: &[Entry],
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let (w, h) = band.dim_in_pixel();
    let (w, h) = (i32::try_from(w).unwrap_or(i32::MAX), i32::try_from(h).unwrap_or(i32::MAX));
    band.draw(&Rectangle::new([(10, 0), (w - 10, h - 4)], BLACK.stroke_width(1)))?;
    let col_px = (w - 20) / COLUMNS as i32;
    let font = ("sans-serif", 15).into_font().color(&BLACK).pos(Pos::new(HPos::Left, VPos::Center));
    for (i, e) in entries.iter().enumerate() {
        let (row, col) = ((i / COLUMNS) as i32, (i % COLUMNS) as i32);
        let x = 20 + col * col_px;
        let y = row * ROW_PX as i32 + ROW_PX as i32 / 2 + 2;
        match e.mark {
            Mark::Line(c, width) => {
                band.draw(&PathElement::new([(x, y), (x + 22, y)], c.stroke_width(width)))?
            }
            Mark::Box(c) => {
                band.draw(&Rectangle::new([(x, y - 6), (x + 22, y + 6)], c.filled()))?
            }
            Mark::Triangle(c) => band.draw(&TriangleMarker::new((x + 11, y), 6, c.filled()))?,
            Mark::Dot(c) => band.draw(&Circle::new((x + 11, y), 4, c.filled()))?,
            Mark::Cross(c) => band.draw(&Cross::new((x + 11, y), 5, c.stroke_width(2)))?,
        }
        band.draw(&Text::new(e.text.clone(), (x + 30, y), font.clone()))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_band_holds_every_entry_in_rows_of_two() {
        assert_eq!(band_px(1), ROW_PX + 8);
        assert_eq!(band_px(2), ROW_PX + 8);
        assert_eq!(band_px(5), 3 * ROW_PX + 8);
    }
}
