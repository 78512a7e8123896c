//! The needle's safety limit in a replay: the probe deflection (compliance × contact force)
//! may not exceed the model's [`crate::Model::probe_deflection_limit_um`]. A replay watches
//! every step ([`NeedleWatch`]) and reports the peak and, when the limit was exceeded, an
//! [`Overload`]: the replay's verdict is then "overloaded", never "inserted", whatever
//! the peg's final pose.
//!
//! A jam (the simulator finds the peg wedged and stops the probe for the rest of the move)
//! bends the needle too: the stage goes on to the move's end while the tip stays, so the
//! deflection at the jam grows by the travel left in the move, as the rig's world measures
//! it (commanded tip − tip). The force is then the bent needle's, deflection / compliance.

use serde::Serialize;

/// A replay bent the needle beyond its limit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Overload {
    /// The limit, µm.
    pub limit_um: f64,
    /// Move (0-based) during which the deflection first exceeded the limit.
    pub first_move_index: usize,
    /// Time of that step, s since the plan started.
    pub first_t_s: f64,
    /// Largest deflection over the replay, µm.
    pub peak_deflection_um: f64,
    /// Move (0-based) of the largest deflection.
    pub peak_move_index: usize,
    /// Probe force at the largest deflection, part weights (after a jam: the bent needle's,
    /// deflection / compliance).
    pub peak_force_weights: f64,
    /// Whether the largest deflection came from a jam (the peg wedged, the stage went on).
    pub peak_at_jam: bool,
}

impl std::fmt::Display for Overload {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (move_no, peak, limit) =
            (self.peak_move_index + 1, self.peak_deflection_um, self.limit_um);
        write!(f, "needle overload at move {move_no}: {peak:.0} µm > {limit:.0} µm (")?;
        if self.peak_at_jam {
            f.write_str("the peg wedged and the stage went on while the tip stayed")?;
        } else {
            write!(f, "probe force {:.0} part weights", self.peak_force_weights)?;
        }
        write!(
            f,
            "; the limit was first exceeded in move {}, t = {:.2} s): the plan pushes the peg \
             against something that does not give — do not run it on a rig; re-plan, or \
             raise probe_deflection_limit_um in the model only if the needle really bends \
             that far elastically",
            self.first_move_index + 1,
            self.first_t_s
        )
    }
}

/// The peak deflection and force of a replay so far, and its overload when it had one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NeedleWatch {
    limit_um: f64,
    peak_deflection_um: f64,
    peak_force_weights: f64,
    peak_move_index: usize,
    peak_at_jam: bool,
    max_force_weights: f64,
    last_deflection_um: f64,
    first: Option<(usize, f64)>,
}

impl NeedleWatch {
    /// Watching against `limit_um`.
    pub fn new(limit_um: f64) -> Self {
        Self {
            limit_um,
            peak_deflection_um: 0.0,
            peak_force_weights: 0.0,
            peak_move_index: 0,
            peak_at_jam: false,
            max_force_weights: 0.0,
            last_deflection_um: 0.0,
            first: None,
        }
    }

    /// Notes one step of move `move_index` at `t_s`: its deflection, µm, and probe force,
    /// part weights. Exceeding means strictly above the limit.
    pub fn note(&mut self, move_index: usize, t_s: f64, deflection_um: f64, force_weights: f64) {
        self.max_force_weights = self.max_force_weights.max(force_weights);
        self.last_deflection_um = deflection_um;
        if deflection_um > self.peak_deflection_um {
            self.peak_deflection_um = deflection_um;
            self.peak_force_weights = force_weights;
            self.peak_move_index = move_index;
            self.peak_at_jam = false;
        }
        if deflection_um > self.limit_um && self.first.is_none() {
            self.first = Some((move_index, t_s));
        }
    }

    /// Notes a jam in move `move_index` at `t_s` with `remaining_um` of the move's travel left:
    /// the needle, pressed by the last step's deflection, bends by that travel more, under
    /// deflection / `compliance_um_per_weight` part weights (infinite for a rigid probe).
    pub fn note_jam(
        &mut self,
        move_index: usize,
        t_s: f64,
        remaining_um: f64,
        compliance_um_per_weight: f64,
    ) {
        let bent_um = self.last_deflection_um + remaining_um.max(0.0);
        let peak_before = self.peak_deflection_um;
        self.note(move_index, t_s, bent_um, bent_um / compliance_um_per_weight);
        self.peak_at_jam |= self.peak_deflection_um > peak_before;
    }

    /// Largest deflection so far, µm.
    pub fn peak_deflection_um(&self) -> f64 {
        self.peak_deflection_um
    }

    /// Largest probe force so far, part weights.
    pub fn max_force_weights(&self) -> f64 {
        self.max_force_weights
    }

    /// The overload, when the limit was exceeded.
    pub fn overload(&self) -> Option<Overload> {
        self.first.map(|(first_move_index, first_t_s)| Overload {
            limit_um: self.limit_um,
            first_move_index,
            first_t_s,
            peak_deflection_um: self.peak_deflection_um,
            peak_move_index: self.peak_move_index,
            peak_force_weights: self.peak_force_weights,
            peak_at_jam: self.peak_at_jam,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_limit_itself_is_no_overload_and_anything_above_is() {
        let mut w = NeedleWatch::new(50.0);
        w.note(0, 0.1, 49.0, 98.0);
        w.note(1, 0.2, 50.0, 100.0);
        assert_eq!(w.overload(), None, "at the limit the needle is still within it");
        w.note(2, 0.3, 50.5, 101.0);
        w.note(3, 0.4, 296.0, 592.0);
        w.note(4, 0.5, 10.0, 20.0);
        let o = w.overload().expect("above the limit");
        assert_eq!((o.first_move_index, o.first_t_s), (2, 0.3));
        assert_eq!(
            (o.peak_move_index, o.peak_deflection_um, o.peak_force_weights),
            (3, 296.0, 592.0)
        );
        assert!(o.to_string().starts_with("needle overload at move 4: 296 µm > 50 µm"), "{o}");
    }

    #[test]
    fn a_jam_bends_the_needle_by_the_travel_left_in_the_move() {
        let mut w = NeedleWatch::new(50.0);
        w.note(0, 1.0, 4.0, 8.0);
        w.note_jam(0, 1.1, 30.0, 0.5);
        assert_eq!(w.overload(), None, "4 + 30 µm is within 50 µm");
        assert_eq!((w.peak_deflection_um(), w.max_force_weights()), (34.0, 68.0));
        w.note(1, 2.0, 0.0, 0.0);
        w.note_jam(1, 2.5, 60.0, 0.5);
        let o = w.overload().expect("60 µm left in the move");
        assert_eq!(
            (o.first_move_index, o.peak_deflection_um, o.peak_force_weights),
            (1, 60.0, 120.0)
        );
        assert!(o.peak_at_jam && o.to_string().contains("the peg wedged"), "{o}");
    }
}
