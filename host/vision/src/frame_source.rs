//! Frames on disk, wherever a recording keeps them: a trial's frame store (`frames.tif`, one
//! multi-page TIFF; `mesopush_framestore`) or a folder of PNG frames (trials recorded before
//! the store, `mesopush render`'s output). [`FrameSet`] walks every frame of either in order
//! (for `track`); [`TrialFrames`] loads the frame a `frames.csv` `file` cell names, a
//! `frames.tif#PAGE` or a PNG path (for completing and re-tracking a trial).

use super::Error;
use super::folder::{frame_stem, list_frames, read_capture_times};
use image::GrayImage;
use mesopush_framestore::{FrameStore, STORE_FILE, page_ref, parse_page_ref};
use std::path::{Path, PathBuf};

/// Every frame of a recording, in order.
#[derive(Debug)]
pub enum FrameSet {
    /// PNG files sorted by name, with their capture times from `frames.csv`.
    Pngs {
        /// The files.
        paths: Vec<PathBuf>,
        /// Capture times, µs.
        times: Vec<Option<i64>>,
    },
    /// A frame store: its pages in order, times from the pages (boxed: a decoder is large).
    Store(Box<FrameStore>),
}

impl FrameSet {
    /// Opens `path`: a store file, a trial directory holding `frames.tif`, or a folder of PNG
    /// frames (leaving out `exclude`, e.g. the background frame in the same folder).
    pub fn open(path: &Path, exclude: Option<&Path>) -> Result<Self, Error> {
        let store = if path.is_file() { Some(path.to_path_buf()) } else { None };
        let store = store.or_else(|| Some(path.join(STORE_FILE)).filter(|p| p.is_file()));
        if let Some(file) = store {
            return Ok(Self::Store(Box::new(FrameStore::open(&file)?)));
        }
        let paths = list_frames(path, exclude)?;
        let times = read_capture_times(path, &paths)?;
        let times = times.into_iter().map(|t| t.and_then(|t| i64::try_from(t).ok())).collect();
        Ok(Self::Pngs { paths, times })
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        match self {
            Self::Pngs { paths, .. } => paths.len(),
            Self::Store(s) => s.len(),
        }
    }

    /// Whether there is no frame.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Frame `k`'s name for pose.csv's `frame` column: the PNG's stem, or `frames.tif#k`.
    pub fn label(&self, k: usize) -> String {
        match self {
            Self::Pngs { paths, .. } => frame_stem(&paths[k]),
            Self::Store(_) => page_ref(k as u64),
        }
    }

    /// Where frame `k` is, for messages: the PNG's path, or the store's path with `#k`.
    pub fn location(&self, k: usize) -> String {
        match self {
            Self::Pngs { paths, .. } => paths[k].display().to_string(),
            Self::Store(s) => format!("{}#{k}", s.path().display()),
        }
    }

    /// Frame `k`'s capture time, µs, when known.
    pub fn time_us(&self, k: usize) -> Option<i64> {
        match self {
            Self::Pngs { times, .. } => times[k],
            Self::Store(s) => s.pages()[k].t_capture_us,
        }
    }

    /// Why a store ends early (cut short by a crash), to tell the user.
    pub fn damage(&self) -> Option<&str> {
        match self {
            Self::Pngs { .. } => None,
            Self::Store(s) => s.damage(),
        }
    }

    /// Decodes frame `k`.
    pub fn image(&mut self, k: usize) -> Result<GrayImage, Error> {
        match self {
            Self::Pngs { paths, .. } => load_gray_png(&paths[k]),
            Self::Store(s) => read_page(s, k),
        }
    }
}

fn read_page(store: &mut FrameStore, page: usize) -> Result<GrayImage, Error> {
    let f = store.read(page)?;
    let path = store.path().to_path_buf();
    GrayImage::from_raw(f.width, f.height, f.pixels)
        .ok_or_else(|| Error::Parse { path, message: format!("page {page}: size mismatch") })
}

/// An image's pixel format in words ("16-bit grey", "8-bit RGB", ...), for messages.
pub fn describe_pixels(c: image::ColorType) -> &'static str {
    use image::ColorType as C;
    match c {
        C::L8 => "8-bit grey",
        C::La8 => "8-bit grey with alpha",
        C::Rgb8 => "8-bit RGB colour",
        C::Rgba8 => "8-bit RGBA colour",
        C::L16 => "16-bit grey",
        C::La16 => "16-bit grey with alpha",
        C::Rgb16 => "16-bit RGB colour",
        C::Rgba16 => "16-bit RGBA colour",
        C::Rgb32F | C::Rgba32F => "32-bit floating-point colour",
        _ => "another pixel format",
    }
}

/// An 8-bit grey PNG (anything else is refused, naming the file and what it holds).
pub fn load_gray_png(path: &Path) -> Result<GrayImage, Error> {
    let img = image::open(path)
        .map_err(|e| Error::Parse { path: path.to_path_buf(), message: e.to_string() })?;
    if !matches!(img, image::DynamicImage::ImageLuma8(_)) {
        let got = describe_pixels(img.color());
        let message = format!("expected an 8-bit grayscale image, got {got}");
        return Err(Error::Parse { path: path.to_path_buf(), message });
    }
    Ok(img.into_luma8())
}

/// The frames of one trial directory, by their `frames.csv` `file` cell.
#[derive(Debug)]
pub struct TrialFrames {
    dir: PathBuf,
    store: Option<FrameStore>,
}

impl TrialFrames {
    /// The frames of the trial in `dir` (the store is opened on the first stored frame).
    pub fn new(dir: &Path) -> Self {
        Self { dir: dir.to_path_buf(), store: None }
    }

    /// The frame `file` names: `frames.tif#PAGE` (the store) or a path relative to the trial.
    pub fn load(&mut self, file: &str) -> Result<GrayImage, Error> {
        self.load_row(file, None)
    }

    /// The frame `file` names, checking that a stored page holds frames.csv row `index`
    /// (each page records its row: a store and a frames.csv that disagree — e.g. a crash
    /// while retention rewrote them — are refused, never tracked as the wrong frame).
    pub fn load_row(&mut self, file: &str, index: Option<u64>) -> Result<GrayImage, Error> {
        let Some(page) = parse_page_ref(file) else {
            return load_gray_png(&self.dir.join(file));
        };
        if self.store.is_none() {
            self.store = Some(FrameStore::open(&self.dir.join(STORE_FILE))?);
        }
        let store = self.store.as_mut().expect("opened above");
        let page = usize::try_from(page).unwrap_or(usize::MAX);
        let holds = store.pages().get(page).map(|m| m.index);
        if let (Some(want), Some(got)) = (index, holds)
            && want != got
        {
            let path = store.path().to_path_buf();
            let message = format!(
                "frames.csv row {want} names {file}, but that page holds row {got}; the \
                 store and frames.csv disagree"
            );
            return Err(Error::Parse { path, message });
        }
        read_page(store, page)
    }
}
