//! The store written and read back: bit-identical pixels and times for frames made by an
//! independent generator (a xorshift over a gradient, not the renderer), a store cut short
//! by a crash reads up to its last whole page, and files that are not stores are refused
//! with the file and the page named.

use mesopush_framestore::{Error, FrameStore, PageMeta, STORE_FILE, StoreWriter};
use std::path::Path;

/// A frame of `w × h` px: a gradient with xorshift noise (seeded), so compression has
/// something real to do and every byte value occurs.
fn frame(seed: u64, w: u32, h: u32) -> Vec<u8> {
    let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    (0..w * h)
        .map(|i| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let base = (i % w) * 200 / w;
            (base as u8).wrapping_add((s % 48) as u8)
        })
        .collect()
}

fn write(path: &Path, metas: &[PageMeta], w: u32, h: u32) -> Vec<u64> {
    let mut wr = StoreWriter::create(path).unwrap();
    let mut sizes = Vec::new();
    for m in metas {
        wr.push(*m, w, h, &frame(m.index, w, h)).unwrap();
        sizes.push(std::fs::metadata(path).unwrap().len());
    }
    assert_eq!(wr.finish().unwrap(), metas.len() as u64);
    sizes
}

fn metas(n: u64) -> Vec<PageMeta> {
    (0..n)
        .map(|i| PageMeta {
            index: 3 * i + 1,
            t_capture_us: if i == 2 { None } else { Some(33_333 * i as i64 - 500) },
        })
        .collect()
}

#[test]
fn frames_and_times_read_back_bit_identical() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(STORE_FILE);
    let (w, h) = (157, 131); // odd sizes: strips of 64 rows leave a partial one
    let m = metas(6);
    write(&path, &m, w, h);
    let mut store = FrameStore::open(&path).unwrap();
    assert_eq!(store.pages(), &m[..]);
    for (page, meta) in m.iter().enumerate().rev() {
        let f = store.read(page).unwrap();
        assert_eq!((f.width, f.height, f.meta), (w, h, *meta));
        assert!(f.pixels == frame(meta.index, w, h), "page {page} differs");
    }
    let err = store.read(6).unwrap_err().to_string();
    assert!(err.contains("page 6") && err.contains("has 6"), "{err}");
}

#[test]
fn a_store_is_never_overwritten() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(STORE_FILE);
    write(&path, &metas(1), 8, 8);
    assert!(matches!(StoreWriter::create(&path), Err(Error::Io { .. })));
}

#[test]
fn frames_of_another_size_or_length_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut wr = StoreWriter::create(&dir.path().join(STORE_FILE)).unwrap();
    let m = PageMeta { index: 0, t_capture_us: Some(0) };
    let short = wr.push(m, 10, 10, &[0; 99]).unwrap_err().to_string();
    assert!(short.contains("99 bytes for 10 × 10"), "{short}");
    wr.push(m, 10, 10, &[0; 100]).unwrap();
    let other = wr.push(m, 12, 10, &[0; 120]).unwrap_err().to_string();
    assert!(other.contains("12 × 10 px in a store of 10 × 10"), "{other}");
}

#[test]
fn a_store_cut_short_by_a_crash_reads_up_to_its_last_whole_page() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(STORE_FILE);
    let m = metas(4);
    let sizes = write(&path, &m, 64, 48);
    let full = std::fs::read(&path).unwrap();
    let cut = ((sizes[2] + sizes[3]) / 2) as usize;
    // the process died while writing page 3: page 2 still ends the chain
    let mut torn = full[..cut].to_vec();
    let mut w = StoreWriter::create(&dir.path().join("three.tif")).unwrap();
    for meta in &m[..3] {
        w.push(*meta, 64, 48, &frame(meta.index, 64, 48)).unwrap();
    }
    w.finish().unwrap();
    let three = std::fs::read(dir.path().join("three.tif")).unwrap();
    // the same bytes but page 2's link, still 0: what the disk held while page 3 was written
    assert_eq!(three.len(), sizes[2] as usize);
    torn[..three.len()].copy_from_slice(&three);
    std::fs::write(&path, &torn).unwrap();
    let mut store = FrameStore::open(&path).unwrap();
    assert_eq!((store.pages(), store.damage()), (&m[..3], None));
    assert!(store.read(2).unwrap().pixels == frame(m[2].index, 64, 48));
    // the link to page 3 reached the disk, page 3 did not (no ordering without fsync)
    std::fs::write(&path, &full[..cut]).unwrap();
    let mut store = FrameStore::open(&path).unwrap();
    assert_eq!(store.pages(), &m[..3]);
    let note = store.damage().expect("the cut is reported");
    assert!(note.contains("page 3 unreadable") && note.contains("ends after page 2"), "{note}");
    assert!(store.read(1).unwrap().pixels == frame(m[1].index, 64, 48));
}

fn refused(bytes: &[u8]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(STORE_FILE);
    std::fs::write(&path, bytes).unwrap();
    let err = FrameStore::open(&path).and_then(|mut s| s.read(0).map(|_| ())).unwrap_err();
    assert!(matches!(err, Error::Malformed { .. }), "{err:?}");
    let text = err.to_string();
    assert!(text.contains(STORE_FILE), "{text}");
    text
}

#[test]
fn files_that_are_not_stores_are_refused_naming_the_problem() {
    assert!(refused(b"").contains("not a readable TIFF"));
    assert!(refused(b"\x89PNG\r\n\x1a\n not a tiff").contains("not a readable TIFF"));
    // a valid TIFF without the store's page description (another program's stack)
    let mut plain = std::io::Cursor::new(Vec::new());
    tiff::encoder::TiffEncoder::new(&mut plain)
        .unwrap()
        .write_image::<tiff::encoder::colortype::Gray8>(4, 4, &[7; 16])
        .unwrap();
    assert!(refused(plain.get_ref()).contains("page 0: no frame description"));
    // an RGB page with the store's description
    let mut rgb = std::io::Cursor::new(Vec::new());
    let mut enc = tiff::encoder::TiffEncoder::new(&mut rgb).unwrap();
    let mut img = enc.new_image::<tiff::encoder::colortype::RGB8>(2, 2).unwrap();
    let desc = PageMeta { index: 0, t_capture_us: Some(0) }.describe();
    img.encoder().write_tag(tiff::tags::Tag::ImageDescription, desc.as_str()).unwrap();
    img.write_data(&[0; 12]).unwrap();
    assert!(
        refused(rgb.get_ref())
            .contains("page 0: 8-bit RGB colour pixels; the store holds 8-bit grey")
    );
    // a store whose first page's data is cut away
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(STORE_FILE);
    write(&path, &metas(1), 64, 64);
    let mut bytes = std::fs::read(&path).unwrap();
    bytes.truncate(40);
    refused(&bytes);
}
