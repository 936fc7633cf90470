//! The telemetry frame the firmware sends to the master device (and the host decodes):
//! what a haptic master needs to render the environment, plus the loop's health and the
//! identity of the firmware that sent it.
//!
//! On the wire it travels as [`crate::protocol::DeviceMessage::Telemetry`] inside a
//! versioned, CRC-checked COBS frame (see [`crate::protocol`]). Serialisation lives behind
//! the `serde` feature so that the core itself needs no serialiser.

use crate::any::{AnyParameters, ModelKind};
use crate::conditioning::ContactState;
use crate::Status;

/// Version of the firmware that produced a frame (its crate version, semver).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FirmwareVersion {
    /// Major version.
    pub major: u8,
    /// Minor version.
    pub minor: u8,
    /// Patch version.
    pub patch: u8,
}

/// Why the MCU last started, from the STM32F4 RCC_CSR reset flags (RM0090 §7.3.21); the
/// first flag found in this order wins, because a watchdog or software reset also sets
/// the pin flag.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ResetCause {
    /// Power-on / power-down reset (PORRSTF).
    PowerOn,
    /// Brown-out reset (BORRSTF).
    BrownOut,
    /// The independent watchdog expired (IWDGRSTF): the 1 kHz task stalled.
    IndependentWatchdog,
    /// The window watchdog (WWDGRSTF).
    WindowWatchdog,
    /// Software reset (SFTRSTF): after a panic (its message is in the boot report) or a
    /// debugger reset.
    Software,
    /// Low-power management reset (LPWRRSTF).
    LowPower,
    /// NRST pin (PINRSTF) only.
    Pin,
    /// No flag set (e.g. QEMU, which does not model RCC_CSR).
    #[default]
    Unknown,
}

/// One telemetry message.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TelemetryFrame {
    /// Firmware that sent the frame.
    pub firmware_version: FirmwareVersion,
    /// Why the MCU last started.
    pub reset_cause: ResetCause,
    /// Index of the 1 kHz sample this frame reports, counted since start (wraps). Assigned
    /// when the sample is taken, so a frame lost anywhere shows as a gap larger than
    /// [`TelemetryFrame::period_samples`].
    pub sample: u32,
    /// Telemetry period in samples when the frame was taken (1000 / rate in Hz).
    pub period_samples: u16,
    /// Model being estimated.
    pub model: ModelKind,
    /// Latest parameters, SI.
    pub parameters: AnyParameters,
    /// Contact state.
    pub contact: ContactState,
    /// Penetration δ \[m\] of the last sample.
    pub depth_m: f32,
    /// Tared force \[N\] of the last sample.
    pub force_n: f32,
    /// Flags of the last sample (e.g. [`Status::OFFSET_UNCERTAIN`] while the force offset
    /// is unconfirmed), OR-ed with [`Status::MODEL_MISMATCH`] and
    /// [`Status::OFFSET_CORRECTED`] if any sample since the previous frame raised them.
    pub status: Status,
    /// 1 kHz deadlines missed since start: the task ran but ended after the next period
    /// had begun.
    pub overruns: u32,
    /// Sample periods that passed with no task run at all (e.g. interrupts masked, a
    /// flash erase stalling the bus), counted from the free-running period clock.
    pub lost_periods: u32,
    /// Frames (telemetry or replies) the firmware could not queue because the UART was
    /// behind, since start: the host adds these to the gaps it sees.
    pub frames_dropped: u32,
}

/// Upper bound on an encoded telemetry frame, bytes (version + postcard + CRC, COBS
/// overhead and terminator included); see `protocol::MAX_FRAME_BYTES` for every message.
pub const MAX_FRAME_BYTES: usize = 96;
