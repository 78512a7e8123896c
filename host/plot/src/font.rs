//! The figures' one typeface, compiled in: DejaVu Sans (`fonts/DejaVuSans.ttf`, licence in
//! `fonts/LICENSE-DejaVu.txt`), registered with plotters' pure-Rust `ab_glyph` text path as
//! the `sans-serif` family every figure asks for. So a machine with only the Rust toolchain
//! draws figures with text: no fontconfig, no system fonts.
//!
//! [`register()`] is idempotent and cheap after the first call; [`crate::save()`] calls it,
//! and a crate that makes its own plotters backend calls it before drawing.

use plotters::style::{FontStyle, register_font};
use std::sync::OnceLock;

/// The embedded font file (TrueType).
const DEJAVU_SANS: &[u8] = include_bytes!("../fonts/DejaVuSans.ttf");

/// The family name figures use (`("sans-serif", size)`).
pub const FAMILY: &str = "sans-serif";

/// Registers the embedded font as [`FAMILY`] (every style falls back to it) once per
/// process. Returns an error only if the embedded file were not a font, which the tests
/// rule out.
pub fn register() -> Result<(), crate::Error> {
    static DONE: OnceLock<bool> = OnceLock::new();
    let ok = *DONE.get_or_init(|| register_font(FAMILY, FontStyle::Normal, DEJAVU_SANS).is_ok());
    if ok {
        Ok(())
    } else {
        Err(crate::Error::Draw {
            path: None,
            message: "the embedded DejaVu Sans font could not be parsed".into(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use plotters::prelude::*;

    #[test]
    fn embedded_font_registers_and_draws_text() {
        register().unwrap();
        register().unwrap(); // idempotent
        let (w, h) = (200u32, 60u32);
        let mut buf = vec![255u8; (w * h * 3) as usize];
        {
            let area = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
            area.draw_text("Ag µm 5°", &(FAMILY, 30).into_font().color(&BLACK), (10, 10)).unwrap();
            area.present().unwrap();
        }
        let dark = buf.chunks(3).filter(|p| p[0] < 128).count();
        // Glyphs cover a good part of the text's box, never the whole image.
        assert!(dark > 200 && dark < (w * h / 2) as usize, "{dark} dark pixels");
    }
}
