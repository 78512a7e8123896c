//! The executor the in-process loops run: the executor crate's allocation-free core and its
//! links ([`Endpoint`]) with the rig's fixed capacities, built one way for the simulated-time
//! and the real-time loop. The link window is the controller's ([`EW`]), so both ends of the
//! line agree.

use crate::Error;
use crate::plant::controller::EW;
use mesopush_executor::endpoint::Endpoint;
use mesopush_executor::{Executor, ExecutorConfig, MemStore};
use mesopush_protocol::LinkConfig;

/// Plan memory of the executor: 4096 steps.
pub const CAP: usize = 12 * 4096;
/// Look-ahead queue.
pub const LA: usize = 32;

/// The in-process executor: core, plan memory, host and controller links.
pub type InProcessEndpoint = Endpoint<MemStore<CAP>, CAP, LA, EW>;

/// An executor with `config` whose links use the session id `session`.
pub fn endpoint(config: ExecutorConfig, session: u16) -> Result<InProcessEndpoint, Error> {
    let core = Executor::new(config, MemStore::new())
        .map_err(|e| Error::invalid("executor config", e.to_string()))?;
    Ok(Endpoint::new(core, LinkConfig::DEFAULT, session))
}
