//! Identifiability before significance: what the record's motion can tell apart (the
//! spread of rate and speed at each depth), why an effect is not tried, and which motion
//! would separate two effects the record confuses.

use super::catalogue::Effect;
use super::data::Prepared;
use super::Diagnosis;
use crate::phases::Phase;

/// How much the penetration rate varies at a given depth, relative to its RMS, over the
/// contact samples of the fit window: √(mean within-bin variance of δ̇) / RMS δ̇, with
/// the contact samples sorted by depth into 20 bins of equal count. 0 when each depth is
/// passed at one speed (a loading ramp at any speed profile), about 1 when it is passed
/// loading and unloading. Below [`RATE_SPREAD_MIN`], every rate effect (λ·δ^q·δ̇, a
/// delay, δ̈, sign δ̇) is a function of depth on this record, the same signature as an
/// elastic law: not identifiable.
pub fn rate_spread_at_depth(data: &Prepared, start: usize) -> f64 {
    spread_at_depth(data, start, |v| v)
}

/// [`rate_spread_at_depth`] of the speed |δ̇| while the probe moves (holds left out):
/// about 0 also on a record that passes each depth at one speed in each direction (a
/// load/unload triangle at one speed, a ramp-and-hold), where a sign law, Coulomb
/// friction F_c·sign δ̇, is the linear damping's λ·δ̇ = ±λv and δ̈ vanishes but at the
/// reversals and velocity steps. A hold adds nothing to tell them apart: friction,
/// damping and a mass all vanish there (counted, the hold at the deepest point made a
/// ramp-and-hold look like two speeds, and clean ones were given Coulomb friction or a
/// mass for the timing of the damping's step). Below [`RATE_SPREAD_MIN`], Coulomb
/// friction and inertia are not identifiable where the speed does not change along a
/// stroke either ([`speed_change_with_depth`]), nor inertia where the record never leaves
/// contact.
pub fn speed_spread_at_depth(data: &Prepared, start: usize) -> f64 {
    spread_at_depth_where(data, start, f64::abs, |i| data.phase[i] != Phase::Hold)
}

/// The within-depth-bin spread of `of(δ̇)` relative to its RMS (see
/// [`rate_spread_at_depth`]).
fn spread_at_depth(data: &Prepared, start: usize, of: impl Fn(f64) -> f64) -> f64 {
    spread_at_depth_where(data, start, of, |_| true)
}

/// [`spread_at_depth`] over the in-contact samples `keep` accepts.
fn spread_at_depth_where(
    data: &Prepared,
    start: usize,
    of: impl Fn(f64) -> f64,
    keep: impl Fn(usize) -> bool,
) -> f64 {
    depth_bins(data, start, of, keep).map_or(0.0, |b| b.within)
}

/// How much the speed |δ̇| changes with depth while the probe moves (holds left out),
/// relative to its RMS: √(Σ over the 20 depth bins of `spread_at_depth` of n_bin ×
/// (bin mean − mean)² / n) / RMS |δ̇|, n_bin a bin's samples and n all of them. About 0 on
/// constant-speed strokes (a load/unload triangle, a ramp-and-hold: δ̈ = 0 but at the
/// reversals and velocity steps, where a sampled record cannot place the step within a
/// sample), 0.43 on a whole sine and 0.24-0.35 on the independent generator's taps at one
/// frequency (δ̈ = −ω²·(δ − δ₀), the speed falling from the onset's to 0 at the deepest
/// point). On a record passed at one speed each way (see [`speed_spread_at_depth`]) that
/// also leaves contact, a mass's force m·δ̈ is a function of depth, but one that is not 0
/// at the contact edges where the acceleration is not: a step at each onset and lift-off
/// that no elastic law and no damping makes (damping's ±λv changes sign between them).
/// Below [`SPEED_CHANGE_MIN`] the speed is taken as constant along the strokes and a mass
/// is not tried. (A proxy: the statistic measures how the speed varies with depth, not
/// the acceleration at the edges themselves; a record whose speed steps between depth
/// ranges, both ways, passes it with δ̈ = 0 but at the steps, and a short acceleration
/// right at the onset can sit below it.)
pub fn speed_change_with_depth(data: &Prepared, start: usize) -> f64 {
    depth_bins(data, start, f64::abs, |i| data.phase[i] != Phase::Hold).map_or(0.0, |b| b.between)
}

/// The spread of `of(δ̇)` within and between depth bins, each relative to its RMS.
struct DepthBins {
    within: f64,
    between: f64,
}

/// `of(δ̇)` over the in-contact samples `keep` accepts, sorted by depth into 20 bins of
/// equal count (fewer, of 2 samples each, under 40 samples: a few short taps); `None`
/// under [`MIN_DEPTH_BIN_SAMPLES`] samples or with an RMS of 0.
///
/// (Before 2026-11-28 under 40 samples gave `None`, which the callers read as a spread of
/// 0: an independent generator's four 50 ms taps of a damped material at 2 kHz, 36
/// contact samples in 5 ms blocks, read as "each depth passed at one speed", the
/// damping held at 0 against its plain hysteresis, λ = 585 N·s/m, and the record ended
/// at 11 times its noise floor with every rate effect "not identifiable".)
fn depth_bins(
    data: &Prepared,
    start: usize,
    of: impl Fn(f64) -> f64,
    keep: impl Fn(usize) -> bool,
) -> Option<DepthBins> {
    let mut samples: Vec<(f64, f64)> = (start..data.len())
        // (Not at a kink, where the rate is between the two sides', nor another sample
        // the scores leave out: `Prepared::left_out`.)
        .filter(|&i| data.contact[i] && data.depth_m[i] > 0.0 && !data.left_out[i] && keep(i))
        .map(|i| (data.depth_m[i], of(data.rate_m_per_s[i])))
        .collect();
    if samples.len() < MIN_DEPTH_BIN_SAMPLES {
        return None;
    }
    samples.sort_by(|a, b| a.0.total_cmp(&b.0));
    let rms = (samples.iter().map(|s| s.1 * s.1).sum::<f64>() / samples.len() as f64).sqrt();
    if rms <= 0.0 {
        return None;
    }
    let mean = samples.iter().map(|s| s.1).sum::<f64>() / samples.len() as f64;
    let bins = (samples.len() / 2).min(20);
    let per = samples.len() / bins;
    let mut within = 0.0;
    let mut between = 0.0;
    let mut count = 0usize;
    for b in 0..bins {
        let chunk = &samples[b * per..if b + 1 == bins {
            samples.len()
        } else {
            (b + 1) * per
        }];
        let m = chunk.iter().map(|s| s.1).sum::<f64>() / chunk.len() as f64;
        within += chunk.iter().map(|s| (s.1 - m) * (s.1 - m)).sum::<f64>();
        between += chunk.len() as f64 * (m - mean) * (m - mean);
        count += chunk.len();
    }
    Some(DepthBins {
        within: (within / count as f64).sqrt() / rms,
        between: (between / count as f64).sqrt() / rms,
    })
}

/// Fewest in-contact samples over which the spread of the rate at a depth is measured
/// (4 depth bins of 2: a loading and an unloading sample at about one depth tell the
/// rate's sign apart); fewer leave it unmeasured, read as one speed.
pub const MIN_DEPTH_BIN_SAMPLES: usize = 8;

/// Whether the fit window holds the probe still in contact long enough to show a
/// relaxation: at least [`MIN_HOLD_SAMPLES`] fitting samples and [`MIN_HOLD_SHARE`] of its
/// contact samples in the hold phase. On a record that passes each depth once (a
/// stress-relaxation test: one ramp, then a hold to the end), the time since contact is
/// a function of depth only along the ramp; in the hold the depth stays while a relaxing
/// force decays, which no elastic law does.
pub fn holds_in_contact(data: &Prepared, start: usize) -> bool {
    let contact = (start..data.len()).filter(|&i| data.contact[i]).count();
    let hold = (start..data.len())
        .filter(|&i| data.contact[i] && data.phase[i] == Phase::Hold)
        .count();
    hold >= MIN_HOLD_SAMPLES && hold as f64 >= MIN_HOLD_SHARE * contact as f64
}

/// Fewest fitting samples of a hold in contact for [`holds_in_contact`].
pub const MIN_HOLD_SAMPLES: usize = 20;

/// Smallest share of the contact samples in a hold for [`holds_in_contact`] (a ramp's
/// last samples, classed as a hold where the probe slows, do not make one).
pub const MIN_HOLD_SHARE: f64 = 0.1;

/// [`rate_spread_at_depth`] below which rate effects are not identifiable.
pub const RATE_SPREAD_MIN: f64 = 0.2;

/// [`speed_change_with_depth`] below which the speed along a record's strokes is taken as
/// constant (Coulomb friction and a mass not tried at one speed each way); 0.24-0.35 on
/// the independent generator's one-frequency taps, ≈ 0 on the project's triangles and
/// ramp-and-holds.
pub const SPEED_CHANGE_MIN: f64 = 0.2;

/// Why the record cannot identify an effect the workflow did not try, and the motion
/// that would: (reason, motion).
pub fn unidentifiable_reason(d: &Diagnosis, e: Effect) -> (&'static str, &'static str) {
    if d.one_speed_each_way_only() && e == Effect::Inertia {
        (
            "each depth is passed at one speed in each direction (holds aside, where a mass's force vanishes), so δ̈ is a function of depth: on constant-speed strokes it vanishes but at the reversals and velocity steps, where a sampled record cannot place the step within a sample; on an oscillation at one frequency ω that stays in contact it is −ω²·(δ − δ₀), so a mass is a stiffness −mω² and a constant. What tells a mass apart there, its step at each contact onset and lift-off where the probe accelerates (a tap), is not in this record",
            "a second frequency or speed (a mass's force is then no function of depth), or taps that leave contact while the probe accelerates (a mass's step at each onset and lift-off)",
        )
    } else if d.one_speed_each_way_only() && e == Effect::CoulombFriction {
        (
            "each depth is passed at one speed in each direction (holds aside, where friction and damping both vanish), and that speed does not change along a stroke: Coulomb friction's ±F_c is the baseline damping's ±λv there",
            "a second speed (damping scales with it, friction does not)",
        )
    } else if e == Effect::PlasticSet {
        (
            "the record only loads: a contact point that follows the deepest indentation scales δ by (1 − p), which the elastic law's own parameters absorb",
            "an unloading (a permanent set shows as a later release)",
        )
    } else if e == Effect::Relaxation {
        (
            "each depth is passed once, at one speed, and the probe never holds still in contact: the time since contact is a function of depth, so a relaxing memory of the elastic force is one more elastic law (the elastic reading is kept)",
            separating_motion(Effect::PowerLawStiffness, e),
        )
    } else if e == Effect::ForceDrift {
        (
            "the record's free space is at most one stretch, too short to see the zero at two times: a zero that drifts is a slope in time, which the contact's own force (relaxation, creep, the law along a stroke) can take",
            "lift-offs spread over the record, or a longer stay out of contact (the free-space force then shows the drift)",
        )
    } else if e == Effect::ContactPointOffset {
        (
            "the record has one contact: a shifted contact point for the later contacts has nothing to act on (the contact point itself is refined in every model)",
            "a lift-off and a second contact",
        )
    } else if e == Effect::TimeDelay && d.rate_spread >= RATE_SPREAD_MIN {
        // (Not one speed: the record oscillates at one speed each way in contact
        // throughout, see `diagnose`.)
        (
            "the record stays in contact at one speed each way (one frequency): a delay τ only rotates the force's phase there, κ·δ(t − τ) + λ·δ̇(t − τ) = (κ cos ωτ + λω sin ωτ)·(δ − δ₀) + (λ cos ωτ − κ sin ωτ/ω)·δ̇ + const on a sinusoid, which the stiffness and damping re-split exactly (under a power law its first-order term is a depth-dependent damping); on constant-speed strokes it shows only at the reversals",
            "a lift-off and a new contact (the force then rises τ after the contact), a hold in contact (the force still moving τ after the probe stops) or motion at several frequencies",
        )
    } else if e.is_rate_effect() && d.damping_held {
        (
            "each depth is passed at one speed: a rate effect is a function of depth here, the signature of an elastic law (the elastic reading is kept and the linear damping held at 0: its one trace, the step λv at a contact onset from free space or where the probe stops or starts moving in contact, is absent or not significant)",
            separating_motion(Effect::PowerLawStiffness, e),
        )
    } else if e.is_rate_effect() {
        (
            "each depth is passed at one speed: a rate effect is a function of depth here, the signature of an elastic law (the elastic reading is kept; the linear damping is fitted from its step λv at the contact onset or where the probe stops or starts moving in contact)",
            separating_motion(Effect::PowerLawStiffness, e),
        )
    } else {
        (
            "the record never leaves contact: a force offset trades off against the contact point and the elastic law (held at the assumed offset)",
            "a lift-off out of contact (free-space samples fix the offset)",
        )
    }
}

/// The motion that would separate effects `a` and `b` on a record that cannot.
pub fn separating_motion(a: Effect, b: Effect) -> &'static str {
    use Effect::*;
    let has = |e: Effect| a == e || b == e;
    let elastic = has(PowerLawStiffness) || has(ExponentialStiffness);
    if has(Relaxation) {
        "a hold at constant depth (relaxation decays while the depth stays; rate terms vanish)"
    } else if has(Inertia) {
        "a faster tap or oscillation (inertia grows with the acceleration, δ̈)"
    } else if elastic && (has(DepthDependentDamping) || has(TimeDelay) || has(CoulombFriction)) {
        "a second indentation speed (a rate effect scales with δ̇, an elastic law does not)"
    } else if has(TimeDelay) && (has(DepthDependentDamping) || has(CoulombFriction)) {
        "motion at several frequencies (a delay's force lead grows with frequency, damping's does not)"
    } else if has(CoulombFriction) {
        "motion reversals at several speeds (friction's step does not scale with speed)"
    } else if has(ForceDrift) {
        "lift-offs spread over the record (a drifting zero shows in the free-space force at each)"
    } else if has(ForceOffset) || has(ContactPointOffset) || has(PlasticSet) {
        "a lift-off out of contact and back (the offset, the contact point and a set differ there)"
    } else {
        "a richer motion: several speeds, a hold and a lift-off"
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::data::prepare_known;
    use std::f64::consts::PI;

    /// Three short taps (half-sines 30 ms long and 1 mm high from 0.2 mm out, one every
    /// 0.75 s) of a Kelvin-Voigt material at 1 kHz: loading and unloading pass each depth
    /// at opposite rates, a spread of about 1, on fewer than 40 fitting samples in
    /// contact. Before 2026-11-28 that few read as a spread of 0 (one speed: such a
    /// record's damping held at 0, its hysteresis unfitted).
    #[test]
    fn a_few_short_taps_pass_each_depth_at_two_rates() {
        let t: Vec<f64> = (0..2200).map(|i| i as f64 * 1e-3).collect();
        let tap = |t: f64| -> (f64, f64) {
            let phase = (t - 0.3).rem_euclid(0.75);
            if t >= 0.3 && phase < 0.03 {
                let w = PI / 0.03;
                (
                    -0.2e-3 + 1.0e-3 * (w * phase).sin(),
                    1.0e-3 * w * (w * phase).cos(),
                )
            } else {
                (-0.2e-3, 0.0)
            }
        };
        let x: Vec<f64> = t.iter().map(|&t| tap(t).0).collect();
        let force: Vec<f64> = t
            .iter()
            .map(|&t| {
                let (x, v) = tap(t);
                if x > 0.0 {
                    (2e4 * x + 20.0 * v).max(0.0)
                } else {
                    0.0
                }
            })
            .collect();
        let data = prepare_known(&t, &x, &force, 0.0, 0.0, 1e-3, 1).expect("prepared");
        let start = data.fit_start();
        let contact = (start..data.len()).filter(|&i| data.contact[i]).count();
        assert!(
            (8..40).contains(&contact),
            "{contact} contact samples in blocks of {}",
            data.block
        );
        let spread = rate_spread_at_depth(&data, start);
        assert!(spread > RATE_SPREAD_MIN, "{spread}");
    }
}
