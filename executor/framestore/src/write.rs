//! Appending frames to a store: one Deflate page per frame, its [`PageMeta`] in the page's
//! ImageDescription. The recorder must keep up with the camera, so the strips are compressed
//! here with `fdeflate` (the fast zlib encoder the PNG frames used before; 2–3× faster than
//! the `tiff` crate's own level-1 Deflate at 3 % more bytes, measured on rendered frames)
//! after horizontal differencing (TIFF predictor 2), and the `tiff` crate writes the
//! directory (its low-level directory API).

use super::{Error, PageMeta, ROWS_PER_STRIP};
use std::fs::{File, OpenOptions};
use std::path::{Path, PathBuf};
use tiff::encoder::TiffEncoder;
use tiff::tags::{
    CompressionMethod, PhotometricInterpretation, PlanarConfiguration, Predictor, Tag,
};

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
        let encoder = TiffEncoder::new(file).map_err(|e| Error::malformed(path, e.to_string()))?;
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
        let strips = compressed_strips(pixels, width as usize);
        let err = |e: tiff::TiffError| {
            Error::malformed(&self.path, format!("writing page {}: {e}", self.pages))
        };
        let mut dir = self.encoder.image_directory().map_err(err)?;
        let mut offsets = Vec::with_capacity(strips.len());
        for strip in &strips {
            let offset = dir.write_data(&strip[..]).map_err(err)?;
            offsets.push(u32::try_from(offset).map_err(|_| over_4_gib(&self.path))?);
        }
        let counts: Vec<u32> = strips.iter().map(|s| s.len() as u32).collect();
        dir.write_tag(Tag::ImageWidth, width).map_err(err)?;
        dir.write_tag(Tag::ImageLength, height).map_err(err)?;
        dir.write_tag(Tag::BitsPerSample, 8u16).map_err(err)?;
        dir.write_tag(Tag::Compression, CompressionMethod::Deflate.to_u16()).map_err(err)?;
        let grey = PhotometricInterpretation::BlackIsZero.to_u16();
        dir.write_tag(Tag::PhotometricInterpretation, grey).map_err(err)?;
        dir.write_tag(Tag::ImageDescription, meta.describe().as_str()).map_err(err)?;
        dir.write_tag(Tag::StripOffsets, &offsets[..]).map_err(err)?;
        dir.write_tag(Tag::SamplesPerPixel, 1u16).map_err(err)?;
        dir.write_tag(Tag::RowsPerStrip, ROWS_PER_STRIP.min(height)).map_err(err)?;
        dir.write_tag(Tag::StripByteCounts, &counts[..]).map_err(err)?;
        let chunky = PlanarConfiguration::Chunky.to_u16();
        dir.write_tag(Tag::PlanarConfiguration, chunky).map_err(err)?;
        dir.write_tag(Tag::Predictor, Predictor::Horizontal.to_u16()).map_err(err)?;
        dir.write_tag(Tag::SampleFormat, 1u16).map_err(err)?;
        dir.finish().map_err(err)?;
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

/// The page's strips of [`ROWS_PER_STRIP`] rows, each horizontally differenced (TIFF
/// predictor 2: every byte minus its left neighbour, modulo 256) and zlib-compressed.
fn compressed_strips(pixels: &[u8], width: usize) -> Vec<Vec<u8>> {
    let mut diff = pixels.to_vec();
    for row in diff.chunks_mut(width) {
        for i in (1..row.len()).rev() {
            row[i] = row[i].wrapping_sub(row[i - 1]);
        }
    }
    diff.chunks(width * ROWS_PER_STRIP as usize).map(fdeflate::compress_to_vec).collect()
}

fn over_4_gib(path: &Path) -> Error {
    Error::invalid(
        "store size",
        format!(
            "{}: a store is a classic TIFF, at most 4 GiB; start another trial",
            path.display()
        ),
    )
}
