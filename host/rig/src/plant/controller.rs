//! The simulated motion controller as the rig runs it: the firmware simulator's
//! [`ControllerNode`] with the rig's queue and link sizes and the world's needle limit, built
//! one way for every loop (the simulated-time loop, the real-time loop, the `mesopush-fwsim`
//! process), and what its event log says about the segments it applied.

use crate::Error;
use mesopush_firmware_sim::{
    ControllerNode, CtrlConfig, CtrlEvent, FaultConfig, NodeEvent, SimRng,
};
use mesopush_protocol::LinkConfig;
use mesopush_protocol::units::um_to_nm;

/// Controller queue slots.
pub const Q: usize = 32;
/// Link window of the lines between executor and controller. The in-process executor's
/// links use the same window (the drive module's endpoint takes it from here).
pub const EW: usize = 48;

/// The controller node with the rig's sizes.
pub type Controller = ControllerNode<Q, EW>;

/// A controller with the default configuration and the needle limit `needle_limit_um` (the
/// world model's `probe_deflection_limit_um`: it faults `NeedleOverload` beyond it), the
/// stage at `start_nm` (stage nm) and its clock at `now_us`; `rng` is its seed stream,
/// `faults` what it injects.
pub fn controller(
    faults: FaultConfig,
    rng: SimRng,
    now_us: u64,
    start_nm: (i32, i32),
    needle_limit_um: f64,
) -> Result<Controller, Error> {
    let limit_nm = um_to_nm("model probe_deflection_limit_um", needle_limit_um)?;
    let cfg = CtrlConfig { needle_deflection_limit_nm: Some(limit_nm), ..CtrlConfig::DEFAULT };
    cfg.validate().map_err(|e| Error::invalid("controller", e.to_string()))?;
    let start_nm = (f64::from(start_nm.0), f64::from(start_nm.1));
    Ok(ControllerNode::new(cfg, faults, LinkConfig::DEFAULT, rng, now_us, start_nm))
}

/// Segments a controller node applied, and whether their ids ran consecutively (every move
/// exactly once, in order).
pub fn applied_segments(events: &[(u64, NodeEvent)]) -> (u64, bool) {
    let ids: Vec<u32> = events
        .iter()
        .filter_map(|(_, e)| match e {
            NodeEvent::Ctrl(CtrlEvent::Applied(id)) => Some(*id),
            _ => None,
        })
        .collect();
    let in_order = ids.windows(2).all(|w| w[1] == w[0].wrapping_add(1));
    (u64::try_from(ids.len()).unwrap_or(u64::MAX), in_order)
}
