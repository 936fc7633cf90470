//! Phases of a contact test, detected from the motion (never given): free space before the
//! first contact, loading (δ̇ > v*), hold (|δ̇| < v*/2), unloading (δ̇ < −v*), release (out of
//! contact after a contact). v* comes from the record's own speeds, and the hysteresis
//! between v*/2 and v* keeps noise from flickering the phase.

use serde::Serialize;

/// A phase of a contact test.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Phase {
    /// Out of contact, before the first contact.
    FreeSpace,
    /// In contact, penetration increasing.
    Loading,
    /// In contact, penetration (nearly) constant.
    Hold,
    /// In contact, penetration decreasing.
    Unloading,
    /// Out of contact after a contact.
    Release,
}

impl Phase {
    /// All phases, in test order.
    pub const ALL: [Phase; 5] = [
        Phase::FreeSpace,
        Phase::Loading,
        Phase::Hold,
        Phase::Unloading,
        Phase::Release,
    ];

    /// kebab-case name.
    pub fn name(self) -> &'static str {
        match self {
            Phase::FreeSpace => "free-space",
            Phase::Loading => "loading",
            Phase::Hold => "hold",
            Phase::Unloading => "unloading",
            Phase::Release => "release",
        }
    }
}

/// Online phase classifier (one sample at a time, as a 1 kHz loop would).
#[derive(Debug, Clone)]
pub struct PhaseClassifier {
    threshold_m_per_s: f64,
    current: Phase,
    seen_contact: bool,
}

impl PhaseClassifier {
    /// Classifier with loading/unloading speed threshold v* \[m/s\].
    pub fn new(threshold_m_per_s: f64) -> Self {
        PhaseClassifier {
            threshold_m_per_s: threshold_m_per_s.abs(),
            current: Phase::FreeSpace,
            seen_contact: false,
        }
    }

    /// Phase of a sample from the contact state and the penetration rate \[m/s\].
    pub fn classify(&mut self, in_contact: bool, rate_m_per_s: f64) -> Phase {
        let v = self.threshold_m_per_s;
        self.current = if !in_contact {
            if self.seen_contact {
                Phase::Release
            } else {
                Phase::FreeSpace
            }
        } else {
            self.seen_contact = true;
            let was_in_contact = matches!(
                self.current,
                Phase::Loading | Phase::Hold | Phase::Unloading
            );
            if rate_m_per_s > v {
                Phase::Loading
            } else if rate_m_per_s < -v {
                Phase::Unloading
            } else if rate_m_per_s.abs() < 0.5 * v {
                Phase::Hold
            } else if was_in_contact {
                // Between v*/2 and v*: keep the phase (hysteresis).
                self.current
            } else if rate_m_per_s > 0.0 {
                Phase::Loading
            } else {
                Phase::Unloading
            }
        };
        self.current
    }
}

/// Fraction of the record's 99.9th-percentile speed that separates loading from a hold
/// (v*). A high percentile, not the 99th: a ramp-and-hold test moves during 1 % of its
/// samples or less, and the 99th percentile would be its noise. 5 %: a load-controlled
/// indentation slows down as it goes deeper (dP/dt constant, P ∝ hⁿ), and its last
/// loading is still loading.
pub const LOADING_SPEED_FRACTION: f64 = 0.05;

/// v* for a record: [`LOADING_SPEED_FRACTION`] of its 99.9th-percentile speed (robust to a
/// few spikes), from positions \[m\] sampled every `sample_time_s`
/// (= `SpanTravel::of(position_m).loading_speed(sample_time_s)`).
pub fn speed_threshold(position_m: &[f64], sample_time_s: f64) -> f64 {
    SpanTravel::of(position_m).loading_speed(sample_time_s)
}

/// The record's 99.9th-percentile travel over a 5-sample span (speeds over such spans stay
/// above quantisation noise): [`speed_threshold`] without the sample time, so that one
/// selection serves every sample time it is asked at. Exact: dividing by the span's
/// duration is monotone, so the percentile of the speeds is the percentile travel divided
/// by it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpanTravel {
    /// The 99.9th percentile of |x\[i + span\] − x\[i\]| \[m\].
    travel_m: f64,
    /// Samples per span (5, fewer on a shorter record; 0: under 3 samples, no speed).
    span: usize,
}

impl SpanTravel {
    /// Of positions `position_m` \[m\].
    pub fn of(position_m: &[f64]) -> Self {
        if position_m.len() < 3 {
            return SpanTravel {
                travel_m: 0.0,
                span: 0,
            };
        }
        let span = 5.min(position_m.len() - 1);
        let mut travel: Vec<f64> = position_m
            .windows(span + 1)
            .map(|w| (w[span] - w[0]).abs())
            .collect();
        SpanTravel {
            travel_m: percentile_999(&mut travel),
            span,
        }
    }

    /// v* \[m/s\] at samples `sample_time_s` \[s\] apart ([`speed_threshold`]); 0 without
    /// a span.
    pub fn loading_speed(&self, sample_time_s: f64) -> f64 {
        if self.span == 0 {
            return 0.0;
        }
        LOADING_SPEED_FRACTION * (self.travel_m / (self.span as f64 * sample_time_s))
    }
}

/// [`LOADING_SPEED_FRACTION`] of the 99.9th percentile of `speeds` \[m/s\] (by selection:
/// `speeds` is reordered); 0 for none.
pub fn loading_speed_of(speeds: &mut [f64]) -> f64 {
    LOADING_SPEED_FRACTION * percentile_999(speeds)
}

/// The 99.9th percentile of `values` (the element at ⌊0.999·(n − 1)⌋ in order), by
/// selection: `values` is reordered; 0 for none. A record's "fast" motion everywhere it
/// is asked (robust to a few spikes, and a ramp-and-hold's brief ramp still counts).
pub fn percentile_999(values: &mut [f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let at = ((values.len() - 1) as f64 * 0.999) as usize;
    *values.select_nth_unstable_by(at, f64::total_cmp).1
}

/// Runs of equal phase: (phase, start, end exclusive).
pub fn segments(phases: &[Phase]) -> Vec<(Phase, usize, usize)> {
    let mut out: Vec<(Phase, usize, usize)> = Vec::new();
    for (i, &p) in phases.iter().enumerate() {
        match out.last_mut() {
            Some(last) if last.0 == p => last.2 = i + 1,
            _ => out.push((p, i, i + 1)),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn indentation_cycle_is_segmented() {
        // Approach, load at 1 unit/s, hold, unload, retract.
        let mut c = PhaseClassifier::new(0.1);
        let mut phases = Vec::new();
        for _ in 0..10 {
            phases.push(c.classify(false, 1.0));
        }
        for _ in 0..20 {
            phases.push(c.classify(true, 1.0));
        }
        for i in 0..20 {
            // Creep: slow drift with noise inside the band.
            phases.push(c.classify(true, 0.02 * (i % 3) as f64));
        }
        for _ in 0..20 {
            phases.push(c.classify(true, -1.0));
        }
        for _ in 0..5 {
            phases.push(c.classify(false, -1.0));
        }
        let seg: Vec<Phase> = segments(&phases).into_iter().map(|s| s.0).collect();
        assert_eq!(
            seg,
            vec![
                Phase::FreeSpace,
                Phase::Loading,
                Phase::Hold,
                Phase::Unloading,
                Phase::Release
            ]
        );
    }

    #[test]
    fn hysteresis_keeps_noise_from_flickering() {
        let mut c = PhaseClassifier::new(1.0);
        c.classify(true, 2.0);
        // Between v*/2 and v*: stays loading.
        for _ in 0..10 {
            assert_eq!(c.classify(true, 0.7), Phase::Loading);
        }
        assert_eq!(c.classify(true, 0.3), Phase::Hold);
    }

    /// One selection of the travel serves every sample time, to the bit: the speeds'
    /// percentile is the travel's divided by the span's duration.
    #[test]
    fn the_span_travel_gives_the_speeds_own_percentile_exactly() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let x: Vec<f64> = (0..20_000)
            .map(|i| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                1e-3 * (i as f64 * 0.01).sin() + 1e-7 * (state % 1000) as f64
            })
            .collect();
        let travel = SpanTravel::of(&x);
        for dt in [1e-3, f64::from(1e-3f32), 1.0 / 124.22, 0.1] {
            let mut speeds: Vec<f64> = x
                .windows(6)
                .map(|w| ((w[5] - w[0]) / (5.0 * dt)).abs())
                .collect();
            assert_eq!(
                travel.loading_speed(dt),
                loading_speed_of(&mut speeds),
                "dt {dt}"
            );
        }
        assert_eq!(SpanTravel::of(&x[..2]).loading_speed(1e-3), 0.0);
    }

    #[test]
    fn speed_threshold_is_a_fraction_of_the_fast_motion() {
        let x: Vec<f64> = (0..1000)
            .map(|i| if i < 500 { i as f64 * 1e-6 } else { 500e-6 })
            .collect();
        let v = speed_threshold(&x, 1e-3);
        assert!((v - LOADING_SPEED_FRACTION * 1e-3).abs() < 1e-8, "{v}");
    }
}
