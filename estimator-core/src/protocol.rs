//! The wire protocol between the firmware and its master device: one definition used by
//! the boards, the QEMU build and the host tools, so that every parser that runs on a
//! board is the parser the host tests exercise.
//!
//! # Framing
//! Every message, in both directions, is one frame:
//!
//! ```text
//! COBS( version: u8 | postcard(message) | CRC-16/CCITT-FALSE(version | message), little endian ) 0x00
//! ```
//!
//! - [`PROTOCOL_VERSION`] first, so that a decoder refuses a frame of another version
//!   before it parses its body ([`FrameError::Version`]).
//! - The CRC is inside the COBS frame: a flipped bit anywhere is caught
//!   ([`FrameError::Crc`]); a lost byte either breaks COBS or the CRC.
//! - 0x00 ends a frame; COBS guarantees none inside. Empty frames (0x00 0x00) are
//!   skipped by the readers, so a sender may pad with zeros.
//! - No frame exceeds [`MAX_FRAME_BYTES`] on the wire.
//!
//! Device → host: [`DeviceMessage`] (telemetry, boot report, replies). Host → device:
//! [`Request`] (an id chosen by the host, echoed in the reply, and a [`Command`]).
//!
//! # Commands
//! [`Configurator::handle`] validates a command against the [`DeviceSettings`] and says
//! what the firmware must do (rebuild the estimator, tare, persist, …); every request is
//! answered by exactly one [`Reply`], [`Ack`] or [`CommandError`], never a panic. A
//! frame that does not decode is answered with request id 0 and
//! [`CommandError::Malformed`].
//!
//! # Byte ports
//! [`TxQueue`] buffers whole frames and hands bytes to a [`BytePort`] that may accept any
//! number of them per call, including none (a UART whose data register is still full):
//! it never blocks and never panics, and a frame that does not fit is refused whole and
//! counted ([`TxQueue::frames_dropped`]), never truncated. [`FrameReader`] collects
//! received bytes into frames.

use serde::{de::DeserializeOwned, Deserialize, Serialize};

use crate::any::ModelKind;
use crate::error::ConfigError;
use crate::rls::Forgetting;
use crate::sensors::LoadCellCalibration;
use crate::telemetry::{FirmwareVersion, ResetCause, TelemetryFrame};

/// Version byte that starts every frame. 1 was the unversioned, CRC-less telemetry of the
/// first firmware.
pub const PROTOCOL_VERSION: u8 = 2;

/// Largest frame on the wire, bytes: COBS overhead and the 0x00 terminator included.
pub const MAX_FRAME_BYTES: usize = 192;

/// Largest frame before COBS (version, postcard body, CRC), bytes. COBS adds one byte per
/// 254 and the terminator one more.
pub const MAX_RAW_BYTES: usize = MAX_FRAME_BYTES - 2;

/// Bytes of a panic message carried by [`BootReport`] (longer messages are cut).
pub const PANIC_MESSAGE_BYTES: usize = 96;

/// Bytes of a field name or a reason in [`CommandError::Invalid`].
pub const TEXT_BYTES: usize = 48;

/// CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF), the `crc` crate's `CRC_16_IBM_3740`.
const CRC16: crc::Crc<u16> = crc::Crc::<u16>::new(&crc::CRC_16_IBM_3740);

/// Text of bounded length (field names, reasons, panic messages).
pub type Text<const N: usize> = heapless::String<N>;

/// `s` cut to at most `N` bytes at a character boundary.
pub fn bounded_text<const N: usize>(s: &str) -> Text<N> {
    let mut out = Text::new();
    for c in s.chars() {
        if out.push(c).is_err() {
            break;
        }
    }
    out
}

/// Why a received frame was refused. Each is answered with [`CommandError::Malformed`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum FrameError {
    /// Longer than [`MAX_FRAME_BYTES`] before its 0x00: discarded up to the next 0x00.
    TooLong,
    /// Not valid COBS.
    Cobs,
    /// Shorter than version + CRC.
    TooShort,
    /// The CRC does not match: a corrupted byte.
    Crc,
    /// Another protocol version (the received version byte).
    Version(u8),
    /// Valid frame whose body is not a message of the expected type.
    Body,
    /// The message does not fit [`MAX_FRAME_BYTES`] (encoder side).
    Overflow,
}

impl core::fmt::Display for FrameError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            FrameError::TooLong => write!(f, "frame longer than {MAX_FRAME_BYTES} bytes"),
            FrameError::Cobs => write!(f, "invalid COBS"),
            FrameError::TooShort => write!(f, "frame shorter than version + CRC"),
            FrameError::Crc => write!(f, "CRC mismatch"),
            FrameError::Version(v) => {
                write!(f, "protocol version {v}, expected {PROTOCOL_VERSION}")
            }
            FrameError::Body => write!(f, "frame body is not a valid message"),
            FrameError::Overflow => write!(f, "message larger than a frame"),
        }
    }
}

impl core::error::Error for FrameError {}

/// Encodes `message` as one frame (terminator included) into `out`; returns the frame.
///
/// # Errors
/// [`FrameError::Overflow`] if it does not fit [`MAX_FRAME_BYTES`] or `out`.
pub fn encode<'a, T: Serialize>(message: &T, out: &'a mut [u8]) -> Result<&'a [u8], FrameError> {
    let mut raw = [0u8; MAX_RAW_BYTES];
    let (version, rest) = raw.split_at_mut(1);
    version[0] = PROTOCOL_VERSION;
    let body_len = postcard::to_slice(message, rest)
        .map_err(|_| FrameError::Overflow)?
        .len();
    let crc_at = 1 + body_len;
    let crc = CRC16.checksum(raw.get(..crc_at).ok_or(FrameError::Overflow)?);
    raw.get_mut(crc_at..crc_at + 2)
        .ok_or(FrameError::Overflow)?
        .copy_from_slice(&crc.to_le_bytes());
    let limit = out.len().min(MAX_FRAME_BYTES);
    let dest = out.get_mut(..limit).ok_or(FrameError::Overflow)?;
    let n = cobs::try_encode(raw.get(..crc_at + 2).ok_or(FrameError::Overflow)?, dest)
        .map_err(|_| FrameError::Overflow)?;
    *dest.get_mut(n).ok_or(FrameError::Overflow)? = 0;
    out.get(..n + 1).ok_or(FrameError::Overflow)
}

/// Decodes one frame, given without or with its 0x00 terminator; `frame` is decoded in
/// place (its bytes are overwritten).
///
/// # Errors
/// The [`FrameError`] that names why the frame was refused.
pub fn decode<T: DeserializeOwned>(frame: &mut [u8]) -> Result<T, FrameError> {
    let frame = match frame.split_last_mut() {
        Some((0, body)) => body,
        _ => frame,
    };
    if frame.len() > MAX_FRAME_BYTES {
        return Err(FrameError::TooLong);
    }
    let n = cobs::decode_in_place(frame).map_err(|_| FrameError::Cobs)?;
    let raw = frame.get(..n).ok_or(FrameError::Cobs)?;
    if raw.len() < 3 {
        return Err(FrameError::TooShort);
    }
    let (checked, crc) = raw.split_at(raw.len() - 2);
    if CRC16.checksum(checked).to_le_bytes() != [crc[0], crc[1]] {
        return Err(FrameError::Crc);
    }
    match checked.split_first() {
        Some((&PROTOCOL_VERSION, body)) => postcard::from_bytes(body).map_err(|_| FrameError::Body),
        Some((&v, _)) => Err(FrameError::Version(v)),
        None => Err(FrameError::TooShort),
    }
}

/// What the firmware reports once after every start (and on [`Command::ReportConfig`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BootReport {
    /// Firmware version.
    pub firmware_version: FirmwareVersion,
    /// Board the firmware was built for (`odrive-v3`, `vesc-6`, `qemu`).
    pub board: Text<16>,
    /// Why the MCU started.
    pub reset_cause: ResetCause,
    /// The message of the panic that caused the last reset, kept in RAM across it; empty
    /// if the last reset was not a panic.
    pub panic_message: Text<PANIC_MESSAGE_BYTES>,
    /// `true` if the settings came from flash, `false` if they are the build's defaults
    /// (nothing stored yet, or the stored record was unreadable or invalid).
    pub settings_from_flash: bool,
}

/// Device → host.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[allow(clippy::large_enum_variant)]
pub enum DeviceMessage {
    /// Periodic estimate and loop health.
    Telemetry(TelemetryFrame),
    /// Start-up report.
    Boot(BootReport),
    /// Answer to one [`Request`].
    Reply(Reply),
}

/// Host → device: a command and the id its [`Reply`] will carry (use ids ≥ 1: 0 answers
/// frames that did not decode).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Request {
    /// Chosen by the host, echoed in the reply.
    pub id: u16,
    /// What to do.
    pub command: Command,
}

/// Which of the two points of a load-cell calibration a measurement is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum CalibrationPoint {
    /// First point (typically the unloaded probe, 0 N).
    First,
    /// Second point (a known weight); completes the calibration.
    Second,
}

/// Operator commands.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Command {
    /// Restart the estimator from its initial parameters (filters, tare and contact state
    /// are kept).
    ResetEstimator,
    /// Estimate another model (persisted).
    SelectModel(ModelKind),
    /// Forgetting policy of every RLS stage: fixed β (eq. 22) or adaptive (eq. 24);
    /// `None` restores each model's default (persisted; restarts the estimator).
    SetForgetting(Option<Forgetting>),
    /// Declare the probe free now: the next sample's force becomes the offset.
    Tare,
    /// Two-point load-cell calibration: the mean amplifier voltage of the last samples is
    /// taken as the output for `force_n` \[N\]. The second point completes it (persisted).
    CalibrateLoadCell {
        /// Which point this is.
        point: CalibrationPoint,
        /// Known force applied now \[N\].
        force_n: f32,
    },
    /// Encoder counts per metre after ×4 quadrature decoding (persisted).
    SetEncoderScale {
        /// Counts per metre, > 0.
        counts_per_m: f32,
    },
    /// Telemetry rate \[Hz\]: a divisor of the 1 kHz sample rate, at most
    /// [`MAX_TELEMETRY_RATE_HZ`] (persisted).
    SetTelemetryRate {
        /// Frames per second.
        rate_hz: u16,
    },
    /// Pause (`false`) or resume (`true`) estimation; filters and contact detection run on.
    SetEstimation {
        /// Estimation on.
        enabled: bool,
    },
    /// Reply with the settings in force (and send the boot report again).
    ReportConfig,
}

/// Highest telemetry rate \[Hz\]: 250 frames of ≤ 96 bytes are 24 kB/s, a quarter of a
/// 921 600 bit/s UART, leaving room for replies.
pub const MAX_TELEMETRY_RATE_HZ: u16 = 250;

/// Sample rate the telemetry rate divides \[Hz\].
pub const SAMPLE_RATE_HZ: u16 = 1000;

/// Settings the operator can change; persisted in flash by the firmware.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DeviceSettings {
    /// Model estimated.
    pub model: ModelKind,
    /// Forgetting policy of every RLS stage; `None`: each model's default.
    pub forgetting: Option<Forgetting>,
    /// Load cell amplifier → ADC → N.
    pub load_cell: LoadCellCalibration,
    /// Encoder counts per metre after ×4 decoding.
    pub encoder_counts_per_m: f32,
    /// Telemetry frames per second.
    pub telemetry_rate_hz: u16,
}

/// Smallest force step between the two calibration points \[N\].
pub const MIN_CALIBRATION_STEP_N: f32 = 0.1;
/// Smallest amplifier-voltage step between the two calibration points \[V\] (≈ 12 codes
/// of a 12-bit ADC at 3.3 V): below it the sensitivity is mostly noise.
pub const MIN_CALIBRATION_STEP_V: f32 = 0.01;

impl DeviceSettings {
    /// Validates every field.
    ///
    /// # Errors
    /// [`CommandError::Invalid`] naming the field.
    pub fn validate(&self) -> Result<(), CommandError> {
        if let Some(f) = self.forgetting {
            f.validate().map_err(CommandError::from)?;
        }
        self.load_cell.validate().map_err(CommandError::from)?;
        if !(self.encoder_counts_per_m.is_finite() && self.encoder_counts_per_m > 0.0) {
            return Err(CommandError::invalid("counts_per_m", "finite and > 0"));
        }
        let rate = self.telemetry_rate_hz;
        if rate == 0 || rate > MAX_TELEMETRY_RATE_HZ || !SAMPLE_RATE_HZ.is_multiple_of(rate) {
            return Err(CommandError::invalid(
                "rate_hz",
                "a divisor of 1000 Hz, at most 250 Hz",
            ));
        }
        Ok(())
    }

    /// Telemetry period in samples.
    pub fn telemetry_period_samples(&self) -> u16 {
        SAMPLE_RATE_HZ / self.telemetry_rate_hz.max(1)
    }
}

/// Positive answer to a command.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Ack {
    /// Done.
    Done,
    /// First calibration point recorded: the amplifier output \[V\] measured for it.
    CalibrationPointRecorded {
        /// Mean amplifier output \[V\].
        load_cell_v: f32,
    },
    /// The settings now in force (after a change, or on [`Command::ReportConfig`]).
    Settings(DeviceSettings),
}

/// Negative answer to a command; the device state is unchanged unless stated.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum CommandError {
    /// The frame did not decode (request id 0).
    Malformed(FrameError),
    /// A value was rejected: the field and its valid range or the reason.
    Invalid {
        /// Field name as in the command or settings.
        field: Text<TEXT_BYTES>,
        /// Valid range or reason.
        expected: Text<TEXT_BYTES>,
    },
    /// [`CalibrationPoint::Second`] without a first point.
    CalibrationIncomplete,
    /// No valid load-cell reading to calibrate on (sensor saturated or dropped).
    NoReading,
    /// The change is in force but could not be written to flash: it is lost at reset.
    NotPersisted,
    /// Received requests arrived faster than they were handled; this many were discarded.
    Overrun(u16),
}

impl CommandError {
    /// [`CommandError::Invalid`] from text.
    pub fn invalid(field: &str, expected: &str) -> Self {
        CommandError::Invalid {
            field: bounded_text(field),
            expected: bounded_text(expected),
        }
    }
}

impl From<ConfigError> for CommandError {
    fn from(e: ConfigError) -> Self {
        match e {
            ConfigError::NonFinite { field } => CommandError::invalid(field, "finite"),
            ConfigError::OutOfRange {
                field, expected, ..
            } => CommandError::invalid(field, expected),
            ConfigError::Inconsistent { field, reason } => CommandError::invalid(field, reason),
        }
    }
}

/// Answer to one request.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Reply {
    /// The request's id (0 for a frame that did not decode).
    pub id: u16,
    /// Outcome.
    pub result: Result<Ack, CommandError>,
}

/// What the firmware must do after [`Configurator::handle`] accepted a command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Effects {
    /// Build a new estimator from the settings and `Pipeline::replace_estimator` it.
    pub rebuild_estimator: bool,
    /// `Pipeline::request_tare`.
    pub tare: bool,
    /// `Pipeline::set_estimation_enabled`.
    pub estimation: Option<bool>,
    /// The conversion (load cell, encoder) or the telemetry rate changed.
    pub conversion_changed: bool,
    /// Write the settings to flash.
    pub persist: bool,
    /// Send the boot report again.
    pub report_boot: bool,
}

/// Validates commands against the settings and keeps the calibration in progress. Pure
/// logic, no hardware: the firmware applies the returned [`Effects`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Configurator {
    settings: DeviceSettings,
    /// First calibration point: (amplifier output \[V\], force \[N\]).
    first_point: Option<(f32, f32)>,
}

impl Configurator {
    /// Starts from `settings` (validated by the caller, e.g. after reading flash).
    pub fn new(settings: DeviceSettings) -> Self {
        Configurator {
            settings,
            first_point: None,
        }
    }

    /// The settings in force.
    pub fn settings(&self) -> &DeviceSettings {
        &self.settings
    }

    /// Handles `command`. `load_cell_v` is the mean amplifier output \[V\] of the last
    /// samples (NaN if there is no valid reading), used by the calibration.
    ///
    /// # Errors
    /// [`CommandError`] when a value is invalid; then nothing changed.
    pub fn handle(
        &mut self,
        command: &Command,
        load_cell_v: f32,
    ) -> Result<(Ack, Effects), CommandError> {
        let mut next = self.settings;
        let mut effects = Effects::default();
        match *command {
            Command::ResetEstimator => {
                effects.rebuild_estimator = true;
                return Ok((Ack::Done, effects));
            }
            Command::Tare => {
                effects.tare = true;
                return Ok((Ack::Done, effects));
            }
            Command::SetEstimation { enabled } => {
                effects.estimation = Some(enabled);
                return Ok((Ack::Done, effects));
            }
            Command::ReportConfig => {
                effects.report_boot = true;
                return Ok((Ack::Settings(self.settings), effects));
            }
            Command::SelectModel(kind) => {
                next.model = kind;
                effects.rebuild_estimator = true;
            }
            Command::SetForgetting(forgetting) => {
                next.forgetting = forgetting;
                effects.rebuild_estimator = true;
            }
            Command::SetEncoderScale { counts_per_m } => {
                next.encoder_counts_per_m = counts_per_m;
                effects.conversion_changed = true;
            }
            Command::SetTelemetryRate { rate_hz } => {
                next.telemetry_rate_hz = rate_hz;
                effects.conversion_changed = true;
            }
            Command::CalibrateLoadCell { point, force_n } => {
                if !force_n.is_finite() {
                    return Err(CommandError::invalid("force_n", "finite"));
                }
                if !load_cell_v.is_finite() {
                    return Err(CommandError::NoReading);
                }
                match point {
                    CalibrationPoint::First => {
                        self.first_point = Some((load_cell_v, force_n));
                        return Ok((Ack::CalibrationPointRecorded { load_cell_v }, effects));
                    }
                    CalibrationPoint::Second => {
                        let first = self
                            .first_point
                            .ok_or(CommandError::CalibrationIncomplete)?;
                        next.load_cell = two_point(next.load_cell, first, (load_cell_v, force_n))?;
                        effects.conversion_changed = true;
                    }
                }
            }
        }
        next.validate()?;
        if matches!(command, Command::CalibrateLoadCell { .. }) {
            self.first_point = None;
        }
        self.settings = next;
        effects.persist = true;
        Ok((Ack::Settings(next), effects))
    }
}

/// The calibration through two (amplifier output \[V\], force \[N\]) points, keeping the
/// ADC's reference and full scale of `base`.
fn two_point(
    base: LoadCellCalibration,
    (v0, f0): (f32, f32),
    (v1, f1): (f32, f32),
) -> Result<LoadCellCalibration, CommandError> {
    if (f1 - f0).abs() < MIN_CALIBRATION_STEP_N {
        return Err(CommandError::invalid(
            "force_n",
            "at least 0.1 N from the first point",
        ));
    }
    if (v1 - v0).abs() < MIN_CALIBRATION_STEP_V {
        return Err(CommandError::invalid(
            "load_cell_v",
            "at least 10 mV from the first point",
        ));
    }
    let sensitivity_v_per_n = (v1 - v0) / (f1 - f0);
    let calibration = LoadCellCalibration {
        offset_v: v0 - sensitivity_v_per_n * f0,
        sensitivity_v_per_n,
        ..base
    };
    calibration.validate()?;
    Ok(calibration)
}

/// Something bytes can be handed to without blocking: a UART data register, a DMA
/// buffer, a host port. Accepting none is normal (still busy) and never an error.
pub trait BytePort {
    /// Takes some prefix of `bytes` (possibly none) and returns its length
    /// (≤ `bytes.len()`).
    fn try_write(&mut self, bytes: &[u8]) -> usize;
}

/// Outgoing bytes: whole frames in, any number of bytes per [`TxQueue::pump`] out.
/// Capacity `N` bytes.
#[derive(Debug, Default)]
pub struct TxQueue<const N: usize> {
    bytes: heapless::Deque<u8, N>,
    frames_dropped: u32,
}

impl<const N: usize> TxQueue<N> {
    /// Empty queue.
    pub const fn new() -> Self {
        TxQueue {
            bytes: heapless::Deque::new(),
            frames_dropped: 0,
        }
    }

    /// Queues one encoded frame whole, or refuses it whole and counts it in
    /// [`TxQueue::frames_dropped`] when it does not fit; returns whether it was queued.
    pub fn push_frame(&mut self, frame: &[u8]) -> bool {
        if self.bytes.capacity() - self.bytes.len() < frame.len() {
            self.frames_dropped = self.frames_dropped.wrapping_add(1);
            return false;
        }
        for &b in frame {
            // Cannot fail: the room was checked above.
            let _ = self.bytes.push_back(b);
        }
        true
    }

    /// Encodes `message` and queues it ([`TxQueue::push_frame`]); a message that does not
    /// encode counts as dropped.
    pub fn push_message<T: Serialize>(&mut self, message: &T) -> bool {
        let mut buffer = [0u8; MAX_FRAME_BYTES];
        match encode(message, &mut buffer) {
            Ok(frame) => self.push_frame(frame),
            Err(_) => {
                self.frames_dropped = self.frames_dropped.wrapping_add(1);
                false
            }
        }
    }

    /// Hands queued bytes to `port` until it accepts none or the queue is empty; returns
    /// `true` when the queue is empty.
    pub fn pump<P: BytePort + ?Sized>(&mut self, port: &mut P) -> bool {
        loop {
            let (front, _) = self.bytes.as_slices();
            if front.is_empty() {
                return true;
            }
            let taken = port.try_write(front).min(front.len());
            if taken == 0 {
                return false;
            }
            for _ in 0..taken {
                self.bytes.pop_front();
            }
        }
    }

    /// Bytes waiting.
    pub fn len(&self) -> usize {
        self.bytes.len()
    }

    /// `true` when nothing is waiting.
    pub fn is_empty(&self) -> bool {
        self.bytes.is_empty()
    }

    /// Frames refused since start (wraps).
    pub fn frames_dropped(&self) -> u32 {
        self.frames_dropped
    }
}

/// Collects received bytes into frames (up to [`MAX_FRAME_BYTES`]).
#[derive(Debug, Default)]
pub struct FrameReader {
    buffer: heapless::Vec<u8, MAX_FRAME_BYTES>,
    overlong: bool,
    /// The buffer holds a frame already handed out: the next byte starts a new one.
    handed_out: bool,
}

impl FrameReader {
    /// Empty reader.
    pub const fn new() -> Self {
        FrameReader {
            buffer: heapless::Vec::new(),
            overlong: false,
            handed_out: false,
        }
    }

    /// Feeds one byte. At a 0x00 that ends a non-empty frame, returns the frame's bytes
    /// (without the terminator) for [`decode`], or [`FrameError::TooLong`] if it
    /// overflowed (its bytes were discarded). Empty frames are skipped.
    pub fn push(&mut self, byte: u8) -> Option<Result<&mut [u8], FrameError>> {
        if core::mem::take(&mut self.handed_out) {
            self.buffer.clear();
        }
        if byte != 0 {
            if self.buffer.push(byte).is_err() {
                self.overlong = true;
            }
            return None;
        }
        if core::mem::take(&mut self.overlong) {
            self.buffer.clear();
            return Some(Err(FrameError::TooLong));
        }
        if self.buffer.is_empty() {
            return None;
        }
        self.handed_out = true;
        Some(Ok(self.buffer.as_mut_slice()))
    }

    /// Feeds one byte and decodes a completed frame as `T`.
    pub fn push_decode<T: DeserializeOwned>(&mut self, byte: u8) -> Option<Result<T, FrameError>> {
        self.push(byte).map(|frame| frame.and_then(|f| decode(f)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::any::AnyParameters;
    use crate::conditioning::ContactState;
    use crate::hunt_crossley::HuntCrossleyParameters;
    use crate::rls::AdaptiveForgetting;
    use crate::Status;

    fn settings() -> DeviceSettings {
        DeviceSettings {
            model: ModelKind::HuntCrossley,
            forgetting: None,
            load_cell: LoadCellCalibration {
                reference_v: 3.3,
                full_scale_code: 4095,
                offset_v: 1.65,
                sensitivity_v_per_n: 0.05,
            },
            encoder_counts_per_m: 1.0e6,
            telemetry_rate_hz: 50,
        }
    }

    fn telemetry(sample: u32) -> TelemetryFrame {
        TelemetryFrame {
            firmware_version: FirmwareVersion {
                major: 0,
                minor: 2,
                patch: 0,
            },
            reset_cause: ResetCause::Software,
            sample,
            period_samples: 20,
            model: ModelKind::HuntCrossley,
            parameters: AnyParameters::HuntCrossley(HuntCrossleyParameters {
                k: 4.58e4,
                lambda: 2.79e5,
                n: 1.2,
            }),
            contact: ContactState::InContact,
            depth_m: 1e-3,
            force_n: 11.5,
            status: Status::CONTACT_PENDING,
            overruns: 0,
            lost_periods: 3,
            frames_dropped: 1,
        }
    }

    #[test]
    fn frames_round_trip_and_hold_no_zero_inside() {
        let message = DeviceMessage::Telemetry(telemetry(1234));
        let mut buffer = [0u8; MAX_FRAME_BYTES];
        let frame = encode(&message, &mut buffer).unwrap();
        assert_eq!(frame.last(), Some(&0));
        assert!(!frame[..frame.len() - 1].contains(&0));
        let mut copy = frame.to_vec();
        assert_eq!(decode::<DeviceMessage>(&mut copy).unwrap(), message);
    }

    #[test]
    fn every_single_bit_flip_is_refused() {
        let request = Request {
            id: 7,
            command: Command::SetForgetting(Some(Forgetting::Adaptive(AdaptiveForgetting {
                alpha1: 0.05,
                alpha2: 10.0,
                alpha3: 20.0,
            }))),
        };
        let mut buffer = [0u8; MAX_FRAME_BYTES];
        let frame = encode(&request, &mut buffer).unwrap().to_vec();
        let body = frame.len() - 1;
        for byte in 0..body {
            for bit in 0..8 {
                let mut corrupted = frame.clone();
                corrupted[byte] ^= 1 << bit;
                let result = decode::<Request>(&mut corrupted[..body]);
                assert!(result.is_err(), "byte {byte} bit {bit}: {result:?}");
            }
        }
    }

    #[test]
    fn another_version_is_refused_before_its_body() {
        let mut raw = vec![PROTOCOL_VERSION + 1, 1, 2, 3];
        let crc = CRC16.checksum(&raw);
        raw.extend_from_slice(&crc.to_le_bytes());
        let mut frame = vec![0u8; raw.len() + 2];
        let n = cobs::encode(&raw, &mut frame);
        assert_eq!(
            decode::<Request>(&mut frame[..n]),
            Err(FrameError::Version(PROTOCOL_VERSION + 1))
        );
    }

    #[test]
    fn the_largest_messages_fit_a_frame() {
        let mut t = telemetry(u32::MAX);
        t.parameters = AnyParameters::Hammerstein {
            gamma1: f32::MAX,
            gamma2: f32::MIN,
            order: 2,
            a: [f32::MAX; 2],
            b: [f32::MIN; 2],
        };
        t.period_samples = u16::MAX;
        t.overruns = u32::MAX;
        t.lost_periods = u32::MAX;
        t.frames_dropped = u32::MAX;
        t.status = Status::all();
        let mut buffer = [0u8; MAX_FRAME_BYTES];
        let n = encode(&DeviceMessage::Telemetry(t), &mut buffer)
            .unwrap()
            .len();
        assert!(n <= crate::telemetry::MAX_FRAME_BYTES, "{n}");
        let boot = DeviceMessage::Boot(BootReport {
            firmware_version: FirmwareVersion::default(),
            board: bounded_text("odrive-v3-and-then-some"),
            reset_cause: ResetCause::Software,
            panic_message: bounded_text(&"x".repeat(500)),
            settings_from_flash: true,
        });
        assert!(encode(&boot, &mut buffer).is_ok());
        let mut s = settings();
        s.forgetting = Some(Forgetting::Adaptive(AdaptiveForgetting {
            alpha1: f32::MAX,
            alpha2: f32::MAX,
            alpha3: f32::MAX,
        }));
        let reply = DeviceMessage::Reply(Reply {
            id: u16::MAX,
            result: Ok(Ack::Settings(s)),
        });
        assert!(encode(&reply, &mut buffer).is_ok());
        let error = DeviceMessage::Reply(Reply {
            id: u16::MAX,
            result: Err(CommandError::invalid(&"f".repeat(99), &"e".repeat(99))),
        });
        assert!(encode(&error, &mut buffer).is_ok());
    }

    #[test]
    fn reader_splits_frames_skips_empty_ones_and_refuses_overlong() {
        let mut buffer = [0u8; MAX_FRAME_BYTES];
        let a = encode(
            &Request {
                id: 1,
                command: Command::Tare,
            },
            &mut buffer,
        )
        .unwrap()
        .to_vec();
        let mut stream = vec![0, 0];
        stream.extend_from_slice(&a);
        stream.extend(std::iter::repeat_n(7u8, MAX_FRAME_BYTES + 10));
        stream.push(0);
        stream.extend_from_slice(&a);
        let mut reader = FrameReader::new();
        let results: Vec<Result<Request, FrameError>> = stream
            .iter()
            .filter_map(|&b| reader.push_decode(b))
            .collect();
        assert_eq!(results.len(), 3, "{results:?}");
        assert_eq!(
            results[0],
            Ok(Request {
                id: 1,
                command: Command::Tare
            })
        );
        assert_eq!(results[1], Err(FrameError::TooLong));
        assert_eq!(
            results[2],
            Ok(Request {
                id: 1,
                command: Command::Tare
            })
        );
    }

    /// A port that takes 0 to 3 bytes per call, as a UART whose data register is full
    /// most of the time would.
    struct StingyPort {
        state: u32,
        received: Vec<u8>,
    }

    impl BytePort for StingyPort {
        fn try_write(&mut self, bytes: &[u8]) -> usize {
            self.state ^= self.state << 13;
            self.state ^= self.state >> 17;
            self.state ^= self.state << 5;
            let n = (self.state % 4) as usize;
            let n = n.min(bytes.len());
            self.received.extend_from_slice(&bytes[..n]);
            n
        }
    }

    #[test]
    fn uart_writer_never_loses_a_frame_silently_with_a_port_taking_0_to_3_bytes() {
        let mut queue = TxQueue::<256>::new();
        let mut port = StingyPort {
            state: 0x1234_5678,
            received: Vec::new(),
        };
        let mut queued = Vec::new();
        let pushed = 2000u32;
        for sample in 0..pushed {
            if queue.push_message(&DeviceMessage::Telemetry(telemetry(sample))) {
                queued.push(sample);
            }
            // Fewer pump calls than frames: the queue fills and must refuse whole frames.
            for _ in 0..(sample % 40) {
                queue.pump(&mut port);
            }
        }
        while !queue.pump(&mut port) {}
        assert!(
            queue.frames_dropped() > 0,
            "the test must overfill the queue"
        );
        assert_eq!(queued.len() as u32 + queue.frames_dropped(), pushed);
        let mut reader = FrameReader::new();
        let decoded: Vec<u32> = port
            .received
            .iter()
            .filter_map(|&b| reader.push_decode::<DeviceMessage>(b))
            .map(|m| match m {
                Ok(DeviceMessage::Telemetry(t)) => t.sample,
                other => panic!("{other:?}"),
            })
            .collect();
        assert_eq!(decoded, queued);
    }

    #[test]
    fn commands_change_settings_only_when_valid() {
        let mut c = Configurator::new(settings());
        let (ack, effects) = c
            .handle(&Command::SelectModel(ModelKind::KelvinVoigt), f32::NAN)
            .unwrap();
        assert!(effects.rebuild_estimator && effects.persist);
        assert_eq!(c.settings().model, ModelKind::KelvinVoigt);
        assert_eq!(ack, Ack::Settings(*c.settings()));

        let before = *c.settings();
        let bad = Command::SetForgetting(Some(Forgetting::Fixed { beta: 1.5 }));
        assert_eq!(
            c.handle(&bad, f32::NAN),
            Err(CommandError::invalid("beta", "(0, 1]"))
        );
        for rate_hz in [0, 3, 300, 1000] {
            let e = c.handle(&Command::SetTelemetryRate { rate_hz }, f32::NAN);
            assert!(matches!(e, Err(CommandError::Invalid { .. })), "{rate_hz}");
        }
        let e = c.handle(
            &Command::SetEncoderScale {
                counts_per_m: f32::NAN,
            },
            f32::NAN,
        );
        assert!(matches!(e, Err(CommandError::Invalid { .. })));
        assert_eq!(*c.settings(), before);

        let (_, effects) = c
            .handle(&Command::SetTelemetryRate { rate_hz: 100 }, f32::NAN)
            .unwrap();
        assert!(effects.conversion_changed && effects.persist);
        assert_eq!(c.settings().telemetry_period_samples(), 10);
    }

    #[test]
    fn two_point_calibration_recovers_the_amplifier_line() {
        let mut c = Configurator::new(settings());
        let second = Command::CalibrateLoadCell {
            point: CalibrationPoint::Second,
            force_n: 9.81,
        };
        assert_eq!(
            c.handle(&second, 2.0),
            Err(CommandError::CalibrationIncomplete)
        );
        let first = Command::CalibrateLoadCell {
            point: CalibrationPoint::First,
            force_n: 0.0,
        };
        assert_eq!(c.handle(&first, f32::NAN), Err(CommandError::NoReading));
        // Amplifier: 1.2 V at 0 N, 0.08 V/N.
        c.handle(&first, 1.2).unwrap();
        // Too close to the first point in volts: refused, first point kept.
        assert!(matches!(
            c.handle(&second, 1.205),
            Err(CommandError::Invalid { .. })
        ));
        let (_, effects) = c.handle(&second, 1.2 + 0.08 * 9.81).unwrap();
        assert!(effects.persist && effects.conversion_changed);
        let cal = c.settings().load_cell;
        assert!((cal.offset_v - 1.2).abs() < 1e-5, "{cal:?}");
        assert!((cal.sensitivity_v_per_n - 0.08).abs() < 1e-5, "{cal:?}");
        // The session ended: a new second point needs a new first point.
        assert_eq!(
            c.handle(&second, 2.0),
            Err(CommandError::CalibrationIncomplete)
        );
    }
}
