//! The firmware under QEMU `netduinoplus2` (an STM32F405): the same RTIC application and
//! 1 kHz task, sensors replaced by a simulated plant (the paper's plastic layer). The run
//! must converge within the firmware's stated tolerance without missing a deadline, and
//! must fail when the estimator is broken or the core faults. Skips (with a message) when
//! `qemu-system-arm` is not installed; `.ci/run` installs it.

use std::path::{Path, PathBuf};
use std::process::Command;

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn qemu_available() -> bool {
    Command::new("qemu-system-arm")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

/// Builds the firmware with `features` into a target directory of its own (the outer
/// cargo holds the workspace's lock) and returns a copy of the ELF named after them.
fn build(features: &str) -> PathBuf {
    let target_dir = workspace().join("target").join("qemu-tests");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut command = Command::new(cargo);
    if Command::new("flip-link").arg("--version").output().is_err() {
        // .cargo/config.toml links with flip-link; without it, rust-lld (no stack guard).
        eprintln!("note: flip-link not installed, linking with rust-lld (cargo install flip-link)");
        command.env("CARGO_TARGET_THUMBV7EM_NONE_EABIHF_LINKER", "rust-lld");
    }
    let out = command
        .current_dir(workspace())
        .env("CARGO_TARGET_DIR", &target_dir)
        .args([
            "build",
            "-p",
            "firmware",
            "--release",
            "--target",
            "thumbv7em-none-eabihf",
            "--features",
            features,
        ])
        .output()
        .expect("cargo runs");
    assert!(
        out.status.success(),
        "firmware build failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let elf = target_dir.join("thumbv7em-none-eabihf/release/firmware");
    let copy = target_dir.join(format!("firmware-{features}"));
    std::fs::copy(&elf, &copy).expect("copy the ELF");
    copy
}

/// Runs `elf` through the repository's QEMU runner; (exit code, stderr, telemetry bytes).
fn run(elf: &Path) -> (i32, String, Vec<u8>) {
    let telemetry = elf.with_file_name("telemetry.bin");
    let _ = std::fs::remove_file(&telemetry);
    let out = Command::new(workspace().join("firmware/qemu-run.sh"))
        .arg(elf)
        .env("QEMU_TELEMETRY", &telemetry)
        .env("QEMU_TIMEOUT", "120")
        .output()
        .expect("the runner runs");
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    println!("{stderr}\n{}", String::from_utf8_lossy(&out.stdout));
    (
        out.status.code().unwrap_or(-1),
        stderr,
        std::fs::read(&telemetry).unwrap_or_default(),
    )
}

/// One test, three builds in sequence: they share a target directory (the dependencies
/// compile once) and must not overwrite each other's ELF while it runs.
#[test]
fn qemu_smoke_runs() {
    if !qemu_available() {
        eprintln!("SKIPPED: qemu-system-arm is not installed (apt-get install qemu-system-arm)");
        return;
    }
    smoke_run_converges_without_missed_deadlines();
    smoke_run_fails_when_the_estimator_is_broken();
    hardfault_exits_non_zero();
}

fn smoke_run_converges_without_missed_deadlines() {
    let (code, stderr, telemetry) = run(&build("qemu"));
    assert_eq!(code, 0, "{stderr}");
    assert!(
        stderr.contains("verdict: converged within tolerance, no deadline missed"),
        "{stderr}"
    );
    assert!(stderr.contains("deadlines missed: 0"));
    for model in [
        "kelvin-voigt",
        "zener",
        "hunt-crossley",
        "hunt-crossley-single-stage",
        "hammerstein",
        "hammerstein2",
    ] {
        assert!(
            stderr.contains(&format!("{model} step: ")),
            "no cost for {model}"
        );
    }
    // The UART stream decodes on the host: 50 Hz for 8 s, none lost.
    let decoded = host_sim::telemetry::decode(&telemetry);
    assert!(decoded.errors.is_empty(), "{:?}", decoded.errors);
    assert!(
        decoded.frames.len() >= 390,
        "{} frames",
        decoded.frames.len()
    );
    assert_eq!(decoded.missing, 0);
    let last = decoded.frames.last().unwrap();
    assert_eq!(last.overruns, 0);
    let estimator_core::AnyParameters::HuntCrossley(p) = last.parameters else {
        panic!("{last:?}")
    };
    assert!((p.n / 1.2 - 1.0).abs() < 0.03, "{p:?}");
}

fn smoke_run_fails_when_the_estimator_is_broken() {
    // The encoder scale is doubled: the elastic force at 1 mm comes out 2^-1.2 too low.
    let (code, stderr, _) = run(&build("qemu-broken-estimator"));
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("verdict: NOT converged"), "{stderr}");
}

fn hardfault_exits_non_zero() {
    let (code, stderr, _) = run(&build("qemu-hardfault"));
    assert_eq!(code, 3, "{stderr}");
    assert!(stderr.contains("HARDFAULT"), "{stderr}");
}
