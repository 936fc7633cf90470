//! Runs the core's per-sample pipeline — the exact call the firmware makes every
//! millisecond — over a uniformly sampled record, and collects what a user needs to judge
//! the result: the per-sample trace, the final parameters with their standard errors, the
//! contact point and force offset the pipeline found, and the fit quality of the final
//! model simulated on the measured motion.

use std::collections::BTreeMap;

use estimator_core::{
    AnyEstimator, AnyParameters, ConfigError, ContactSample, Estimator, EstimatorSettings,
    ModelKind, Pipeline, PipelineConfig, RawSample, Status,
};
use serde::Serialize;

use crate::phases::{self, Phase, PhaseClassifier};
use crate::simulate::{nrmse_percent_of, simulate_force, vaf_percent_of};

/// What to run.
#[derive(Debug, Clone, PartialEq)]
pub struct RunOptions {
    /// Model / estimator.
    pub model: ModelKind,
    /// Pipeline (sample time, state-variable filter, contact detection, monitor).
    pub pipeline: PipelineConfig,
    /// Estimator settings (units, forgetting, guards).
    pub settings: EstimatorSettings,
    /// Update the estimator only during these phases (e.g. loading only, for a test whose
    /// hold and unloading follow other laws); `None` = whenever in contact.
    pub estimate_during: Option<Vec<Phase>>,
    /// Keep the parameters after every sample in [`Trace::parameters`] (for the
    /// per-sample estimates file and plots; ≈ 28 B a sample). Without it the trace's
    /// parameters are empty and only the phases' final parameters are kept.
    pub parameter_trace: bool,
    /// The position's span travel, when the caller has it ([`phases::SpanTravel`]: the
    /// phases' speed threshold from it is the one [`run`] computes); `None`: computed.
    pub span_travel: Option<phases::SpanTravel>,
}

impl RunOptions {
    /// Defaults for the paper's rig (1 kHz, mm and N) and `model`, with the pipeline
    /// settings the core's tests chose for it (see [`recommended_pipeline`]).
    pub fn for_model(model: ModelKind) -> Self {
        RunOptions {
            model,
            pipeline: recommended_pipeline(model),
            settings: EstimatorSettings::default(),
            estimate_during: None,
            parameter_trace: true,
            span_travel: None,
        }
    }
}

/// The pipeline configuration used for each model: all signals through the
/// state-variable filter at 100 Hz, except Hammerstein at 240 Hz (its elastic stage fits a
/// power law on the loading ramp, which the filter would otherwise distort at small
/// depth; see the core's convergence tests).
pub fn recommended_pipeline(model: ModelKind) -> PipelineConfig {
    let mut p = PipelineConfig::default();
    if matches!(model, ModelKind::Hammerstein1 | ModelKind::Hammerstein2) {
        p.velocity_filter.bandwidth_hz = 240.0;
    }
    p
}

/// Per-sample trace of a run.
#[derive(Debug, Clone, Default)]
pub struct Trace {
    /// In contact after the sample.
    pub contact: Vec<bool>,
    /// δ \[m\] as handed to the estimator (0 out of contact).
    pub depth_m: Vec<f64>,
    /// δ̇ \[m/s\].
    pub rate_m_per_s: Vec<f64>,
    /// Force after tare and conditioning \[N\].
    pub force_n: Vec<f64>,
    /// A-priori model force \[N\] (the estimator's prediction before its update).
    pub predicted_force_n: Vec<f64>,
    /// Parameters after the sample.
    pub parameters: Vec<AnyParameters>,
    /// Status bits.
    pub status: Vec<u32>,
    /// Phase of each sample (detected online from the contact state and δ̇).
    pub phase: Vec<Phase>,
}

/// Phases whose final parameters a run reports.
fn phase_with_parameters(p: Phase) -> bool {
    matches!(p, Phase::Loading | Phase::Hold | Phase::Unloading)
}

/// Result of a run.
#[derive(Debug, Clone)]
pub struct RunResult {
    /// Model run.
    pub model: ModelKind,
    /// Per-sample trace.
    pub trace: Trace,
    /// Parameters at the end.
    pub parameters: AnyParameters,
    /// Their standard errors (σ̂·√P_ii, delta method for derived parameters).
    pub standard_errors: AnyParameters,
    /// Contact position x_contact the pipeline found \[m\] (last contact).
    pub contact_position_m: f64,
    /// Force offset the tare found \[N\].
    pub force_offset_n: f64,
    /// Free-space force noise σ \[N\].
    pub force_noise_n: f64,
    /// Index of the first in-contact sample.
    pub first_contact: Option<usize>,
    /// Number of in-contact samples.
    pub contact_samples: usize,
    /// Samples that updated the estimator (in contact, not skipped: not saturated,
    /// dropped, paused, pending a contact point, nor below the depth guard).
    pub updates: usize,
    /// NRMSE \[%\] of the final model simulated on the in-contact motion against the
    /// conditioned measured force (range-normalised).
    pub nrmse_percent: Option<f64>,
    /// Variance accounted for \[%\], same samples.
    pub vaf_percent: Option<f64>,
    /// How many samples raised each status flag.
    pub status_counts: BTreeMap<String, usize>,
    /// Parameters at the end of the last segment of each in-contact phase.
    pub phase_parameters: BTreeMap<Phase, AnyParameters>,
    /// The loading/unloading speed threshold v* used for the phases \[m/s\].
    pub phase_speed_threshold_m_per_s: f64,
}

/// Why a run could not produce an estimate.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The configuration was rejected by the core.
    #[error("invalid configuration: {0}")]
    Config(#[from] ConfigError),
    /// `position` and `force` differ in length.
    #[error("position has {position} samples but force has {force}")]
    Length {
        /// Position samples.
        position: usize,
        /// Force samples.
        force: usize,
    },
    /// The pipeline never detected a contact.
    #[error(
        "no contact found: the force never rose above the onset threshold ({threshold_n:.3e} N \
         over an offset of {offset_n:.3e} N); the record may not touch the material, or its \
         force sign is inverted"
    )]
    NoContact {
        /// Onset threshold at the end of the run \[N\].
        threshold_n: f64,
        /// Force offset found \[N\].
        offset_n: f64,
    },
}

/// Flags of a sample whose estimator update did not happen.
const NOT_UPDATED: Status = Status::NO_CONTACT
    .union(Status::SATURATED)
    .union(Status::SAMPLE_DROPPED)
    .union(Status::ESTIMATION_PAUSED)
    .union(Status::CONTACT_PENDING)
    .union(Status::GUARD_DEPTH)
    .union(Status::NON_FINITE_INPUT);

/// Runs the pipeline over `position_m` \[m\] and `force_n` \[N\] sampled at
/// `options.pipeline.sample_time_s`. `saturated` marks samples at a sensor limit (may be
/// empty). `progress` is called with the number of samples done, every 10 000 samples.
///
/// # Errors
/// [`RunError`] on an invalid configuration, mismatched lengths or a record without
/// contact.
pub fn run(
    options: &RunOptions,
    position_m: &[f64],
    force_n: &[f64],
    saturated: &[bool],
    progress: &mut dyn FnMut(usize),
) -> Result<RunResult, RunError> {
    if position_m.len() != force_n.len() {
        return Err(RunError::Length {
            position: position_m.len(),
            force: force_n.len(),
        });
    }
    let estimator = AnyEstimator::try_new(options.model, &options.settings)?;
    let mut pipeline = Pipeline::try_new(options.pipeline, estimator)?;
    let n = position_m.len();
    let mut trace = Trace {
        contact: Vec::with_capacity(n),
        depth_m: Vec::with_capacity(n),
        rate_m_per_s: Vec::with_capacity(n),
        force_n: Vec::with_capacity(n),
        predicted_force_n: Vec::with_capacity(n),
        parameters: Vec::with_capacity(if options.parameter_trace { n } else { 0 }),
        status: Vec::with_capacity(n),
        phase: Vec::with_capacity(n),
    };
    let dt = f64::from(options.pipeline.sample_time_s);
    let phase_threshold = options
        .span_travel
        .unwrap_or_else(|| phases::SpanTravel::of(position_m))
        .loading_speed(dt);
    let mut classifier = PhaseClassifier::new(phase_threshold);
    let mut phase = Phase::FreeSpace;
    // Samples per distinct status value, named after the loop (not a name String per
    // flag and sample).
    let mut by_status: BTreeMap<u32, usize> = BTreeMap::new();
    let mut run = (0u32, 0usize);
    let mut first_contact = None;
    let mut phase_parameters = BTreeMap::new();
    let mut last_parameters: Option<AnyParameters> = None;
    for i in 0..n {
        if let Some(allowed) = &options.estimate_during {
            // The phase of the previous sample gates this one (the loop is causal).
            pipeline.set_estimation_enabled(allowed.contains(&phase));
        }
        let out = pipeline.step(&RawSample {
            position_m: position_m[i] as f32,
            force_n: force_n[i] as f32,
            saturated: saturated.get(i).copied().unwrap_or(false),
        });
        let in_contact = out.contact == estimator_core::conditioning::ContactState::InContact;
        if in_contact && first_contact.is_none() {
            first_contact = Some(i);
        }
        let ContactSample {
            depth_m,
            depth_rate_m_per_s,
            force_n,
        } = out.sample;
        trace.contact.push(in_contact);
        trace.depth_m.push(f64::from(depth_m));
        trace.rate_m_per_s.push(f64::from(depth_rate_m_per_s));
        trace.force_n.push(f64::from(force_n));
        trace
            .predicted_force_n
            .push(f64::from(out.estimate.predicted_force_n));
        if options.parameter_trace {
            trace.parameters.push(out.estimate.parameters);
        }
        trace.status.push(out.status.bits());
        let previous = phase;
        phase = classifier.classify(in_contact, f64::from(depth_rate_m_per_s));
        trace.phase.push(phase);
        // The parameters at the end of each loading, hold and unloading segment (the
        // last segment of each phase is kept).
        if phase != previous {
            if let Some(p) = last_parameters.filter(|_| phase_with_parameters(previous)) {
                phase_parameters.insert(previous, p);
            }
        }
        last_parameters = Some(out.estimate.parameters);
        // (Runs of one status counted at their end, not a map entry per sample: the 600 s
        // log's whole estimate A/B 0.96.)
        let bits = out.status.bits();
        if bits != run.0 {
            if run.1 > 0 {
                *by_status.entry(run.0).or_default() += run.1;
            }
            run = (bits, 0);
        }
        run.1 += 1;
        if (i + 1) % 10_000 == 0 {
            progress(i + 1);
        }
    }
    progress(n);
    if run.1 > 0 {
        *by_status.entry(run.0).or_default() += run.1;
    }
    let mut counts: BTreeMap<String, usize> = BTreeMap::new();
    for (bits, samples) in by_status {
        for (name, _) in Status::from_bits_retain(bits).iter_names() {
            *counts.entry(name.to_string()).or_default() += samples;
        }
    }
    let Some(first) = first_contact else {
        return Err(RunError::NoContact {
            threshold_n: f64::from(pipeline.onset_threshold_n()),
            offset_n: f64::from(pipeline.force_offset_n()),
        });
    };
    let parameters = pipeline.estimator().parameters();
    // Judge the fit where the model was fitted: in contact and, if restricted, in the
    // phases the estimator saw.
    let judged: Vec<bool> = (0..n)
        .map(|i| {
            trace.contact[i]
                && options
                    .estimate_during
                    .as_ref()
                    .is_none_or(|allowed| allowed.contains(&trace.phase[i]))
        })
        .collect();
    let (nrmse, vaf) = fit_quality_on(&parameters, options.pipeline.sample_time_s, &trace, &judged);
    if let Some(p) = last_parameters.filter(|_| phase_with_parameters(phase)) {
        phase_parameters.insert(phase, p);
    }
    Ok(RunResult {
        model: options.model,
        parameters,
        standard_errors: pipeline.estimator().standard_errors(),
        contact_position_m: f64::from(pipeline.contact_position_m()),
        force_offset_n: f64::from(pipeline.force_offset_n()),
        force_noise_n: f64::from(pipeline.force_noise_n()),
        first_contact: Some(first),
        contact_samples: trace.contact.iter().filter(|c| **c).count(),
        updates: trace
            .status
            .iter()
            .filter(|&&bits| !Status::from_bits_truncate(bits).intersects(NOT_UPDATED))
            .count(),
        nrmse_percent: nrmse,
        vaf_percent: vaf,
        status_counts: counts,
        phase_parameters,
        phase_speed_threshold_m_per_s: phase_threshold,
        trace,
    })
}

/// NRMSE and VAF of `parameters` simulated over the in-contact samples of `trace`.
pub fn fit_quality(
    parameters: &AnyParameters,
    sample_time_s: f32,
    trace: &Trace,
) -> (Option<f64>, Option<f64>) {
    fit_quality_from(parameters, sample_time_s, trace, 0)
}

/// As [`fit_quality`], over the in-contact samples from index `from` on (the model is
/// simulated from the start so that its state is right at `from`).
pub fn fit_quality_from(
    parameters: &AnyParameters,
    sample_time_s: f32,
    trace: &Trace,
    from: usize,
) -> (Option<f64>, Option<f64>) {
    let judged: Vec<bool> = (0..trace.contact.len())
        .map(|i| i >= from && trace.contact[i])
        .collect();
    fit_quality_on(parameters, sample_time_s, trace, &judged)
}

/// NRMSE and VAF over the samples marked in `judged` (the model runs on every sample).
pub fn fit_quality_on(
    parameters: &AnyParameters,
    sample_time_s: f32,
    trace: &Trace,
    judged: &[bool],
) -> (Option<f64>, Option<f64>) {
    let Some(model) = simulate_force(
        parameters,
        sample_time_s,
        &trace.depth_m,
        &trace.rate_m_per_s,
        &trace.contact,
    ) else {
        return (None, None);
    };
    // The judged samples read where they lie (a long record's trace is tens of MB: no
    // copy of them).
    let pairs = judged
        .iter()
        .zip(trace.force_n.iter().zip(&model))
        .filter(|(j, _)| **j)
        .map(|(_, (m, s))| (*m, *s));
    (nrmse_percent_of(pairs.clone()), vaf_percent_of(pairs))
}

/// The model simulated with `parameters` on the trace's motion (0 out of contact).
pub fn simulated_force(parameters: &AnyParameters, sample_time_s: f32, trace: &Trace) -> Vec<f64> {
    simulate_force(
        parameters,
        sample_time_s,
        &trace.depth_m,
        &trace.rate_m_per_s,
        &trace.contact,
    )
    .unwrap_or_else(|| vec![f64::NAN; trace.depth_m.len()])
}

/// Parameters as (name, value) pairs, named as the paper names them.
pub fn named(parameters: &AnyParameters) -> Vec<(&'static str, f64)> {
    parameters.iter().map(|(n, v)| (n, f64::from(v))).collect()
}

/// JSON-friendly summary of a run (what `--json` prints, plus diagnostics).
#[derive(Debug, Clone, Serialize)]
pub struct RunSummary {
    /// CLI name of the model.
    pub model: String,
    /// name → SI value.
    pub parameters: BTreeMap<String, f64>,
    /// name → standard error (SI).
    pub standard_errors: BTreeMap<String, f64>,
    /// NRMSE \[%\] of the simulated force.
    pub nrmse_percent: Option<f64>,
    /// VAF \[%\].
    pub vaf_percent: Option<f64>,
    /// Contact position found \[m\].
    pub contact_position_m: f64,
    /// Force offset found \[N\].
    pub force_offset_n: f64,
    /// Free-space force noise \[N\].
    pub force_noise_n: f64,
    /// In-contact samples.
    pub contact_samples: usize,
    /// Samples per status flag.
    pub status_counts: BTreeMap<String, usize>,
    /// Parameters at the end of the last loading / hold / unloading segment.
    pub phases: BTreeMap<String, BTreeMap<String, f64>>,
    /// Phases during which the estimator was updated (all in contact when absent).
    pub estimated_during: Option<Vec<String>>,
}

impl RunResult {
    /// The summary of this run.
    pub fn summary(&self) -> RunSummary {
        RunSummary {
            model: self.model.name().to_string(),
            parameters: named(&self.parameters)
                .into_iter()
                .map(|(k, v)| (k.to_string(), v))
                .collect(),
            standard_errors: named(&self.standard_errors)
                .into_iter()
                .map(|(k, v)| (k.to_string(), v))
                .collect(),
            nrmse_percent: self.nrmse_percent,
            vaf_percent: self.vaf_percent,
            contact_position_m: self.contact_position_m,
            force_offset_n: self.force_offset_n,
            force_noise_n: self.force_noise_n,
            contact_samples: self.contact_samples,
            status_counts: self.status_counts.clone(),
            phases: self
                .phase_parameters
                .iter()
                .map(|(p, params)| {
                    (
                        p.name().to_string(),
                        named(params)
                            .into_iter()
                            .map(|(k, v)| (k.to_string(), v))
                            .collect(),
                    )
                })
                .collect(),
            estimated_during: None,
        }
    }

    /// Final value of the status-flag set as names.
    pub fn flag_names(status: u32) -> Vec<&'static str> {
        Status::from_bits_truncate(status)
            .iter_names()
            .map(|(n, _)| n)
            .collect()
    }
}
