//! The frame-format conversion on buffers laid out as V4L2 drivers deliver them, written by
//! hand byte by byte (not by the conversion): GREY with and without line padding, YUYV with
//! chroma bytes that must not leak into the luma, an odd YUYV width (its last macropixel half
//! padding), a stride-padded YUYV frame, trailing bytes beyond the frame, and short buffers,
//! refused with an error naming both sizes.

use mesopush_capture::{Error, FrameLayout, PixelFormat};

fn luma(format: PixelFormat, w: u32, h: u32, bpl: usize, buf: &[u8]) -> Result<Vec<u8>, Error> {
    let mut out = vec![0xAB; 3]; // replaced, not appended to
    FrameLayout::new(format, w, h, bpl)?.to_luma(buf, &mut out)?;
    Ok(out)
}

/// 4 × 3 GREY, rows packed.
const GREY_4X3: [u8; 12] = [
    10, 20, 30, 40, //
    50, 60, 70, 80, //
    90, 100, 110, 120,
];

/// 3 × 2 GREY with 8 bytes per line: 5 bytes of padding (0xEE) after each row's pixels; the
/// last row's padding is absent, as drivers may leave it out of `bytesused`.
const GREY_3X2_PADDED: [u8; 11] = [
    1, 2, 3, 0xEE, 0xEE, 0xEE, 0xEE, 0xEE, //
    4, 5, 6,
];

/// 4 × 2 YUYV: macropixels `Y0 U Y1 V`; U = 0x11, V = 0x99 (must not appear in the luma).
const YUYV_4X2: [u8; 16] = [
    200, 0x11, 201, 0x99, 202, 0x11, 203, 0x99, //
    100, 0x11, 101, 0x99, 102, 0x11, 103, 0x99,
];

/// 3 × 2 YUYV (odd width): each row is two macropixels (8 bytes = 4 × ceil(3 / 2)), the
/// second's `Y1` (0xFF) padding; then 8 bytes beyond the frame (a driver's larger buffer).
const YUYV_3X2_ODD: [u8; 24] = [
    7, 0x80, 8, 0x80, 9, 0x80, 0xFF, 0x80, //
    17, 0x80, 18, 0x80, 19, 0x80, 0xFF, 0x80, //
    0, 0, 0, 0, 0, 0, 0, 0,
];

/// 3 × 3 YUYV with 16 bytes per line (8 bytes of the row, 8 of padding 0x55).
const YUYV_3X3_STRIDE16: [u8; 40] = [
    30, 1, 31, 2, 32, 3, 0xFF, 4, 0x55, 0x55, 0x55, 0x55, 0x55, 0x55, 0x55, 0x55, //
    40, 1, 41, 2, 42, 3, 0xFF, 4, 0x55, 0x55, 0x55, 0x55, 0x55, 0x55, 0x55, 0x55, //
    50, 1, 51, 2, 52, 3, 0xFF, 4,
];

#[test]
fn grey_frames_come_through_unchanged_and_padding_is_skipped() {
    let out = luma(PixelFormat::Grey, 4, 3, 4, &GREY_4X3).unwrap();
    assert_eq!(out, GREY_4X3.to_vec());
    let out = luma(PixelFormat::Grey, 3, 2, 8, &GREY_3X2_PADDED).unwrap();
    assert_eq!(out, vec![1, 2, 3, 4, 5, 6]);
}

#[test]
fn yuyv_keeps_the_luma_of_every_pixel() {
    let out = luma(PixelFormat::Yuyv, 4, 2, 8, &YUYV_4X2).unwrap();
    assert_eq!(out, vec![200, 201, 202, 203, 100, 101, 102, 103]);
}

#[test]
fn an_odd_yuyv_width_drops_the_padding_pixel() {
    let out = luma(PixelFormat::Yuyv, 3, 2, 8, &YUYV_3X2_ODD[..16]).unwrap();
    assert_eq!(out, vec![7, 8, 9, 17, 18, 19]);
    // bytes beyond the frame (a driver's larger buffer) are ignored
    let out = luma(PixelFormat::Yuyv, 3, 2, 8, &YUYV_3X2_ODD).unwrap();
    assert_eq!(out, vec![7, 8, 9, 17, 18, 19]);
}

#[test]
fn a_stride_padded_yuyv_frame_reads_each_row_from_its_line_start() {
    let out = luma(PixelFormat::Yuyv, 3, 3, 16, &YUYV_3X3_STRIDE16).unwrap();
    assert_eq!(out, vec![30, 31, 32, 40, 41, 42, 50, 51, 52]);
}

#[test]
fn short_buffers_are_refused_naming_the_sizes() {
    // one byte short of the last row's last macropixel
    let e = luma(PixelFormat::Yuyv, 3, 3, 16, &YUYV_3X3_STRIDE16[..39]).unwrap_err();
    assert!(matches!(e, Error::ShortFrame { got: 39, need: 40, .. }), "{e:?}");
    let text = e.to_string();
    for part in ["39 bytes", "needs 40", "3×3", "YUYV", "16 bytes per line"] {
        assert!(text.contains(part), "{part:?} missing from: {text}");
    }
    let e = luma(PixelFormat::Grey, 4, 3, 4, &GREY_4X3[..11]).unwrap_err().to_string();
    assert!(e.contains("11 bytes") && e.contains("needs 12"), "{e}");
    // a stride below what a row needs is refused before any buffer is read
    let e = luma(PixelFormat::Grey, 4, 3, 3, &GREY_4X3).unwrap_err().to_string();
    assert!(e.contains("bytes per line 3"), "{e}");
}
