//! `host-sim serial PORT`: live telemetry from the firmware's UART as CSV or JSON lines,
//! with the frames lost on the way counted, and operator commands (`--send`), each
//! waited for until the firmware acknowledges it. The framing, CRC and message types are
//! the core's [`estimator_core::protocol`], the very code the firmware runs; the stream
//! decoder is [`crate::telemetry::StreamDecoder`], which also reads captured files
//! (`host-sim telemetry FILE`).
//!
//! Commands, as text (`--send`, repeatable, sent in order):
//!
//! | text | command |
//! |---|---|
//! | `reset` | [`Command::ResetEstimator`] |
//! | `model NAME` (`kelvin-voigt`, `zener`, `hunt-crossley`, `hunt-crossley-single-stage`, `hammerstein`, `hammerstein2`) | [`Command::SelectModel`] |
//! | `forgetting fixed BETA` / `forgetting adaptive A1 A2 A3` / `forgetting default` | [`Command::SetForgetting`] (eq. 22 / eq. 24) |
//! | `tare` | [`Command::Tare`] |
//! | `calibrate first FORCE_N` / `calibrate second FORCE_N` | [`Command::CalibrateLoadCell`] |
//! | `encoder-scale COUNTS_PER_M` | [`Command::SetEncoderScale`] |
//! | `rate HZ` | [`Command::SetTelemetryRate`] |
//! | `estimation on` / `estimation off` | [`Command::SetEstimation`] |
//! | `config` | [`Command::ReportConfig`] |

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use estimator_core::protocol::{
    encode, CalibrationPoint, Command, DeviceMessage, Reply, Request, MAX_FRAME_BYTES,
};
use estimator_core::rls::{AdaptiveForgetting, Forgetting};
use estimator_core::telemetry::TelemetryFrame;
use estimator_core::ModelKind;

use crate::telemetry::{Event, StreamDecoder};

/// Output format of the stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// One CSV row per telemetry frame on stdout; boot reports, replies and errors as text
    /// on stderr.
    Csv,
    /// One JSON object per message (and per undecodable frame) on stdout.
    Json,
}

/// Arguments of `host-sim serial`.
#[derive(Debug, Clone, clap::Args)]
pub struct SerialArgs {
    /// Serial port (e.g. /dev/ttyUSB0, or a pseudo-terminal).
    pub port: String,
    /// Baud rate (the firmware's is 921 600 bit/s).
    #[arg(long, default_value_t = 921_600)]
    pub baud: u32,
    /// Output format.
    #[arg(long, value_enum, default_value = "csv")]
    pub format: Format,
    /// Command to send (repeatable, in order); e.g. 'model kelvin-voigt', 'tare',
    /// 'forgetting adaptive 0.05 10 20'. With commands and no --frames/--seconds, exits
    /// after the last reply.
    #[arg(long = "send")]
    pub send: Vec<String>,
    /// Seconds to wait for each reply.
    #[arg(long, default_value_t = 2.0)]
    pub reply_timeout_s: f64,
    /// Stop after this many telemetry frames.
    #[arg(long)]
    pub frames: Option<u64>,
    /// Stop after this many seconds.
    #[arg(long)]
    pub seconds: Option<f64>,
}

/// Parses one command of the table in the module docs.
///
/// # Errors
/// A message naming the word that is wrong and what was expected.
pub fn parse_command(text: &str) -> Result<Command> {
    let words: Vec<&str> = text.split_whitespace().collect();
    let number = |i: usize, what: &str| -> Result<f32> {
        let word = words
            .get(i)
            .with_context(|| format!("`{text}`: missing {what}"))?;
        word.parse::<f32>()
            .with_context(|| format!("`{text}`: {what} `{word}` is not a number"))
    };
    let command = match words.as_slice() {
        ["reset"] => Command::ResetEstimator,
        ["tare"] => Command::Tare,
        ["config"] => Command::ReportConfig,
        ["model", name] => Command::SelectModel(ModelKind::from_name(name).with_context(|| {
            let names: Vec<_> = ModelKind::ALL.iter().map(|k| k.name()).collect();
            format!(
                "`{text}`: unknown model, expected one of {}",
                names.join(", ")
            )
        })?),
        ["forgetting", "default"] => Command::SetForgetting(None),
        ["forgetting", "fixed", _] => Command::SetForgetting(Some(Forgetting::Fixed {
            beta: number(2, "beta")?,
        })),
        ["forgetting", "adaptive", _, _, _] => {
            Command::SetForgetting(Some(Forgetting::Adaptive(AdaptiveForgetting {
                alpha1: number(2, "alpha1")?,
                alpha2: number(3, "alpha2")?,
                alpha3: number(4, "alpha3")?,
            })))
        }
        ["calibrate", point, _] => Command::CalibrateLoadCell {
            point: match *point {
                "first" => CalibrationPoint::First,
                "second" => CalibrationPoint::Second,
                _ => bail!("`{text}`: expected `calibrate first|second FORCE_N`"),
            },
            force_n: number(2, "force_n")?,
        },
        ["encoder-scale", _] => Command::SetEncoderScale {
            counts_per_m: number(1, "counts_per_m")?,
        },
        ["rate", hz] => Command::SetTelemetryRate {
            rate_hz: hz
                .parse()
                .with_context(|| format!("`{text}`: rate `{hz}` is not a whole number of Hz"))?,
        },
        ["estimation", "on"] => Command::SetEstimation { enabled: true },
        ["estimation", "off"] => Command::SetEstimation { enabled: false },
        _ => bail!(
            "`{text}`: unknown command (reset, model NAME, forgetting fixed|adaptive|default, \
             tare, calibrate first|second FORCE_N, encoder-scale COUNTS_PER_M, rate HZ, \
             estimation on|off, config)"
        ),
    };
    Ok(command)
}

/// Header of the CSV output.
pub const CSV_HEADER: &str = "sample,model,contact,depth_m,force_n,status,overruns,lost_periods,frames_dropped,missing_before,parameters";

/// One CSV row; the parameters as `name=value` pairs separated by spaces.
pub fn csv_row(t: &TelemetryFrame, missing_before: u64) -> String {
    let parameters: Vec<String> = t
        .parameters
        .iter()
        .map(|(name, value)| format!("{name}={value:e}"))
        .collect();
    format!(
        "{},{},{:?},{:e},{:e},{:#x},{},{},{},{},{}",
        t.sample,
        t.model.name(),
        t.contact,
        t.depth_m,
        t.force_n,
        t.status.bits(),
        t.overruns,
        t.lost_periods,
        t.frames_dropped,
        missing_before,
        parameters.join(" ")
    )
}

/// Writes `event` to `out` (data) and `log` (human-readable) in `format`.
///
/// # Errors
/// I/O errors of the writers.
pub fn write_event(
    event: &Event,
    format: Format,
    out: &mut dyn Write,
    log: &mut dyn Write,
) -> Result<()> {
    match (format, event) {
        (
            Format::Json,
            Event::Message {
                message,
                missing_before,
            },
        ) => writeln!(
            out,
            "{}",
            serde_json::json!({ "message": message, "missing_before": missing_before })
        )?,
        (Format::Json, Event::Error { offset, error }) => writeln!(
            out,
            "{}",
            serde_json::json!({ "undecodable": { "offset": offset, "error": error.to_string() } })
        )?,
        (
            Format::Csv,
            Event::Message {
                message: DeviceMessage::Telemetry(t),
                missing_before,
            },
        ) => writeln!(out, "{}", csv_row(t, *missing_before))?,
        (Format::Csv, Event::Message { message, .. }) => {
            writeln!(log, "{}", serde_json::to_string(message)?)?
        }
        (Format::Csv, Event::Error { offset, error }) => {
            writeln!(log, "byte {offset}: undecodable frame: {error}")?
        }
    }
    Ok(())
}

/// Totals of a session.
#[derive(Debug, Default, Clone, PartialEq)]
pub struct Session {
    /// Telemetry frames received.
    pub frames: u64,
    /// Telemetry frames missing by sample index.
    pub missing: u64,
    /// Frames that did not decode.
    pub undecodable: u64,
    /// The reply to each sent command, in order (`None`: no reply within the timeout).
    pub replies: Vec<Option<Reply>>,
}

/// Runs a session on `port` (anything readable with a short timeout and writable):
/// sends `args.send` one by one, each after the reply to the previous one, and streams
/// what arrives to `out` / `log` until the commands are answered and the frame or time
/// limit (if any) is reached.
///
/// # Errors
/// Unparsable commands (before anything is sent), I/O errors other than timeouts.
pub fn run<P: Read + Write + ?Sized>(
    port: &mut P,
    args: &SerialArgs,
    out: &mut dyn Write,
    log: &mut dyn Write,
) -> Result<Session> {
    let commands = args
        .send
        .iter()
        .map(|text| parse_command(text))
        .collect::<Result<Vec<_>>>()?;
    let start = Instant::now();
    let reply_timeout = Duration::from_secs_f64(args.reply_timeout_s.max(0.0));
    let mut decoder = StreamDecoder::new();
    let mut session = Session::default();
    let mut next = 0usize;
    let mut waiting: Option<(u16, Instant)> = None;
    let mut buffer = [0u8; 256];
    loop {
        if waiting.is_none() && next < commands.len() {
            let id = u16::try_from(next + 1).context("too many commands")?;
            let mut frame = [0u8; MAX_FRAME_BYTES];
            let bytes = encode(
                &Request {
                    id,
                    command: commands[next],
                },
                &mut frame,
            )
            .context("encoding a command")?;
            port.write_all(bytes).context("writing to the port")?;
            port.flush().context("writing to the port")?;
            writeln!(log, "sent #{id}: {}", args.send[next])?;
            waiting = Some((id, Instant::now()));
            next += 1;
        }
        if let Some((id, since)) = waiting {
            if since.elapsed() > reply_timeout {
                writeln!(
                    log,
                    "no reply to #{id} within {:.1} s",
                    args.reply_timeout_s
                )?;
                session.replies.push(None);
                waiting = None;
            }
        }
        let commands_done = next == commands.len() && waiting.is_none();
        let frames_done = args.frames.is_some_and(|n| session.frames >= n);
        let time_done = args
            .seconds
            .is_some_and(|s| start.elapsed().as_secs_f64() >= s);
        let limited = args.frames.is_some() || args.seconds.is_some();
        if commands_done && (frames_done || time_done || (!limited && !commands.is_empty())) {
            break;
        }
        let n = match port.read(&mut buffer) {
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::TimedOut => 0,
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => 0,
            Err(e) => return Err(e).context("reading the port"),
        };
        let mut result = Ok(());
        decoder.feed(&buffer[..n], |event| {
            match &event {
                Event::Message {
                    message: DeviceMessage::Telemetry(_),
                    ..
                } => session.frames += 1,
                Event::Message {
                    message: DeviceMessage::Reply(reply),
                    ..
                } => {
                    if waiting.is_some_and(|(id, _)| id == reply.id) {
                        session.replies.push(Some(reply.clone()));
                        waiting = None;
                    }
                }
                Event::Error { .. } => session.undecodable += 1,
                Event::Message { .. } => {}
            }
            if result.is_ok() {
                result = write_event(&event, args.format, out, log);
            }
        });
        result?;
    }
    session.missing = decoder.missing;
    writeln!(
        log,
        "{} telemetry frames, {} missing by sample index, {} undecodable",
        session.frames, session.missing, session.undecodable
    )?;
    Ok(session)
}

/// `host-sim serial`: opens the port and runs the session on stdout / stderr. Fails if a
/// command was refused or not answered.
///
/// # Errors
/// The port cannot be opened, I/O errors, a refused or unanswered command.
pub fn cli(args: &SerialArgs) -> Result<()> {
    let mut port = serialport::new(&args.port, args.baud)
        .timeout(Duration::from_millis(50))
        .open()
        .with_context(|| format!("{}: opening the serial port", args.port))?;
    if args.format == Format::Csv {
        println!("{CSV_HEADER}");
    }
    let session = run(
        &mut *port,
        args,
        &mut std::io::stdout().lock(),
        &mut std::io::stderr().lock(),
    )?;
    let refused = session
        .replies
        .iter()
        .filter(|r| !matches!(r, Some(Reply { result: Ok(_), .. })))
        .count();
    if refused > 0 {
        bail!(
            "{refused} of {} commands refused or unanswered",
            args.send.len()
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use estimator_core::protocol::CommandError;

    #[test]
    fn every_command_of_the_table_parses() {
        let cases = [
            ("reset", Command::ResetEstimator),
            ("tare", Command::Tare),
            ("config", Command::ReportConfig),
            ("model zener", Command::SelectModel(ModelKind::Zener)),
            ("forgetting default", Command::SetForgetting(None)),
            (
                "forgetting fixed 0.995",
                Command::SetForgetting(Some(Forgetting::Fixed { beta: 0.995 })),
            ),
            (
                "forgetting adaptive 0.05 10 20",
                Command::SetForgetting(Some(Forgetting::Adaptive(AdaptiveForgetting {
                    alpha1: 0.05,
                    alpha2: 10.0,
                    alpha3: 20.0,
                }))),
            ),
            (
                "calibrate second 9.81",
                Command::CalibrateLoadCell {
                    point: CalibrationPoint::Second,
                    force_n: 9.81,
                },
            ),
            (
                "encoder-scale 2e6",
                Command::SetEncoderScale { counts_per_m: 2e6 },
            ),
            ("rate 100", Command::SetTelemetryRate { rate_hz: 100 }),
            ("estimation off", Command::SetEstimation { enabled: false }),
        ];
        for (text, command) in cases {
            assert_eq!(parse_command(text).unwrap(), command, "{text}");
        }
    }

    #[test]
    fn bad_commands_name_what_is_wrong() {
        for (text, word) in [
            ("model maxwell", "unknown model"),
            ("forgetting fixed x", "beta `x`"),
            ("rate 2.5", "rate `2.5`"),
            ("calibrate third 1", "calibrate first|second"),
            ("jump", "unknown command"),
        ] {
            let e = parse_command(text).unwrap_err().to_string();
            assert!(e.contains(word), "{text}: {e}");
        }
    }

    #[test]
    fn csv_rows_have_the_header_s_columns_and_replies_go_to_the_log() {
        let decoded = crate::telemetry::decode(
            &std::fs::read(
                std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                    .join("tests/fuzz_regressions/seed-telemetry.bin"),
            )
            .unwrap(),
        );
        let row = csv_row(&decoded.frames[2], 2);
        assert_eq!(
            row.split(',').count(),
            CSV_HEADER.split(',').count(),
            "{row}"
        );
        assert!(row.starts_with("100,hunt-crossley,InContact,"), "{row}");
        assert!(row.contains(",2,k="), "{row}");
        let reply = DeviceMessage::Reply(Reply {
            id: 3,
            result: Err(CommandError::invalid("beta", "(0, 1]")),
        });
        let mut out = Vec::new();
        let mut log = Vec::new();
        let event = Event::Message {
            message: reply,
            missing_before: 0,
        };
        write_event(&event, Format::Csv, &mut out, &mut log).unwrap();
        assert!(out.is_empty());
        assert!(String::from_utf8_lossy(&log).contains("beta"));
        write_event(&event, Format::Json, &mut out, &mut log).unwrap();
        let json: serde_json::Value = serde_json::from_slice(&out).unwrap();
        assert_eq!(json["message"]["Reply"]["id"], 3);
    }
}
