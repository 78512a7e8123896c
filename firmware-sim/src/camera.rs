//! The simulated camera: a frame every period with a running counter, some dropped (the
//! counter skips) and some black, drawn from the seed.

use crate::config::FaultConfig;
use crate::rng::SimRng;
use crate::world::World;

/// One frame the camera delivered.
#[derive(Debug, Clone, PartialEq)]
pub struct SimFrame<F> {
    /// Frame counter (gaps are dropped frames).
    pub frame_seq: u32,
    /// Exposure time, µs in simulation time (the driver timestamp).
    pub exposure_sim_us: u64,
    /// The frame is black (lamp or sensor fault); `image` is then `None`.
    pub black: bool,
    /// The rendered image.
    pub image: Option<F>,
}

/// A camera at a fixed frame period; a frame is delivered `readout_us` after its exposure.
#[derive(Debug)]
pub struct SimCamera {
    period_us: u64,
    readout_us: u64,
    next_us: u64,
    seq: u32,
    rng: SimRng,
    faults: FaultConfig,
    /// Counters: frames delivered, dropped, black.
    pub delivered: u64,
    /// Frames dropped.
    pub dropped: u64,
    /// Black frames delivered.
    pub black: u64,
}

impl SimCamera {
    /// A camera with its first exposure at `start_us`, then every `period_us` (30 Hz:
    /// 33_333), each frame delivered `readout_us` after its exposure.
    pub fn new(
        period_us: u64,
        readout_us: u64,
        start_us: u64,
        rng: SimRng,
        faults: FaultConfig,
    ) -> Self {
        let (delivered, dropped, black) = (0, 0, 0);
        Self {
            period_us,
            readout_us,
            next_us: start_us,
            seq: 0,
            rng,
            faults,
            delivered,
            dropped,
            black,
        }
    }

    /// The frame delivered by `now_us`, if one is due and not dropped. The world renders it
    /// at delivery (the exposure time is in the frame).
    pub fn poll<W: World>(&mut self, now_us: u64, world: &mut W) -> Option<SimFrame<W::Frame>> {
        if now_us < self.next_us + self.readout_us {
            return None;
        }
        let exposure_sim_us = self.next_us;
        self.next_us += self.period_us;
        let frame_seq = self.seq;
        self.seq = self.seq.wrapping_add(1);
        if self.rng.chance(self.faults.frame_drop) {
            self.dropped += 1;
            return None;
        }
        let black = self.rng.chance(self.faults.frame_black);
        self.delivered += 1;
        self.black += u64::from(black);
        let image = (!black).then(|| world.render(exposure_sim_us));
        Some(SimFrame { frame_seq, exposure_sim_us, black, image })
    }
}
