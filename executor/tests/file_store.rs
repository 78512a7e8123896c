//! The std plan store: atomic replacement, and a failed write leaves the old plan.
#![cfg(feature = "std")]

use mesopush_executor::store::file::FileStore;
use mesopush_executor::store::load_plan;
use mesopush_executor::{PlanStore, StoreError};
use mesopush_protocol::flash::{FlashHeader, PlanStep};

fn plan(plan_id: u32, n: i32) -> (FlashHeader, Vec<u8>) {
    let image: Vec<u8> = (0..n)
        .flat_map(|i| PlanStep { dx_nm: i + 1, dy_nm: -i, speed_nm_s: 1_000 }.to_image_bytes())
        .collect();
    (FlashHeader::for_image(plan_id, &image).unwrap(), image)
}

#[test]
fn save_then_load_round_trips() {
    let dir = tempfile::tempdir().unwrap();
    let mut store = FileStore::new(dir.path().join("plan.bin"));
    let mut buf = [0u8; 1200];
    assert_eq!(store.load(&mut buf), Ok(None));
    let (header, image) = plan(3, 10);
    store.save(&header, &image).unwrap();
    assert_eq!(store.load(&mut buf), Ok(Some((header, image.len()))));
    assert_eq!(&buf[..image.len()], &image[..]);
    let loaded = load_plan::<1200>(&mut store).unwrap().expect("stored");
    assert_eq!(loaded.plan_id(), 3);
}

#[test]
fn a_failed_write_leaves_the_old_plan() {
    let dir = tempfile::tempdir().unwrap();
    let mut store = FileStore::new(dir.path().join("plan.bin"));
    let (old_header, old_image) = plan(1, 4);
    store.save(&old_header, &old_image).unwrap();
    // Make the temporary file impossible to create: a directory sits at its path.
    std::fs::create_dir(store.tmp_path()).unwrap();
    let (new_header, new_image) = plan(2, 8);
    assert_eq!(store.save(&new_header, &new_image), Err(StoreError::WriteFailed));
    let mut buf = [0u8; 1200];
    assert_eq!(store.load(&mut buf), Ok(Some((old_header, old_image.len()))));
    assert_eq!(&buf[..old_image.len()], &old_image[..]);
}

#[test]
fn an_interrupted_save_is_ignored_and_overwritten() {
    let dir = tempfile::tempdir().unwrap();
    let mut store = FileStore::new(dir.path().join("plan.bin"));
    let (old_header, old_image) = plan(1, 4);
    store.save(&old_header, &old_image).unwrap();
    // A crash mid-save leaves half a temporary file behind.
    std::fs::write(store.tmp_path(), [0xAB; 7]).unwrap();
    let mut buf = [0u8; 1200];
    assert_eq!(store.load(&mut buf), Ok(Some((old_header, old_image.len()))));
    let (new_header, new_image) = plan(2, 8);
    store.save(&new_header, &new_image).unwrap();
    assert_eq!(store.load(&mut buf), Ok(Some((new_header, new_image.len()))));
    assert!(!store.tmp_path().exists());
}

#[test]
fn a_damaged_file_is_reported_corrupt() {
    let dir = tempfile::tempdir().unwrap();
    let mut store = FileStore::new(dir.path().join("plan.bin"));
    let (header, image) = plan(1, 4);
    store.save(&header, &image).unwrap();
    let mut bytes = std::fs::read(store.path()).unwrap();
    let last = bytes.len() - 1;
    bytes[last] ^= 1;
    std::fs::write(store.path(), &bytes).unwrap();
    let mut buf = [0u8; 1200];
    assert_eq!(store.load(&mut buf), Err(StoreError::Corrupt));
    std::fs::write(store.path(), &bytes[..10]).unwrap();
    assert_eq!(store.load(&mut buf), Err(StoreError::Corrupt));
}
