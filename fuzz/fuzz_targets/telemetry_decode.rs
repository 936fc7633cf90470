//! `host_sim::telemetry::decode` on any byte stream: never panics, and every 0x00 ends
//! exactly one frame (decoded or reported).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let d = host_sim::telemetry::decode(data);
    let zeros = data.iter().filter(|&&b| b == 0).count();
    let trailing = usize::from(data.last().is_some_and(|&b| b != 0));
    assert_eq!(d.frames.len() + d.errors.len(), zeros + trailing);
});
