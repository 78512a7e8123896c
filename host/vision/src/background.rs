//! The reference frame of the empty fixture: what background subtraction subtracts, the plate's
//! illumination (a smooth quadratic fitted to the bright plate, so contrast can be normalised
//! across an unevenly lit field) and where the fixture walls are.

use image::GrayImage;
use nalgebra::{SMatrix, SVector};

use crate::Error;

/// A pixel is wall when the background there is darker than this share of the plate's light.
const WALL_LEVEL: f32 = 0.75;

/// The background model built once from a reference frame.
#[derive(Debug, Clone)]
pub struct Background {
    width: usize,
    height: usize,
    bg: Vec<f32>,
    inv_light: Vec<f32>,
    /// Wall pixels at least one pixel from the wall's edge.
    wall_core: Vec<bool>,
    /// Pixels with a wall-core pixel 2 px away along their row or column (or on one).
    near_wall: Vec<bool>,
}

impl Background {
    /// Builds the model; fails when the frame shows no bright plate to fit the light to.
    pub fn new(image: &GrayImage) -> Result<Self, Error> {
        let (w, h) = (image.width() as usize, image.height() as usize);
        if w < 16 || h < 16 {
            return Err(Error::invalid(
                "background",
                format!("image {w}×{h} is too small (16×16 minimum)"),
            ));
        }
        let bg: Vec<f32> = image.as_raw().iter().map(|&v| f32::from(v)).collect();
        let coeffs = fit_light(&bg, w, h)?;
        let mut inv_light = Vec::with_capacity(w * h);
        for j in 0..h {
            for i in 0..w {
                let l = eval(&coeffs, i, j, w, h).max(1.0);
                inv_light.push((1.0 / l) as f32);
            }
        }
        let wall: Vec<bool> =
            bg.iter().zip(&inv_light).map(|(b, il)| b * il < WALL_LEVEL).collect();
        let mut wall_core = wall.clone();
        for j in 0..h {
            for i in 0..w {
                let k = j * w + i;
                if wall[k] {
                    let nb = [
                        (i > 0, k.wrapping_sub(1)),
                        (i + 1 < w, k + 1),
                        (j > 0, k.wrapping_sub(w)),
                        (j + 1 < h, k + w),
                    ];
                    wall_core[k] = nb.iter().all(|&(ok, n)| !ok || wall[n]);
                }
            }
        }
        let near_wall = (0..w * h)
            .map(|k| {
                let (x, y) = (k % w, k / w);
                wall_core[k]
                    || (x >= 2 && wall_core[k - 2])
                    || (x + 2 < w && wall_core[k + 2])
                    || (y >= 2 && wall_core[k - 2 * w])
                    || (y + 2 < h && wall_core[k + 2 * w])
            })
            .collect();
        Ok(Self { width: w, height: h, bg, inv_light, wall_core, near_wall })
    }

    /// Image width, px.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Image height, px.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Whether pixel index `k` lies well inside a fixture wall.
    pub fn is_wall_core(&self, k: usize) -> bool {
        self.wall_core[k]
    }

    /// Whether a wall-core pixel lies within 2 pixels of pixel index `k` along its row or
    /// column (precomputed).
    pub fn is_near_wall(&self, k: usize) -> bool {
        self.near_wall[k]
    }

    /// Darkening of `frame` against the background as a share of the local plate light:
    /// `(bg − frame) / light`; 0 on unchanged pixels, `1 − transmission` on an object over the
    /// plate. Fails if the frame's size differs from the background's.
    pub fn darkening(&self, frame: &GrayImage, out: &mut Vec<f32>) -> Result<(), Error> {
        if frame.width() as usize != self.width || frame.height() as usize != self.height {
            return Err(Error::invalid(
                "frame",
                format!(
                    "size {}×{} differs from the background's {}×{}",
                    frame.width(),
                    frame.height(),
                    self.width,
                    self.height
                ),
            ));
        }
        out.clear();
        out.extend(
            frame
                .as_raw()
                .iter()
                .zip(&self.bg)
                .zip(&self.inv_light)
                .map(|((&f, b), il)| (b - f32::from(f)) * il),
        );
        Ok(())
    }
}

type Coeffs = SVector<f64, 6>;

fn basis(i: usize, j: usize, w: usize, h: usize) -> Coeffs {
    let x = (i as f64 + 0.5) / w as f64 - 0.5;
    let y = (j as f64 + 0.5) / h as f64 - 0.5;
    Coeffs::new(1.0, x, y, x * x, x * y, y * y)
}

fn eval(c: &Coeffs, i: usize, j: usize, w: usize, h: usize) -> f64 {
    c.dot(&basis(i, j, w, h))
}

/// Least-squares quadratic through the plate pixels (sampled every 4 px), refitting three times
/// on the pixels brighter than 85 % of the previous fit so walls drop out.
fn fit_light(bg: &[f32], w: usize, h: usize) -> Result<Coeffs, Error> {
    let max = bg.iter().copied().fold(0.0f32, f32::max);
    if max < 20.0 {
        return Err(Error::invalid(
            "background",
            "the frame is dark: no lit plate to calibrate the light on",
        ));
    }
    let mut coeffs = solve(w, h, bg, |i, j| bg[j * w + i] > 0.6 * max)?;
    for _ in 0..3 {
        let prev = coeffs;
        coeffs = solve(w, h, bg, |i, j| f64::from(bg[j * w + i]) > 0.85 * eval(&prev, i, j, w, h))?;
    }
    Ok(coeffs)
}

fn solve(
    w: usize,
    h: usize,
    bg: &[f32],
    keep: impl Fn(usize, usize) -> bool,
) -> Result<Coeffs, Error> {
    let mut ata = SMatrix::<f64, 6, 6>::zeros();
    let mut atb = Coeffs::zeros();
    let (mut used, mut total) = (0usize, 0usize);
    for j in (0..h).step_by(4) {
        for i in (0..w).step_by(4) {
            total += 1;
            if keep(i, j) {
                let b = basis(i, j, w, h);
                ata += b * b.transpose();
                atb += b * f64::from(bg[j * w + i]);
                used += 1;
            }
        }
    }
    if used * 20 < total {
        return Err(Error::invalid("background", "less than 5 % of the frame is bright plate"));
    }
    ata.lu()
        .solve(&atb)
        .ok_or_else(|| Error::invalid("background", "the plate's light cannot be fitted"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flat_plate_gives_zero_darkening_and_a_dark_object_its_contrast() {
        let bg = GrayImage::from_pixel(64, 48, image::Luma([200]));
        let model = Background::new(&bg).unwrap();
        let mut frame = bg.clone();
        frame.put_pixel(10, 10, image::Luma([100]));
        let mut d = Vec::new();
        model.darkening(&frame, &mut d).unwrap();
        assert!(d[0].abs() < 1e-3);
        assert!((d[10 * 64 + 10] - 0.5).abs() < 1e-3);
    }

    #[test]
    fn dark_or_mismatched_frames_are_refused() {
        assert!(Background::new(&GrayImage::new(64, 48)).is_err());
        let model = Background::new(&GrayImage::from_pixel(64, 48, image::Luma([200]))).unwrap();
        let e = model.darkening(&GrayImage::new(32, 48), &mut Vec::new()).unwrap_err();
        assert!(e.to_string().contains("differs"), "{e}");
    }
}
