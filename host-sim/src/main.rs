//! `host-sim`: the estimator core on the host — the paper's experiments on a simulated
//! plant, the same per-sample pipeline over measured files, plots and summaries.
//!
//! Human-readable summaries go to stderr; data (`--json`) to stdout; files to `--out`.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::builder::{PossibleValuesParser, TypedValueParser};
use clap::{Parser, Subcommand};
use estimator_core::ModelKind;
use host_sim::batch;
use host_sim::diagnose::spec::ModelSpec;
use host_sim::diagnose::{report as diagnosis_report, Options as DiagnoseOptions, BASELINES};
use host_sim::files::{diagnose_file, estimate_file, FileRun, REAL_FILES};
use host_sim::phases::Phase;
use host_sim::report::{self, ScenarioOutcome};
use host_sim::runner;
use host_sim::scenarios;
use host_sim::setup::Overrides;
use indicatif::{ProgressBar, ProgressStyle};

/// Online contact-environment estimation (Biagiotti & Melchiorri) on the host.
///
/// Without a subcommand, runs the demo: every paper scenario on the simulated plant and
/// `estimate` on the shipped real files, writing tables and plots to ./out.
#[derive(Parser, Debug)]
#[command(name = "host-sim", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Run a paper scenario on the simulated plant (log, estimates, summary, plots), or,
    /// with --model-spec and --motion, a diagnosed model over a measured motion.
    Simulate {
        /// Scenario name, or `all`.
        #[arg(long, default_value = "all", conflicts_with = "model_spec")]
        scenario: String,
        /// Output folder (default: out/scenarios; with --model-spec, out/simulate).
        #[arg(long)]
        out: Option<PathBuf>,
        /// A model specification (`model.json`, written by `diagnose`) to run over the
        /// motion of --motion; writes simulation.csv and prints the NRMSE.
        #[arg(long, requires = "motion")]
        model_spec: Option<PathBuf>,
        /// The measured record whose motion drives the model (any format `estimate` reads).
        #[arg(long, requires = "model_spec")]
        motion: Option<PathBuf>,
        /// File format of --motion (auto-detected by default).
        #[arg(long, default_value = "auto")]
        format: String,
    },
    /// Run the per-sample pipeline over measured files and report the parameters.
    Estimate {
        /// Model to estimate.
        #[arg(long, value_parser = model_kind(&ModelKind::ALL), required_unless_present = "model_spec")]
        model: Option<ModelKind>,
        /// Estimate the online structure of a diagnosed model (`model.json`, written by
        /// `diagnose`): power law and depth-dependent damping → hunt-crossley, with
        /// relaxation → hammerstein, relaxation alone → zener; an error names the effects
        /// no online estimator in the core models.
        #[arg(long, conflicts_with = "model")]
        model_spec: Option<PathBuf>,
        /// Input files or folders (every file below a folder). Several files run in
        /// parallel with one progress bar and write summary.csv and summary.json.
        #[arg(required = true)]
        files: Vec<PathBuf>,
        /// File format (auto-detected by default).
        #[arg(long, default_value = "auto")]
        format: String,
        /// Print one JSON object per file to stdout.
        #[arg(long)]
        json: bool,
        /// Output folder for estimates, summary and plots.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Folder for the batch summary (summary.csv, summary.json) when several files
        /// are given (default: --out, else ./out).
        #[arg(long)]
        summary: Option<PathBuf>,
        /// Contact-onset threshold (N) (default: from the record's noise and range).
        #[arg(long)]
        onset_threshold_n: Option<f64>,
        /// State-variable filter bandwidth (Hz).
        #[arg(long)]
        bandwidth_hz: Option<f64>,
        /// Free-space samples (at 1 kHz) averaged for the force offset.
        #[arg(long)]
        tare_samples: Option<u32>,
        /// Update the estimator only during these phases (repeatable; detected from the
        /// motion). Default: whenever in contact.
        #[arg(long, value_enum)]
        phase: Vec<Phase>,
        /// Orientation of the position axis: 1 if the position increases into the
        /// material, -1 if it decreases (default: detected from the record).
        #[arg(long, allow_hyphen_values = true, value_parser = parse_sign)]
        position_sign: Option<i8>,
        #[command(flatten)]
        force_sign: ForceSign,
        /// The force offset (N) to remove, if known (default: estimated from the samples
        /// out of contact; 0 when the record never leaves contact).
        #[arg(long, allow_hyphen_values = true)]
        force_offset_n: Option<f64>,
        /// Memory of the estimators' recursive least squares (s): the forgetting factor is
        /// 1 − T/memory (default: the record's time in contact, at least 2 s; the firmware
        /// uses 2 s to track changes).
        #[arg(long)]
        memory_s: Option<f64>,
        /// Start the estimator from its defaults, as the firmware does (default: from the
        /// whole-record fit of the front end).
        #[arg(long)]
        cold_start: bool,
    },
    /// Discrepancy workflow: fit a baseline model to a measured log, localise where the
    /// simulation and the measurement disagree, add the missing physical effects one at
    /// a time while significant, and report the steps (Markdown, plots, JSON).
    Diagnose {
        /// Input files or folders: the `time_s,position_m,force_n` CSV or any format
        /// `estimate` reads. Several files run in parallel, each into its own subfolder of
        /// --out, with summary.csv and summary.json in --out.
        #[arg(required = true)]
        files: Vec<PathBuf>,
        /// File format (auto-detected by default).
        #[arg(long, default_value = "auto")]
        format: String,
        /// Model the workflow starts from: Kelvin-Voigt, or a core model read as effects on
        /// it (hunt-crossley: power law and depth-dependent damping; zener: relaxation;
        /// hammerstein: power law and relaxation).
        #[arg(long, value_parser = model_kind(&BASELINES), default_value = "kelvin-voigt")]
        baseline: ModelKind,
        /// Output folder for report.md, diagnosis.json and the plots.
        #[arg(long, default_value = "out/diagnose")]
        out: PathBuf,
        /// Print the result as one JSON object to stdout.
        #[arg(long)]
        json: bool,
        /// Most effects to add.
        #[arg(long, default_value_t = 4)]
        max_steps: usize,
        /// Contact-onset threshold (N) (default: from the record's noise and range).
        #[arg(long)]
        onset_threshold_n: Option<f64>,
        #[command(flatten)]
        force_sign: ForceSign,
        /// Fit only up to the end of the first segment of this phase (detected from the
        /// motion): `loading` diagnoses the first loading curve alone.
        #[arg(long, value_enum)]
        until: Option<Phase>,
    },
    /// Decode a captured telemetry stream (the firmware's UART, or QEMU's serial file)
    /// into one JSON object per message (telemetry, boot report, reply) on stdout.
    Telemetry {
        /// Captured bytes.
        file: PathBuf,
    },
    /// Live telemetry from the firmware's UART (CSV or JSON lines, drops counted), and
    /// operator commands (--send 'model kelvin-voigt', 'tare', …).
    Serial(host_sim::serial::SerialArgs),
    /// The main job: all scenarios and the shipped real files, with a summary.
    Demo {
        /// Output folder.
        #[arg(long, default_value = "out")]
        out: PathBuf,
        /// Folder with the shipped real files.
        #[arg(long, default_value = "../shared/data")]
        data: PathBuf,
    },
}

/// `--model` / `--baseline` values: the names ([`ModelKind::name`]) of `kinds`, parsed
/// into the core's one model enum.
fn model_kind(kinds: &'static [ModelKind]) -> impl TypedValueParser<Value = ModelKind> {
    PossibleValuesParser::new(kinds.iter().map(|k| k.name()))
        .map(|name| ModelKind::from_name(&name).expect("clap accepts only the names of `kinds`"))
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        None => demo(Path::new("out"), Path::new("../shared/data")),
        Some(Command::Demo { out, data }) => demo(&out, &data),
        Some(Command::Simulate {
            scenario,
            out,
            model_spec,
            motion,
            format,
        }) => match (model_spec, motion) {
            (Some(spec), Some(motion)) => simulate_model_spec(
                &spec,
                &motion,
                &format,
                &out.unwrap_or_else(|| PathBuf::from("out/simulate")),
            ),
            _ => simulate(
                &scenario,
                &out.unwrap_or_else(|| PathBuf::from("out/scenarios")),
            )
            .map(|_| ()),
        },
        Some(Command::Telemetry { file }) => decode_telemetry(&file),
        Some(Command::Serial(args)) => host_sim::serial::cli(&args),
        Some(Command::Diagnose {
            files,
            format,
            baseline,
            out,
            json,
            max_steps,
            onset_threshold_n,
            force_sign,
            until,
        }) => {
            let options = DiagnoseOptions {
                baseline,
                max_steps,
                ..DiagnoseOptions::default()
            };
            let overrides = Overrides {
                onset_threshold_n,
                force_sign: force_sign.force_sign.map(f64::from),
                ..Overrides::default()
            };
            diagnose_files(&files, &format, &options, &overrides, until, &out, json)
        }
        Some(Command::Estimate {
            model,
            model_spec,
            files,
            format,
            json,
            out,
            summary,
            onset_threshold_n,
            bandwidth_hz,
            tare_samples,
            phase,
            position_sign,
            force_sign,
            force_offset_n,
            memory_s,
            cold_start,
        }) => {
            let overrides = Overrides {
                onset_threshold_n,
                bandwidth_hz,
                tare_samples,
                front_end: host_sim::frontend::Options {
                    position_sign: position_sign.map(f64::from),
                    force_offset_n,
                },
                force_sign: force_sign.force_sign.map(f64::from),
                memory_s,
                cold_start,
                show_progress: true,
                // Only the per-file outputs under --out read the per-sample parameters.
                no_parameter_trace: out.is_none(),
            };
            let phases = (!phase.is_empty()).then_some(phase);
            let kind = match (model, model_spec) {
                (Some(model), _) => Ok(model),
                (None, Some(spec)) => estimator_of_spec(&spec),
                (None, None) => Err(anyhow::anyhow!("--model or --model-spec is required")),
            };
            kind.and_then(|kind| {
                estimate_files(
                    kind,
                    &files,
                    &format,
                    json,
                    out.as_deref(),
                    summary.as_deref(),
                    &overrides,
                    phases,
                )
            })
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// The online estimator of a `model.json` (`estimate --model-spec`), said on stderr.
fn estimator_of_spec(path: &Path) -> anyhow::Result<ModelKind> {
    let spec = ModelSpec::read(path)?;
    let kind = spec
        .online_estimator()
        .with_context(|| format!("{}: {}", path.display(), describe_effects(&spec)))?;
    eprintln!(
        "{}: {} → the online estimator {}",
        path.display(),
        describe_effects(&spec),
        kind.name()
    );
    Ok(kind)
}

/// "kelvin-voigt + a + b" for a spec.
fn describe_effects(spec: &ModelSpec) -> String {
    std::iter::once("kelvin-voigt")
        .chain(spec.effects.iter().map(|e| e.id()))
        .collect::<Vec<_>>()
        .join(" + ")
}

/// `simulate --model-spec SPEC --motion FILE`: the model's force over the measured
/// motion, written to `out/simulation.csv` (time, penetration, measured and model force)
/// with the NRMSE printed beside the one the diagnosis reported.
fn simulate_model_spec(spec: &Path, motion: &Path, format: &str, out: &Path) -> anyhow::Result<()> {
    let model = ModelSpec::read(spec)?;
    let run = host_sim::files::simulate_spec(&model, motion, format)?;
    let data = &run.prepare.prepared;
    let start = data.fit_start();
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let path = out.join("simulation.csv");
    let mut w =
        csv::Writer::from_path(&path).with_context(|| format!("writing {}", path.display()))?;
    w.write_record(["time_s", "depth_m", "measured_force_n", "model_force_n"])?;
    for (i, f) in run.force_n.iter().enumerate() {
        let k = start + i;
        w.write_record([
            format!("{:.6}", data.time_s[k]),
            format!("{:.9e}", data.depth_m[k]),
            format!("{:.9e}", data.force_n[k]),
            format!("{f:.9e}"),
        ])?;
    }
    w.flush()
        .with_context(|| format!("writing {}", path.display()))?;
    println!(
        "{} over the motion of {}: NRMSE {:.3} % (the diagnosis reported {:.3} % on {})",
        describe_effects(&model),
        motion.display(),
        run.nrmse_percent,
        model.nrmse_percent,
        model.source
    );
    println!("simulation: {}", path.display());
    Ok(())
}

/// `--force-sign`, shared by `estimate` and `diagnose`.
#[derive(clap::Args, Debug)]
struct ForceSign {
    /// Sign of the force column: -1 if the file reads compression negative (the force
    /// is then negated on reading), 1 if positive (default: detected, where the force as
    /// read misfits every contact law and its negation fits the whole record; the notes
    /// say so).
    #[arg(long, allow_hyphen_values = true, value_parser = parse_sign)]
    force_sign: Option<i8>,
}

/// `--position-sign`, `--force-sign`: 1 or -1 (also +1).
fn parse_sign(s: &str) -> Result<i8, String> {
    match s.trim() {
        "1" | "+1" => Ok(1),
        "-1" => Ok(-1),
        other => Err(format!("expected 1 or -1, got `{other}`")),
    }
}

/// `diagnose` on one file or, for several files or a folder, on each in parallel (see
/// [`batch`]).
fn diagnose_files(
    inputs: &[PathBuf],
    format: &str,
    options: &DiagnoseOptions,
    overrides: &Overrides,
    until: Option<Phase>,
    out: &Path,
    json: bool,
) -> Result<()> {
    let files = batch::expand_inputs(inputs)?;
    if !is_batch(inputs, &files) {
        let done = diagnose_one(&files[0], format, options, overrides, until, out)?;
        eprint!("{}", done.text);
        if json {
            println!("{}", serde_json::to_string(&done.json)?);
        }
        return Ok(());
    }
    let stems = batch::unique_stems(&files);
    let results = batch::run(&files, "diagnose", |i, path| {
        diagnose_one(
            path,
            format,
            options,
            overrides,
            until,
            &out.join(&stems[i]),
        )
    });
    let rows = report_batch(&files, results, json, |path, done, seconds| {
        batch::Row::from_diagnosis(path, &done.json, seconds)
    })?;
    finish_batch(out, &rows)
}

/// More than one file, or a folder: the batch path.
fn is_batch(inputs: &[PathBuf], files: &[PathBuf]) -> bool {
    files.len() != 1 || inputs.iter().any(|p| p.is_dir())
}

/// Prints a batch's results in input order (one line each on stderr, the `--json`
/// objects on stdout) and returns the summary rows.
fn report_batch(
    files: &[PathBuf],
    results: Vec<(Result<batch::Done>, f64)>,
    json: bool,
    row: impl Fn(&Path, &batch::Done, f64) -> batch::Row,
) -> Result<Vec<batch::Row>> {
    let mut rows = Vec::with_capacity(files.len());
    for (path, (result, seconds)) in files.iter().zip(results) {
        match result {
            Ok(done) => {
                let r = row(path, &done, seconds);
                eprintln!(
                    "{} — {}: NRMSE {}{}",
                    path.display(),
                    r.model.as_deref().unwrap_or("-"),
                    r.nrmse_percent.map_or("-".into(), |v| format!("{v:.3} %")),
                    if r.warnings.is_empty() {
                        String::new()
                    } else {
                        format!(", {} warning(s)", r.warnings.len())
                    }
                );
                if json {
                    println!("{}", serde_json::to_string(&done.json)?);
                }
                rows.push(r);
            }
            Err(e) => {
                eprintln!("error: {e:#}");
                rows.push(batch::Row::failed(path, &e, seconds));
            }
        }
    }
    Ok(rows)
}

/// Writes the summary of `rows` to `dir`, says where, and fails if any file failed.
fn finish_batch(dir: &Path, rows: &[batch::Row]) -> Result<()> {
    let (json, csv) = batch::write_summary(dir, rows)?;
    let failed = rows.iter().filter(|r| r.status != "ok").count();
    let seconds: f64 = rows.iter().map(|r| r.seconds).sum();
    eprintln!(
        "{} file(s), {failed} failed, {seconds:.1} s of work; summary: {} and {}",
        rows.len(),
        csv.display(),
        json.display()
    );
    if failed > 0 {
        bail!("{failed} of {} files failed", rows.len());
    }
    Ok(())
}

fn diagnose_one(
    path: &Path,
    format: &str,
    options: &DiagnoseOptions,
    overrides: &Overrides,
    until: Option<Phase>,
    out: &Path,
) -> Result<batch::Done> {
    use std::fmt::Write as _;
    let started = Instant::now();
    let run = diagnose_file(path, format, options, overrides, until)?;
    let elapsed = started.elapsed().as_secs_f64();
    let d = &run.diagnosis;
    let mut text = String::new();
    let _ = writeln!(
        text,
        "{} — diagnosis from {}",
        path.display(),
        d.baseline.name()
    );
    for note in &run.notes {
        let _ = writeln!(text, "  · {note}");
    }
    let _ = writeln!(
        text,
        "  baseline: NRMSE {:.3} %, VAF {:.2} %",
        d.baseline_fit.nrmse_percent, d.baseline_fit.vaf_percent
    );
    for (i, s) in d.steps.iter().enumerate() {
        let _ = writeln!(
            text,
            "  step {}: + {}{}{}  NRMSE {:.3} % -> {:.3} %, BIC {:.0} -> {:.0}",
            i + 1,
            s.effect.id(),
            s.replaces
                .map_or(String::new(), |e| format!(" (replaces {})", e.id())),
            s.jointly_with.map_or(String::new(), |e| format!(
                " (jointly with {}: neither passes alone)",
                e.id()
            )),
            s.before.nrmse_percent,
            s.after.nrmse_percent,
            s.before.bic,
            s.after.bic
        );
        for i in &s.indistinguishable_from {
            let _ = writeln!(
                text,
                "    the record cannot tell it from {} (ΔBIC {:+.1}): needs {}",
                i.effect.id(),
                i.delta_bic,
                i.separating_motion
            );
        }
    }
    for r in &d.removed {
        let _ = writeln!(
            text,
            "  backward check: - {}  NRMSE -> {:.3} % (keeping it: ΔBIC {:+.0}, held-out {:+.2} %, {} folds better: {})",
            r.effect.id(),
            r.after.nrmse_percent,
            r.kept.delta_bic,
            100.0 * r.kept.cv_improvement,
            r.kept.folds_better,
            r.reason()
        );
    }
    if !d.unidentifiable.is_empty() {
        let _ = writeln!(
            text,
            "  not tried (the record cannot identify them; see the report): {}",
            d.unidentifiable
                .iter()
                .map(|e| e.id())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    let _ = writeln!(
        text,
        "  final model: {} (NRMSE {:.3} %, VAF {:.2} %) in {elapsed:.2} s",
        d.final_model(),
        d.final_fit.nrmse_percent,
        d.final_fit.vaf_percent
    );
    let name = path.display().to_string();
    let report = diagnosis_report::write(out, &name, &run.prepared, d, options)?;
    let _ = writeln!(text, "  report: {}", report.display());
    Ok(batch::Done {
        json: diagnosis_report::json(&name, d, &run.prepared),
        text,
    })
}

fn decode_telemetry(path: &Path) -> Result<()> {
    let bytes = std::fs::read(path).with_context(|| format!("{}: reading", path.display()))?;
    let decoded = host_sim::telemetry::decode(&bytes);
    for message in &decoded.messages {
        println!("{}", serde_json::to_string(message)?);
    }
    for (offset, error) in &decoded.errors {
        eprintln!("{}: byte {offset}: {error}", path.display());
    }
    eprintln!(
        "{}: {} messages ({} telemetry frames), {} telemetry frames missing by sample index, {} undecodable{}",
        path.display(),
        decoded.messages.len(),
        decoded.frames.len(),
        decoded.missing,
        decoded.errors.len(),
        if decoded.truncated { ", ends mid-frame" } else { "" }
    );
    if decoded.frames.is_empty() {
        bail!("{}: no telemetry frame decoded", path.display());
    }
    Ok(())
}

fn progress(len: u64, what: &str) -> ProgressBar {
    let bar = ProgressBar::new(len);
    bar.set_style(
        ProgressStyle::with_template("{spinner} {msg} [{bar:30}] {pos}/{len} ({elapsed})")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.set_message(what.to_string());
    bar
}

fn simulate(name: &str, out: &Path) -> Result<Vec<ScenarioOutcome>> {
    let list = if name == "all" {
        scenarios::all()
    } else {
        match scenarios::by_name(name) {
            Some(s) => vec![s],
            None => bail!(
                "unknown scenario `{name}`; known: all, {}",
                scenarios::names().join(", ")
            ),
        }
    };
    let bar = progress(list.len() as u64, "scenarios");
    let mut outcomes = Vec::new();
    for s in &list {
        bar.set_message(s.name);
        let t0 = Instant::now();
        let outcome = report::run_scenario(s, Some(out))?;
        bar.suspend(|| {
            eprintln!(
                "{} ({}): {} [{:.1} s]",
                s.name,
                s.paper,
                s.title,
                t0.elapsed().as_secs_f64()
            );
            for e in &outcome.estimators {
                eprintln!(
                    "  {:28} {}  NRMSE {}  within 5 % from {}",
                    e.model,
                    if e.passes() { "ok  " } else { "OVER" },
                    e.run
                        .nrmse_percent
                        .map_or("-".into(), |v| format!("{v:.2} %")),
                    e.within_5_percent_from_s
                        .map_or("never".into(), |t| format!("{t:.2} s")),
                );
            }
        });
        outcomes.push(outcome);
        bar.inc(1);
    }
    bar.finish_and_clear();
    let table = report::scenario_table(&outcomes);
    std::fs::create_dir_all(out)?;
    report::write_text(&out.join("summary.md"), &table)?;
    eprintln!("\n{table}\nwritten to {}", out.display());
    Ok(outcomes)
}

#[allow(clippy::too_many_arguments)]
fn estimate_files(
    model: ModelKind,
    inputs: &[PathBuf],
    format: &str,
    json: bool,
    out: Option<&Path>,
    summary: Option<&Path>,
    overrides: &Overrides,
    phases: Option<Vec<Phase>>,
) -> Result<()> {
    let files = batch::expand_inputs(inputs)?;
    if !is_batch(inputs, &files) {
        let path = &files[0];
        let run = estimate_file(model, path, format, overrides, phases)?;
        eprint!("{}", describe_run(path, &run));
        if json {
            println!("{}", serde_json::to_string(&run.summary_json(path)?)?);
        }
        if let Some(out) = out {
            write_file_outputs(&out.join(stem(path)), path, &run)?;
        }
        return Ok(());
    }
    let stems = batch::unique_stems(&files);
    let quiet = Overrides {
        show_progress: false,
        ..*overrides
    };
    let results = batch::run(&files, "estimate", |i, path| {
        let run = estimate_file(model, path, format, &quiet, phases.clone())?;
        if let Some(out) = out {
            write_file_outputs(&out.join(&stems[i]), path, &run)?;
        }
        Ok(batch::Done {
            json: run.summary_json(path)?,
            text: describe_run(path, &run),
        })
    });
    let rows = report_batch(&files, results, json, |path, done, seconds| {
        batch::Row::from_estimate(path, &done.json, seconds)
    })?;
    finish_batch(summary.or(out).unwrap_or(Path::new("out")), &rows)
}

/// What `estimate` prints on stderr about one file: notes, warnings, parameters, fit.
fn describe_run(path: &Path, run: &FileRun) -> String {
    use std::fmt::Write as _;
    let mut text = String::new();
    let r = &run.result;
    let _ = writeln!(text, "{} — {}", path.display(), r.model.name());
    for note in &run.notes {
        let _ = writeln!(text, "  · {note}");
    }
    for warning in &run.warnings {
        let _ = writeln!(text, "  warning: {warning}");
    }
    for ((name, value), (_, se)) in runner::named(&r.parameters)
        .into_iter()
        .zip(runner::named(&r.standard_errors))
    {
        let verdict = if let Some(v) = run.held.get(name) {
            format!("  (held at {v}: not determined by the record)")
        } else if run.identifiable.get(name) == Some(&false) {
            "  (NOT determined by the record)".to_string()
        } else {
            String::new()
        };
        let _ = writeln!(text, "  {name:>8} = {value:.5e} ± {se:.2e}{verdict}");
    }
    let _ = writeln!(
        text,
        "  contact at {:.6e} m, force offset {:.4e} N, {} samples in contact, NRMSE {}, VAF {}",
        run.front_end.contact_position_m,
        run.front_end.force_offset_n,
        r.contact_samples,
        r.nrmse_percent.map_or("-".into(), |v| format!("{v:.2} %")),
        r.vaf_percent.map_or("-".into(), |v| format!("{v:.1} %")),
    );
    text
}

fn stem(path: &Path) -> String {
    path.file_stem()
        .map_or("record".into(), |s| s.to_string_lossy().into_owned())
}

/// Per-sample estimates, summary and plots of one file into `dir`.
fn write_file_outputs(dir: &Path, path: &Path, run: &FileRun) -> Result<()> {
    let dir = dir.to_path_buf();
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    let label = run.result.model.name();
    report::write_estimates(
        &dir.join(format!("estimates_{label}.csv")),
        &run.record.time_s,
        &run.result,
    )?;
    let mut summary = serde_json::to_value(run.result.summary())?;
    summary["file"] = serde_json::Value::String(path.display().to_string());
    summary["notes"] = serde_json::to_value(&run.notes)?;
    std::fs::write(
        dir.join(format!("summary_{label}.json")),
        serde_json::to_string_pretty(&summary)?,
    )?;
    report::plot_run(&dir, label, &run.record.time_s, &run.result, 1.0e-3, None)?;
    Ok(())
}

fn demo(out: &Path, data: &Path) -> Result<()> {
    let t0 = Instant::now();
    eprintln!("== Paper scenarios on the simulated plant");
    simulate("all", &out.join("scenarios"))?;
    eprintln!("\n== Measured files in {}", data.display());
    let mut table = String::from(
        "| file | model | fitted on | parameters | NRMSE | contact at | offset |\n|---|---|---|---|---|---|---|\n",
    );
    for (file, models) in REAL_FILES {
        let path = data.join(file);
        for &(model, phase) in *models {
            match estimate_file(
                model,
                &path,
                "auto",
                &Overrides::default(),
                phase.map(|p| vec![p]),
            ) {
                Ok(run) => {
                    eprint!("{}", describe_run(&path, &run));
                    write_file_outputs(&out.join("files").join(stem(&path)), &path, &run)?;
                    let params: Vec<String> = runner::named(&run.result.parameters)
                        .into_iter()
                        .map(|(n, v)| format!("{n} = {v:.6e}"))
                        .collect();
                    table.push_str(&format!(
                        "| {file} | {} | {} | {} | {} | {:.4e} m | {:.4e} N |\n",
                        model.name(),
                        phase.map_or("whole contact", |p| p.name()),
                        params.join(", "),
                        run.result
                            .nrmse_percent
                            .map_or("-".into(), |v| format!("{v:.2} %")),
                        run.front_end.contact_position_m,
                        run.front_end.force_offset_n
                    ));
                }
                Err(e) => {
                    eprintln!("{}: {e:#}", path.display());
                    table.push_str(&format!(
                        "| {file} | {} | | error: {e} | | | |\n",
                        model.name()
                    ));
                }
            }
        }
    }
    report::write_text(&out.join("files").join("summary.md"), &table)?;
    eprintln!("\n{table}");
    eprintln!("\n== Discrepancy diagnosis of the measured files (from Kelvin-Voigt)");
    let options = DiagnoseOptions::default();
    let runs = REAL_FILES
        .iter()
        .map(|(file, _)| (*file, None))
        .chain([("nanoindentation/steel-hysitron.txt", Some(Phase::Loading))]);
    for (file, until) in runs {
        let name = stem(Path::new(file)) + until.map_or("", |_| "-loading");
        let path = data.join(file);
        let done = diagnose_one(
            &path,
            "auto",
            &options,
            &Overrides::default(),
            until,
            &out.join("diagnose").join(name),
        )?;
        eprint!("{}", done.text);
    }
    eprintln!(
        "done in {:.1} s: scenario plots and tables in {}/scenarios, file results in {}/files, diagnoses in {}/diagnose",
        t0.elapsed().as_secs_f64(),
        out.display(),
        out.display(),
        out.display()
    );
    Ok(())
}
