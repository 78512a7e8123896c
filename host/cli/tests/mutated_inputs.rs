//! Property test over every loader (issue 19): valid files — a plan, a model, a fixture, a
//! world, a trial's trial.json / probe.csv / pose.csv, an LCP file, PNG frames, a Zhou-Mason
//! run file — are mutated from fixed seeds, and random bytes are given to each loader (numbers replaced by NaN, ±inf, ±1e300, −1 or 0,
//! lines dropped, duplicated or swapped, files truncated, bytes flipped) and fed to the real
//! binary; whatever the mutation, it must end with exit code 0, 1 or 2 — never a panic
//! (exit code 101), a signal or a hang. The seeds are fixed, so every run tries the same
//! files; a failure names its kind, seed and mutation.

mod common;

use rand::{Rng, RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Longer than any of these commands takes on valid input in the test profile.
const LIMIT: Duration = Duration::from_secs(120);

/// The numbers a mutation puts in place of one (TOML spellings; CSV and the LCP reader take
/// them too, JSON refuses the non-finite ones as a parse error).
const NUMBERS: [&str; 9] = ["nan", "inf", "-inf", "1e300", "-1e300", "-1", "0", "1e-300", "-0.0"];

/// Byte spans of the numbers in `text`: runs of digits, signs, points and exponents that
/// hold a digit.
fn number_spans(text: &str) -> Vec<(usize, usize)> {
    let b = text.as_bytes();
    let mut spans = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let starts = b[i].is_ascii_digit()
            || (matches!(b[i], b'-' | b'.') && b.get(i + 1).is_some_and(u8::is_ascii_digit));
        if !starts {
            i += 1;
            continue;
        }
        let j = (i + 1..b.len())
            .find(|&k| !(b[k].is_ascii_digit() || matches!(b[k], b'.' | b'e' | b'E' | b'-' | b'+')))
            .unwrap_or(b.len());
        spans.push((i, j));
        i = j;
    }
    spans
}

/// One to three text mutations of `text`, and what they were.
fn mutate_text(text: &str, rng: &mut impl Rng) -> (String, String) {
    let mut t = text.to_string();
    let mut what = Vec::new();
    for _ in 0..rng.random_range(1..=3) {
        let lines: Vec<&str> = t.lines().collect();
        let spans = number_spans(&t);
        match rng.random_range(0..6) {
            0 | 1 if !spans.is_empty() => {
                let (a, b) = spans[rng.random_range(0..spans.len())];
                let n = NUMBERS[rng.random_range(0..NUMBERS.len())];
                what.push(format!("number {:?} at byte {a} -> {n}", &t[a..b]));
                t.replace_range(a..b, n);
            }
            2 if lines.len() > 1 => {
                let k = rng.random_range(0..lines.len());
                what.push(format!("line {} dropped", k + 1));
                t = lines
                    .iter()
                    .enumerate()
                    .filter(|(i, _)| *i != k)
                    .map(|(_, l)| *l)
                    .collect::<Vec<_>>()
                    .join("\n");
            }
            3 if !lines.is_empty() => {
                let k = rng.random_range(0..lines.len());
                what.push(format!("line {} duplicated", k + 1));
                let mut v = lines.clone();
                v.insert(k, lines[k]);
                t = v.join("\n");
            }
            4 if lines.len() > 1 => {
                let (i, j) = (rng.random_range(0..lines.len()), rng.random_range(0..lines.len()));
                what.push(format!("lines {} and {} swapped", i + 1, j + 1));
                let mut v = lines.clone();
                v.swap(i, j);
                t = v.join("\n");
            }
            _ => {
                let mut cut = rng.random_range(0..=t.len());
                while !t.is_char_boundary(cut) {
                    cut -= 1;
                }
                what.push(format!("truncated at byte {cut}"));
                t.truncate(cut);
            }
        }
    }
    (t, what.join(", "))
}

/// A PNG of `img` (encoding a valid image cannot fail).
fn png(img: image::DynamicImage) -> Vec<u8> {
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).expect("encode png");
    out.into_inner()
}

/// A PNG truncated, bit-flipped or its header's size overwritten (all caught by the
/// decoder), or re-encoded as a valid PNG the tracker must cope with: another size (down to
/// 1 × 1 px), one flat grey level, random noise, colour or 16-bit samples.
fn mutate_bytes(bytes: &[u8], rng: &mut impl Rng) -> (Vec<u8>, String) {
    use image::{DynamicImage, GrayImage, Luma};
    let mut b = bytes.to_vec();
    let orig = image::load_from_memory(bytes).expect("the corpus PNG decodes");
    let (w, h) = (orig.width(), orig.height());
    match rng.random_range(0..7) {
        0 => {
            let cut = rng.random_range(0..b.len());
            b.truncate(cut);
            (b, format!("truncated at byte {cut}"))
        }
        1 => {
            let n = rng.random_range(1..=8);
            for _ in 0..n {
                let k = rng.random_range(0..b.len());
                b[k] ^= 1 << rng.random_range(0..8);
            }
            (b, format!("{n} bits flipped"))
        }
        2 => {
            let (w, h) = (rng.random_range(0..u32::MAX), rng.random_range(0..u32::MAX));
            b[16..20].copy_from_slice(&w.to_be_bytes());
            b[20..24].copy_from_slice(&h.to_be_bytes());
            (b, format!("header size set to {w} x {h}"))
        }
        3 => {
            let (w, h) = (rng.random_range(1..=200), rng.random_range(1..=200));
            let seed: u8 = rng.random();
            let img = GrayImage::from_fn(w, h, |x, y| Luma([(x * 7 + y * 13) as u8 ^ seed]));
            (png(DynamicImage::ImageLuma8(img)), format!("re-encoded as {w} x {h} px of noise"))
        }
        4 => {
            let v: u8 = [0, 255, rng.random()][rng.random_range(0..3)];
            let img = GrayImage::from_pixel(w, h, Luma([v]));
            (png(DynamicImage::ImageLuma8(img)), format!("re-encoded flat at grey {v}"))
        }
        5 => (png(DynamicImage::ImageRgb8(orig.to_rgb8())), "re-encoded as RGB".into()),
        _ => (png(DynamicImage::ImageLuma16(orig.to_luma16())), "re-encoded as 16-bit".into()),
    }
}

/// One kind of input: its valid file (relative to the corpus), and how a mutated copy is laid
/// out and run.
struct Kind {
    name: &'static str,
    /// Mutations tried.
    count: u64,
    /// Lays out the mutated input in `dir` from the seed's rng; returns the arguments and the
    /// mutation's description.
    make: fn(&Path, &Path, &mut ChaCha8Rng) -> (Vec<String>, String),
}

fn s(p: impl AsRef<Path>) -> String {
    p.as_ref().display().to_string()
}

/// Writes a text mutation of `corpus/rel` to `dir/name`; returns its path and description.
fn text_file(
    c: &Path,
    rel: &str,
    dir: &Path,
    name: &str,
    rng: &mut ChaCha8Rng,
) -> (PathBuf, String) {
    let text = std::fs::read_to_string(c.join(rel)).expect("valid corpus file");
    let (m, what) = mutate_text(&text, rng);
    let path = dir.join(name);
    std::fs::write(&path, m).expect("write mutation");
    (path, what)
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).expect("mkdir");
    for e in std::fs::read_dir(from).expect("read corpus dir") {
        let e = e.expect("entry");
        if e.path().is_file() {
            std::fs::copy(e.path(), to.join(e.file_name())).expect("copy");
        }
    }
}

const KINDS: &[Kind] = &[
    Kind {
        name: "plan (sim)",
        count: 60,
        make: |c, d, r| {
            let (f, w) = text_file(c, "plans/valid.toml", d, "plan.toml", r);
            (vec!["sim".into(), "--plan".into(), s(f), "--out".into(), s(d.join("out"))], w)
        },
    },
    Kind {
        name: "model (sim)",
        count: 50,
        make: |c, d, r| {
            let (f, w) = text_file(c, "models/valid.toml", d, "model.toml", r);
            let plan = s(c.join("plans/short.toml"));
            (
                vec![
                    "sim".into(),
                    "--plan".into(),
                    plan,
                    "--model".into(),
                    s(f),
                    "--out".into(),
                    s(d.join("out")),
                ],
                w,
            )
        },
    },
    Kind {
        name: "fixture (sim)",
        count: 40,
        make: |c, d, r| {
            let (f, w) = text_file(c, "fixtures/valid.toml", d, "fixture.toml", r);
            let plan = s(c.join("plans/short.toml"));
            (
                vec![
                    "sim".into(),
                    "--plan".into(),
                    plan,
                    "--fixture".into(),
                    s(f),
                    "--out".into(),
                    s(d.join("out")),
                ],
                w,
            )
        },
    },
    Kind {
        name: "world (demo)",
        count: 30,
        make: |c, d, r| {
            let (f, w) = text_file(c, "worlds/valid.toml", d, "world.toml", r);
            let plan = s(c.join("plans/short.toml"));
            (
                vec![
                    "demo".into(),
                    "--plan".into(),
                    plan,
                    "--world".into(),
                    s(f),
                    "--out".into(),
                    s(d.join("out")),
                    "--json".into(),
                ],
                w,
            )
        },
    },
    Kind {
        name: "trial files (replay)",
        count: 60,
        make: |c, d, r| {
            let trial = d.join("trial");
            copy_dir(&c.join("trials/valid/synth-00"), &trial);
            let file = ["trial.json", "probe.csv", "pose.csv"][r.random_range(0..3)];
            let (_, w) = text_file(&trial, file, &trial, file, r);
            let model = s(c.join("models/valid.toml"));
            (
                vec![
                    "replay".into(),
                    "--model".into(),
                    model,
                    s(&trial),
                    "--no-fig".into(),
                    "--out".into(),
                    s(d.join("out")),
                ],
                format!("{file}: {w}"),
            )
        },
    },
    Kind {
        name: "LCP file (lcp solve)",
        count: 50,
        make: |c, d, r| {
            let (f, w) = text_file(c, "lcp/valid.dat", d, "p.dat", r);
            (vec!["lcp".into(), "solve".into(), s(f)], w)
        },
    },
    Kind {
        name: "PNG frame or background (track)",
        count: 40,
        make: |c, d, r| {
            let frames = d.join("frames");
            copy_dir(&c.join("images/valid/frames"), &frames);
            let bg = d.join("background.png");
            std::fs::copy(c.join("images/valid/background.png"), &bg).expect("copy");
            let target = if r.random_bool(0.5) { bg.clone() } else { frames.join("frame-001.png") };
            let (m, w) = mutate_bytes(&std::fs::read(&target).expect("read png"), r);
            std::fs::write(&target, m).expect("write png");
            let what =
                format!("{}: {w}", target.file_name().and_then(|n| n.to_str()).unwrap_or("?"));
            (
                vec![
                    "track".into(),
                    s(&frames),
                    "--background".into(),
                    s(&bg),
                    "--out".into(),
                    s(d.join("pose.csv")),
                ],
                what,
            )
        },
    },
    Kind {
        name: "Zhou-Mason run file (import)",
        count: 40,
        make: |c, d, r| {
            let rel = "tri/tri_0_0_90/log2017-05-23_20-25-09.txt";
            let dir = d.join("data/tri/tri_0_0_90");
            std::fs::create_dir_all(&dir).expect("mkdir");
            let (_, w) =
                text_file(&c.join("import/valid"), rel, &dir, "log2017-05-23_20-25-09.txt", r);
            (
                vec![
                    "import".into(),
                    "zhou-mason".into(),
                    s(d.join("data")),
                    "--out".into(),
                    s(d.join("out")),
                ],
                w,
            )
        },
    },
    Kind {
        name: "random bytes (every loader)",
        count: 40,
        make: |c, d, r| {
            let n = r.random_range(0..2000);
            let text = r.random_bool(0.5);
            let bytes: Vec<u8> = (0..n)
                .map(|_| {
                    if text {
                        let alphabet = b" \n,.=[]-+e0123456789nainf";
                        alphabet[r.random_range(0..alphabet.len())]
                    } else {
                        r.random()
                    }
                })
                .collect();
            let f = d.join("input");
            std::fs::write(&f, &bytes).expect("write");
            let (plan, out) = (s(c.join("plans/short.toml")), s(d.join("out")));
            let frames = s(c.join("images/valid/frames"));
            let (f, what) =
                (s(&f), format!("{n} random {}", if text { "characters" } else { "bytes" }));
            let args: Vec<&str> = match r.random_range(0..6) {
                0 => vec!["sim", "--plan", &f, "--out", &out],
                1 => vec!["sim", "--plan", &plan, "--model", &f, "--out", &out],
                2 => vec!["sim", "--plan", &plan, "--fixture", &f, "--out", &out],
                3 => vec!["demo", "--plan", &plan, "--world", &f, "--out", &out],
                4 => vec!["lcp", "solve", &f],
                _ => vec!["track", &frames, "--background", &f, "--out", &out],
            };
            (args.into_iter().map(String::from).collect(), what)
        },
    },
];

#[test]
fn mutated_valid_inputs_never_panic() {
    let c = common::corpus();
    let runs: Vec<(usize, u64)> = KINDS
        .iter()
        .enumerate()
        .flat_map(|(k, kind)| (0..kind.count).map(move |i| (k, i)))
        .collect();
    let ends: Vec<(usize, Option<i32>, Option<String>)> = runs
        .par_iter()
        .map(|&(k, i)| {
            let kind = &KINDS[k];
            let seed = 1000 * k as u64 + i;
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let tmp = tempfile::tempdir().expect("temporary directory");
            let (args, what) = (kind.make)(&c, tmp.path(), &mut rng);
            let ended = common::run(&common::binary("mesopush"), &args, tmp.path(), LIMIT);
            let ok = !ended.panicked() && !ended.timed_out && matches!(ended.code, Some(0..=2));
            let failure = (!ok).then(|| {
                let tail: String =
                    ended.stderr.lines().rev().take(6).collect::<Vec<_>>().join(" | ");
                format!(
                    "{} seed {seed} ({what}): exit {:?}, timed out {}: {tail}",
                    kind.name, ended.code, ended.timed_out
                )
            });
            (k, ended.code, failure)
        })
        .collect();
    for (k, kind) in KINDS.iter().enumerate() {
        let code = |c| ends.iter().filter(|e| e.0 == k && e.1 == Some(c)).count();
        eprintln!("{:<34} exit 0: {:>3}, 1: {:>3}, 2: {:>3}", kind.name, code(0), code(1), code(2));
        // The mutations reach the checks: some of each kind are refused as invalid input.
        assert!(code(2) > 0, "no mutated {} was refused", kind.name);
    }
    let failures: Vec<&String> = ends.iter().filter_map(|e| e.2.as_ref()).collect();
    assert!(
        failures.is_empty(),
        "{} of {} mutated inputs failed:\n{}",
        failures.len(),
        runs.len(),
        failures.iter().map(|f| f.as_str()).collect::<Vec<_>>().join("\n")
    );
}

#[test]
fn the_mutations_are_the_same_on_every_run() {
    let text = "a = 1.5\nb = [2, -3e4]\nc = \"x\"\n";
    let draw = |seed| mutate_text(text, &mut ChaCha8Rng::seed_from_u64(seed));
    assert_eq!(draw(7), draw(7));
    assert_eq!(number_spans(text).len(), 3);
}
