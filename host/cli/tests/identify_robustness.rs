//! The identification → robustness pipeline through the command line: `identify run
//! --optimize` writes its consistent set (bootstrap refits included), `robustness --supports`
//! reads that very file and samples its (μ_probe, support) pairs whole, and `plan robust
//! --supports` designs and checks on the same pairs. Caught: identify wrote
//! `[[supports]]` while robustness read `[[support]]`, and no test joined the two.

use std::path::Path;
use std::process::{Command, Output};

const SEED: &str = "3";

fn mesopush(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mesopush")).args(args).current_dir(dir).output().unwrap()
}

fn ok(o: Output) -> serde_json::Value {
    assert!(o.status.success(), "seed {SEED}: {}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).unwrap()
}

#[test]
fn identify_writes_the_support_set_robustness_samples_as_pairs() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    ok(mesopush(&["identify", "synth", "trials", "--seed", SEED, "--json"], d));
    let id = ok(mesopush(
        &[
            "identify",
            "run",
            "trials",
            "--mu-step",
            "0.25",
            "--supports",
            "4",
            "--seed",
            SEED,
            "--optimize",
            "--max-evals",
            "60",
            "--bootstrap",
            "3",
            "--bootstrap-evals",
            "40",
            "--out",
            "model.toml",
            "--consistent-out",
            "set.toml",
            "--json",
        ],
        d,
    ));
    let boot = &id["report"]["bootstrap"];
    assert_eq!(boot["fits"].as_array().map(Vec::len), Some(3), "{boot}");
    let spread = boot["spread"].as_array().unwrap();
    assert_eq!(spread.len(), 8, "μ_probe, mean μ_s and six coordinates: {boot}");
    assert!(spread.iter().all(|s| s["sd"].as_f64().is_some_and(f64::is_finite)), "{boot}");
    let set = std::fs::read_to_string(d.join("set.toml")).unwrap();
    let members = set.matches("[[support]]").count();
    // Every refit joins the set. (With 20 evaluations per refit, Levenberg–Marquardt never
    // left the full fit: three identical refits, which made a count of three fail; 40 let
    // each resample move.)
    let fits = boot["fits"].as_array().unwrap();
    let mut distinct: Vec<String> = fits.iter().map(|f| f[0].to_string()).collect();
    distinct.sort();
    distinct.dedup();
    assert!(members >= distinct.len(), "the set holds at least the distinct refits:\n{set}");
    for f in fits {
        let mu = f[0]["mu_probe"].as_f64().unwrap();
        assert!(set.contains(&format!("mu_probe = {mu}")), "refit μ {mu} not in the set:\n{set}");
    }
    let best = &id["report"]["optimized"]["candidate"];
    assert!(fits.iter().any(|f| &f[0] != best), "no refit moved from the full fit: {boot}");
    assert_eq!(set.matches("mu_probe = ").count(), members, "every member has its μ:\n{set}");

    let plan = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../plans/table2.toml");
    let rob = ok(mesopush(
        &[
            "robustness",
            plan.to_str().unwrap(),
            "--model",
            "model.toml",
            "--supports",
            "set.toml",
            "--samples",
            "12",
            "--seed",
            SEED,
            "--out",
            "rob",
            "--json",
        ],
        d,
    ));
    assert_eq!(rob["samples"].as_u64(), Some(12), "{rob}");

    // `plan robust --supports` designs and checks on the same pairs: its fresh check of the
    // plan it wrote equals `robustness --supports` on that plan with the check's seed. (On
    // the nominal model: in the one identified from these few synthetic trials Table II's
    // plan wedges the peg beyond the needle's limit, and `plan robust` refuses it.)
    let designed = ok(mesopush(
        &[
            "plan",
            "robust",
            "--from-plan",
            plan.to_str().unwrap(),
            "--supports",
            "set.toml",
            "--seed",
            SEED,
            "--generations",
            "1",
            "--population",
            "4",
            "--elite",
            "2",
            "--train-samples",
            "6",
            "--validation-samples",
            "6",
            "--confirm-samples",
            "0",
            "--rounds",
            "1",
            "--check-samples",
            "24",
            "--check-seed",
            "41",
            "--out",
            "robust.toml",
            "--json",
        ],
        d,
    ));
    let again = ok(mesopush(
        &[
            "robustness",
            "robust.toml",
            "--supports",
            "set.toml",
            "--samples",
            "24",
            "--seed",
            "41",
            "--out",
            "rob2",
            "--json",
        ],
        d,
    ));
    assert_eq!(designed["success_rate"], again["success_rate"], "{designed}\n{again}");
}
