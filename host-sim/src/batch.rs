//! Many files at once: `estimate` and `diagnose` on several paths or folders, in parallel
//! (rayon), with one progress bar and one summary table (`summary.csv`, `summary.json`).
//!
//! A file that fails is a row with `status = "error"` and its message (naming the file,
//! line and field as the readers do); the others go on.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Instant;

use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use serde::Serialize;
use serde_json::Value;

/// The files named by `inputs`: a file as given, a folder as every regular file below it
/// (recursively, sorted by path; names starting with `.` skipped). A path that does not
/// exist stays, for the reader to report (as an error row in a batch).
///
/// # Errors
/// A folder that cannot be listed, naming it.
pub fn expand_inputs(inputs: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    for input in inputs {
        if input.is_dir() {
            let mut found = Vec::new();
            walk(input, &mut found)?;
            found.sort();
            files.extend(found);
        } else {
            files.push(input.clone());
        }
    }
    Ok(files)
}

fn walk(dir: &Path, out: &mut Vec<PathBuf>) -> Result<()> {
    let entries =
        std::fs::read_dir(dir).with_context(|| format!("{}: cannot list it", dir.display()))?;
    for entry in entries {
        let entry = entry.with_context(|| format!("{}: cannot list it", dir.display()))?;
        let path = entry.path();
        if entry.file_name().to_string_lossy().starts_with('.') {
            continue;
        }
        let kind = entry
            .file_type()
            .with_context(|| format!("{}: cannot read it", path.display()))?;
        if kind.is_dir() {
            walk(&path, out)?;
        } else if kind.is_file() {
            out.push(path);
        }
    }
    Ok(())
}

/// One file's line of the summary table.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Row {
    /// The file as given.
    pub file: String,
    /// `ok` or `error`.
    pub status: &'static str,
    /// Why the file failed (`status = "error"`).
    pub error: Option<String>,
    /// `estimate`: the model; `diagnose`: the final model (baseline + effects).
    pub model: Option<String>,
    /// name → SI value: the estimate's parameters (with `contact_position_m`,
    /// `force_offset_n`), or the diagnosis's final parameters.
    pub parameters: BTreeMap<String, f64>,
    /// name → whether the record determines it (`estimate`).
    pub identifiable: BTreeMap<String, bool>,
    /// NRMSE \[%\] of the model simulated over the record (`diagnose`: the final model).
    pub nrmse_percent: Option<f64>,
    /// VAF \[%\].
    pub vaf_percent: Option<f64>,
    /// `estimate`: the online estimate agrees with the whole-record fit.
    pub converged: Option<bool>,
    /// Warnings about the result.
    pub warnings: Vec<String>,
    /// `diagnose`: the effects added, in order.
    pub effects: Vec<String>,
    /// `diagnose`: the effects the record cannot identify.
    pub not_identifiable: Vec<String>,
    /// Wall time of this file \[s\].
    pub seconds: f64,
}

impl Row {
    /// The row of an `estimate --json` object.
    pub fn from_estimate(file: &Path, json: &Value, seconds: f64) -> Row {
        Row {
            file: file.display().to_string(),
            status: "ok",
            model: json["model"].as_str().map(str::to_owned),
            parameters: numbers(&json["parameters"]),
            identifiable: json["identifiable"]
                .as_object()
                .map(|m| {
                    m.iter()
                        .filter_map(|(k, v)| Some((k.clone(), v.as_bool()?)))
                        .collect()
                })
                .unwrap_or_default(),
            nrmse_percent: json["nrmse_percent"].as_f64(),
            vaf_percent: json["vaf_percent"].as_f64(),
            converged: json["converged"].as_bool(),
            warnings: strings(&json["warnings"]),
            seconds,
            ..Row::default()
        }
    }

    /// The row of a `diagnose --json` object (a final parameter is identifiable unless its
    /// `"final_undetermined"` says why not).
    pub fn from_diagnosis(file: &Path, json: &Value, seconds: f64) -> Row {
        let parameters = numbers(&json["final_parameters"]);
        Row {
            file: file.display().to_string(),
            status: "ok",
            model: json["final_model"].as_str().map(str::to_owned),
            identifiable: parameters
                .keys()
                .map(|k| (k.clone(), json["final_undetermined"].get(k).is_none()))
                .collect(),
            parameters,
            nrmse_percent: json["nrmse_percent_final"].as_f64(),
            vaf_percent: json["vaf_percent_final"].as_f64(),
            effects: strings(&json["effects_added"]),
            not_identifiable: json["not_identifiable"]
                .as_array()
                .map(|a| {
                    a.iter()
                        .filter_map(|e| e["effect"].as_str().map(str::to_owned))
                        .collect()
                })
                .unwrap_or_default(),
            seconds,
            ..Row::default()
        }
    }

    /// The row of a file that failed.
    pub fn failed(file: &Path, error: &anyhow::Error, seconds: f64) -> Row {
        Row {
            file: file.display().to_string(),
            status: "error",
            error: Some(format!("{error:#}")),
            seconds,
            ..Row::default()
        }
    }
}

fn numbers(v: &Value) -> BTreeMap<String, f64> {
    v.as_object()
        .map(|m| {
            m.iter()
                .filter_map(|(k, v)| Some((k.clone(), v.as_f64()?)))
                .collect()
        })
        .unwrap_or_default()
}

fn strings(v: &Value) -> Vec<String> {
    v.as_array()
        .map(|a| {
            a.iter()
                .filter_map(|s| s.as_str().map(str::to_owned))
                .collect()
        })
        .unwrap_or_default()
}

/// What one file's job returns: its JSON object (as `--json` prints it) and the lines to
/// print about it on stderr.
pub struct Done {
    /// The file's `--json` object.
    pub json: Value,
    /// Human-readable lines (notes, parameters), printed in input order.
    pub text: String,
}

/// Runs `job(index, path)` on every file in parallel with one progress bar; results in input order.
/// Each result is the file's [`Done`] or its error, with the wall time \[s\].
pub fn run<F>(files: &[PathBuf], what: &str, job: F) -> Vec<(Result<Done>, f64)>
where
    F: Fn(usize, &Path) -> Result<Done> + Sync,
{
    let bar = ProgressBar::new(files.len() as u64);
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} {msg} [{bar:30}] {pos}/{len} files ({elapsed}, eta {eta})",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.set_message(what.to_owned());
    let failures = Mutex::new(0usize);
    let results: Vec<(Result<Done>, f64)> = files
        .par_iter()
        .enumerate()
        .map(|(i, path)| {
            let started = Instant::now();
            let result = job(i, path);
            if result.is_err() {
                if let Ok(mut n) = failures.lock() {
                    *n += 1;
                    bar.set_message(format!("{what} ({n} failed)"));
                }
            }
            bar.inc(1);
            (result, started.elapsed().as_secs_f64())
        })
        .collect();
    bar.finish_and_clear();
    results
}

/// Writes `rows` to `dir/summary.json` (an array of [`Row`]) and `dir/summary.csv` (one
/// line per file; a column per parameter name found in any row, and `<name>_identifiable`
/// where known; lists joined with `;`). Returns the two paths.
///
/// # Errors
/// The folder or a file cannot be written.
pub fn write_summary(dir: &Path, rows: &[Row]) -> Result<(PathBuf, PathBuf)> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let json_path = dir.join("summary.json");
    std::fs::write(&json_path, serde_json::to_string_pretty(rows)?)
        .with_context(|| format!("writing {}", json_path.display()))?;

    let mut names: Vec<&str> = Vec::new();
    let mut flagged: Vec<&str> = Vec::new();
    for row in rows {
        for name in row.parameters.keys() {
            if !names.contains(&name.as_str()) {
                names.push(name);
            }
        }
        for name in row.identifiable.keys() {
            if !flagged.contains(&name.as_str()) {
                flagged.push(name);
            }
        }
    }
    let csv_path = dir.join("summary.csv");
    let mut w = csv::Writer::from_path(&csv_path)
        .with_context(|| format!("creating {}", csv_path.display()))?;
    let mut header: Vec<String> = [
        "file",
        "status",
        "model",
        "nrmse_percent",
        "vaf_percent",
        "converged",
        "effects",
        "not_identifiable",
        "warnings",
        "seconds",
        "error",
    ]
    .iter()
    .map(|s| (*s).to_owned())
    .collect();
    header.extend(names.iter().map(|n| (*n).to_owned()));
    header.extend(flagged.iter().map(|n| format!("{n}_identifiable")));
    w.write_record(&header)?;
    let opt = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:.6e}"));
    for row in rows {
        let mut record = vec![
            row.file.clone(),
            row.status.to_owned(),
            row.model.clone().unwrap_or_default(),
            opt(row.nrmse_percent),
            opt(row.vaf_percent),
            row.converged.map_or(String::new(), |c| c.to_string()),
            row.effects.join(";"),
            row.not_identifiable.join(";"),
            row.warnings.len().to_string(),
            format!("{:.3}", row.seconds),
            row.error.clone().unwrap_or_default(),
        ];
        record.extend(names.iter().map(|n| opt(row.parameters.get(*n).copied())));
        record.extend(flagged.iter().map(|n| {
            row.identifiable
                .get(*n)
                .map_or(String::new(), |b| b.to_string())
        }));
        w.write_record(&record)?;
    }
    w.flush()
        .with_context(|| format!("writing {}", csv_path.display()))?;
    Ok((json_path, csv_path))
}

/// An output folder name for each file: its stem, with `-2`, `-3`, … on repeats (two
/// `sample.csv` in different folders).
pub fn unique_stems(files: &[PathBuf]) -> Vec<String> {
    let mut seen: BTreeMap<String, usize> = BTreeMap::new();
    files
        .iter()
        .map(|p| {
            let stem = p
                .file_stem()
                .map_or("record".into(), |s| s.to_string_lossy().into_owned());
            let n = seen.entry(stem.clone()).or_insert(0);
            *n += 1;
            if *n == 1 {
                stem
            } else {
                format!("{stem}-{n}")
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn folders_expand_sorted_without_hidden_files_and_stems_stay_unique() {
        let dir = std::env::temp_dir().join(format!("batch-expand-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("b")).unwrap();
        for f in ["z.csv", ".hidden", "b/z.csv", "a.txt"] {
            std::fs::write(dir.join(f), "x").unwrap();
        }
        let files = expand_inputs(std::slice::from_ref(&dir)).unwrap();
        let names: Vec<String> = files
            .iter()
            .map(|p| p.strip_prefix(&dir).unwrap().display().to_string())
            .collect();
        assert_eq!(names, ["a.txt", "b/z.csv", "z.csv"]);
        assert_eq!(unique_stems(&files), ["a", "z", "z-2"]);
        let missing = dir.join("missing.csv");
        assert_eq!(
            expand_inputs(std::slice::from_ref(&missing)).unwrap(),
            [missing]
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn the_summary_has_a_column_per_parameter_and_error_rows() {
        let dir = std::env::temp_dir().join(format!("batch-summary-{}", std::process::id()));
        let ok = Row::from_estimate(
            Path::new("a.csv"),
            &serde_json::json!({
                "model": "hunt-crossley",
                "parameters": {"k": 1.0e5, "n": 1.5},
                "identifiable": {"k": true, "n": false},
                "nrmse_percent": 1.25, "vaf_percent": 99.0, "converged": true,
                "warnings": ["w"]
            }),
            0.5,
        );
        let bad = Row::failed(
            Path::new("b.csv"),
            &anyhow::anyhow!("b.csv:3: field `x`"),
            0.1,
        );
        let (json, csv) = write_summary(&dir, &[ok, bad]).unwrap();
        let text = std::fs::read_to_string(csv).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert!(
            lines[0].ends_with(",k,n,k_identifiable,n_identifiable"),
            "{}",
            lines[0]
        );
        assert!(lines[1].starts_with("a.csv,ok,hunt-crossley,1.250000e0,"));
        assert!(lines[1].ends_with(",1.000000e5,1.500000e0,true,false"));
        assert!(lines[2].contains("b.csv,error,") && lines[2].contains("b.csv:3: field `x`"));
        let rows: Value = serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap();
        assert_eq!(rows[1]["status"], "error");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
