//! The discrepancy workflow on the shipped real files (`../shared/data`), through the
//! library and through `host-sim diagnose`.

use std::path::{Path, PathBuf};
use std::process::Command;

use host_sim::diagnose::catalogue::{Determination, Param};
use host_sim::diagnose::{Diagnosis, Options};
use host_sim::files::diagnose_file;
use host_sim::phases::Phase;
use host_sim::setup::Overrides;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data")
        .join(name)
}

fn diagnosed(name: &str, until: Option<Phase>) -> Diagnosis {
    diagnose_file(
        &data(name),
        "auto",
        &Options::default(),
        &Overrides::default(),
        until,
    )
    .unwrap_or_else(|e| panic!("{name}: {e:#}"))
    .diagnosis
}

/// Every step lowers the NRMSE, and the final model closes a real part of the gap.
fn gap_shrinks(name: &str, d: &Diagnosis, factor: f64) {
    assert!(!d.steps.is_empty(), "{name}: nothing added");
    for s in &d.steps {
        assert!(
            s.after.nrmse_percent < s.before.nrmse_percent,
            "{name}: {} did not lower the NRMSE",
            s.effect.id()
        );
        assert!(
            s.after.bic < s.before.bic - 10.0,
            "{name}: {} did not lower the BIC by 10",
            s.effect.id()
        );
    }
    assert!(
        d.final_fit.nrmse_percent <= factor * d.baseline_fit.nrmse_percent,
        "{name}: NRMSE {:.3} % -> {:.3} %",
        d.baseline_fit.nrmse_percent,
        d.final_fit.nrmse_percent
    );
}

/// The AFM stress-relaxation test holds the cantilever at constant height for 30 s
/// while the force relaxes by 64 %: relaxation is what a spring-damper misses first.
#[test]
fn afm_stress_relaxation_names_relaxation_first() {
    let d = diagnosed("afm/cell-stress-relaxation.tab", None);
    assert_eq!(d.steps[0].effect.id(), "relaxation", "{}", d.final_model());
    let f = d.steps[0]
        .after
        .parameter(Param::RelaxedFraction)
        .expect("relaxation parameters");
    assert!((0.3..1.0).contains(&f), "relaxed fraction {f}");
    gap_shrinks("cell-stress-relaxation", &d, 0.25);
}

/// The steel nanoindentation loading curve (load ramp to 3000 µN, up to the end of the
/// ramp): a stiffening elastic law is what a linear spring misses first. The power law
/// is significant with Kick's exponent for a sharp indenter (P ∝ h², n near 2); the
/// exponential law fits this curve slightly better and is the one added (see the README
/// and the closing note of the issue: the expected power law is not what wins).
#[test]
fn steel_loading_names_a_stiffening_law_first() {
    let d = diagnosed("nanoindentation/steel-hysitron.txt", Some(Phase::Loading));
    let first = d.steps[0].effect.id();
    assert!(
        first == "power_law_stiffness" || first == "exponential_stiffness",
        "first effect {first}"
    );
    let power = d.steps[0]
        .candidates
        .iter()
        .find(|c| c.effect.id() == "power_law_stiffness")
        .expect("power law tried");
    assert!(
        power.significant,
        "power law not significant: ΔBIC {}",
        power.delta_bic
    );
    let n = power.fit.parameter(Param::N).expect("exponent");
    assert!((1.5..=2.2).contains(&n), "n = {n}");
    gap_shrinks("steel loading", &d, 0.2);
}

#[test]
fn gap_shrinks_on_the_whole_steel_indentation() {
    let d = diagnosed("nanoindentation/steel-hysitron.txt", None);
    gap_shrinks("steel-hysitron", &d, 0.25);
}

/// h_f/h_max of a nanoindentation file read directly (`Depth (nm)`, `Load (µN)` rows):
/// the depth where the unloading force first falls below 2 % of its peak after the
/// deepest point, and the deepest, both from the depth where the loading force first
/// exceeds 2 % of its peak.
fn residual_depth_ratio(path: &Path) -> f64 {
    let bytes = std::fs::read(path).unwrap();
    let rows: Vec<(f64, f64)> = String::from_utf8_lossy(&bytes)
        .lines()
        .filter_map(|l| {
            let mut f = l.split_whitespace().map(|x| x.parse::<f64>());
            match (f.next(), f.next(), f.next()) {
                (Some(Ok(d)), Some(Ok(f)), Some(Ok(_))) => Some((d, f)),
                _ => None,
            }
        })
        .collect();
    let peak = rows.iter().map(|r| r.1).fold(f64::MIN, f64::max);
    let deepest = (0..rows.len())
        .max_by(|a, b| rows[*a].0.total_cmp(&rows[*b].0))
        .unwrap();
    let onset = rows.iter().find(|r| r.1 > 0.02 * peak).unwrap().0;
    let residual = rows[deepest..]
        .iter()
        .find(|r| r.1 < 0.02 * peak)
        .unwrap()
        .0;
    (residual - onset) / (rows[deepest].0 - onset)
}

/// The whole steel indentation (load to 3000 µN, hold, unload): a metal indented by a
/// sharp tip keeps most of its depth (h_f/h_max 0.85 on this file). The plastic set is
/// named with its fraction within 0.1 of the file's own h_f/h_max (searched up to 0.4,
/// it was held there and a slow relaxation with a relaxed fraction of 3 made up the
/// rest), and a relaxed fraction above 1 is never reported as determined.
#[test]
fn steel_indentation_keeps_its_plastic_depth() {
    let name = "nanoindentation/steel-hysitron.txt";
    let d = diagnosed(name, None);
    assert!(
        d.effects_added().contains(&"plastic_set"),
        "{}",
        d.final_model()
    );
    let p = d
        .final_fit
        .parameter(Param::PlasticFraction)
        .expect("plastic fraction");
    let ratio = residual_depth_ratio(&data(name));
    assert!(
        (0.6..0.95).contains(&ratio) && (p - ratio).abs() <= 0.1,
        "plastic fraction {p} against h_f/h_max {ratio}"
    );
    for e in &d.final_fit.parameters {
        if e.param == Param::RelaxedFraction && e.determination == Determination::Determined {
            assert!(e.value <= 1.0, "relaxed fraction {}", e.value);
        }
    }
}

/// Ecoflex compression to 67 % strain at one speed (10 mm/min), loading only, never out
/// of contact: strong stiffening (local log-log slope 1.1 → 2.3), so a stiffening law
/// comes first; the record passes each depth at one speed, so no rate effect (damping,
/// delay, inertia, friction) may be named, the baseline's damping is held at 0, the
/// offset, which no free-space sample fixes, is not refitted, and neither a plastic set
/// (no unloading) nor a shifted later contact (no second contact) is tried: only elastic
/// laws can be named.
#[test]
fn silicone_compression_names_only_elastic_effects() {
    let d = diagnosed("silicone-compression/ecoflex-00-10-A1.csv", None);
    let first = d.steps[0].effect.id();
    assert!(
        first == "exponential_stiffness" || first == "power_law_stiffness",
        "first effect {first}"
    );
    for e in d.effects_added() {
        assert!(
            ["exponential_stiffness", "power_law_stiffness"].contains(&e),
            "{} named on a one-speed loading curve",
            e
        );
    }
    for e in [
        "depth_dependent_damping",
        "time_delay",
        "inertia",
        "coulomb_friction",
        "force_offset",
        "plastic_set",
        "contact_point_offset",
    ] {
        assert!(
            d.unidentifiable.iter().any(|u| u.id() == e),
            "{e} should be reported not identifiable: {:?}",
            d.unidentifiable
        );
    }
    for fit in std::iter::once(&d.baseline_fit).chain(d.steps.iter().map(|s| &s.after)) {
        assert_eq!(fit.parameter(Param::Lambda), Some(0.0), "damping not held");
        assert_eq!(fit.parameter(Param::TareN), Some(0.0), "tare refitted");
    }
    gap_shrinks("ecoflex", &d, 0.25);
    // The final elastic law is the material's, not a curve bent into shape by moving the
    // contact point: its secant over the first 1.5 mm of depth matches a straight line
    // through the loading curve over the same 1.5 mm (measured from the law's contact
    // point: the specimen's toe before it is not the material's).
    let record = host_sim::readers::read(&data("silicone-compression/ecoflex-00-10-A1.csv"), None)
        .expect("the Ecoflex file reads");
    let contact = d
        .final_fit
        .parameter(Param::ContactPositionM)
        .expect("a contact position");
    let span = 1.5e-3;
    let (mut sx, mut sy, mut sxx, mut sxy, mut count) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (x, f) in record.position_m.iter().zip(&record.force_n) {
        let depth = x - contact;
        if (0.0..=span).contains(&depth) {
            sx += depth;
            sy += f;
            sxx += depth * depth;
            sxy += depth * f;
            count += 1.0;
        }
    }
    assert!(count >= 20.0, "only {count} samples in the first 1.5 mm");
    let line = (count * sxy - sx * sy) / (count * sxx - sx * sx);
    let secant = d.final_fit.elastic_force_n(span) / span;
    assert!(
        (secant / line - 1.0).abs() <= 0.15,
        "secant {secant:.0} N/m against the loading curve's {line:.0} N/m ({})",
        d.final_model()
    );
}

/// The AFM creep record: its free-space force is strongly coloured (cantilever drift
/// and vibration; N_eff ≈ 2 % of N), and no candidate's gain (at most 0.3 % of the 6.5 %
/// NRMSE, none in the creep hold) survives the BIC on the effective samples. Counting
/// every sample, the workflow used to add Coulomb friction and depth-dependent damping to
/// brain tissue here; it must now add nothing and say why.
#[test]
fn afm_creep_adds_nothing_its_coloured_noise_cannot_support() {
    let d = diagnosed("afm/brain-creep-jpk.txt", None);
    let fraction = d.noise_sample_fraction.expect("free space measured");
    assert!(fraction < 0.1, "N_eff / N = {fraction}");
    assert!(
        d.steps.is_empty(),
        "added {:?} on coloured noise",
        d.effects_added()
    );
    assert!(d.final_candidates.iter().all(|c| !c.significant));
}

/// `host-sim diagnose FILE --json --out DIR`: one JSON object with the documented keys on
/// stdout, and the report, JSON and plots in the folder. One step (`--max-steps 1`):
/// relaxation on the linear spring, whose `model.json` turns into the Zener estimator
/// (the whole diagnosis adds a stiffening law, which no online estimator models beside
/// relaxation: refused, as `cli_model_spec_without_an_online_estimator_says_so` tests).
#[test]
fn cli_writes_report_plots_and_json() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(["diagnose", "--json", "--max-steps", "1", "--out"])
        .arg(dir.path())
        .arg(data("afm/cell-stress-relaxation.tab"))
        .output()
        .expect("the binary runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    assert_eq!(v["baseline"], "kelvin-voigt");
    let steps = v["steps"].as_array().expect("steps");
    assert_eq!(steps[0]["effect"], "relaxation");
    for s in steps {
        assert!(s["parameters"].is_object());
        assert!(
            s["nrmse_percent_after"].as_f64().unwrap()
                < s["nrmse_percent_before"].as_f64().unwrap()
        );
    }
    let added: Vec<&str> = v["effects_added"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e.as_str().unwrap())
        .collect();
    assert_eq!(added[0], "relaxation");
    let final_model = v["final_model"].as_str().unwrap();
    assert_eq!(
        final_model,
        ["kelvin-voigt"]
            .into_iter()
            .chain(added.iter().copied())
            .collect::<Vec<_>>()
            .join(" + ")
    );
    assert!(
        v["nrmse_percent_final"].as_f64().unwrap()
            < steps[0]["nrmse_percent_before"].as_f64().unwrap()
    );
    // The elastic law for a master device: ≥ 32 depths from 0, force 0 at 0 and
    // non-decreasing (a passive spring).
    let table = &v["elastic_force_table"];
    let depth: Vec<f64> = serde_json::from_value(table["depth_m"].clone()).unwrap();
    let force: Vec<f64> = serde_json::from_value(table["force_n"].clone()).unwrap();
    assert!(depth.len() >= 32 && depth.len() == force.len());
    assert_eq!((depth[0], force[0]), (0.0, 0.0));
    assert!(depth.windows(2).all(|w| w[1] > w[0]));
    assert!(force.windows(2).all(|w| w[1] >= w[0]), "{force:?}");
    assert!(*force.last().unwrap() > 0.0);
    for f in [
        "report.md",
        "diagnosis.json",
        "fit.png",
        "fit.svg",
        "residual.png",
        "residual.svg",
        "autocorrelation.png",
        "autocorrelation.svg",
    ] {
        let p = dir.path().join(f);
        assert!(
            std::fs::metadata(&p)
                .map(|m| m.len() > 100)
                .unwrap_or(false),
            "{} missing",
            p.display()
        );
    }
    let report = std::fs::read_to_string(dir.path().join("report.md")).unwrap();
    assert!(report.contains("| 1 | `relaxation`"), "{report}");
    assert!(report.contains("Residual RMS per phase"));

    // model.json: the final model, run over the measured motion, reproduces the
    // diagnosis's NRMSE (within 10 %), and turns into the online estimator of its
    // structure (relaxation on a linear spring: Zener).
    let spec = dir.path().join("model.json");
    let file = data("afm/cell-stress-relaxation.tab");
    let sim_dir = dir.path().join("sim");
    let sim = Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(["simulate", "--model-spec"])
        .arg(&spec)
        .arg("--motion")
        .arg(&file)
        .arg("--out")
        .arg(&sim_dir)
        .output()
        .expect("the binary runs");
    let stdout = String::from_utf8_lossy(&sim.stdout);
    assert!(
        sim.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&sim.stderr)
    );
    let nrmse: f64 = stdout
        .split("NRMSE ")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("no NRMSE in {stdout}"));
    let reported = v["nrmse_percent_final"].as_f64().unwrap();
    assert!(
        (nrmse / reported - 1.0).abs() <= 0.1,
        "simulated {nrmse} % against the diagnosis's {reported} %"
    );
    let csv = std::fs::read_to_string(sim_dir.join("simulation.csv")).unwrap();
    assert!(csv.starts_with("time_s,depth_m,measured_force_n,model_force_n\n"));
    assert!(csv.lines().count() > 1000);
    let est = Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(["estimate", "--json", "--model-spec"])
        .arg(&spec)
        .arg(&file)
        .output()
        .expect("the binary runs");
    let stderr = String::from_utf8_lossy(&est.stderr);
    assert!(est.status.success(), "{stderr}");
    assert!(stderr.contains("the online estimator zener"), "{stderr}");
    let e: serde_json::Value = serde_json::from_slice(&est.stdout).expect("one JSON object");
    assert_eq!(e["model"], "zener", "{e}");
}

/// A structure no online estimator models is refused with the effects named, and a
/// broken spec names its file and field.
#[test]
fn cli_model_spec_without_an_online_estimator_says_so() {
    let dir = tempfile::tempdir().expect("tempdir");
    let spec = dir.path().join("model.json");
    let text = r#"{"schema": "contact-model-spec/1", "source": "x", "effects": ["exponential_stiffness", "time_delay"],
        "elastic": {"law": "exponential", "kappa": 0.0, "m": 100.0, "b": 50.0},
        "damping_lambda": 1.0, "damping_exponent": 0.0, "relaxation": null, "mass_kg": null,
        "coulomb": null, "delay_s": 0.001, "plastic_fraction": null, "position_sign": 1.0,
        "contact_position_m": 0.0, "contact_shift_m": null, "force_offset_n": 0.0,
        "later_force_offset_n": null, "nrmse_percent": 1.0}"#;
    std::fs::write(&spec, text).unwrap();
    let run = |spec: &Path| {
        Command::new(env!("CARGO_BIN_EXE_host-sim"))
            .args(["estimate", "--model-spec"])
            .arg(spec)
            .arg(data("silicone-compression/ecoflex-00-10-A1.csv"))
            .output()
            .expect("the binary runs")
    };
    let out = run(&spec);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        stderr.contains("model.json")
            && stderr.contains("no online estimator")
            && stderr.contains("exponential_stiffness, time_delay"),
        "{stderr}"
    );
    std::fs::write(&spec, text.replace("\"m\": 100.0", "\"m\": -100.0")).unwrap();
    let out = run(&spec);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        stderr.contains("model.json") && stderr.contains("field elastic.m"),
        "{stderr}"
    );
}

/// Bad input: the reader's error with the file named, exit code 1, no panic.
#[test]
fn cli_reports_a_log_without_contact() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("flat.csv");
    let mut csv = String::from("time_s,position_m,force_n\n");
    for i in 0..1000 {
        csv.push_str(&format!(
            "{},{},{}\n",
            i as f64 * 1e-3,
            0.0,
            0.001 * ((i * 7919) % 13) as f64
        ));
    }
    std::fs::write(&path, csv).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(["diagnose", "--out"])
        .arg(dir.path())
        .arg(&path)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(
        stderr.contains(&format!(
            "error: {}: the position never changes",
            path.display()
        )),
        "{stderr}"
    );
}
