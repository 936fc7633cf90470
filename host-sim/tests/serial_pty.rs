//! `host-sim serial` through a pseudo-terminal pair: the host side opens the pty by path
//! exactly as it opens a USB-serial adapter, and a device thread on the other end answers
//! with the core's own `Configurator` and framing (the code the firmware runs), sending
//! telemetry with a deliberate gap in the sample index.

use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use estimator_core::conditioning::ContactState;
use estimator_core::protocol::{
    encode, Ack, CommandError, Configurator, DeviceMessage, DeviceSettings, FrameReader, Reply,
    Request, MAX_FRAME_BYTES,
};
use estimator_core::sensors::LoadCellCalibration;
use estimator_core::telemetry::{FirmwareVersion, ResetCause, TelemetryFrame};
use estimator_core::{AnyEstimator, Estimator, ModelKind, Scaling, Status};
use host_sim::serial::{run, Format, SerialArgs};
use serialport::SerialPort;

fn settings() -> DeviceSettings {
    DeviceSettings {
        model: ModelKind::HuntCrossley,
        forgetting: None,
        load_cell: LoadCellCalibration {
            reference_v: 3.3,
            full_scale_code: 65520,
            offset_v: 1.65,
            sensitivity_v_per_n: 0.05,
        },
        encoder_counts_per_m: 1e6,
        telemetry_rate_hz: 50,
    }
}

fn send(port: &mut dyn Write, message: &DeviceMessage) {
    let mut buffer = [0u8; MAX_FRAME_BYTES];
    port.write_all(encode(message, &mut buffer).unwrap())
        .unwrap();
}

/// The device: telemetry every 5 ms (sample index +20; index 100 is never sent), a reply
/// to every request.
fn device(mut port: serialport::TTYPort, stop: Arc<AtomicBool>) {
    let mut configurator = Configurator::new(settings());
    let mut reader = FrameReader::new();
    let mut sample = 0u32;
    let mut buffer = [0u8; 64];
    port.set_timeout(Duration::from_millis(5)).unwrap();
    while !stop.load(Ordering::Relaxed) {
        sample += 20;
        if sample != 100 {
            let model = configurator.settings().model;
            let estimator = AnyEstimator::try_default(model, Scaling::default()).unwrap();
            let frame = TelemetryFrame {
                firmware_version: FirmwareVersion {
                    major: 0,
                    minor: 2,
                    patch: 0,
                },
                reset_cause: ResetCause::PowerOn,
                sample,
                period_samples: 20,
                model,
                parameters: estimator.parameters(),
                contact: ContactState::FreeSpace,
                depth_m: 0.0,
                force_n: 0.0,
                status: Status::NO_CONTACT,
                overruns: 0,
                lost_periods: 0,
                frames_dropped: 0,
            };
            send(&mut port, &DeviceMessage::Telemetry(frame));
        }
        let n = match port.read(&mut buffer) {
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::TimedOut => 0,
            Err(e) => panic!("{e}"),
        };
        for &b in &buffer[..n] {
            let Some(inbound) = reader.push_decode::<Request>(b) else {
                continue;
            };
            let reply = match inbound {
                Ok(request) => Reply {
                    id: request.id,
                    result: configurator
                        // The amplifier reads 1.2 V.
                        .handle(&request.command, 1.2)
                        .map(|(ack, _)| ack),
                },
                Err(e) => Reply {
                    id: 0,
                    result: Err(CommandError::Malformed(e)),
                },
            };
            send(&mut port, &DeviceMessage::Reply(reply));
        }
    }
}

#[test]
fn commands_are_acknowledged_and_telemetry_streams_through_a_pty() {
    let (master, slave) = serialport::TTYPort::pair().expect("a pseudo-terminal pair");
    let path = slave.name().expect("the pty has a path");
    let stop = Arc::new(AtomicBool::new(false));
    let device = {
        let stop = stop.clone();
        std::thread::spawn(move || device(master, stop))
    };
    let args = SerialArgs {
        port: path.clone(),
        baud: 921_600,
        format: Format::Csv,
        send: vec![
            "model kelvin-voigt".into(),
            "rate 3".into(),
            "config".into(),
            "calibrate second 1".into(),
        ],
        reply_timeout_s: 2.0,
        frames: Some(12),
        seconds: None,
    };
    let mut port = serialport::new(&path, args.baud)
        .timeout(Duration::from_millis(20))
        .open()
        .expect("open the pty by path, as a USB adapter");
    let mut out = Vec::new();
    let mut log = Vec::new();
    let session = run(&mut *port, &args, &mut out, &mut log).unwrap();
    stop.store(true, Ordering::Relaxed);
    device.join().unwrap();
    let log = String::from_utf8(log).unwrap();
    let out = String::from_utf8(out).unwrap();
    println!("{log}\n{out}");

    assert_eq!(session.replies.len(), 4, "{log}");
    let ack = |i: usize| session.replies[i].clone().expect("a reply").result;
    let Ok(Ack::Settings(s)) = ack(0) else {
        panic!("{:?}", ack(0))
    };
    assert_eq!(s.model, ModelKind::KelvinVoigt);
    let Err(CommandError::Invalid { field, .. }) = ack(1) else {
        panic!("{:?}", ack(1))
    };
    assert_eq!(field.as_str(), "rate_hz");
    let Ok(Ack::Settings(s)) = ack(2) else {
        panic!("{:?}", ack(2))
    };
    assert_eq!((s.model, s.telemetry_rate_hz), (ModelKind::KelvinVoigt, 50));
    assert_eq!(ack(3), Err(CommandError::CalibrationIncomplete));

    // The stream: at least the requested frames, the gap at sample 100 counted once,
    // and the model change visible in the telemetry after its acknowledgement.
    assert!(session.frames >= 12, "{}", session.frames);
    assert_eq!(session.missing, 1, "{out}");
    let rows: Vec<&str> = out.lines().collect();
    assert_eq!(rows.len() as u64, session.frames);
    let missing_before = |sample: &str| -> Vec<String> {
        rows.iter()
            .filter(|r| r.starts_with(&format!("{sample},")))
            .map(|r| r.split(',').nth(9).unwrap().to_string())
            .collect()
    };
    assert_eq!(missing_before("120"), ["1"], "{out}");
    assert_eq!(missing_before("140"), ["0"], "{out}");
    assert!(rows.last().unwrap().contains(",kelvin-voigt,"), "{out}");
    assert_eq!(session.undecodable, 0);
}
