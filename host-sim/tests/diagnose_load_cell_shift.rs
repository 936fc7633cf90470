//! A load-cell zero shift after the first contact, on Kelvin-Voigt taps sampled at 124 Hz:
//! the case that made the BIC, not the held-out error alone, choose among accepted
//! candidates (`diagnose::choose`). Held out, the first contact is the only stretch that
//! separates the shift from the tare, so the force offset's held-out error is poor, and a
//! contact-point shift, which fits the taps at about three times its NRMSE, had the better
//! held-out error and was named (3 of 5 logs of an independent generator; this record
//! follows its seed 201: κ = 5458 N/m, λ = 521 N·s/m, six taps at 11.9 mm/s to 3-5 mm, a
//! 3.53 N shift, force quantised at 10 bits over 1.6× its range, 1 µm encoder steps).

use host_sim::diagnose::Options;
use host_sim::files::diagnose_file;
use host_sim::setup::Overrides;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};

/// (time \[s\], position \[m\], force \[N\]) of the record.
fn record(seed: u64) -> Vec<(f64, f64, f64)> {
    let mut rng = StdRng::seed_from_u64(seed);
    let (kappa, lambda, speed, bias) = (5458.0, 520.7, 0.011_876, 3.531);
    let deepest = 4.958e-3;
    let gap = deepest * rng.random_range(0.2..0.6);
    // Waypoints of the penetration z (> 0 in contact): approach, then six taps.
    let mut points = vec![(0.0, -gap)];
    let mut t = rng.random_range(0.2..0.4);
    points.push((t, -gap));
    for _ in 0..6 {
        let depth = deepest * rng.random_range(0.6..1.0);
        t += (depth + gap) / speed;
        points.push((t, depth));
        t += (depth + gap) / speed;
        points.push((t, -gap));
        t += rng.random_range(0.1..0.4);
        points.push((t, -gap));
    }
    let z_at = |t: f64| -> (f64, f64) {
        let k = points
            .windows(2)
            .position(|w| t < w[1].0)
            .unwrap_or(points.len() - 2);
        let ((t0, z0), (t1, z1)) = (points[k], points[k + 1]);
        let rate = (z1 - z0) / (t1 - t0);
        (z0 + rate * (t - t0), rate)
    };
    let fs = 124.22;
    let samples = (t * fs) as usize;
    let force: Vec<(f64, f64)> = (0..samples)
        .map(|i| {
            let (z, v) = z_at(i as f64 / fs);
            let f = if z > 0.0 {
                (kappa * z + lambda * v).max(0.0)
            } else {
                0.0
            };
            (z, f)
        })
        .collect();
    let range = force.iter().map(|p| p.1).fold(0.0, f64::max);
    let first_end = force
        .iter()
        .position(|p| p.0 > 0.0)
        .and_then(|i| (i..samples).find(|&j| force[j].0 <= 0.0))
        .unwrap();
    let offset = -3.473;
    let noise = Normal::new(0.0, 0.337).unwrap();
    let step = 1.6 * range / 1024.0;
    let encoder = deepest * 2e-4;
    let position_noise = Normal::new(0.0, encoder).unwrap();
    (0..samples)
        .map(|i| {
            let (z, f) = force[i];
            let shifted = if i >= first_end { f + bias } else { f };
            let measured = ((shifted + offset + noise.sample(&mut rng)) / step).round() * step;
            let x = 6.68e-4 + z + position_noise.sample(&mut rng);
            (i as f64 / fs, (x / encoder).round() * encoder, measured)
        })
        .collect()
}

#[test]
fn a_load_cell_shift_after_the_first_tap_is_named_not_a_contact_shift() {
    let dir = tempfile::tempdir().unwrap();
    let mut named = Vec::new();
    for seed in 0..3 {
        let path = dir.path().join(format!("shift-{seed}.csv"));
        let mut text = String::from("time_s,position_m,force_n\n");
        for (t, x, f) in record(seed) {
            text.push_str(&format!("{t:.6},{x:.9e},{f:.9e}\n"));
        }
        std::fs::write(&path, text).unwrap();
        let run = diagnose_file(
            &path,
            "csv",
            &Options::default(),
            &Overrides::default(),
            None,
        )
        .unwrap();
        named.push(run.diagnosis.effects_added());
    }
    for effects in &named {
        assert_eq!(effects.first(), Some(&"force_offset"), "{named:?}");
        assert!(!effects.contains(&"contact_point_offset"), "{named:?}");
    }
}
