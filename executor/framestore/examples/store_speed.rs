//! Prints how fast a frame store is written and read on this machine: re-writes the pages of
//! a given store (`cargo run --release -p mesopush-framestore --example store_speed --
//! TRIAL/frames.tif [COPY.tif]`) into a temporary store (or COPY.tif) and reads them back, in ms per frame, with the
//! store's size per frame. The recorder must write a frame well within the camera period
//! (33 ms at 30 Hz).

use mesopush_framestore::{FrameStore, StoreWriter};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let Some(path) = std::env::args().nth(1) else {
        return Err("usage: store_speed FRAMES.tif".into());
    };
    let mut src = FrameStore::open(std::path::Path::new(&path))?;
    let n = src.len().min(300);
    let frames: Vec<_> = (0..n).map(|k| src.read(k)).collect::<Result<_, _>>()?;
    let dir = tempfile::tempdir()?;
    let out = std::env::args().nth(2).map_or(dir.path().join("copy.tif"), Into::into);
    let t = Instant::now();
    let mut w = StoreWriter::create(&out)?;
    for f in &frames {
        w.push(f.meta, f.width, f.height, &f.pixels)?;
    }
    w.finish()?;
    let write_ms = 1e3 * t.elapsed().as_secs_f64() / n as f64;
    let t = Instant::now();
    let mut back = FrameStore::open(&out)?;
    for k in 0..n {
        back.read(k)?;
    }
    let read_ms = 1e3 * t.elapsed().as_secs_f64() / n as f64;
    let (w_px, h_px) = (frames[0].width, frames[0].height);
    let bytes = std::fs::metadata(&out)?.len() as f64 / n as f64;
    let raw = f64::from(w_px) * f64::from(h_px);
    println!(
        "{n} frames of {w_px} × {h_px} px: write {write_ms:.2} ms/frame, read {read_ms:.2} \
         ms/frame, {:.0} kB/frame ({:.1} % of raw)",
        bytes / 1e3,
        100.0 * bytes / raw
    );
    Ok(())
}
