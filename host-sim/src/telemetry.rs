//! Decoding the firmware's telemetry stream: COBS frames (0x00-terminated) of
//! postcard-serialised [`TelemetryFrame`]s, as captured from the UART (or from QEMU's
//! serial port).

use estimator_core::telemetry::TelemetryFrame;

/// Result of decoding a captured stream.
#[derive(Debug, Default)]
pub struct Decoded {
    /// Frames decoded, in order.
    pub frames: Vec<TelemetryFrame>,
    /// Frames that failed to decode (corrupt or truncated), with their byte offset.
    pub errors: Vec<(usize, String)>,
    /// Frames missing according to the sequence numbers.
    pub missing: u64,
}

/// Decodes every frame in `bytes`. Never panics on any byte string: a corrupt frame is
/// recorded in [`Decoded::errors`] and decoding resumes at the next 0x00.
pub fn decode(bytes: &[u8]) -> Decoded {
    let mut out = Decoded::default();
    let mut start = 0;
    for (i, &b) in bytes.iter().enumerate() {
        if b != 0 {
            continue;
        }
        let mut frame = bytes[start..=i].to_vec();
        match postcard::from_bytes_cobs::<TelemetryFrame>(&mut frame) {
            Ok(f) => {
                if let Some(last) = out.frames.last() {
                    out.missing +=
                        u64::from(f.sequence.wrapping_sub(last.sequence).saturating_sub(1));
                }
                out.frames.push(f);
            }
            Err(e) => out.errors.push((start, e.to_string())),
        }
        start = i + 1;
    }
    if start < bytes.len() {
        out.errors
            .push((start, "truncated frame at the end of the stream".into()));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use estimator_core::conditioning::ContactState;
    use estimator_core::hunt_crossley::HuntCrossleyParameters;
    use estimator_core::telemetry::MAX_FRAME_BYTES;
    use estimator_core::{AnyParameters, ModelKind, Status};

    fn frame(sequence: u32, parameters: AnyParameters) -> TelemetryFrame {
        TelemetryFrame {
            sequence,
            sample: 1000,
            model: ModelKind::HuntCrossley,
            parameters,
            contact: ContactState::InContact,
            depth_m: 1e-3,
            force_n: 11.5,
            status: Status::MODEL_MISMATCH | Status::CONTACT_PENDING,
            overruns: 0,
        }
    }

    #[test]
    fn round_trip_and_gaps() {
        let hc = AnyParameters::HuntCrossley(HuntCrossleyParameters {
            k: 4.58e4,
            lambda: 2.79e5,
            n: 1.2,
        });
        let mut stream = Vec::new();
        for seq in [1u32, 2, 5] {
            let mut buf = [0u8; MAX_FRAME_BYTES];
            stream.extend_from_slice(postcard::to_slice_cobs(&frame(seq, hc), &mut buf).unwrap());
        }
        let d = decode(&stream);
        assert_eq!(d.frames.len(), 3);
        assert_eq!(d.frames[0], frame(1, hc));
        assert_eq!(d.missing, 2);
        assert!(d.errors.is_empty());
    }

    #[test]
    fn largest_frame_fits_the_firmware_buffer() {
        let big = AnyParameters::Hammerstein {
            gamma1: f32::MAX,
            gamma2: f32::MIN,
            order: 2,
            a: [f32::MAX; 2],
            b: [f32::MIN; 2],
        };
        let mut f = frame(u32::MAX, big);
        f.sample = u32::MAX;
        f.overruns = u32::MAX;
        f.status = Status::all();
        let mut buf = [0u8; MAX_FRAME_BYTES];
        let encoded = postcard::to_slice_cobs(&f, &mut buf).unwrap();
        assert!(encoded.len() <= MAX_FRAME_BYTES, "{}", encoded.len());
    }

    #[test]
    fn garbage_is_reported_not_panicked_on() {
        let d = decode(&[1, 2, 3, 0, 0xff, 0xff, 0, 7]);
        assert!(d.frames.is_empty());
        assert_eq!(d.errors.len(), 3);
    }
}
