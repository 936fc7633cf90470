//! The telemetry frame the firmware sends to the master device (and the host decodes):
//! what a haptic master needs to render the environment, plus the loop's health.
//!
//! On the wire: postcard-serialised, COBS-framed (0x00 terminates each frame), see
//! [`MAX_FRAME_BYTES`]. Serialisation lives behind the `serde` feature so that the core
//! itself needs no serialiser.

use crate::any::{AnyParameters, ModelKind};
use crate::conditioning::ContactState;
use crate::Status;

/// One telemetry message.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TelemetryFrame {
    /// Frame counter (wraps), to detect lost frames.
    pub sequence: u32,
    /// Samples processed by the 1 kHz task since start (wraps).
    pub sample: u32,
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
    /// Flags of the last sample, OR-ed with [`Status::MODEL_MISMATCH`] if the monitor
    /// raised it since the previous frame.
    pub status: Status,
    /// 1 kHz deadlines missed since start.
    pub overruns: u32,
}

/// Upper bound on an encoded frame (postcard + COBS overhead + terminator), bytes.
pub const MAX_FRAME_BYTES: usize = 96;
