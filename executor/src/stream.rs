//! Turns a plan into controller segments at a fixed setpoint rate, with flow control.
//!
//! The plan's path is piecewise linear in time (each step at its own speed). Setpoint `k`
//! (1-based) is the path position at `k × T` after the trial start (`T` = setpoint period,
//! the last one at the path's end); segment `k` moves from setpoint `k−1` to setpoint `k`
//! starting at `start_ctrl_time_us = t0 + (k−1) × T` in the controller's clock, at the speed
//! that covers it in `T` (rounded up, at least 1 nm/s). Segments go out no earlier than
//! `lookahead_segments × T` before their start, at most `min(LA, lookahead_segments,
//! controller queue capacity)` in flight (sent, not reported done), where the capacity is
//! `queue_free_slots + queue_len` from the controller's last status. A segment still unsent
//! `underrun_margin_us` before its start is an underrun: the controller's queue would run dry.
//!
//! With [`Segmenting::PlanSteps`] (point-to-point controllers) segment `k` is plan step `k`
//! whole: from the step's start to its end, starting at the step's scheduled start, at the
//! step's own speed; send schedule, flow control and underrun are as above.

use crate::config::{ExecutorConfig, Segmenting};
use crate::plan::{FlashedPlan, StepGeometry, hypot_nm, lerp_nm};
use heapless::Deque;
use mesopush_protocol::ctrl::MoveSegment;

/// What the streamer wants done now.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StreamPoll {
    /// Send this segment (then call [`Streamer::sent`]).
    Send(MoveSegment),
    /// Nothing to send yet.
    Wait,
    /// The segment for this step could not be sent in time.
    Underrun {
        /// Step the unsent segment belongs to.
        step_index: u32,
    },
    /// Every segment was sent and reported done.
    Finished,
}

/// Position along the path: cursor over the plan's steps.
#[derive(Debug, Clone, Copy)]
struct Cursor {
    step_index: u32,
    step_start_rel_us: u64,
    step_start_nm: (i64, i64),
    geometry: Option<StepGeometry>,
}

/// Streams one trial of a plan; `LA` is the look-ahead queue's capacity.
#[derive(Debug)]
pub struct Streamer<const LA: usize> {
    t0_ctrl_us: u64,
    started_ctrl_us: u64,
    period_us: u64,
    total_us: u64,
    next_k: u64,
    segment_count: u64,
    first_segment_id: u32,
    cursor: Cursor,
    prev_setpoint_nm: (i64, i64),
    next: Option<(MoveSegment, u32, u64)>,
    inflight: Deque<(MoveSegment, u32, u64), LA>,
    done_base_nm: (i64, i64),
    ctrl_capacity: u16,
    per_step: bool,
}

impl<const LA: usize> Streamer<LA> {
    /// A trial of `plan` from `start_nm`, first segment starting at `t0_ctrl_us`, segment ids
    /// from `first_segment_id`. `ctrl_capacity` is the controller queue size last reported.
    pub fn new<const CAP: usize>(
        plan: &FlashedPlan<CAP>,
        config: &ExecutorConfig,
        start_nm: (i32, i32),
        t0_ctrl_us: u64,
        first_segment_id: u32,
        ctrl_capacity: u16,
    ) -> Self {
        let period_us = config.setpoint_period_us();
        let total_us: u64 = plan.steps().map(|s| StepGeometry::of(&s).duration_us).sum();
        let start = (i64::from(start_nm.0), i64::from(start_nm.1));
        let per_step = config.segmenting == Segmenting::PlanSteps;
        let segment_count =
            if per_step { u64::from(plan.step_count()) } else { total_us.div_ceil(period_us) };
        Self {
            t0_ctrl_us,
            started_ctrl_us: t0_ctrl_us.saturating_sub(config.start_lead_us),
            period_us,
            total_us,
            next_k: 1,
            segment_count,
            first_segment_id,
            cursor: Cursor {
                step_index: 0,
                step_start_rel_us: 0,
                step_start_nm: start,
                geometry: plan.step(0).map(|s| StepGeometry::of(&s)),
            },
            prev_setpoint_nm: start,
            next: None,
            inflight: Deque::new(),
            done_base_nm: start,
            ctrl_capacity,
            per_step,
        }
    }

    /// Segments this trial consists of.
    pub fn segment_count(&self) -> u64 {
        self.segment_count
    }

    /// Trial duration, µs.
    pub fn duration_us(&self) -> u64 {
        self.total_us
    }

    /// Id of the trial's last segment.
    pub fn last_segment_id(&self) -> u32 {
        self.first_segment_id.wrapping_add(self.segment_count.saturating_sub(1) as u32)
    }

    /// Step of the next segment to send (the plan's step count once all are sent).
    pub fn step_index(&self) -> u32 {
        match &self.next {
            Some((_, step, _)) => *step,
            None => self.cursor.step_index,
        }
    }

    /// Segments sent and not yet reported done.
    pub fn inflight(&self) -> usize {
        self.inflight.len()
    }

    /// What to do at controller time `now_ctrl_us`.
    pub fn poll<const CAP: usize>(
        &mut self,
        plan: &FlashedPlan<CAP>,
        config: &ExecutorConfig,
        now_ctrl_us: u64,
    ) -> StreamPoll {
        if self.next.is_none() && self.next_k <= self.segment_count {
            self.next = Some(self.generate(plan));
        }
        let Some((segment, step_index, _)) = self.next else {
            return if self.inflight.is_empty() { StreamPoll::Finished } else { StreamPoll::Wait };
        };
        if segment.start_ctrl_time_us <= now_ctrl_us.saturating_add(config.underrun_margin_us) {
            return StreamPoll::Underrun { step_index };
        }
        let horizon_us = u64::from(config.lookahead_segments) * self.period_us;
        if self.flow_held() || segment.start_ctrl_time_us > now_ctrl_us + horizon_us {
            return StreamPoll::Wait;
        }
        StreamPoll::Send(segment)
    }

    /// When the next segment is due to go out, controller µs: its start minus
    /// `lookahead_segments × T`, but not before the trial started (`t0 − start_lead_us`: the
    /// first segments are all due at the start). `None` when none is waiting (call [`Self::poll`] first) or
    /// flow control holds it (the in-flight limit is reached; a status report frees it).
    pub fn send_due_ctrl_us(&self, config: &ExecutorConfig) -> Option<u64> {
        let (segment, _, _) = self.next.as_ref()?;
        let horizon_us = u64::from(config.lookahead_segments) * self.period_us;
        let due = segment.start_ctrl_time_us.saturating_sub(horizon_us);
        (!self.flow_held()).then_some(due.max(self.started_ctrl_us))
    }

    /// Whether the in-flight limit `min(LA, controller capacity)` is reached.
    fn flow_held(&self) -> bool {
        self.inflight.len() >= LA.min(usize::from(self.ctrl_capacity))
    }

    /// The segment from the last [`StreamPoll::Send`] went out.
    pub fn sent(&mut self) {
        if let Some(entry) = self.next.take() {
            // Cannot fail: poll only offers a segment while the deque has room.
            let _ = self.inflight.push_back(entry);
        }
    }

    /// Controller status: retire finished segments, learn the queue's capacity.
    pub fn on_status(&mut self, last_done_segment_id: Option<u32>, capacity: u16) {
        self.ctrl_capacity = capacity;
        let Some(done) = last_done_segment_id else { return };
        let done_rel = done.wrapping_sub(self.first_segment_id);
        if u64::from(done_rel) >= self.segment_count {
            // A segment of an earlier stream (a trial or goto stopped before its end): none
            // of this one is done yet. Taken as this stream's, it retired every segment in
            // flight at once, so a run after an abort was reported done before the
            // controller had executed it.
            return;
        }
        while let Some((front, _, _)) = self.inflight.front() {
            let rel = front.segment_id.wrapping_sub(self.first_segment_id);
            if rel > done_rel {
                break;
            }
            self.done_base_nm = (i64::from(front.target_x_nm), i64::from(front.target_y_nm));
            self.inflight.pop_front();
        }
    }

    /// Commanded position at controller time `ctrl_time_us`, from the in-flight schedule;
    /// `None` outside it.
    pub fn commanded_at(&self, ctrl_time_us: u64) -> Option<(i64, i64)> {
        let mut from = self.done_base_nm;
        for (seg, _, dur_us) in self.inflight.iter() {
            let to = (i64::from(seg.target_x_nm), i64::from(seg.target_y_nm));
            let end = seg.start_ctrl_time_us + dur_us;
            if ctrl_time_us < seg.start_ctrl_time_us {
                return Some(from);
            }
            if ctrl_time_us <= end {
                let num = ctrl_time_us - seg.start_ctrl_time_us;
                return Some(lerp_nm(from, to, num, *dur_us));
            }
            from = to;
        }
        None
    }

    fn generate<const CAP: usize>(&mut self, plan: &FlashedPlan<CAP>) -> (MoveSegment, u32, u64) {
        if self.per_step {
            return self.generate_step(plan);
        }
        let k = self.next_k;
        self.next_k += 1;
        let start_rel = (k - 1) * self.period_us;
        let end_rel = (k * self.period_us).min(self.total_us);
        let step_index = self.cursor.step_index;
        let target = self.position_at(plan, end_rel);
        let dist = hypot_nm(target.0 - self.prev_setpoint_nm.0, target.1 - self.prev_setpoint_nm.1);
        let dur = (end_rel - start_rel).max(1);
        let speed = (dist * 1_000_000).div_ceil(dur).clamp(1, u64::from(u32::MAX)) as u32;
        self.prev_setpoint_nm = target;
        let segment = MoveSegment {
            segment_id: self.first_segment_id.wrapping_add((k - 1) as u32),
            start_ctrl_time_us: self.t0_ctrl_us + start_rel,
            target_x_nm: target.0 as i32,
            target_y_nm: target.1 as i32,
            speed_nm_s: speed,
        };
        (segment, step_index, dur)
    }

    /// Segment `k` of [`Segmenting::PlanSteps`]: plan step `k − 1` whole, at its speed.
    fn generate_step<const CAP: usize>(
        &mut self,
        plan: &FlashedPlan<CAP>,
    ) -> (MoveSegment, u32, u64) {
        let k = self.next_k;
        self.next_k += 1;
        let step_index = self.cursor.step_index;
        let start_rel = self.cursor.step_start_rel_us;
        let dur = self.cursor.geometry.map_or(0, |g| g.duration_us);
        let speed = plan.step(step_index).map_or(1, |s| s.speed_nm_s.max(1));
        // The step's end: the cursor moves on to the next step's start.
        let target = self.position_at(plan, start_rel + dur);
        self.prev_setpoint_nm = target;
        let segment = MoveSegment {
            segment_id: self.first_segment_id.wrapping_add((k - 1) as u32),
            start_ctrl_time_us: self.t0_ctrl_us + start_rel,
            target_x_nm: target.0 as i32,
            target_y_nm: target.1 as i32,
            speed_nm_s: speed,
        };
        (segment, step_index, dur.max(1))
    }

    /// Path position `rel_us` after the start; advances the cursor (times never decrease).
    fn position_at<const CAP: usize>(
        &mut self,
        plan: &FlashedPlan<CAP>,
        rel_us: u64,
    ) -> (i64, i64) {
        loop {
            let c = &mut self.cursor;
            let Some(g) = c.geometry else { return c.step_start_nm };
            let Some(step) = plan.step(c.step_index) else { return c.step_start_nm };
            let end_nm = (
                c.step_start_nm.0 + i64::from(step.dx_nm),
                c.step_start_nm.1 + i64::from(step.dy_nm),
            );
            let step_end_rel = c.step_start_rel_us + g.duration_us;
            if rel_us < step_end_rel {
                return lerp_nm(
                    c.step_start_nm,
                    end_nm,
                    rel_us - c.step_start_rel_us,
                    g.duration_us,
                );
            }
            c.step_index += 1;
            c.step_start_rel_us = step_end_rel;
            c.step_start_nm = end_nm;
            c.geometry = plan.step(c.step_index).map(|s| StepGeometry::of(&s));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mesopush_protocol::flash::{FlashHeader, PlanStep};

    fn plan(steps: &[PlanStep]) -> FlashedPlan<120> {
        let mut image = heapless::Vec::<u8, 120>::new();
        for s in steps {
            image.extend_from_slice(&s.to_image_bytes()).unwrap();
        }
        let header = FlashHeader::for_image(1, &image).unwrap();
        FlashedPlan::from_verified(header, image).unwrap()
    }

    /// 2.1 µm at 140 µm/s = 15 ms: a 10 ms segment and a 5 ms one; the schedule
    /// interpolates the short one over its own duration.
    #[test]
    fn last_segment_is_short_and_interpolated_over_its_duration() {
        let plan = plan(&[PlanStep { dx_nm: 2_100, dy_nm: 0, speed_nm_s: 140_000 }]);
        let config = ExecutorConfig::DEFAULT;
        let mut s: Streamer<4> = Streamer::new(&plan, &config, (0, 0), 100_000, 7, 32);
        assert_eq!(s.segment_count(), 2);
        let mut sent = [None; 2];
        for slot in &mut sent {
            let StreamPoll::Send(seg) = s.poll(&plan, &config, 50_000) else { panic!() };
            *slot = Some(seg);
            s.sent();
        }
        assert_eq!(s.poll(&plan, &config, 50_000), StreamPoll::Wait);
        let [a, b] = sent.map(Option::unwrap);
        assert_eq!(
            (a.segment_id, a.start_ctrl_time_us, a.target_x_nm, a.speed_nm_s),
            (7, 100_000, 1_400, 140_000)
        );
        assert_eq!(
            (b.segment_id, b.start_ctrl_time_us, b.target_x_nm, b.speed_nm_s),
            (8, 110_000, 2_100, 140_000)
        );
        assert_eq!(s.commanded_at(112_500), Some((1_750, 0)));
        assert_eq!(s.commanded_at(200_000), None);
        s.on_status(Some(8), 32);
        assert_eq!(s.poll(&plan, &config, 120_000), StreamPoll::Finished);
    }

    #[test]
    fn unsent_segment_near_its_start_is_an_underrun() {
        let plan = plan(&[PlanStep { dx_nm: 14_000, dy_nm: 0, speed_nm_s: 140_000 }]);
        let config = ExecutorConfig::DEFAULT;
        let mut s: Streamer<4> = Streamer::new(&plan, &config, (0, 0), 100_000, 1, 1);
        assert!(matches!(s.poll(&plan, &config, 0), StreamPoll::Send(_)));
        s.sent();
        // Capacity 1 and no status: segment 2 (start 110 ms) cannot go.
        assert_eq!(s.poll(&plan, &config, 100_000), StreamPoll::Wait);
        assert_eq!(s.poll(&plan, &config, 108_000), StreamPoll::Underrun { step_index: 0 });
    }

    /// Point-to-point controllers get whole steps: 2 steps → 2 segments, each from its
    /// scheduled start to the step's end at the step's speed.
    #[test]
    fn plan_steps_segmenting_sends_one_segment_per_step() {
        let plan = plan(&[
            PlanStep { dx_nm: 14_000, dy_nm: 0, speed_nm_s: 140_000 },
            PlanStep { dx_nm: 0, dy_nm: -30_000, speed_nm_s: 100_000 },
        ]);
        let config =
            ExecutorConfig { segmenting: Segmenting::PlanSteps, ..ExecutorConfig::DEFAULT };
        let mut s: Streamer<4> = Streamer::new(&plan, &config, (1_000, 2_000), 100_000, 5, 8);
        assert_eq!(s.segment_count(), 2);
        let StreamPoll::Send(a) = s.poll(&plan, &config, 50_000) else { panic!() };
        s.sent();
        // The second starts 100 ms later (14 µm at 140 µm/s), at 200 ms: due 160 ms (the
        // look-ahead horizon) before, at 40 ms, so at 50 ms it goes out too.
        let StreamPoll::Send(b) = s.poll(&plan, &config, 50_000) else { panic!() };
        s.sent();
        assert_eq!(
            (a.segment_id, a.start_ctrl_time_us, a.target_x_nm, a.target_y_nm, a.speed_nm_s),
            (5, 100_000, 15_000, 2_000, 140_000)
        );
        assert_eq!(
            (b.segment_id, b.start_ctrl_time_us, b.target_x_nm, b.target_y_nm, b.speed_nm_s),
            (6, 200_000, 15_000, -28_000, 100_000)
        );
        assert_eq!(s.commanded_at(150_000), Some((8_000, 2_000)));
        assert_eq!(s.commanded_at(350_000), Some((15_000, -13_000)));
        s.on_status(Some(6), 8);
        assert_eq!(s.poll(&plan, &config, 600_000), StreamPoll::Finished);
    }
}
