//! How a driver lays out a frame, and its conversion to the 8-bit luma the tracker and the
//! recorder use. Two formats are accepted: `GREY` (one byte per pixel) and `YUYV` (4:2:2,
//! four-byte macropixels `Y0 U Y1 V` of two pixels; the luma is kept). A row may be padded
//! (`bytes_per_line` larger than the pixels need, as drivers align lines); the padding is
//! skipped. Pure functions: tested on recorded buffers, no camera needed.

use crate::Error;

/// A pixel format the capture accepts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PixelFormat {
    /// 8-bit grey, one byte per pixel (V4L2 `GREY`).
    Grey,
    /// YUV 4:2:2 packed as `Y0 U Y1 V` (V4L2 `YUYV`); the luma bytes are kept.
    Yuyv,
}

impl PixelFormat {
    /// Every accepted format, in order of preference.
    pub const ALL: [PixelFormat; 2] = [PixelFormat::Grey, PixelFormat::Yuyv];

    /// The V4L2 four-character code.
    pub const fn fourcc(self) -> [u8; 4] {
        match self {
            PixelFormat::Grey => *b"GREY",
            PixelFormat::Yuyv => *b"YUYV",
        }
    }

    /// The format with this V4L2 four-character code, if it is accepted.
    pub fn from_fourcc(code: [u8; 4]) -> Option<Self> {
        Self::ALL.into_iter().find(|f| f.fourcc() == code)
    }

    /// Bytes a row of `width` pixels needs: `width` for GREY, whole four-byte macropixels for
    /// YUYV (an odd width ends in a macropixel whose second pixel is padding).
    pub fn row_bytes(self, width: u32) -> usize {
        let w = width as usize;
        match self {
            PixelFormat::Grey => w,
            PixelFormat::Yuyv => 4 * w.div_ceil(2),
        }
    }
}

impl core::fmt::Display for PixelFormat {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            PixelFormat::Grey => "GREY",
            PixelFormat::Yuyv => "YUYV",
        })
    }
}

/// Largest frame side accepted, px (far beyond a microscope camera; keeps sizes in range).
pub const MAX_SIDE_PX: u32 = 16_384;

/// A frame's layout in a driver's buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameLayout {
    /// Pixel format.
    pub format: PixelFormat,
    /// Width, px.
    pub width: u32,
    /// Height, px.
    pub height: u32,
    /// Bytes from the start of one row to the next (V4L2 `bytesperline`).
    pub bytes_per_line: usize,
}

impl FrameLayout {
    /// A checked layout: sides in 1..=[`MAX_SIDE_PX`] and `bytes_per_line` at least what a
    /// row needs ([`PixelFormat::row_bytes`]). A driver reporting `bytes_per_line` 0 means
    /// unpadded rows: pass `format.row_bytes(width)`.
    pub fn new(
        format: PixelFormat,
        width: u32,
        height: u32,
        bytes_per_line: usize,
    ) -> Result<Self, Error> {
        for (side, v) in [("width", width), ("height", height)] {
            if !(1..=MAX_SIDE_PX).contains(&v) {
                return Err(Error::invalid(
                    "frame layout",
                    format!("{side} {v} px is outside 1..={MAX_SIDE_PX}"),
                ));
            }
        }
        let row = format.row_bytes(width);
        if bytes_per_line < row {
            return Err(Error::invalid(
                "frame layout",
                format!(
                    "bytes per line {bytes_per_line} is less than a {width} px {format} row \
                     needs ({row})"
                ),
            ));
        }
        Ok(Self { format, width, height, bytes_per_line })
    }

    /// Bytes a buffer must hold: every row but the last with its padding, then the last
    /// row's pixels.
    pub fn frame_bytes(&self) -> usize {
        self.bytes_per_line * (self.height as usize - 1) + self.format.row_bytes(self.width)
    }

    /// Pixels of the luma image, `width × height`.
    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Writes the frame in `buf` (the driver's bytes in use) into `out` as row-major 8-bit
    /// luma, `width × height` bytes (replacing what `out` held). A buffer shorter than
    /// [`Self::frame_bytes`] is refused naming both sizes; bytes beyond it are ignored.
    pub fn to_luma(&self, buf: &[u8], out: &mut Vec<u8>) -> Result<(), Error> {
        let need = self.frame_bytes();
        if buf.len() < need {
            return Err(Error::ShortFrame {
                got: buf.len(),
                need,
                width: self.width,
                height: self.height,
                bytes_per_line: self.bytes_per_line,
                format: self.format,
            });
        }
        let w = self.width as usize;
        out.clear();
        out.reserve(self.pixel_count());
        for row in buf[..need].chunks(self.bytes_per_line).take(self.height as usize) {
            match self.format {
                PixelFormat::Grey => out.extend_from_slice(&row[..w]),
                PixelFormat::Yuyv => out.extend(row[..2 * w].iter().step_by(2)),
            }
        }
        debug_assert_eq!(out.len(), self.pixel_count());
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn row_bytes_count_whole_macropixels() {
        assert_eq!(PixelFormat::Grey.row_bytes(5), 5);
        assert_eq!(PixelFormat::Yuyv.row_bytes(4), 8);
        assert_eq!(PixelFormat::Yuyv.row_bytes(5), 12);
        assert_eq!(PixelFormat::from_fourcc(*b"YUYV"), Some(PixelFormat::Yuyv));
        assert_eq!(PixelFormat::from_fourcc(*b"MJPG"), None);
    }

    #[test]
    fn layouts_out_of_range_are_refused_naming_the_sizes() {
        let e = FrameLayout::new(PixelFormat::Yuyv, 5, 2, 10).unwrap_err().to_string();
        assert!(e.contains("10") && e.contains("12") && e.contains("YUYV"), "{e}");
        assert!(FrameLayout::new(PixelFormat::Grey, 0, 2, 4).is_err());
        assert!(FrameLayout::new(PixelFormat::Grey, 2, MAX_SIDE_PX + 1, 4).is_err());
        let ok = FrameLayout::new(PixelFormat::Grey, 3, 2, 8).unwrap();
        assert_eq!(ok.frame_bytes(), 8 + 3);
    }
}
