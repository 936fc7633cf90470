//! `host_sim::telemetry::decode` on any byte stream: never panics, and every 0x00 that
//! ends a non-empty frame yields exactly one message or one error.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let d = host_sim::telemetry::decode(data);
    let (frames, tail) = host_sim::telemetry::frame_counts(data);
    assert_eq!(d.messages.len() + d.errors.len(), frames);
    assert_eq!(d.truncated, tail);
});
