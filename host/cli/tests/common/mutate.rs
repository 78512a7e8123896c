//! Mutations of valid inputs from a seeded rng, for the mutation test: numbers replaced by
//! NaN, ±inf, ±1e300, −1, 0, tiny or negative zero; lines dropped, duplicated or swapped;
//! text truncated; PNG bytes truncated or flipped, or the image re-encoded as valid PNGs of
//! other sizes, levels and sample formats.

use rand::{Rng, RngExt};

/// The numbers a mutation puts in place of one (TOML spellings; CSV and the LCP reader take
/// them too, JSON refuses the non-finite ones as a parse error).
const NUMBERS: [&str; 9] = ["nan", "inf", "-inf", "1e300", "-1e300", "-1", "0", "1e-300", "-0.0"];

/// Byte spans of the numbers in `text`: runs of digits, signs, points and exponents that
/// hold a digit.
pub(crate) fn number_spans(text: &str) -> Vec<(usize, usize)> {
    let b = text.as_bytes();
    let mut spans = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let starts = b[i].is_ascii_digit()
            || (matches!(b[i], b'-' | b'.') && b.get(i + 1).is_some_and(u8::is_ascii_digit));
        if !starts {
            i += 1;
            continue;
        }
        let j = (i + 1..b.len())
            .find(|&k| !(b[k].is_ascii_digit() || matches!(b[k], b'.' | b'e' | b'E' | b'-' | b'+')))
            .unwrap_or(b.len());
        spans.push((i, j));
        i = j;
    }
    spans
}

/// One to three text mutations of `text`, and what they were.
pub(crate) fn mutate_text(text: &str, rng: &mut impl Rng) -> (String, String) {
    let mut t = text.to_string();
    let mut what = Vec::new();
    for _ in 0..rng.random_range(1..=3) {
        let lines: Vec<&str> = t.lines().collect();
        let spans = number_spans(&t);
        match rng.random_range(0..6) {
            0 | 1 if !spans.is_empty() => {
                let (a, b) = spans[rng.random_range(0..spans.len())];
                let n = NUMBERS[rng.random_range(0..NUMBERS.len())];
                what.push(format!("number {:?} at byte {a} -> {n}", &t[a..b]));
                t.replace_range(a..b, n);
            }
            2 if lines.len() > 1 => {
                let k = rng.random_range(0..lines.len());
                what.push(format!("line {} dropped", k + 1));
                t = lines
                    .iter()
                    .enumerate()
                    .filter(|(i, _)| *i != k)
                    .map(|(_, l)| *l)
                    .collect::<Vec<_>>()
                    .join("\n");
            }
            3 if !lines.is_empty() => {
                let k = rng.random_range(0..lines.len());
                what.push(format!("line {} duplicated", k + 1));
                let mut v = lines.clone();
                v.insert(k, lines[k]);
                t = v.join("\n");
            }
            4 if lines.len() > 1 => {
                let (i, j) = (rng.random_range(0..lines.len()), rng.random_range(0..lines.len()));
                what.push(format!("lines {} and {} swapped", i + 1, j + 1));
                let mut v = lines.clone();
                v.swap(i, j);
                t = v.join("\n");
            }
            _ => {
                let mut cut = rng.random_range(0..=t.len());
                while !t.is_char_boundary(cut) {
                    cut -= 1;
                }
                what.push(format!("truncated at byte {cut}"));
                t.truncate(cut);
            }
        }
    }
    (t, what.join(", "))
}

/// A PNG of `img` (encoding a valid image cannot fail).
fn png(img: image::DynamicImage) -> Vec<u8> {
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).expect("encode png");
    out.into_inner()
}

/// A PNG truncated, bit-flipped or its header's size overwritten (all caught by the
/// decoder), or re-encoded as a valid PNG the tracker must cope with: another size (down to
/// 1 × 1 px), one flat grey level, random noise, colour or 16-bit samples.
pub(crate) fn mutate_bytes(bytes: &[u8], rng: &mut impl Rng) -> (Vec<u8>, String) {
    use image::{DynamicImage, GrayImage, Luma};
    let mut b = bytes.to_vec();
    let orig = image::load_from_memory(bytes).expect("the corpus PNG decodes");
    let (w, h) = (orig.width(), orig.height());
    match rng.random_range(0..7) {
        0 => {
            let cut = rng.random_range(0..b.len());
            b.truncate(cut);
            (b, format!("truncated at byte {cut}"))
        }
        1 => {
            let n = rng.random_range(1..=8);
            for _ in 0..n {
                let k = rng.random_range(0..b.len());
                b[k] ^= 1 << rng.random_range(0..8);
            }
            (b, format!("{n} bits flipped"))
        }
        2 => {
            let (w, h) = (rng.random_range(0..u32::MAX), rng.random_range(0..u32::MAX));
            b[16..20].copy_from_slice(&w.to_be_bytes());
            b[20..24].copy_from_slice(&h.to_be_bytes());
            (b, format!("header size set to {w} x {h}"))
        }
        3 => {
            let (w, h) = (rng.random_range(1..=200), rng.random_range(1..=200));
            let seed: u8 = rng.random();
            let img = GrayImage::from_fn(w, h, |x, y| Luma([(x * 7 + y * 13) as u8 ^ seed]));
            (png(DynamicImage::ImageLuma8(img)), format!("re-encoded as {w} x {h} px of noise"))
        }
        4 => {
            let v: u8 = [0, 255, rng.random()][rng.random_range(0..3)];
            let img = GrayImage::from_pixel(w, h, Luma([v]));
            (png(DynamicImage::ImageLuma8(img)), format!("re-encoded flat at grey {v}"))
        }
        5 => (png(DynamicImage::ImageRgb8(orig.to_rgb8())), "re-encoded as RGB".into()),
        _ => (png(DynamicImage::ImageLuma16(orig.to_luma16())), "re-encoded as 16-bit".into()),
    }
}
