//! Reading a store: the pages' [`PageMeta`] at open (directories only, no pixels), then any
//! page's pixels on demand. Anything that is not a store this crate could have written — not
//! a TIFF, a page that is not 8-bit grey, a description that is not a [`PageMeta`] — is an
//! error naming the file and the page, never a panic.

use super::{Error, PageMeta};
use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};
use tiff::ColorType;
use tiff::decoder::{Decoder, DecodingResult, Limits};
use tiff::tags::Tag;

/// Most pages a store may hold (a bounded walk: ten hours at 30 Hz).
const MAX_PAGES: usize = 1_080_000;
/// Largest page accepted, pixels (a 64-megapixel camera).
const MAX_PIXELS: u64 = 1 << 26;

/// One decoded frame.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Frame {
    /// Which frame.
    pub meta: PageMeta,
    /// Width, px.
    pub width: u32,
    /// Height, px.
    pub height: u32,
    /// Row-major 8-bit grey pixels.
    pub pixels: Vec<u8>,
}

/// An open store.
pub struct FrameStore {
    path: PathBuf,
    decoder: Decoder<BufReader<File>>,
    pages: Vec<PageMeta>,
    damage: Option<String>,
}

impl std::fmt::Debug for FrameStore {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FrameStore")
            .field("path", &self.path)
            .field("pages", &self.pages.len())
            .finish_non_exhaustive()
    }
}

impl FrameStore {
    /// Opens `path` and reads every page's description.
    pub fn open(path: &Path) -> Result<Self, Error> {
        let file = File::open(path).map_err(|e| Error::io(path, e))?;
        let mut limits = Limits::default();
        limits.decoding_buffer_size = MAX_PIXELS as usize;
        let decoder = Decoder::new(BufReader::new(file))
            .map_err(|e| Error::malformed(path, format!("not a readable TIFF: {e}")))?
            .with_limits(limits);
        let mut store = Self { path: path.to_path_buf(), decoder, pages: Vec::new(), damage: None };
        loop {
            let page = store.pages.len();
            let meta = store.current_meta(page)?;
            store.pages.push(meta);
            if !store.decoder.more_images() {
                break;
            }
            if store.pages.len() >= MAX_PAGES {
                return Err(store.bad(page, format!("more than {MAX_PAGES} pages")));
            }
            if let Err(e) = store.decoder.next_image() {
                // A crash after the link to a page was written but before the page reached
                // the disk: keep the whole pages before it, and say so.
                store.damage = Some(format!(
                    "page {} unreadable ({e}); the store ends after page {page}",
                    page + 1
                ));
                break;
            }
        }
        Ok(store)
    }

    fn bad(&self, page: usize, message: impl std::fmt::Display) -> Error {
        Error::malformed(&self.path, format!("page {page}: {message}"))
    }

    fn current_meta(&mut self, page: usize) -> Result<PageMeta, Error> {
        let text = self
            .decoder
            .get_tag_ascii_string(Tag::ImageDescription)
            .map_err(|e| self.bad(page, format!("no frame description (ImageDescription): {e}")))?;
        PageMeta::parse(&text).map_err(|m| self.bad(page, m))
    }

    /// The store file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Which frame each page holds, in page order.
    pub fn pages(&self) -> &[PageMeta] {
        &self.pages
    }

    /// Why the store ends early, when a page after its last readable one is linked but cannot
    /// be read (a store cut short by a crash); `None` for a whole store.
    pub fn damage(&self) -> Option<&str> {
        self.damage.as_deref()
    }

    /// Number of pages.
    pub fn len(&self) -> usize {
        self.pages.len()
    }

    /// Whether the store holds no page (never true for a file [`Self::open`] accepted).
    pub fn is_empty(&self) -> bool {
        self.pages.is_empty()
    }

    /// Decodes page `page`.
    pub fn read(&mut self, page: usize) -> Result<Frame, Error> {
        let Some(&meta) = self.pages.get(page) else {
            return Err(Error::invalid(
                "page",
                format!(
                    "{}: page {page} asked for; the store has {}",
                    self.path.display(),
                    self.pages.len()
                ),
            ));
        };
        self.decoder.seek_to_image(page).map_err(|e| self.bad(page, e.to_string()))?;
        let colour = self.decoder.colortype().map_err(|e| self.bad(page, e.to_string()))?;
        if colour != ColorType::Gray(8) {
            let got = match colour {
                ColorType::Gray(bits) => format!("{bits}-bit grey"),
                ColorType::RGB(bits) => format!("{bits}-bit RGB colour"),
                ColorType::RGBA(bits) => format!("{bits}-bit RGBA colour"),
                _ => "another pixel format".to_string(),
            };
            return Err(self.bad(page, format!("{got} pixels; the store holds 8-bit grey")));
        }
        let (width, height) =
            self.decoder.dimensions().map_err(|e| self.bad(page, e.to_string()))?;
        if u64::from(width) * u64::from(height) > MAX_PIXELS {
            return Err(
                self.bad(page, format!("{width} × {height} px is over {MAX_PIXELS} pixels"))
            );
        }
        let pixels = match self.decoder.read_image().map_err(|e| self.bad(page, e.to_string()))? {
            DecodingResult::U8(p) => p,
            _ => return Err(self.bad(page, "pixels are not bytes")),
        };
        if pixels.len() as u64 != u64::from(width) * u64::from(height) {
            return Err(self.bad(page, format!("{} bytes for {width} × {height} px", pixels.len())));
        }
        Ok(Frame { meta, width, height, pixels })
    }
}
