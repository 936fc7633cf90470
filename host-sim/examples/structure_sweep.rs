//! Runs `estimate` on recordings of every structure (start in or out of contact, lift-offs,
//! ramps at one or several speeds, sines, chirps, holds, taps; 100 Hz–10 kHz; offsets,
//! both axis orientations, white and AR(1) noise) for a range of seeds and prints the
//! structure × estimator table of the README and the failures.
//!
//! `cargo run --release -p host-sim --example structure_sweep -- 1000..1020 [STRUCTURE]`
//! `... -- dump STRUCTURE MATERIAL SEED FILE.csv` writes one recording (and its truth to
//! stderr) to look at with `host-sim estimate`.

use host_sim::recordings::{
    cases, generate, run_case, table_row, MaterialKind, Structure, TABLE_HEADER,
};

fn main() {
    let mut args = std::env::args().skip(1);
    if std::env::args().nth(1).as_deref() == Some("dump") {
        let a: Vec<String> = args.skip(1).collect();
        let structure = Structure::ALL
            .into_iter()
            .find(|s| s.name() == a[0])
            .expect("a structure name");
        let material = match a[1].as_str() {
            "kv" => MaterialKind::KelvinVoigt,
            "hc" => MaterialKind::HuntCrossley,
            "power" => MaterialKind::PowerLaw,
            _ => MaterialKind::Qlv,
        };
        let r = generate(structure, material, a[2].parse().expect("a seed"));
        std::fs::write(&a[3], r.to_csv()).expect("writable");
        eprintln!("{:#?}", r.truth);
        return;
    }
    let seeds: Vec<u64> = args
        .next()
        .and_then(|a| {
            let (a, b) = a.split_once("..")?;
            Some((a.parse().ok()?..b.parse().ok()?).collect())
        })
        .unwrap_or_else(|| (1000..1020).collect());
    let only = args.next();
    let dir = tempfile::tempdir().expect("a temporary directory");
    println!("{TABLE_HEADER}");
    let mut failures = Vec::new();
    for case in cases() {
        if only.as_deref().is_some_and(|o| o != case.structure.name()) {
            continue;
        }
        let scores = run_case(case, &seeds, dir.path());
        println!("{}", table_row(case, &scores));
        failures.extend(scores.iter().filter(|s| !s.passes()).map(|s| s.describe()));
    }
    println!("\n{} failing runs", failures.len());
    for f in failures {
        println!("{f}");
    }
}
