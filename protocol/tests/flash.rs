//! Flash images: chunking and reassembly, and every way a bad image is refused with its
//! reason (the executor relies on these checks before accepting a plan).

use mesopush_protocol::flash::{
    FLASH_CHUNK_MAX_BYTES, FLASH_FORMAT_VERSION, FlashHeader, FlashRejectReason,
    PLAN_STEP_LEN_BYTES, PlanStep, image_chunks, image_crc32, image_steps,
};
use mesopush_protocol::host::Hello;
use mesopush_protocol::{PROTOCOL_VERSION, SCHEMA_HASH};

fn plan(step_count: i32) -> Vec<u8> {
    (0..step_count)
        .map(|i| PlanStep { dx_nm: 1_000 * i, dy_nm: -7 * i, speed_nm_s: 20_000 + i as u32 })
        .flat_map(|s| s.to_image_bytes())
        .collect()
}

#[test]
fn chunks_reassemble_into_a_verified_image() {
    let image = plan(37); // 444 bytes: two full chunks and a partial one
    let header = FlashHeader::for_image(9, &image).expect("whole steps");
    assert_eq!(header.step_count, 37);
    assert_eq!(header.format_version, FLASH_FORMAT_VERSION);
    let mut received = Vec::new();
    for chunk in image_chunks(9, &image) {
        assert_eq!(chunk.plan_id, 9);
        assert_eq!(chunk.offset_bytes as usize, received.len(), "in order, no gaps");
        assert!(chunk.data.len() <= FLASH_CHUNK_MAX_BYTES);
        received.extend_from_slice(&chunk.data);
    }
    assert_eq!(received, image);
    assert_eq!(header.verify_image(&received), Ok(()));
    assert_eq!(image_steps(&received).count(), 37);
    assert_eq!(
        image_steps(&received).nth(5),
        Some(PlanStep { dx_nm: 5_000, dy_nm: -35, speed_nm_s: 20_005 })
    );
}

#[test]
fn truncated_image_is_rejected_as_truncated() {
    let image = plan(20);
    let header = FlashHeader::for_image(1, &image).expect("whole steps");
    let cut = &image[..image.len() - PLAN_STEP_LEN_BYTES];
    assert_eq!(
        header.verify_image(cut),
        Err(FlashRejectReason::LengthMismatch { expected_len_bytes: 240, received_len_bytes: 228 })
    );
}

#[test]
fn corrupted_image_is_rejected_by_crc() {
    let image = plan(20);
    let header = FlashHeader::for_image(1, &image).expect("whole steps");
    for byte in [0, 100, image.len() - 1] {
        let mut bad = image.clone();
        bad[byte] ^= 0x10;
        assert_eq!(
            header.verify_image(&bad),
            Err(FlashRejectReason::CrcMismatch {
                expected_crc32: image_crc32(&image),
                computed_crc32: image_crc32(&bad)
            }),
            "flip in byte {byte}"
        );
    }
}

#[test]
fn bad_headers_are_rejected_with_their_reason() {
    let image = plan(4);
    let good = FlashHeader::for_image(1, &image).expect("whole steps");
    let version = FlashHeader { format_version: 2, ..good };
    assert_eq!(
        version.verify_image(&image),
        Err(FlashRejectReason::UnsupportedFormatVersion { got: 2 })
    );
    let count = FlashHeader { step_count: 5, ..good };
    assert_eq!(
        count.check(1 << 20),
        Err(FlashRejectReason::StepCountMismatch { step_count: 5, image_len_bytes: 48 })
    );
    assert_eq!(
        good.check(47),
        Err(FlashRejectReason::TooLarge { image_len_bytes: 48, capacity_bytes: 47 })
    );
    assert_eq!(good.check(48), Ok(()));
    assert_eq!(
        FlashHeader::for_image(1, &image[..13]),
        Err(FlashRejectReason::PartialStep { image_len_bytes: 13 })
    );
}

#[test]
fn crc_is_the_standard_crc32() {
    // CRC-32/ISO-HDLC check value from the CRC catalogue.
    assert_eq!(image_crc32(b"123456789"), 0xCBF4_3926);
}

#[test]
fn hello_compatibility_requires_equal_version_and_schema() {
    assert!(Hello::CURRENT.is_compatible());
    assert_eq!(Hello::CURRENT.protocol_version, PROTOCOL_VERSION);
    let other_schema = Hello { schema_hash: SCHEMA_HASH ^ 1, ..Hello::CURRENT };
    assert!(!other_schema.is_compatible());
    let other_version = Hello { protocol_version: PROTOCOL_VERSION + 1, ..Hello::CURRENT };
    assert!(!other_version.is_compatible());
}
