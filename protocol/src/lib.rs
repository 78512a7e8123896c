//! Wire types shared by the mesopush host, executor and motion-controller firmware.
//!
//! `no_std`, no allocation: only message types, framing, checksums, version checks and the
//! checked conversions between host units and the wire's integer units ([`units`]).
//!
//! # Layers
//! - Messages: [`host`] (host ↔ executor), [`ctrl`] (executor ↔ controller), [`flash`]
//!   (plan flash images). Integers are sized and carry their unit in their name: positions
//!   `*_nm: i32`, speeds `*_nm_s: u32`, times `*_us: u64` named after their clock
//!   (`exec_time_us`, `ctrl_time_us`, `frame_stamp_us`, `host_time_us`).
//! - Framing ([`frame`]): postcard body, CRC-32/ISO-HDLC, COBS stuffing, `0x00` delimiter,
//!   at most [`FRAME_BUF_LEN`] bytes, with a compile-time bound ([`MaxSize`]) per message.
//! - Reliability ([`link`]): a sans-IO go-back-N link with cumulative acks, nacks, a bounded
//!   retransmit window, timeouts on the caller's clock and session ids that resynchronise
//!   after a peer restarts, used by both ends.
//!
//! # Versioning
//! Peers exchange [`host::Hello`] with [`PROTOCOL_VERSION`] and [`SCHEMA_HASH`] and refuse
//! to work unless both match. Any change to a wire type must change [`SCHEMA`] (and so the
//! hash); a change that breaks old peers also bumps [`PROTOCOL_VERSION`]. The golden-vector
//! test refuses to re-bless changed bytes under an unchanged hash.
//!
//! See `docs/protocol.md` for the frame layout and the table of message sizes.
#![no_std]
#![deny(missing_docs)]

pub mod camera;
pub mod ctrl;
pub mod describe;
pub mod error;
pub mod flash;
pub mod frame;
pub mod host;
pub mod link;
pub mod max_size;
pub mod reader;
pub mod units;

pub use ctrl::{CtrlToExec, ExecToCtrl};
pub use error::WireError;
pub use frame::{FRAME_BUF_LEN, Frame, FrameKind, decode_frame, encode_frame};
pub use host::{ExecToHost, HostToExec};
pub use link::{Link, LinkConfig, LinkDown, LinkStats};
pub use max_size::MaxSize;
pub use reader::FrameReader;

/// Protocol version; bumped when a change breaks compatibility with deployed peers.
pub const PROTOCOL_VERSION: u16 = 4;

/// Description of every wire type, in encoding order. Edit it with every change to a type in
/// [`host`], [`ctrl`], [`flash`] or [`frame`]; [`SCHEMA_HASH`] is derived from it.
pub const SCHEMA: &str = "\
frame: Frame<M>{sender_session:u16,receiver_session:Option<u16>,ack:u16,kind:FrameKind<M>}; FrameKind<M>=Data{seq:u16,msg:M}|Ack|Nack; crc32-iso-hdlc-le; cobs; 0x00
flash: FlashHeader{format_version:u16,plan_id:u32,step_count:u32,image_len_bytes:u32,image_crc32:u32}
flash: FlashChunk{plan_id:u32,offset_bytes:u32,data:Vec<u8,192>}
flash: PlanStep{dx_nm:i32,dy_nm:i32,speed_nm_s:u32} image=le-fixed-12
flash: FlashRejectReason=UnsupportedFormatVersion{got:u16}|StepCountMismatch{step_count:u32,image_len_bytes:u32}|PartialStep{image_len_bytes:u32}|TooLarge{image_len_bytes:u32,capacity_bytes:u32}|PlanIdMismatch{expected_plan_id:u32,got_plan_id:u32}|OutOfOrderChunk{expected_offset_bytes:u32,got_offset_bytes:u32}|LengthMismatch{expected_len_bytes:u32,received_len_bytes:u32}|CrcMismatch{expected_crc32:u32,computed_crc32:u32}|NoFlashInProgress|Unsafe{step_index:u32,limit:SafetyLimit}|NotStored
flash: SafetyLimit=ZeroSpeed|ZeroLength|Speed|Acceleration|Workspace
ctrl: MoveSegment{segment_id:u32,start_ctrl_time_us:u64,target_x_nm:i32,target_y_nm:i32,speed_nm_s:u32}
ctrl: ExecToCtrl=Move(MoveSegment)|Stop|ClockSyncQuery{query_id:u32}|StatusQuery|Heartbeat{exec_time_us:u64}|ClearFault
ctrl: CtrlState=Idle|Moving|Stopped|Faulted
ctrl: PositionReport{ctrl_time_us:u64,x_nm:i32,y_nm:i32,active_segment_id:Option<u32>}
ctrl: CtrlStatus{ctrl_time_us:u64,state:CtrlState,queue_free_slots:u16,queue_len:u16,last_done_segment_id:Option<u32>}
ctrl: FaultCode=Stall|LimitSwitch|Reboot|QueueOverflow|QueueUnderrun|BadSegment|SegmentLate|ExecutorSilent|NeedleOverload|Other(u16)|MoveIgnored
ctrl: FaultReport{ctrl_time_us:u64,code:FaultCode,segment_id:Option<u32>,x_nm:i32,y_nm:i32}
ctrl: CtrlToExec=Position(PositionReport)|Status(CtrlStatus)|ClockSyncReply{query_id:u32,ctrl_time_us:u64}|Heartbeat{ctrl_time_us:u64}|Fault(FaultReport)
host: Hello{protocol_version:u16,schema_hash:u32}
host: StagePoint{x_nm:i32,y_nm:i32}
host: HostToExec=Hello(Hello)|FlashBegin(FlashHeader)|FlashChunk(FlashChunk)|FlashCommit{plan_id:u32}|Arm{plan_id:u32,start:StagePoint}|Start{plan_id:u32}|Abort|StatusQuery|Heartbeat{host_time_us:u64}|Goto{target:StagePoint}|Home|Stop
host: ExecState=Idle|Flashing|PlanFlashed|Armed|Running|Done|Aborted|Faulted|Moving
host: ExecStatus{exec_time_us:u64,state:ExecState,plan_id:Option<u32>,step_count:u32,step_index:u32,last_fault:Option<TrialFault>,probe:Option<StagePoint>,ctrl_state:Option<CtrlState>}
host: CommandRejectReason=WrongState{state:ExecState}|PlanIdMismatch{stored_plan_id:Option<u32>}|Incompatible|Unsafe{step_index:Option<u32>,limit:SafetyLimit}|NotReady{clock_synced:bool,position_known:bool,ctrl_ready:bool}|StartMismatch{probe:StagePoint,start:StagePoint,tolerance_nm:u32}|OutsideWorkspace{target:StagePoint,min:StagePoint,max:StagePoint}
host: TrialFault=Controller(FaultReport)|ControllerSilent{last_heard_exec_time_us:u64}|HostLinkLost{last_heard_exec_time_us:u64}|ClockSyncLost|StreamUnderrun{step_index:u32}
host: TrialEventKind=Started|Done|Aborted|Faulted(TrialFault)
host: TrialEvent{exec_time_us:u64,plan_id:u32,step_index:u32,kind:TrialEventKind}
host: FrameStamp{frame_seq:u32,frame_stamp_us:u64,probe_x_nm:i32,probe_y_nm:i32}
host: ProbeTelemetry{exec_time_us:u64,ctrl_time_us:u64,probe_x_nm:i32,probe_y_nm:i32,step_index:u32,ctrl_queue_free_slots:u16}
host: MotionEventKind=Started{target:StagePoint}|Arrived{at:StagePoint}|Stopped|Faulted(TrialFault)
host: MotionEvent{exec_time_us:u64,kind:MotionEventKind}
host: ExecToHost=HelloReply{hello:Hello,accepted:bool}|FlashProgress{plan_id:u32,received_bytes:u32}|FlashAccepted{plan_id:u32,step_count:u32}|FlashRejected{plan_id:u32,reason:FlashRejectReason}|CommandRejected(CommandRejectReason)|Status(ExecStatus)|Trial(TrialEvent)|Frame(FrameStamp)|Telemetry(ProbeTelemetry)|Motion(MotionEvent)
";

/// 32-bit FNV-1a hash of [`SCHEMA`], exchanged in the handshake.
pub const SCHEMA_HASH: u32 = fnv1a_32(SCHEMA.as_bytes());

/// 32-bit FNV-1a hash, usable in `const` context.
pub const fn fnv1a_32(bytes: &[u8]) -> u32 {
    let mut hash: u32 = 0x811c_9dc5;
    let mut i = 0;
    while i < bytes.len() {
        hash ^= bytes[i] as u32;
        hash = hash.wrapping_mul(0x0100_0193);
        i += 1;
    }
    hash
}

#[cfg(test)]
mod tests {
    use super::fnv1a_32;

    #[test]
    fn fnv1a_matches_reference_vectors() {
        // Published FNV-1a 32-bit test vectors.
        assert_eq!(fnv1a_32(b""), 0x811c_9dc5);
        assert_eq!(fnv1a_32(b"a"), 0xe40c_292c);
        assert_eq!(fnv1a_32(b"foobar"), 0xbf9c_f968);
    }
}
