//! Sweeps the discrepancy workflow over generated logs: one hidden effect, pairs, none.
//! Prints, per case, the effects found for each seed, and a confusion table.
//!
//! `cargo run --release -p host-sim --example diagnose_sweep -- FIRST_SEED COUNT [CASE]`
//! (`ARRAYS=1`: the generator's arrays prepared directly, without the front end)

use std::time::Instant;

use estimator_core::conditioning::ImpactConfig;
use host_sim::diagnose::{self, catalogue::Effect, data, Options};
use host_sim::generator;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let first: u64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(1);
    let count: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(5);
    let only = args.get(3).cloned();
    // Each log is written as a CSV and diagnosed as `host-sim diagnose` diagnoses a file
    // (the front end finds the axis, offset, contact point and noise), as the sweep test
    // does; ARRAYS=1 prepares the generator's arrays with the impact detector instead.
    let user_path = std::env::var("ARRAYS").is_ok_and(|v| v == "1");
    let user_path = !user_path;
    let dir = std::env::temp_dir().join(format!("diagnose_sweep-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary folder");
    let mut cases: Vec<Vec<Effect>> = Effect::ALL.iter().map(|e| vec![*e]).collect();
    cases.push(vec![Effect::PowerLawStiffness, Effect::Relaxation]);
    cases.push(vec![Effect::DepthDependentDamping, Effect::ForceOffset]);
    cases.push(vec![Effect::Inertia, Effect::CoulombFriction]);
    cases.push(vec![Effect::TimeDelay, Effect::PlasticSet]);
    cases.push(vec![
        Effect::ExponentialStiffness,
        Effect::ContactPointOffset,
    ]);
    cases.push(vec![]);
    for case in cases {
        let name = if case.is_empty() {
            "none".to_string()
        } else {
            case.iter().map(|e| e.id()).collect::<Vec<_>>().join("+")
        };
        if let Some(o) = &only {
            if !name.contains(o.as_str()) {
                continue;
            }
        }
        let mut good = 0;
        let mut lines = Vec::new();
        let mut worst_ratio: f64 = 0.0;
        let mut time = 0.0f64;
        for seed in first..first + count {
            let g = generator::generate(&case, seed);
            let t0 = Instant::now();
            let (prepared, d) = if user_path {
                let path = dir.join(format!("{name}-{seed}.csv"));
                host_sim::report::write_simulated_log(&path, &g.log).expect("write the log");
                let run = host_sim::files::diagnose_file(
                    &path,
                    "csv",
                    &Options::default(),
                    &host_sim::setup::Overrides::default(),
                    None,
                );
                let _ = std::fs::remove_file(&path);
                match run {
                    Ok(run) => (run.prepared, run.diagnosis),
                    Err(e) => {
                        lines.push(format!("  seed {seed}: {e:#}"));
                        continue;
                    }
                }
            } else {
                let prepared = match data::prepare(
                    &g.log.time_s,
                    &g.log.position_m,
                    &g.log.force_n,
                    ImpactConfig::default(),
                ) {
                    Ok(p) => p,
                    Err(e) => {
                        lines.push(format!("  seed {seed}: {e}"));
                        continue;
                    }
                };
                let d = diagnose::diagnose(&prepared, &Options::default()).expect("fit");
                (prepared, d)
            };
            time = time.max(t0.elapsed().as_secs_f64());
            let found = d.effects_added();
            let floor = generator::noise_floor_percent(&g, &prepared);
            let ratio = d.final_fit.nrmse_percent / floor;
            worst_ratio = worst_ratio.max(ratio);
            let ok = if case.is_empty() {
                found.is_empty()
            } else if case.len() == 1 {
                d.steps.first().map(|s| s.effect) == Some(case[0])
            } else {
                case.iter().all(|e| found.contains(&e.id()))
            };
            if ok {
                good += 1;
            }
            let cands: Vec<String> = d
                .steps
                .first()
                .map(|s| &s.candidates)
                .unwrap_or(&d.final_candidates)
                .iter()
                .take(3)
                .map(|c| {
                    format!(
                        "{}(dBIC {:.0}, cv {:.1}%, {}f)",
                        c.effect.id(),
                        c.delta_bic,
                        100.0 * c.cv_improvement,
                        c.folds_better
                    )
                })
                .collect();
            let last: Vec<String> = d
                .final_candidates
                .iter()
                .take(3)
                .map(|c| {
                    format!(
                        "{}(dBIC {:.0}, cv {:.1}%, {}f)",
                        c.effect.id(),
                        c.delta_bic,
                        100.0 * c.cv_improvement,
                        c.folds_better
                    )
                })
                .collect();
            lines.push(format!(
                "  seed {seed}: {} {:?} nrmse {:.2}% -> {:.2}% floor {:.2}% (x{:.2}) | {} || last: {}",
                if ok { "ok " } else { "BAD" },
                found,
                d.baseline_fit.nrmse_percent,
                d.final_fit.nrmse_percent,
                floor,
                ratio,
                cands.join(", "),
                last.join(", ")
            ));
        }
        println!("{name}: {good}/{count}, worst final/floor {worst_ratio:.2}, slowest {time:.2} s");
        for l in lines {
            println!("{l}");
        }
    }
}
