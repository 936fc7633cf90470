//! The plant the QEMU smoke run senses instead of the ADC and the encoder: the probe of
//! the paper's rig pressing the thin plastic layer (Hunt-Crossley, the paper's values in
//! SI: k = 4.58e4 N/m^1.2, λ = 2.79e5 N·s/m^2.2, n = 1.2), 20 mN of load-cell noise from a
//! xorshift generator, the boards' oversampled ADC code (16 × 12 bit, read through the
//! default amplifier calibration) and a 16-bit encoder counter. The motion is
//! the host scenario `plastic-hc`'s: free space, then 1-3 Hz pressing to 1 mm that leaves
//! the surface by 50 µm at every cycle.

use estimator_core::models::HuntCrossley;

use crate::board::{
    RawCodes, DEFAULT_ENCODER_COUNTS_PER_M, DEFAULT_LOAD_CELL, OVERSAMPLED_FULL_SCALE_CODE,
    SAMPLE_TIME_S,
};

/// The simulated material.
pub const TRUTH: HuntCrossley = HuntCrossley {
    k: 4.578e4,
    lambda: 2.787e5,
    n: 1.2,
    q: 1.2,
};

/// Position of the material surface in encoder coordinates \[m\] (the probe starts 1 mm
/// above it; the counter wraps 0.065 m).
const SURFACE_M: f32 = 0.1;
/// Load-cell noise \[N\].
const NOISE_N: f32 = 0.02;

/// xorshift32: enough for sensor noise, no_std, no state beyond a word.
struct XorShift(u32);

impl XorShift {
    fn next(&mut self) -> f32 {
        let mut x = self.0;
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        self.0 = x;
        (x >> 8) as f32 / (1u32 << 24) as f32
    }

    /// Approximately normal, unit variance (sum of four uniforms).
    fn normal(&mut self) -> f32 {
        (self.next() + self.next() + self.next() + self.next() - 2.0) * 1.732_050_8
    }
}

/// The simulated plant.
pub struct SimPlant {
    sample: u32,
    previous_depth_m: f32,
    noise: XorShift,
}

impl SimPlant {
    /// Starts at t = 0.
    pub fn new() -> Self {
        SimPlant {
            sample: 0,
            previous_depth_m: -1.0e-3,
            noise: XorShift(0x2545_F491),
        }
    }

    /// Depth reference \[m\] at `t` \[s\] (as `host_sim::plant::Trajectory::SineSweep`).
    fn depth_m(t: f32) -> f32 {
        let (approach, start, min, max, f0, f1, sweep) =
            (-1.0e-3, 0.5, -0.05e-3, 1.0e-3, 1.0, 3.0, 2.0);
        if t < start {
            return approach;
        }
        let tau = t - start;
        let (fm, fa) = (0.5 * (f0 + f1), 0.5 * (f1 - f0));
        let wm = 2.0 * core::f32::consts::PI / sweep;
        let phase =
            2.0 * core::f32::consts::PI * (fm * tau + fa * (1.0 - libm::cosf(wm * tau)) / wm);
        let blend = (tau / 0.2).min(1.0);
        let sine = min + (max - min) * 0.5 * (1.0 - libm::cosf(phase));
        approach + blend * (sine - approach)
    }

    /// Advances one sample and returns what the ADC and the encoder counter would read.
    pub fn read(&mut self) -> RawCodes {
        let t = self.sample as f32 * SAMPLE_TIME_S;
        self.sample += 1;
        let depth = Self::depth_m(t);
        let rate = (depth - self.previous_depth_m) / SAMPLE_TIME_S;
        self.previous_depth_m = depth;
        let force = TRUTH.force_n(depth, rate) + NOISE_N * self.noise.normal();
        let counts = libm::floorf((SURFACE_M + depth) * DEFAULT_ENCODER_COUNTS_PER_M) as i32;
        let code = DEFAULT_LOAD_CELL.code(force);
        RawCodes {
            adc: Some(code),
            adc_at_rail: code == 0 || code >= OVERSAMPLED_FULL_SCALE_CODE,
            encoder: counts as u16,
        }
    }
}
