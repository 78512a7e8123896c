//! A camera frame as PNG bytes: the simulator process's `background.png` (the trial's frames
//! go to its frame store, `mesopush_framestore`). Fast compression.

use crate::Error;
use image::GrayImage;

/// PNG bytes of a grayscale frame.
pub fn encode_png(img: &GrayImage) -> Result<Vec<u8>, Error> {
    use image::ImageEncoder;
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    let mut bytes = Vec::with_capacity(img.as_raw().len() / 2);
    PngEncoder::new_with_quality(&mut bytes, CompressionType::Fast, FilterType::Sub)
        .write_image(img.as_raw(), img.width(), img.height(), image::ExtendedColorType::L8)
        .map_err(|e| Error::invalid("frame PNG", e.to_string()))?;
    Ok(bytes)
}
