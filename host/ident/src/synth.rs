//! Synthetic identification trials: unconstrained pushes of any convex part, simulated with a
//! known true model and written as ordinary trial logs (probe.csv at the setpoint rate,
//! pose.csv at the camera rate with Gaussian tracking noise). Tests and the demo dataset
//! ([`write_demo`], `mesopush identify synth DIR`) use them; identification reads them like
//! any other trial, and the truth sits in `trial.json`'s `world` field, which identification
//! never reads. Times go to the log through `mesopush_protocol::units` (rounded to the µs).

use super::data::open_plate;
use super::optim::es::normal;
use super::score::pose_at;
use crate::Error;
use mesopush_core::geom::{ConvexPolygon, Pose, Vec2};
use mesopush_protocol::units;
use mesopush_sim::{Model, ProbePoint, SimSettings, Simulator, follow_path};
use mesopush_trial::{Outcome, PoseRow, ProbeRow, TrialMeta, TrialState, TrialWriter};
use rand::Rng;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// One pushing trial, described relative to the part so any part and scale works.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PushSpec {
    /// Direction of the first leg in the part's body frame, rad (0 = body +x).
    pub dir_body_rad: f64,
    /// Offset of the push line from the COM, as a fraction of the part's half-extent across
    /// the push (signed; |offset| < 0.9).
    pub offset_frac: f64,
    /// Legs after touching: (probe travel µm, turn from the previous leg's direction rad).
    pub legs: Vec<(f64, f64)>,
    /// Peg start pose offset from the set's nominal start: (dx µm, dy µm, dθ rad).
    pub start_offset: (f64, f64, f64),
}

/// A set of synthetic trials and how they are recorded.
#[derive(Debug, Clone, PartialEq)]
pub struct SynthSpec {
    /// The true model (part, support, friction, probe radius).
    pub model: Model,
    /// Nominal peg start pose.
    pub start: Pose,
    /// One trial per push.
    pub pushes: Vec<PushSpec>,
    /// Probe speed, µm/s.
    pub speed_um_s: f64,
    /// Setpoint period of probe.csv, µs.
    pub setpoint_period_us: i64,
    /// Camera frame period of pose.csv, µs.
    pub frame_period_us: i64,
    /// Gap between probe and part before the first leg, µm.
    pub clearance_um: f64,
    /// Tracking noise on x and y (each), µm (1σ).
    pub noise_xy_um: f64,
    /// Tracking noise on θ, rad (1σ).
    pub noise_theta_rad: f64,
}

/// Six pushes like the paper's six unconstrained trials: off-centre side pushes (straight and
/// oblique, so the probe slides), axial pushes, and pushes that turn while in contact.
/// `travel_um` scales every leg.
pub fn paper_like_pushes(travel_um: f64) -> Vec<PushSpec> {
    let d = |deg: f64| deg.to_radians();
    let p = |dir: f64, off: f64, legs: Vec<(f64, f64)>, so: (f64, f64, f64)| PushSpec {
        dir_body_rad: d(dir),
        offset_frac: off,
        legs: legs.into_iter().map(|(l, t)| (l * travel_um, d(t))).collect(),
        start_offset: so,
    };
    vec![
        p(90.0, 0.45, vec![(1.0, 0.0)], (0.0, 0.0, 0.0)),
        p(125.0, -0.3, vec![(1.0, 0.0)], (40.0, -30.0, d(5.0))),
        p(0.0, 0.35, vec![(1.0, 0.0)], (-60.0, 20.0, d(-4.0))),
        p(90.0, 0.2, vec![(0.5, 0.0), (0.5, 40.0)], (20.0, 50.0, d(8.0))),
        p(-40.0, 0.0, vec![(1.0, 0.0)], (-30.0, -40.0, d(-8.0))),
        p(140.0, 0.1, vec![(0.6, 0.0), (0.4, -35.0)], (10.0, 10.0, d(12.0))),
    ]
}

impl SynthSpec {
    /// The paper's peg pushed at 200 µm/s, 10 ms setpoints, 30 Hz camera, σ = 0.5 µm and
    /// 0.04°, with `model` as the truth.
    pub fn paper_like(model: Model, travel_um: f64) -> Self {
        Self {
            model,
            start: Pose::new(1700.0, 1260.0, 0.0),
            pushes: paper_like_pushes(travel_um),
            speed_um_s: 200.0,
            setpoint_period_us: 10_000,
            frame_period_us: 33_333,
            clearance_um: 40.0,
            noise_xy_um: 0.5,
            noise_theta_rad: 0.04f64.to_radians(),
        }
    }
}

/// Where the probe starts for `push` with the peg at `pose`: `clearance_um` before the point
/// where the push line enters the part, and the first leg's world direction.
fn approach(
    part: &ConvexPolygon,
    pose: &Pose,
    push: &PushSpec,
    gap_um: f64,
) -> Result<(Vec2, Vec2), Error> {
    let dir_b = Vec2::new(push.dir_body_rad.cos(), push.dir_body_rad.sin());
    let perp_b = Vec2::new(-dir_b.y, dir_b.x);
    let half = part.vertices().iter().map(|v| v.dot(&perp_b).abs()).fold(0.0, f64::max);
    if push.offset_frac.abs() >= 0.9 {
        return Err(Error::invalid("push", "offset_frac must be within (-0.9, 0.9)"));
    }
    let through = perp_b * (push.offset_frac * half);
    let reach = 2.0 * part.vertices().iter().map(|v| v.norm()).fold(0.0, f64::max);
    // Bisect for the entry point between `through - dir·reach` (outside) and `through`.
    let (mut lo, mut hi) = (0.0, reach);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if part.signed_distance(&(through - dir_b * mid)) <= 0.0 { lo = mid } else { hi = mid }
    }
    let start_b = through - dir_b * (hi + gap_um);
    Ok((pose.transform_point(&start_b), pose.rotate(&dir_b)))
}

/// The probe waypoints of one push (time from 0, one every setpoint period; times as
/// `t_us × 1e-6`, which the recorded trials were simulated with — `units::us_i64_to_s`
/// divides and differs in the last bit).
fn waypoints(spec: &SynthSpec, pose: &Pose, push: &PushSpec) -> Result<Vec<ProbePoint>, Error> {
    let gap = spec.clearance_um + spec.model.probe_radius_um;
    let (mut p, mut dir) = approach(spec.model.part.polygon(), pose, push, gap)?;
    let step_um = spec.speed_um_s * spec.setpoint_period_us as f64 * 1e-6;
    let mut out = vec![ProbePoint::new(0.0, p)];
    let mut t_us = 0i64;
    for (k, (len, turn)) in push.legs.iter().enumerate() {
        let (s, c) = turn.sin_cos();
        dir = Vec2::new(c * dir.x - s * dir.y, s * dir.x + c * dir.y);
        let len = if k == 0 { len + spec.clearance_um } else { *len };
        let n = (len / step_um).ceil().max(1.0) as usize;
        for _ in 0..n {
            p += dir * (len / n as f64);
            t_us += spec.setpoint_period_us;
            out.push(ProbePoint::new(t_us as f64 * 1e-6, p));
        }
    }
    Ok(out)
}

/// The camera frame period as a step over µs stamps; an error unless both periods are > 0.
fn frame_step(spec: &SynthSpec) -> Result<usize, Error> {
    let (setpoint, frame) = (spec.setpoint_period_us, spec.frame_period_us);
    usize::try_from(frame).ok().filter(|&f| f > 0 && setpoint > 0).ok_or_else(|| {
        Error::invalid(
            "synthetic trial periods",
            format!("setpoint {setpoint} us, frame {frame} us: both must be > 0"),
        )
    })
}

/// The metadata of trial `k`: the truth in `world`, which identification never reads.
fn meta(spec: &SynthSpec, k: usize, push: &PushSpec, jams: usize) -> TrialMeta {
    let mut meta = TrialMeta::new(format!("synth-{k:02}"), "ident-synth", spec.model.part.clone());
    meta.pusher = mesopush_sim::Pusher::single(spec.model.probe_radius_um);
    meta.frame_period_us = Some(spec.frame_period_us.unsigned_abs() as f64);
    meta.world = Some(serde_json::json!({
        "generator": "mesopush ident::synth",
        "true_model": spec.model,
        "push": push,
        "noise_xy_um": spec.noise_xy_um,
        "noise_theta_rad": spec.noise_theta_rad,
        "jams": jams,
    }));
    meta
}

/// Simulates and writes trial `k` of `spec` into `dir` (which must not hold a trial).
pub fn write_trial(
    spec: &SynthSpec,
    k: usize,
    dir: &Path,
    rng: &mut impl Rng,
) -> Result<PathBuf, Error> {
    let push = spec.pushes.get(k).ok_or_else(|| {
        Error::invalid("trial", format!("{k}: the spec has {} pushes", spec.pushes.len()))
    })?;
    let frame_step = frame_step(spec)?;
    let (dx, dy, dth) = push.start_offset;
    let start = Pose::new(spec.start.x_um + dx, spec.start.y_um + dy, spec.start.theta_rad + dth);
    let path = waypoints(spec, &start, push)?;
    let mut sim = Simulator::new(spec.model.clone(), open_plate(), SimSettings::default())?;
    let replay = follow_path(&mut sim, start, &path)?;
    let mut w = TrialWriter::create(dir, meta(spec, k, push, replay.jams))?;
    for p in &path {
        let t_us = units::s_to_us_i64("probe t_s", p.t_s)?;
        let (x, y) = (p.probe_um.x, p.probe_um.y);
        w.probe(&ProbeRow {
            t_us,
            cmd_x_um: x,
            cmd_y_um: y,
            rep_x_um: None,
            rep_y_um: None,
            cmd_theta_rad: None,
        })?;
    }
    let end_us = units::s_to_us_i64("last setpoint t_s", path[path.len() - 1].t_s)?;
    for (i, t_us) in (0..=end_us).step_by(frame_step).enumerate() {
        // × 1e-6, not `units::us_i64_to_s` (÷ 1e6): they differ in the last bit for about a
        // third of the stamps, and the recorded poses were sampled with this one.
        let truth = pose_at(&replay.samples, t_us as f64 * 1e-6);
        w.pose(&PoseRow {
            t_us,
            x_um: truth.x_um + spec.noise_xy_um * normal(rng),
            y_um: truth.y_um + spec.noise_xy_um * normal(rng),
            theta_rad: truth.theta_rad + spec.noise_theta_rad * normal(rng),
            frame_index: Some(i as u64),
            residual_px: None,
            probe_tip_x_um: None,
            probe_tip_y_um: None,
        })?;
    }
    Ok(w.finish(Outcome { state: TrialState::Done, reason: None, inserted: None })?)
}

/// Writes every trial of `spec` as `root/synth-NN/`; returns their directories.
pub fn write_trials(
    spec: &SynthSpec,
    root: &Path,
    rng: &mut impl Rng,
) -> Result<Vec<PathBuf>, Error> {
    (0..spec.pushes.len())
        .map(|k| write_trial(spec, k, &root.join(format!("synth-{k:02}")), rng))
        .collect()
}

/// The true support of the peg demo (relative to the COM, µm, before scaling).
pub const PEG_SUPPORT_UM: [[f64; 2]; 3] = [[-520.0, 300.0], [-260.0, -380.0], [560.0, 90.0]];
/// The true support of the hexagon demo (relative to the COM, µm, before scaling).
pub const HEXAGON_SUPPORT_UM: [[f64; 2]; 3] = [[-300.0, 250.0], [-150.0, -350.0], [420.0, 60.0]];
/// Circumradius of the demo hexagon before scaling, µm.
pub const HEXAGON_RADIUS_UM: f64 = 650.0;
/// Probe travel of each demo push before scaling, µm.
pub const DEMO_TRAVEL_UM: f64 = 900.0;

/// The demo's true model: the paper's peg with an off-centre support ([`PEG_SUPPORT_UM`]),
/// μ = 0.6 and surface friction 0.3.
pub fn demo_truth() -> Model {
    Model {
        support: mesopush_sim::SupportDistribution {
            points_um: PEG_SUPPORT_UM,
            mu_surface: [0.3; 3],
        },
        mu_probe: 0.6,
        ..Model::default()
    }
}

/// A regular hexagon part of circumradius `r_um` (for trials of another part and scale).
pub fn hexagon(r_um: f64) -> mesopush_sim::Part {
    let v: Vec<Vec2> = (0..6)
        .map(|i| {
            let a = std::f64::consts::FRAC_PI_3 * i as f64;
            Vec2::new(r_um * a.cos(), r_um * a.sin())
        })
        .collect();
    mesopush_sim::Part::from_polygon(&ConvexPolygon::new(v).expect("regular hexagon"))
}

/// The part of the demo dataset.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DemoPart {
    /// The paper's peg (1615 × 985 µm), support [`PEG_SUPPORT_UM`].
    Peg,
    /// A regular hexagon of circumradius [`HEXAGON_RADIUS_UM`], support
    /// [`HEXAGON_SUPPORT_UM`].
    Hexagon,
}

impl std::str::FromStr for DemoPart {
    type Err = Error;

    /// `peg` or `hexagon`.
    fn from_str(s: &str) -> Result<Self, Error> {
        match s {
            "peg" => Ok(DemoPart::Peg),
            "hexagon" => Ok(DemoPart::Hexagon),
            other => Err(Error::invalid("demo part", format!("{other:?}: use peg or hexagon"))),
        }
    }
}

/// The demo dataset: six paper-like pushes ([`paper_like_pushes`]) of a part with known
/// truth (μ 0.6, an off-centre support), written as ordinary trial logs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DemoSettings {
    /// The part. Default [`DemoPart::Peg`].
    pub part: DemoPart,
    /// Scale of the part, its support and the push lengths ([`DEMO_TRAVEL_UM`]). Default 1.
    pub scale: f64,
    /// Probe speed, µm/s. Default 200.
    pub speed_um_s: f64,
}

impl Default for DemoSettings {
    fn default() -> Self {
        Self { part: DemoPart::Peg, scale: 1.0, speed_um_s: 200.0 }
    }
}

/// A demo dataset as written.
#[derive(Debug, Clone, PartialEq)]
pub struct Demo {
    /// The true model.
    pub truth: Model,
    /// The trial directories.
    pub trials: Vec<PathBuf>,
    /// Where the true model was written (`true_model.toml` beside the trials).
    pub truth_file: PathBuf,
}

/// The demo's true model for `settings`: the part and its support scaled.
pub fn demo_model(settings: &DemoSettings) -> Result<Model, Error> {
    let s = settings.scale;
    if !(s.is_finite() && s > 0.0) {
        return Err(Error::invalid("demo scale", format!("{s}: must be finite and > 0")));
    }
    let (part, support) = match settings.part {
        DemoPart::Peg => (demo_truth().part, PEG_SUPPORT_UM),
        DemoPart::Hexagon => (hexagon(HEXAGON_RADIUS_UM), HEXAGON_SUPPORT_UM),
    };
    let verts: Vec<Vec2> = part.polygon().vertices().iter().map(|v| v * s).collect();
    let polygon = ConvexPolygon::new(verts)
        .map_err(|e| Error::invalid("demo part", format!("scaled by {s}: {e}")))?;
    let mut truth = demo_truth();
    truth.part = mesopush_sim::Part::from_polygon(&polygon);
    truth.support.points_um = support.map(|[x, y]| [x * s, y * s]);
    truth.validate().map_err(|e| Error::invalid("synthetic truth", e.to_string()))?;
    Ok(truth)
}

/// Writes the demo dataset of `settings` into `dir` (`synth-NN/` trials and
/// `true_model.toml`), the tracking noise drawn from `rng`.
pub fn write_demo(settings: &DemoSettings, dir: &Path, rng: &mut impl Rng) -> Result<Demo, Error> {
    let v = settings.speed_um_s;
    if !(v.is_finite() && v > 0.0) {
        return Err(Error::invalid("demo speed", format!("{v} um/s: must be finite and > 0")));
    }
    let truth = demo_model(settings)?;
    let mut spec = SynthSpec::paper_like(truth.clone(), DEMO_TRAVEL_UM * settings.scale);
    spec.speed_um_s = v;
    let trials = write_trials(&spec, dir, rng)?;
    let truth_file = dir.join("true_model.toml");
    truth.save(&truth_file)?;
    Ok(Demo { truth, trials, truth_file })
}
