//! The record as the front end fits it: at most [`MAX_POINTS`] points (so that a 600 s,
//! 1 kHz file costs the same as a 10 s one), each the mean of a run of native samples
//! short enough that the motion within it is negligible, with a zero-phase rate estimate
//! computed on the native samples.

/// Most fitting points; a longer record is split into blocks of equal length, one point
/// each.
pub const MAX_POINTS: usize = 6000;

/// Half-widths \[s\] tried for the symmetric difference that estimates the rate, shortest
/// first: 4 ms follows a 10 Hz tap; a slow indentation with nanometre jitter needs up to
/// 0.5 s before its rate is more than noise. (A one-sample difference was tried: its rate
/// noise, up to [`MAX_RATE_NOISE`] of the speed on an encoder's quantisation, made the
/// damping column of a constant-speed ramp look independent of the stiffness's, VIF 2.5e4
/// → below the limit, and λ was reported determined at one speed. The corners of a ramp
/// that a wider window smears are left out instead: [`KINK_FRACTION`].)
pub const RATE_HALF_WINDOWS_S: [f64; 7] = [4.0e-3, 10.0e-3, 25.0e-3, 50.0e-3, 0.1, 0.25, 0.5];

/// Largest change of the native rate over one sample, as a fraction of the record's
/// 99.9th-percentile speed, that is still motion: a larger one is a kink (a ramp starting
/// or stopping within a sample), where the rate is not defined and the symmetric difference
/// gives a value between the two sides that neither side's force follows. Points whose rate
/// reads across a kink are left out of the fit ([`Series::kinks`]). A 10 Hz tap sampled at
/// 1 kHz changes its rate by 6 % of its peak per sample.
pub const KINK_FRACTION: f64 = 0.2;

/// Largest share of the points a kink may remove: beyond it the motion is not made of
/// smooth pieces at this sample rate (a tap sampled a few times per cycle) and every point
/// is kept.
pub const MAX_KINK_SHARE: f64 = 0.05;

/// Largest share of the moving samples (one-sample speed above
/// [`crate::phases::LOADING_SPEED_FRACTION`] of the fast speed) that may be kinks: a ramp
/// has two (its start and its end) in dozens of moving samples; a quantised position
/// moving a count at a time makes every step one.
pub const MAX_KINK_SHARE_OF_MOTION: f64 = 0.1;

/// [`MAX_KINK_SHARE_OF_MOTION`] for the diagnosis's block means (`rate_and_kinks`): a fast
/// ramp lasts a few blocks, and its two to six kinks are a fifth or more of the moving
/// blocks (a 60 ms ramp at 5 ms blocks: 6 of 28), which the rule for points (a quantised
/// encoder's every count a kink) read as no kinks at all; block means average the counts.
/// The three blocks at a structure sweep ramp-and-hold's corners then carried 90 % of its
/// Kelvin-Voigt baseline's RSS.
pub const MAX_KINK_SHARE_OF_BLOCKS_IN_MOTION: f64 = 0.5;

/// Largest rate noise the chosen half-width may leave, as a fraction of the record's
/// 99.9th-percentile speed.
pub const MAX_RATE_NOISE: f64 = 0.02;

/// Largest travel of the position within one averaged run (99th percentile over the
/// points), as a fraction of the record's position range. A mean over a run that spans a
/// good part of a tap is not a point of the law (a 0.1 s block of a 2 Hz tap averages
/// a fifth of the cycle, contact onset included), so a fast record averages fewer
/// samples per point instead.
pub const MAX_RUN_TRAVEL: f64 = 0.01;

/// The fitting points of a record.
#[derive(Debug, Clone)]
pub struct Series {
    /// Time \[s\] of each point (mean over its run).
    pub time_s: Vec<f64>,
    /// Position \[m\] on the record's own axis (mean over its run).
    pub position_m: Vec<f64>,
    /// Rate of the position \[m/s\]: the native symmetric difference, mean over the run.
    pub rate_m_per_s: Vec<f64>,
    /// Acceleration of the position \[m/s²\]: the symmetric difference of the points'
    /// rates over their neighbours (one-sided at the ends), for a mass's m·δ̈; 0 beside a
    /// kink ([`Series::without_kinks`]).
    pub accel_m_per_s2: Vec<f64>,
    /// Force \[N\] (mean over its run).
    pub force_n: Vec<f64>,
    /// Native samples each point stands for (the block length).
    pub block: usize,
    /// Width \[m\] of the positions each point averages, as a uniform spread: the run's
    /// travel (max − min) × m/(m − 1) for a run of m samples (each sample stands for 1/m of
    /// it), 0 for one sample. Where a run straddles the contact point its mean force is
    /// the mean of the law over the run, not the law at the mean (a Kelvin-Voigt law jumps
    /// by λ·v at contact).
    pub spread_m: Vec<f64>,
    /// Native samples averaged into each point (≤ `block`): the force noise of a point
    /// is the native noise / √`averaged`.
    pub averaged: usize,
    /// Points left out because their rate reads across a kink of the motion
    /// ([`KINK_FRACTION`], [`Series::without_kinks`]; 0 in a [`Series::subset`]).
    pub kinks: usize,
    /// Which points [`Series::without_kinks`] keeps (`None`: all).
    kink_free: Option<Vec<bool>>,
}

impl Series {
    /// Force noise of a point \[N\] from the noise of one native sample \[N\]: over the
    /// square root of the samples averaged into it ([`Series::averaged`]).
    pub fn point_noise_n(&self, sample_noise_n: f64) -> f64 {
        sample_noise_n / (self.averaged as f64).sqrt()
    }

    /// The points of `time_s`, `position_m`, `force_n` (same length ≥ 2, time
    /// increasing): the record is cut into blocks of ⌈n / [`MAX_POINTS`]⌉ samples, and each
    /// block gives the mean of one run of `averaged` consecutive samples: the whole block
    /// when the position travels less than [`MAX_RUN_TRAVEL`] of its range across it, else
    /// the longest power-of-two fraction of it that does, starting at a pseudo-random
    /// (fixed-seed) place in the block so that a periodic motion is not sampled at the
    /// same few phases.
    pub fn new(time_s: &[f64], position_m: &[f64], force_n: &[f64]) -> Series {
        let n = time_s.len().min(position_m.len()).min(force_n.len());
        let block = n.div_ceil(MAX_POINTS).max(1);
        let points = (n / block).max(1);
        let averaged = run_length(&position_m[..n], block, points);
        let starts: Vec<usize> = (0..points)
            .map(|b| b * block + jitter(b, (block - averaged + 1).min(n - b * block)))
            .collect();
        let run = |s: usize| s..(s + averaged).min(n);
        let mean = |v: &[f64], s: usize| {
            let r = &v[run(s)];
            r.iter().sum::<f64>() / r.len() as f64
        };
        let time: Vec<f64> = starts.iter().map(|&s| mean(time_s, s)).collect();
        let position: Vec<f64> = starts.iter().map(|&s| mean(position_m, s)).collect();
        let force: Vec<f64> = starts.iter().map(|&s| mean(force_n, s)).collect();
        let spread: Vec<f64> = starts
            .iter()
            .map(|&s| {
                let r = &position_m[run(s)];
                let (lo, hi) = super::fit::min_max(r);
                if r.len() > 1 {
                    (hi - lo) * r.len() as f64 / (r.len() - 1) as f64
                } else {
                    0.0
                }
            })
            .collect();
        let sigma_x = crate::setup::noise_level(&position_m[..n]);
        let (rate, k) = native_rate(&time_s[..n], &position_m[..n], sigma_x, &starts, averaged);
        let kink_free = kink_counts(
            &time_s[..n],
            &position_m[..n],
            sigma_x,
            &rate,
            MAX_KINK_SHARE_OF_MOTION,
        )
        .and_then(|kinks| off_kinks(&kinks, &starts, averaged, k));
        Series {
            accel_m_per_s2: point_accel(&time, &rate),
            time_s: time,
            position_m: position,
            rate_m_per_s: rate,
            force_n: force,
            spread_m: spread,
            block,
            averaged,
            kinks: 0,
            kink_free,
        }
    }

    /// The series without the points whose rate reads across a kink of the motion (none
    /// when kinks would remove more than [`MAX_KINK_SHARE`] of them): for the laws whose
    /// columns read the rate (Kelvin-Voigt, Hunt-Crossley, exponential damping). The
    /// relaxation laws do not read it, and there those points are the peak of a step and
    /// the start of its relaxation.
    pub fn without_kinks(mut self) -> Series {
        match self.kink_free.take() {
            Some(keep) => {
                // A kept point next to a kink differences its rate against the kink's
                // smeared one: an acceleration that is the kink's step, not motion (a
                // ramp's speed is constant on either side). 0 there.
                let n = keep.len();
                for i in 0..n {
                    let beside = (i > 0 && !keep[i - 1]) || (i + 1 < n && !keep[i + 1]);
                    if keep[i] && beside {
                        self.accel_m_per_s2[i] = 0.0;
                    }
                }
                Series {
                    kinks: keep.iter().filter(|k| !**k).count(),
                    ..self.subset(&keep)
                }
            }
            None => self,
        }
    }

    /// The points where `keep` is true (rates kept as computed on the whole series).
    pub fn subset(&self, keep: &[bool]) -> Series {
        let pick = |v: &[f64]| {
            v.iter()
                .zip(keep)
                .filter(|(_, k)| **k)
                .map(|(x, _)| *x)
                .collect()
        };
        Series {
            time_s: pick(&self.time_s),
            position_m: pick(&self.position_m),
            rate_m_per_s: pick(&self.rate_m_per_s),
            accel_m_per_s2: pick(&self.accel_m_per_s2),
            force_n: pick(&self.force_n),
            spread_m: pick(&self.spread_m),
            block: self.block,
            averaged: self.averaged,
            kinks: 0,
            kink_free: None,
        }
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.time_s.len()
    }

    /// `true` without points.
    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }
}

/// The derivative of the points' `rate` over their `time`: the symmetric difference over
/// each point's neighbours, one-sided at the ends (0 for fewer than two points).
fn point_accel(time: &[f64], rate: &[f64]) -> Vec<f64> {
    let n = time.len();
    (0..n)
        .map(|i| {
            let (a, b) = (i.saturating_sub(1), (i + 1).min(n.saturating_sub(1)));
            let dt = time[b] - time[a];
            if b > a && dt > 0.0 {
                (rate[b] - rate[a]) / dt
            } else {
                0.0
            }
        })
        .collect()
}

/// Samples averaged per point: `block`, halved while the 99th percentile over the blocks
/// of the position's travel across a run exceeds [`MAX_RUN_TRAVEL`] of its range.
fn run_length(position: &[f64], block: usize, points: usize) -> usize {
    let (lo, hi) = super::fit::min_max(position);
    let limit = MAX_RUN_TRAVEL * (hi - lo);
    let mut m = block;
    while m > 1 {
        let mut travel: Vec<f64> = (0..points)
            .map(|b| {
                let r = &position[b * block..(b * block + m).min(position.len())];
                let (l, h) = super::fit::min_max(r);
                h - l
            })
            .collect();
        let k = ((travel.len() - 1) as f64 * 0.99) as usize;
        let (_, p99, _) = travel.select_nth_unstable_by(k, f64::total_cmp);
        if *p99 <= limit {
            break;
        }
        m /= 2;
    }
    m
}

/// A fixed pseudo-random offset in `0..span` for block `b` (SplitMix64).
fn jitter(b: usize, span: usize) -> usize {
    if span <= 1 {
        return 0;
    }
    let mut z = (b as u64)
        .wrapping_add(1)
        .wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z % span as u64) as usize
}

/// The rate of each point: the native symmetric difference of [`symmetric_rate`] averaged
/// over the point's run, with the half-width chosen as in [`rate_and_kinks`] (σ_x from the
/// native position's second differences, `sigma_x`; the 99.9th-percentile speed over the
/// points), and
/// that half-width in samples.
fn native_rate(
    time_s: &[f64],
    position: &[f64],
    sigma_x: f64,
    starts: &[usize],
    averaged: usize,
) -> (Vec<f64>, usize) {
    let n = time_s.len();
    if n < 2 {
        return (vec![0.0; starts.len()], 1);
    }
    let dt = (time_s[n - 1] - time_s[0]) / (n - 1) as f64;
    let mut last = (Vec::new(), 1);
    for (k, h) in half_windows(dt) {
        let at = |i: usize| symmetric_difference(time_s, position, i, k);
        let rate: Vec<f64> = starts
            .iter()
            .map(|&s| {
                let run = s..(s + averaged).min(n);
                let len = run.len() as f64;
                run.map(at).sum::<f64>() / len
            })
            .collect();
        if quiet_enough(sigma_x, h, fast_speed(&rate)) {
            return (rate, k);
        }
        last = (rate, k);
    }
    last
}

/// The half-widths of [`RATE_HALF_WINDOWS_S`] at sample interval `dt` \[s\]: (samples, at
/// least one; seconds).
fn half_windows(dt: f64) -> impl Iterator<Item = (usize, f64)> {
    RATE_HALF_WINDOWS_S
        .into_iter()
        .map(move |h| (((h / dt).round() as usize).max(1), h))
}

/// The 99.9th-percentile speed of `rate` (0 when empty).
pub(crate) fn fast_speed(rate: &[f64]) -> f64 {
    let mut speeds: Vec<f64> = rate.iter().map(|v| v.abs()).collect();
    crate::phases::percentile_999(&mut speeds)
}

/// Whether a symmetric difference of half-width `h` \[s\] on a position of noise
/// `sigma_x` has a noise (σ_x/(√2·h)) within [`MAX_RATE_NOISE`] of the speed `fast`.
fn quiet_enough(sigma_x: f64, h: f64, fast: f64) -> bool {
    sigma_x / (std::f64::consts::SQRT_2 * h) <= MAX_RATE_NOISE * fast
}

/// Which points to keep, given the kinks counted up to each native sample (`kinks`, from
/// [`kink_counts`]): `None` when no point's rate reads across a kink of the motion, or
/// when kinks would remove more than [`MAX_KINK_SHARE`] of them; else `false` for the
/// points whose rate (the mean over the run from each start, `averaged` samples, of
/// symmetric differences of half-width `k` samples) spans a kink.
fn off_kinks(kinks: &[usize], starts: &[usize], averaged: usize, k: usize) -> Option<Vec<bool>> {
    let n = kinks.len() - 1;
    // The symmetric difference at j reads x[j − k] and x[j + k]: a kink strictly between
    // them bends it. A run from s of `averaged` samples: kinks in s − k + 1 ..= s + m + k − 2.
    let keep: Vec<bool> = starts
        .iter()
        .map(|&s| {
            let lo = (s + 1).saturating_sub(k);
            let hi = (s + averaged + k - 1).min(n);
            kinks[hi] == kinks[lo.min(hi)]
        })
        .collect();
    let dropped = keep.iter().filter(|k| !**k).count();
    (dropped > 0 && dropped as f64 <= MAX_KINK_SHARE * keep.len() as f64).then_some(keep)
}

/// The kinks of `position` counted up to each sample (`n + 1` counts: element i + 1 counts
/// those at samples ≤ i): samples whose rate changes by more than [`KINK_FRACTION`] of the
/// 99.9th-percentile point speed and by more than 8 deviations of that change's noise
/// (σ_x·√6 / Δt, σ_x from second differences). `None` when there are none, or when they
/// are more than `max_share_of_motion` of the moving samples ([`MAX_KINK_SHARE_OF_MOTION`]
/// for points: an encoder's slow ramp, where most samples do not change, the median
/// second difference is 0, and every count is a step of the one-sample rate).
fn kink_counts(
    time_s: &[f64],
    position: &[f64],
    sigma_x: f64,
    rate: &[f64],
    max_share_of_motion: f64,
) -> Option<Vec<usize>> {
    let n = time_s.len();
    if n < 3 {
        return None;
    }
    let dt = (time_s[n - 1] - time_s[0]) / (n - 1) as f64;
    let noise = 8.0 * sigma_x * 6f64.sqrt() / dt;
    let fast_speed_of = fast_speed(rate);
    let limit = (KINK_FRACTION * fast_speed_of).max(noise);
    // Kinks counted up to each sample: the difference of the rates on either side of i.
    let mut kinks = vec![0usize; n + 1];
    let mut moving = 0usize;
    for i in 0..n {
        if i + 1 < n
            && (position[i + 1] - position[i]).abs()
                > crate::phases::LOADING_SPEED_FRACTION
                    * fast_speed_of
                    * (time_s[i + 1] - time_s[i])
        {
            moving += 1;
        }
        // |Δx⁺/Δt⁺ − Δx⁻/Δt⁻| > limit, multiplied out (one pass over a long record).
        let kink = i > 0 && i + 1 < n && {
            let (ta, tb) = (time_s[i + 1] - time_s[i], time_s[i] - time_s[i - 1]);
            let change =
                (position[i + 1] - position[i]) * tb - (position[i] - position[i - 1]) * ta;
            change.abs() > limit * ta * tb
        };
        kinks[i + 1] = kinks[i] + usize::from(kink);
    }
    (kinks[n] > 0 && kinks[n] as f64 <= max_share_of_motion * moving as f64).then_some(kinks)
}

/// The rate of `position` by the shortest symmetric difference of [`RATE_HALF_WINDOWS_S`]
/// whose noise (σ_x/(√2·h), σ_x the position noise from second differences) stays below
/// [`MAX_RATE_NOISE`] of the 99.9th-percentile speed it gives (not the 99th: the ramps of
/// a ramp-and-hold are 1-2 % of its samples), and which samples' rate reads across a kink
/// of the motion (`true`; by the front end's [`KINK_FRACTION`], with up to
/// [`MAX_KINK_SHARE_OF_BLOCKS_IN_MOTION`] of the moving blocks kinks; all `false` when
/// there are none or too many to be kinks). A kept rate whose difference ends on a kinked
/// block (a mean of both sides) is the one-sided difference away from it. Both of length
/// `position.len()`.
///
/// The window's noise reads σ_x from third differences (`curvature_free_noise`): on
/// block means of a fast oscillation the second differences are the motion's own
/// curvature (25 µm on a 7 Hz, 0.5 mm tap at 5 ms blocks, against 0.1 µm of encoder
/// noise), which chose a 25 ms half-window and read the speed 19 % low (sinc ωh): a
/// material's damping then came out 20 % low and the misfit named a delay for a mass.
/// The kinks keep σ_x from second differences, under which a smooth motion's curvature
/// is not a kink.
///
/// Away from kinks, the rate is the block's mean rate to fourth order, Richardson's
/// (4·D(k) − D(2k))/3 of the symmetric differences, where the squared error that removes
/// exceeds the noise it adds over the `judged` blocks (those whose rates a fit reads;
/// empty: all): a fast motion's rate, which the symmetric difference misses by δ⃛·h²/6.
/// The third value says whether it did.
pub fn rate_and_kinks(
    time_s: &[f64],
    position: &[f64],
    judged: &[bool],
) -> (Vec<f64>, Vec<bool>, bool) {
    let n = time_s.len();
    let sigma_x = crate::setup::noise_level(position);
    let starts: Vec<usize> = (0..n).collect();
    let sigma_smooth = curvature_free_noise(position);
    let (mut rate, k) = native_rate(time_s, position, sigma_smooth, &starts, 1);
    let fourth_order = |rate: &mut [f64], clear: &dyn Fn(usize) -> bool| -> bool {
        let eligible: Vec<usize> = (2 * k..n.saturating_sub(2 * k))
            .filter(|j| clear(*j))
            .collect();
        let fourth: Vec<f64> = eligible
            .iter()
            .map(|&j| mean_rate_of_block(time_s, position, j, k))
            .collect();
        let pays = fourth_order_pays(time_s, k, sigma_smooth, judged, &eligible, &fourth, rate);
        if pays {
            for (&j, v) in eligible.iter().zip(fourth) {
                rate[j] = v;
            }
        }
        pays
    };
    let share = MAX_KINK_SHARE_OF_BLOCKS_IN_MOTION;
    let Some((kinks, keep)) = kink_counts(time_s, position, sigma_x, &rate, share)
        .and_then(|kinks| off_kinks(&kinks, &starts, 1, k).map(|keep| (kinks, keep)))
    else {
        let fourth = fourth_order(&mut rate, &|_| true);
        return (rate, vec![false; n], fourth);
    };
    // A block in which the motion bends is a mean over both sides, on neither line: a
    // kept difference that ends on it reads across the kink too (the block after a
    // ramp-and-hold's ramp read 5 mm/s, a sixth of the ramp's speed, where the hold has
    // none: 10 N of λ·v the force never had). Such a block's rate is the one-sided
    // difference away from the kink, exact on its own side's line.
    let kinked = |i: usize| {
        kinks
            .get(i + 1)
            .zip(kinks.get(i))
            .is_some_and(|(a, b)| a > b)
    };
    let mut left_out: Vec<bool> = keep.iter().map(|k| !k).collect();
    // No kink among the samples in `range`.
    let clear = |mut range: std::ops::Range<usize>| range.all(|i| !kinked(i));
    for j in (0..n).filter(|j| keep[*j]) {
        let (lo, hi) = (j.saturating_sub(k), (j + k).min(n - 1));
        let (left, right) = (lo < j && kinked(lo), hi > j && kinked(hi));
        match (left, right) {
            (false, false) => {}
            // Over the symmetric difference's span 2k where its own side has no kink
            // (the same noise; over k alone, twice it), else over k. (The other end is
            // past the kink: at a record's end, j itself.)
            (true, false) if hi > j => {
                let far = (j + 2 * k).min(n - 1);
                let hi = if clear(j + 1..far + 1) { far } else { hi };
                rate[j] = (position[hi] - position[j]) / (time_s[hi] - time_s[j]);
            }
            (false, true) if lo < j => {
                let far = j.saturating_sub(2 * k);
                let lo = if clear(far..j) { far } else { lo };
                rate[j] = (position[j] - position[lo]) / (time_s[j] - time_s[lo]);
            }
            _ => left_out[j] = true,
        }
    }
    // Where no kink lies within the span the stencil reads.
    let fourth = fourth_order(&mut rate, &|j| {
        !left_out[j] && kinks[j + 2 * k + 1] == kinks[j - 2 * k]
    });
    (rate, left_out, fourth)
}

/// Whether the blocks' fourth-order rates (`fourth`, at `eligible`) are to replace the
/// symmetric differences of half-width `k` (`rate`): where the squared error they remove
/// exceeds the noise they add, over the `judged` blocks among the eligible (all when
/// `judged` is empty). With σ the block means' noise and h = k·Δt, the symmetric
/// difference's variance is σ²/(2h²), the fourth-order one's 130/144·σ²/h², and their
/// difference c (the symmetric difference's bias, δ⃛·h²/6, plus noise) has variance
/// 10/144·σ²/h². The bias removed is E[c²] − 10/144·σ²/h², the variance added
/// 58/144·σ²/h²: the fourth order pays where the judged blocks' mean c² exceeds
/// 68/144·σ²/h². A slow or noisy motion keeps the symmetric difference, whose bias is
/// below its noise (the structure sweep's records that never leave contact: the fourth
/// order everywhere added a relaxation to a clean Kelvin-Voigt record, seed 3017, and
/// dropped a QLV's relaxation, seed 3000); fast taps, impacts and chirps take it.
fn fourth_order_pays(
    time_s: &[f64],
    k: usize,
    sigma: f64,
    judged: &[bool],
    eligible: &[usize],
    fourth: &[f64],
    rate: &[f64],
) -> bool {
    let (mut sum, mut count) = (0.0, 0usize);
    for (&j, v) in eligible.iter().zip(fourth) {
        if judged.is_empty() || judged[j] {
            sum += (v - rate[j]).powi(2);
            count += 1;
        }
    }
    let n = time_s.len();
    if count == 0 || n < 2 {
        return false;
    }
    let h = k as f64 * (time_s[n - 1] - time_s[0]) / (n - 1) as f64;
    sum / count as f64 > 68.0 / 144.0 * (sigma / h).powi(2)
}

/// The mean rate over block `j` of `position` (block means; `j` at least `2k` from
/// either end): Richardson's (4·D(k) − D(2k))/3 of the symmetric differences D of
/// half-widths `k` and `2k` samples. A symmetric difference of block means of half-width
/// h is the block's mean rate plus h²/6 of its mean δ⃛ (plus O(h⁴)); the combination
/// cancels that term: at k = 1, (x̄ⱼ₋₂ − 8x̄ⱼ₋₁ + 8x̄ⱼ₊₁ − x̄ⱼ₊₂)/(12Δt). Used where the
/// record's motion bends fast enough against its noise ([`fourth_order_pays`]). Its noise
/// is √1.8 times D(k)'s.
fn mean_rate_of_block(time_s: &[f64], position: &[f64], j: usize, k: usize) -> f64 {
    let d = |h: usize| (position[j + h] - position[j - h]) / (time_s[j + h] - time_s[j - h]);
    richardson_rate(d(k), d(2 * k))
}

/// Richardson's combination (4·D(h) − D(2h))/3 of two symmetric differences of block
/// means about the same centre, half-widths h and 2h \[m/s\]: the block's mean rate to
/// fourth order (the h²/6·δ⃛ term of each cancels). The one formula of the front end's
/// rates ([`rate_and_kinks`]) and the discrepancy workflow's delayed rates.
pub fn richardson_rate(d_h: f64, d_2h: f64) -> f64 {
    (4.0 * d_h - d_2h) / 3.0
}

/// Robust noise level of `x` from third differences, σ = MAD(Δ³x)/0.6745/√20: like
/// [`crate::setup::noise_level`] on white noise, but a motion that is quadratic over four
/// samples cancels, so a fast smooth motion is not read as noise. Its third-order term
/// stays, A·(ωΔt)³ on a sine: at 5 ms samples of a 0.5 mm oscillation σ reads 1.2 µm at
/// 7 Hz (the shortest window still passes) but 11 µm at 15 Hz (a 10 ms half-window,
/// the speed ≈ 14 % low): faster motion needs a faster block or a noise from the free
/// space.
fn curvature_free_noise(x: &[f64]) -> f64 {
    crate::setup::difference_noise(x, 4, |w| w[3] - 3.0 * w[2] + 3.0 * w[1] - w[0], 20.0)
}

/// (x\[i+k\] − x\[i−k\]) / (t\[i+k\] − t\[i−k\]) with k the number of samples in
/// `half_window_s` (at least 1, clipped at the ends): zero-phase, unlike the causal
/// state-variable filter, which the batch fits have no need for.
pub fn symmetric_rate(time_s: &[f64], position: &[f64], half_window_s: f64) -> Vec<f64> {
    let n = time_s.len();
    if n < 2 {
        return vec![0.0; n];
    }
    let dt = (time_s[n - 1] - time_s[0]) / (n - 1) as f64;
    let k = ((half_window_s / dt).round() as usize).max(1);
    (0..n)
        .map(|i| symmetric_difference(time_s, position, i, k))
        .collect()
}

/// (x\[i+k\] − x\[i−k\]) / (t\[i+k\] − t\[i−k\]), clipped at the ends; 0 over no time.
fn symmetric_difference(time_s: &[f64], position: &[f64], i: usize, k: usize) -> f64 {
    let n = time_s.len();
    let (lo, hi) = (i.saturating_sub(k), (i + k).min(n - 1));
    let span = time_s[hi] - time_s[lo];
    if span > 0.0 {
        (position[hi] - position[lo]) / span
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ramp-and-hold at 1 kHz: 0.1 s of ramp at `speed` \[m/s\] from t = 0.5 s, then a
    /// 5 s hold, the position rounded to `quantum` \[m\] (0: exact).
    fn ramp_and_hold(speed: f64, quantum: f64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let t: Vec<f64> = (0..6000).map(|i| i as f64 * 1e-3).collect();
        let x: Vec<f64> = t
            .iter()
            .map(|t| {
                let x = speed * (t - 0.5).clamp(0.0, 0.1);
                if quantum > 0.0 {
                    (x / quantum).round() * quantum
                } else {
                    x
                }
            })
            .collect();
        let f: Vec<f64> = x.iter().map(|x| 1e3 * x).collect();
        (t, x, f)
    }

    #[test]
    fn a_ramp_s_corners_are_kinks_and_an_encoder_s_counts_are_not() {
        // Exact: the start and the end of the ramp bend the rate of the points whose
        // window spans them (k = 4 samples each side: two corners, 7 samples each).
        let (t, x, f) = ramp_and_hold(0.05, 0.0);
        let s = Series::new(&t, &x, &f).without_kinks();
        assert_eq!(s.kinks, 14);
        assert_eq!(s.len(), 6000 - 14);
        // The kept points beside a corner read no acceleration from its step: the ramp's
        // speed is constant on either side (the difference across the corner's smeared
        // rates had been up to 0.05 m/s over 2 ms).
        let largest = s.accel_m_per_s2.iter().fold(0.0f64, |m, a| m.max(a.abs()));
        assert!(largest < 1e-6, "{largest}");
        // A 1 µm encoder at 0.3 counts per sample: every count is a step of the
        // one-sample rate; none is taken for a kink.
        let (t, x, f) = ramp_and_hold(3e-4, 1e-6);
        let s = Series::new(&t, &x, &f).without_kinks();
        assert_eq!(s.kinks, 0);
        assert_eq!(s.len(), 6000);
    }

    /// Block means of a fast smooth motion (a 25 Hz, 1 mm oscillation sampled at 1 kHz,
    /// in 2 ms blocks, where the shortest half-width is two blocks): the rate is the mean
    /// of the raw samples' rates within 0.5 % of the peak speed, where the symmetric
    /// difference of the means alone misses it by δ⃛·h²/6, 6.6 % of the peak speed.
    #[test]
    fn block_rates_of_a_fast_motion_are_the_blocks_mean_rates() {
        let (amplitude, omega, block) = (1e-3, 2.0 * std::f64::consts::PI * 25.0, 2);
        let raw_t: Vec<f64> = (0..1000).map(|i| i as f64 * 1e-3).collect();
        let raw: Vec<f64> = raw_t
            .iter()
            .map(|t| amplitude * (omega * t).sin())
            .collect();
        let raw_rate: Vec<f64> = raw_t
            .iter()
            .map(|t| amplitude * omega * (omega * t).cos())
            .collect();
        let mean = |v: &[f64]| -> Vec<f64> {
            v.chunks_exact(block)
                .map(|c| c.iter().sum::<f64>() / block as f64)
                .collect()
        };
        let (time, means, truth) = (mean(&raw_t), mean(&raw), mean(&raw_rate));
        let (rate, kink, _) = rate_and_kinks(&time, &means, &[]);
        assert!(kink.iter().all(|k| !k));
        let peak = amplitude * omega;
        let interior = 4..means.len() - 4;
        let worst = interior
            .clone()
            .map(|b| (rate[b] - truth[b]).abs())
            .fold(0.0, f64::max);
        assert!(worst < 5e-3 * peak, "{worst} against {peak}");
        let plain = interior
            .map(|b| ((means[b + 2] - means[b - 2]) / (time[b + 2] - time[b - 2]) - truth[b]).abs())
            .fold(0.0, f64::max);
        assert!(plain > 5e-2 * peak, "{plain} against {peak}");
    }

    /// A slow motion under noise (a 0.5 Hz, 1 mm oscillation in 5 ms blocks, 2 µm of
    /// noise on the block means) keeps the symmetric difference: its bias (0.01 % of the
    /// peak speed) is far below the noise the fourth order would add.
    #[test]
    fn block_rates_of_a_slow_noisy_motion_stay_symmetric_differences() {
        let omega = 2.0 * std::f64::consts::PI * 0.5;
        let time: Vec<f64> = (0..2000).map(|b| b as f64 * 5e-3).collect();
        // (A fixed pseudo-random noise: SplitMix64 through a uniform ±√3·σ.)
        let means: Vec<f64> = time
            .iter()
            .enumerate()
            .map(|(b, t)| {
                let u = jitter(b, 1 << 20) as f64 / f64::from(1 << 20) - 0.5;
                1e-3 * (omega * t).sin() + 2e-6 * 12f64.sqrt() * u
            })
            .collect();
        let (rate, _, fourth) = rate_and_kinks(&time, &means, &[]);
        assert!(!fourth);
        let symmetric = (1..200).find(|k| {
            (2 * k..time.len() - 2 * k)
                .all(|j| rate[j] == symmetric_difference(&time, &means, j, *k))
        });
        assert!(symmetric.is_some(), "a rate is not a symmetric difference");
    }

    /// The diagnosis's block means of a fast ramp-and-hold (a 60 ms ramp at 30 mm/s, a
    /// 1 s hold, the same ramp back, each corner inside a 5 ms block): a block with a
    /// corner inside is left out, and every other reads its own side's rate exactly. Before
    /// [`MAX_KINK_SHARE_OF_BLOCKS_IN_MOTION`] the ramp's six kinks were more than a tenth of
    /// its 28 moving blocks and none was flagged, and the block after each corner (a mean
    /// of both sides, an end of the next block's difference) gave a rate between the
    /// sides, where it now reads its own side's by a one-sided difference: on a structure
    /// sweep record those three blocks carried 90 % of a Kelvin-Voigt baseline's RSS.
    #[test]
    fn block_means_of_a_fast_ramp_keep_only_rates_of_one_side() {
        let (speed, ramp_s, block) = (0.03, 0.06, 5);
        let position = |t: f64| {
            let up = speed * (t - 0.5023).clamp(0.0, ramp_s);
            let down = speed * (t - 1.5623).clamp(0.0, ramp_s);
            up - down
        };
        let slope = |t: f64| {
            if (0.5023..0.5023 + ramp_s).contains(&t) {
                speed
            } else if (1.5623..1.5623 + ramp_s).contains(&t) {
                -speed
            } else {
                0.0
            }
        };
        let raw: Vec<f64> = (0..2500).map(|i| position(i as f64 * 1e-3)).collect();
        let blocks = raw.len() / block;
        let dt = block as f64 * 1e-3;
        let time: Vec<f64> = (0..blocks).map(|b| b as f64 * dt).collect();
        let means: Vec<f64> = raw
            .chunks_exact(block)
            .map(|c| c.iter().sum::<f64>() / block as f64)
            .collect();
        let (rate, kink, _) = rate_and_kinks(&time, &means, &[]);
        assert!(kink.iter().any(|k| *k), "no kink flagged");
        assert!(kink.iter().filter(|k| **k).count() <= 12, "{kink:?}");
        for b in (0..blocks).filter(|b| !kink[*b]) {
            // The motion's rate over this block's raw samples: one side's.
            let sides: Vec<f64> = (b * block..(b + 1) * block)
                .map(|i| slope(i as f64 * 1e-3))
                .collect();
            assert!(
                sides.iter().all(|v| *v == sides[0]),
                "block {b} kept across a corner: rate {}",
                rate[b]
            );
            assert!(
                (rate[b] - sides[0]).abs() < 1e-9,
                "block {b}: {} against {}",
                rate[b],
                sides[0]
            );
        }
    }

    #[test]
    fn long_records_are_averaged_in_blocks_and_rates_are_exact_on_ramps() {
        let n = 20_000;
        let t: Vec<f64> = (0..n).map(|i| i as f64 * 1e-3).collect();
        let x: Vec<f64> = t.iter().map(|t| 2e-3 * t).collect();
        let f: Vec<f64> = t.iter().map(|t| 3.0 + t).collect();
        let s = Series::new(&t, &x, &f);
        assert_eq!(s.block, 4);
        assert_eq!(s.len(), 5000);
        assert!((s.time_s[0] - 1.5e-3).abs() < 1e-12);
        assert_eq!(s.averaged, 4);
        assert!(s.rate_m_per_s.iter().all(|v| (v - 2e-3).abs() < 1e-9));
    }

    /// A 600 s record of 2 Hz taps: a 100-sample block spans a fifth of a tap, so each
    /// point averages a short run instead, at phases spread over the whole cycle.
    #[test]
    fn fast_taps_in_a_long_record_are_not_averaged_across_the_tap() {
        let n = 600_000;
        let t: Vec<f64> = (0..n).map(|i| i as f64 * 1e-3).collect();
        let x: Vec<f64> = t
            .iter()
            .map(|t| 1e-3 * (1.0 - (2.0 * std::f64::consts::PI * 2.0 * t).cos()))
            .collect();
        let f: Vec<f64> = x.iter().map(|x| 1e6 * x * x).collect();
        let s = Series::new(&t, &x, &f);
        assert_eq!(s.block, 100);
        assert!(s.averaged <= 2, "averaged {}", s.averaged);
        // each point still lies on the law (its run is short) ...
        for (x, f) in s.position_m.iter().zip(&s.force_n) {
            assert!((f - 1e6 * x * x).abs() < 1e-3 * 4.0, "{x} {f}");
        }
        // ... and the phases of the cycle are all visited, not 5 of them
        let mut phases = [false; 50];
        for t in &s.time_s {
            phases[((t * 2.0).fract() * 50.0) as usize % 50] = true;
        }
        assert!(phases.iter().all(|&p| p));
        // the rate is the tap's, not a block's average of it
        let worst = s
            .time_s
            .iter()
            .zip(&s.rate_m_per_s)
            .map(|(t, v)| {
                let w = 2.0 * std::f64::consts::PI * 2.0;
                (v - 1e-3 * w * (w * t).sin()).abs()
            })
            .fold(0.0, f64::max);
        assert!(
            worst < 0.01 * 1e-3 * 4.0 * std::f64::consts::PI,
            "rate error {worst}"
        );
    }
}
