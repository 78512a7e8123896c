//! Property test over every loader (issue 19): valid files — a plan, a model, a fixture, a
//! world, a trial's trial.json / probe.csv / pose.csv, an LCP file, PNG frames, a Zhou-Mason
//! run file — are mutated from fixed seeds (`common::mutate`: numbers replaced by NaN, ±inf,
//! ±1e300, −1 or 0, lines dropped, duplicated or swapped, files truncated, PNG bytes flipped
//! or re-encoded), random bytes are given to each loader, and each is fed to the real binary;
//! whatever the input, it must end with exit code 0, 1 or 2 — never a panic (exit code 101),
//! a signal or a hang. The seeds are fixed, so every run tries the same files; a failure
//! names its kind, seed and mutation.

mod common;

use common::mutate::{mutate_bytes, mutate_text, number_spans};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Longer than any of these commands takes on valid input in the test profile.
const LIMIT: Duration = Duration::from_secs(120);

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
