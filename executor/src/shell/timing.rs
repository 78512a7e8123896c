//! Send timing of the shell: how late each setpoint segment's write to the controller line
//! finished past its send schedule ([`crate::Executor::next_send_due_us`]).
//!
//! A fixed histogram (1 µs bins up to 2 ms, 100 µs bins up to 100 ms, one overflow bin),
//! allocated once with the stats, so recording in the loop never allocates. Percentiles are
//! reported as the upper edge of their bin (exact below 2 ms).

/// 1 µs bins below this, µs.
const FINE_US: u64 = 2_000;
/// Width of the coarse bins, µs.
const COARSE_BIN_US: u64 = 100;
/// Coarse bins end here, µs; later sends land in the overflow bin.
const COARSE_END_US: u64 = 100_000;
const BINS: usize = (FINE_US + (COARSE_END_US - FINE_US) / COARSE_BIN_US) as usize + 1;

/// Histogram of send deviations plus the sends that had no schedule to compare with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SendTiming {
    bins: [u32; BINS],
    /// Segments whose write was compared with their schedule (the first of each loop pass).
    pub timed: u64,
    /// Further segments written in the same pass (a catch-up or the trial's first batch).
    pub batched: u64,
    /// Segments released by a controller status (flow control held them; no time schedule).
    pub flow_released: u64,
    /// Largest deviation, µs (exact).
    pub max_us: u64,
}

impl Default for SendTiming {
    fn default() -> Self {
        Self { bins: [0; BINS], timed: 0, batched: 0, flow_released: 0, max_us: 0 }
    }
}

impl SendTiming {
    /// One loop pass wrote `sent` segments, the write done at `write_us`; `due_us` was the
    /// first one's schedule when the pass began (`None`: held by flow control).
    pub fn record(&mut self, due_us: Option<u64>, write_us: u64, sent: u64) {
        if sent == 0 {
            return;
        }
        let Some(due) = due_us else {
            self.flow_released += sent;
            return;
        };
        let dev = write_us.saturating_sub(due);
        self.bins[Self::bin(dev)] = self.bins[Self::bin(dev)].saturating_add(1);
        self.timed += 1;
        self.batched += sent - 1;
        self.max_us = self.max_us.max(dev);
    }

    fn bin(dev_us: u64) -> usize {
        if dev_us < FINE_US {
            dev_us as usize
        } else if dev_us < COARSE_END_US {
            (FINE_US + (dev_us - FINE_US) / COARSE_BIN_US) as usize
        } else {
            BINS - 1
        }
    }

    fn upper_edge_us(bin: usize) -> u64 {
        let b = bin as u64;
        if b < FINE_US { b } else { FINE_US + (b - FINE_US + 1) * COARSE_BIN_US }
    }

    /// The `p`-quantile (0..=1) of the deviations, µs; 0 without samples. At most the
    /// maximum.
    pub fn quantile_us(&self, p: f64) -> u64 {
        if self.timed == 0 {
            return 0;
        }
        let rank = ((self.timed - 1) as f64 * p.clamp(0.0, 1.0)).round() as u64 + 1;
        let mut seen = 0u64;
        for (i, &n) in self.bins.iter().enumerate() {
            seen += u64::from(n);
            if seen >= rank {
                return Self::upper_edge_us(i).min(self.max_us);
            }
        }
        self.max_us
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_are_exact_below_two_ms_and_bin_edges_above() {
        let mut t = SendTiming::default();
        for dev in 0..100u64 {
            t.record(Some(1_000), 1_000 + dev, 1);
        }
        t.record(Some(0), 5_050, 3);
        t.record(None, 9, 2);
        assert_eq!((t.timed, t.batched, t.flow_released, t.max_us), (101, 2, 2, 5_050));
        assert_eq!(t.quantile_us(0.5), 50);
        assert_eq!(t.quantile_us(0.99), 99);
        assert_eq!(t.quantile_us(1.0), 5_050);
        let mut late = SendTiming::default();
        late.record(Some(0), 2_345, 1);
        late.record(Some(0), 2_345, 1);
        assert_eq!(late.quantile_us(0.5), 2_345); // bin edge 2 400, capped at the max
        late.record(Some(0), 9_000, 1);
        assert_eq!(late.quantile_us(0.5), 2_400);
    }
}
