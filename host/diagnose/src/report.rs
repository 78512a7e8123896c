//! What a diagnosis reports: the verdict, the Table I of held-out errors before and after,
//! the fitted parameters with their uncertainty, the residual's structure, the JSON summary
//! (the before/after residual figure is [`super::figure`]).

use super::attribute::Diagnosis;
use super::candidates::Effect;
use super::decide::{Ambiguity, Verdict};
use super::free_tip::FreeTip;
use super::residual::Mse;
use super::structure::Structure;
use serde_json::{Value, json};

/// Held-out errors before (nominal) and after (extended model).
pub fn mse_before_after(d: &Diagnosis) -> (Mse, Mse) {
    (Mse::of(&d.residuals.0), Mse::of(&d.residuals.1))
}

/// Held-out error in noise units before (nominal) and after (the winner).
fn norms(d: &Diagnosis) -> (f64, f64) {
    let of = |c| d.scores.iter().find(|s| s.candidate == c).map_or(f64::NAN, |s| s.heldout_norm);
    (of(Effect::Nominal), of(d.best.candidate))
}

/// How much of the held-out error the named effect explains, and whether what remains is
/// still far above the floor (another effect at once, or this one's model incomplete).
fn remaining_line(d: &Diagnosis) -> String {
    let (before, after) = norms(d);
    let explained = 100.0 * (1.0 - after / before);
    if after > REMAINING_FACTOR * d.floor_band {
        format!(
            "remaining: it explains {explained:.0} % of the held-out error; the rest ({after:.0} \
             noise units, floor band {:.0}) is far above the floor — another effect at once, \
             or this one's model incomplete\n",
            d.floor_band
        )
    } else {
        format!(
            "remaining: it explains {explained:.1} % of the held-out error; the rest is near the floor\n"
        )
    }
}

/// What remains after the named effect counts as "far above the floor" beyond this many
/// floor bands.
const REMAINING_FACTOR: f64 = 10.0;

/// The verdict in one line, with its reason.
fn verdict_line(d: &Diagnosis) -> String {
    match (d.verdict, d.ambiguity) {
        (Verdict::Effect, _) if d.named_by_tip => {
            let tip = |c: Effect| {
                d.scores.iter().find(|s| s.candidate == c).map_or(f64::NAN, |s| s.heldout_tip_norm)
            };
            let free = d.free_tip.as_ref().and_then(|f| {
                let w = f.fit_of(d.best.candidate)?;
                Some(format!(
                    "; the free tip alone, fitted without the part: {:.1} → {:.1}",
                    f.nominal_heldout_norm, w.heldout_norm
                ))
            });
            let poses = if norms(d).1 <= d.floor_band {
                "with it in, the part's poses are predicted within the floor band"
            } else {
                "the part's poses are not predicted to the floor"
            };
            format!(
                "effect: {} — named by the imaged probe tip, on which it acts whatever the \
                 part's physics (held-out tip error {:.1} → {:.1} noise units, 1 at the floor{}; \
                 no other candidate brings it to the floor band); {poses}",
                d.best.candidate.name(),
                tip(Effect::Nominal),
                tip(d.best.candidate),
                free.unwrap_or_default()
            )
        }
        (Verdict::Effect, _) => format!("effect: {}", d.best.candidate.name()),
        (Verdict::Unexplained, Some(Ambiguity::Tie(a, b))) => format!(
            "unexplained: {} and {} fit the held-out trials about as well, and neither \
             reaches the floor; no single library effect explains the residual",
            a.name(),
            b.name()
        ),
        (Verdict::Unexplained, Some(Ambiguity::TrainVsHeldout { heldout, train })) => format!(
            "unexplained: {} fits the held-out trials best but {} fits the training trials \
             far better; the evidence is split, no single library effect explains the residual",
            heldout.name(),
            train.name()
        ),
        (Verdict::Unexplained, None) => {
            "unexplained: no library effect explains the residual on the held-out trials".into()
        }
        (Verdict::None, _) => match d.nominal_all_norm {
            Some(e) => format!(
                "none: the nominal model, refitted on every trial, reaches the floor band \
                 ({e:.1} noise units); the held-out gap is the nominal parameters' \
                 uncertainty on the training split, no missing effect found"
            ),
            None => {
                "none: the residual is at the measurement floor; no missing effect found".into()
            }
        },
    }
}

/// The report as text (markdown).
pub fn text(d: &Diagnosis) -> String {
    let (b, a) = mse_before_after(d);
    let mut s = String::new();
    s += &format!("verdict: {}\n", verdict_line(d));
    s += &format!("train: {}\nheld out: {}\n", d.split.0.join(", "), d.split.1.join(", "));
    if let Some(e) = d.effect {
        s += &format!("signature: {}\n", e.signature());
        s += &remaining_line(d);
    } else if let Some(l) = d.training_lead {
        s += &format!(
            "lead: {} fits the training trials best ({}), but is not named\n",
            l.name(),
            l.signature()
        );
    }
    s += "\n| held-out | before | after |\n|---|---|---|\n";
    s += &format!("| X,Y MSE (µm²) | {:.3} | {:.3} |\n", b.xy_um2, a.xy_um2);
    s += &format!("| θ MSE (rad²) | {:.3e} | {:.3e} |\n", b.theta_rad2, a.theta_rad2);
    s += &format!("| tip MSE (µm²) | {:.3} | {:.3} |\n", b.tip_um2, a.tip_um2);
    let sf = &d.support_fit;
    let tried: Vec<String> = sf.heldout_norm.iter().map(|(f, e)| format!("{f} {e:.1}")).collect();
    s += &format!(
        "\nnominal support: {} (held-out error, noise units: {})\n",
        sf.family,
        tried.join(", ")
    );
    if let Some(p) = &sf.polish {
        s += &format!(
            "  refitted at a {:.2} µm step (near the floor): {} {:.1} noise units, {}\n",
            p.step_um,
            p.family,
            p.heldout_norm,
            if p.kept { "kept" } else { "not kept (the coarse fit predicts better)" }
        );
    }
    let p = d.nominal.model.support.points_um;
    s += &format!(
        "  points [{:.0}, {:.0}] [{:.0}, {:.0}] [{:.0}, {:.0}] µm, μ_surface {:.3?}\n",
        p[0][0], p[0][1], p[1][0], p[1][1], p[2][0], p[2][1], d.nominal.model.support.mu_surface
    );
    if d.scores.len() == 1 {
        s += "(no effect fitted: the nominal model is at the measurement floor on the held-out trials)\n";
    }
    for sc in &d.scores {
        let mark = if sc.candidate == d.best.candidate { " (kept)" } else { "" };
        s += &format!(
            "\n{}{mark}: held-out {:.1} noise units, BIC {:.0}\n",
            sc.candidate.name(),
            sc.heldout_norm,
            sc.bic
        );
        for (n, v, e) in &sc.params {
            s += &format!("  {n} = {}\n", pm(*v, *e));
        }
    }
    if let Some(e) = d.nominal_all_norm {
        s += &format!("\nnominal model refitted on every trial: {e:.2} noise units\n");
    }
    if let Some(e) = d.effect_all_norm {
        s += &format!("held-out winner refitted on every trial: {e:.2} noise units\n");
    }
    s += "\ncandidates (train BIC, held-out error in noise units; floor ≈ 2–3):\n";
    for sc in &d.scores {
        s += &format!(
            "  {:<18} BIC {:>12.1}  held-out {:>10.2}\n",
            sc.candidate.name(),
            sc.bic,
            sc.heldout_norm
        );
    }
    s += &format!("\nresidual before: {}\n", Structure::of(&d.residuals.0).describe(&d.noise));
    s += &format!("residual after:  {}\n", Structure::of(&d.residuals.1).describe(&d.noise));
    s
}

/// Parameters as `{name: {value, sigma}}`; sigma null when the trials do not determine it.
fn param_map(params: &[(String, f64, f64)]) -> serde_json::Map<String, Value> {
    params
        .iter()
        .map(|(n, v, e)| {
            let sigma = if e.is_finite() { json!(e) } else { Value::Null };
            (n.clone(), json!({"value": v, "sigma": sigma}))
        })
        .collect()
}

/// `v ± σ`, or `v (undetermined)` when the trials do not pin it down.
fn pm(v: f64, e: f64) -> String {
    if e.is_finite() { format!("{v:.5} ± {e:.2}") } else { format!("{v:.5} (undetermined)") }
}

/// The free-tip fits ([`crate::free_tip`]) as JSON: each effect by its library name, with
/// its parameters by name.
fn free_tip_json(f: &FreeTip) -> Value {
    json!({
        "nominal_train_norm": f.nominal_train_norm,
        "nominal_heldout_norm": f.nominal_heldout_norm,
        "frames_train": f.frames.0,
        "frames_heldout": f.frames.1,
        "fits": f.fits.iter().map(|w| json!({
            "name": w.candidate.name(),
            "parameters": w.candidate.effect_params().iter().zip(&w.values)
                .map(|(p, v)| (p.name.to_owned(), json!(v)))
                .collect::<serde_json::Map<String, Value>>(),
            "train_norm": w.train_norm,
            "heldout_norm": w.heldout_norm,
        })).collect::<Vec<_>>(),
    })
}

/// The `--json` summary.
pub fn json(d: &Diagnosis) -> Value {
    let (b, a) = mse_before_after(d);
    let params = d
        .scores
        .iter()
        .find(|s| s.candidate == d.best.candidate)
        .map(|sc| param_map(&sc.params))
        .unwrap_or_default();
    json!({
        "verdict": d.verdict,
        "effect": d.effect.map(|e| e.name()),
        "named_by_tip": d.named_by_tip,
        "signature": d.effect.map(|e| e.signature()),
        "ambiguous_with": d.ambiguity.map(|a| { let (x, y) = a.pair(); [x.name(), y.name()] }),
        "ambiguity": d.ambiguity.map(|a| match a {
            Ambiguity::Tie(..) => "tie",
            Ambiguity::TrainVsHeldout { .. } => "train_vs_heldout",
        }),
        "training_lead": d.training_lead.map(|c| c.name()),
        "heldout_norm_before": norms(d).0,
        "heldout_norm_after": norms(d).1,
        "floor_band": d.floor_band,
        "remaining_far_above_floor": d.effect.is_some() && norms(d).1 > REMAINING_FACTOR * d.floor_band,
        "parameters": params,
        "mse_before": {"xy_um2": b.xy_um2, "theta_rad2": b.theta_rad2, "tip_um2": b.tip_um2},
        "mse_after": {"xy_um2": a.xy_um2, "theta_rad2": a.theta_rad2, "tip_um2": a.tip_um2},
        "noise": d.noise,
        "nominal_all_trials_norm": d.nominal_all_norm,
        "effect_all_trials_norm": d.effect_all_norm,
        "train": d.split.0,
        "heldout": d.split.1,
        "candidates": d.scores.iter().map(|s| json!({
            "name": s.candidate.name(), "bic": s.bic, "heldout_norm": s.heldout_norm,
            "heldout_per_trial_norm": s.heldout_per_trial_norm,
            "heldout": s.heldout, "parameters": param_map(&s.params)})).collect::<Vec<_>>(),
        "support_fit": d.support_fit,
        "free_tip": d.free_tip.as_ref().map(free_tip_json),
        "nominal_model": {"mu_probe": d.nominal.model.mu_probe,
            "support_points_um": d.nominal.model.support.points_um,
            "mu_surface": d.nominal.model.support.mu_surface},
        "structure_before": Structure::of(&d.residuals.0),
        "structure_after": Structure::of(&d.residuals.1),
    })
}
