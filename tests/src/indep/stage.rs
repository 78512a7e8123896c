//! The stage between the command and the needle: a periodic lead-screw error in x (a
//! function of the commanded x), then per-axis lost motion (a play operator). Its output is
//! where the needle's centre really is.

use super::effects::Effect;
use crate::coulomb::V2;

/// The stage's state.
#[derive(Debug, Clone, PartialEq)]
pub struct Stage {
    deadband_um: [f64; 2],
    screw: Option<(f64, f64, f64)>,
    out: Option<[f64; 2]>,
}

impl Stage {
    /// A stage with the stage effects of `effect` (others leave it ideal).
    pub fn new(effect: &Effect) -> Self {
        let deadband_um = match *effect {
            Effect::Backlash { deadband_um } => deadband_um,
            _ => [0.0; 2],
        };
        let screw = match *effect {
            Effect::LeadScrew { pitch_um, amplitude_um, phase_rad } => {
                Some((pitch_um, amplitude_um, phase_rad))
            }
            _ => None,
        };
        Self { deadband_um, screw, out: None }
    }

    /// Where the needle is when `cmd` is commanded (the play starts centred on the first
    /// command).
    pub fn position(&mut self, cmd: V2) -> V2 {
        let mut drive = [cmd.x, cmd.y];
        if let Some((pitch, amp, phase)) = self.screw {
            drive[0] += amp * (std::f64::consts::TAU * cmd.x / pitch + phase).sin();
        }
        let out = self.out.get_or_insert(drive);
        for ((o, d), w) in out.iter_mut().zip(drive).zip(self.deadband_um) {
            let half = w / 2.0;
            if d - *o > half {
                *o = d - half;
            } else if *o - d > half {
                *o = d + half;
            }
        }
        V2::new(out[0], out[1])
    }
}
