//! Overlays for checking the tracker by eye: the peg's outline at the measured pose (green when
//! trusted, red when flagged), its centre and major axis, and the probe tip (cyan cross).

use image::{GrayImage, Rgb, RgbImage};

use crate::assess::Measurement;
use crate::calib::Calibration;
use mesopush_core::geom::{ConvexPolygon, Vec2};

const GOOD: Rgb<u8> = Rgb([40, 220, 60]);
const FLAGGED: Rgb<u8> = Rgb([235, 40, 40]);
const TIP: Rgb<u8> = Rgb([0, 220, 235]);

/// `frame` in colour with the measurement drawn on it.
pub fn draw_overlay(
    frame: &GrayImage,
    m: &Measurement,
    peg: &ConvexPolygon,
    calib: &Calibration,
) -> RgbImage {
    let mut img = RgbImage::from_fn(frame.width(), frame.height(), |x, y| {
        let v = frame.get_pixel(x, y)[0];
        Rgb([v, v, v])
    });
    if let Some(pose) = m.pose {
        let colour = if m.is_flagged() { FLAGGED } else { GOOD };
        let px: Vec<Vec2> =
            peg.transformed(&pose).vertices().iter().map(|v| calib.um_to_px(v)).collect();
        for i in 0..px.len() {
            line(&mut img, px[i], px[(i + 1) % px.len()], colour);
        }
        let c = calib.um_to_px(&pose.position());
        cross(&mut img, c, 6.0, colour);
        let axis = Vec2::new(pose.theta_rad.cos(), pose.theta_rad.sin());
        let tip = calib.um_to_px(&(pose.position() + axis * 300.0));
        line(&mut img, c, tip, colour);
    }
    if let Some(t) = m.probe_tip_um {
        cross(&mut img, calib.um_to_px(&t), 5.0, TIP);
    }
    img
}

fn cross(img: &mut RgbImage, c: Vec2, r: f64, colour: Rgb<u8>) {
    line(img, c - Vec2::new(r, 0.0), c + Vec2::new(r, 0.0), colour);
    line(img, c - Vec2::new(0.0, r), c + Vec2::new(0.0, r), colour);
}

/// A one-pixel line between continuous pixel coordinates, clipped to the image.
fn line(img: &mut RgbImage, a: Vec2, b: Vec2, colour: Rgb<u8>) {
    let steps = (b - a).abs().max().ceil().clamp(1.0, 10_000.0) as usize;
    for k in 0..=steps {
        let p = a + (b - a) * (k as f64 / steps as f64);
        let (x, y) = (p.x.floor(), p.y.floor());
        if x >= 0.0 && y >= 0.0 && x < f64::from(img.width()) && y < f64::from(img.height()) {
            img.put_pixel(x as u32, y as u32, colour);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mesopush_core::geom::Pose;

    #[test]
    fn outline_is_drawn_where_the_pose_puts_it() {
        let frame = GrayImage::from_pixel(640, 480, image::Luma([128]));
        let m = Measurement {
            pose: Some(Pose::new(1685.0, 1260.0, 0.0)),
            probe_tip_um: None,
            tip_flag: None,
            confidence: 1.0,
            flags: vec![],
            threshold: 0.2,
            area_um2: 0.0,
        };
        let peg = ConvexPolygon::rectangle(1000.0, 500.0).unwrap();
        let calib = Calibration::default();
        let img = draw_overlay(&frame, &m, &peg, &calib);
        // left edge at x = 1185 µm → pixel 225; the pixel there is drawn, its neighbour not
        let y = (1260.0 / calib.sy_um_per_px) as u32;
        assert_eq!(*img.get_pixel(225, y), GOOD);
        assert_eq!(*img.get_pixel(215, y), Rgb([128, 128, 128]));
    }
}
