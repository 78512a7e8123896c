//! Bounded queues between the real-time loop and everything else, safe across scheduling
//! classes: a thread waiting on one sleeps in the kernel (mutex and condition variable,
//! futexes), it never spins on another thread's half-finished operation.
//!
//! Why not `crossbeam-channel` here: its array queue lets a sender claim a slot and then
//! write it; a receiver that finds a slot claimed but not yet written spins (without
//! yielding) until the write lands. When the receiver is a `SCHED_FIFO` thread and the
//! sender a normal thread preempted on the same CPU between claim and write, the write can
//! never land: the FIFO thread spins on the CPU the sender needs. A kernel trace of the
//! executor bench (`sched_switch`, 1 kHz, FIFO 80 pinned to CPU 1) caught it: the host
//! line's reader thread ran 104.7 ms without a switch while the loop, woken on time, waited
//! behind it at the same priority; the trial ended `ControllerSilent`. The livelock lasts
//! until the kernel moves the preempted sender to another CPU or its fair-class server runs
//! it — the 58–132 ms stalls that ended real-time trials (docs/executor.md).
//!
//! Here a waiter that cannot proceed blocks, so the preempted thread gets the CPU, finishes
//! its short critical section and wakes it. Capacity is fixed at creation (no allocation
//! afterwards). A [`Bell`] lets one thread wait on several queues at once: every queue
//! attached to it rings it on a push or a disconnect.

use std::collections::VecDeque;
use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};
use std::time::{Duration, Instant};

/// A doorbell several queues ring: the loop waits on it for input from any of them.
#[derive(Debug, Default)]
pub struct Bell {
    rings: Mutex<u64>,
    rung: Condvar,
}

impl Bell {
    /// A new bell.
    pub fn new() -> Arc<Self> {
        Arc::new(Self::default())
    }

    /// Rings received so far (pass to [`Self::wait_past`]).
    pub fn rings(&self) -> u64 {
        *lock(&self.rings)
    }

    fn ring(&self) {
        *lock(&self.rings) += 1;
        self.rung.notify_all();
    }

    /// Waits until the bell has rung more than `seen` times or `timeout` has passed.
    pub fn wait_past(&self, seen: u64, timeout: Duration) {
        let guard = lock(&self.rings);
        let _ = self
            .rung
            .wait_timeout_while(guard, timeout, |rings| *rings == seen)
            .unwrap_or_else(PoisonError::into_inner);
    }
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    // A thread that panicked holding the lock left the queue consistent (no operation
    // here panics half-way), so its poison is ignored.
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

#[derive(Debug)]
struct State<T> {
    items: VecDeque<T>,
    capacity: usize,
    senders: usize,
    receiver: bool,
    bell: Option<Arc<Bell>>,
}

#[derive(Debug)]
struct Shared<T> {
    state: Mutex<State<T>>,
    not_empty: Condvar,
    not_full: Condvar,
}

impl<T> Shared<T> {
    fn ring(&self, bell: Option<Arc<Bell>>) {
        self.not_empty.notify_one();
        if let Some(b) = bell {
            b.ring();
        }
    }
}

/// The sending end (clone it for several producers).
pub struct Sender<T> {
    shared: Arc<Shared<T>>,
}

/// The receiving end (one consumer).
pub struct Receiver<T> {
    shared: Arc<Shared<T>>,
}

impl<T> core::fmt::Debug for Sender<T> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("rt_queue::Sender { .. }")
    }
}

impl<T> core::fmt::Debug for Receiver<T> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("rt_queue::Receiver { .. }")
    }
}

/// Why [`Sender::try_send`] did not queue the value (which it hands back).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TrySendError<T> {
    /// The queue holds its capacity.
    Full(T),
    /// The receiver is gone.
    Disconnected(T),
}

/// [`Sender::send`] failed: the receiver is gone (the value is handed back).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SendError<T>(pub T);

/// Why [`Receiver::try_recv`] returned nothing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TryRecvError {
    /// Nothing queued.
    Empty,
    /// Nothing queued and every sender is gone.
    Disconnected,
}

/// Why [`Receiver::recv_timeout`] returned nothing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RecvTimeoutError {
    /// Nothing arrived in time.
    Timeout,
    /// Nothing queued and every sender is gone.
    Disconnected,
}

/// A queue holding at most `capacity` values (at least one), allocated now.
pub fn bounded<T>(capacity: usize) -> (Sender<T>, Receiver<T>) {
    let capacity = capacity.max(1);
    let state = State {
        items: VecDeque::with_capacity(capacity),
        capacity,
        senders: 1,
        receiver: true,
        bell: None,
    };
    let shared = Arc::new(Shared {
        state: Mutex::new(state),
        not_empty: Condvar::new(),
        not_full: Condvar::new(),
    });
    (Sender { shared: shared.clone() }, Receiver { shared })
}

impl<T> Sender<T> {
    /// Values queued now.
    pub fn len(&self) -> usize {
        lock(&self.shared.state).items.len()
    }

    /// Whether nothing is queued now.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Queues `value` unless the queue is full or the receiver gone.
    pub fn try_send(&self, value: T) -> Result<(), TrySendError<T>> {
        let mut s = lock(&self.shared.state);
        if !s.receiver {
            return Err(TrySendError::Disconnected(value));
        }
        if s.items.len() >= s.capacity {
            return Err(TrySendError::Full(value));
        }
        s.items.push_back(value);
        let bell = s.bell.clone();
        drop(s);
        self.shared.ring(bell);
        Ok(())
    }

    /// Queues `value`, sleeping while the queue is full; fails once the receiver is gone.
    pub fn send(&self, value: T) -> Result<(), SendError<T>> {
        let s = lock(&self.shared.state);
        let mut s = self
            .shared
            .not_full
            .wait_while(s, |s| s.receiver && s.items.len() >= s.capacity)
            .unwrap_or_else(PoisonError::into_inner);
        if !s.receiver {
            return Err(SendError(value));
        }
        s.items.push_back(value);
        let bell = s.bell.clone();
        drop(s);
        self.shared.ring(bell);
        Ok(())
    }
}

impl<T> Clone for Sender<T> {
    fn clone(&self) -> Self {
        lock(&self.shared.state).senders += 1;
        Self { shared: self.shared.clone() }
    }
}

impl<T> Drop for Sender<T> {
    fn drop(&mut self) {
        let mut s = lock(&self.shared.state);
        s.senders -= 1;
        let last = s.senders == 0;
        let bell = s.bell.clone();
        drop(s);
        if last {
            self.shared.not_empty.notify_all();
            if let Some(b) = bell {
                b.ring();
            }
        }
    }
}

impl<T> Receiver<T> {
    /// Rings `bell` on every later push and when the last sender goes (rung once now, so a
    /// value already queued is not missed).
    pub fn attach(&self, bell: &Arc<Bell>) {
        lock(&self.shared.state).bell = Some(bell.clone());
        bell.ring();
    }

    /// Takes the oldest value if there is one.
    pub fn try_recv(&self) -> Result<T, TryRecvError> {
        let mut s = lock(&self.shared.state);
        match s.items.pop_front() {
            Some(v) => {
                drop(s);
                self.shared.not_full.notify_one();
                Ok(v)
            }
            None if s.senders == 0 => Err(TryRecvError::Disconnected),
            None => Err(TryRecvError::Empty),
        }
    }

    /// Takes the oldest value, waiting up to `timeout` for one.
    pub fn recv_timeout(&self, timeout: Duration) -> Result<T, RecvTimeoutError> {
        let until = Instant::now() + timeout;
        let mut s = lock(&self.shared.state);
        loop {
            if let Some(v) = s.items.pop_front() {
                drop(s);
                self.shared.not_full.notify_one();
                return Ok(v);
            }
            if s.senders == 0 {
                return Err(RecvTimeoutError::Disconnected);
            }
            let left = until.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Err(RecvTimeoutError::Timeout);
            }
            s = self
                .shared
                .not_empty
                .wait_timeout(s, left)
                .unwrap_or_else(PoisonError::into_inner)
                .0;
        }
    }

    /// Takes the oldest value, waiting for one; `None` once every sender is gone.
    pub fn recv(&self) -> Option<T> {
        let s = lock(&self.shared.state);
        let mut s = self
            .shared
            .not_empty
            .wait_while(s, |s| s.items.is_empty() && s.senders > 0)
            .unwrap_or_else(PoisonError::into_inner);
        let v = s.items.pop_front();
        drop(s);
        self.shared.not_full.notify_one();
        v
    }
}

impl<T> Drop for Receiver<T> {
    fn drop(&mut self) {
        lock(&self.shared.state).receiver = false;
        self.shared.not_full.notify_all();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec::Vec;

    #[test]
    fn values_arrive_in_order_and_a_full_queue_refuses_without_blocking() {
        let (tx, rx) = bounded(2);
        tx.try_send(1).unwrap();
        tx.try_send(2).unwrap();
        assert_eq!(tx.try_send(3), Err(TrySendError::Full(3)));
        assert_eq!(rx.try_recv(), Ok(1));
        assert_eq!(rx.recv_timeout(Duration::from_millis(1)), Ok(2));
        assert_eq!(rx.try_recv(), Err(TryRecvError::Empty));
        assert_eq!(rx.recv_timeout(Duration::from_millis(1)), Err(RecvTimeoutError::Timeout));
    }

    #[test]
    fn the_ends_see_each_other_go() {
        let (tx, rx) = bounded::<u8>(1);
        let tx2 = tx.clone();
        tx.try_send(7).unwrap();
        drop(tx);
        drop(tx2);
        assert_eq!(rx.try_recv(), Ok(7), "what was queued is still delivered");
        assert_eq!(rx.try_recv(), Err(TryRecvError::Disconnected));
        assert_eq!(rx.recv(), None);
        let (tx, rx) = bounded::<u8>(1);
        drop(rx);
        assert_eq!(tx.send(1), Err(SendError(1)));
        assert_eq!(tx.try_send(2), Err(TrySendError::Disconnected(2)));
    }

    #[test]
    fn a_blocked_sender_resumes_when_the_receiver_takes_and_the_bell_rings_on_push() {
        let (tx, rx) = bounded(1);
        let bell = Bell::new();
        rx.attach(&bell);
        let seen = bell.rings();
        tx.send(1u32).unwrap();
        assert!(bell.rings() > seen, "a push rings the attached bell");
        let t = std::thread::spawn(move || {
            for i in 2..=200u32 {
                tx.send(i).unwrap();
            }
        });
        let got: Vec<u32> = std::iter::from_fn(|| rx.recv()).collect();
        t.join().unwrap();
        assert_eq!(got, (1..=200).collect::<Vec<_>>());
    }

    #[test]
    fn a_bell_wait_returns_on_a_ring_from_another_thread() {
        let bell = Bell::new();
        let (tx, rx) = bounded(4);
        rx.attach(&bell);
        let seen = bell.rings();
        let t = std::thread::spawn(move || tx.send(5u8).unwrap());
        bell.wait_past(seen, Duration::from_secs(30));
        t.join().unwrap();
        assert_eq!(rx.try_recv(), Ok(5));
    }
}
