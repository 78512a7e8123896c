//! Plan flash images: the byte layout of a plan, its header and the chunks that carry it.
//!
//! The host uploads a plan as one image split into chunks; the executor reassembles it and
//! verifies it against the header (format version, length, step count, CRC-32 over the whole
//! image) before accepting it. The image layout is fixed-width little-endian so the executor
//! can index step `i` at `i * PLAN_STEP_LEN_BYTES` without parsing.

use crate::max_size::MaxSize;
use crc::{CRC_32_ISO_HDLC, Crc};
use heapless::Vec;
use serde::{Deserialize, Serialize};

/// Version of the flash image layout described in this module.
pub const FLASH_FORMAT_VERSION: u16 = 1;
/// Bytes per plan step in a flash image.
pub const PLAN_STEP_LEN_BYTES: usize = 12;
/// Most image bytes one [`FlashChunk`] carries (16 plan steps).
pub const FLASH_CHUNK_MAX_BYTES: usize = 16 * PLAN_STEP_LEN_BYTES;

/// The CRC used over flash images and frames: CRC-32/ISO-HDLC (the zlib/Ethernet CRC-32).
pub const CRC32: Crc<u32> = Crc::<u32>::new(&CRC_32_ISO_HDLC);

/// CRC-32/ISO-HDLC of a whole flash image.
pub fn image_crc32(image: &[u8]) -> u32 {
    CRC32.checksum(image)
}

/// One plan step: a relative probe move at a commanded speed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct PlanStep {
    /// Probe displacement along x, nm.
    pub dx_nm: i32,
    /// Probe displacement along y, nm.
    pub dy_nm: i32,
    /// Probe speed along the move, nm/s.
    pub speed_nm_s: u32,
}

impl PlanStep {
    /// The step's fixed-width little-endian image layout: `dx_nm`, `dy_nm`, `speed_nm_s`.
    pub fn to_image_bytes(&self) -> [u8; PLAN_STEP_LEN_BYTES] {
        let mut out = [0u8; PLAN_STEP_LEN_BYTES];
        out[0..4].copy_from_slice(&self.dx_nm.to_le_bytes());
        out[4..8].copy_from_slice(&self.dy_nm.to_le_bytes());
        out[8..12].copy_from_slice(&self.speed_nm_s.to_le_bytes());
        out
    }

    /// Reads a step from its image layout (inverse of [`Self::to_image_bytes`]).
    pub fn from_image_bytes(bytes: &[u8; PLAN_STEP_LEN_BYTES]) -> Self {
        let word = |i: usize| [bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]];
        Self {
            dx_nm: i32::from_le_bytes(word(0)),
            dy_nm: i32::from_le_bytes(word(4)),
            speed_nm_s: u32::from_le_bytes(word(8)),
        }
    }
}

/// Iterates over the steps of a verified image. A trailing partial step is ignored, which
/// [`FlashHeader::verify_image`] rules out beforehand.
pub fn image_steps(image: &[u8]) -> impl Iterator<Item = PlanStep> + '_ {
    image.chunks_exact(PLAN_STEP_LEN_BYTES).filter_map(|chunk| {
        <&[u8; PLAN_STEP_LEN_BYTES]>::try_from(chunk).ok().map(PlanStep::from_image_bytes)
    })
}

/// Describes a flash image; sent before its chunks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct FlashHeader {
    /// Image layout version; must equal [`FLASH_FORMAT_VERSION`].
    pub format_version: u16,
    /// Identifier the host gives the plan; echoed in every later message about it.
    pub plan_id: u32,
    /// Number of plan steps in the image.
    pub step_count: u32,
    /// Image length in bytes (`step_count * PLAN_STEP_LEN_BYTES`).
    pub image_len_bytes: u32,
    /// CRC-32/ISO-HDLC over the whole image.
    pub image_crc32: u32,
}

impl FlashHeader {
    /// Header for `image`, which must be a whole number of steps.
    pub fn for_image(plan_id: u32, image: &[u8]) -> Result<Self, FlashRejectReason> {
        let image_len_bytes = u32::try_from(image.len()).map_err(|_| {
            FlashRejectReason::TooLarge { image_len_bytes: u32::MAX, capacity_bytes: u32::MAX }
        })?;
        if !image.len().is_multiple_of(PLAN_STEP_LEN_BYTES) {
            return Err(FlashRejectReason::PartialStep { image_len_bytes });
        }
        Ok(Self {
            format_version: FLASH_FORMAT_VERSION,
            plan_id,
            step_count: image_len_bytes / PLAN_STEP_LEN_BYTES as u32,
            image_len_bytes,
            image_crc32: image_crc32(image),
        })
    }

    /// Checks the header alone: format version, consistent length, fits in `capacity_bytes`.
    pub fn check(&self, capacity_bytes: u32) -> Result<(), FlashRejectReason> {
        if self.format_version != FLASH_FORMAT_VERSION {
            return Err(FlashRejectReason::UnsupportedFormatVersion { got: self.format_version });
        }
        if u64::from(self.step_count) * PLAN_STEP_LEN_BYTES as u64
            != u64::from(self.image_len_bytes)
        {
            return Err(FlashRejectReason::StepCountMismatch {
                step_count: self.step_count,
                image_len_bytes: self.image_len_bytes,
            });
        }
        if self.image_len_bytes > capacity_bytes {
            return Err(FlashRejectReason::TooLarge {
                image_len_bytes: self.image_len_bytes,
                capacity_bytes,
            });
        }
        Ok(())
    }

    /// Verifies a fully received image against this header: length first (a truncated
    /// image is reported as such), then the CRC-32.
    pub fn verify_image(&self, image: &[u8]) -> Result<(), FlashRejectReason> {
        self.check(u32::MAX)?;
        let received_len_bytes = u32::try_from(image.len()).unwrap_or(u32::MAX);
        if received_len_bytes != self.image_len_bytes {
            return Err(FlashRejectReason::LengthMismatch {
                expected_len_bytes: self.image_len_bytes,
                received_len_bytes,
            });
        }
        let computed_crc32 = image_crc32(image);
        if computed_crc32 != self.image_crc32 {
            return Err(FlashRejectReason::CrcMismatch {
                expected_crc32: self.image_crc32,
                computed_crc32,
            });
        }
        Ok(())
    }
}

/// A slice of a flash image at a byte offset.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct FlashChunk {
    /// Plan the chunk belongs to (must match the pending [`FlashHeader`]).
    pub plan_id: u32,
    /// Offset of `data` in the image, bytes. Chunks are sent in order without gaps.
    pub offset_bytes: u32,
    /// Image bytes.
    pub data: Vec<u8, FLASH_CHUNK_MAX_BYTES>,
}

/// Splits `image` into consecutive chunks of at most [`FLASH_CHUNK_MAX_BYTES`].
pub fn image_chunks(plan_id: u32, image: &[u8]) -> impl Iterator<Item = FlashChunk> + '_ {
    image.chunks(FLASH_CHUNK_MAX_BYTES).enumerate().filter_map(move |(i, part)| {
        let offset_bytes = u32::try_from(i * FLASH_CHUNK_MAX_BYTES).ok()?;
        let data = Vec::from_slice(part).ok()?;
        Some(FlashChunk { plan_id, offset_bytes, data })
    })
}

/// Why an executor refused a flash image.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum FlashRejectReason {
    /// The header's image layout version is not [`FLASH_FORMAT_VERSION`].
    UnsupportedFormatVersion {
        /// Version found in the header.
        got: u16,
    },
    /// `image_len_bytes` is not `step_count * PLAN_STEP_LEN_BYTES`.
    StepCountMismatch {
        /// Steps declared in the header.
        step_count: u32,
        /// Length declared in the header, bytes.
        image_len_bytes: u32,
    },
    /// The image length is not a whole number of plan steps.
    PartialStep {
        /// Image length, bytes.
        image_len_bytes: u32,
    },
    /// The image does not fit the executor's plan memory.
    TooLarge {
        /// Length declared in the header, bytes.
        image_len_bytes: u32,
        /// Plan memory of the executor, bytes.
        capacity_bytes: u32,
    },
    /// A chunk arrived for another plan than the one being flashed.
    PlanIdMismatch {
        /// Plan being flashed.
        expected_plan_id: u32,
        /// Plan named by the chunk.
        got_plan_id: u32,
    },
    /// A chunk did not start where the previous one ended, or ran past the declared length.
    OutOfOrderChunk {
        /// Offset the executor expected, bytes.
        expected_offset_bytes: u32,
        /// Offset of the chunk, bytes.
        got_offset_bytes: u32,
    },
    /// The image received is not as long as the header declared (truncated upload).
    LengthMismatch {
        /// Length declared in the header, bytes.
        expected_len_bytes: u32,
        /// Bytes actually received.
        received_len_bytes: u32,
    },
    /// The CRC-32 over the received image differs from the header's.
    CrcMismatch {
        /// CRC-32 declared in the header.
        expected_crc32: u32,
        /// CRC-32 computed over the received image.
        computed_crc32: u32,
    },
    /// A chunk or commit arrived without a header first.
    NoFlashInProgress,
    /// The image is intact but the plan breaks a safety limit of the executor's
    /// configuration.
    Unsafe {
        /// Offending step; `step_count` when the plan as a whole is at fault (its final stop
        /// or its extent).
        step_index: u32,
        /// Which limit.
        limit: SafetyLimit,
    },
    /// The image verified but could not be stored persistently; the previous plan stays.
    NotStored,
}

/// A safety limit a plan can break (the executor's log has the numbers).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum SafetyLimit {
    /// A step's speed is zero.
    ZeroSpeed,
    /// A step moves by less than 1 nm.
    ZeroLength,
    /// A step is faster than the speed limit.
    Speed,
    /// A velocity change needs more than the acceleration limit.
    Acceleration,
    /// The path leaves (or does not fit) the workspace box.
    Workspace,
}

impl MaxSize for PlanStep {
    const MAX_SIZE: usize = 2 * i32::MAX_SIZE + u32::MAX_SIZE;
}

impl MaxSize for FlashHeader {
    const MAX_SIZE: usize = u16::MAX_SIZE + 4 * u32::MAX_SIZE;
}

impl MaxSize for FlashChunk {
    const MAX_SIZE: usize = 2 * u32::MAX_SIZE + <Vec<u8, FLASH_CHUNK_MAX_BYTES>>::MAX_SIZE;
}

impl MaxSize for SafetyLimit {
    const MAX_SIZE: usize = crate::max_size::discriminant_bytes(5);
}

impl MaxSize for FlashRejectReason {
    // Largest variants carry two u32 fields (`Unsafe` carries one and a `SafetyLimit`).
    const MAX_SIZE: usize = crate::max_size::discriminant_bytes(11)
        + crate::max_size::max_of(&[2 * u32::MAX_SIZE, u32::MAX_SIZE + SafetyLimit::MAX_SIZE]);
}
