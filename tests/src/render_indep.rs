//! An independent microscope for testing the tracker's probe tip (issue 18, point 7): frames of
//! a rough-edged peg and a tapered needle that touches it, stops just short of it or is free,
//! made with no code, types or defaults of `mesopush-vision`'s renderer. Shared with the
//! project are only its documented imaging conventions (docs/vision.md): the inverted
//! microscope's bright plate lit from below, acrylic darker than the plate, a nearly opaque
//! needle; pixel `(i, j)` covers `[i, i+1) × [j, j+1)` and `x_um = u · sx`, `y_um = v · sy`
//! over the paper's 3370 × 2520 µm field at 640 × 480 px.
//!
//! What differs from the project's renderer, on purpose: the peg's edges are rough by a few
//! pixels (a sum of sinusoids, 3.5 µm RMS, up to about 2 px), not 1.5 µm; the needle's flanks
//! are tangent to its round tip (20 µm diameter, 2° half-angle); coverage comes from
//! supersampled scanlines; transmissions multiply; the lamp has a gradient and cos⁴
//! vignetting about an off-centre axis; noise is photon counting plus read noise.
//!
//! Layout: [`pt`] points, [`outline`] the rough peg, [`wedge`] the needle and its contact,
//! [`optics`] coverage, light, blur and sensor; this module places scenes and renders them.

pub mod optics;
pub mod outline;
pub mod pt;
pub mod wedge;

use crate::indep::rng::Rng;
use optics::{Plane, expose, gaussian_blur, illumination, needle_coverage, polygon_coverage};
use outline::RoughPeg;
use pt::Pt;
use wedge::{Wedge, touching_at};

/// Image size, px.
pub const SIZE_PX: (usize, usize) = (640, 480);
/// The field, µm.
pub const FIELD_UM: (f64, f64) = (3370.0, 2520.0);
/// The channel between the fixture's walls, µm: the walls cover `y < .0` and `y > .1`.
pub const CHANNEL_Y_UM: (f64, f64) = (290.0, 2235.0);

/// µm per pixel along x and y.
pub fn um_per_px() -> (f64, f64) {
    (FIELD_UM.0 / SIZE_PX.0 as f64, FIELD_UM.1 / SIZE_PX.1 as f64)
}

/// The microscope's optics and sensor.
#[derive(Debug, Clone, PartialEq)]
pub struct Optics {
    /// Plate brightness on the optical axis, DN.
    pub plate_dn: f64,
    /// Relative brightness change across the field, (x, y).
    pub gradient: (f64, f64),
    /// The optical axis, px (off the image centre).
    pub axis_px: Pt,
    /// cos⁴ vignetting focal length, px (the corners lose about 18 %).
    pub focal_px: f64,
    /// Gaussian blur σ, px.
    pub blur_px: f64,
    /// Electrons per DN (photon noise).
    pub electrons_per_dn: f64,
    /// Read noise, DN.
    pub read_dn: f64,
    /// Transmission of the walls, the peg and the needle.
    pub transmission: (f64, f64, f64),
}

impl Default for Optics {
    fn default() -> Self {
        Self {
            plate_dn: 190.0,
            gradient: (-0.05, 0.03),
            axis_px: Pt::new(342.0, 226.0),
            focal_px: 1250.0,
            blur_px: 1.1,
            electrons_per_dn: 14.0,
            read_dn: 2.0,
            transmission: (0.35, 0.55, 0.08),
        }
    }
}

/// Where the needle is relative to the peg.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Contact {
    /// No needle in view.
    Absent,
    /// Tip 40–600 µm back along its shaft from touching.
    Free,
    /// Tip 3–40 µm back along its shaft from touching.
    Near,
    /// Tip touching the rough outline.
    Touching,
}

/// What a frame shows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Truth {
    /// The peg's centre of mass (area centroid of the rough outline), µm.
    pub peg_um: Pt,
    /// The peg's orientation, rad.
    pub peg_theta_rad: f64,
    /// The needle, when in view.
    pub needle: Option<Wedge>,
    /// How the needle meets the peg.
    pub contact: Contact,
    /// Angle between the shaft and the touched edge's outward normal, rad (0 = head on).
    pub approach_rad: f64,
    /// How far back along the shaft from touching the tip is, µm.
    pub withdrawn_um: f64,
}

/// The independent microscope with one rough peg.
#[derive(Debug, Clone)]
pub struct Microscope {
    /// Optics and sensor.
    pub optics: Optics,
    /// The peg (its roughness is fixed: the same peg in every frame).
    pub peg: RoughPeg,
    /// Needle tip radius, µm.
    pub tip_radius_um: f64,
    /// Needle taper half-angle, rad.
    pub taper_rad: f64,
    light: Plane,
    walls: Plane,
}

impl Microscope {
    /// A 1500 × 900 µm peg with 3.5 µm RMS edge roughness drawn from `seed`.
    pub fn new(seed: u64) -> Self {
        let optics = Optics::default();
        let mut rng = Rng::new(crate::indep::rng::derive(seed, 0x0BE6));
        let peg = RoughPeg::new(1500.0, 900.0, 3.5, &mut rng);
        let (w, h) = SIZE_PX;
        let light =
            illumination(w, h, optics.plate_dn, optics.gradient, optics.axis_px, optics.focal_px);
        let (sx, sy) = um_per_px();
        let px = |x: f64, y: f64| Pt::new(x / sx, y / sy);
        let (y0, y1) = CHANNEL_Y_UM;
        // slightly tilted wall edges, reaching past the field
        let top = [px(-99.0, -99.0), px(3470.0, -99.0), px(3470.0, y0 + 9.0), px(-99.0, y0)];
        let bottom = [px(-99.0, y1), px(3470.0, y1 - 7.0), px(3470.0, 2620.0), px(-99.0, 2620.0)];
        let mut walls = Plane::filled(w, h, 1.0);
        walls.attenuate(&polygon_coverage(&top, w, h), optics.transmission.0);
        walls.attenuate(&polygon_coverage(&bottom, w, h), optics.transmission.0);
        Self { optics, peg, tip_radius_um: 10.0, taper_rad: 2f64.to_radians(), light, walls }
    }

    /// The empty fixture as a user would record it: the mean of `frames` exposures.
    pub fn background(&self, frames: u32, rng: &mut Rng) -> Vec<u8> {
        self.expose(&self.walls.clone(), frames, rng)
    }

    /// Renders the frame `truth` describes.
    pub fn render(&self, truth: &Truth, rng: &mut Rng) -> Vec<u8> {
        let (w, h) = SIZE_PX;
        let (sx, sy) = um_per_px();
        let mut t = self.walls.clone();
        let outline: Vec<Pt> = self
            .world_outline(truth.peg_um, truth.peg_theta_rad)
            .into_iter()
            .map(|p| Pt::new(p.x / sx, p.y / sy))
            .collect();
        t.attenuate(&polygon_coverage(&outline, w, h), self.optics.transmission.1);
        if let Some(needle) = &truth.needle {
            t.attenuate(&needle_coverage(needle, (sx, sy), w, h), self.optics.transmission.2);
        }
        self.expose(&t, 1, rng)
    }

    fn expose(&self, transmission: &Plane, frames: u32, rng: &mut Rng) -> Vec<u8> {
        let mut lit = transmission.clone();
        for (v, l) in lit.data.iter_mut().zip(&self.light.data) {
            *v *= l;
        }
        let o = &self.optics;
        expose(&gaussian_blur(&lit, o.blur_px), o.electrons_per_dn, o.read_dn, frames, rng)
    }

    /// The rough outline with its centre of mass at `com` turned by `theta`, µm.
    pub fn world_outline(&self, com: Pt, theta: f64) -> Vec<Pt> {
        let c = self.peg.centroid;
        self.peg.outline.iter().map(|&p| com + (p - c).rotated(theta)).collect()
    }

    /// A random frame: the peg anywhere in the channel at any angle; the needle absent
    /// (10 %), free (15 %), near (15 %) or touching (60 %) a random point of a random edge
    /// (not within 8 % of a corner), its shaft within 75° of the edge's normal.
    pub fn random_truth(&self, rng: &mut Rng) -> Truth {
        loop {
            if let Some(t) = self.try_truth(rng) {
                return t;
            }
        }
    }

    fn try_truth(&self, rng: &mut Rng) -> Option<Truth> {
        let theta = rng.range(-std::f64::consts::PI, std::f64::consts::PI);
        let (a, b) = (0.5 * self.peg.size_um.0, 0.5 * self.peg.size_um.1);
        let (c, s) = (theta.cos().abs(), theta.sin().abs());
        let m = 60.0 + self.peg.max_deviation_um;
        let (hx, hy) = (a * c + b * s + m, a * s + b * c + m);
        let (y0, y1) = (CHANNEL_Y_UM.0 + hy, CHANNEL_Y_UM.1 - hy);
        let com = Pt::new(rng.range(hx, FIELD_UM.0 - hx), rng.range(y0, y1.max(y0)));
        let u = rng.unit();
        let contact = match u {
            _ if u < 0.10 => Contact::Absent,
            _ if u < 0.25 => Contact::Free,
            _ if u < 0.40 => Contact::Near,
            _ => Contact::Touching,
        };
        let mut truth = Truth {
            peg_um: com,
            peg_theta_rad: theta,
            needle: None,
            contact,
            approach_rad: 0.0,
            withdrawn_um: 0.0,
        };
        if contact == Contact::Absent {
            return Some(truth);
        }
        // a point of the nominal outline, body frame about the centroid, and its normal
        let edge = rng.index(4);
        let f = rng.range(-0.42, 0.42);
        let (p_body, n_body) = match edge {
            0 => (Pt::new(2.0 * a * f, -b), Pt::new(0.0, -1.0)),
            1 => (Pt::new(a, 2.0 * b * f), Pt::new(1.0, 0.0)),
            2 => (Pt::new(2.0 * a * f, b), Pt::new(0.0, 1.0)),
            _ => (Pt::new(-a, 2.0 * b * f), Pt::new(-1.0, 0.0)),
        };
        let approach = rng.range(-75f64.to_radians(), 75f64.to_radians());
        let at = com + (p_body - self.peg.centroid).rotated(theta);
        let shaft = n_body.rotated(theta + approach);
        let probe = Wedge {
            tip: at,
            shaft,
            tip_radius_um: self.tip_radius_um,
            half_angle_rad: self.taper_rad,
        };
        let outline = self.world_outline(com, theta);
        let reach = self.tip_radius_um + 2.0 * self.peg.max_deviation_um + 5.0;
        let t0 = touching_at(&probe, &outline, -reach, reach / approach.cos());
        let back = match contact {
            Contact::Free => rng.range(40.0, 600.0),
            Contact::Near => rng.range(3.0, 40.0),
            _ => 0.0,
        };
        let needle = probe.withdrawn(t0 + back);
        let tip = needle.tip;
        let margin = 60.0;
        let in_plate = tip.x > margin
            && tip.x < FIELD_UM.0 - margin
            && tip.y > CHANNEL_Y_UM.0 + margin
            && tip.y < CHANNEL_Y_UM.1 - margin;
        if !in_plate {
            return None;
        }
        truth.needle = Some(needle);
        truth.approach_rad = approach;
        truth.withdrawn_um = back;
        Some(truth)
    }
}
