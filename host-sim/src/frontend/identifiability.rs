//! Which parameters a record determines, from the excitation it actually had.
//!
//! For a law F(θ) fitted to the in-contact samples, the columns of its Jacobian ∂F/∂θ_j
//! say how each parameter shows in the force. A parameter is determined when
//! - its column is not (nearly) a combination of the others: the variance inflation
//!   factor VIF_j = G_jj·(G⁻¹)_jj of the Gram matrix G of the columns stays below
//!   [`MAX_VIF`] (on a constant-speed ramp δⁿ·δ̇ = v·δⁿ and VIF = ∞: damping and stiffness
//!   are one regressor), and
//! - the force it carries is known to better than [`MAX_FORCE_UNCERTAINTY`] of the force's
//!   RMS: SE_j·rms(∂F/∂θ_j), with SE_j = σ·√((JᵀJ)⁻¹_jj) from the measurement noise σ and
//!   an effective sample size N·(1 − ρ1)/(1 + ρ1) for noise with lag-1 autocorrelation ρ1
//!   (both from the record's free-space samples where it has them: real noise is
//!   coloured). What the law misses (plastic flow, creep) is not noise: it is the model's
//!   error, judged by the fit's NRMSE and by `diagnose`.
//!
//! The contact point is a fitted parameter too: for a law whose force is continuous at
//! contact (all but Kelvin-Voigt, whose λ·v jump at impact places it to a sample), its
//! column ∂F/∂u_c joins the law's when the elastic parameters' force uncertainty is
//! computed. A ramp's k and n trade with it, and under coloured noise a record may place
//! it only to ±0.1 mm: the force at a depth below it is then not determined, however well
//! the law follows the force over position.
//! Not counted: the force offset (taken as known: the free space behind the contact
//! point determines it, and where the record has none it is held and flagged); the
//! damping's verdict (its column reads the rate; an undetermined damping is held at 0).
//! Kelvin-Voigt's exclusion assumes its impact jump λ·v stands out of the noise; where
//! it does not, its κ is judged as if the contact point were known.

use estimator_core::ModelKind;
use nalgebra::DMatrix;
use serde::Serialize;

use super::fit::LawFamily;
use super::FrontEnd;

/// Largest variance inflation factor of a determined parameter (a correlation of 0.995
/// with the other columns).
pub const MAX_VIF: f64 = 100.0;

/// Largest uncertainty of the force a determined parameter carries, as a fraction of the
/// in-contact force's RMS.
pub const MAX_FORCE_UNCERTAINTY: f64 = 0.02;

/// The verdict on one parameter.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Verdict {
    /// Parameter name (as in the estimate's parameters).
    pub name: &'static str,
    /// The record determines it.
    pub identifiable: bool,
    /// Variance inflation factor of its column.
    pub vif: f64,
    /// Standard error of the force it carries, relative to the force's RMS: for the
    /// elastic parameters (not λ) with the contact point fitted beside them (see the
    /// module's doc; all laws but Kelvin-Voigt's).
    pub force_uncertainty: f64,
    /// Why not, in words (empty when identifiable).
    pub reason: String,
    /// In-contact points the verdict rests on.
    pub points: usize,
}

/// Verdicts for the columns `jacobian` (one `Vec` per parameter, over the same in-contact
/// samples) under measurement noise of standard deviation `residual_n` \[N\] and lag-1
/// autocorrelation `rho1`, for a force of RMS `force_rms_n` \[N\].
pub fn verdicts(
    names: &[&'static str],
    jacobian: &[Vec<f64>],
    residual_n: f64,
    rho1: f64,
    force_rms_n: f64,
) -> Vec<Verdict> {
    let p = jacobian.len();
    let n = jacobian.first().map_or(0, Vec::len);
    if p == 0 || n < p + 2 {
        return names
            .iter()
            .map(|&name| Verdict {
                name,
                identifiable: false,
                vif: f64::INFINITY,
                force_uncertainty: f64::INFINITY,
                reason: format!("only {n} samples in contact"),
                points: n,
            })
            .collect();
    }
    let rms: Vec<f64> = jacobian
        .iter()
        .map(|c| (c.iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt())
        .collect();
    // Gram matrix of the unit-RMS columns.
    let mut g = DMatrix::<f64>::zeros(p, p);
    for a in 0..p {
        for b in a..p {
            let s: f64 = jacobian[a]
                .iter()
                .zip(&jacobian[b])
                .map(|(x, y)| x * y)
                .sum::<f64>()
                / (n as f64 * rms[a].max(f64::MIN_POSITIVE) * rms[b].max(f64::MIN_POSITIVE));
            g[(a, b)] = s;
            g[(b, a)] = s;
        }
    }
    // A (numerically) singular Gram matrix means collinear columns: infinite VIF, not the
    // finite answer a pseudo-inverse would give.
    let eigen = g.clone().symmetric_eigenvalues();
    let (lo, hi) = eigen.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &e| {
        (lo.min(e), hi.max(e))
    });
    let inverse = (lo > 1e-12 * hi).then(|| g.clone().try_inverse()).flatten();
    let rho = rho1.clamp(0.0, 0.999);
    let n_eff = (n as f64 * (1.0 - rho) / (1.0 + rho)).max(1.0);
    names
        .iter()
        .enumerate()
        .map(|(j, &name)| {
            let (vif, uncertainty) = match &inverse {
                Some(inv) if rms[j] > 0.0 => {
                    let vif = g[(j, j)] * inv[(j, j)];
                    // SE of the unit-RMS coefficient is σ·√(inv_jj/N_eff); the force it
                    // carries has that RMS.
                    let force_se = residual_n * (inv[(j, j)].max(0.0) / n_eff).sqrt();
                    (
                        if vif.is_finite() && vif >= 1.0 - 1e-9 {
                            vif
                        } else {
                            f64::INFINITY
                        },
                        force_se / force_rms_n.max(f64::MIN_POSITIVE),
                    )
                }
                _ => (f64::INFINITY, f64::INFINITY),
            };
            let mut reason = String::new();
            if vif.is_nan() || vif >= MAX_VIF {
                reason = format!(
                    "its regressor is nearly a combination of the others (VIF {})",
                    if vif.is_finite() {
                        format!("{vif:.3e}")
                    } else {
                        "∞".into()
                    }
                );
            } else if uncertainty.is_nan() || uncertainty >= MAX_FORCE_UNCERTAINTY {
                reason = format!(
                    "the force it carries is uncertain by {:.1} % of the force",
                    100.0 * uncertainty
                );
            }
            Verdict {
                name,
                identifiable: reason.is_empty(),
                vif,
                force_uncertainty: uncertainty,
                reason,
                points: n,
            }
        })
        .collect()
}

/// The law family whose joint fit sets up a record for `model`: power-law onsets
/// (Hunt-Crossley, Hammerstein) or a linear onset (Kelvin-Voigt, with its jump λ·v at
/// impact, and Zener).
pub fn family_for(model: ModelKind) -> LawFamily {
    match model {
        ModelKind::KelvinVoigt => LawFamily::KelvinVoigt,
        ModelKind::Zener => LawFamily::Zener,
        ModelKind::HuntCrossley | ModelKind::HuntCrossleySingleStage => LawFamily::HuntCrossley,
        ModelKind::Hammerstein1 | ModelKind::Hammerstein2 => LawFamily::PowerLawRelaxation,
    }
}

/// Time within which the double-stage Hunt-Crossley estimator needs the damping excited
/// \[s\]: the 2 s memory of the estimators' default forgetting, over which its coupled
/// stages Γ1/Γ2 iterate. A record whose rate is constant within such spans (constant-speed
/// strokes) determines λ only across strokes, which the coupled stages cannot use: while
/// one stroke lasts, the damping absorbs part of the stiffness and, through Γ2, the
/// exponent. The single-stage and Kelvin-Voigt estimators are single linear regressions
/// over their whole memory and use every stroke.
pub const ONLINE_WINDOW_S: f64 = 2.0;

/// Fraction of the in-contact [`ONLINE_WINDOW_S`] spans (weighted by their points) in which
/// the damping must be determined for an online estimator to determine it.
pub const MIN_ONLINE_FRACTION: f64 = 0.8;

/// Verdicts on the elastic and damping parameters of `model` from the front end's joint
/// fit: Kelvin-Voigt and Zener κ, λ (columns δ, δ̇); Hunt-Crossley k, λ, n (columns δⁿ,
/// δⁿ·δ̇, (k + λ·δ̇)·δⁿ·ln δ, with δ relative to the record's typical depth so that k
/// stands for the force there); Hammerstein γ1, γ2 (columns δ^γ2, γ1·δ^γ2·ln δ). Computed
/// over the fitted points in contact where the law pushes (δ > 0, law force > 0), the
/// elastic parameters' force uncertainty with the contact point's column beside them (see
/// the module's doc); `along` is [`law_along_with_contact`] for `model`. For the double
/// stage the damping must also be determined within most [`ONLINE_WINDOW_S`] spans of the
/// record. The relaxation filter of Zener and Hammerstein is judged by
/// [`relaxation_verdict`].
pub fn for_model(front: &FrontEnd, along: &Along, model: ModelKind) -> Vec<Verdict> {
    let mut verdicts = whole_record(front, along, model, None, &[]);
    let Some(j) = verdicts.iter().position(|v| v.name == "lambda") else {
        return verdicts;
    };
    if model != ModelKind::HuntCrossley || !verdicts[j].identifiable {
        return verdicts;
    }
    let t = &front.series.time_s;
    let (t0, t1) = (t[0], t[t.len() - 1]);
    let (mut determined, mut total) = (0usize, 0usize);
    let mut start = t0;
    while start < t1 {
        let window = (start, start + ONLINE_WINDOW_S);
        let v = whole_record(front, along, model, Some(window), &[]);
        let points = v.first().map_or(0, |v| v.points);
        if points >= 20 {
            total += points;
            if v.iter().any(|v| v.name == "lambda" && v.identifiable) {
                determined += points;
            }
        }
        start += 0.5 * ONLINE_WINDOW_S;
    }
    if total > 0 && (determined as f64) < MIN_ONLINE_FRACTION * total as f64 {
        verdicts[j].identifiable = false;
        verdicts[j].reason = format!(
            "the rate hardly varies within {ONLINE_WINDOW_S} s spans (λ is determined in only {:.0} % \
             of them: constant-speed strokes determine it only across strokes, which the double \
             stage's coupled Γ1/Γ2 cannot use; the single stage can)",
            100.0 * determined as f64 / total as f64
        );
    }
    verdicts
}

/// Verdicts on the parameters of `model` other than `held` (held at a default: their
/// columns leave the regression, so a parameter collinear only with a held one is
/// determined).
pub fn without_held(
    front: &FrontEnd,
    along: &Along,
    model: ModelKind,
    held: &[&str],
) -> Vec<Verdict> {
    whole_record(front, along, model, None, held)
}

/// As [`for_model`] over the whole record, or over the points in `window` (start, end)
/// \[s\], leaving out the parameters in `held`; `along` is [`law_along_with_contact`].
fn whole_record(
    front: &FrontEnd,
    along: &Along,
    model: ModelKind,
    window: Option<(f64, f64)>,
    held: &[&str],
) -> Vec<Verdict> {
    let law = &front.law;
    let (depth, rate, predicted) = (&along.0, &along.1, &along.2);
    let t = &front.series.time_s;
    // The points' times increase: a window is one index range.
    let points = match window {
        Some((a, b)) => t.partition_point(|&t| t < a)..t.partition_point(|&t| t < b),
        None => 0..depth.len(),
    };
    let contact: Vec<usize> = points
        .filter(|&i| depth[i] > 0.0 && predicted[i] > 0.0)
        .collect();
    let force: Vec<f64> = contact
        .iter()
        .map(|&i| front.series.force_n[i] - front.force_offset_n)
        .collect();
    // Depth relative to the typical one (the geometric mean): ln(δ/δ_ref) is centred, so
    // the exponent's column does not carry the stiffness's (ln δ in metres is ≈ −7 all
    // over a record, and k, n would look collinear merely through the unit).
    let ln_ref = contact.iter().map(|&i| depth[i].ln()).sum::<f64>() / contact.len().max(1) as f64;
    let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt();
    let col = |f: &dyn Fn(usize) -> f64| -> Vec<f64> { contact.iter().map(|&i| f(i)).collect() };
    let n = law.exponent;
    let (names, columns): (Vec<&'static str>, Vec<Vec<f64>>) = match model {
        ModelKind::KelvinVoigt => (
            vec!["kappa", "lambda"],
            vec![col(&|i| depth[i]), col(&|i| rate[i])],
        ),
        ModelKind::Zener => {
            // The relaxed and the relaxing stiffness: δ and its relaxing part.
            let g: Vec<f64> = depth.iter().map(|d| d.max(0.0)).collect();
            let z = super::fit::relaxing(&g, t, law.rate_per_s.max(f64::MIN_POSITIVE));
            (
                vec!["kappa2", "kappa1"],
                vec![col(&|i| g[i]), col(&|i| z[i])],
            )
        }
        ModelKind::HuntCrossley | ModelKind::HuntCrossleySingleStage => {
            let (k, lambda) = (law.stiffness, law.damping());
            (
                vec!["k", "lambda", "n"],
                vec![
                    col(&|i| depth[i].powf(n)),
                    col(&|i| depth[i].powf(n) * rate[i]),
                    col(&|i| (k + lambda * rate[i]) * depth[i].powf(n) * (depth[i].ln() - ln_ref)),
                ],
            )
        }
        ModelKind::Hammerstein1 | ModelKind::Hammerstein2 => {
            // γ1 scales the whole response; γ2 enters through ln δ (in its elastic part).
            (
                vec!["gamma1", "gamma2"],
                vec![
                    col(&|i| predicted[i]),
                    col(&|i| predicted[i] * (depth[i].ln() - ln_ref)),
                ],
            )
        }
    };
    let (names, columns): (Vec<&'static str>, Vec<Vec<f64>>) = names
        .into_iter()
        .zip(columns)
        .filter(|(name, _)| !held.contains(name))
        .unzip();
    let force_rms = rms(&force);
    let mut v = verdicts(&names, &columns, front.noise_n, front.noise_rho1, force_rms);
    // (Over a window only λ's verdict is read, which the contact point does not enter.)
    if let (Some(c), None) = (&along.3, window) {
        let c = col(&|i| c[i]);
        let c_rms = rms(&c);
        let (mut names, mut columns) = (names, columns);
        names.push(CONTACT);
        columns.push(c);
        let mut with = verdicts(&names, &columns, front.noise_n, front.noise_rho1, force_rms);
        let placed = with.pop().filter(|c| c.name == CONTACT);
        // The contact point's standard error [m]: the force its column carries over the
        // column's RMS.
        let se_m = placed.map_or(f64::INFINITY, |c| {
            c.force_uncertainty * force_rms / c_rms.max(f64::MIN_POSITIVE)
        });
        // The contact point widens the others' uncertainty; their collinearity is judged
        // among the law's own columns (with the contact point's, a power law's columns
        // are always strongly correlated, VIF 10³-10⁴, yet determined under little noise).
        // The damping is judged as before: its column reads the rate, which no shift of
        // the contact point mimics, and a damping found undetermined is held at 0, a
        // larger step than a flag on the elastic law.
        for (alone, with) in v.iter_mut().zip(&with).filter(|(a, _)| a.name != "lambda") {
            if alone.identifiable
                && (with.force_uncertainty.is_nan()
                    || with.force_uncertainty >= MAX_FORCE_UNCERTAINTY)
            {
                alone.identifiable = false;
                alone.reason = if se_m.is_finite() && with.force_uncertainty.is_finite() {
                    format!(
                        "it trades with the contact point, which the record places only to \
                         ±{se_m:.2e} m: the force it carries is uncertain by {:.1} % of the \
                         force ({:.1} % with the contact point given)",
                        100.0 * with.force_uncertainty,
                        100.0 * alone.force_uncertainty
                    )
                } else {
                    // Too few points, or a singular set of columns, with the contact point.
                    format!("with the contact point fitted, {}", with.reason)
                };
            }
            alone.force_uncertainty = with.force_uncertainty;
        }
    }
    for v in &mut v {
        v.points = contact.len();
    }
    v
}

/// The contact point's name among the columns (it gets no verdict of its own: the front
/// end's note says where it was found, and a parameter it leaves undetermined quotes its
/// standard error).
const CONTACT: &str = "contact_position_m";

/// The law along the fitted points ([`FrontEnd::law_along`]: depth, rate, force) and, for
/// a law whose force is continuous at the contact point, its derivative with respect to
/// the contact point (a central difference over a ten-thousandth of the deepest point),
/// the column of the one parameter of the joint fit every record must determine too:
/// on a ramp the contact point trades with the exponent and the stiffness (a shallower
/// contact and a smaller n draw nearly the same loading curve), and under coloured noise
/// it is far less certain than a fit with the contact point given would say. Kelvin-Voigt
/// is left without it: its force jumps by λ·v at impact, which places the contact point
/// to a sample and which a derivative cannot express.
pub fn law_along_with_contact(front: &FrontEnd, model: ModelKind) -> Along {
    let (depth, rate, force) = front.law_along();
    let deepest = depth.iter().copied().fold(0.0f64, f64::max);
    let h = 1e-4 * deepest;
    let contact = (model != ModelKind::KelvinVoigt && h.is_normal()).then(|| {
        let t = &front.series.time_s;
        let accel = super::accel_along(&front.series, front.position_sign);
        let at = |shift: f64| {
            let d: Vec<f64> = depth.iter().map(|d| d - shift).collect();
            front.law.predict(&d, &rate, &accel, t)
        };
        // ∂F/∂u_c with δ = u − u_c.
        at(h)
            .iter()
            .zip(at(-h))
            .map(|(a, b)| (a - b) / (2.0 * h))
            .collect::<Vec<f64>>()
    });
    // (A column that is not finite everywhere judges nothing.)
    let contact = contact.filter(|c| c.iter().all(|v| v.is_finite()));
    (depth, rate, force, contact)
}

/// [`law_along_with_contact`]'s depth, rate, force and contact-point column, computed once
/// and shared by [`for_model`], its windows and [`without_held`].
pub type Along = (Vec<f64>, Vec<f64>, Vec<f64>, Option<Vec<f64>>);

/// Whether the record can show relaxation (the Zener and Hammerstein filter): it needs
/// the force to evolve at a (nearly) constant depth — a hold in contact of at least
/// `min_hold_s` \[s\] where |δ̇| stays below a tenth of the record's typical in-contact
/// speed — or a change of speed (loading at two speeds at least a factor 2 apart).
pub fn relaxation_verdict(
    front: &FrontEnd,
    names: &[&'static str],
    min_hold_s: f64,
) -> Vec<Verdict> {
    let (depth, rate) = front.series_depth_and_rate();
    let t = &front.series.time_s;
    let mut moving: Vec<f64> = (0..depth.len())
        .filter(|&i| depth[i] > 0.0)
        .map(|i| rate[i].abs())
        .collect();
    let k = moving.len() * 9 / 10;
    let typical = if k < moving.len() {
        *moving.select_nth_unstable_by(k, f64::total_cmp).1
    } else {
        0.0
    };
    let mut longest: f64 = 0.0;
    let mut start: Option<f64> = None;
    for i in 0..depth.len() {
        let holding = depth[i] > 0.0 && rate[i].abs() < 0.1 * typical;
        match (holding, start) {
            (true, None) => start = Some(t[i]),
            (false, Some(s)) => {
                longest = longest.max(t[i] - s);
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        longest = longest.max(t[t.len() - 1] - s);
    }
    let loading: Vec<f64> = (0..depth.len())
        .filter(|&i| depth[i] > 0.0 && rate[i] > 0.3 * typical)
        .map(|i| rate[i])
        .collect();
    let (lo, hi) = super::fit::min_max(&loading);
    let speeds_differ = loading.len() > 10 && hi > 2.0 * lo;
    let identifiable = longest >= min_hold_s || speeds_differ;
    names
        .iter()
        .map(|&name| Verdict {
            name,
            identifiable,
            vif: f64::NAN,
            force_uncertainty: f64::NAN,
            points: moving.len(),
            reason: if identifiable {
                String::new()
            } else {
                format!(
                    "the record has no hold in contact (longest {longest:.2} s) and no change of loading speed: \
                     relaxation cannot be told from stiffness"
                )
            },
        })
        .collect()
}

/// Lag-1 autocorrelation of `r` (0 for fewer than 3 values).
pub fn lag1_autocorrelation(r: &[f64]) -> f64 {
    if r.len() < 3 {
        return 0.0;
    }
    let m = r.iter().sum::<f64>() / r.len() as f64;
    let var: f64 = r.iter().map(|x| (x - m) * (x - m)).sum();
    if var <= 0.0 {
        return 0.0;
    }
    r.windows(2).map(|w| (w[0] - m) * (w[1] - m)).sum::<f64>() / var
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn collinear_damping_is_not_identifiable_and_a_varied_rate_is() {
        let d: Vec<f64> = (1..2000).map(|i| i as f64 * 1e-6).collect();
        let g: Vec<f64> = d.iter().map(|d| d.powf(1.3)).collect();
        // Constant speed: δⁿ·δ̇ = v·δⁿ.
        let ramp: Vec<f64> = g.iter().map(|g| g * 1e-3).collect();
        let v = verdicts(&["k", "lambda"], &[g.clone(), ramp], 1e-3, 0.0, 1.0);
        assert!(!v[1].identifiable && !v[0].identifiable, "{v:?}");
        assert!(v[1].vif.is_infinite() || v[1].vif > 1e6);
        // A rate that goes both ways.
        let both: Vec<f64> = g
            .iter()
            .enumerate()
            .map(|(i, g)| g * 1e-3 * (i as f64 * 0.01).sin())
            .collect();
        let v = verdicts(&["k", "lambda"], &[g, both], 1e-3, 0.0, 1.0);
        assert!(v.iter().all(|v| v.identifiable), "{v:?}");
    }

    /// A power-law ramp into a hold and back at 250 Hz (F = 1.37e5·δ^1.65 N, 4.7 mm deep at
    /// 15 mm/s, a 9 N offset), under AR(1) noise of lag-1 correlation `rho` and deviation
    /// `sigma_n`: time \[s\], position \[m\], force \[N\].
    fn power_law_ramp_and_hold(sigma_n: f64, rho: f64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let (rate_hz, speed, deepest) = (250.0, 0.015, 0.0047);
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        let normal = Normal::new(0.0, sigma_n * (1.0 - rho * rho).sqrt()).unwrap();
        let (mut t, mut x, mut f) = (Vec::new(), Vec::new(), Vec::new());
        let ramp = deepest / speed;
        let mut e = 0.0;
        for i in 0..(12.0 * rate_hz) as usize {
            let time = i as f64 / rate_hz;
            // 0.5 s behind the surface, the ramp, 10 s hold, the retract, the rest out.
            let u = time - 0.5;
            let depth = if u < 0.0 {
                -0.5e-3
            } else if u < ramp {
                -0.5e-3 + (deepest + 0.5e-3) * u / ramp
            } else if u < ramp + 10.0 {
                deepest
            } else {
                (deepest - (deepest + 0.5e-3) * (u - ramp - 10.0) / ramp).max(-0.5e-3)
            };
            e = rho * e + normal.sample(&mut rng);
            t.push(time);
            x.push(depth);
            f.push(9.0 + 1.37e5 * depth.max(0.0).powf(1.65) + e);
        }
        (t, x, f)
    }

    #[test]
    fn an_elastic_law_that_trades_with_an_uncertain_contact_point_is_flagged() {
        // Under strongly coloured noise (as on seed 1006 of the structure sweep's
        // ramp-and-hold, where F(1 mm) came out 18 % off "identifiable") the contact point
        // is placed only to ±0.1 mm, and k (the force at a depth below it) with it.
        let verdict = |sigma_n, rho| {
            let (t, x, f) = power_law_ramp_and_hold(sigma_n, rho);
            let front =
                super::super::analyse(&t, &x, &f, LawFamily::HuntCrossley, &Default::default())
                    .unwrap();
            let model = ModelKind::HuntCrossleySingleStage;
            for_model(&front, &law_along_with_contact(&front, model), model)
        };
        let coloured = verdict(0.2, 0.93);
        let k = coloured.iter().find(|v| v.name == "k").unwrap();
        assert!(
            !k.identifiable && k.reason.contains("trades with the contact point"),
            "{coloured:?}"
        );
        // The contact point's standard error it quotes is of the size the fits miss by on
        // such records (seeds of this record: 8 µm to 0.3 mm; 190 µm on the sweep's seed).
        let se_m: f64 = k
            .reason
            .split('±')
            .nth(1)
            .unwrap()
            .split(' ')
            .next()
            .unwrap()
            .parse()
            .unwrap();
        assert!((3e-5..1e-3).contains(&se_m), "{}", k.reason);
        // The damping's verdict does not read the contact point.
        assert!(
            coloured
                .iter()
                .any(|v| v.name == "lambda" && v.identifiable),
            "{coloured:?}"
        );
        // Under little white noise the same motion determines every parameter.
        let white = verdict(0.005, 0.0);
        assert!(white.iter().all(|v| v.identifiable), "{white:?}");
    }

    #[test]
    fn autocorrelation_of_a_slow_wave_is_near_one() {
        let r: Vec<f64> = (0..1000).map(|i| (i as f64 * 0.01).sin()).collect();
        assert!(lag1_autocorrelation(&r) > 0.99);
    }
}
