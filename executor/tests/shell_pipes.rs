//! The shell loop in-process over in-memory pipes: it answers the host, hands log records
//! to the recorder channel, stops on request, and ends when a line closes.
#![cfg(feature = "std")]

use crossbeam_channel::bounded;
use mesopush_executor::clock::MonotonicClock;
use mesopush_executor::endpoint::Endpoint;
use mesopush_executor::shell::port::{ByteRead, ByteWrite, pipe};
use mesopush_executor::shell::rt_queue;
use mesopush_executor::shell::runner::ShellEnd;
use mesopush_executor::shell::{Shell, ShellStats};
use mesopush_executor::{Executor, ExecutorConfig, MemStore};
use mesopush_protocol::host::{ExecToHost, Hello, HostToExec};
use mesopush_protocol::{FRAME_BUF_LEN, FrameReader, Link, LinkConfig, encode_frame};
use std::time::{Duration, Instant};

type Ep = Endpoint<MemStore<1200>, 1200, 16, 32>;

fn endpoint() -> Ep {
    let core = Executor::new(ExecutorConfig::DEFAULT, MemStore::new()).unwrap();
    Endpoint::new(core, LinkConfig::DEFAULT, 1)
}

#[test]
fn answers_the_host_then_stops_on_request_or_when_a_line_closes() {
    let (mut to_exec_host, exec_host_r) = pipe(64);
    let (exec_host_w, mut from_exec_host) = pipe(64);
    let (ctrl_w_test, exec_ctrl_r) = pipe(64);
    let (exec_ctrl_w, mut from_exec_ctrl) = pipe(64);
    let (log_tx, log_rx) = bounded(1024);
    let (stop_tx, stop_rx) = rt_queue::bounded(1);
    let runner = std::thread::spawn(move || {
        let mut ep = endpoint();
        let mut stats = ShellStats::default();
        let clock = MonotonicClock::new();
        let host = (exec_host_r, exec_host_w);
        let ctrl = (exec_ctrl_r, exec_ctrl_w);
        let end = Shell::run(&mut ep, &clock, host, ctrl, None, log_tx, stop_rx, &mut stats);
        (end, stats)
    });
    let mut link: Link<HostToExec, ExecToHost, 8> = Link::new(LinkConfig::DEFAULT, 9);
    link.send(HostToExec::Hello(Hello::CURRENT)).unwrap();
    let start = Instant::now();
    let mut reader = FrameReader::<FRAME_BUF_LEN>::new();
    let (mut buf, mut out) = ([0u8; 64], [0u8; FRAME_BUF_LEN]);
    let mut reply = None;
    while reply.is_none() && start.elapsed() < Duration::from_secs(5) {
        let now = start.elapsed().as_micros() as u64;
        while let Some(frame) = link.poll_transmit(now) {
            to_exec_host.write_bytes(encode_frame(&frame, &mut out).unwrap()).unwrap();
        }
        let n = from_exec_host.read_bytes(&mut buf).unwrap();
        for &b in &buf[..n] {
            if let Some(Ok(f)) = reader.push_byte(b) {
                reply = reply.or(link.on_bytes(now, f));
            }
        }
    }
    assert_eq!(reply, Some(ExecToHost::HelloReply { hello: Hello::CURRENT, accepted: true }));
    // The executor talks to the controller on its own (heartbeats, clock-sync queries).
    let n = from_exec_ctrl.read_bytes(&mut buf).unwrap();
    assert!(n > 0, "nothing sent to the controller");
    stop_tx.send(()).unwrap();
    let (end, stats) = runner.join().unwrap();
    assert!(matches!(end, ShellEnd::Stopped), "{end:?}");
    assert!(stats.iterations > 0 && stats.log_dropped == 0);
    drop(log_rx);
    drop(ctrl_w_test);

    // A closed controller line ends the loop with the reason.
    let (_to_host, exec_host_r) = pipe(8);
    let (exec_host_w, _from_host) = pipe(8);
    let (ctrl_w, exec_ctrl_r) = pipe(8);
    let (exec_ctrl_w, _from_ctrl) = pipe(8);
    drop(ctrl_w);
    let (log_tx, _log_rx) = bounded(16);
    let (_stop_tx, stop_rx) = rt_queue::bounded::<()>(1);
    let mut ep = endpoint();
    let mut stats = ShellStats::default();
    let host = (exec_host_r, exec_host_w);
    let ctrl = (exec_ctrl_r, exec_ctrl_w);
    let clock = MonotonicClock::new();
    let end = Shell::run(&mut ep, &clock, host, ctrl, None, log_tx, stop_rx, &mut stats);
    assert!(matches!(end, ShellEnd::CtrlLine(_)), "{end:?}");
}
