//! Runs every paper scenario over a range of plant seeds and prints, per estimator, the
//! worst relative error of each checked quantity: the "worst of 40 seeds" column of the
//! README.
//!
//! `cargo run --release -p host-sim --example seed_sweep -- 1..41`

use host_sim::{report, scenarios};

fn main() {
    let seeds: Vec<u64> = std::env::args()
        .nth(1)
        .and_then(|a| {
            let (a, b) = a.split_once("..")?;
            Some((a.parse().ok()?..b.parse().ok()?).collect())
        })
        .unwrap_or_else(|| (1..41).collect());
    for template in scenarios::all() {
        let mut worst: Vec<Vec<(String, f64)>> = vec![Vec::new(); template.estimators.len()];
        let mut settle = vec![0.0f64; template.estimators.len()];
        let mut contact = 0.0f64;
        for &seed in &seeds {
            let mut s = scenarios::by_name(template.name).expect("scenario exists");
            s.plant.seed = seed;
            let outcome = report::run_scenario(&s, None).expect("scenario runs");
            for (k, e) in outcome.estimators.iter().enumerate() {
                if worst[k].is_empty() {
                    worst[k] = e.checks.iter().map(|c| (c.name.clone(), 0.0)).collect();
                }
                for (w, c) in worst[k].iter_mut().zip(&e.checks) {
                    w.1 = w.1.max(c.relative_error);
                }
                settle[k] = settle[k].max(e.within_5_percent_from_s.unwrap_or(f64::INFINITY));
                contact = contact.max((e.contact_position_m.0 - e.contact_position_m.1).abs());
            }
        }
        for (k, spec) in template.estimators.iter().enumerate() {
            let v: Vec<String> = worst[k]
                .iter()
                .map(|(n, e)| format!("{n}: {:.2} %", 100.0 * e))
                .collect();
            println!(
                "{} {} (tolerance {:.0} %, {} seeds): worst {} | within 5 % from ≤ {:.2} s | contact ≤ {:.1} µm",
                template.name,
                spec.options.model.name(),
                100.0 * spec.tolerance,
                seeds.len(),
                v.join(", "),
                settle[k],
                contact * 1e6
            );
        }
    }
}
