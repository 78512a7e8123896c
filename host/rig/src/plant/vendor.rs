//! The emulated commercial controllers as the rig runs them ([`Plant`]): the firmware
//! simulator's vendor emulators (written from the vendors' public protocol documentation,
//! independently of the executor's adapters) with the stage at the trial's start, beside
//! the project's own controller node, behind one enum the loops drive.
//!
//! Registration: each emulator's axes are set to run along the stage's (a positive scale);
//! a real manipulator mounted the other way round needs its axes registered before a plan
//! means anything (docs/hardware.md).

use super::controller::Controller;
use crate::Error;
use mesopush_executor::shell::controller::ControllerKind;
use mesopush_firmware_sim::vendor::{
    Card, Mp285, Mp285Settings, Mpc200, Mpc200Settings, Scientifica, ScientificaSettings, Sensapex,
    SensapexSettings, VendorController,
};
use mesopush_firmware_sim::{NodeEvent, PegPose, World};

/// An emulated vendor controller.
pub type Emulator = Box<dyn VendorController + Send>;

/// The controller the world's stage answers to.
#[derive(Debug)]
pub enum Plant {
    /// The project's streaming controller node.
    Native(Box<Controller>),
    /// An emulated commercial controller.
    Vendor(EmulatorBox),
}

/// An emulator with a `Debug` the loops can print.
pub struct EmulatorBox(pub Emulator);

impl std::fmt::Debug for EmulatorBox {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("vendor controller emulator")
    }
}

/// µsteps (or ticks) at `per_um` per µm for a stage position in nm. The emulators are set
/// up in their own units; this is the rig's one conversion into them.
fn units(nm: i32, per_um: i64) -> i64 {
    (i64::from(nm) * per_um).div_euclid(1000)
}

/// The emulator of `kind` with the stage at `start_nm` (stage nm) and its clock at
/// `now_us`; `seed` drives its random quirks.
pub fn emulator(
    kind: ControllerKind,
    start_nm: (i32, i32),
    now_us: u64,
    seed: u64,
) -> Result<Emulator, Error> {
    let (x, y) = start_nm;
    let bad =
        |e: mesopush_firmware_sim::SimError| Error::invalid("controller emulator", e.to_string());
    Ok(match kind {
        ControllerKind::Native => {
            return Err(Error::invalid("controller", "the native controller is not an emulator"));
        }
        ControllerKind::Mpc200 => {
            let start_usteps = [units(x, 16), units(y, 16), 200_000];
            let cfg = Mpc200Settings { start_usteps, seed, ..Mpc200Settings::DEFAULT };
            Box::new(Mpc200::new(cfg, now_us).map_err(bad)?)
        }
        ControllerKind::Mp285 => {
            let start_usteps = [units(x, 25), units(y, 25), 0];
            let cfg = Mp285Settings { start_usteps, ..Mp285Settings::DEFAULT };
            Box::new(Mp285::new(cfg, now_us).map_err(bad)?)
        }
        ControllerKind::Scientifica => {
            let mut cfg = ScientificaSettings::patchstar(Card::V3);
            cfg.start_nm = [i64::from(x), i64::from(y), 0];
            cfg.default_scale = [1600.0; 3]; // registered: axes along the stage's
            Box::new(Scientifica::new(cfg, now_us).map_err(bad)?)
        }
        ControllerKind::Sensapex => {
            let start_nm = [i64::from(x), i64::from(y), 0, 0];
            let cfg = SensapexSettings { start_nm, ..SensapexSettings::DEFAULT };
            Box::new(Sensapex::new(cfg, now_us).map_err(bad)?)
        }
    })
}

impl Plant {
    /// Bytes (or a datagram) from the executor.
    pub fn on_bytes(&mut self, now_us: u64, bytes: &[u8]) {
        match self {
            Self::Native(n) => n.on_bytes(now_us, bytes),
            Self::Vendor(v) => v.0.receive(now_us, bytes),
        }
    }

    /// Time passes.
    pub fn tick(&mut self, now_us: u64) {
        match self {
            Self::Native(n) => n.tick(now_us),
            Self::Vendor(v) => v.0.poll(now_us),
        }
    }

    /// The next bytes (or datagram) for the executor.
    pub fn transmit<'b>(&mut self, now_us: u64, buf: &'b mut [u8]) -> Option<&'b [u8]> {
        match self {
            Self::Native(n) => n.transmit(now_us, buf),
            Self::Vendor(v) => {
                let n = v.0.transmit(now_us, buf)?;
                Some(&buf[..n])
            }
        }
    }

    /// Moves the world to the stage's true position at `now_us` and returns the peg's pose.
    /// The native controller also senses the needle's deflection the world reports (and
    /// faults beyond its limit); the commercial controllers have no such sensor.
    pub fn step_world<W: World>(&mut self, now_us: u64, world: &mut W) -> PegPose {
        match self {
            Self::Native(n) => n.step_world(now_us, world),
            Self::Vendor(v) => world.step(now_us, v.0.probe_nm()),
        }
    }

    /// The stage's true position, nm.
    pub fn probe_nm(&self) -> (i32, i32) {
        match self {
            Self::Native(n) => n.probe_nm(),
            Self::Vendor(v) => v.0.probe_nm(),
        }
    }

    /// The native node's event log (an emulator keeps none).
    pub fn events(&self) -> &[(u64, NodeEvent)] {
        match self {
            Self::Native(n) => &n.events,
            Self::Vendor(_) => &[],
        }
    }
}
