//! Decoding the firmware's UART stream (live from `host-sim serial` or captured to a file,
//! e.g. QEMU's serial port): versioned, CRC-checked COBS frames of
//! [`DeviceMessage`]s, decoded by the core's own [`estimator_core::protocol`] code, with
//! drops counted from the sample index every telemetry frame carries.

use estimator_core::protocol::{DeviceMessage, FrameError, FrameReader};
use estimator_core::telemetry::TelemetryFrame;

/// One item of the decoded stream.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// A decoded message, with the number of telemetry frames missing just before it
    /// (from the sample-index gap; 0 for other messages).
    Message {
        /// The message.
        message: DeviceMessage,
        /// Telemetry frames lost between the previous telemetry frame and this one.
        missing_before: u64,
    },
    /// A frame that did not decode, at this byte offset of the stream.
    Error {
        /// Offset of the byte that ended the frame.
        offset: u64,
        /// Why.
        error: FrameError,
    },
}

/// Incremental decoder: feed it bytes as they arrive.
#[derive(Debug, Default)]
pub struct StreamDecoder {
    reader: FrameReader,
    offset: u64,
    last: Option<(u32, u16)>,
    /// Telemetry frames missing so far (sample-index gaps).
    pub missing: u64,
}

impl StreamDecoder {
    /// New decoder.
    pub fn new() -> Self {
        Self::default()
    }

    /// Decodes `bytes`, calling `each` for every completed frame. Never panics on any
    /// byte string.
    pub fn feed(&mut self, bytes: &[u8], mut each: impl FnMut(Event)) {
        for &b in bytes {
            self.offset += 1;
            let Some(result) = self.reader.push_decode::<DeviceMessage>(b) else {
                continue;
            };
            match result {
                Ok(message) => {
                    let missing_before = self.track(&message);
                    self.missing += missing_before;
                    each(Event::Message {
                        message,
                        missing_before,
                    });
                }
                Err(error) => each(Event::Error {
                    offset: self.offset - 1,
                    error,
                }),
            }
        }
    }

    /// Telemetry frames missing before `message`. A boot report starts a new count (the
    /// firmware restarted, its sample index from 0).
    fn track(&mut self, message: &DeviceMessage) -> u64 {
        match message {
            DeviceMessage::Boot(_) => {
                self.last = None;
                0
            }
            DeviceMessage::Telemetry(t) => {
                let missing = match self.last {
                    Some((sample, _)) if t.sample > sample => {
                        u64::from((t.sample - sample) / u32::from(t.period_samples.max(1)))
                            .saturating_sub(1)
                    }
                    _ => 0,
                };
                self.last = Some((t.sample, t.period_samples));
                missing
            }
            DeviceMessage::Reply(_) => 0,
        }
    }
}

/// Result of decoding a whole captured stream.
#[derive(Debug, Default)]
pub struct Decoded {
    /// Every message, in order.
    pub messages: Vec<DeviceMessage>,
    /// The telemetry frames among them, in order.
    pub frames: Vec<TelemetryFrame>,
    /// Frames that failed to decode, with the offset of their last byte.
    pub errors: Vec<(u64, FrameError)>,
    /// Telemetry frames missing according to the sample indices.
    pub missing: u64,
    /// The stream ended inside a frame.
    pub truncated: bool,
}

/// Decodes every frame in `bytes`. Never panics on any byte string: a corrupt frame is
/// recorded in [`Decoded::errors`] and decoding resumes at the next 0x00.
pub fn decode(bytes: &[u8]) -> Decoded {
    let mut out = Decoded::default();
    let mut decoder = StreamDecoder::new();
    decoder.feed(bytes, |event| match event {
        Event::Message { message, .. } => {
            if let DeviceMessage::Telemetry(t) = &message {
                out.frames.push(*t);
            }
            out.messages.push(message);
        }
        Event::Error { offset, error } => out.errors.push((offset, error)),
    });
    out.missing = decoder.missing;
    out.truncated = bytes.last().is_some_and(|&b| b != 0);
    out
}

/// (non-empty 0x00-terminated frames, whether bytes follow the last 0x00) of a stream:
/// what [`decode`] must account for, one message or error per frame.
pub fn frame_counts(bytes: &[u8]) -> (usize, bool) {
    let mut segments: Vec<&[u8]> = bytes.split(|&b| b == 0).collect();
    let tail = segments.pop().is_some_and(|last| !last.is_empty());
    (segments.iter().filter(|s| !s.is_empty()).count(), tail)
}

#[cfg(test)]
mod tests {
    use super::*;
    use estimator_core::conditioning::ContactState;
    use estimator_core::hunt_crossley::HuntCrossleyParameters;
    use estimator_core::protocol::{encode, MAX_FRAME_BYTES};
    use estimator_core::telemetry::{FirmwareVersion, ResetCause};
    use estimator_core::{AnyParameters, ModelKind, Status};

    fn frame(sample: u32) -> DeviceMessage {
        DeviceMessage::Telemetry(TelemetryFrame {
            firmware_version: FirmwareVersion::default(),
            reset_cause: ResetCause::PowerOn,
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
            status: Status::MODEL_MISMATCH,
            overruns: 0,
            lost_periods: 0,
            frames_dropped: 0,
        })
    }

    fn stream(samples: &[u32]) -> Vec<u8> {
        let mut out = Vec::new();
        for &s in samples {
            let mut buf = [0u8; MAX_FRAME_BYTES];
            out.extend_from_slice(encode(&frame(s), &mut buf).unwrap());
        }
        out
    }

    #[test]
    fn gaps_in_the_sample_index_count_as_missing_frames() {
        let d = decode(&stream(&[20, 40, 100, 120]));
        assert_eq!(d.frames.len(), 4);
        assert_eq!(d.messages[0], frame(20));
        assert_eq!(d.missing, 2);
        assert!(d.errors.is_empty() && !d.truncated);
    }

    #[test]
    fn garbage_is_reported_not_panicked_on() {
        let mut bytes = vec![1, 2, 3, 0, 0xff, 0xff, 0];
        bytes.extend(stream(&[20]));
        bytes.push(7);
        let d = decode(&bytes);
        assert_eq!(d.frames.len(), 1);
        assert_eq!(d.errors.len(), 2);
        assert!(d.truncated);
    }
}
