#!/usr/bin/env python3
"""Held-out prediction on the real Zhou & Mason pushes (issue 18 point 3).

For each set-up and each of its three start conditions: `mesopush identify run --optimize`
on the runs of the other two conditions, then `mesopush replay` of the held-out condition's
runs with the identified model and with the importer's nominal model. Prints, per held-out
condition, the median final-pose error next to the condition's repeat spread (the RMS
distance of each run's measured final pose from the condition's mean final pose, and the
standard deviation of the final angle) and the target max(2 x spread, 2 mm / 2 deg).

    mesopush import zhou-mason ../shared/real-pushes/zhou-mason-2017 --out DATA
    python3 tools/real_heldout.py --data DATA --out OUT [--mesopush target/release/mesopush]

Writes OUT/heldout.json and OUT/heldout.md. Only the project's CLI and the imported trial
logs are used (pose.csv's last row is the measured final pose).
"""
import argparse
import csv
import json
import math
import statistics
import subprocess
import sys
from pathlib import Path


def final_pose(trial: Path):
    rows = list(csv.DictReader(open(trial / "pose.csv")))
    r = rows[-1]
    return float(r["x_um"]), float(r["y_um"]), float(r["theta_rad"])


def spread(trials):
    poses = [final_pose(t) for t in trials]
    mx = statistics.fmean(p[0] for p in poses)
    my = statistics.fmean(p[1] for p in poses)
    rms = math.sqrt(statistics.fmean((p[0] - mx) ** 2 + (p[1] - my) ** 2 for p in poses))
    # Angles about the first run's (no wrap across ±π between repeats).
    th0 = poses[0][2]
    d = [math.remainder(p[2] - th0, math.tau) for p in poses]
    sd = statistics.pstdev(d) if len(d) > 1 else 0.0
    return rms, math.degrees(sd)


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"failed ({r.returncode}): {' '.join(map(str, cmd))}\n{r.stderr}")
    return r.stdout


def replay(exe, model, trials, out):
    s = run([exe, "replay", "--json", "--no-fig", "--model", str(model), *map(str, trials),
             "--out", str(out)])
    return json.loads(s)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--data", required=True, type=Path)
    ap.add_argument("--out", required=True, type=Path)
    ap.add_argument("--mesopush", default="target/release/mesopush")
    ap.add_argument("--supports", default="40")
    ap.add_argument("--max-evals", default="200")
    a = ap.parse_args()
    a.out.mkdir(parents=True, exist_ok=True)
    by = {}
    for r in csv.DictReader(open(a.data / "runs.csv")):
        by.setdefault(r["set_up"], {}).setdefault(r["start"], []).append(a.data / r["trial_dir"])
    results = []
    for set_up, starts in sorted(by.items()):
        for held in sorted(starts):
            train = [t for s, ts in starts.items() if s != held for t in ts]
            model = a.out / f"{set_up}--not-{held}.toml"
            sup = a.out / f"{set_up}--not-{held}-supports.toml"
            run([a.mesopush, "identify", "run", "--optimize", "--supports", a.supports,
                 "--max-evals", a.max_evals, "--bootstrap", "0", "--out", str(model),
                 "--consistent-out", str(sup), *map(str, train)])
            fit = replay(a.mesopush, model, starts[held], a.out / f"replay-{set_up}-{held}")
            nom = replay(a.mesopush, a.data / f"nominal-{set_up}.toml", starts[held],
                         a.out / f"replay-nominal-{set_up}-{held}")
            sp_um, sp_deg = spread(starts[held])
            row = {
                "set_up": set_up, "held_out": held, "runs": len(starts[held]),
                "spread_um": sp_um, "spread_deg": sp_deg,
                "target_um": max(2 * sp_um, 2000.0), "target_deg": max(2 * sp_deg, 2.0),
                "identified": {k: fit[k] for k in fit if k.startswith("median")},
                "nominal": {k: nom[k] for k in nom if k.startswith("median")},
                "per_run_final_um": [t["final_error_um"] for t in fit["trials"]],
                "per_run_final_deg": [t["final_error_deg"] for t in fit["trials"]],
            }
            row["met"] = (row["identified"]["median_final_error_um"] <= row["target_um"]
                          and row["identified"]["median_abs_final_error_deg"] <= row["target_deg"])
            results.append(row)
            print(json.dumps(row), flush=True)
    json.dump(results, open(a.out / "heldout.json", "w"), indent=1)
    with open(a.out / "heldout.md", "w") as f:
        f.write("| set-up | held-out start | runs | repeat spread | target | identified: median final error | nominal: median final error | met |\n")
        f.write("|---|---|---:|---|---|---|---|---|\n")
        for r in results:
            i, n = r["identified"], r["nominal"]
            f.write(f"| {r['set_up']} | {r['held_out']} | {r['runs']} | "
                    f"{r['spread_um'] / 1000:.2f} mm, {r['spread_deg']:.2f}° | "
                    f"{r['target_um'] / 1000:.1f} mm, {r['target_deg']:.1f}° | "
                    f"{i['median_final_error_um'] / 1000:.2f} mm, {i['median_abs_final_error_deg']:.2f}° | "
                    f"{n['median_final_error_um'] / 1000:.2f} mm, {n['median_abs_final_error_deg']:.2f}° | "
                    f"{'yes' if r['met'] else 'no'} |\n")
    print(open(a.out / "heldout.md").read())


if __name__ == "__main__":
    main()
