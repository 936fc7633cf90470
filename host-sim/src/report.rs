//! Running scenarios and writing what a user looks at: logs and estimates as CSV,
//! summaries as JSON, and plots like the paper's figures.

use std::fs;
use std::io::Write;
use std::path::Path;

use anyhow::{Context, Result};
use estimator_core::{AnyParameters, ModelKind};
use serde::Serialize;

use crate::plant::{Acquisition, Plant};
use crate::plots::{self, Chart, Series, PALETTE};
use crate::runner::{self, RunResult, RunSummary};
use crate::scenarios::{Check, Scenario, Truth};

/// A simulated record: the acquisition's SI samples and the plant's truth.
#[derive(Debug, Clone, Default)]
pub struct SimulatedLog {
    /// Time \[s\].
    pub time_s: Vec<f64>,
    /// Encoder position (0 at the start) \[m\].
    pub position_m: Vec<f64>,
    /// Load-cell force \[N\].
    pub force_n: Vec<f64>,
    /// ADC at a rail.
    pub saturated: Vec<bool>,
    /// True penetration \[m\].
    pub true_depth_m: Vec<f64>,
    /// True contact force \[N\].
    pub true_force_n: Vec<f64>,
    /// Raw ADC codes.
    pub adc_code: Vec<u16>,
    /// Raw 16-bit encoder counter.
    pub encoder_raw: Vec<u16>,
}

/// Runs the plant of `scenario` for its duration.
///
/// # Errors
/// If the plant config is not usable.
pub fn simulate_plant(scenario: &Scenario) -> Result<SimulatedLog> {
    let mut plant = Plant::new(scenario.plant.clone(), (scenario.materials)())?;
    let mut acquisition = Acquisition::new(&scenario.plant, 0.0)?;
    let n = (scenario.duration_s / scenario.plant.sample_time_s).round() as usize;
    Ok(record_plant(&mut plant, &mut acquisition, n))
}

/// Steps `plant` `n` times and records what `acquisition` makes of each sample (the
/// measured log) next to the plant's truth and raw codes.
pub fn record_plant(plant: &mut Plant, acquisition: &mut Acquisition, n: usize) -> SimulatedLog {
    let mut log = SimulatedLog::default();
    for _ in 0..n {
        let s = plant.step();
        let raw = acquisition.convert(&s);
        log.time_s.push(s.time_s);
        log.position_m.push(f64::from(raw.position_m));
        log.force_n.push(f64::from(raw.force_n));
        log.saturated.push(raw.saturated);
        log.true_depth_m.push(s.true_depth_m);
        log.true_force_n.push(s.true_force_n);
        log.adc_code.push(s.adc_code);
        log.encoder_raw.push(s.encoder_raw);
    }
    log
}

/// Outcome of one estimator in a scenario.
#[derive(Debug, Clone, Serialize)]
pub struct EstimatorOutcome {
    /// Model (CLI name).
    pub model: String,
    /// True vs estimated.
    pub checks: Vec<Check>,
    /// Time after the truth starts to apply from which every check stays within 5 % \[s\].
    pub within_5_percent_from_s: Option<f64>,
    /// Same, 2 %.
    pub within_2_percent_from_s: Option<f64>,
    /// Contact position the pipeline found \[m\] and the truth.
    pub contact_position_m: (f64, f64),
    /// Run summary (parameters, uncertainty, fit, flags).
    pub run: RunSummary,
}

impl EstimatorOutcome {
    /// All checks within tolerance.
    pub fn passes(&self) -> bool {
        self.checks.iter().all(Check::passes)
    }
}

/// Outcome of a scenario.
#[derive(Debug, Clone, Serialize)]
pub struct ScenarioOutcome {
    /// Scenario name.
    pub name: String,
    /// Title.
    pub title: String,
    /// Where in the paper.
    pub paper: String,
    /// Duration \[s\].
    pub duration_s: f64,
    /// One per estimator.
    pub estimators: Vec<EstimatorOutcome>,
}

/// First time (relative to `from`) after which `ok(i)` holds for every later sample.
fn settled(from: usize, n: usize, dt: f64, ok: impl Fn(usize) -> bool) -> Option<f64> {
    let mut last_bad = None;
    for i in from..n {
        if !ok(i) {
            last_bad = Some(i);
        }
    }
    match last_bad {
        None => Some(0.0),
        Some(i) if i + 1 < n => Some((i + 1 - from) as f64 * dt),
        Some(_) => None,
    }
}

/// Runs `scenario`: plant, then each estimator on the same record. Writes the log,
/// estimates, summary and plots under `out_dir/<name>/` when given.
///
/// # Errors
/// If the plant or an estimator cannot run, or a file cannot be written.
pub fn run_scenario(scenario: &Scenario, out_dir: Option<&Path>) -> Result<ScenarioOutcome> {
    let log = simulate_plant(scenario)?;
    let dt = scenario.plant.sample_time_s;
    let truth_contact = -scenario.plant.trajectory.depth_m(0.0);
    let dir = out_dir.map(|d| d.join(scenario.name));
    if let Some(dir) = &dir {
        fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        write_simulated_log(&dir.join("log.csv"), &log)?;
    }
    let mut outcomes = Vec::new();
    for spec in &scenario.estimators {
        let result = runner::run(
            &spec.options,
            &log.position_m,
            &log.force_n,
            &log.saturated,
            &mut |_| {},
        )?;
        let checks = scenario.truth.checks(&result.parameters, spec.tolerance);
        let from = (scenario.truth_from_s / dt).round() as usize;
        let n = result.trace.parameters.len();
        let within = |tol: f64| {
            settled(from, n, dt, |i| {
                scenario
                    .truth
                    .checks(&result.trace.parameters[i], tol)
                    .iter()
                    .all(Check::passes)
            })
        };
        let mut run = result.summary();
        if from > 0 {
            // The fit is judged against the material the truth describes.
            let (nrmse, vaf) = runner::fit_quality_from(
                &result.parameters,
                spec.options.pipeline.sample_time_s,
                &result.trace,
                from,
            );
            run.nrmse_percent = nrmse;
            run.vaf_percent = vaf;
        }
        let outcome = EstimatorOutcome {
            model: spec.options.model.name().to_string(),
            within_5_percent_from_s: within(0.05),
            within_2_percent_from_s: within(0.02),
            checks,
            contact_position_m: (result.contact_position_m, truth_contact),
            run,
        };
        if let Some(dir) = &dir {
            let label = spec.options.model.name();
            write_estimates(
                &dir.join(format!("estimates_{label}.csv")),
                &log.time_s,
                &result,
            )?;
            plot_run(
                dir,
                label,
                &log.time_s,
                &result,
                spec.options.pipeline.sample_time_s,
                Some(&scenario.truth),
            )?;
        }
        outcomes.push(outcome);
    }
    let outcome = ScenarioOutcome {
        name: scenario.name.to_string(),
        title: scenario.title.to_string(),
        paper: scenario.paper.to_string(),
        duration_s: scenario.duration_s,
        estimators: outcomes,
    };
    if let Some(dir) = &dir {
        let json = serde_json::to_string_pretty(&outcome)?;
        fs::write(dir.join("summary.json"), json)
            .with_context(|| format!("writing {}", dir.display()))?;
    }
    Ok(outcome)
}

/// Writes the simulated log in the project's format (`time_s,position_m,force_n`) with
/// the truth and raw codes as extra columns (ignored by readers).
///
/// # Errors
/// If the file cannot be written.
pub fn write_simulated_log(path: &Path, log: &SimulatedLog) -> Result<()> {
    let mut w =
        csv::Writer::from_path(path).with_context(|| format!("creating {}", path.display()))?;
    w.write_record([
        "time_s",
        "position_m",
        "force_n",
        "true_depth_m",
        "true_force_n",
        "adc_code",
        "encoder_raw",
    ])?;
    for i in 0..log.time_s.len() {
        w.write_record([
            format!("{:.6}", log.time_s[i]),
            format!("{:.9e}", log.position_m[i]),
            format!("{:.6e}", log.force_n[i]),
            format!("{:.9e}", log.true_depth_m[i]),
            format!("{:.6e}", log.true_force_n[i]),
            log.adc_code[i].to_string(),
            log.encoder_raw[i].to_string(),
        ])?;
    }
    w.flush()?;
    Ok(())
}

/// Writes the per-sample estimates of a run.
///
/// # Errors
/// If the file cannot be written.
pub fn write_estimates(path: &Path, time_s: &[f64], result: &RunResult) -> Result<()> {
    let mut w =
        csv::Writer::from_path(path).with_context(|| format!("creating {}", path.display()))?;
    let t = &result.trace;
    if t.parameters.len() != t.depth_m.len() {
        anyhow::bail!(
            "{}: the run kept no per-sample parameters (RunOptions::parameter_trace)",
            path.display()
        );
    }
    let names: Vec<&str> = result.parameters.iter().map(|(n, _)| n).collect();
    let mut header = vec![
        "time_s",
        "contact",
        "depth_m",
        "depth_rate_m_per_s",
        "force_n",
        "predicted_force_n",
    ];
    header.extend(names.iter());
    header.push("status");
    w.write_record(&header)?;
    for i in 0..t.depth_m.len() {
        let mut row = vec![
            format!("{:.6}", time_s.get(i).copied().unwrap_or(i as f64 * 1e-3)),
            u8::from(t.contact[i]).to_string(),
            format!("{:.6e}", t.depth_m[i]),
            format!("{:.6e}", t.rate_m_per_s[i]),
            format!("{:.6e}", t.force_n[i]),
            format!("{:.6e}", t.predicted_force_n[i]),
        ];
        row.extend(t.parameters[i].iter().map(|(_, v)| format!("{v:.6e}")));
        row.push(format!("{:#06x}", t.status[i]));
        w.write_record(&row)?;
    }
    w.flush()?;
    Ok(())
}

/// Plots of one run, like the paper's figures: hysteresis loop (force vs penetration,
/// measured vs model), power exchange, parameter convergence, and for Hammerstein the
/// time response and elastic response.
///
/// # Errors
/// If a plot cannot be written.
pub fn plot_run(
    dir: &Path,
    label: &str,
    time_s: &[f64],
    result: &RunResult,
    sample_time_s: f32,
    truth: Option<&Truth>,
) -> Result<()> {
    let t = &result.trace;
    let model = runner::simulated_force(&result.parameters, sample_time_s, t);
    let contact: Vec<usize> = (0..t.contact.len()).filter(|&i| t.contact[i]).collect();
    let Some(&last) = contact.last() else {
        return Ok(());
    };
    // The last few seconds of contact, as the paper's loops show a few cycles.
    let window_start = time_s[last] - 3.0;
    let recent: Vec<usize> = contact
        .iter()
        .copied()
        .filter(|&i| time_s[i] >= window_start)
        .collect();
    let pick = |ys: &[f64], xs: &dyn Fn(usize) -> f64, idx: &[usize]| -> Vec<(f64, f64)> {
        plots::thin(idx.iter().map(|&i| (xs(i), ys[i])).collect(), 4000)
    };
    let depth_mm = |i: usize| t.depth_m[i] * 1e3;
    plots::save(
        &[Chart {
            title: format!("Hysteresis loop, {label} (last 3 s of contact)"),
            x_label: "penetration δ [mm]".into(),
            y_label: "force F [N]".into(),
            series: vec![
                Series::dashed("measured", pick(&t.force_n, &depth_mm, &recent), PALETTE[0]),
                Series::solid(
                    "estimated model",
                    pick(&model, &depth_mm, &recent),
                    PALETTE[1],
                ),
            ],
        }],
        &dir.join(format!("hysteresis_{label}")),
    )?;
    let power = |f: &[f64]| -> Vec<f64> {
        f.iter()
            .zip(&t.rate_m_per_s)
            .map(|(f, v)| f * v * 1e3)
            .collect()
    };
    let time = |i: usize| time_s[i];
    let window: Vec<usize> = contact
        .iter()
        .copied()
        .filter(|&i| time_s[i] >= time_s[last] - 2.0)
        .collect();
    plots::save(
        &[Chart {
            title: format!("Power exchange, {label} (last 2 s of contact)"),
            x_label: "time [s]".into(),
            y_label: "P = F·dδ/dt [mW]".into(),
            series: vec![
                Series::dashed(
                    "measured",
                    pick(&power(&t.force_n), &time, &window),
                    PALETTE[0],
                ),
                Series::solid(
                    "estimated model",
                    pick(&power(&model), &time, &window),
                    PALETTE[1],
                ),
            ],
        }],
        &dir.join(format!("power_{label}")),
    )?;
    plot_parameters(
        dir,
        label,
        time_s,
        result,
        truth.and_then(Truth::parameters),
    )?;
    if matches!(
        result.model,
        ModelKind::Hammerstein1 | ModelKind::Hammerstein2
    ) {
        plot_hammerstein(
            dir,
            label,
            time_s,
            result,
            &model,
            truth.and_then(Truth::parameters),
        )?;
    }
    Ok(())
}

fn plot_parameters(
    dir: &Path,
    label: &str,
    time_s: &[f64],
    result: &RunResult,
    truth: Option<AnyParameters>,
) -> Result<()> {
    let t = &result.trace;
    let reference = truth.unwrap_or(result.parameters);
    let divisor: Vec<f64> = reference
        .iter()
        .map(|(_, v)| if v != 0.0 { f64::from(v) } else { 1.0 })
        .collect();
    let what = if truth.is_some() {
        "true value"
    } else {
        "final estimate"
    };
    let series = reference
        .iter()
        .enumerate()
        .map(|(k, (name, _))| {
            let pts = (0..t.parameters.len())
                .map(|i| {
                    (
                        time_s[i],
                        t.parameters[i]
                            .get(k)
                            .map_or(f64::NAN, |(_, v)| f64::from(v) / divisor[k])
                            .clamp(0.0, 2.0),
                    )
                })
                .collect();
            Series::solid(name, plots::thin(pts, 3000), PALETTE[k % PALETTE.len()])
        })
        .collect();
    plots::save(
        &[Chart {
            title: format!(
                "Parameter convergence, {label} (each divided by its {what}, clipped to 0-2)"
            ),
            x_label: "time [s]".into(),
            y_label: format!("estimate / {what}"),
            series,
        }],
        &dir.join(format!("parameters_{label}")),
    )
}

fn plot_hammerstein(
    dir: &Path,
    label: &str,
    time_s: &[f64],
    result: &RunResult,
    model: &[f64],
    truth: Option<AnyParameters>,
) -> Result<()> {
    let t = &result.trace;
    let all: Vec<usize> = (0..t.depth_m.len()).collect();
    let pts = |ys: &[f64], scale: f64| {
        plots::thin(
            all.iter().map(|&i| (time_s[i], ys[i] * scale)).collect(),
            4000,
        )
    };
    plots::save(
        &[
            Chart {
                title: format!("Penetration, {label}"),
                x_label: "time [s]".into(),
                y_label: "δ [mm]".into(),
                series: vec![Series::dashed("measured", pts(&t.depth_m, 1e3), PALETTE[0])],
            },
            Chart {
                title: format!("Force, {label}: measured and estimated model"),
                x_label: "time [s]".into(),
                y_label: "F [N]".into(),
                series: vec![
                    Series::dashed("measured", pts(&t.force_n, 1.0), PALETTE[0]),
                    Series::solid("estimated model", pts(model, 1.0), PALETTE[1]),
                ],
            },
        ],
        &dir.join(format!("response_{label}")),
    )?;
    let fe = |p: &AnyParameters, d: f64| match *p {
        AnyParameters::Hammerstein { gamma1, gamma2, .. } => {
            f64::from(gamma1) * d.powf(f64::from(gamma2))
        }
        _ => f64::NAN,
    };
    let max_depth = t.depth_m.iter().copied().fold(0.0f64, f64::max);
    let grid: Vec<f64> = (0..=200).map(|i| max_depth * i as f64 / 200.0).collect();
    let loading: Vec<(f64, f64)> = (0..t.depth_m.len())
        .filter(|&i| t.contact[i] && t.rate_m_per_s[i] > 0.0)
        .map(|i| (t.depth_m[i] * 1e3, t.force_n[i]))
        .collect();
    let mut series = vec![
        Series::dashed("measured (loading)", loading, PALETTE[0]),
        Series::solid(
            "estimated F_e",
            grid.iter()
                .map(|&d| (d * 1e3, fe(&result.parameters, d)))
                .collect(),
            PALETTE[1],
        ),
    ];
    if let Some(truth) = truth {
        series.push(Series::solid(
            "true F_e",
            grid.iter().map(|&d| (d * 1e3, fe(&truth, d))).collect(),
            PALETTE[2],
        ));
    }
    plots::save(
        &[Chart {
            title: format!("Elastic response, {label}"),
            x_label: "δ [mm]".into(),
            y_label: "F [N]".into(),
            series,
        }],
        &dir.join(format!("elastic_{label}")),
    )
}

/// Markdown table of scenario outcomes (true vs estimated, convergence, fit).
pub fn scenario_table(outcomes: &[ScenarioOutcome]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| scenario | model | quantity | true | estimated | error | tolerance | within 5 % from | within 2 % from | NRMSE |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|");
    for o in outcomes {
        for e in &o.estimators {
            for (i, c) in e.checks.iter().enumerate() {
                let first = i == 0;
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {:.4e} | {:.4e} | {:.2} % {} | {} | {} | {} | {} |",
                    if first { o.name.as_str() } else { "" },
                    if first { e.model.as_str() } else { "" },
                    c.name,
                    c.truth,
                    c.estimate,
                    100.0 * c.relative_error,
                    if c.passes() { "" } else { "**(over)**" },
                    c.tolerance
                        .map_or("reported".into(), |t| format!("{:.0} %", 100.0 * t)),
                    if first {
                        fmt_time(e.within_5_percent_from_s)
                    } else {
                        String::new()
                    },
                    if first {
                        fmt_time(e.within_2_percent_from_s)
                    } else {
                        String::new()
                    },
                    if first {
                        e.run
                            .nrmse_percent
                            .map_or("-".into(), |v| format!("{v:.2} %"))
                    } else {
                        String::new()
                    },
                );
            }
        }
    }
    s
}

fn fmt_time(t: Option<f64>) -> String {
    t.map_or("not reached".into(), |t| format!("{t:.2} s"))
}

use std::fmt::Write as _;

/// Writes `text` to `path`.
///
/// # Errors
/// If the file cannot be written.
pub fn write_text(path: &Path, text: &str) -> Result<()> {
    let mut f = fs::File::create(path).with_context(|| format!("creating {}", path.display()))?;
    f.write_all(text.as_bytes())?;
    Ok(())
}
