//! A frame's driver timestamp. V4L2 stamps each buffer with a `timeval` and says in the
//! buffer's flags which clock it read (`V4L2_BUF_FLAG_TIMESTAMP_MASK`: we need
//! `CLOCK_MONOTONIC`, the clock every process on the machine shares — the executor converts
//! it into its own clock exactly, docs/hil.md) and which instant it marks
//! (`V4L2_BUF_FLAG_TSTAMP_SRC_MASK`: start of exposure or end of frame). Decoded here from
//! the raw flag bits, so the rules are tested without a camera.

use crate::Error;

/// `V4L2_BUF_FLAG_TIMESTAMP_MASK`: which clock the timestamp was read from.
pub const TIMESTAMP_MASK: u32 = 0x0000_e000;
/// `V4L2_BUF_FLAG_TIMESTAMP_UNKNOWN`.
pub const TIMESTAMP_UNKNOWN: u32 = 0x0000_0000;
/// `V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC`: `CLOCK_MONOTONIC`.
pub const TIMESTAMP_MONOTONIC: u32 = 0x0000_2000;
/// `V4L2_BUF_FLAG_TIMESTAMP_COPY`: copied from an output buffer (not a capture time).
pub const TIMESTAMP_COPY: u32 = 0x0000_4000;
/// `V4L2_BUF_FLAG_TSTAMP_SRC_MASK`: which instant of the frame the timestamp marks.
pub const TSTAMP_SRC_MASK: u32 = 0x0007_0000;
/// `V4L2_BUF_FLAG_TSTAMP_SRC_SOE`: start of exposure.
pub const TSTAMP_SRC_SOE: u32 = 0x0001_0000;

/// Which instant of the exposure a timestamp marks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StampInstant {
    /// Start of exposure (the driver says so: `V4L2_BUF_FLAG_TSTAMP_SRC_SOE`).
    StartOfExposure,
    /// End of frame (V4L2's default when the driver says nothing else): later than the
    /// exposure by the exposure and readout times.
    EndOfFrame,
}

impl core::fmt::Display for StampInstant {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            StampInstant::StartOfExposure => "start of exposure",
            StampInstant::EndOfFrame => "end of frame",
        })
    }
}

/// A buffer's timestamp on `CLOCK_MONOTONIC`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DriverStamp {
    /// `CLOCK_MONOTONIC`, µs (`frame_stamp_us` before conversion to the executor's clock).
    pub mono_us: u64,
    /// Which instant it marks.
    pub instant: StampInstant,
}

impl DriverStamp {
    /// Decodes a buffer's `flags` and `timestamp` (`tv_sec`, `tv_usec`). Refused, naming the
    /// clock, when the driver did not read `CLOCK_MONOTONIC`; refused, naming the value, when
    /// the time is negative or its µs are outside 0..1 000 000.
    pub fn decode(flags: u32, sec: i64, usec: i64) -> Result<Self, Error> {
        let clock = flags & TIMESTAMP_MASK;
        if clock != TIMESTAMP_MONOTONIC {
            let name = match clock {
                TIMESTAMP_UNKNOWN => "an unknown clock",
                TIMESTAMP_COPY => "a copied timestamp",
                _ => "an unrecognised clock",
            };
            return Err(Error::invalid(
                "driver timestamp",
                format!(
                    "the driver stamps frames with {name} (flags {flags:#x}), not \
                     CLOCK_MONOTONIC: their times cannot be put on the executor's clock"
                ),
            ));
        }
        if !(0..1_000_000).contains(&usec) || sec < 0 {
            return Err(Error::invalid(
                "driver timestamp",
                format!("{sec} s {usec} µs: want sec ≥ 0 and µs in 0..1000000"),
            ));
        }
        let mono_us = u64::try_from(i128::from(sec) * 1_000_000 + i128::from(usec))
            .map_err(|_| Error::invalid("driver timestamp", format!("{sec} s is too large")))?;
        let instant = if flags & TSTAMP_SRC_MASK == TSTAMP_SRC_SOE {
            StampInstant::StartOfExposure
        } else {
            StampInstant::EndOfFrame
        };
        Ok(Self { mono_us, instant })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn monotonic_stamps_decode_with_their_instant() {
        let soe = DriverStamp::decode(TIMESTAMP_MONOTONIC | TSTAMP_SRC_SOE | 0x1, 12, 345).unwrap();
        assert_eq!(
            soe,
            DriverStamp { mono_us: 12_000_345, instant: StampInstant::StartOfExposure }
        );
        let eof = DriverStamp::decode(TIMESTAMP_MONOTONIC, 0, 999_999).unwrap();
        assert_eq!(eof.instant, StampInstant::EndOfFrame);
        assert_eq!(eof.mono_us, 999_999);
    }

    #[test]
    fn other_clocks_and_bad_times_are_refused() {
        let e = DriverStamp::decode(TIMESTAMP_COPY, 1, 0).unwrap_err().to_string();
        assert!(e.contains("copied") && e.contains("CLOCK_MONOTONIC"), "{e}");
        assert!(DriverStamp::decode(TIMESTAMP_UNKNOWN, 1, 0).is_err());
        assert!(DriverStamp::decode(TIMESTAMP_MONOTONIC, -1, 0).is_err());
        let e = DriverStamp::decode(TIMESTAMP_MONOTONIC, 1, 1_000_000).unwrap_err().to_string();
        assert!(e.contains("1000000"), "{e}");
    }
}
