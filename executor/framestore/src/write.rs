//! Appending frames to a store: one Deflate page per frame, its [`PageMeta`] in the page's
//! ImageDescription. Fast Deflate level: the recorder must keep up with a 30 Hz camera.

use super::{Error, PageMeta, ROWS_PER_STRIP};
use std::fs::{File, OpenOptions};
use std::path::{Path, PathBuf};
use tiff::encoder::compression::DeflateLevel;
use tiff::encoder::{Compression, Predictor, TiffEncoder, colortype};
use tiff::tags::Tag;

/// Writes one store file, page by page.
pub struct StoreWriter {
    path: PathBuf,
    encoder: TiffEncoder<File>,
    /// The same file, to fsync at the end (the encoder owns the writing handle).
    sync: File,
    pages: u64,
    size_px: Option<(u32, u32)>,
}

impl std::fmt::Debug for StoreWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StoreWriter")
            .field("path", &self.path)
            .field("pages", &self.pages)
            .finish_non_exhaustive()
    }
}

impl StoreWriter {
    /// Creates the store at `path`; refuses a file that exists (a store is never
    /// overwritten: it is recorded data).
    pub fn create(path: &Path) -> Result<Self, Error> {
        let file = OpenOptions::new()
            .write(true)
            .read(true)
            .create_new(true)
            .open(path)
            .map_err(|e| Error::io(path, e))?;
        let sync = file.try_clone().map_err(|e| Error::io(path, e))?;
        let encoder = TiffEncoder::new(file)
            .map_err(|e| Error::malformed(path, e.to_string()))?
            .with_compression(Compression::Deflate(DeflateLevel::Fast))
            .with_predictor(Predictor::Horizontal);
        Ok(Self { path: path.to_path_buf(), encoder, sync, pages: 0, size_px: None })
    }

    /// The store file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Pages written so far.
    pub fn pages(&self) -> u64 {
        self.pages
    }

    /// Appends an 8-bit grey frame (`pixels` row-major, `width × height` bytes); returns its
    /// page number. Every page of a store has the first page's size.
    pub fn push(
        &mut self,
        meta: PageMeta,
        width: u32,
        height: u32,
        pixels: &[u8],
    ) -> Result<u64, Error> {
        let expected = u64::from(width) * u64::from(height);
        if width == 0 || height == 0 || pixels.len() as u64 != expected {
            return Err(Error::invalid(
                "frame",
                format!(
                    "frame {}: {} bytes for {width} × {height} px; one byte per pixel, size > 0",
                    meta.index,
                    pixels.len()
                ),
            ));
        }
        if let Some((w, h)) = self.size_px.filter(|&s| s != (width, height)) {
            return Err(Error::invalid(
                "frame",
                format!(
                    "frame {}: {width} × {height} px in a store of {w} × {h} px frames; one \
                     camera, one size",
                    meta.index
                ),
            ));
        }
        let err = |e: tiff::TiffError| {
            Error::malformed(&self.path, format!("writing page {}: {e}", self.pages))
        };
        let mut image = self.encoder.new_image::<colortype::Gray8>(width, height).map_err(err)?;
        image.rows_per_strip(ROWS_PER_STRIP.min(height)).map_err(err)?;
        image.encoder().write_tag(Tag::ImageDescription, meta.describe().as_str()).map_err(err)?;
        image.write_data(pixels).map_err(err)?;
        self.size_px = Some((width, height));
        self.pages += 1;
        Ok(self.pages - 1)
    }

    /// Syncs the file to disk; returns the pages written.
    pub fn finish(self) -> Result<u64, Error> {
        drop(self.encoder);
        self.sync.sync_all().map_err(|e| Error::io(&self.path, e))?;
        Ok(self.pages)
    }
}
