//! Configures the pipeline for a measured record: the core's defaults are for the paper's
//! rig (1 kHz, millimetres, newtons, 20 mN noise), while a nanoindenter works in nm and µN
//! and an AFM in µm and nN. Everything here is derived from the record itself — noise
//! level, force and depth ranges, loading rate — never from a per-file table, and every
//! choice is reported so that the user can see (and override) it.

use estimator_core::{EstimatorSettings, ModelKind, Scaling};

use crate::runner::{recommended_pipeline, RunOptions};

/// User overrides from the command line (`None` = derive from the record).
#[derive(Debug, Clone, Copy, Default)]
pub struct Overrides {
    /// Contact-onset threshold \[N\].
    pub onset_threshold_n: Option<f64>,
    /// State-variable filter bandwidth \[Hz\].
    pub bandwidth_hz: Option<f64>,
    /// Free-space samples (at 1 kHz) for the online tare (`--online-front-end` only).
    pub tare_samples: Option<u32>,
    /// Axis orientation and force offset, if known (see [`crate::frontend::Options`]).
    pub front_end: crate::frontend::Options,
    /// Sign of the file's force column: −1 where it reads compression negative (many load
    /// frames), so that it is negated on reading; +1: compression positive, as read;
    /// `None`: detected, by the rule of [`crate::files::Loaded::with_force_sign_of`].
    pub force_sign: Option<f64>,
    /// RLS memory \[s\] (default: the record's time in contact, at least 2 s).
    pub memory_s: Option<f64>,
    /// Start the estimator from its defaults, as the firmware does, instead of from the
    /// front end's whole-record fit.
    pub cold_start: bool,
    /// Show a per-sample progress bar while estimating (the CLI on one file; batches show
    /// one bar over the files instead).
    pub show_progress: bool,
    /// Keep no per-sample parameters (nothing will write the estimates file or plots):
    /// ≈ 28 B a sample less ([`crate::runner::RunOptions::parameter_trace`]).
    pub no_parameter_trace: bool,
}

/// Largest state-variable filter bandwidth as a fraction of a record's native sample
/// rate. A quarter was tried (less lag on 100 Hz records, whose exponent a tenth biases:
/// the filter acts after the δⁿ nonlinearity on the force but before it on the position)
/// and broke the steel and brain files' fits; a tenth stays until that is understood.
pub const NATIVE_BANDWIDTH_FRACTION: f64 = 0.1;

/// Shortest RLS memory on a record \[s\]: the estimators' own default (β = 0.9995 at 1 kHz).
pub const MIN_MEMORY_S: f64 = 2.0;

/// Robust noise level of `x` \[same unit\]: the median absolute second difference scaled to
/// a standard deviation (σ = MAD(Δ²x)/0.6745/√6). Second differences cancel slow signal
/// (ramps), so this works inside a ramp as well as in free space.
pub fn noise_level(x: &[f64]) -> f64 {
    difference_noise(x, 3, |w| w[2] - 2.0 * w[1] + w[0], 6.0)
}

/// The robust noise level of `x` from a difference of `width` samples, `difference` of
/// each window, whose noise variance is `sum_squares` (the sum of its coefficients'
/// squares) times the samples': MAD/0.6745/√`sum_squares`; 0 with fewer than `width`
/// samples.
pub fn difference_noise(
    x: &[f64],
    width: usize,
    difference: impl Fn(&[f64]) -> f64,
    sum_squares: f64,
) -> f64 {
    if x.len() < width {
        return 0.0;
    }
    let mut d: Vec<f64> = x.windows(width).map(|w| difference(w).abs()).collect();
    let mid = d.len() / 2;
    let median = *d.select_nth_unstable_by(mid, f64::total_cmp).1;
    median / 0.6745 / sum_squares.sqrt()
}

fn range(x: &[f64]) -> f64 {
    let (lo, hi) = x
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    if hi > lo {
        hi - lo
    } else {
        0.0
    }
}

/// Run options for `model` on a record sampled at 1 kHz (`position_m`, `force_n`), with
/// the reasons for each choice. `native_force_noise_n` \[N\] is the noise
/// ([`noise_level`]) of the force at the file's own rate `native_rate_hz` (before
/// resampling), whose sample-to-sample noise is not smoothed by interpolation.
///
/// The pipeline tares and detects contacts online, as the firmware does; a record set up
/// by the whole-record front end then switches to its known surface and offset
/// ([`estimator_core::PipelineConfig::with_known_surface_and_offset`]).
pub fn options_for_record(
    model: ModelKind,
    position_m: &[f64],
    force_n: &[f64],
    native_force_noise_n: f64,
    native_rate_hz: f64,
    overrides: &Overrides,
) -> (RunOptions, Vec<String>) {
    let mut notes = Vec::new();
    let mut options = RunOptions::for_model(model);
    let force_range = range(force_n);
    let depth_range = range(position_m);
    let sigma = native_force_noise_n;

    // Internal units: powers of ten near the record's force and depth ranges.
    let scaling = Scaling::for_magnitudes((0.5 * depth_range) as f32, (0.5 * force_range) as f32);
    notes.push(format!(
        "internal units: {:e} m and {:e} N (force range {force_range:.3e} N, position range {depth_range:.3e} m)",
        scaling.length_m, scaling.force_n
    ));

    // Contact onset: well above the noise, and above 0.5 % of the force range so that drift
    // before contact is not taken for an impact.
    let onset = overrides.onset_threshold_n.unwrap_or_else(|| {
        (8.0 * sigma)
            .max(0.005 * force_range)
            .max(f64::MIN_POSITIVE)
    });
    options.pipeline.impact.onset_threshold_n = onset as f32;
    options.pipeline.impact.noise_multiplier = 8.0;
    notes.push(format!(
        "contact onset threshold {onset:.3e} N (noise σ = {sigma:.3e} N from second differences; {})",
        if overrides.onset_threshold_n.is_some() { "given" } else { "max(8σ, 0.5 % of the force range)" }
    ));
    if let Some(tare) = overrides.tare_samples {
        options.pipeline.tare.startup_samples = tare.max(1);
        notes.push(format!("tare over the first {tare} samples (given)"));
    }
    // The filter cannot see beyond the file's own Nyquist rate: resampling to 1 kHz adds
    // no information, so the bandwidth follows the native rate (a tenth of it).
    let default_bw = f64::from(options.pipeline.velocity_filter.bandwidth_hz);
    let bandwidth = overrides
        .bandwidth_hz
        .unwrap_or_else(|| default_bw.min(NATIVE_BANDWIDTH_FRACTION * native_rate_hz));
    options.pipeline.velocity_filter.bandwidth_hz = bandwidth as f32;
    notes.push(format!(
        "state-variable filter bandwidth {bandwidth:.3} Hz ({})",
        if overrides.bandwidth_hz.is_some() {
            "given".to_string()
        } else {
            format!("min({default_bw} Hz, a tenth of the native {native_rate_hz:.1} Hz)")
        }
    ));
    // Loading speed v*: 5 % of the 99.9th-percentile speed. Drift of the force offset is
    // only learned while the probe is slower than v*/2: a slow compression of a soft
    // sample is not drift.
    let travel = crate::phases::SpanTravel::of(position_m);
    let v_star = travel.loading_speed(1.0e-3);
    options.span_travel = Some(travel);
    // A slow test may take seconds to load from half to twice the onset threshold.
    options.pipeline.refinement.timeout_samples = (position_m.len() / 10).max(500) as u32;
    options.pipeline.tare.tracking_max_speed_m_per_s = (0.5 * v_star) as f32;

    // Logarithm guards relative to the record: 2 % of the force range, 1 % of the depth.
    let min_force = (0.02 * force_range).max(3.0 * sigma);
    let min_depth = 0.01 * depth_range;
    // Hammerstein δ̇*: the loading-speed threshold v* (the paper: 10 mm/s for a 30 mm/s
    // ramp). Per-sample differences would be dominated by position noise.
    // RLS memory: a file is estimated as a whole, so the estimators remember all of its
    // time in contact (β = 1 − T/memory); the firmware keeps its 2 s memory to track
    // changes. The start-up forgetting still lets the coupled stages iterate early on.
    let in_contact_s = 1.0e-3 * position_m.iter().filter(|d| **d > 0.0).count() as f64;
    let memory_s = overrides.memory_s.unwrap_or(in_contact_s).max(MIN_MEMORY_S);
    notes.push(format!(
        "estimator memory {memory_s:.3} s ({}; β = {:.7})",
        if overrides.memory_s.is_some() {
            "given".to_string()
        } else {
            format!("the record's time in contact, at least {MIN_MEMORY_S} s")
        },
        1.0 - 1.0e-3 / memory_s
    ));
    options.settings = EstimatorSettings {
        scaling,
        forgetting: Some(estimator_core::rls::Forgetting::Fixed {
            beta: (1.0 - 1.0e-3 / memory_s) as f32,
        }),
        min_depth_m: Some(min_depth as f32),
        min_force_n: Some(min_force as f32),
        min_depth_rate_m_per_s: Some(v_star as f32),
        hold_damping: false,
        initial: None,
        // Additive force noise of variance σ² is log noise of variance σ²/F²: weighting the
        // log residual by F² is maximum likelihood; uniform weights let the noisiest
        // samples near the force guard pull the exponent.
        log_weighting: Some(estimator_core::hunt_crossley::LogWeighting::ForceSquared),
    };
    notes.push(format!(
        "logarithm guards: F > {min_force:.3e} N, δ > {min_depth:.3e} m{}",
        if matches!(model, ModelKind::Hammerstein1 | ModelKind::Hammerstein2) {
            format!("; elastic stage while dδ/dt > {v_star:.3e} m/s (the loading-speed threshold)")
        } else {
            String::new()
        }
    ));
    if options.pipeline == recommended_pipeline(model) {
        notes.push("pipeline otherwise at the model's defaults".into());
    }
    (options, notes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_level_recovers_sigma_under_a_ramp() {
        // Deterministic pseudo-noise with σ ≈ 0.1 on a steep ramp.
        let mut state = 1u64;
        let x: Vec<f64> = (0..20_000)
            .map(|i| {
                let mut s = 0.0;
                for _ in 0..12 {
                    state = state
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    s += (state >> 11) as f64 / (1u64 << 53) as f64;
                }
                i as f64 * 5.0 + 0.1 * (s - 6.0)
            })
            .collect();
        let sigma = noise_level(&x);
        assert!((sigma - 0.1).abs() < 0.01, "{sigma}");
    }
}
