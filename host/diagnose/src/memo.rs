//! A memo of what a diagnosis computes from one trial again and again. Its fits evaluate
//! the same model on the same trial many times over (a simplex's proposals clamped onto the
//! same bound, the vertex a simplex or Levenberg–Marquardt run starts from, a fit's final
//! score, the held-out check of the winner: a sixth of all evaluations on the independent
//! batches), and a replay is nearly the whole cost of one; the trial's own geometry (where
//! its replays restart, where its imaged tip is free of the peg) is the same at every
//! evaluation. So the last few hundred results are kept.
//!
//! Keys are content, compared bit for bit, never addresses: the trial's every field (its
//! floats by their bits) and a text key the caller builds from everything else the value
//! depends on ([`model_key`]: the `Debug` text of the model and the settings, which spells
//! every float exactly, −0, ∞ and NaN included). A hit therefore returns exactly what the
//! computation would, and a changed trial or model can never see a stale value. Only
//! successes are kept. Bounded: at most [`CAPACITY`] values (the oldest go first) and
//! [`TRIALS`] trials (past that the memo starts afresh).

use super::data::{Measured, TrialData};
use mesopush_sim::{Model, ProbePoint, SimSettings};
use std::any::Any;
use std::collections::{HashMap, VecDeque};
use std::sync::{Arc, LazyLock, Mutex};

/// Values kept (a six-trial batch's predictions of about sixty evaluations: every repeat a
/// diagnosis makes lies within that distance of the first, bar a few).
pub const CAPACITY: usize = 384;

/// Trials kept.
pub const TRIALS: usize = 32;

type Value = Arc<dyn Any + Send + Sync>;

#[derive(Default)]
struct Memo {
    trials: Vec<Arc<TrialData>>,
    values: HashMap<(usize, String), Value>,
    order: VecDeque<(usize, String)>,
}

static MEMO: LazyLock<Mutex<Memo>> = LazyLock::new(|| Mutex::new(Memo::default()));

/// The text key of a value that depends on `model` and `settings` (and the trial): `what`
/// names the computation.
pub fn model_key(what: &str, model: &Model, settings: &SimSettings) -> String {
    format!("{what} {model:?} {settings:?}")
}

/// The value `compute` gives for `data` under `key`, computed once while it is kept; an
/// error is passed on and not kept.
pub fn cached<T: Send + Sync + 'static, E>(
    data: &TrialData,
    key: &str,
    compute: impl FnOnce() -> Result<T, E>,
) -> Result<Arc<T>, E> {
    cached_in(&MEMO, data, key, compute)
}

fn cached_in<T: Send + Sync + 'static, E>(
    memo: &Mutex<Memo>,
    data: &TrialData,
    key: &str,
    compute: impl FnOnce() -> Result<T, E>,
) -> Result<Arc<T>, E> {
    let lock = || memo.lock().unwrap_or_else(|e| e.into_inner());
    let slot = {
        let mut memo = lock();
        let slot = memo.slot(data);
        if let Some(v) = memo.values.get(&(slot, key.to_owned()))
            && let Ok(v) = Arc::clone(v).downcast::<T>()
        {
            return Ok(v);
        }
        slot
    };
    let v = Arc::new(compute()?);
    let mut memo = lock();
    // The memo may have started afresh meanwhile: then the trial's slot is another.
    if memo.trials.get(slot).is_some_and(|t| same_trial(t, data)) {
        memo.insert((slot, key.to_owned()), v.clone());
    }
    Ok(v)
}

impl Memo {
    /// The slot of `data` in the trial table, added if new (the table starts afresh when
    /// full).
    fn slot(&mut self, data: &TrialData) -> usize {
        if let Some(i) = self.trials.iter().position(|t| same_trial(t, data)) {
            return i;
        }
        if self.trials.len() == TRIALS {
            *self = Memo::default();
        }
        self.trials.push(Arc::new(data.clone()));
        self.trials.len() - 1
    }

    fn insert(&mut self, key: (usize, String), v: Value) {
        if self.values.contains_key(&key) {
            return;
        }
        if self.order.len() == CAPACITY
            && let Some(old) = self.order.pop_front()
        {
            self.values.remove(&old);
        }
        self.order.push_back(key.clone());
        self.values.insert(key, v);
    }
}

fn same_f64(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

fn same_points(a: &[ProbePoint], b: &[ProbePoint]) -> bool {
    let bits =
        |p: &ProbePoint| [p.t_s, p.probe_um.x, p.probe_um.y, p.probe_theta_rad].map(f64::to_bits);
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| bits(x) == bits(y))
}

fn same_frames(a: &[Measured], b: &[Measured]) -> bool {
    let bits = |m: &Measured| {
        let tip = m.tip_um.map(|t| [t.x.to_bits(), t.y.to_bits()]);
        ([m.t_s, m.pose.x_um, m.pose.y_um, m.pose.theta_rad].map(f64::to_bits), tip)
    };
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| bits(x) == bits(y))
}

/// Whether two trials are the same bit for bit (the cheap fields first; the part, pusher
/// and fixture by their `Debug` text, exact for floats).
fn same_trial(a: &TrialData, b: &TrialData) -> bool {
    a.id == b.id
        && a.index == b.index
        && a.pose_rows_dropped == b.pose_rows_dropped
        && a.probe_radius_um.to_bits() == b.probe_radius_um.to_bits()
        && a.registration_tol_um.map(f64::to_bits) == b.registration_tol_um.map(f64::to_bits)
        && same_f64(&a.log_gaps_s, &b.log_gaps_s)
        && same_points(&a.cmd, &b.cmd)
        && same_frames(&a.frames, &b.frames)
        && format!("{:?}", (&a.part, &a.pusher, &a.fixture))
            == format!("{:?}", (&b.part, &b.pusher, &b.fixture))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::open_plate;
    use mesopush_core::geom::{Pose, Vec2};
    use std::sync::atomic::{AtomicUsize, Ordering};

    fn trial(id: &str) -> TrialData {
        let frames = (0..10)
            .map(|k| Measured {
                t_s: k as f64 / 30.0,
                pose: Pose::new(1000.0, 800.0, 0.1),
                tip_um: None,
            })
            .collect();
        TrialData {
            id: id.into(),
            index: 0,
            part: Model::default().part,
            probe_radius_um: 12.5,
            pusher: mesopush_sim::Pusher::single(12.5),
            registration_tol_um: None,
            pose_rows_dropped: 0,
            log_gaps_s: Vec::new(),
            fixture: open_plate(),
            cmd: vec![ProbePoint::new(0.0, Vec2::new(0.0, 0.0)), ProbePoint::new(1.0, Vec2::x())],
            frames,
            start_sensitivity: None,
        }
    }

    /// A value is computed once per trial content and key; a trial that differs in one bit
    /// of one frame (−0 for +0), or another key, computes afresh; errors are not kept.
    #[test]
    fn a_value_is_kept_per_bitwise_trial_content_and_key() {
        let (memo, calls) = (Mutex::new(Memo::default()), AtomicUsize::new(0));
        let get = |t: &TrialData, key: &str| {
            cached_in(&memo, t, key, || {
                calls.fetch_add(1, Ordering::SeqCst);
                Ok::<_, ()>(t.frames[0].pose.x_um.to_bits())
            })
            .unwrap()
        };
        let a = trial("memo-test-a");
        let mut b = a.clone();
        b.frames[3].pose.y_um = 0.0;
        let mut c = b.clone();
        c.frames[3].pose.y_um = -0.0;
        assert_eq!(*get(&a, "k"), 1000f64.to_bits());
        get(&a.clone(), "k");
        assert_eq!(calls.load(Ordering::SeqCst), 1, "same content: kept");
        get(&b, "k");
        get(&c, "k");
        get(&a, "other");
        assert_eq!(calls.load(Ordering::SeqCst), 4, "other content or key: computed");
        let failing = cached_in(&memo, &a, "fails", || Err::<u64, _>("no"));
        assert!(failing.is_err());
        assert_eq!(*cached_in(&memo, &a, "fails", || Ok::<_, ()>(7u64)).unwrap(), 7);
    }

    /// At most CAPACITY values are kept, the oldest going first; past TRIALS trials the memo
    /// starts afresh.
    #[test]
    fn the_memo_is_bounded() {
        let (memo, calls) = (Mutex::new(Memo::default()), AtomicUsize::new(0));
        let get = |t: &TrialData, key: &str| {
            cached_in(&memo, t, key, || Ok::<_, ()>(calls.fetch_add(1, Ordering::SeqCst))).unwrap()
        };
        let a = trial("memo-test-bounds");
        for k in 0..=CAPACITY {
            get(&a, &k.to_string());
        }
        get(&a, &CAPACITY.to_string());
        assert_eq!(calls.load(Ordering::SeqCst), CAPACITY + 1, "the newest are kept");
        get(&a, "0");
        assert_eq!(calls.load(Ordering::SeqCst), CAPACITY + 2, "the oldest went");
        for i in 0..TRIALS {
            get(&trial(&format!("memo-test-{i}")), "k");
        }
        let m = memo.lock().unwrap();
        assert!(m.trials.len() <= TRIALS && m.order.len() <= CAPACITY);
        assert_eq!(m.trials.len(), 1, "started afresh at the 33rd trial");
    }
}
