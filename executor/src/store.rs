//! Plan persistence across restarts, behind the small [`PlanStore`] trait.
//!
//! A stored plan is its header in a fixed 18-byte little-endian layout (`format_version`
//! u16, `plan_id`, `step_count`, `image_len_bytes`, `image_crc32` u32) followed by the
//! image; it is verified again (length, CRC-32) when loaded. [`MemStore`] keeps it in RAM
//! (tests, and the no_std build without real flash); with the `std` feature
//! [`file::FileStore`] writes a file atomically (write, fsync, rename, fsync the directory).
//! A failed save leaves the previously stored plan intact.

use crate::error::StoreError;
use crate::plan::FlashedPlan;
use heapless::Vec;
use mesopush_protocol::flash::FlashHeader;

#[cfg(feature = "std")]
pub mod file;

/// Bytes of the stored header.
pub const STORED_HEADER_LEN: usize = 18;

/// Where accepted plans are kept across restarts.
pub trait PlanStore {
    /// Stores `image` with `header`, replacing the stored plan only when fully written.
    fn save(&mut self, header: &FlashHeader, image: &[u8]) -> Result<(), StoreError>;
    /// Loads the stored plan's header and image into `image`; `Ok(None)` when none is stored.
    /// Returns the image length.
    fn load(&mut self, image: &mut [u8]) -> Result<Option<(FlashHeader, usize)>, StoreError>;
}

/// Encodes `header` in the stored layout.
pub fn encode_header(header: &FlashHeader) -> [u8; STORED_HEADER_LEN] {
    let mut out = [0u8; STORED_HEADER_LEN];
    out[0..2].copy_from_slice(&header.format_version.to_le_bytes());
    out[2..6].copy_from_slice(&header.plan_id.to_le_bytes());
    out[6..10].copy_from_slice(&header.step_count.to_le_bytes());
    out[10..14].copy_from_slice(&header.image_len_bytes.to_le_bytes());
    out[14..18].copy_from_slice(&header.image_crc32.to_le_bytes());
    out
}

/// Decodes the stored header layout.
pub fn decode_header(bytes: &[u8; STORED_HEADER_LEN]) -> FlashHeader {
    let word = |i: usize| u32::from_le_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
    FlashHeader {
        format_version: u16::from_le_bytes([bytes[0], bytes[1]]),
        plan_id: word(2),
        step_count: word(6),
        image_len_bytes: word(10),
        image_crc32: word(14),
    }
}

/// Loads and re-verifies the stored plan, if any.
pub fn load_plan<const CAP: usize>(
    store: &mut impl PlanStore,
) -> Result<Option<FlashedPlan<CAP>>, StoreError> {
    let mut image: Vec<u8, CAP> = Vec::new();
    image.resize(CAP, 0).map_err(|_| StoreError::TooLarge)?;
    let Some((header, len)) = store.load(&mut image)? else { return Ok(None) };
    image.truncate(len);
    FlashedPlan::from_verified(header, image).map(Some).map_err(|_| StoreError::Corrupt)
}

/// A plan store in RAM holding at most `CAP` image bytes.
#[derive(Debug, Default)]
pub struct MemStore<const CAP: usize> {
    stored: Option<(FlashHeader, Vec<u8, CAP>)>,
    /// Test hook: the next save fails (as a write error would), leaving the old plan.
    pub fail_next_save: bool,
}

impl<const CAP: usize> MemStore<CAP> {
    /// Empty.
    pub const fn new() -> Self {
        Self { stored: None, fail_next_save: false }
    }
}

impl<const CAP: usize> PlanStore for MemStore<CAP> {
    fn save(&mut self, header: &FlashHeader, image: &[u8]) -> Result<(), StoreError> {
        if core::mem::take(&mut self.fail_next_save) {
            return Err(StoreError::WriteFailed);
        }
        let copy = Vec::from_slice(image).map_err(|_| StoreError::TooLarge)?;
        self.stored = Some((*header, copy));
        Ok(())
    }

    fn load(&mut self, image: &mut [u8]) -> Result<Option<(FlashHeader, usize)>, StoreError> {
        let Some((header, stored)) = &self.stored else { return Ok(None) };
        let dst = image.get_mut(..stored.len()).ok_or(StoreError::TooLarge)?;
        dst.copy_from_slice(stored);
        Ok(Some((*header, stored.len())))
    }
}
