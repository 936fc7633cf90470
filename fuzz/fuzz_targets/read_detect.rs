//! `host_sim::readers::read_bytes` with auto-detection (`None`), then `detect` alone: any
//! bytes give a record or a `ReadError`, never a panic; a record keeps the reader's
//! invariants.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let path = std::path::Path::new("fuzz.input");
    let _ = host_sim::readers::detect(data);
    if let Ok(r) = host_sim::readers::read_bytes(data, path, None) {
        assert!(r.len() >= 2 && r.position_m.len() == r.len() && r.force_n.len() == r.len());
        assert!(r.time_s.windows(2).all(|w| w[1] > w[0]));
        let values = r.time_s.iter().chain(&r.position_m).chain(&r.force_n);
        assert!(values.copied().all(f64::is_finite));
    }
});
