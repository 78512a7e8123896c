//! Shared by the vision tests: a seeded generator of rendered frames with random peg poses in
//! the demo fixture (some partly out of the field, some merged with a wall), the probe touching
//! the peg in some and lying over it in others, and the error statistics of a tracker on them.

#![allow(dead_code, unreachable_pub)]

use std::f64::consts::PI;

use mesopush_core::geom::{ConvexPolygon, Pose, Vec2};
use mesopush_vision::demo::{edge_facing_needle, probe_touching};
use mesopush_vision::scene::polygons_overlap;
use mesopush_vision::{
    DemoFixture, Measurement, NeedleSettings, RenderSettings, Rendered, Renderer, Scene, paper_peg,
};
use rand::{Rng, RngExt};

/// Where a generated frame puts the peg.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Placement {
    /// Free in the wide channel.
    Wide,
    /// In or entering the narrow channel.
    Narrow,
    /// Near the left edge, possibly partly out of the field.
    Edge,
    /// Overlapping the top wall (merged with it in the image).
    Wall,
}

/// Where the generated frame puts the probe.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProbeUse {
    /// No probe in view.
    Absent,
    /// Tip touching the peg's edge, shaft leaving the peg.
    Touching,
    /// Tip inside the peg's outline: the shaft hides part of it.
    Over,
}

/// A generated test frame.
#[derive(Debug)]
pub struct Case {
    pub frame: Rendered,
    pub placement: Placement,
    pub probe: ProbeUse,
}

/// Renders frames from a fixed fixture.
pub struct Generator {
    pub walls: Vec<ConvexPolygon>,
    pub peg: ConvexPolygon,
    pub renderer: Renderer,
    pub background: image::GrayImage,
}

impl Generator {
    pub fn new(rng: &mut impl Rng) -> Self {
        let walls = DemoFixture::default().walls().unwrap();
        let peg = paper_peg();
        let mut renderer = Renderer::new(RenderSettings::default(), &walls).unwrap();
        let empty = Scene { walls: &walls, peg: None, peg_pose: Pose::default(), probe_tip: None };
        let background = renderer.render_averaged(&empty, 16, rng).image;
        Self { walls, peg, renderer, background }
    }

    fn overlaps_walls(&self, pose: &Pose) -> bool {
        let p = self.peg.transformed(pose);
        self.walls.iter().any(|w| polygons_overlap(&p, w, 2.0))
    }

    fn pose_for(&self, placement: Placement, rng: &mut impl Rng) -> Pose {
        for _ in 0..1000 {
            let pose = match placement {
                Placement::Wide => Pose::new(
                    rng.random_range(700.0..1900.0),
                    rng.random_range(950.0..1550.0),
                    rng.random_range(-PI..PI),
                ),
                Placement::Narrow => Pose::new(
                    rng.random_range(2300.0..2900.0),
                    rng.random_range(1220.0..1300.0),
                    rng.random_range(-0.05..0.05),
                ),
                Placement::Edge => Pose::new(
                    rng.random_range(150.0..900.0),
                    rng.random_range(950.0..1550.0),
                    rng.random_range(-PI..PI),
                ),
                Placement::Wall => Pose::new(
                    rng.random_range(700.0..1900.0),
                    rng.random_range(500.0..650.0),
                    rng.random_range(-0.3..0.3),
                ),
            };
            if (placement == Placement::Wall) == self.overlaps_walls(&pose) {
                return pose;
            }
        }
        panic!("no pose found for {placement:?}");
    }

    /// One random frame.
    pub fn case(&mut self, rng: &mut impl Rng) -> Case {
        let placement = match rng.random_range(0..20) {
            0..=11 => Placement::Wide,
            12..=14 => Placement::Narrow,
            15..=17 => Placement::Edge,
            _ => Placement::Wall,
        };
        let probe = match rng.random_range(0..10) {
            0..=3 => ProbeUse::Absent,
            4..=8 => ProbeUse::Touching,
            _ => ProbeUse::Over,
        };
        let pose = self.pose_for(placement, rng);
        let mut needle = NeedleSettings {
            shaft_angle_rad: rng.random_range(-2.6..-0.5),
            ..NeedleSettings::default()
        };
        let tip = match probe {
            ProbeUse::Absent => None,
            ProbeUse::Touching => {
                let e = edge_facing_needle(&self.peg, &pose, &needle);
                Some(probe_touching(&self.peg, &pose, &needle, e, rng.random_range(0.1..0.9)))
            }
            ProbeUse::Over => {
                // shaft crossing the peg: tip well inside, shaft leaving over the peg's body
                needle.shaft_angle_rad += rng.random_range(-0.3..0.3);
                let inside =
                    Vec2::new(rng.random_range(-300.0..300.0), rng.random_range(-200.0..200.0));
                Some(pose.transform_point(&inside))
            }
        };
        self.renderer.set_needle(needle).unwrap();
        let scene =
            Scene { walls: &self.walls, peg: Some(&self.peg), peg_pose: pose, probe_tip: tip };
        Case { frame: self.renderer.render(&scene, rng), placement, probe }
    }
}

/// Position error (µm) and orientation error (rad, modulo π: the peg is symmetric).
pub fn errors(m: &Measurement, truth: &Pose) -> Option<(f64, f64)> {
    let p = m.pose?;
    let d = (p.position() - truth.position()).norm();
    let mut a = (p.theta_rad - truth.theta_rad) % PI;
    if a > PI / 2.0 {
        a -= PI;
    } else if a < -PI / 2.0 {
        a += PI;
    }
    Some((d, a.abs()))
}

/// Accuracy figures over a set of frames.
#[derive(Debug, Default)]
pub struct Stats {
    pub frames: usize,
    pub flagged: usize,
    pub unflagged: usize,
    pub sum_d2: f64,
    pub sum_a2: f64,
    pub max_d: f64,
    pub max_a: f64,
}

impl Stats {
    pub fn add(&mut self, m: &Measurement, truth: &Pose) {
        self.frames += 1;
        if m.is_flagged() {
            self.flagged += 1;
            return;
        }
        let (d, a) = errors(m, truth).expect("an unflagged measurement has a pose");
        self.unflagged += 1;
        self.sum_d2 += d * d;
        self.sum_a2 += a * a;
        self.max_d = self.max_d.max(d);
        self.max_a = self.max_a.max(a);
    }

    pub fn rms_um(&self) -> f64 {
        (self.sum_d2 / self.unflagged.max(1) as f64).sqrt()
    }

    pub fn rms_deg(&self) -> f64 {
        (self.sum_a2 / self.unflagged.max(1) as f64).sqrt().to_degrees()
    }

    pub fn share_flagged(&self) -> f64 {
        self.flagged as f64 / self.frames.max(1) as f64
    }
}
