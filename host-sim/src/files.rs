//! Estimation on measured files, as `host-sim estimate` and the demo run it: read,
//! resample to 1 kHz, derive the pipeline settings from the record, run, report.

use std::path::Path;

use anyhow::{Context, Result};
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
    let native_rate = native.sample_rate_hz().unwrap_or_else(|| {
        (native.len() as f64 - 1.0)
            / (native.time_s.last().copied().unwrap_or(1.0) - native.time_s[0]).max(1e-9)
    });
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
