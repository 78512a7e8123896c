//! Dropped frames from gaps in the driver's (wrapping, 32-bit) frame sequence numbers: a
//! frame the camera exposed but the program never got leaves its number out.

/// Counts frames missing between consecutive sequence numbers.
#[derive(Debug, Clone, Default)]
pub struct DropCounter {
    last: Option<u32>,
    total: u64,
}

impl DropCounter {
    /// A counter that has seen no frame.
    pub const fn new() -> Self {
        Self { last: None, total: 0 }
    }

    /// Records frame `sequence`; returns how many were skipped since the previous one. A
    /// sequence that repeats or goes backwards (driver restart) counts as no drop and
    /// restarts the count.
    pub fn observe(&mut self, sequence: u32) -> u32 {
        let gap = match self.last {
            Some(prev) => {
                let step = sequence.wrapping_sub(prev);
                if step == 0 || step > u32::MAX / 2 { 0 } else { step - 1 }
            }
            None => 0,
        };
        self.last = Some(sequence);
        self.total += u64::from(gap);
        gap
    }

    /// Frames dropped so far.
    pub fn total(&self) -> u64 {
        self.total
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaps_count_as_drops_and_wrap_around() {
        let mut d = DropCounter::new();
        assert_eq!(d.observe(5), 0);
        assert_eq!(d.observe(6), 0);
        assert_eq!(d.observe(9), 2);
        assert_eq!(d.observe(3), 0, "a restart is not a drop");
        let mut w = DropCounter::new();
        w.observe(u32::MAX - 1);
        assert_eq!(w.observe(1), 2);
        assert_eq!(d.total(), 2);
    }
}
