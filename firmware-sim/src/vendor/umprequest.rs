//! SMCP1 requests a Sensapex uMp understands, decoded from their sub-blocks.
//!
//! Argument layouts from the SDK's `smcp1.h` comments and `libum.c` encoders (controller
//! protocol notes, section 4.3): GOTO_POS takes 1, 3 or 4 positions (nm, `ARG_UNDEF` = keep
//! the axis), then optionally speed (µm/s; negative = nm/s, the SDK's encoding below
//! 1 µm/s), drive mode (0 = one axis after another, the default; 1 = all together) and
//! max acceleration (µm/s²), and an optional second sub-block of per-axis speeds.
//! TAKE_STEP takes 1, 3 or 4 steps (nm, 0 = axis still), optionally four speeds, a mode
//! (the closed-loop setting, ignored here) and a max acceleration.
//!
//! A request that does not decode is "not understood": the device answers ACK|ERROR.

use super::smcp::{ARG_UNDEF, SubBlock, kind};
use mesopush_protocol::units::um_s_to_nm_s;

/// Parameter ids answered by GET_PARAMETER (`smcp1.h` `smcp1_params`).
pub mod param {
    /// Speed of memory drives and of GOTO_POS without a speed, µm/s.
    pub const MEM_SPEED: i32 = 2;
    /// The device id.
    pub const DEV_ID: i32 = 3;
    /// Number of axes (read-only).
    pub const AXIS_COUNT: i32 = 0x105;
}

/// A decoded request.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Request {
    /// PING: echo.
    Ping,
    /// STOP.
    Stop,
    /// GET_POSITIONS.
    GetPositions,
    /// GET_PARAMETER of a known id.
    GetParameter(i32),
    /// SET_PARAMETER of MEM_SPEED (µm/s > 0).
    SetMemSpeed(i32),
    /// GET_VERSION.
    GetVersion,
    /// GOTO_POS.
    Goto {
        /// Target per axis, nm (`None` = keep).
        target_nm: [Option<i64>; 4],
        /// Speed per axis, nm/s (`None` = the device's MEM_SPEED).
        speed_nm_s: [Option<f64>; 4],
        /// Mode 1: all axes together; mode 0: one after another.
        simultaneous: bool,
        /// Max acceleration, µm/s² (`None` = the device default).
        max_acc_um_s2: Option<i32>,
    },
    /// TAKE_STEP.
    Step {
        /// Step per axis, nm.
        delta_nm: [i64; 4],
        /// Speed per axis, nm/s (`None` = MEM_SPEED).
        speed_nm_s: [Option<f64>; 4],
        /// Max acceleration, µm/s².
        max_acc_um_s2: Option<i32>,
    },
}

/// Why a request was not understood.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rejected;

/// A speed argument as nm/s: positive µm/s, negative nm/s, 0 → `None` (invalid).
pub fn speed_nm_s(v: i32) -> Option<f64> {
    match v {
        0 | ARG_UNDEF => None,
        v if v < 0 => Some(-f64::from(v)),
        v => um_s_to_nm_s("sensapex speed", f64::from(v)).ok().map(f64::from),
    }
}

fn args(blocks: &[SubBlock], i: usize) -> &[i32] {
    blocks.get(i).map_or(&[], |b| b.values.as_slice())
}

/// Decodes a request of type `kind_` with its sub-blocks.
pub fn decode(kind_: u16, blocks: &[SubBlock]) -> Result<Request, Rejected> {
    let a = args(blocks, 0);
    match (kind_, a) {
        (kind::PING, _) => Ok(Request::Ping),
        (kind::STOP, []) => Ok(Request::Stop),
        (kind::GET_POSITIONS, []) => Ok(Request::GetPositions),
        (kind::GET_VERSION, []) => Ok(Request::GetVersion),
        (kind::GET_PARAMETER, [id])
            if [param::MEM_SPEED, param::DEV_ID, param::AXIS_COUNT].contains(id) =>
        {
            Ok(Request::GetParameter(*id))
        }
        (kind::SET_PARAMETER, [param::MEM_SPEED, v]) if *v > 0 => Ok(Request::SetMemSpeed(*v)),
        (kind::GOTO_POS, _) => goto(a, args(blocks, 1)),
        (kind::TAKE_STEP, _) => step(a),
        _ => Err(Rejected),
    }
}

fn goto(a: &[i32], per_axis: &[i32]) -> Result<Request, Rejected> {
    if !matches!(a.len(), 1 | 3..=7) || per_axis.len() > 4 {
        return Err(Rejected);
    }
    let target_nm: [Option<i64>; 4] = core::array::from_fn(|i| match a.get(i) {
        Some(&v) if v != ARG_UNDEF => Some(i64::from(v)),
        _ => None,
    });
    let shared = match a.get(4) {
        Some(&v) => Some(speed_nm_s(v).ok_or(Rejected)?),
        None => None,
    };
    let mut speed_nm_s = [shared; 4];
    for (i, &v) in per_axis.iter().enumerate() {
        speed_nm_s[i] = self::speed_nm_s(v);
        if speed_nm_s[i].is_none() && target_nm[i].is_some() {
            return Err(Rejected);
        }
    }
    let simultaneous = a.get(5).is_some_and(|&m| m != 0);
    let max_acc_um_s2 = a.get(6).copied().filter(|&v| v > 0);
    Ok(Request::Goto { target_nm, speed_nm_s, simultaneous, max_acc_um_s2 })
}

fn step(a: &[i32]) -> Result<Request, Rejected> {
    if !matches!(a.len(), 1 | 3 | 4 | 8..=10) {
        return Err(Rejected);
    }
    let delta_nm: [i64; 4] = core::array::from_fn(|i| a.get(i).map_or(0, |&v| i64::from(v)));
    let mut speed = [None; 4];
    if a.len() >= 8 {
        for i in 0..4 {
            speed[i] = speed_nm_s(a[4 + i]);
            if speed[i].is_none() && delta_nm[i] != 0 {
                return Err(Rejected);
            }
        }
    }
    let max_acc_um_s2 = a.get(9).copied().filter(|&v| v > 0);
    Ok(Request::Step { delta_nm, speed_nm_s: speed, max_acc_um_s2 })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vendor::smcp::DATA_INT32;

    fn block(v: &[i32]) -> Vec<SubBlock> {
        vec![SubBlock { data_type: DATA_INT32, values: v.to_vec() }]
    }

    #[test]
    fn goto_arguments_and_speed_encoding() {
        let r = decode(kind::GOTO_POS, &block(&[1, 2, 3, ARG_UNDEF, -500, 1])).unwrap();
        let Request::Goto { target_nm, speed_nm_s, simultaneous, .. } = r else { panic!() };
        assert_eq!(target_nm, [Some(1), Some(2), Some(3), None]);
        assert_eq!(speed_nm_s[0], Some(500.0), "negative speed is nm/s");
        assert!(simultaneous);
        assert_eq!(decode(kind::GOTO_POS, &block(&[1, 2])), Err(Rejected));
        assert_eq!(decode(kind::GOTO_POS, &block(&[1, 2, 3, 4, 0])), Err(Rejected), "speed 0");
        assert_eq!(decode(kind::TAKE_STEP, &block(&[5, 0, 0, 0, 0, 0, 0, 0])), Err(Rejected));
        assert_eq!(decode(999, &[]), Err(Rejected));
    }
}
