//! Attacks the frame decoder with over a million damaged frames: random bytes, truncations,
//! bit flips and overwritten bursts of valid frames. Nothing may panic and every damaged
//! frame must be rejected; the counts per kind of damage and per rejection reason are printed
//! (`--nocapture`) and included in the assertion message. Seeded: `MESOPUSH_SEED=<u64>`
//! replays another run.

mod common;

use mesopush_protocol::flash::{FLASH_CHUNK_MAX_BYTES, FlashChunk};
use mesopush_protocol::{
    CtrlToExec, ExecToCtrl, ExecToHost, FRAME_BUF_LEN, HostToExec, WireError, decode_frame,
};
use std::collections::BTreeMap;

/// xorshift64*: tiny, seedable, good enough to pick damage.
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
}

#[derive(Clone, Copy)]
enum Kind {
    HostToExec,
    ExecToHost,
    ExecToCtrl,
    CtrlToExec,
}

const KINDS: [Kind; 4] = [Kind::HostToExec, Kind::ExecToHost, Kind::ExecToCtrl, Kind::CtrlToExec];

fn decode(kind: Kind, bytes: &mut [u8]) -> Result<(), WireError> {
    match kind {
        Kind::HostToExec => decode_frame::<HostToExec>(bytes).map(drop),
        Kind::ExecToHost => decode_frame::<ExecToHost>(bytes).map(drop),
        Kind::ExecToCtrl => decode_frame::<ExecToCtrl>(bytes).map(drop),
        Kind::CtrlToExec => decode_frame::<CtrlToExec>(bytes).map(drop),
    }
}

/// Valid frames of every variant, plus long flash chunks with random (often zero-free) data
/// so that COBS runs of 254 bytes are attacked too.
fn base_frames(rng: &mut Rng) -> Vec<(Kind, Vec<u8>)> {
    let mut out = Vec::new();
    for (name, bytes) in common::all_sample_frames() {
        let kind = match name.split('.').next() {
            Some("host") => Kind::HostToExec,
            Some("exec") => Kind::ExecToHost,
            Some("ctrl_cmd") => Kind::ExecToCtrl,
            _ => Kind::CtrlToExec,
        };
        out.push((kind, bytes));
    }
    for i in 0..64 {
        let len = if i % 2 == 0 { FLASH_CHUNK_MAX_BYTES } else { rng.below(FLASH_CHUNK_MAX_BYTES) };
        let zero_free = i % 4 < 2;
        let data: Vec<u8> = (0..len)
            .map(|_| {
                let b = rng.next_u64() as u8;
                if zero_free { b | 1 } else { b }
            })
            .collect();
        let chunk = FlashChunk {
            plan_id: rng.next_u64() as u32,
            offset_bytes: rng.next_u64() as u32,
            data: heapless::Vec::from_slice(&data).expect("bounded"),
        };
        out.push((Kind::HostToExec, common::data_frame(i, i, HostToExec::FlashChunk(chunk))));
    }
    out
}

#[derive(Default)]
struct Tally {
    tried: BTreeMap<&'static str, u64>,
    accepted: BTreeMap<&'static str, u64>,
    unchanged_skipped: u64,
    reasons: BTreeMap<String, u64>,
}

impl Tally {
    fn record(&mut self, damage: &'static str, result: Result<(), WireError>) {
        *self.tried.entry(damage).or_default() += 1;
        match result {
            Ok(()) => *self.accepted.entry(damage).or_default() += 1,
            Err(e) => {
                let reason = format!("{e:?}");
                let reason = reason.split([' ', '{', '(']).next().unwrap_or("?").to_string();
                *self.reasons.entry(reason).or_default() += 1;
            }
        }
    }
    fn total(&self) -> u64 {
        self.tried.values().sum()
    }
    fn summary(&self, seed: u64) -> String {
        format!(
            "seed {seed}: {} damaged frames decoded; by damage {:?}; accepted {:?}; \
             rejected by reason {:?}; identical-after-flip skipped {}",
            self.total(),
            self.tried,
            self.accepted,
            self.reasons,
            self.unchanged_skipped
        )
    }
}

fn random_bytes(rng: &mut Rng, tally: &mut Tally) {
    let len = rng.below(FRAME_BUF_LEN + 40);
    let zero_rate = 1 + rng.below(64); // sometimes zero-dense, sometimes zero-free
    let mut bytes: Vec<u8> = (0..len)
        .map(|_| if rng.below(zero_rate) == 0 { 0 } else { rng.next_u64() as u8 })
        .collect();
    let kind = KINDS[rng.below(4)];
    tally.record("random", decode(kind, &mut bytes));
}

fn truncated(rng: &mut Rng, base: &[(Kind, Vec<u8>)], tally: &mut Tally) {
    let (kind, frame) = &base[rng.below(base.len())];
    let keep = rng.below(frame.len() - 1); // at least the delimiter and one byte lost
    let mut bytes = frame[..keep].to_vec();
    if rng.below(2) == 0 {
        bytes.push(0); // a receiver that resynchronised at a delimiter
    }
    tally.record("truncated", decode(*kind, &mut bytes));
}

fn bit_flipped(rng: &mut Rng, base: &[(Kind, Vec<u8>)], tally: &mut Tally) {
    let (kind, frame) = &base[rng.below(base.len())];
    let mut bytes = frame.clone();
    for _ in 0..1 + rng.below(8) {
        let bit = rng.below(bytes.len() * 8);
        bytes[bit / 8] ^= 1 << (bit % 8);
    }
    if bytes == *frame {
        tally.unchanged_skipped += 1;
        return;
    }
    tally.record("bit_flipped", decode(*kind, &mut bytes));
}

fn burst_overwritten(rng: &mut Rng, base: &[(Kind, Vec<u8>)], tally: &mut Tally) {
    let (kind, frame) = &base[rng.below(base.len())];
    let mut bytes = frame.clone();
    let start = rng.below(bytes.len());
    let end = (start + 1 + rng.below(16)).min(bytes.len());
    for b in &mut bytes[start..end] {
        *b = rng.next_u64() as u8;
    }
    if bytes == *frame {
        tally.unchanged_skipped += 1;
        return;
    }
    tally.record("burst", decode(*kind, &mut bytes));
}

#[test]
fn decoder_rejects_a_million_damaged_frames() {
    let seed = std::env::var("MESOPUSH_SEED").ok().and_then(|s| s.parse().ok());
    let seed: u64 = seed.unwrap_or(0x6d65_736f_7075_7368);
    let mut rng = Rng(seed | 1);
    let base = base_frames(&mut rng);
    for (kind, frame) in &base {
        assert_eq!(decode(*kind, &mut frame.clone()), Ok(()), "base frames are valid");
    }
    let mut tally = Tally::default();
    for _ in 0..250_000 {
        random_bytes(&mut rng, &mut tally);
        truncated(&mut rng, &base, &mut tally);
        bit_flipped(&mut rng, &base, &mut tally);
        burst_overwritten(&mut rng, &base, &mut tally);
    }
    // Every truncation of every base frame, exhaustively.
    for (kind, frame) in &base {
        for keep in 0..frame.len() - 1 {
            tally.record("truncated", decode(*kind, &mut frame[..keep].to_vec()));
        }
    }
    let summary = tally.summary(seed);
    println!("{summary}");
    assert!(tally.total() >= 1_000_000, "too few frames: {summary}");
    assert!(tally.accepted.is_empty(), "damaged frames accepted: {summary}");
}
