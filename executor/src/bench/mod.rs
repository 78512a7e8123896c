//! Real-time timing bench of the std shell (`mesopush-executor bench`): the executor's own
//! shell loop ([`crate::shell::Shell::run_with`], the allocation-free core, a monotonic
//! clock) streams a plan to an in-process controller ([`ctrl`]) over in-memory lines while a
//! host ([`host`]) flashes, arms and starts it.
//!
//! The schedule: segment `k` is due to go out `lookahead_segments × T` before its start
//! ([`crate::Executor::next_send_due_us`]; the first ones at the trial's start). The
//! *send deviation* (`p50_us`, `p99_us`, `max_us`) is the instant the shell's write of the
//! segment to the controller line returned minus that schedule, measured in the shell
//! ([`crate::shell::SendTiming`]): wake-up, decode, core and write latency. The controller
//! also stamps each move's arrival; `arrival_*` is that arrival minus the same schedule (the
//! in-memory line and the controller thread's own wake-up added). The *margin* is how long
//! before its start a move arrived (an underrun below the executor's `underrun_margin_us`).
//! `--hog` adds one busy-looping thread, pinned to the other CPU when the shell is pinned
//! (`--pin-cpu`), else free. With `--rt-priority N` the shell loop runs at `SCHED_FIFO` N
//! and the in-process controller (standing for a separate microcontroller) at N − 1; the
//! host thread and the hog keep the normal scheduler.

use std::prelude::rust_2024::*;
pub mod ctrl;
pub mod host;

use crate::clock::{Clock, MonotonicClock};
use crate::endpoint::Endpoint;
use crate::shell::port::{Chunk, PipeReader, PipeWriter};
use crate::shell::rt::{RtApplied, RtOptions, apply, pin_current_thread};
use crate::shell::rt_queue;
use crate::shell::{Shell, ShellOptions, ShellStats};
use crate::{Executor, ExecutorConfig, MemStore};
use crossbeam_channel::bounded;
use mesopush_protocol::LinkConfig;
use mesopush_protocol::host::{ExecToHost, TrialEventKind};
use std::io;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// Plan memory of the bench executor (steps × 12 bytes).
const CAP: usize = 12 * 1024;
/// Look-ahead queue.
const LA: usize = 32;

/// What to run.
#[derive(Debug, Clone, Copy)]
pub struct BenchOptions {
    /// Setpoint rate, Hz (1..=1000).
    pub rate_hz: u32,
    /// Length of the streamed plan, s.
    pub seconds: f64,
    /// Run a busy-looping thread beside the shell.
    pub hog: bool,
    /// Real-time set-up of the shell's loop thread.
    pub rt: RtOptions,
    /// The loop's spin before a send deadline, µs.
    pub spin_us: u64,
}

/// The figures.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct BenchReport {
    /// Setpoint rate, Hz.
    pub rate_hz: u32,
    /// Plan length, s.
    pub seconds: f64,
    /// Whether a busy thread ran.
    pub hog: bool,
    /// Moves the controller received.
    pub segments: u64,
    /// Sends compared with their schedule (the first segment of each loop pass).
    pub timed_sends: u64,
    /// Further segments written in the same pass (the trial's first batch, catch-ups).
    pub batched_sends: u64,
    /// Segments released by a controller status after flow control held them.
    pub flow_released_sends: u64,
    /// Send deviation (write returned − schedule), µs: median.
    pub p50_us: u64,
    /// 99th percentile.
    pub p99_us: u64,
    /// Maximum.
    pub max_us: u64,
    /// Arrival at the in-process controller − schedule, µs: median.
    pub arrival_p50_us: u64,
    /// 99th percentile.
    pub arrival_p99_us: u64,
    /// Maximum.
    pub arrival_max_us: u64,
    /// Smallest time a move arrived before its start, µs (negative: after it).
    pub min_margin_us: i64,
    /// Largest lateness of a shell wake-up past the core's deadline, µs.
    pub shell_max_late_us: u64,
    /// The loop's spin before a send deadline, µs.
    pub spin_us: u64,
    /// Real-time set-up granted (and refused) for the shell's loop thread.
    pub rt: RtApplied,
    /// How the trial ended: `done`, or the executor's fault (e.g. a stream underrun).
    pub trial_end: String,
}

/// Runs the bench in real time (takes `seconds` plus about a second).
pub fn run_bench(opts: BenchOptions) -> io::Result<BenchReport> {
    if !((1..=1000).contains(&opts.rate_hz) && opts.seconds > 0.0 && opts.seconds <= 3600.0) {
        return Err(io::Error::other("rate must be 1..=1000 Hz and seconds in (0, 3600]"));
    }
    let config = ExecutorConfig { setpoint_rate_hz: opts.rate_hz, ..ExecutorConfig::DEFAULT };
    let core = Executor::<_, CAP, LA>::new(config, MemStore::<CAP>::new())
        .map_err(|e| io::Error::other(format!("executor config: {e:?}")))?;
    let mut endpoint = Endpoint::<_, CAP, LA, 48>::new(core, LinkConfig::DEFAULT, 1);
    let clock = Arc::new(MonotonicClock::new());
    let stop = Arc::new(AtomicBool::new(false));
    let [(h_in_tx, h_in_rx), (h_out_tx, h_out_rx), (c_in_tx, c_in_rx), (c_out_tx, c_out_rx)] =
        [(); 4].map(|()| rt_queue::bounded::<Chunk>(4096));
    let steps = host::bench_plan(opts.seconds);
    let expected = (opts.seconds * f64::from(opts.rate_hz)) as usize;
    let ctrl = ctrl::BenchCtrl::new(host::START_NM, expected);
    let (c2, s2) = (clock.clone(), stop.clone());
    // The controller stands for a separate microcontroller: with --rt-priority it runs one
    // below the shell (unpinned), so a loaded host does not starve its replies and reports.
    let ctrl_prio = opts.rt.fifo_priority.map(|p| (p - 1).max(1));
    let ctrl_thread = std::thread::spawn(move || {
        let refused = apply(&RtOptions { fifo_priority: ctrl_prio, ..RtOptions::default() });
        (ctrl.serve(c2, c_out_rx, c_in_tx, s2), refused)
    });
    let hog_cpu = opts.rt.pin_cpu.map(|c| if c == 0 { 1 } else { 0 });
    let hog = opts.hog.then(|| {
        let s = stop.clone();
        std::thread::spawn(move || {
            if let Some(cpu) = hog_cpu {
                let _ = pin_current_thread(cpu);
            }
            let mut n = 0u64;
            while !s.load(Ordering::Relaxed) {
                n = std::hint::black_box(n.wrapping_add(1));
            }
        })
    });
    let (stop_tx, stop_rx) = rt_queue::bounded(1);
    let (log_tx, log_rx) = bounded(1 << 16);
    let give_up = clock.now_us() + ((opts.seconds + 30.0) * 1e6) as u64;
    let c3 = clock.clone();
    let host_thread = std::thread::spawn(move || {
        let r = host::drive(c3, &steps, h_out_rx, h_in_tx, give_up);
        let _ = stop_tx.send(());
        r
    });
    let drain = std::thread::spawn(move || log_rx.iter().count());
    let mut stats = ShellStats::default();
    let (host_line, ctrl_line) = (
        (PipeReader::from(h_in_rx), PipeWriter::from(h_out_tx)),
        (PipeReader::from(c_in_rx), PipeWriter::from(c_out_tx)),
    );
    // The threads above keep the normal scheduler; this one (and its line readers) get the
    // real-time set-up.
    let rt = apply(&opts.rt);
    let lines = (host_line, ctrl_line, None);
    let shell_opts = ShellOptions { spin_us: opts.spin_us };
    Shell::run_with(&mut endpoint, &*clock, lines, log_tx, stop_rx, shell_opts, &mut stats);
    stop.store(true, Ordering::Relaxed);
    let end = host_thread.join().map_err(|_| io::Error::other("host thread panicked"))?;
    let (ctrl, ctrl_rt) =
        ctrl_thread.join().map_err(|_| io::Error::other("controller thread panicked"))?;
    if let Some(h) = hog {
        let _ = h.join();
    }
    let _ = drain.join();
    let end = end.map_err(|e| {
        let last = ctrl.arrivals.last().map(|a| a.segment_id);
        io::Error::other(format!("{e} ({} moves received, last {last:?})", ctrl.arrivals.len()))
    })?;
    let mut rt = rt;
    rt.refused.extend(ctrl_rt.refused.into_iter().map(|r| format!("bench controller: {r}")));
    let mut r = report(opts, &config, &ctrl.arrivals, &stats, rt)?;
    // In words (the JSON is read by people): "done", "aborted", "faulted: <the fault>".
    r.trial_end = match end {
        ExecToHost::Trial(t) => match t.kind {
            TrialEventKind::Done => "done".into(),
            TrialEventKind::Started => "started, never ended".into(),
            TrialEventKind::Aborted => "aborted".into(),
            TrialEventKind::Faulted(f) => format!("faulted: {f}"),
        },
        _ => "ended without a trial event".into(),
    };
    Ok(r)
}

fn report(
    opts: BenchOptions,
    config: &ExecutorConfig,
    arrivals: &[ctrl::Arrival],
    stats: &ShellStats,
    rt: RtApplied,
) -> io::Result<BenchReport> {
    let t = config.setpoint_period_us();
    let horizon_us = u64::from(config.lookahead_segments) * t;
    let mut dev: Vec<u64> = Vec::with_capacity(arrivals.len());
    let mut min_margin_us = i64::MAX;
    // The first segments are all due when the trial starts (the first one went out).
    let streaming_from_us = arrivals.first().map_or(0, |a| a.arrival_us);
    for a in arrivals {
        let due = a.start_us.saturating_sub(horizon_us).max(streaming_from_us);
        dev.push(a.arrival_us.saturating_sub(due));
        min_margin_us = min_margin_us.min(a.start_us as i64 - a.arrival_us as i64);
    }
    if dev.is_empty() {
        return Err(io::Error::other("no move reached the controller"));
    }
    dev.sort_unstable();
    let q = |p: f64| dev[((dev.len() - 1) as f64 * p).round() as usize];
    let sends = &stats.sends;
    Ok(BenchReport {
        rate_hz: opts.rate_hz,
        seconds: opts.seconds,
        hog: opts.hog,
        segments: dev.len() as u64,
        timed_sends: sends.timed,
        batched_sends: sends.batched,
        flow_released_sends: sends.flow_released,
        p50_us: sends.quantile_us(0.5),
        p99_us: sends.quantile_us(0.99),
        max_us: sends.max_us,
        arrival_p50_us: q(0.5),
        arrival_p99_us: q(0.99),
        arrival_max_us: q(1.0),
        min_margin_us,
        shell_max_late_us: stats.max_late_us,
        spin_us: opts.spin_us,
        rt,
        trial_end: String::new(),
    })
}
