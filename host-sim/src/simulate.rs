//! Forward simulation of an estimated model on a measured motion: the force the model
//! predicts for the recorded depth and depth rate, with the core's own contact models.
//! Used for the fit quality (NRMSE) and for the plots' "estimated" curves.

use estimator_core::models::{
    ContactModel, ElasticResponse, Hammerstein, HuntCrossley, KelvinVoigt, Zener,
};
use estimator_core::AnyParameters;

/// Builds the core contact model for `parameters` (at sample time `sample_time_s`), or
/// `None` when the parameters are not physical (negative stiffness, unstable filter…).
pub fn contact_model(
    parameters: &AnyParameters,
    sample_time_s: f32,
) -> Option<Box<dyn ContactModel>> {
    match *parameters {
        AnyParameters::KelvinVoigt(p) => {
            // A negative damping estimate is still a prediction; clamp only the stiffness.
            Some(Box::new(KelvinVoigt {
                kappa: p.kappa.max(0.0),
                lambda: p.lambda,
            }))
        }
        AnyParameters::HuntCrossley(p) => Some(Box::new(HuntCrossley {
            k: p.k.max(0.0),
            lambda: p.lambda,
            n: p.n,
            q: p.n,
        })),
        AnyParameters::Zener(p) => Zener::try_new(p.kappa1, p.kappa2, p.lambda, sample_time_s)
            .ok()
            .map(|z| Box::new(z) as Box<dyn ContactModel>),
        AnyParameters::Hammerstein {
            gamma1,
            gamma2,
            order,
            a,
            b,
        } => {
            let elastic = ElasticResponse::PowerLaw { gamma1, gamma2 };
            match order {
                1 => Hammerstein::<1>::try_new(elastic, [a[0]], [b[0]])
                    .ok()
                    .map(|h| Box::new(h) as Box<dyn ContactModel>),
                2 => Hammerstein::<2>::try_new(elastic, a, b)
                    .ok()
                    .map(|h| Box::new(h) as Box<dyn ContactModel>),
                _ => None,
            }
        }
    }
}

/// Simulated force \[N\] for each (depth \[m\], depth rate \[m/s\]); the model restarts from
/// rest whenever `in_contact` goes from false to true (a new contact). Out of contact
/// the force is 0 and the model is not stepped (it restarts from rest at the next onset:
/// nothing it would do there reaches an output).
///
/// Each contact starts the model from rest, so the contacts are independent: they are
/// simulated in parallel, each stretch from an onset to the next with a model of its own
/// (the same numbers as one model stepped through the whole record).
pub fn simulate_force(
    parameters: &AnyParameters,
    sample_time_s: f32,
    depth_m: &[f64],
    rate_m_per_s: &[f64],
    in_contact: &[bool],
) -> Option<Vec<f64>> {
    use rayon::prelude::*;
    // Fails here, before any work, if the parameters are not physical.
    contact_model(parameters, sample_time_s)?;
    let n = depth_m.len();
    // Stretches of at least n/64 samples (a few per thread), each cut at a contact onset.
    let least = n.div_ceil(64).max(1);
    let mut cuts = vec![0];
    for i in 1..n {
        if in_contact[i] && !in_contact[i - 1] && i - cuts[cuts.len() - 1] >= least {
            cuts.push(i);
        }
    }
    cuts.push(n);
    let mut out = vec![0.0; n];
    let mut stretches = Vec::with_capacity(cuts.len());
    let mut rest = out.as_mut_slice();
    for w in cuts.windows(2) {
        let (stretch, tail) = rest.split_at_mut(w[1] - w[0]);
        stretches.push((w[0], stretch));
        rest = tail;
    }
    stretches.into_par_iter().for_each(|(start, stretch)| {
        let Some(mut model) = contact_model(parameters, sample_time_s) else {
            return;
        };
        let mut was_in_contact = false;
        for (k, out) in stretch.iter_mut().enumerate() {
            let i = start + k;
            if !in_contact[i] {
                was_in_contact = false;
                continue;
            }
            if !was_in_contact {
                model.reset();
            }
            was_in_contact = true;
            *out = f64::from(model.step(depth_m[i] as f32, rate_m_per_s[i] as f32));
        }
    });
    Some(out)
}

/// Normalised RMS error of `model` against `measured`, in percent of the measured range
/// (max − min): 100·sqrt(mean((m − s)²))/range. `None` on an empty or flat record, or
/// on slices of different lengths.
pub fn nrmse_percent(measured: &[f64], model: &[f64]) -> Option<f64> {
    if measured.len() != model.len() {
        return None;
    }
    nrmse_percent_of(measured.iter().copied().zip(model.iter().copied()))
}

/// [`nrmse_percent`] of (measured, model) pairs, read without a copy (a long record's
/// judged samples are megabytes); the sums in the same order, so the same value.
pub fn nrmse_percent_of(pairs: impl Iterator<Item = (f64, f64)> + Clone) -> Option<f64> {
    let (count, lo, hi) = pairs.clone().fold(
        (0usize, f64::INFINITY, f64::NEG_INFINITY),
        |(count, lo, hi), (m, _)| (count + 1, lo.min(m), hi.max(m)),
    );
    let range = hi - lo;
    if count == 0 || range.is_nan() || range <= 0.0 {
        return None;
    }
    let mse = pairs.map(|(m, s)| (m - s) * (m - s)).sum::<f64>() / count as f64;
    Some(100.0 * mse.sqrt() / range)
}

/// Variance accounted for, percent: 100·(1 − var(m − s)/var(m)). `None` below 2 samples,
/// on a flat record, or on slices of different lengths.
pub fn vaf_percent(measured: &[f64], model: &[f64]) -> Option<f64> {
    if measured.len() != model.len() {
        return None;
    }
    vaf_percent_of(measured.iter().copied().zip(model.iter().copied()))
}

/// The variance of the `n` values of `values`, in two passes (the mean, then the squared
/// deviations from it) \[their unit²\].
pub(crate) fn variance(values: impl Iterator<Item = f64> + Clone, n: usize) -> f64 {
    let mean = values.clone().sum::<f64>() / n as f64;
    values.map(|x| (x - mean) * (x - mean)).sum::<f64>() / n as f64
}

/// [`vaf_percent`] of (measured, model) pairs, read without a copy.
pub fn vaf_percent_of(pairs: impl Iterator<Item = (f64, f64)> + Clone) -> Option<f64> {
    let n = pairs.clone().count();
    if n < 2 {
        return None;
    }
    let vm = variance(pairs.clone().map(|(m, _)| m), n);
    if vm.is_nan() || vm <= 0.0 {
        return None;
    }
    let vr = variance(pairs.map(|(m, s)| m - s), n);
    Some(100.0 * (1.0 - vr / vm))
}

#[cfg(test)]
mod tests {
    use super::*;
    use estimator_core::kelvin_voigt::KelvinVoigtParameters;

    #[test]
    fn kelvin_voigt_simulation_and_fit_metrics() {
        let p = AnyParameters::KelvinVoigt(KelvinVoigtParameters {
            kappa: 1000.0,
            lambda: 10.0,
        });
        let depth: Vec<f64> = (0..100)
            .map(|i| 1e-3 * (i as f64 / 10.0).sin().abs())
            .collect();
        let rate = vec![0.0; 100];
        let contact = vec![true; 100];
        let f = simulate_force(&p, 1e-3, &depth, &rate, &contact).unwrap();
        for (d, f) in depth.iter().zip(&f) {
            assert!((f - 1000.0 * d).abs() < 1e-6);
        }
        assert_eq!(nrmse_percent(&f, &f), Some(0.0));
        assert!((vaf_percent(&f, &f).unwrap() - 100.0).abs() < 1e-9);
        let shifted: Vec<f64> = f.iter().map(|v| v + 0.1).collect();
        let range =
            f.iter().cloned().fold(f64::MIN, f64::max) - f.iter().cloned().fold(f64::MAX, f64::min);
        assert!((nrmse_percent(&f, &shifted).unwrap() - 10.0 / range).abs() < 1e-9);
        assert_eq!(nrmse_percent(&[], &[]), None);
    }
}
