//! Optional real-time set-up of the shell's loop thread (Linux): lock memory (`mlockall`),
//! `SCHED_FIFO` priority, pinning to one CPU. Each step fails soft: when the OS refuses
//! (no `CAP_SYS_NICE`, a CPU that does not exist, a memlock limit) the shell runs without it
//! and the refusal is reported, never fatal. Threads the loop thread spawns afterwards (the
//! line readers) inherit its policy and CPU set, as Linux threads do; a helper that must not
//! (the log forwarder) calls [`leave_real_time`]. Threads of different scheduling classes
//! exchange data only through [`super::rt_queue`] (its note says why).
//!
//! The only `unsafe` of the shell: a few libc calls with no safe wrapper in our
//! dependencies (`rustix` has none for `pthread_setschedparam`).
#![allow(unsafe_code)]

use crate::error::{ExecError, RtCause, RtStep};
use std::format;
use std::string::{String, ToString};
use std::vec::Vec;

/// What to ask for.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RtOptions {
    /// `SCHED_FIFO` priority (1..=99); `None` leaves the normal scheduler.
    pub fifo_priority: Option<i32>,
    /// CPU to pin the calling thread to; `None` leaves it free.
    pub pin_cpu: Option<usize>,
    /// Lock current and future memory (no page faults in the loop).
    pub lock_memory: bool,
}

/// What was granted, and why not where not.
#[derive(Debug, Clone, Default, PartialEq, Eq, serde::Serialize)]
pub struct RtApplied {
    /// `SCHED_FIFO` priority in effect.
    pub fifo_priority: Option<i32>,
    /// CPU the thread is pinned to.
    pub pinned_cpu: Option<usize>,
    /// Whether memory is locked.
    pub memory_locked: bool,
    /// One message per refused step.
    pub refused: Vec<String>,
}

/// Applies `opts` to the calling thread (and memory to the process).
pub fn apply(opts: &RtOptions) -> RtApplied {
    let mut applied = RtApplied::default();
    if opts.lock_memory {
        match lock_memory() {
            Ok(()) => applied.memory_locked = true,
            Err(e) => applied.refused.push(describe(&e)),
        }
    }
    if let Some(cpu) = opts.pin_cpu {
        match pin_current_thread(cpu) {
            Ok(()) => applied.pinned_cpu = Some(cpu),
            Err(e) => applied.refused.push(describe(&e)),
        }
    }
    if let Some(prio) = opts.fifo_priority {
        match set_fifo_priority(prio) {
            Ok(()) => applied.fifo_priority = Some(prio),
            Err(e) => applied.refused.push(describe(&e)),
        }
    }
    applied
}

/// A refusal in words, with the OS's own text for its error codes.
pub fn describe(e: &ExecError) -> String {
    match e {
        ExecError::RealTime { step, cause: RtCause::Os(errno) } => {
            format!("{step}: {}", std::io::Error::from_raw_os_error(*errno))
        }
        other => other.to_string(),
    }
}

fn refused(step: RtStep, cause: RtCause) -> ExecError {
    ExecError::RealTime { step, cause }
}

#[cfg(target_os = "linux")]
fn last_os_error(step: RtStep) -> ExecError {
    refused(step, RtCause::Os(std::io::Error::last_os_error().raw_os_error().unwrap_or(0)))
}

#[cfg(target_os = "linux")]
fn lock_memory() -> Result<(), ExecError> {
    // SAFETY: plain system call without pointers.
    let rc = unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) };
    if rc == 0 { Ok(()) } else { Err(last_os_error(RtStep::LockMemory)) }
}

/// Pins the calling thread to `cpu`.
#[cfg(target_os = "linux")]
pub fn pin_current_thread(cpu: usize) -> Result<(), ExecError> {
    if cpu >= libc::CPU_SETSIZE as usize {
        return Err(refused(RtStep::PinCpu { cpu }, RtCause::OutOfRange { allowed: "0..1024" }));
    }
    // SAFETY: `set` is a plain bit set initialised by CPU_ZERO; pid 0 is the calling thread.
    let rc = unsafe {
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        libc::CPU_ZERO(&mut set);
        libc::CPU_SET(cpu, &mut set);
        libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set)
    };
    if rc == 0 { Ok(()) } else { Err(last_os_error(RtStep::PinCpu { cpu })) }
}

#[cfg(target_os = "linux")]
fn set_fifo_priority(prio: i32) -> Result<(), ExecError> {
    let step = RtStep::FifoPriority { priority: prio };
    if !(1..=99).contains(&prio) {
        return Err(refused(step, RtCause::OutOfRange { allowed: "1..=99" }));
    }
    let param = libc::sched_param { sched_priority: prio };
    // SAFETY: `param` outlives the call; pthread_self is the calling thread.
    let rc = unsafe { libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_FIFO, &param) };
    if rc == 0 { Ok(()) } else { Err(refused(step, RtCause::Os(rc))) }
}

/// Returns the calling thread to the normal scheduler and lets it run on any CPU: for the
/// helper threads the loop spawns that must not inherit its real-time set-up (a normal
/// thread's work must never take the loop's CPU at the loop's priority). Best effort: a
/// refusal leaves the thread as it was.
#[cfg(target_os = "linux")]
pub fn leave_real_time() {
    let param = libc::sched_param { sched_priority: 0 };
    // SAFETY: `param` and `set` outlive the calls; pthread_self / pid 0 are the calling
    // thread; `set` is a plain bit set (every CPU; the kernel keeps those the process may use).
    unsafe {
        let _ = libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_OTHER, &param);
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        for cpu in 0..libc::CPU_SETSIZE as usize {
            libc::CPU_SET(cpu, &mut set);
        }
        let _ = libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set);
    }
}

/// Nothing to undo where the set-up is not supported.
#[cfg(not(target_os = "linux"))]
pub fn leave_real_time() {}

#[cfg(not(target_os = "linux"))]
fn lock_memory() -> Result<(), ExecError> {
    Err(refused(RtStep::LockMemory, RtCause::Unsupported))
}

/// Pins the calling thread to `cpu` (Linux only).
#[cfg(not(target_os = "linux"))]
pub fn pin_current_thread(cpu: usize) -> Result<(), ExecError> {
    Err(refused(RtStep::PinCpu { cpu }, RtCause::Unsupported))
}

#[cfg(not(target_os = "linux"))]
fn set_fifo_priority(priority: i32) -> Result<(), ExecError> {
    Err(refused(RtStep::FifoPriority { priority }, RtCause::Unsupported))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_requests_are_refused_with_a_reason_not_a_panic() {
        let opts = RtOptions { fifo_priority: Some(0), pin_cpu: Some(100_000), lock_memory: false };
        let a = std::thread::spawn(move || apply(&opts)).join().unwrap();
        assert_eq!((a.fifo_priority, a.pinned_cpu), (None, None));
        assert_eq!(a.refused.len(), 2, "{:?}", a.refused);
        assert!(a.refused[0].contains("CPU 100000"), "{:?}", a.refused);
        assert!(a.refused[1].contains("1..=99"), "{:?}", a.refused);
    }
}
