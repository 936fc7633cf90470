//! Reports of the discrepancy workflow: the JSON object of `host-sim diagnose --json`,
//! a Markdown report and plots (measured vs simulated before and after, residual per
//! phase, residual autocorrelation with its 99 % band) written to the output folder.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use rayon::prelude::*;
use serde_json::{json, Map, Value};

use super::catalogue::{Determination, Effect, Estimate, Param};
use super::data::Prepared;
use super::solver::Fit;
use super::{Candidate, Diagnosis, Localisation, Options, PHASE_ORDER};
use crate::plots::{self, Chart, Series, PALETTE};

/// Parameters of a fit as a JSON object `{name: value}` (SI units, names as in the
/// report) and their standard errors as a second object (`null` where not estimated or
/// where the record did not determine the parameter: its reason says what it did).
fn parameters_json(fit: &Fit, position_sign: f64) -> (Value, Value) {
    let mut values = Map::new();
    let mut errors = Map::new();
    for p in &fit.parameters {
        values.insert(
            p.param.id().into(),
            json!(on_file_axis(p.param, p.value, position_sign)),
        );
        errors.insert(
            p.param.id().into(),
            if p.standard_error.is_finite() && p.determination == Determination::Determined {
                json!(p.standard_error)
            } else {
                Value::Null
            },
        );
    }
    (Value::Object(values), Value::Object(errors))
}

/// A parameter's value as reported: the contact position on the file's own position axis
/// (as `estimate` reports it; the fit works on the penetration axis, the file's position
/// times `position_sign`), every other parameter as fitted (a contact shift is along the
/// penetration).
fn on_file_axis(param: Param, value: f64, position_sign: f64) -> f64 {
    if param == Param::ContactPositionM {
        position_sign * value
    } else {
        value
    }
}

/// Why the record did not determine a parameter ([`Determination`]), or `None` where it did.
pub(super) fn undetermined_reason(fit: &Fit, p: &Estimate) -> Option<String> {
    match p.determination {
        Determination::Determined => None,
        Determination::AtSearchBound => Some(
            "held at a bound of its search range: the record's optimum may lie beyond, so the value is the range's"
                .into(),
        ),
        Determination::Unresolved => Some(
            "the record's residual rises by less than its noise away from this value on one side (to a bound of the search range, or at all): any value on that side fits as well"
                .into(),
        ),
        Determination::Held => Some(
            "held at 0: the record cannot identify it (see not_identifiable)".into(),
        ),
        Determination::ProductOnly(other) => Some(format!(
            "only its product with {} is determined ({:.4e}): the mode is slower than the record",
            other.id(),
            p.value * fit.parameter(other).unwrap_or(f64::NAN)
        )),
        Determination::DampingCombination(other) => {
            let param = |q: Param| fit.parameter(q).unwrap_or(f64::NAN);
            let (kappa, lambda, tau) = (
                param(Param::Kappa),
                param(Param::Lambda),
                param(Param::DelayS),
            );
            let combination = lambda - kappa * tau;
            // A delay the profile measured (`solver::delay_se`) and did not resolve from 0
            // keeps its standard error; the other routes' are NaN.
            let delay_se = fit
                .parameters
                .iter()
                .find(|p| p.param == Param::DelayS)
                .map_or(f64::NAN, |p| p.standard_error);
            let from_edges = fit.nonlinear.delay_as_damping || !delay_se.is_nan();
            Some(format!(
                "{}, where a delay τ is to first order a change −κ·τ of the damping: only λ − κ·τ is determined ({combination:.4e} N·s/m), not each (with {}){}; {}",
                if fit.nonlinear.delay_as_damping {
                    "the delay shows as a lag of the force in contact, not clearly at the contact onsets, lift-offs and kinks of the motion".to_string()
                } else if delay_se.is_finite() {
                    format!(
                        "the contact onsets, lift-offs and kinks of the motion fix the delay only to ± {delay_se:.2e} s, less than {} standard errors from 0",
                        super::solver::DELAY_RESOLVED_T
                    )
                } else if !delay_se.is_nan() {
                    "the contact onsets, lift-offs and kinks of the motion do not fix the delay within its search range".to_string()
                } else {
                    "the record never leaves contact".to_string()
                },
                other.id(),
                if combination < 0.0 {
                    format!(
                        "; a passive damping (λ ≥ 0) puts the delay at {:.4e} s or more",
                        -combination / kappa
                    )
                } else {
                    String::new()
                },
                if from_edges {
                    "a faster onset or lift-off, less noise or a faster sampling shows the delay at the edges"
                } else {
                    "a lift-off out of contact determines them"
                }
            ))
        }
        Determination::CombinationOnly(other) => Some(format!(
            "the record never leaves contact and the elastic law is linear: a shift of the contact point changes the force by a constant, which the tare takes, so only their combination is determined, not each (with {}); a lift-off out of contact determines them",
            other.id()
        )),
    }
}

/// `{name: why}` of the parameters a fit's record did not determine.
fn undetermined_json(fit: &Fit) -> Value {
    Value::Object(
        fit.parameters
            .iter()
            .filter_map(|p| {
                undetermined_reason(fit, p).map(|why| (p.param.id().into(), json!(why)))
            })
            .collect(),
    )
}

/// The `--json` object: `{"baseline", "steps": [{"effect", "parameters",
/// "nrmse_percent_before", "nrmse_percent_after", …}], "effects_added", "final_model",
/// "nrmse_percent_final", "elastic_force_table", …}`; each step lists the effects the
/// record cannot tell apart from it (`"indistinguishable_from"`), and the parameters its
/// record did not determine (`"undetermined"`, `{name: why}`, their standard errors
/// `null`; `"final_undetermined"` for the final model). `file` names the input.
/// `contact_position_m` is on the file's position axis (`"position_sign"`: +1 where the
/// position increases into the material), as `estimate` reports it.
pub fn json(file: &str, d: &Diagnosis, data: &Prepared) -> Value {
    let steps: Vec<Value> = d
        .steps
        .iter()
        .map(|s| {
            let (parameters, uncertainties) = parameters_json(&s.after, data.position_sign);
            json!({
                "effect": s.effect.id(),
                "replaces": s.replaces.map(|e| e.id()),
                "jointly_with": s.jointly_with.map(|e| e.id()),
                "parameters": parameters,
                "standard_errors": uncertainties,
                "undetermined": undetermined_json(&s.after),
                "nrmse_percent_before": s.before.nrmse_percent,
                "nrmse_percent_after": s.after.nrmse_percent,
                "vaf_percent_after": s.after.vaf_percent,
                "bic_before": s.before.bic,
                "bic_after": s.after.bic,
                "cv_rmse_n_before": s.before.cv_rmse,
                "cv_rmse_n_after": s.after.cv_rmse,
                "indistinguishable_from": s.indistinguishable_from.iter().map(|i| json!({
                    "effect": i.effect.id(),
                    "delta_bic": i.delta_bic,
                    "separating_motion": i.separating_motion,
                })).collect::<Vec<_>>(),
            })
        })
        .collect();
    let (parameters, uncertainties) = parameters_json(&d.final_fit, data.position_sign);
    json!({
        "file": file,
        "position_sign": data.position_sign,
        "baseline": d.baseline.name(),
        "nrmse_percent_baseline": d.baseline_fit.nrmse_percent,
        "vaf_percent_baseline": d.baseline_fit.vaf_percent,
        "steps": steps,
        "effects_added": d.effects_added(),
        "effects_removed": d.removed.iter().map(|r| json!({
            "effect": r.effect.id(),
            "delta_bic_of_keeping": r.kept.delta_bic,
            "cv_improvement_of_keeping": r.kept.cv_improvement,
            "folds_better_of_keeping": r.kept.folds_better,
            "folds_judged_of_keeping": r.kept.folds_judged,
            "reason": r.reason(),
            "nrmse_percent_after": r.after.nrmse_percent,
        })).collect::<Vec<_>>(),
        "final_model": d.final_model(),
        "final_parameters": parameters,
        "final_standard_errors": uncertainties,
        "final_undetermined": undetermined_json(&d.final_fit),
        "nrmse_percent_final": d.final_fit.nrmse_percent,
        "vaf_percent_final": d.final_fit.vaf_percent,
        "elastic_force_table": elastic_force_table(d, data),
        "noise_sample_fraction": d.noise_sample_fraction,
        "cv_interleaved_block_samples": d.cv_block,
        "rate_spread_at_depth": d.rate_spread,
        "speed_spread_at_depth": d.speed_spread,
        "speed_change_with_depth": d.speed_change,
        "linear_damping_held": d.damping_held,
        "onset_damping_delta_bic": d.onset_damping_delta_bic,
        "effects_not_determined": not_determined_candidates(d).map(|c| json!({
            "effect": c.effect.id(),
            "delta_bic": c.delta_bic,
            "cv_improvement": c.cv_improvement,
            "folds_better": c.folds_better,
            "folds_judged": c.folds_judged,
            "separating_motion": determining_motion(d, c.effect),
        })).collect::<Vec<_>>(),
        "not_identifiable": d.unidentifiable.iter().map(|e| {
            let (why, motion) = super::unidentifiable_reason(d, *e);
            json!({"effect": e.id(), "why": why, "separating_motion": motion})
        }).collect::<Vec<_>>(),
    })
}

/// The final candidates the record does not determine (`Diagnosis::not_determined`).
fn not_determined_candidates(d: &Diagnosis) -> impl Iterator<Item = &Candidate> {
    d.final_candidates
        .iter()
        .filter(|c| d.not_determined.contains(&c.effect))
}

/// The motion that would determine `effect` beside the final model: what separates it
/// from the effect added last ([`super::separating_motion`]; from itself on a bare
/// baseline).
fn determining_motion(d: &Diagnosis, effect: Effect) -> &'static str {
    let last = d.steps.last().map_or(effect, |s| s.effect);
    super::separating_motion(effect, last)
}

/// Depths in [`elastic_force_table`].
pub const ELASTIC_TABLE_POINTS: usize = 64;

/// The final model's elastic law for a master device: `{"depth_m": [...], "force_n":
/// [...]}`, F_e(δ) ([`Fit::elastic_force_n`]) at [`ELASTIC_TABLE_POINTS`] depths evenly
/// from 0 to the deepest δ of the record, measured from the model's own contact point.
pub fn elastic_force_table(d: &Diagnosis, data: &Prepared) -> Value {
    // δ from the final model's own (refined) contact point.
    let deepest = (data.depth_m.iter().copied().fold(0.0f64, f64::max)
        - d.final_fit.nonlinear.contact_m)
        .max(0.0);
    let depth: Vec<f64> = (0..ELASTIC_TABLE_POINTS)
        .map(|i| deepest * i as f64 / (ELASTIC_TABLE_POINTS - 1) as f64)
        .collect();
    let force: Vec<f64> = depth
        .iter()
        .map(|x| d.final_fit.elastic_force_n(*x))
        .collect();
    json!({"depth_m": depth, "force_n": force})
}

/// Parameters as `name = value ± se` (SI; value only where no error was estimated, and
/// why where the record did not determine it).
fn parameters_text(fit: &Fit, position_sign: f64) -> String {
    fit.parameters
        .iter()
        .map(|p| {
            let (n, se) = (p.param.id(), p.standard_error);
            let v = on_file_axis(p.param, p.value, position_sign);
            if let Some(why) = undetermined_reason(fit, p) {
                format!("{n} = {v:.4e} (not determined: {why})")
            } else if se.is_finite() && se > 0.0 {
                format!("{n} = {v:.4e} ± {se:.2e}")
            } else {
                format!("{n} = {v:.4e}")
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// The candidate's own parameters (those its effect adds), as `name = value`.
fn shape_text(c: &Candidate) -> String {
    c.effect
        .own_parameters()
        .iter()
        .filter_map(|p| c.fit.parameter(*p).map(|v| format!("{} = {v:.3e}", p.id())))
        .collect::<Vec<_>>()
        .join(", ")
}

fn candidates_table(out: &mut String, candidates: &[Candidate]) {
    out.push_str(
        "| candidate | replaces | NRMSE % | ΔBIC | CV gain % | folds better | significant |\n",
    );
    out.push_str("|---|---|---|---|---|---|---|---|\n");
    for c in candidates {
        let _ = writeln!(
            out,
            "| `{}` | {} | {:.3} | {:.1} | {:.2} | {}/{} | {} | {} |",
            c.effect.id(),
            c.replaces
                .map_or("—".to_string(), |e| format!("`{}`", e.id())),
            c.fit.nrmse_percent,
            c.delta_bic,
            100.0 * c.cv_improvement,
            c.folds_better,
            c.folds_judged,
            if c.significant {
                "yes"
            } else if !c.physical {
                "no (nonphysical)"
            } else if c.nested && c.fit.relaxes_at_the_fast_bound() {
                "no (a mode faster than the record resolves: the damping the model has)"
            } else if c.nested && c.fit.relaxes_at_the_slow_bound() {
                "no (a mode slower than the record resolves: a trend with the load, which a drifting zero or another misfit makes too)"
            } else if c.nested {
                "no (its parameter stayed at the current model's value)"
            } else if c.unseen_in_free_space && c.effect == Effect::ForceOffset {
                "no (the free space before the step fits worse: a constant under the contact, not a step of the zero)"
            } else if c.unseen_in_free_space {
                "no (the free-space force shows no such trend)"
            } else if c.within_zero_wander && c.effect == Effect::ForceDrift {
                "no (a drift no larger than the load cell's zero wanders by itself over the free space's span)"
            } else if c.within_zero_wander && c.effect == Effect::ForceOffset {
                "no (a step no larger than the load cell's zero wanders by itself between adjacent stretches of the free space)"
            } else if c.within_zero_wander {
                "no (the later contacts' force moves no more than the load cell's zero wanders by itself in the free space)"
            } else if c.unseen_at_contact_edges {
                "no (the contact onsets and lift-offs do not show it)"
            } else if c.a_damping_change_in_contact {
                "no (the record never leaves contact, where a delay is a change of the damping, and a passive damping explains this one)"
            } else if c.under_half_a_sample {
                "no (under half a sample: the rate's own discretization at a reversal or onset)"
            } else {
                "no"
            },
            shape_text(c)
        );
    }
}

/// What a step of a pair named together means ([`Step::jointly_with`]).
fn joint_text(out: &mut String, d: &Diagnosis, i: usize, min_bic_drop: f64) {
    let s = &d.steps[i];
    let Some(other) = s.jointly_with else {
        return;
    };
    let first = d
        .steps
        .get(i + 1)
        .is_some_and(|n| n.jointly_with == Some(s.effect));
    if let (true, Some(replaced)) = (first, s.replaces) {
        let _ = writeln!(
            out,
            "\nNo candidate passes the rule alone. `{}` in place of `{}` was tried with each of the {} best added candidates by BIC: with `{}` it passes the rule against this model, and each lowers the BIC of the other alone by more than {}; both are named (steps {} and {}). This step's parameters and NRMSE are the swap's alone.",
            s.effect.id(),
            replaced.id(),
            super::PAIRED,
            other.id(),
            min_bic_drop,
            i + 1,
            i + 2,
        );
    } else if first {
        let _ = writeln!(
            out,
            "\nNo candidate passes the rule alone. The {} best by BIC were tried in pairs: `{}` with `{}` passes it against this model, and each lowers the BIC of the other alone by more than {}; both are named (steps {} and {}). This step's parameters and NRMSE are `{}` alone.",
            super::PAIRED,
            s.effect.id(),
            other.id(),
            min_bic_drop,
            i + 1,
            i + 2,
            s.effect.id()
        );
    } else {
        let _ = writeln!(
            out,
            "\nThe pair `{}` + `{}` (step {} and this one), fitted jointly and scored against the model before step {}: the row above.",
            other.id(),
            s.effect.id(),
            i,
            i
        );
    }
}

fn localisation_text(out: &mut String, l: &Localisation) {
    let outside: Vec<String> = l
        .autocorrelation
        .iter()
        .enumerate()
        .skip(1)
        .filter(|(_, r)| r.abs() > l.band)
        .map(|(k, _)| k.to_string())
        .collect();
    let _ = writeln!(
        out,
        "- residual autocorrelation: {} of 50 lags outside the 99 % band ±{:.3}{}",
        outside.len(),
        l.band,
        if outside.is_empty() {
            String::new()
        } else {
            format!(
                " (first lags: {})",
                outside
                    .iter()
                    .take(8)
                    .cloned()
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        }
    );
    let mut cross: Vec<(&String, &(f64, i32))> = l.cross_correlation.iter().collect();
    cross.sort_by(|a, b| b.1 .0.abs().total_cmp(&a.1 .0.abs()));
    let text: Vec<String> = cross
        .iter()
        .map(|(name, (r, lag))| {
            format!(
                "{name} {r:+.2}{}{}",
                if *lag != 0 {
                    format!(" (lag {lag})")
                } else {
                    String::new()
                },
                if r.abs() > l.band { "*" } else { "" }
            )
        })
        .collect();
    let _ = writeln!(
        out,
        "- largest cross-correlations with the residual (* outside the band): {}",
        text.join(", ")
    );
    let windows: Vec<String> = l
        .worst_windows
        .iter()
        .map(|(a, b, rms, phase)| format!("{a:.2}–{b:.2} s ({phase}, RMS {rms:.3e} N)"))
        .collect();
    let _ = writeln!(out, "- worst 0.5 s windows: {}", windows.join("; "));
}

/// The Markdown report of a diagnosis of `file`, with the plot files named by `plots`
/// (relative to the report).
pub fn markdown(
    file: &str,
    data: &Prepared,
    d: &Diagnosis,
    options: &Options,
    plots: &[String],
) -> String {
    let mut out = String::new();
    let f = &d.final_fit;
    let _ = writeln!(out, "# Discrepancy diagnosis: `{file}`\n");
    let _ = writeln!(
        out,
        "Baseline **{}**; final model **{}**: NRMSE {:.3} % → {:.3} % (VAF {:.2} % → {:.2} %).\n",
        d.baseline.name(),
        d.final_model(),
        d.baseline_fit.nrmse_percent,
        f.nrmse_percent,
        d.baseline_fit.vaf_percent,
        f.vaf_percent
    );
    let start = f.start;
    let _ = writeln!(
        out,
        "Fit window {:.3}–{:.3} s: {} samples{}, each the mean of {} raw samples ({:.1} ms). Force offset removed {:.4e} N; contact position (first impact) {:.6e} m; noise of one fitting sample {:.3e} N.\n",
        data.time_s[start],
        data.time_s[data.len() - 1],
        f.samples,
        {
            let leading = data.leading_left_out.saturating_sub(start);
            let trailing = data.trailing_left_out;
            let kinks = (data.len() - start).saturating_sub(f.samples + leading + trailing);
            let mut why = Vec::new();
            if kinks > 0 {
                why.push(format!(
                    "{kinks} whose rate reads across a kink of the motion: a ramp starting, \
                     stopping or reversing within a sample, where the rate is not defined"
                ));
            }
            if leading > 0 {
                why.push(format!(
                    "the first {leading}: the record begins in contact, and a model with a \
                     delay as long as the longest tried would predict them from motion \
                     before the record"
                ));
            }
            if trailing > 0 {
                why.push(
                    "the last: the record ends in contact, and neither its rate nor its \
                     acceleration has a sample after it"
                        .to_string(),
                );
            }
            if why.is_empty() {
                String::new()
            } else {
                format!(
                    " ({} more left out: {})",
                    kinks + leading + trailing,
                    why.join("; ")
                )
            }
        },
        data.block,
        1e3 * data.dt,
        data.force_offset_n,
        data.contact_position_m,
        data.noise_n
    );
    let _ = writeln!(
        out,
        "A candidate is accepted when BIC (on the effective samples of its residual) falls by more than {} and the blocked {}-fold cross-validation error improves by at least {:.0} % and on at least {} folds (a load-cell step's on that many of the folds where the two errors differ by more than that share, all of them where fewer differ); the best accepted by held-out error (by BIC where another accepted one's BIC is lower by more than that threshold) is added, and the loop repeats (at most {} steps). Where none passes alone, the {} best by BIC are tried in pairs, fitted jointly, and then a swap of the elastic law with each of them: a pair that passes, each of whose effects lowers the BIC of the other alone by more than that threshold, is named in two steps. At the end every added effect must still pass that rule against the final model without it (an effect added later can take over an earlier one's role); the least needed one that does not is removed, and the check repeats.\n",
        options.min_bic_drop,
        super::scoring::FOLDS,
        100.0 * options.min_cv_improvement,
        options.min_folds_better,
        options.max_steps,
        super::PAIRED
    );
    let _ = writeln!(
        out,
        "{}\n",
        match d.cv_block {
            None => "The folds are contiguous fifths of the fit window.".to_string(),
            Some(b) => format!(
                "The probe moves in fewer than {} of the fit window's fifths (a hold between brief ramps), where contiguous folds cannot show an effect of the motion on enough folds: the folds interleave, blocks of {} fitting samples (2·N/N_eff of the sensor noise{}, at least 4) held out in turn, every fifth block one fold. A short held-out block of a slow function of time (relaxation, a drift) is then predicted almost in-sample: the BIC on effective samples is the guard against those.",
                super::scoring::MIN_MOVING_FOLDS,
                b,
                if d.noise_sample_fraction.is_some() {
                    ""
                } else {
                    ", as far as the little free space shows it, else taken as white"
                }
            ),
        }
    );
    let _ = writeln!(
        out,
        "{}\n",
        match d.noise_sample_fraction {
            Some(f) => format!(
                "The sensor noise on the free-space stretches is coloured: the BIC counts N_eff = {:.3} N effective samples (1 for white noise).",
                f
            ),
            None => "The record has no free space to measure the noise's colour on (under 100 free samples, or none the front end could confirm): the BIC counts the effective samples of each model's own residual, from its autocorrelation, where that residual is within 1.5 noise deviations of one fitting sample (it is then the noise), and every sample where it is larger (a misfit, which the held-out error judges).".to_string(),
        }
    );
    out.push_str("## Steps\n\n");
    out.push_str("| step | effect added | parameters after (SI, ± 1 s.e.) | NRMSE % before → after | BIC before → after |\n");
    out.push_str("|---|---|---|---|---|\n");
    let _ = writeln!(
        out,
        "| 0 | baseline `{}` | {} | {:.3} | {:.0} |",
        d.baseline.name(),
        parameters_text(&d.baseline_fit, data.position_sign),
        d.baseline_fit.nrmse_percent,
        d.baseline_fit.bic
    );
    for (i, s) in d.steps.iter().enumerate() {
        let _ = writeln!(
            out,
            "| {} | `{}`{}{} | {} | {:.3} → {:.3} | {:.0} → {:.0} |",
            i + 1,
            s.effect.id(),
            s.replaces
                .map_or(String::new(), |e| format!(" (replaces `{}`)", e.id())),
            s.jointly_with
                .map_or(String::new(), |e| format!(" (jointly with `{}`)", e.id())),
            parameters_text(&s.after, data.position_sign),
            s.before.nrmse_percent,
            s.after.nrmse_percent,
            s.before.bic,
            s.after.bic
        );
    }
    for (i, r) in d.removed.iter().enumerate() {
        let _ = writeln!(
            out,
            "| {}, backward check | `{}` removed: keeping it gained ΔBIC {:+.1}, held-out {:+.2} % on {}/{} folds, {} | {} | → {:.3} | → {:.0} |",
            d.steps.len() + i + 1,
            r.effect.id(),
            r.kept.delta_bic,
            100.0 * r.kept.cv_improvement,
            r.kept.folds_better,
            r.kept.folds_judged,
            r.reason(),
            parameters_text(&r.after, data.position_sign),
            r.after.nrmse_percent,
            r.after.bic
        );
    }
    let ambiguous: Vec<String> = d
        .steps
        .iter()
        .enumerate()
        .flat_map(|(i, s)| {
            s.indistinguishable_from.iter().map(move |a| {
                let why = if s.effect.precedence() < a.effect.precedence() {
                    "it needs less of the motion (the physical default)"
                } else {
                    "its held-out error is lower, which is weak evidence"
                };
                format!(
                    "- step {}: the record cannot tell `{}` from `{}` (ΔBIC {:+.1}, on effective samples); `{}` is named because {why}. What would separate them: {}.",
                    i + 1,
                    s.effect.id(),
                    a.effect.id(),
                    a.delta_bic,
                    s.effect.id(),
                    a.separating_motion
                )
            })
        })
        .collect();
    let mut ambiguous = ambiguous;
    for c in not_determined_candidates(d) {
        ambiguous.push(format!(
            "- not determined: `{}` fits the record better in-sample (ΔBIC {:+.1}) but predicts it worse held out ({:+.2} %, better on {}/{} folds): fitted on four fifths of the record, its parameters do not carry to the fifth, so the record does not determine it beside `{}` (neither named nor ruled out). What would: {}.",
            c.effect.id(),
            c.delta_bic,
            100.0 * c.cv_improvement,
            c.folds_better,
            c.folds_judged,
            d.final_model(),
            determining_motion(d, c.effect)
        ));
    }
    for (k, e) in d.unidentifiable.iter().enumerate() {
        let (why, motion) = super::unidentifiable_reason(d, *e);
        let spread = if *e == Effect::CoulombFriction && d.one_speed_each_way_only() {
            format!(
                " (spread of |δ̇| at a depth {:.2} of its RMS, below {}; its change with depth {:.2}, below {})",
                d.speed_spread,
                super::RATE_SPREAD_MIN,
                d.speed_change,
                super::SPEED_CHANGE_MIN
            )
        } else if *e == Effect::Inertia && d.one_speed_each_way_only() {
            format!(
                " (spread of |δ̇| at a depth {:.2} of its RMS, below {min}; its change with depth {:.2}{})",
                d.speed_spread,
                d.speed_change,
                if d.speed_change < super::SPEED_CHANGE_MIN {
                    format!(", below {}", super::SPEED_CHANGE_MIN)
                } else {
                    ", but the record never leaves contact".to_string()
                },
                min = super::RATE_SPREAD_MIN
            )
        } else if e.is_rate_effect() && d.one_speed_each_way_only() {
            format!(
                " (spread of |δ̇| at a depth {:.2} of its RMS, below {})",
                d.speed_spread,
                super::RATE_SPREAD_MIN
            )
        } else if e.is_rate_effect() {
            format!(
                " (spread of δ̇ at a depth {:.2} of its RMS, below {})",
                d.rate_spread,
                super::RATE_SPREAD_MIN
            )
        } else {
            String::new()
        };
        ambiguous.insert(
            k,
            format!(
                "- not tried: `{}`: {why}{spread}. What would identify it: {motion}.",
                e.id()
            ),
        );
    }
    if let Some(drop) = d.onset_damping_delta_bic {
        let _ = writeln!(
            out,
            "\n**The linear damping at one speed.** Each depth is passed at one speed, but the contact begins from free space or the probe stops or starts moving in contact, where the damping λ·δ̇ is the step λv that no elastic law makes. The workflow was run with the damping free and held at 0: ΔBIC (free − held, λ counted) {drop:+.1} on effective samples; the {} reading is kept (the free one needs a drop below −{}).",
            if d.damping_held { "held" } else { "free" },
            options.min_bic_drop,
        );
    }
    if !ambiguous.is_empty() {
        out.push_str("\n## What this record cannot distinguish\n\n");
        for line in ambiguous {
            let _ = writeln!(out, "{line}");
        }
    }
    out.push_str("\n## Residual RMS per phase [N]\n\n");
    let mut header = "| phase | baseline |".to_string();
    let mut rule = "|---|---|".to_string();
    for s in &d.steps {
        let _ = write!(header, " + `{}` |", s.effect.id());
        rule.push_str("---|");
    }
    let _ = writeln!(out, "{header}\n{rule}");
    let localisations: Vec<&Localisation> = d
        .steps
        .first()
        .map(|s| &s.localisation_before)
        .into_iter()
        .chain(d.steps.iter().map(|s| &s.localisation_after))
        .collect();
    let localisations = if localisations.is_empty() {
        vec![&d.final_localisation]
    } else {
        localisations
    };
    for phase in PHASE_ORDER {
        let mut row = format!("| {} |", phase.name());
        let mut any = false;
        for l in &localisations {
            match l.phase_rms_n.get(phase.name()) {
                Some((rms, n)) => {
                    any = true;
                    let _ = write!(row, " {rms:.3e} ({n}) |");
                }
                None => row.push_str(" — |"),
            }
        }
        if any {
            let _ = writeln!(out, "{row}");
        }
    }
    out.push_str("\n(number of fitting samples in the phase in parentheses)\n");
    for (i, s) in d.steps.iter().enumerate() {
        let _ = writeln!(
            out,
            "\n## Step {}: candidates on `{}`\n",
            i + 1,
            s.before
                .effects
                .iter()
                .fold(d.baseline.name().to_string(), |a, e| a + " + " + e.id())
        );
        out.push_str("Where the residual of the model before this step sat:\n\n");
        localisation_text(&mut out, &s.localisation_before);
        out.push('\n');
        candidates_table(&mut out, &s.candidates);
        joint_text(&mut out, d, i, options.min_bic_drop);
    }
    let _ = writeln!(out, "\n## Final model `{}`\n", d.final_model());
    localisation_text(&mut out, &d.final_localisation);
    if !d.final_candidates.is_empty() {
        out.push_str("\nNo further candidate is significant:\n\n");
        candidates_table(&mut out, &d.final_candidates);
    }
    if !plots.is_empty() {
        out.push_str("\n## Plots\n\n");
        for p in plots {
            let _ = writeln!(out, "![{p}]({p})\n");
        }
    }
    out
}

/// Writes `fit`, `residual` and `autocorrelation` plots (PNG and SVG) into `dir`;
/// returns the PNG file names.
///
/// # Errors
/// If a file cannot be written.
pub fn write_plots(dir: &Path, data: &Prepared, d: &Diagnosis) -> Result<Vec<String>> {
    let start = d.final_fit.start;
    let t = &data.time_s[start..];
    let series = |fit: &Fit| -> Vec<(f64, f64)> {
        t.iter()
            .copied()
            .zip(fit.prediction.iter().copied())
            .collect()
    };
    let measured: Vec<(f64, f64)> = t
        .iter()
        .copied()
        .zip(data.force_n[start..].iter().copied())
        .collect();
    let max = 4000;
    let final_name = format!("final: {}", d.final_model());
    let fit_chart = Chart {
        title: "Measured vs simulated force".into(),
        x_label: "time [s]".into(),
        y_label: "force [N]".into(),
        series: vec![
            Series::dashed("measured", plots::thin(measured, max), PALETTE[5]),
            Series::solid(
                format!("baseline: {}", d.baseline.name()),
                plots::thin(series(&d.baseline_fit), max),
                PALETTE[1],
            ),
            Series::solid(
                final_name.clone(),
                plots::thin(series(&d.final_fit), max),
                PALETTE[0],
            ),
        ],
    };
    let depth: Vec<f64> = data.depth_m[start..].to_vec();
    let by_depth = |y: &[f64]| -> Vec<(f64, f64)> {
        depth
            .iter()
            .copied()
            .zip(y.iter().copied())
            .filter(|(x, _)| *x > 0.0)
            .collect()
    };
    let hysteresis = Chart {
        title: "Force vs depth (in contact)".into(),
        x_label: "depth δ [m]".into(),
        y_label: "force [N]".into(),
        series: vec![
            Series::dashed(
                "measured",
                plots::thin(by_depth(&data.force_n[start..]), max),
                PALETTE[5],
            ),
            Series::solid(
                "baseline",
                plots::thin(by_depth(&d.baseline_fit.prediction), max),
                PALETTE[1],
            ),
            Series::solid(
                "final",
                plots::thin(by_depth(&d.final_fit.prediction), max),
                PALETTE[0],
            ),
        ],
    };

    let residual =
        |fit: &Fit| -> Vec<(f64, f64)> { t.iter().copied().zip(fit.residual(data)).collect() };
    let residual_chart = Chart {
        title: "Residual (measured − simulated)".into(),
        x_label: "time [s]".into(),
        y_label: "residual [N]".into(),
        series: vec![
            Series::solid(
                "baseline",
                plots::thin(residual(&d.baseline_fit), max),
                PALETTE[1],
            ),
            Series::solid(
                "final",
                plots::thin(residual(&d.final_fit), max),
                PALETTE[0],
            ),
        ],
    };
    // Residual RMS per phase, one curve per model along the workflow: x = phase number.
    let mut per_phase = Vec::new();
    let mut models: Vec<(String, &Localisation)> = Vec::new();
    if let Some(first) = d.steps.first() {
        models.push(("baseline".into(), &first.localisation_before));
    }
    for s in &d.steps {
        models.push((format!("+ {}", s.effect.id()), &s.localisation_after));
    }
    if models.is_empty() {
        models.push(("baseline".into(), &d.final_localisation));
    } else if !d.removed.is_empty() {
        // The backward check took effects out again: the last step is not the final model.
        models.push(("final".into(), &d.final_localisation));
    }
    // The baseline and the final model in the residual panel's colours (red, blue), the
    // models between them in the palette's others.
    let last = models.len() - 1;
    for (i, (name, l)) in models.iter().enumerate() {
        let points: Vec<(f64, f64)> = PHASE_ORDER
            .iter()
            .enumerate()
            .filter_map(|(k, p)| l.phase_rms_n.get(p.name()).map(|(rms, _)| (k as f64, *rms)))
            .collect();
        let color = match i {
            0 => PALETTE[1],
            _ if i == last => PALETTE[0],
            _ => PALETTE[2 + (i - 1) % (PALETTE.len() - 2)],
        };
        per_phase.push(Series::solid(name.clone(), points, color));
    }
    let phase_chart = Chart {
        title: format!(
            "Residual RMS per phase (0 {}, 1 {}, 2 {}, 3 {}, 4 {})",
            PHASE_ORDER[0].name(),
            PHASE_ORDER[1].name(),
            PHASE_ORDER[2].name(),
            PHASE_ORDER[3].name(),
            PHASE_ORDER[4].name()
        ),
        x_label: "phase".into(),
        y_label: "RMS residual [N]".into(),
        series: per_phase,
    };

    let lag_ms = 1e3 * data.dt;
    let acf = |l: &Localisation| -> Vec<(f64, f64)> {
        l.autocorrelation
            .iter()
            .enumerate()
            .map(|(k, r)| (k as f64 * lag_ms, *r))
            .collect()
    };
    let first = d
        .steps
        .first()
        .map_or(&d.final_localisation, |s| &s.localisation_before);
    let band = d.final_localisation.band;
    let last_lag = (d.final_localisation.autocorrelation.len().max(2) - 1) as f64 * lag_ms;
    let acf_chart = Chart {
        title: "Residual autocorrelation with the 99 % band".into(),
        x_label: "lag [ms]".into(),
        y_label: "autocorrelation".into(),
        series: vec![
            Series::solid("baseline", acf(first), PALETTE[1]),
            Series::solid("final", acf(&d.final_localisation), PALETTE[0]),
            Series::dashed(
                "+99 % band",
                vec![(0.0, band), (last_lag, band)],
                PALETTE[5],
            ),
            Series::dashed(
                "−99 % band",
                vec![(0.0, -band), (last_lag, -band)],
                PALETTE[5],
            ),
        ],
    };
    // (The three files are drawn in parallel.)
    [
        (vec![fit_chart, hysteresis], "fit"),
        (vec![residual_chart, phase_chart], "residual"),
        (vec![acf_chart], "autocorrelation"),
    ]
    .par_iter()
    .try_for_each(|(charts, name)| plots::save(charts, &dir.join(name)))?;
    Ok(vec![
        "fit.png".into(),
        "residual.png".into(),
        "autocorrelation.png".into(),
    ])
}

/// Writes `report.md`, `diagnosis.json`, `model.json` (the final model,
/// [`super::spec::ModelSpec`]) and the plots into `dir` (created if needed);
/// returns the report's path.
///
/// # Errors
/// If the folder or a file cannot be written.
pub fn write(
    dir: &Path,
    file: &str,
    data: &Prepared,
    d: &Diagnosis,
    options: &Options,
) -> Result<PathBuf> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let plots = write_plots(dir, data, d)?;
    let report = dir.join("report.md");
    std::fs::write(&report, markdown(file, data, d, options, &plots))
        .with_context(|| format!("writing {}", report.display()))?;
    let path = dir.join("diagnosis.json");
    std::fs::write(&path, serde_json::to_string_pretty(&json(file, d, data))?)
        .with_context(|| format!("writing {}", path.display()))?;
    let spec = super::spec::ModelSpec::of_fit(&d.final_fit, data, file)?;
    let path = dir.join("model.json");
    std::fs::write(&path, serde_json::to_string_pretty(&spec)?)
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(report)
}
