//! Rig commands between trials against a running `mesopush-executor` (`mesopush rig`):
//! [`status`], [`goto`], [`home`], [`stop`]. Each opens the executor's host line, sends one
//! command through a [`HostSession`] and returns its answer; a goto waits until the probe
//! is there (or the move stopped or faulted). Positions cross the wire in the stage frame;
//! [`Registration`] converts to and from the fixture frame plans are written in.

use super::hostlink::{HostPort, drive, fresh_session_id};
use super::session::{HostSession, RigCommand, SessionEnd};
use crate::Error;
use mesopush_core::geom::Vec2;
use mesopush_protocol::host::{ExecStatus, MotionEventKind, StagePoint};
use mesopush_protocol::units::{nm_to_um, um_to_nm};
use std::time::Duration;

/// Longest wait for a status or stop answer.
pub const COMMAND_TIMEOUT: Duration = Duration::from_secs(10);

/// The stage registration: the fixture frame's origin in stage coordinates, µm (a world
/// file's `[stage] offset_um`; the executor's `--fixture-origin-um`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Registration {
    /// Fixture origin in stage coordinates, µm.
    pub fixture_origin_um: Vec2,
}

impl Registration {
    /// A fixture-frame point in the stage frame, nm (refused, naming it, when it does not
    /// fit the wire).
    pub fn to_stage(&self, fixture_um: Vec2) -> Result<StagePoint, Error> {
        let p = fixture_um + self.fixture_origin_um;
        Ok(StagePoint { x_nm: um_to_nm("target x", p.x)?, y_nm: um_to_nm("target y", p.y)? })
    }

    /// A stage-frame point in the fixture frame, µm.
    pub fn to_fixture(&self, stage: StagePoint) -> Vec2 {
        stage_um(stage) - self.fixture_origin_um
    }
}

/// A stage point in µm.
pub fn stage_um(p: StagePoint) -> Vec2 {
    Vec2::new(nm_to_um(p.x_nm), nm_to_um(p.y_nm))
}

/// Runs `command` on the executor at `addr`, waiting at most `timeout` for its end.
fn command(addr: &str, command: RigCommand, timeout: Duration) -> Result<SessionEnd, Error> {
    let mut port = HostPort::open(addr)?;
    let mut session = HostSession::command(command, fresh_session_id());
    let end = drive(&mut session, &mut port, addr, timeout, &mut |_, _| {})?;
    match end {
        SessionEnd::Rejected(r) => Err(Error::invalid("rig", format!("command refused: {r}"))),
        SessionEnd::Refused(r) => Err(Error::invalid("rig", r)),
        end => Ok(end),
    }
}

fn expect_status(end: SessionEnd) -> Result<ExecStatus, Error> {
    match end {
        SessionEnd::Status(s) => Ok(s),
        other => Err(Error::invalid("rig", format!("unexpected answer: {other}"))),
    }
}

fn expect_motion(end: SessionEnd) -> Result<MotionEventKind, Error> {
    match end {
        SessionEnd::Motion(m) => Ok(m),
        other => Err(Error::invalid("rig", format!("unexpected answer: {other}"))),
    }
}

/// The executor's status: state, plan, absolute probe position, controller state, last
/// fault.
pub fn status(addr: &str) -> Result<ExecStatus, Error> {
    expect_status(command(addr, RigCommand::Status, COMMAND_TIMEOUT)?)
}

/// Stops the probe now (a running trial ends aborted, a goto stopped); the status after.
pub fn stop(addr: &str) -> Result<ExecStatus, Error> {
    expect_status(command(addr, RigCommand::Stop, COMMAND_TIMEOUT)?)
}

/// Moves the probe to `target` (stage frame) and waits up to `timeout` for the end:
/// `Arrived`, `Stopped` (another host's `stop`) or `Faulted`.
pub fn goto(addr: &str, target: StagePoint, timeout: Duration) -> Result<MotionEventKind, Error> {
    expect_motion(command(addr, RigCommand::Goto(target), timeout)?)
}

/// Moves the probe to the executor's home position, as [`goto`].
pub fn home(addr: &str, timeout: Duration) -> Result<MotionEventKind, Error> {
    expect_motion(command(addr, RigCommand::Home, timeout)?)
}
