//! Emulator of a Scientifica motion card (PatchStar, MicroStar, SliceScope …; LinLab
//! command set), v2 or v3.
//!
//! Sources (controller-protocol notes, section 3): acq4 `Scientifica/scientifica.py` (VER
//! → 10 or 100 ticks/µm, `POS` vs `P`, TOP/ACC units per card, axis scales, LIMITS bits,
//! "devices report they are finished moving before they have completely stopped"),
//! Micro-Manager `Scientifica.cpp` (`abs x y`, `E <n>`, TOP/ACC defaults), ScanImage
//! `LinearStageController.m`, Burgt's PatchStar driver (`ABS` → `A` at once).
//!
//! Emulated (ASCII lines ending `\r`, case-insensitive, `\n` ignored; replies are one line
//! ending `\r`; 9600 or 38400 baud 8N1 with byte timing; no processing latency):
//! - `scientifica` → `Y519`; `VER` → `2.13` (v2) / `3.13` (v3); `TYPE` → `1.05` / `3.05`;
//!   `DESC` → `PatchStar`; `BAUD 96`/`BAUD 38` switch the reply rate, no reply.
//! - `POS` (both cards) / `P` (v3 only; a v2 card answers `E,1`, inferred) → `x\ty\tz` in
//!   ticks: 0.1 µm (v2) or 0.01 µm (v3) at the default axis scale; `PX`/`PY`/`PZ` → one
//!   value; `PX n` and `ZERO` set counters (refused with `E,3` while the stage moves).
//! - `ABS x y z` / `ABS x y` / `ABSZ z` / `REL dx dy dz` / `REL dx dy` → `A` at once and the
//!   move runs on (straight line, TOP on the fastest axis, ACC) (line: inferred); `E,3`
//!   while `S` is non-zero. Targets beyond the travel are clamped and LIMITS shows it.
//! - `S` → `0` idle, else the moving axes as bits x=1, y=2, z=4 (bits: inferred). **Early
//!   finish:** `S` reads 0 from [`ScientificaSettings::early_done_us`] before the end of
//!   the move while the stage still travels its last ticks; a new move is accepted then.
//!   Optionally the stage also stops [`ScientificaSettings::short_stop_ticks`] short of
//!   the target (acq4 re-checks the position 100 ms after `S` = 0 and retries beyond
//!   0.5 µm).
//! - `STOP` → `A`, the stage stops dead. `LIMITS` → decimal bitmask (x_low 1, x_high 2,
//!   y_low 4, …; acq4 reads decimal, ScanImage hex: decimal chosen).
//! - `TOP`/`FIRST`/`ACC` get/set. v2: raw values, speed (µm/s) = TOP / (2·|UU|), accel
//!   (µm/s²) = ACC·250/|UU|, TOP/FIRST 1000..=50000, ACC 10..=1000. v3: µm/s and µm/s²
//!   (TOP/FIRST 1..=10000, ACC 1..=100000 (ranges inferred)). The physical speed uses the
//!   default scale (the mechanics), so a changed scale does not change the motion.
//! - `UUX` … (v2) / `USTEP X` … (v3) get/set the axis scale; reported ticks scale by
//!   default/current (acq4: the scale makes the position unit). The other card's form is
//!   unknown to a card (`E,1`).
//! - Errors (numbers inferred): `E,1` unknown command, `E,2` bad or missing argument, `E,3`
//!   refused while moving. A line longer than 64 bytes is answered `E,1` at its `\r`.
//!
//! Not verifiable without a device: the real error numbers, the `S` bit meaning, the `VER`
//! format beyond `float()`, the travel (±10 mm chosen), the use of `FIRST` (stored only),
//! v3 ranges and defaults, the path shape of a multi-axis move.

use super::controller::{VendorController, steps_to_nm, to_i32};
use super::linlab::{self, Command, Param, ScaleCmd};
use super::motion::{AxisLimits, Path, Stage};
use super::serial::SerialTx;
use crate::error::SimError;

/// The motion card generation (`VER` 2.x or 3.x).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Card {
    /// v2: 0.1 µm ticks, scaled TOP/ACC (Micro-Manager's "Motion Card V1").
    V2,
    /// v3: 0.01 µm ticks, TOP/ACC in µm/s and µm/s².
    V3,
}

impl Card {
    /// Size of a position tick at the default scale, nm.
    pub fn nm_per_tick(self) -> f64 {
        match self {
            Self::V2 => 100.0,
            Self::V3 => 10.0,
        }
    }

    fn ticks_per_um(self) -> f64 {
        1000.0 / self.nm_per_tick()
    }
}

/// Settings of an emulated Scientifica device.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScientificaSettings {
    /// The card generation.
    pub card: Card,
    /// Link rate, bits/s (9600 or 38400).
    pub baud: u32,
    /// Start position, nm (rounded to ticks).
    pub start_nm: [i64; 3],
    /// Travel of every axis (min, max), nm.
    pub travel_nm: (i64, i64),
    /// How long before the end of a move `S` already reads 0, µs.
    pub early_done_us: u64,
    /// How far short of its target every moving axis stops, ticks (0: on target).
    pub short_stop_ticks: i64,
    /// Default axis scale (v2 UU, v3 USTEP) at which a tick is 0.1 / 0.01 µm.
    pub default_scale: [f64; 3],
    /// Power-on `TOP`, card units.
    pub top: f64,
    /// Power-on `FIRST`, card units.
    pub first: f64,
    /// Power-on `ACC`, card units.
    pub acc: f64,
}

impl ScientificaSettings {
    /// A PatchStar (UU −6.4; v3 USTEP −1600 = 10240/−6.4) at the origin, 9600 baud, a 30 ms
    /// early finish. v2: TOP 30000, FIRST 5000, ACC 500 (MM/ScanImage defaults: 2343.75
    /// µm/s, 19531 µm/s²); v3: the same physical values rounded (2344, 391, 19531).
    pub const fn patchstar(card: Card) -> Self {
        let (scale, top, first, acc) = match card {
            Card::V2 => (-6.4, 30_000.0, 5_000.0, 500.0),
            Card::V3 => (-1600.0, 2_344.0, 391.0, 19_531.0),
        };
        Self {
            card,
            baud: 9600,
            start_nm: [0; 3],
            travel_nm: (-10_000_000, 10_000_000),
            early_done_us: 30_000,
            short_stop_ticks: 0,
            default_scale: [scale; 3],
            top,
            first,
            acc,
        }
    }
}

/// Allowed range of a parameter on a card.
fn range(card: Card, p: Param) -> (f64, f64) {
    match (card, p) {
        (Card::V2, Param::Acc) => (10.0, 1000.0),
        (Card::V2, _) => (1000.0, 50_000.0),
        (Card::V3, Param::Acc) => (1.0, 100_000.0),
        (Card::V3, _) => (1.0, 10_000.0),
    }
}

const MAX_LINE: usize = 64;

/// An emulated Scientifica controller on its serial link.
#[derive(Debug, Clone)]
pub struct Scientifica {
    cfg: ScientificaSettings,
    now_us: u64,
    line: Vec<u8>,
    tx: SerialTx,
    stage: Stage<3>,
    busy_until_us: u64,
    scale: [f64; 3],
    params: [f64; 3],
}

impl Scientifica {
    /// Powered on at `now_us`.
    pub fn new(cfg: ScientificaSettings, now_us: u64) -> Result<Self, SimError> {
        if cfg.baud == 0 {
            return Err(SimError::BadConfig { field: "scientifica.baud" });
        }
        if cfg.default_scale.iter().any(|s| *s == 0.0 || !s.is_finite()) {
            return Err(SimError::BadConfig { field: "scientifica.default_scale" });
        }
        if cfg.travel_nm.0 >= cfg.travel_nm.1 || cfg.short_stop_ticks < 0 {
            return Err(SimError::BadConfig { field: "scientifica.travel_nm" });
        }
        for (p, v) in [(Param::Top, cfg.top), (Param::First, cfg.first), (Param::Acc, cfg.acc)] {
            let (lo, hi) = range(cfg.card, p);
            if !(lo..=hi).contains(&v) {
                return Err(SimError::BadConfig { field: "scientifica.top/first/acc" });
            }
        }
        let tick = cfg.card.nm_per_tick();
        let start = cfg.start_nm.map(|v| (v as f64 / tick).round() as i64);
        Ok(Self {
            cfg,
            now_us,
            line: Vec::new(),
            tx: SerialTx::new(cfg.baud),
            stage: Stage::new(start),
            busy_until_us: now_us,
            scale: cfg.default_scale,
            params: [cfg.top, cfg.first, cfg.acc],
        })
    }

    /// Starts or ends a stall at `now_us` (see [`Stage::set_stalled`]).
    pub fn set_stalled(&mut self, now_us: u64, stalled: bool) {
        self.advance(now_us);
        self.stage.set_stalled(self.now_us, stalled);
    }

    fn advance(&mut self, now_us: u64) {
        self.now_us = self.now_us.max(now_us);
        self.stage.settle(self.now_us);
    }

    fn busy(&self) -> bool {
        self.now_us < self.busy_until_us && self.stage.is_moving(self.now_us)
    }

    /// Reported ticks per true tick on each axis (default scale / current scale).
    fn factor(&self, i: usize) -> f64 {
        self.cfg.default_scale[i] / self.scale[i]
    }

    fn reported(&self) -> [i64; 3] {
        let c = self.stage.counter(self.now_us);
        core::array::from_fn(|i| (c[i] as f64 * self.factor(i)).round() as i64)
    }

    fn byte(&mut self, b: u8) {
        match b {
            b'\n' => {}
            b'\r' => {
                let line = std::mem::take(&mut self.line);
                if line.len() > MAX_LINE {
                    self.reply("E,1");
                } else if !line.is_empty() {
                    let cmd = linlab::parse(std::str::from_utf8(&line).unwrap_or("\u{1}"));
                    self.execute(cmd);
                }
            }
            _ if self.line.len() <= MAX_LINE => self.line.push(b),
            _ => {}
        }
    }

    fn execute(&mut self, cmd: Command) {
        let card = self.cfg.card;
        let text = match cmd {
            Command::Identify => "Y519".to_owned(),
            Command::Version => if card == Card::V2 { "2.13" } else { "3.13" }.to_owned(),
            Command::Type => if card == Card::V2 { "1.05" } else { "3.05" }.to_owned(),
            Command::Description => "PatchStar".to_owned(),
            Command::Position { short: true } if card == Card::V2 => "E,1".to_owned(),
            Command::Position { .. } => {
                let [x, y, z] = self.reported().map(to_i32);
                format!("{x}\t{y}\t{z}")
            }
            Command::AxisPosition(a) => to_i32(self.reported()[a.index()]).to_string(),
            Command::Status => self.status().to_string(),
            Command::Limits => self.limits().to_string(),
            Command::Stop => {
                self.stage.stop(self.now_us);
                self.busy_until_us = self.now_us;
                "A".to_owned()
            }
            Command::Get(p) => self.params[p as usize].to_string(),
            Command::Set(p, v) => {
                let (lo, hi) = range(card, p);
                let ok = (lo..=hi).contains(&v);
                if ok {
                    self.params[p as usize] = v;
                }
                if ok { "A" } else { "E,2" }.to_owned()
            }
            Command::GetScale(s, a) if own_scale(card, s) => self.scale[a.index()].to_string(),
            Command::SetScale(s, a, v) if own_scale(card, s) => {
                let ok = v != 0.0 && v.abs() <= 1e6;
                if ok {
                    self.scale[a.index()] = v;
                }
                if ok { "A" } else { "E,2" }.to_owned()
            }
            Command::GetScale(..) | Command::SetScale(..) | Command::Unknown => "E,1".to_owned(),
            Command::BadArgument => "E,2".to_owned(),
            Command::Baud(b) => {
                self.tx.set_baud(b);
                return;
            }
            Command::Zero | Command::SetAxisPosition(..) => self.set_counter(cmd),
            Command::Abs(t) => {
                let r = self.reported();
                self.start_move(core::array::from_fn(|i| t[i].unwrap_or(r[i])))
            }
            Command::Rel(d) => {
                let r = self.reported();
                self.start_move(core::array::from_fn(|i| r[i] + d[i]))
            }
        };
        self.reply(&text);
    }

    fn status(&self) -> u8 {
        if !self.busy() {
            return 0;
        }
        let m = self.stage.moving_axes(self.now_us);
        (u8::from(m[0]) | u8::from(m[1]) << 1 | u8::from(m[2]) << 2).max(1)
    }

    fn limits(&self) -> u8 {
        let tick = self.cfg.card.nm_per_tick();
        let (lo, hi) = self.travel_ticks(tick);
        let p = self.stage.true_pos(self.now_us);
        (0..3).fold(0, |acc, i| {
            acc | u8::from(p[i] <= lo) << (2 * i) | u8::from(p[i] >= hi) << (2 * i + 1)
        })
    }

    fn travel_ticks(&self, tick: f64) -> (i64, i64) {
        let (lo, hi) = self.cfg.travel_nm;
        ((lo as f64 / tick).ceil() as i64, (hi as f64 / tick).floor() as i64)
    }

    fn set_counter(&mut self, cmd: Command) -> String {
        if self.stage.is_moving(self.now_us) {
            return "E,3".to_owned();
        }
        let mut c = self.stage.counter(self.now_us);
        match cmd {
            Command::SetAxisPosition(a, v) => {
                c[a.index()] = (v as f64 / self.factor(a.index())).round() as i64;
            }
            _ => c = [0; 3],
        }
        self.stage.set_counter(c);
        "A".to_owned()
    }

    /// Starts a move to `target` (reported ticks): `A`, or `E,3` while busy.
    fn start_move(&mut self, target: [i64; 3]) -> String {
        if self.busy() {
            return "E,3".to_owned();
        }
        let card = self.cfg.card;
        let (lo, hi) = self.travel_ticks(card.nm_per_tick());
        let cur = self.stage.counter(self.now_us);
        let slip = self.stage.slip();
        let short = self.cfg.short_stop_ticks;
        let to: [i64; 3] = core::array::from_fn(|i| {
            let counter = (target[i] as f64 / self.factor(i)).round() as i64;
            let clamped = (counter + slip[i]).clamp(lo, hi) - slip[i];
            let d = clamped - cur[i];
            clamped - d.signum() * short.min(d.abs())
        });
        let lim: [AxisLimits; 3] = core::array::from_fn(|i| self.limits_of(i));
        let end = self.stage.start(self.now_us, to, Path::Linear, lim);
        self.busy_until_us = end.saturating_sub(self.cfg.early_done_us).max(self.now_us);
        "A".to_owned()
    }

    /// Physical speed and acceleration of axis `i`, true ticks/s and ticks/s².
    fn limits_of(&self, i: usize) -> AxisLimits {
        let [top, _, acc] = self.params;
        let tpu = self.cfg.card.ticks_per_um();
        let (um_s, um_s2) = match self.cfg.card {
            Card::V2 => {
                let uu = self.cfg.default_scale[i].abs();
                (top / (2.0 * uu), acc * 250.0 / uu)
            }
            Card::V3 => (top, acc),
        };
        AxisLimits { speed_steps_s: um_s * tpu, accel_steps_s2: um_s2 * tpu }
    }

    fn reply(&mut self, text: &str) {
        self.tx.send(self.now_us, text.as_bytes());
        self.tx.send(self.now_us, b"\r");
    }
}

fn own_scale(card: Card, s: ScaleCmd) -> bool {
    matches!((card, s), (Card::V2, ScaleCmd::Uu) | (Card::V3, ScaleCmd::Ustep))
}

impl VendorController for Scientifica {
    fn receive(&mut self, now_us: u64, bytes: &[u8]) {
        self.advance(now_us);
        for &b in bytes {
            self.byte(b);
        }
    }

    fn poll(&mut self, now_us: u64) {
        self.advance(now_us);
    }

    fn transmit(&mut self, now_us: u64, buf: &mut [u8]) -> Option<usize> {
        self.advance(now_us);
        self.tx.transmit(self.now_us, buf)
    }

    fn probe_nm(&self) -> (i32, i32) {
        let p = self.stage.true_pos(self.now_us);
        let t = self.cfg.card.nm_per_tick();
        (steps_to_nm(p[0], t), steps_to_nm(p[1], t))
    }

    fn probe_z_nm(&self) -> i32 {
        steps_to_nm(self.stage.true_pos(self.now_us)[2], self.cfg.card.nm_per_tick())
    }

    fn next_deadline_us(&self) -> Option<u64> {
        let busy = (self.now_us < self.busy_until_us).then_some(self.busy_until_us);
        [self.tx.next_release_us(), self.stage.end_us(), busy].into_iter().flatten().min()
    }
}
