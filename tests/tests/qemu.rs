//! The firmware under QEMU `netduinoplus2` (an STM32F405): the same RTIC application, 1 kHz
//! task, framing, CRC, command parser and telemetry as the boards, sensors replaced by a
//! simulated plant (the paper's plastic layer). The run must converge within the
//! firmware's stated tolerance without missing a deadline, must fail when the estimator is
//! broken or the core faults, and must answer commands sent into its UART. Skips (with a
//! message) when `qemu-system-arm` is not installed; `.ci/run` installs it.

use std::io::{Read, Write};
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use estimator_core::conditioning::ContactState;
use estimator_core::protocol::{
    encode, Ack, Command as Cmd, CommandError, DeviceMessage, FrameError, Reply, Request,
    MAX_FRAME_BYTES,
};
use estimator_core::rls::Forgetting;
use estimator_core::telemetry::{ResetCause, TelemetryFrame};
use estimator_core::{AnyEstimator, Estimator, ModelKind, Scaling, Status};
use host_sim::telemetry::{Event, StreamDecoder};

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

/// Four runs in sequence: they share a target directory (the dependencies compile once)
/// and must not overwrite each other's ELF while it runs.
#[test]
fn qemu_smoke_runs() {
    if !qemu_available() {
        eprintln!("SKIPPED: qemu-system-arm is not installed (apt-get install qemu-system-arm)");
        return;
    }
    let elf = build("qemu");
    smoke_run_converges_without_missed_deadlines(&elf);
    commands_are_answered_and_change_the_telemetry(&elf);
    smoke_run_fails_when_the_estimator_is_broken();
    hardfault_exits_non_zero();
}

fn initial_parameters(kind: ModelKind) -> estimator_core::AnyParameters {
    AnyEstimator::try_default(kind, Scaling::default())
        .unwrap()
        .parameters()
}

fn smoke_run_converges_without_missed_deadlines(elf: &Path) {
    let (code, stderr, telemetry) = run(elf);
    assert_eq!(code, 0, "{stderr}");
    assert!(
        stderr.contains("verdict: converged within tolerance, no deadline missed"),
        "{stderr}"
    );
    assert!(stderr.contains("deadlines missed: 0; periods lost: 0"));
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
    // The UART stream decodes on the host with the core's parser: the boot report
    // first, then 50 Hz of telemetry for 8 s, none lost.
    let decoded = host_sim::telemetry::decode(&telemetry);
    assert!(decoded.errors.is_empty(), "{:?}", decoded.errors);
    let Some(DeviceMessage::Boot(boot)) = decoded.messages.first() else {
        panic!("{:?}", decoded.messages.first())
    };
    assert_eq!(boot.board.as_str(), "qemu");
    assert_eq!(boot.firmware_version, firmware_version());
    assert_eq!(boot.reset_cause, ResetCause::Unknown);
    assert!(boot.panic_message.is_empty() && !boot.settings_from_flash);
    assert!(
        decoded.frames.len() >= 390,
        "{} frames",
        decoded.frames.len()
    );
    assert_eq!(decoded.missing, 0);
    for pair in decoded.frames.windows(2) {
        assert_eq!(pair[1].sample - pair[0].sample, 20, "{pair:?}");
    }
    // The force offset is the start-up value, flagged, until the probe's free-space
    // approach confirms it (it starts moving at 0.5 s), before the first contact; it is
    // never corrected (the simulated load cell's zero does not move).
    let first = decoded.frames[0];
    assert!(first.status.contains(Status::OFFSET_UNCERTAIN), "{first:?}");
    let confirmed = decoded
        .frames
        .iter()
        .position(|f| !f.status.contains(Status::OFFSET_UNCERTAIN))
        .expect("offset never confirmed");
    assert!(
        decoded.frames[confirmed..]
            .iter()
            .all(|f| !f.status.contains(Status::OFFSET_UNCERTAIN)),
        "offset unconfirmed again"
    );
    let first_contact = decoded
        .frames
        .iter()
        .position(|f| f.contact == ContactState::InContact)
        .expect("no contact");
    assert!(confirmed < first_contact, "{confirmed} {first_contact}");
    assert!(decoded
        .frames
        .iter()
        .all(|f| !f.status.contains(Status::OFFSET_CORRECTED)));
    let last = decoded.frames.last().unwrap();
    assert_eq!(
        (last.overruns, last.lost_periods, last.frames_dropped),
        (0, 0, 0)
    );
    let estimator_core::AnyParameters::HuntCrossley(p) = last.parameters else {
        panic!("{last:?}")
    };
    assert!((p.n / 1.2 - 1.0).abs() < 0.03, "{p:?}");
}

fn firmware_version() -> estimator_core::telemetry::FirmwareVersion {
    let manifest = std::fs::read_to_string(workspace().join("firmware/Cargo.toml")).unwrap();
    let version = manifest
        .lines()
        .find_map(|l| l.strip_prefix("version = \""))
        .and_then(|v| v.strip_suffix('"'))
        .expect("firmware version in its manifest");
    let parts: Vec<u8> = version.split('.').map(|p| p.parse().unwrap()).collect();
    estimator_core::telemetry::FirmwareVersion {
        major: parts[0],
        minor: parts[1],
        patch: parts[2],
    }
}

/// The emulated UART, seen from the master device: a Unix-socket chardev, the core's
/// framing both ways, every decoded message kept in order.
struct Master {
    socket: UnixStream,
    events: mpsc::Receiver<Event>,
    seen: Vec<DeviceMessage>,
}

impl Master {
    fn connect(path: &Path) -> Master {
        let deadline = Instant::now() + Duration::from_secs(20);
        let socket = loop {
            match UnixStream::connect(path) {
                Ok(s) => break s,
                Err(e) if Instant::now() < deadline => {
                    let _ = e;
                    std::thread::sleep(Duration::from_millis(20));
                }
                Err(e) => panic!("QEMU's serial socket {}: {e}", path.display()),
            }
        };
        let mut reader = socket.try_clone().unwrap();
        let (sender, events) = mpsc::channel();
        std::thread::spawn(move || {
            let mut decoder = StreamDecoder::new();
            let mut buffer = [0u8; 512];
            while let Ok(n) = reader.read(&mut buffer) {
                if n == 0 {
                    break;
                }
                decoder.feed(&buffer[..n], |e| {
                    let _ = sender.send(e);
                });
            }
        });
        Master {
            socket,
            events,
            seen: Vec::new(),
        }
    }

    fn send_bytes(&mut self, bytes: &[u8]) {
        self.socket.write_all(bytes).unwrap();
    }

    fn send(&mut self, id: u16, command: Cmd) {
        let mut frame = [0u8; MAX_FRAME_BYTES];
        let bytes = encode(&Request { id, command }, &mut frame)
            .unwrap()
            .to_vec();
        self.send_bytes(&bytes);
    }

    /// The next message; a frame that does not decode fails the test.
    fn next(&mut self) -> DeviceMessage {
        match self.events.recv_timeout(Duration::from_secs(20)) {
            Ok(Event::Message { message, .. }) => {
                self.seen.push(message.clone());
                message
            }
            Ok(Event::Error { offset, error }) => panic!("undecodable frame at {offset}: {error}"),
            Err(e) => panic!(
                "no message from the firmware: {e}; seen {:?}",
                self.seen.last()
            ),
        }
    }

    /// Waits for the reply with `id`; the telemetry frames that came before it.
    fn reply(&mut self, id: u16) -> (Reply, Vec<TelemetryFrame>) {
        let mut frames = Vec::new();
        loop {
            match self.next() {
                DeviceMessage::Reply(r) if r.id == id => return (r, frames),
                DeviceMessage::Reply(r) => panic!("reply {r:?} while waiting for #{id}"),
                DeviceMessage::Telemetry(t) => frames.push(t),
                DeviceMessage::Boot(_) => {}
            }
        }
    }

    /// The telemetry frames taken after the last reply: the next `n` but the first (a
    /// frame may have been taken in the period the command was applied in).
    fn frames_after(&mut self, n: usize) -> Vec<TelemetryFrame> {
        self.frames(n + 1).split_off(1)
    }

    /// The next `n` telemetry frames.
    fn frames(&mut self, n: usize) -> Vec<TelemetryFrame> {
        let mut frames = Vec::new();
        while frames.len() < n {
            match self.next() {
                DeviceMessage::Telemetry(t) => frames.push(t),
                DeviceMessage::Reply(r) => panic!("unexpected reply {r:?}"),
                DeviceMessage::Boot(_) => {}
            }
        }
        frames
    }
}

fn settings_of(reply: &Reply) -> estimator_core::protocol::DeviceSettings {
    match &reply.result {
        Ok(Ack::Settings(s)) => *s,
        other => panic!("expected the settings, got {other:?}"),
    }
}

/// Commands into the emulated UART, as the master device sends them: every one is
/// answered, the malformed and invalid ones with errors, and the valid ones change what
/// the telemetry reports. QEMU runs the guest faster than real time (`-icount
/// sleep=off`), so the checks wait for acknowledgements and frames, never for a time.
fn commands_are_answered_and_change_the_telemetry(elf: &Path) {
    let socket = elf.with_file_name("uart.sock");
    let _ = std::fs::remove_file(&socket);
    let qemu = Command::new(workspace().join("firmware/qemu-run.sh"))
        .arg(elf)
        .env(
            "QEMU_SERIAL",
            format!("unix:{},server=on,wait=on", socket.display()),
        )
        .env("QEMU_TIMEOUT", "120")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the runner runs");
    let mut m = Master::connect(&socket);

    // Boot report first.
    let DeviceMessage::Boot(boot) = m.next() else {
        panic!("{:?}", m.seen)
    };
    assert_eq!(boot.board.as_str(), "qemu");

    // A frame that is not COBS + CRC, then a valid request with one bit flipped: both
    // answered with "malformed", id 0.
    m.send_bytes(&[0x01, 0x02, 0x03, 0x00]);
    let (r, _) = m.reply(0);
    assert!(matches!(r.result, Err(CommandError::Malformed(_))), "{r:?}");
    let mut frame = [0u8; MAX_FRAME_BYTES];
    let mut corrupted = encode(
        &Request {
            id: 9,
            command: Cmd::Tare,
        },
        &mut frame,
    )
    .unwrap()
    .to_vec();
    corrupted[2] ^= 0x10;
    m.send_bytes(&corrupted);
    let (r, _) = m.reply(0);
    assert_eq!(r.result, Err(CommandError::Malformed(FrameError::Crc)));

    // The configuration in force: the defaults (nothing in flash).
    m.send(1, Cmd::ReportConfig);
    let (r, _) = m.reply(1);
    let defaults = settings_of(&r);
    assert_eq!(
        (
            defaults.model,
            defaults.telemetry_rate_hz,
            defaults.forgetting
        ),
        (ModelKind::HuntCrossley, 50, None)
    );

    // An invalid value names its field and changes nothing.
    m.send(2, Cmd::SetForgetting(Some(Forgetting::Fixed { beta: 1.5 })));
    let (r, _) = m.reply(2);
    let Err(CommandError::Invalid { field, .. }) = &r.result else {
        panic!("{r:?}")
    };
    assert_eq!(field.as_str(), "beta");

    // Select a model: acknowledged with the new settings, and every frame after the
    // acknowledgement reports the new model with its initial parameters (free space).
    m.send(3, Cmd::SelectModel(ModelKind::KelvinVoigt));
    let (r, _) = m.reply(3);
    assert_eq!(settings_of(&r).model, ModelKind::KelvinVoigt);
    for f in m.frames_after(3) {
        assert_eq!(f.model, ModelKind::KelvinVoigt, "{f:?}");
        assert_eq!(f.parameters, initial_parameters(ModelKind::KelvinVoigt));
    }

    // Telemetry rate 100 Hz: frames every 10 samples.
    m.send(4, Cmd::SetTelemetryRate { rate_hz: 100 });
    let (r, _) = m.reply(4);
    assert_eq!(settings_of(&r).telemetry_rate_hz, 100);
    let frames = m.frames_after(4);
    for pair in frames.windows(2) {
        assert_eq!(pair[1].sample - pair[0].sample, 10, "{pair:?}");
        assert_eq!(pair[1].period_samples, 10);
    }

    // Tare while the probe is free: acknowledged; the offset is then confirmed.
    m.send(5, Cmd::Tare);
    let (r, _) = m.reply(5);
    assert_eq!(r.result, Ok(Ack::Done));
    for f in m.frames_after(3) {
        assert!(!f.status.contains(Status::OFFSET_UNCERTAIN), "{f:?}");
    }

    // Back to Hunt-Crossley before the probe reaches the material (t = 0.5 s).
    m.send(6, Cmd::SelectModel(ModelKind::HuntCrossley));
    let (r, _) = m.reply(6);
    assert_eq!(settings_of(&r).model, ModelKind::HuntCrossley);
    let after = m.frames_after(1);
    assert_eq!(after[0].model, ModelKind::HuntCrossley);

    // In contact, once the estimate has moved: pause, reset, and the frames after the
    // reset's acknowledgement carry the initial parameters, held while paused.
    let initial = initial_parameters(ModelKind::HuntCrossley);
    loop {
        let f = m.frames(1)[0];
        if f.contact == ContactState::InContact && f.parameters != initial {
            break;
        }
        assert!(f.sample < 6000, "no contact by 6 s: {f:?}");
    }
    m.send(7, Cmd::SetEstimation { enabled: false });
    assert_eq!(m.reply(7).0.result, Ok(Ack::Done));
    m.send(8, Cmd::ResetEstimator);
    assert_eq!(m.reply(8).0.result, Ok(Ack::Done));
    let held = m.frames_after(3);
    for f in &held {
        assert_eq!(f.parameters, initial, "{f:?}");
    }
    assert!(
        held.iter()
            .any(|f| f.status.contains(Status::ESTIMATION_PAUSED)),
        "{held:?}"
    );
    m.send(10, Cmd::SetEstimation { enabled: true });
    assert_eq!(m.reply(10).0.result, Ok(Ack::Done));
    let resumed = m.frames(20);
    assert!(
        resumed.iter().any(|f| f.parameters != initial),
        "estimation did not resume: {resumed:?}"
    );

    // The settings changed above are in force and were stored.
    m.send(11, Cmd::ReportConfig);
    let (r, _) = m.reply(11);
    let now = settings_of(&r);
    assert_eq!(
        (now.model, now.telemetry_rate_hz),
        (ModelKind::HuntCrossley, 100)
    );

    // Let the run finish: every frame until the end decodes, none lost, then the verdict.
    let mut tail = 0;
    while let Ok(event) = m.events.recv_timeout(Duration::from_secs(30)) {
        match event {
            Event::Message { missing_before, .. } => {
                assert_eq!(missing_before, 0);
                tail += 1;
            }
            Event::Error { offset, error } => panic!("undecodable frame at {offset}: {error}"),
        }
    }
    let out = qemu.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    println!("{stderr}\n{tail} messages after the last command");
    assert!(
        stderr.contains("deadlines missed: 0; periods lost: 0"),
        "{stderr}"
    );
    let last = m.seen.iter().rev().find_map(|msg| match msg {
        DeviceMessage::Telemetry(t) => Some(*t),
        _ => None,
    });
    assert_eq!(last.map(|t| t.frames_dropped), Some(0));
    // The estimator was reset in contact at a guest time that depends on the host's
    // pace (QEMU runs ahead of real time), so convergence by the end is the smoke run's
    // check, not this one's: here the run must end with a verdict, no fault, no panic
    // and no deadline missed.
    assert!(matches!(out.status.code(), Some(0 | 1)), "{stderr}");
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
