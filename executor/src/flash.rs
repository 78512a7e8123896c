//! Reassembles a plan image from flash chunks into a staging buffer.
//!
//! The previously accepted plan lives elsewhere ([`crate::plan::FlashedPlan`] in the executor) and
//! is not touched while an upload is in progress: a corrupt or truncated upload is rejected
//! and the old plan stays. Checks, in order: header ([`FlashHeader::check`] against the plan
//! memory `CAP`), each chunk (plan id, offset = bytes so far, not past the declared length),
//! then at commit the whole image ([`FlashHeader::verify_image`]: length, then CRC-32).

use crate::plan::FlashedPlan;
use heapless::Vec;
use mesopush_protocol::flash::{FlashChunk, FlashHeader, FlashRejectReason};

/// An upload in progress, with a `CAP`-byte staging buffer.
#[derive(Debug, Default)]
pub struct FlashSession<const CAP: usize> {
    header: Option<FlashHeader>,
    staging: Vec<u8, CAP>,
}

impl<const CAP: usize> FlashSession<CAP> {
    /// No upload in progress.
    pub const fn new() -> Self {
        Self { header: None, staging: Vec::new() }
    }

    /// Plan memory, bytes.
    pub fn capacity_bytes() -> u32 {
        u32::try_from(CAP).unwrap_or(u32::MAX)
    }

    /// The header of the upload in progress, if any.
    pub fn header(&self) -> Option<&FlashHeader> {
        self.header.as_ref()
    }

    /// Starts an upload, dropping any unfinished one.
    pub fn begin(&mut self, header: FlashHeader) -> Result<(), FlashRejectReason> {
        self.cancel();
        header.check(Self::capacity_bytes())?;
        self.header = Some(header);
        Ok(())
    }

    /// Appends a chunk; returns the image bytes received so far. A bad chunk cancels the
    /// upload.
    pub fn chunk(&mut self, chunk: &FlashChunk) -> Result<u32, FlashRejectReason> {
        let result = self.try_chunk(chunk);
        if result.is_err() {
            self.cancel();
        }
        result
    }

    fn try_chunk(&mut self, chunk: &FlashChunk) -> Result<u32, FlashRejectReason> {
        let header = self.header.ok_or(FlashRejectReason::NoFlashInProgress)?;
        if chunk.plan_id != header.plan_id {
            return Err(FlashRejectReason::PlanIdMismatch {
                expected_plan_id: header.plan_id,
                got_plan_id: chunk.plan_id,
            });
        }
        let received = self.staging.len() as u32;
        let end = u64::from(chunk.offset_bytes) + chunk.data.len() as u64;
        if chunk.offset_bytes != received || end > u64::from(header.image_len_bytes) {
            return Err(FlashRejectReason::OutOfOrderChunk {
                expected_offset_bytes: received,
                got_offset_bytes: chunk.offset_bytes,
            });
        }
        // Cannot fail: the header check bounded image_len_bytes by CAP.
        self.staging.extend_from_slice(&chunk.data).map_err(|_| FlashRejectReason::TooLarge {
            image_len_bytes: header.image_len_bytes,
            capacity_bytes: Self::capacity_bytes(),
        })?;
        Ok(self.staging.len() as u32)
    }

    /// Verifies the whole image and hands it over as a plan; the session is over either way.
    pub fn commit(&mut self, plan_id: u32) -> Result<FlashedPlan<CAP>, FlashRejectReason> {
        let header = self.header.take().ok_or(FlashRejectReason::NoFlashInProgress)?;
        let image = core::mem::take(&mut self.staging);
        if plan_id != header.plan_id {
            return Err(FlashRejectReason::PlanIdMismatch {
                expected_plan_id: header.plan_id,
                got_plan_id: plan_id,
            });
        }
        FlashedPlan::from_verified(header, image)
    }

    /// Drops the upload in progress.
    pub fn cancel(&mut self) {
        self.header = None;
        self.staging.clear();
    }
}
