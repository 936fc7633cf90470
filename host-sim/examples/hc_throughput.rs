//! Samples per second of the core's double-stage Hunt-Crossley estimator over a CSV of
//! in-contact samples (`depth_m,depth_rate_m_per_s,force_n`), for the comparison with the
//! pure-Python reference (`bench/reference.py`, `bench/compare.sh`).
//!
//! ```sh
//! # Write the samples: the paper's plastic layer (k = 4.578e4 N/m^1.2,
//! # λ = 2.787e5 N·s/m^2.2, n = 1.2) pressed 0.1-1 mm at 2 Hz, 20 mN force noise.
//! cargo run --release -p host-sim --example hc_throughput -- --write-csv samples.csv
//! # Estimate: one JSON line with the final k, λ, n and the samples per second.
//! cargo run --release -p host-sim --example hc_throughput -- samples.csv
//! ```
//!
//! Only the estimation loop is timed (the file is parsed first), as in the Python
//! reference. The record is run repeatedly, each time by a fresh estimator, until at
//! least `--min-seconds` have passed; the rate is the total samples over the total time.

use std::hint::black_box;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Parser;
use estimator_core::hunt_crossley::{HuntCrossleyConfig, HuntCrossleyEstimator};
use estimator_core::models::HuntCrossley;
use estimator_core::{ContactSample, Estimator};

#[derive(Parser)]
#[command(about = "Hunt-Crossley double-stage throughput over a CSV of in-contact samples")]
struct Args {
    /// Write the samples to this CSV instead of estimating.
    #[arg(long, value_name = "PATH")]
    write_csv: Option<PathBuf>,
    /// Length of the written record [s] at 1 kHz.
    #[arg(long, default_value_t = 120.0)]
    seconds: f64,
    /// Time the estimation loop for at least this long [s].
    #[arg(long, default_value_t = 2.0)]
    min_seconds: f64,
    /// CSV to estimate from.
    input: Option<PathBuf>,
}

/// Sample time \[s\].
const T: f64 = 1.0e-3;

/// The plastic layer pressed between 0.1 and 1 mm at 2 Hz, with 20 mN of Gaussian-ish
/// force noise (sum of 12 uniforms from a fixed LCG, so the file is reproducible).
fn generate(seconds: f64) -> Result<Vec<ContactSample>> {
    let plastic = HuntCrossley::try_new(4.578e4, 2.787e5, 1.2)?;
    let mut state = 1u64;
    let mut noise = move || {
        let mut s = 0.0;
        for _ in 0..12 {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            s += (state >> 40) as f64 / (1u64 << 24) as f64;
        }
        0.02 * (s - 6.0)
    };
    let w = 2.0 * std::f64::consts::PI * 2.0;
    let n = (seconds / T).round() as usize;
    Ok((0..n)
        .map(|h| {
            let t = h as f64 * T;
            let depth_m = (0.55e-3 - 0.45e-3 * (w * t).cos()) as f32;
            let depth_rate_m_per_s = (0.45e-3 * w * (w * t).sin()) as f32;
            let force_n = plastic.force_n(depth_m, depth_rate_m_per_s) + noise() as f32;
            ContactSample {
                depth_m,
                depth_rate_m_per_s,
                force_n,
            }
        })
        .collect())
}

fn write_csv(path: &PathBuf, samples: &[ContactSample]) -> Result<()> {
    let mut w = csv::Writer::from_path(path).with_context(|| format!("{}", path.display()))?;
    w.write_record(["depth_m", "depth_rate_m_per_s", "force_n"])?;
    for s in samples {
        // Shortest round-trip f32 text: Python reads back exactly the same values.
        w.write_record([
            s.depth_m.to_string(),
            s.depth_rate_m_per_s.to_string(),
            s.force_n.to_string(),
        ])?;
    }
    w.flush()?;
    Ok(())
}

fn read_csv(path: &PathBuf) -> Result<Vec<ContactSample>> {
    let mut r = csv::Reader::from_path(path).with_context(|| format!("{}", path.display()))?;
    let header = r.headers()?.clone();
    let column = |name: &str| {
        header
            .iter()
            .position(|h| h == name)
            .with_context(|| format!("{}: no `{name}` column", path.display()))
    };
    let (id, iv, i_f) = (
        column("depth_m")?,
        column("depth_rate_m_per_s")?,
        column("force_n")?,
    );
    let mut samples = Vec::new();
    for (line, row) in r.records().enumerate() {
        let row = row?;
        let cell = |i: usize| -> Result<f32> {
            let text = row.get(i).unwrap_or("");
            text.trim()
                .parse()
                .with_context(|| format!("{}:{}: not a number: {text:?}", path.display(), line + 2))
        };
        samples.push(ContactSample {
            depth_m: cell(id)?,
            depth_rate_m_per_s: cell(iv)?,
            force_n: cell(i_f)?,
        });
    }
    Ok(samples)
}

fn main() -> Result<()> {
    let args = Args::parse();
    if let Some(path) = &args.write_csv {
        let samples = generate(args.seconds)?;
        write_csv(path, &samples)?;
        eprintln!("wrote {} samples to {}", samples.len(), path.display());
        return Ok(());
    }
    let path = args
        .input
        .context("give a CSV to estimate from, or --write-csv PATH")?;
    let samples = read_csv(&path)?;
    anyhow::ensure!(!samples.is_empty(), "{}: no samples", path.display());
    let template = HuntCrossleyEstimator::try_new(HuntCrossleyConfig::default())?;

    let mut runs = 0u64;
    let mut final_parameters = template.parameters();
    let start = Instant::now();
    while runs == 0 || start.elapsed().as_secs_f64() < args.min_seconds {
        let mut estimator = template;
        for s in &samples {
            black_box(estimator.step(black_box(s)));
        }
        final_parameters = estimator.parameters();
        runs += 1;
    }
    let seconds = start.elapsed().as_secs_f64();
    let total = runs * samples.len() as u64;
    let p = final_parameters;
    println!(
        "{}",
        serde_json::json!({
            "implementation": "rust",
            "k": p.k,
            "lambda": p.lambda,
            "n": p.n,
            "samples": samples.len(),
            "runs": runs,
            "seconds": seconds,
            "samples_per_s": total as f64 / seconds,
        })
    );
    Ok(())
}
