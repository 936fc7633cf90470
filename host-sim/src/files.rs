//! Estimation on measured files, as `host-sim estimate` and the demo run it: read,
//! resample to 1 kHz, derive the pipeline settings from the record, run, report.

use std::path::Path;

use anyhow::{bail, Context, Result};
use estimator_core::ModelKind;
use indicatif::{ProgressBar, ProgressStyle};

use crate::phases::Phase;
use crate::readers;
use crate::record::{Format, Record};
use crate::runner::{self, RunResult};
use crate::setup::{self, Overrides};

fn progress(len: u64) -> ProgressBar {
    let bar = ProgressBar::new(len);
    bar.set_style(
        ProgressStyle::with_template("{spinner} samples [{bar:30}] {pos}/{len} ({elapsed})")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar
}

/// Reads `path`, resampled to 1 kHz.
pub fn load(path: &Path, format: &str) -> Result<(Record, Record)> {
    let format = if format == "auto" {
        None
    } else {
        Some(format.parse::<Format>().map_err(anyhow::Error::msg)?)
    };
    let native = readers::read(path, format)?;
    let uniform = match native.sample_rate_hz() {
        Some(rate) if (rate - 1000.0).abs() < 1e-6 * 1000.0 => native.clone(),
        _ => native
            .try_resample(1000.0)
            .with_context(|| format!("{}: cannot resample to 1 kHz", path.display()))?,
    };
    Ok((native, uniform))
}

/// The file's own sampling rate \[Hz\]: exact when uniform, else the mean over its span.
fn native_rate_hz(native: &Record) -> f64 {
    native.sample_rate_hz().unwrap_or_else(|| {
        (native.len() as f64 - 1.0)
            / (native.time_s.last().copied().unwrap_or(1.0) - native.time_s[0]).max(1e-9)
    })
}

/// Estimation on one file: the record, options used and the result.
pub struct FileRun {
    /// The record at 1 kHz.
    pub record: Record,
    /// How it was read and configured, in words.
    pub notes: Vec<String>,
    /// The run.
    pub result: RunResult,
    /// Phases the estimator was updated in, if restricted.
    pub estimated_during: Option<Vec<String>>,
}

impl FileRun {
    pub fn summary_json(&self, path: &Path) -> Result<serde_json::Value> {
        let mut summary = self.result.summary();
        summary.estimated_during = self.estimated_during.clone();
        let mut value = serde_json::to_value(&summary)?;
        value["file"] = serde_json::Value::String(path.display().to_string());
        value["notes"] = serde_json::to_value(&self.notes)?;
        // The pipeline's own findings, next to the model parameters as well.
        value["parameters"]["contact_position_m"] = summary.contact_position_m.into();
        value["parameters"]["force_offset_n"] = summary.force_offset_n.into();
        Ok(value)
    }
}

pub fn estimate_file(
    model: ModelKind,
    path: &Path,
    format: &str,
    overrides: &Overrides,
    phases: Option<Vec<Phase>>,
) -> Result<FileRun> {
    let (native, record) = load(path, format)?;
    let native_rate = native_rate_hz(&native);
    let (mut options, mut notes) = setup::options_for_record(
        model,
        &record.position_m,
        &record.force_n,
        &native.force_n,
        native_rate,
        overrides,
    );
    notes.splice(0..0, native.notes.iter().cloned());
    if let Some(p) = &phases {
        let names: Vec<&str> = p.iter().map(|p| p.name()).collect();
        notes.push(format!(
            "estimator updated only during: {}",
            names.join(", ")
        ));
    }
    options.estimate_during = phases;
    let bar = progress(record.len() as u64);
    let result = runner::run(
        &options,
        &record.position_m,
        &record.force_n,
        &[],
        &mut |i| bar.set_position(i as u64),
    )
    .with_context(|| format!("{}", path.display()))?;
    bar.finish_and_clear();
    notes.push(format!(
        "phases: loading above {:.3e} m/s (10 % of the 99th-percentile speed)",
        result.phase_speed_threshold_m_per_s
    ));
    let estimated_during = options
        .estimate_during
        .map(|p| p.iter().map(|p| p.name().to_string()).collect());
    Ok(FileRun {
        record,
        notes,
        result,
        estimated_during,
    })
}

/// The shipped real files, and per file the models run and the phase they are fitted on
/// (`None`: the whole contact). These are quasi-static tests (indentation, compression):
/// a power law describes the loading, fitted with the single-stage Hunt-Crossley estimator
/// (the double stage needs dynamic excitation: in a quasi-static test its damping
/// regressor is nearly collinear with the elastic one, and n ends at a bound); the
/// Hammerstein model adds the creep or relaxation of the hold.
pub type FileModels = &'static [(ModelKind, Option<Phase>)];
pub const REAL_FILES: &[(&str, FileModels)] = &[
    (
        "nanoindentation/steel-hysitron.txt",
        &[
            (ModelKind::HuntCrossleySingleStage, Some(Phase::Loading)),
            (ModelKind::Hammerstein1, None),
        ],
    ),
    (
        "silicone-compression/ecoflex-00-10-A1.csv",
        &[
            (ModelKind::HuntCrossleySingleStage, None),
            (ModelKind::KelvinVoigt, None),
        ],
    ),
    (
        "afm/brain-creep-jpk.txt",
        &[
            (ModelKind::HuntCrossleySingleStage, Some(Phase::Loading)),
            (ModelKind::Hammerstein1, None),
        ],
    ),
    (
        "afm/cell-stress-relaxation.tab",
        &[
            (ModelKind::Hammerstein1, None),
            (ModelKind::HuntCrossleySingleStage, Some(Phase::Loading)),
        ],
    ),
];

/// A diagnosed file: the record at 1 kHz, notes on how it was read and prepared, the
/// prepared log and the workflow's result.
pub struct FileDiagnosis {
    /// The record at 1 kHz.
    pub record: Record,
    /// How it was read and prepared, in words.
    pub notes: Vec<String>,
    /// The log as fitted (block means, depth, phases).
    pub prepared: crate::diagnose::data::Prepared,
    /// The result.
    pub diagnosis: crate::diagnose::Diagnosis,
}

/// Runs the discrepancy workflow on `path` (read as `format`, resampled to 1 kHz). The
/// contact detector is configured from the record as for `estimate` (onset threshold
/// from the noise and range, unless overridden).
///
/// # Errors
/// The reader's error (file, line, field), a log without contact or too short, or a
/// baseline that cannot be fitted.
pub fn diagnose_file(
    path: &Path,
    format: &str,
    options: &crate::diagnose::Options,
    overrides: &Overrides,
    until_end_of: Option<Phase>,
) -> Result<FileDiagnosis> {
    let (native, record) = load(path, format)?;
    let native_rate = native_rate_hz(&native);
    let (run_options, mut notes) = setup::options_for_record(
        ModelKind::KelvinVoigt,
        &record.position_m,
        &record.force_n,
        &native.force_n,
        native_rate,
        overrides,
    );
    notes.splice(0..0, native.notes.iter().cloned());
    notes.retain(|n| !n.starts_with("internal units") && !n.starts_with("state-variable"));
    let prepared = crate::diagnose::data::prepare(
        &record.time_s,
        &record.position_m,
        &record.force_n,
        run_options.pipeline.contact,
    )
    .with_context(|| format!("{}", path.display()))?;
    let mut prepared = prepared;
    if let Some(phase) = until_end_of {
        if !prepared.keep_until_end_of(phase) {
            bail!(
                "{}: no {} phase after the first contact long enough to fit (100 samples)",
                path.display(),
                phase.name()
            );
        }
        notes.push(format!(
            "fitted up to the end of the first {} phase, {:.3} s",
            phase.name(),
            prepared.time_s[prepared.len() - 1]
        ));
    }
    notes.push(format!(
        "fitted on {} samples of {:.1} ms (block means of the 1 kHz record)",
        prepared.len(),
        1e3 * prepared.dt
    ));
    let diagnosis = crate::diagnose::diagnose(&prepared, options).with_context(|| {
        format!(
            "{}: the baseline model cannot be fitted (no contact samples)",
            path.display()
        )
    })?;
    Ok(FileDiagnosis {
        record,
        notes,
        prepared,
        diagnosis,
    })
}
