//! The executor the in-process loops run: the executor crate's allocation-free core and its
//! links ([`Endpoint`]) with the rig's fixed capacities, built one way for the simulated-time
//! and the real-time loop. The link window is the controller's ([`EW`]), so both ends of the
//! line agree. The controller behind it is chosen per trial ([`ControllerKind`]): the
//! project's streaming controller, or a point-to-point one through its adapter
//! ([`ExecEndpoint`]), which then receives one segment per plan step.

use crate::Error;
use crate::plant::controller::EW;
use mesopush_executor::adapter::p2p::Protocol;
use mesopush_executor::adapter::p2p::driver::{P2pSettings, PointToPointAdapter};
use mesopush_executor::adapter::p2p::mp285::Mp285;
use mesopush_executor::adapter::p2p::mpc200::Mpc200;
use mesopush_executor::adapter::p2p::scientifica::Scientifica;
use mesopush_executor::adapter::p2p::sensapex::{Sensapex, SensapexSettings};
use mesopush_executor::endpoint::Endpoint;
use mesopush_executor::shell::controller::ControllerKind;
use mesopush_executor::{ExecError, Executor, ExecutorConfig, LogEvent, MemStore, Segmenting};
use mesopush_protocol::{LinkConfig, LinkStats};

/// Plan memory of the executor: 4096 steps.
pub const CAP: usize = 12 * 4096;
/// Look-ahead queue.
pub const LA: usize = 32;

/// The in-process executor: core, plan memory, host and controller links.
pub type InProcessEndpoint = Endpoint<MemStore<CAP>, CAP, LA, EW>;

/// The in-process executor with a point-to-point adapter speaking `P`.
pub type P2pEndpoint<P> = Endpoint<MemStore<CAP>, CAP, LA, EW, PointToPointAdapter<P, LA>>;

/// The in-process executor with the controller chosen for the trial.
#[derive(Debug)]
pub enum ExecEndpoint {
    /// The project's streaming controller.
    Native(Box<InProcessEndpoint>),
    /// A Sutter MPC-200.
    Mpc200(Box<P2pEndpoint<Mpc200>>),
    /// A Sutter MP-285.
    Mp285(Box<P2pEndpoint<Mp285>>),
    /// A Scientifica motion card.
    Scientifica(Box<P2pEndpoint<Scientifica>>),
    /// A Sensapex uMp.
    Sensapex(Box<P2pEndpoint<Sensapex>>),
}

/// An executor with `config` whose links use the session id `session`.
pub fn endpoint(config: ExecutorConfig, session: u16) -> Result<InProcessEndpoint, Error> {
    Ok(Endpoint::new(core(config)?, LinkConfig::DEFAULT, session))
}

fn core(config: ExecutorConfig) -> Result<Executor<MemStore<CAP>, CAP, LA>, Error> {
    Executor::new(config, MemStore::new())
        .map_err(|e| Error::invalid("executor config", e.to_string()))
}

/// The executor for `kind`: point-to-point controllers get plan steps whole.
pub fn endpoint_for(
    kind: ControllerKind,
    mut config: ExecutorConfig,
    session: u16,
) -> Result<ExecEndpoint, Error> {
    if kind.point_to_point() {
        config.segmenting = Segmenting::PlanSteps;
    }
    Ok(match kind {
        ControllerKind::Native => ExecEndpoint::Native(Box::new(endpoint(config, session)?)),
        ControllerKind::Mpc200 => ExecEndpoint::Mpc200(p2p(config, session, Mpc200::new())?),
        ControllerKind::Mp285 => ExecEndpoint::Mp285(p2p(config, session, Mp285::new())?),
        ControllerKind::Scientifica => {
            ExecEndpoint::Scientifica(p2p(config, session, Scientifica::new())?)
        }
        ControllerKind::Sensapex => {
            let proto = Sensapex::new(SensapexSettings::DEFAULT);
            ExecEndpoint::Sensapex(p2p(config, session, proto)?)
        }
    })
}

fn p2p<P: Protocol>(
    config: ExecutorConfig,
    session: u16,
    proto: P,
) -> Result<Box<P2pEndpoint<P>>, Error> {
    let adapter = PointToPointAdapter::new(proto, P2pSettings::DEFAULT);
    Ok(Box::new(Endpoint::with_adapter(core(config)?, LinkConfig::DEFAULT, session, adapter)))
}

/// The same call on whichever endpoint it is.
macro_rules! each {
    ($self:expr, $ep:ident => $body:expr) => {
        match $self {
            ExecEndpoint::Native($ep) => $body,
            ExecEndpoint::Mpc200($ep) => $body,
            ExecEndpoint::Mp285($ep) => $body,
            ExecEndpoint::Scientifica($ep) => $body,
            ExecEndpoint::Sensapex($ep) => $body,
        }
    };
}

type Log<'a> = &'a mut dyn FnMut(&LogEvent);

impl ExecEndpoint {
    /// Bytes from the controller.
    pub fn on_ctrl_bytes(&mut self, now: u64, b: &[u8], log: Log<'_>) -> Result<(), ExecError> {
        each!(self, ep => ep.on_ctrl_bytes(now, b, &mut |e| log(e)))
    }

    /// Bytes from the host.
    pub fn on_host_bytes(&mut self, now: u64, b: &[u8], log: Log<'_>) -> Result<(), ExecError> {
        each!(self, ep => ep.on_host_bytes(now, b, &mut |e| log(e)))
    }

    /// A camera frame.
    pub fn on_frame(
        &mut self,
        now: u64,
        frame: mesopush_executor::CameraFrame,
        log: Log<'_>,
    ) -> Result<(), ExecError> {
        each!(self, ep => ep.on_frame(now, frame, &mut |e| log(e)))
    }

    /// Timers.
    pub fn poll(&mut self, now: u64, log: Log<'_>) -> Result<(), ExecError> {
        each!(self, ep => ep.poll(now, &mut |e| log(e)))
    }

    /// The next bytes for the controller.
    pub fn transmit_ctrl<'b>(&mut self, now: u64, buf: &'b mut [u8]) -> Option<&'b [u8]> {
        each!(self, ep => ep.transmit_ctrl(now, buf))
    }

    /// The next frame for the host.
    pub fn transmit_host<'b>(&mut self, now: u64, buf: &'b mut [u8]) -> Option<&'b [u8]> {
        each!(self, ep => ep.transmit_host(now, buf))
    }

    /// The host link's statistics.
    pub fn host_link_stats(&self) -> LinkStats {
        each!(self, ep => ep.host_link().stats())
    }

    /// Moves a point-to-point controller completed (checked at their targets); `None` for
    /// the native controller, whose node counts the segments it applied.
    pub fn moves_done(&self) -> Option<u64> {
        match self {
            Self::Native(_) => None,
            _ => Some(each!(self, ep => ep.adapter_stats().moves_done)),
        }
    }

    /// The controller link's statistics (the native link's; a point-to-point controller's
    /// line has no link layer: zero).
    pub fn ctrl_link_stats(&self) -> LinkStats {
        match self {
            Self::Native(ep) => ep.ctrl_link().stats(),
            _ => LinkStats::default(),
        }
    }
}
