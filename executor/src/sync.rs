//! Clock sync with the controller: an estimate of `ctrl_time_us − exec_time_us`.
//!
//! As Klipper does, the executor sends `ClockSyncQuery { query_id }` and notes its send time;
//! the reply carries the controller's time when it handled the query. Assuming the
//! controller answered midway through the round trip, `offset = ctrl − (sent + received)/2`
//! with an uncertainty of ±rtt/2. The estimate used is the sample with the shortest round
//! trip among the last [`SAMPLES`] good ones (round trip ≤ `sync_max_rtt_us`); queries go out
//! every `sync_interval_us`, four times faster until `sync_samples_to_arm` samples are in.
//! Drift between the two crystals is not modelled: at 100 ppm and a 100 ms query interval a
//! sample up to `SAMPLES` intervals old is off by ≤ 80 µs, well under a 10 ms setpoint period.

use crate::config::ExecutorConfig;
use heapless::Deque;

/// Good samples kept for the minimum-round-trip choice.
pub const SAMPLES: usize = 8;
/// Queries awaiting a reply; an older one is forgotten when a new one is sent.
const PENDING: usize = 4;

#[derive(Debug, Clone, Copy)]
struct Sample {
    offset_us: i64,
    rtt_us: u64,
}

/// Clock-sync state.
#[derive(Debug, Default)]
pub struct ClockSync {
    pending: Deque<(u32, u64), PENDING>,
    samples: Deque<Sample, SAMPLES>,
    good_count: u32,
    last_good_exec_us: Option<u64>,
    last_query_exec_us: Option<u64>,
    next_query_id: u32,
}

impl ClockSync {
    /// No samples yet.
    pub const fn new() -> Self {
        Self {
            pending: Deque::new(),
            samples: Deque::new(),
            good_count: 0,
            last_good_exec_us: None,
            last_query_exec_us: None,
            next_query_id: 0,
        }
    }

    /// Forgets everything (e.g. after the controller rebooted: its clock restarted).
    pub fn reset(&mut self) {
        let next_query_id = self.next_query_id;
        *self = Self::new();
        self.next_query_id = next_query_id;
    }

    /// The query id to send now, if a query is due.
    pub fn poll_query(&mut self, now_us: u64, config: &ExecutorConfig) -> Option<u32> {
        let acquiring = self.good_count < u32::from(config.sync_samples_to_arm);
        let interval =
            if acquiring { config.sync_interval_us / 4 } else { config.sync_interval_us };
        if self.last_query_exec_us.is_some_and(|t| now_us < t.saturating_add(interval)) {
            return None;
        }
        let query_id = self.next_query_id;
        self.next_query_id = self.next_query_id.wrapping_add(1);
        if self.pending.is_full() {
            self.pending.pop_front();
        }
        let _ = self.pending.push_back((query_id, now_us)); // room made above
        self.last_query_exec_us = Some(now_us);
        Some(query_id)
    }

    /// A reply arrived at `now_us`; returns whether it gave a good sample.
    pub fn on_reply(
        &mut self,
        now_us: u64,
        query_id: u32,
        ctrl_time_us: u64,
        config: &ExecutorConfig,
    ) -> bool {
        let Some(index) = self.pending.iter().position(|&(id, _)| id == query_id) else {
            return false; // unknown, stale or duplicate
        };
        let mut sent_us = 0;
        for _ in 0..=index {
            if let Some((_, t)) = self.pending.pop_front() {
                sent_us = t;
            }
        }
        let rtt_us = now_us.saturating_sub(sent_us);
        if rtt_us > config.sync_max_rtt_us {
            return false;
        }
        let midpoint_us = sent_us + rtt_us / 2;
        let offset_us = ctrl_time_us as i64 - midpoint_us as i64;
        if self.samples.is_full() {
            self.samples.pop_front();
        }
        let _ = self.samples.push_back(Sample { offset_us, rtt_us });
        self.good_count = self.good_count.saturating_add(1);
        self.last_good_exec_us = Some(now_us);
        true
    }

    /// Whether the estimate is good enough to schedule moves at `now_us`.
    pub fn is_synced(&self, now_us: u64, config: &ExecutorConfig) -> bool {
        self.good_count >= u32::from(config.sync_samples_to_arm)
            && self
                .last_good_exec_us
                .is_some_and(|t| now_us.saturating_sub(t) <= config.sync_max_age_us)
    }

    /// Current offset estimate, `ctrl − exec`, µs, and its uncertainty (half the round trip).
    pub fn offset_us(&self) -> Option<(i64, u64)> {
        let best = self.samples.iter().min_by_key(|s| s.rtt_us)?;
        Some((best.offset_us, best.rtt_us / 2))
    }

    /// Executor time → controller time.
    pub fn to_ctrl_us(&self, exec_time_us: u64) -> Option<u64> {
        let (offset, _) = self.offset_us()?;
        u64::try_from(exec_time_us as i64 + offset).ok()
    }

    /// Controller time → executor time.
    pub fn to_exec_us(&self, ctrl_time_us: u64) -> Option<u64> {
        let (offset, _) = self.offset_us()?;
        u64::try_from(ctrl_time_us as i64 - offset).ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A controller whose clock runs `offset` ahead, with asymmetric delays: the estimate's
    /// error stays within half the shortest round trip.
    #[test]
    fn picks_the_shortest_round_trip() {
        let config = ExecutorConfig::DEFAULT;
        let mut sync = ClockSync::new();
        let offset: i64 = 1_234_567;
        let mut now = 1_000;
        for (up, down) in [(900u64, 100u64), (300, 50), (2_000, 1_000), (40, 60)] {
            let id = loop {
                if let Some(id) = sync.poll_query(now, &config) {
                    break id;
                }
                now += 1_000;
            };
            let ctrl = (now + up) as i64 + offset;
            now += up + down;
            assert!(sync.on_reply(now, id, ctrl as u64, &config));
        }
        assert!(sync.is_synced(now, &config));
        let (est, err) = sync.offset_us().expect("samples");
        assert_eq!(err, 50);
        assert!((est - offset).abs() <= 50, "estimate {est} vs {offset}");
        assert!(!sync.is_synced(now + config.sync_max_age_us + 1, &config));
    }

    #[test]
    fn long_round_trips_and_unknown_ids_are_ignored() {
        let config = ExecutorConfig::DEFAULT;
        let mut sync = ClockSync::new();
        let id = sync.poll_query(0, &config).expect("first query is due at once");
        assert!(!sync.on_reply(10, id.wrapping_add(7), 5, &config));
        assert!(!sync.on_reply(config.sync_max_rtt_us + 1, id, 5, &config));
        assert!(sync.offset_us().is_none());
        assert!(!sync.on_reply(10, id, 5, &config), "a reply is used once");
    }
}
