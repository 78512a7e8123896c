//! The per-trial frame store: every camera frame of a trial in ONE file, `frames.tif`, a
//! multi-page TIFF (one 8-bit grey page per frame, Deflate-compressed with the horizontal
//! predictor, in strips of [`ROWS_PER_STRIP`] rows) instead of one PNG per frame. TIFF
//! because every tool a lab has opens it without code of ours: ImageJ/Fiji open a
//! multi-page TIFF as a stack, Python reads it with `tifffile` or Pillow, and the
//! `tiff` crate (image-rs, pure Rust) writes compressed multi-page files. Lossless, so the
//! tracker sees the same pixels as from PNG.
//!
//! Each page carries its frame's identity in the TIFF ImageDescription tag (see
//! [`PageMeta`]): the row `index` in `frames.csv` and `t_capture_us`, so a store read alone
//! (Python, ImageJ's "Show Info") still has its frame times. `frames.csv`'s `file` column
//! names a stored frame as `frames.tif#PAGE` ([`page_ref`]).
//!
//! Crash safety: pages are appended; the previous page's link to the next is written only
//! after the next page is complete, so a store cut short by a crash reads back up to its
//! last whole page. Classic TIFF (32-bit offsets) caps a store at 4 GiB, far above a trial
//! (a 30 Hz trial of 60 s at 640 × 480 is about 110 MB); a write past it is refused.
//!
//! Shared by the executor's recorder and the host (trial writer, `track`, `run`), so it is a
//! leaf crate beside the executor. May depend on: `tiff`, `thiserror` only.

pub mod error;
mod page;
mod read;
mod write;

pub use error::Error;
pub use page::{PageMeta, page_ref, parse_page_ref};
pub use read::{Frame, FrameStore};
pub use write::StoreWriter;

/// The store's file name inside a trial directory.
pub const STORE_FILE: &str = "frames.tif";

/// Rows per compressed strip (the store's chunk: a reader decodes a page strip by strip).
pub const ROWS_PER_STRIP: u32 = 64;
