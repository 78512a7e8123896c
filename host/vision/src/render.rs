//! The synthetic microscope: renders the fixture, the peg and the probe needle as the paper's
//! inverted microscope shows them (bright plate lit from below, darker acrylic walls and peg,
//! a dark needle), with uneven illumination, optical blur, sensor noise and 8-bit quantisation,
//! and returns the ground truth with every frame. Deterministic: the same settings, scene and
//! RNG state give identical bytes. The static part (walls, illumination) is cached.

use image::GrayImage;
use rand::Rng;

use crate::Error;
use crate::calib::Calibration;
use crate::needle::{NeedleSettings, fill_needle};
use crate::optics::{blur, changed_region, expose, gaussian_kernel, illumination, reblur_region};
use crate::raster::{Plane, Roughness, fill_polygon};
use crate::scene::Scene;
use mesopush_core::geom::{ConvexPolygon, Pose, Vec2};

/// How the microscope and camera behave. Plain data; see `Default` for the documented values.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderSettings {
    /// Image width, px (default 640).
    pub width_px: u32,
    /// Image height, px (default 480).
    pub height_px: u32,
    /// Pixels ↔ fixture frame (default: 3370 × 2520 µm over 640 × 480, origin top-left).
    pub calibration: Calibration,
    /// Brightness of the bare plate at the image centre, DN (default 200).
    pub plate_level_dn: f64,
    /// Relative brightness change from the image centre to the right and bottom edges
    /// (default (0.06, −0.04)).
    pub illumination_gradient: (f64, f64),
    /// Relative darkening in the image corners (default 0.10).
    pub vignetting: f64,
    /// Share of the light the fixture walls let through (default 0.30: thick acrylic).
    pub wall_transmission: f64,
    /// Share of the light the peg lets through (default 0.50: half as thick as the walls).
    pub peg_transmission: f64,
    /// Share of the light the needle lets through (default 0.06: tungsten, nearly opaque).
    pub needle_transmission: f64,
    /// Optical blur, Gaussian σ in px (default 0.9).
    pub blur_sigma_px: f64,
    /// Read noise σ, DN (default 1.5).
    pub read_noise_dn: f64,
    /// Shot noise: variance added per DN of signal (default 0.05, i.e. σ ≈ 3.2 DN on the plate).
    pub shot_noise_gain: f64,
    /// RMS of the laser-cut edge roughness of the peg, µm (default 1.5).
    pub edge_roughness_rms_um: f64,
    /// Seed of the peg's roughness profile: the same peg looks the same in every frame.
    pub edge_roughness_seed: u64,
    /// The probe needle's shape and entry direction.
    pub needle: NeedleSettings,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            width_px: 640,
            height_px: 480,
            calibration: Calibration::default(),
            plate_level_dn: 200.0,
            illumination_gradient: (0.06, -0.04),
            vignetting: 0.10,
            wall_transmission: 0.30,
            peg_transmission: 0.50,
            needle_transmission: 0.06,
            blur_sigma_px: 0.9,
            read_noise_dn: 1.5,
            shot_noise_gain: 0.05,
            edge_roughness_rms_um: 1.5,
            edge_roughness_seed: 1,
            needle: NeedleSettings::default(),
        }
    }
}

impl RenderSettings {
    /// Checks every field; the error names the one that is wrong.
    pub fn validate(&self) -> Result<(), Error> {
        if self.width_px == 0
            || self.height_px == 0
            || self.width_px > 8192
            || self.height_px > 8192
        {
            return Err(Error::invalid("render size", "width and height must be in 1..=8192 px"));
        }
        let unit = [
            ("wall_transmission", self.wall_transmission),
            ("peg_transmission", self.peg_transmission),
            ("needle_transmission", self.needle_transmission),
        ];
        for (name, t) in unit {
            if !(0.0..=1.0).contains(&t) {
                return Err(Error::invalid("render settings", format!("{name} must be in [0, 1]")));
            }
        }
        let non_negative = [
            ("plate_level_dn", self.plate_level_dn),
            ("blur_sigma_px", self.blur_sigma_px),
            ("read_noise_dn", self.read_noise_dn),
            ("shot_noise_gain", self.shot_noise_gain),
            ("edge_roughness_rms_um", self.edge_roughness_rms_um),
            ("vignetting", self.vignetting),
        ];
        for (name, v) in non_negative {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::invalid("render settings", format!("{name} must be ≥ 0")));
            }
        }
        if self.blur_sigma_px > 10.0 {
            return Err(Error::invalid("render settings", "blur_sigma_px must be ≤ 10"));
        }
        self.needle.validate()
    }
}

/// What was really in the frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GroundTruth {
    /// The peg's pose (centre of mass), or `None` when the scene had no peg.
    pub peg_pose: Option<Pose>,
    /// Centre of the probe's rounded tip, fixture frame, µm.
    pub probe_tip_um: Option<Vec2>,
    /// Whether the whole peg lies inside the image.
    pub peg_in_field: bool,
}

/// One rendered frame and its truth.
#[derive(Debug, Clone)]
pub struct Rendered {
    /// 8-bit grayscale image.
    pub image: GrayImage,
    /// What the frame shows.
    pub truth: GroundTruth,
}

/// A renderer with the static part of the picture cached. Reuse it across frames.
#[derive(Debug, Clone)]
pub struct Renderer {
    settings: RenderSettings,
    walls: Vec<ConvexPolygon>,
    /// Transmission of the walls alone.
    base: Plane,
    /// Plate brightness per pixel, DN (illumination × plate level).
    light: Plane,
    /// The walls alone, lit (`base × light`), and that blurred: frames re-blur only where
    /// the peg and the needle change the picture.
    lit_static: Plane,
    blurred_static: Plane,
    kernel: Vec<f32>,
    rough: Option<(ConvexPolygon, Roughness)>,
}

impl Renderer {
    /// Prepares a renderer for `settings` (validated) and the fixture `walls`.
    pub fn new(settings: RenderSettings, walls: &[ConvexPolygon]) -> Result<Self, Error> {
        settings.validate()?;
        let (w, h) = (settings.width_px as usize, settings.height_px as usize);
        let mut light = Plane::filled(w, h, 0.0);
        for j in 0..h {
            for i in 0..w {
                let l = illumination(
                    i as f64 + 0.5,
                    j as f64 + 0.5,
                    w as f64,
                    h as f64,
                    settings.illumination_gradient,
                    settings.vignetting,
                );
                light.data[j * w + i] = (settings.plate_level_dn * l.max(0.0)) as f32;
            }
        }
        let kernel = gaussian_kernel(settings.blur_sigma_px);
        let mut r = Self {
            settings,
            walls: Vec::new(),
            base: Plane::filled(w, h, 1.0),
            lit_static: light.clone(),
            blurred_static: light.clone(),
            light,
            kernel,
            rough: None,
        };
        r.set_walls(walls);
        Ok(r)
    }

    /// The settings in use.
    pub fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    /// Changes the needle (e.g. its entry direction) without rebuilding the cached layers.
    pub fn set_needle(&mut self, needle: NeedleSettings) -> Result<(), Error> {
        needle.validate()?;
        self.settings.needle = needle;
        Ok(())
    }

    fn set_walls(&mut self, walls: &[ConvexPolygon]) {
        let (w, h) = (self.base.width, self.base.height);
        self.base = Plane::filled(w, h, 1.0);
        let t = self.settings.wall_transmission as f32;
        for wall in walls {
            fill_polygon(
                &mut self.base,
                &self.settings.calibration,
                wall,
                &Pose::default(),
                None,
                t,
            );
        }
        self.walls = walls.to_vec();
        let mut lit = self.base.clone();
        for (v, l) in lit.data.iter_mut().zip(&self.light.data) {
            *v *= l;
        }
        self.blurred_static = blur(&lit, &self.kernel);
        self.lit_static = lit;
    }

    /// Renders `scene` with sensor noise drawn from `rng`.
    pub fn render(&mut self, scene: &Scene<'_>, rng: &mut impl Rng) -> Rendered {
        self.render_averaged(scene, 1, rng)
    }

    /// Renders `scene` as the mean of `frames` exposures (noise σ shrinks by √frames), as a
    /// user would record a reference background. `frames` of 0 is taken as 1.
    pub fn render_averaged(
        &mut self,
        scene: &Scene<'_>,
        frames: u32,
        rng: &mut impl Rng,
    ) -> Rendered {
        if scene.walls != self.walls.as_slice() {
            self.set_walls(scene.walls);
        }
        let s = &self.settings;
        let mut t = self.base.clone();
        let mut peg_in_field = false;
        if let Some(peg) = scene.peg {
            let stale = self.rough.as_ref().is_none_or(|(p, _)| p != peg);
            if stale {
                let r = Roughness::new(peg, s.edge_roughness_rms_um, s.edge_roughness_seed);
                self.rough = Some((peg.clone(), r));
            }
            let rough = self.rough.as_ref().map(|(_, r)| r);
            let calib = &s.calibration;
            fill_polygon(&mut t, calib, peg, &scene.peg_pose, rough, s.peg_transmission as f32);
            let (lo, hi) = peg.transformed(&scene.peg_pose).bounds();
            let (lo, hi) = (calib.um_to_px(&lo), calib.um_to_px(&hi));
            peg_in_field =
                lo.x >= 0.0 && lo.y >= 0.0 && hi.x <= t.width as f64 && hi.y <= t.height as f64;
        }
        if let Some(tip) = &scene.probe_tip {
            fill_needle(&mut t, &s.calibration, &s.needle, tip, s.needle_transmission as f32);
        }
        let mut radiance = self.blurred_static.clone();
        if let Some(region) = changed_region(&t, &self.base) {
            let mut lit = self.lit_static.clone();
            let (x0, x1, y0, y1) = region;
            for j in y0..y1 {
                let row = j * t.width;
                for i in row + x0..row + x1 {
                    lit.data[i] = t.data[i] * self.light.data[i];
                }
            }
            reblur_region(&lit, &self.kernel, region, &mut radiance);
        }
        let n = f64::from(frames.max(1));
        let pixels = expose(&radiance, s.read_noise_dn / n.sqrt(), s.shot_noise_gain / n, rng);
        let image = GrayImage::from_raw(s.width_px, s.height_px, pixels)
            .expect("the buffer has width × height pixels");
        let truth = GroundTruth {
            peg_pose: scene.peg.map(|_| scene.peg_pose),
            probe_tip_um: scene.probe_tip,
            peg_in_field,
        };
        Rendered { image, truth }
    }
}

/// Renders one frame of `scene` (convenience over [`Renderer`]).
pub fn render(
    scene: &Scene<'_>,
    settings: &RenderSettings,
    rng: &mut impl Rng,
) -> Result<Rendered, Error> {
    Ok(Renderer::new(settings.clone(), scene.walls)?.render(scene, rng))
}
