//! The measured log, prepared for batch fitting: force offset and first-impact contact
//! point from the core's own contact detector, block averages (which keep position and
//! force on the same time base), derivatives, and the phases of the test.

use estimator_core::conditioning::{
    ForceTare, ImpactConfig, ImpactDetector, RecontactPolicy, TareConfig,
};

use crate::phases::{Phase, PhaseClassifier};

/// Fitting samples are block averages over about this long \[s\] (200 Hz from a 1 kHz
/// log; a log resampled from a slower file is fitted one block per measurement of the
/// file).
pub const BLOCK_S: f64 = 5.0e-3;

/// Longest fitting series: a longer log gets longer blocks (a 60 s, 1 kHz log is fitted
/// on 15 ms blocks). Every candidate fit is O(rows); this bounds a diagnosis to about a
/// second whatever the log length, and 4000 blocks still resolve the slowest effect
/// (a relaxation mode) and the fastest (a 5 ms delay, through the raw-sample prefix
/// sums, not the block grid).
pub const MAX_BLOCKS: usize = 4000;

/// Longest typical contact \[s\] ([`typical_contact_samples`]) fitted on
/// [`SHORT_BLOCK_SAMPLES`]-sample blocks instead of [`BLOCK_S`]: driven impacts of 10-70 ms.
/// A 5 ms block averages 2-12 per such contact, across which the rate reverses and the
/// damping's step λ·v₀ at impact is a large share of the force. Measured on an
/// independent generator's driven impacts (README, "A second independent generator"):
/// fixed 2 ms blocks on seeds 8-15 (114 records) named an effect that was not there in
/// 15 against 33 at 5 ms, the hidden effect first in 77 against 71 of 80 singles; 1 ms
/// blocks were worse than 5 (41 of 117 seeds 0-7 with an extra). Not longer: taps of
/// 80-110 ms with a mass (6-9 Hz) fitted on 3 ms blocks named a power law on a linear
/// material beside the mass (the acceleration from second differences of a 1 µm
/// quantised position is 2.8× noisier on 3 ms blocks than on 5 ms, and the mass's column
/// with it), two structure tests of this crate failed.
pub const SHORT_CONTACT_S: f64 = 0.07;

/// Raw samples (1 kHz) in a fitting sample of a record with short contacts
/// ([`SHORT_CONTACT_S`]): two, not one, since a block of one sample has no raw samples to
/// average the law over where the contact begins or ends within it.
pub const SHORT_BLOCK_SAMPLES: usize = 2;

/// [`MAX_BLOCKS`] for a record fitted on blocks shortened for its short contacts: keeps
/// 2 ms blocks up to a 20 s record at 1 kHz (an impact diagnosis is then about 1.2× as
/// long as at 5 ms).
pub const MAX_BLOCKS_SHORT_CONTACTS: usize = 10_000;

/// The typical length of a contact \[raw samples\]: the length of the contact run that
/// holds the median in-contact sample (runs of `contact`, weighted by their length, so
/// that a position flickering across the contact point on a hold adds runs but not
/// weight). `None` without contact.
pub fn typical_contact_samples(contact: &[bool]) -> Option<usize> {
    let mut runs: Vec<usize> = contact
        .chunk_by(|a, b| a == b)
        .filter(|run| run[0])
        .map(<[bool]>::len)
        .collect();
    runs.sort_unstable();
    let total: usize = runs.iter().sum();
    let mut seen = 0;
    runs.into_iter().find(|len| {
        seen += len;
        2 * seen >= total
    })
}

/// A kink of the motion (a ramp starting, stopping or reversing within a sample) as a
/// model with a force-channel delay reads it: the rate steps from `rate_before` to
/// `rate_after` \[m/s\] at raw sample index `raw_index` (fractional, 1 kHz axis). The
/// fitting samples `first_block..=last_block` are the run whose symmetric-difference rate
/// reads across it plus one good sample on either side, whose rates these are. Undelayed,
/// those samples are left out ([`Prepared::left_out`]); delayed, the force reads the
/// motion τ earlier, so a kink falls among the samples that count, where a rate
/// interpolated across it would smear the step λ·Δv over the run (on ramps the delay then
/// traded with the damping there: 5 ms fitted at 4.0-4.8 ms with a standard error of
/// 0.03-0.07 ms).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KinkStep {
    /// First fitting sample of the step (the good one before the run).
    pub first_block: usize,
    /// Last fitting sample of the step (the good one after the run).
    pub last_block: usize,
    /// Raw sample index of the kink.
    pub raw_index: f64,
    /// Rate before the kink \[m/s\].
    pub rate_before: f64,
    /// Rate after the kink \[m/s\].
    pub rate_after: f64,
}

/// The kinks of a motion ([`KinkStep`]) from the fitting samples' rates read across one
/// (`kink`), their rates and the raw depths (`block` raw samples of `dt / block` each per
/// fitting sample): each kink's raw index is the least-squares breakpoint, on a half-raw-
/// sample grid, of the continuous two-slope line through the raw depths between the two
/// good samples' centres, with the rates one sample beyond those as the slopes. A run at either end of
/// the record (no good sample on one side) gives none.
fn kink_steps(
    kink: &[bool],
    rate: &[f64],
    raw_depth: &[f64],
    block: usize,
    dt: f64,
) -> Vec<KinkStep> {
    let n = kink.len();
    let h = dt / block as f64;
    let mut steps = Vec::new();
    let mut i = 0;
    while i < n {
        if !kink[i] {
            i += 1;
            continue;
        }
        let a = i;
        while i < n && kink[i] {
            i += 1;
        }
        if a == 0 || i >= n {
            continue;
        }
        let (first_block, last_block) = (a - 1, i);
        // (One sample further out where there is one: the good sample next to the run can
        // read a block mean the kink bends, a tenth of the rate off on a triangle.)
        let (before, after) = (
            rate[first_block.saturating_sub(1)],
            rate[(last_block + 1).min(n - 1)],
        );
        let lo = first_block * block + block / 2;
        let hi = (last_block * block + block / 2).min(raw_depth.len() - 1);
        let span = &raw_depth[lo..=hi];
        let sse = |r0: f64| {
            let line = |j: usize| {
                let r = (lo + j) as f64;
                (if r < r0 { before } else { after }) * (r - r0) * h
            };
            let x0 = span
                .iter()
                .enumerate()
                .map(|(j, x)| x - line(j))
                .sum::<f64>()
                / span.len() as f64;
            span.iter()
                .enumerate()
                .map(|(j, x)| (x - line(j) - x0).powi(2))
                .sum::<f64>()
        };
        let raw_index = (0..=2 * (hi - lo))
            .map(|k| lo as f64 + 0.5 * k as f64)
            .min_by(|p, q| sse(*p).total_cmp(&sse(*q)))
            .unwrap_or(lo as f64);
        steps.push(KinkStep {
            first_block,
            last_block,
            raw_index,
            rate_before: before,
            rate_after: after,
        });
    }
    steps
}

/// A log prepared for fitting.
#[derive(Debug, Clone)]
pub struct Prepared {
    /// Sample time of the fitting samples \[s\].
    pub dt: f64,
    /// Time \[s\].
    pub time_s: Vec<f64>,
    /// δ = x − x_contact \[m\] (negative out of contact, not clamped).
    pub depth_m: Vec<f64>,
    /// δ̇ \[m/s\] (central difference).
    pub rate_m_per_s: Vec<f64>,
    /// Whether [`Prepared::rate_m_per_s`] is the blocks' mean rate to fourth order (a fast
    /// motion against the noise, `frontend::series::rate_and_kinks`): a delayed model's
    /// rates are then taken the same way.
    pub fourth_order_rate: bool,
    /// δ̈ \[m/s²\] (second difference).
    pub accel_m_per_s2: Vec<f64>,
    /// The sample is left out of every fit and of what decides (RSS, N, NRMSE, BIC, the
    /// folds, the contact edges, the speed spread of the one-speed rules); the
    /// localisation and the residual plots still show it. Three kinds:
    /// - its rate reads across a kink of the motion (a ramp starting, stopping or
    ///   reversing within a sample: the symmetric difference there is neither side's
    ///   rate, and a Kelvin-Voigt law turns it into a force λ·Δv/2 off, tens of noise
    ///   deviations on a 100 Hz ramp; the front end's rule,
    ///   `frontend::series::rate_and_kinks`: none when kinks would be more than 5 % of the
    ///   samples or half of the moving ones; a rate whose difference ends on a kinked
    ///   block, a mean of both sides, is the one-sided difference away from it),
    ///   [`Prepared::kinks`] of them;
    /// - the first [`Prepared::leading_left_out`] samples of a record that begins in
    ///   contact ([`leading_left_out_s`], 50 ms at 1 kHz): a model with a force-channel
    ///   delay τ predicts the force at t from the motion at t − τ, which for the record's
    ///   first τ is before the record, unknown, and every model is scored on the same
    ///   samples. (The catalogue searches delays to
    ///   [`longest_delay_s`](super::catalogue::longest_delay_s), 100 ms; a delay
    ///   beyond 50 ms reads the record's first motion for the motion before it. Leaving
    ///   100 ms out cost the project's structure sweep two of twenty relaxations in
    ///   records that never leave contact: the fastest of a relaxation is at the start.)
    ///   (What a delayed channel shows there depends on the instrument: the force before
    ///   the record, or a delay line that starts empty. An independent generator's delays,
    ///   `np.concatenate([zeros(k), f[:-k]])`, start at zero force under a probe 1.5 mm
    ///   deep: its sines pressed in contact ended at 1.2-1.8 % NRMSE, 3-8× their noise,
    ///   nearly all of it two 14 N residuals among 4000.) The models' states (a
    ///   relaxation's memory) still run from the record's first sample;
    /// - the last sample of a record that ends in contact ([`Prepared::trailing_left_out`]).
    pub left_out: Vec<bool>,
    /// Leading samples of [`Prepared::left_out`] (a record that begins in contact), 0
    /// otherwise.
    pub leading_left_out: usize,
    /// 1 where the record's last fitting sample is in contact (and not left out for a
    /// kink), 0 otherwise: its δ̈, a second difference, has no sample after it (set to
    /// 0), so a mass's m·δ̈ is missing there, and its rate is a one-sided difference.
    /// (Where the rate's symmetric window is wider than one sample on each side, the
    /// samples before the last read a clipped window too, a lag of up to half the window
    /// in λ·δ̇; they are kept.) (An independent generator's taps with a mass and a
    /// relaxation end mid-tap: at the true parameters that one sample was about 1 N off,
    /// and the last fifth's held-out error 0.045 N against 0.026 N without it, worse than
    /// a model without the mass.) Left out only while the record keeps its end
    /// ([`Prepared::keep_until_end_of`] resets it).
    pub trailing_left_out: usize,
    /// The motion's kinks as a delayed model reads them ([`KinkStep`]), in time order.
    pub kink_steps: Vec<KinkStep>,
    /// The file's own sample times on the raw (1 kHz) index axis of a log resampled from a
    /// file not at 1 kHz (index = (t − t₀)·1 kHz, increasing); empty otherwise. The
    /// resampler draws straight lines between them where they are sparser than 1 kHz and
    /// averages them where they are denser (`record::cell_overlaps`), and the regressors
    /// model a block at a contact's edge the same way (`regressors::design`).
    pub native_raw_index: Vec<f64>,
    /// Force with the pre-contact offset removed \[N\].
    pub force_n: Vec<f64>,
    /// In contact according to the detector (majority of the block).
    pub contact: Vec<bool>,
    /// Phase of each sample.
    pub phase: Vec<Phase>,
    /// Force offset removed \[N\] and contact position \[m\] found.
    pub force_offset_n: f64,
    /// Contact position x_contact \[m\] (first impact).
    pub contact_position_m: f64,
    /// Noise level of one fitting sample \[N\] (free-space force spread of one measurement
    /// / √(measurements per block)).
    pub noise_n: f64,
    /// Raw samples per fitting sample.
    pub block: usize,
    /// Raw samples per measurement of the file the log was resampled from (1 when it was
    /// not): `block` is at least this (a whole number of them only when the
    /// [`MAX_BLOCKS`] bound does not lengthen it).
    pub measurement_samples: usize,
    /// The record's typical contact \[s\] ([`typical_contact_samples`]) where the blocks
    /// were shortened for it ([`SHORT_CONTACT_S`]: 2 ms, not [`BLOCK_S`]); `None`
    /// where they were not.
    pub short_contact_s: Option<f64>,
    /// δ of every raw sample (position − contact position) \[m\], `block` per fitting
    /// sample.
    pub raw_depth_m: Vec<f64>,
    /// Prefix sums of `raw_depth_m` (one more element), for shifted block means.
    pub raw_depth_prefix: Vec<f64>,
    /// Shallowest raw δ within each fitting sample \[m\].
    pub block_min_depth_m: Vec<f64>,
    /// Deepest raw δ within each fitting sample \[m\].
    pub block_max_depth_m: Vec<f64>,
    /// First fitting sample after the end of the first contact: the probe is back above
    /// the first contact point (the length if the log never leaves its first contact).
    pub first_contact_end: usize,
    /// First fitting sample read from the later contacts' surface by a
    /// `contact_point_offset` ([`surface_switch`]): `first_contact_end` unless the
    /// contacts' onset depths show the surface moving after a later contact.
    pub surface_switch: usize,
    /// First fitting sample of a `force_offset`'s later load-cell zero: the change point
    /// of the free-space force after the first contact ([`load_cell_step`]);
    /// `first_contact_end` where the free space shows none.
    pub offset_step: usize,
    /// The linear damping coefficient is held at 0 in every model (set by the workflow
    /// when the record passes each depth at one speed, where λ·δ̇ is indistinguishable
    /// from the elastic law and the tare but for its step λv at a contact onset from free
    /// space: see `Diagnosis::damping_held`).
    pub hold_damping: bool,
    /// The whole-record front end could not determine the force offset (the record
    /// never leaves contact). On a record that is also a one-speed loading curve, the
    /// workflow then holds the tare (see [`Prepared::hold_tare`]).
    pub offset_unidentified: bool,
    /// The tare refinement is held at 0 in every model and a `force_offset` is not tried:
    /// set by the workflow on a loading curve that never leaves contact, where an offset
    /// is the elastic law's value at the first sample, indistinguishable from a contact
    /// point before the record and the law's shape. (With a hold, an unloading or
    /// several speeds, the dynamics separate them and the tare stays free.)
    pub hold_tare: bool,
    /// Sign that turned the file's position into the penetration axis the log is on
    /// (+1 unless the caller set it from the front end's axis).
    pub position_sign: f64,
    /// Fitting samples per block of the interleaved cross-validation folds (block `b`
    /// held out in fold `b mod FOLDS`), or `None` for contiguous fifths of the fit window:
    /// set by the workflow ([`super::scoring::interleaved_block`]), `None` as prepared.
    pub cv_block: Option<usize>,
    /// N_eff / N of the sensor noise ([`super::scoring::noise_sample_fraction`]), measured
    /// once by the workflow ([`super::diagnose`]) for every fit's standard errors (σ² per
    /// effective sample); `None` as prepared or where the record shows no noise to
    /// measure (then each fit's own [`super::solver::Fit::residual_sample_fraction`]).
    pub noise_fraction: Option<f64>,
    /// An `inertia`'s mass also acts out of contact: a probe's mass beyond the load cell,
    /// whose force m·δ̈ the free space itself shows ([`super::scoring::free_space_inertia`]),
    /// not only a mass that moves with the contact. Set by the workflow ([`super::diagnose`])
    /// or a spec's `mass_in_free_space`; `false` as prepared.
    pub mass_in_free_space: bool,
}

/// Why a log cannot be diagnosed.
#[derive(Debug, thiserror::Error)]
pub enum PrepareError {
    /// Position and force differ in length or are too short.
    #[error("the log has {0} samples; at least 200 are needed")]
    TooShort(usize),
    /// The detector never saw a contact.
    #[error("no contact found: the force never rose above {threshold_n:.3e} N over its offset")]
    NoContact {
        /// Onset threshold \[N\].
        threshold_n: f64,
    },
}

/// Prepares a log (`time_s` uniformly sampled, `position_m` positive into the material,
/// `force_n` compressive positive) with the contact detector configured by `detector`
/// (its recontact policy is forced to the first impact and its tare frozen: δ is
/// measured from one contact point, as in the paper, and the offset is the one before
/// that impact).
///
/// # Errors
/// [`PrepareError`] when the log is too short or never touches.
pub fn prepare(
    time_s: &[f64],
    position_m: &[f64],
    force_n: &[f64],
    detector: ImpactConfig,
) -> Result<Prepared, PrepareError> {
    let n = time_s.len().min(position_m.len()).min(force_n.len());
    if n < MIN_SAMPLES {
        return Err(PrepareError::TooShort(n));
    }
    let impact_config = ImpactConfig {
        recontact: RecontactPolicy::FirstImpact,
        ..detector
    };
    let mut impact = ImpactDetector::try_new(impact_config)
        .or_else(|_| ImpactDetector::try_new(ImpactConfig::default()))
        .expect("defaults are valid");
    // The offset is the mean of the first samples, frozen (no free-space re-estimation).
    let mut tare = ForceTare::try_new(TareConfig {
        tracking_samples: 0,
        free_space_travel_m: 1.0e30,
        ..TareConfig::default()
    })
    .expect("defaults are valid");
    let mut contact = Vec::with_capacity(n);
    let mut frozen_offset = None;
    for i in 0..n {
        let (x, f) = (position_m[i] as f32, force_n[i] as f32);
        let noise = tare.noise_n();
        if frozen_offset.is_none() {
            tare.update(
                x,
                f,
                0.0,
                false,
                f32::NAN,
                impact.config().release_threshold(noise),
            );
        }
        let offset = frozen_offset.unwrap_or(tare.offset_n());
        let u = impact.update(x, f - offset, 0.0, noise, tare.samples() >= 20);
        if impact.in_contact() && frozen_offset.is_none() {
            frozen_offset = Some(offset);
        }
        let _ = u;
        contact.push(impact.in_contact());
    }
    let Some(first) = contact.iter().position(|c| *c) else {
        return Err(PrepareError::NoContact {
            threshold_n: f64::from(impact.config().onset_threshold(tare.noise_n())),
        });
    };
    let offset = f64::from(frozen_offset.unwrap_or(tare.offset_n()));
    let x_c = f64::from(impact.contact_position_m());
    // Noise of one raw sample: spread of the raw force before the first contact.
    let quiet = &force_n[..first];
    let noise_raw = if quiet.len() > 10 {
        let m = quiet.iter().sum::<f64>() / quiet.len() as f64;
        (quiet.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (quiet.len() - 1) as f64).sqrt()
    } else {
        crate::setup::noise_level(&force_n[..n])
    };
    Ok(assemble(
        &time_s[..n],
        &position_m[..n],
        &force_n[..n],
        &contact,
        Reference {
            offset,
            x_c,
            noise_raw,
            measurement_samples: 1,
        },
    ))
}

/// Prepares a log whose force offset `offset_n` \[N\], contact position `contact_m` \[m\]
/// (on the log's own position axis, positive into the material) and raw-sample noise
/// `noise_n` \[N\] are known (the whole-record front end's): contact is geometric,
/// x > x_contact. `measurement_samples`: samples of the log per measurement of the file it
/// was resampled from (1 when it was not; 100 for a 10 Hz file at 1 kHz): a fitting block
/// is never shorter than one measurement, since a shorter one would hold interpolations
/// rather than data (and count one measurement's noise as several).
///
/// # Errors
/// [`PrepareError`] when the log is too short or never goes beyond the contact point.
pub fn prepare_known(
    time_s: &[f64],
    position_m: &[f64],
    force_n: &[f64],
    offset_n: f64,
    contact_m: f64,
    noise_n: f64,
    measurement_samples: usize,
) -> Result<Prepared, PrepareError> {
    let n = time_s.len().min(position_m.len()).min(force_n.len());
    if n < MIN_SAMPLES {
        return Err(PrepareError::TooShort(n));
    }
    let contact: Vec<bool> = position_m[..n].iter().map(|x| *x > contact_m).collect();
    if !contact.iter().any(|c| *c) {
        return Err(PrepareError::NoContact { threshold_n: 0.0 });
    }
    Ok(assemble(
        &time_s[..n],
        &position_m[..n],
        &force_n[..n],
        &contact,
        Reference {
            offset: offset_n,
            x_c: contact_m,
            noise_raw: noise_n,
            measurement_samples,
        },
    ))
}

/// What a log is prepared relative to: force offset \[N\], contact position \[m\], noise
/// of one raw sample \[N\] and raw samples per measurement of the file.
struct Reference {
    offset: f64,
    x_c: f64,
    noise_raw: f64,
    measurement_samples: usize,
}

/// Block means, derivatives and phases of a log with per-sample contact flags, offset,
/// contact position and raw-sample noise.
fn assemble(
    time_s: &[f64],
    position_m: &[f64],
    force_n: &[f64],
    contact: &[bool],
    reference: Reference,
) -> Prepared {
    let Reference {
        offset,
        x_c,
        noise_raw,
        measurement_samples,
    } = reference;
    let n = time_s.len();
    let first = contact.iter().position(|c| *c).unwrap_or(0);
    let native_dt = (time_s[n - 1] - time_s[0]) / (n - 1) as f64;
    let measurement_samples = measurement_samples.max(1);
    let by_time = ((BLOCK_S / native_dt).round() as usize).max(1);
    let short_contact_s = typical_contact_samples(contact)
        .map(|len| len as f64 * native_dt)
        .filter(|c| *c <= SHORT_CONTACT_S && SHORT_BLOCK_SAMPLES < by_time);
    let (base, max_blocks) = if short_contact_s.is_some() {
        (SHORT_BLOCK_SAMPLES, MAX_BLOCKS_SHORT_CONTACTS)
    } else {
        (by_time, MAX_BLOCKS)
    };
    let block = base
        .max(measurement_samples)
        .max(n.div_ceil(max_blocks))
        .clamp(1, n / MIN_BLOCKS);
    let blocks = n / block;
    let dt = block as f64 * native_dt;
    let avg =
        |v: &[f64], b: usize| v[b * block..(b + 1) * block].iter().sum::<f64>() / block as f64;
    let depth: Vec<f64> = (0..blocks).map(|b| avg(position_m, b) - x_c).collect();
    let force: Vec<f64> = (0..blocks).map(|b| avg(force_n, b) - offset).collect();
    let in_contact: Vec<bool> = (0..blocks)
        .map(|b| {
            contact[b * block..(b + 1) * block]
                .iter()
                .filter(|c| **c)
                .count()
                * 2
                > block
        })
        .collect();
    // The symmetric difference whose window keeps the position noise small against the
    // motion (the front end's): a slow indentation's nanometre jitter would otherwise
    // flicker the phases between loading and hold.
    let block_time: Vec<f64> = (0..blocks).map(|b| b as f64 * dt).collect();
    let (rate, kink, fourth_order_rate) =
        crate::frontend::series::rate_and_kinks(&block_time, &depth, &in_contact);
    // (Out of contact the force does not read the rate: a kink there costs nothing.)
    let mut left_out: Vec<bool> = kink
        .iter()
        .zip(&in_contact)
        .map(|(k, c)| *k && *c)
        .collect();
    let leading_left_out = if in_contact.first() == Some(&true) {
        // (Less a hair: a dt from time stamps a rounding above the exact one.)
        ((leading_left_out_s(dt) / dt - 1e-9).ceil() as usize).min(blocks.saturating_sub(1))
    } else {
        0
    };
    for flag in &mut left_out[..leading_left_out] {
        *flag = true;
    }
    let trailing_left_out = usize::from(in_contact.last() == Some(&true) && !left_out[blocks - 1]);
    if trailing_left_out > 0 {
        left_out[blocks - 1] = true;
    }
    let accel: Vec<f64> = (0..blocks)
        .map(|b| {
            if b == 0 || b + 1 >= blocks {
                0.0
            } else {
                (depth[b + 1] - 2.0 * depth[b] + depth[b - 1]) / (dt * dt)
            }
        })
        .collect();
    let v_star = crate::phases::speed_threshold(&depth, dt);
    let mut classifier = PhaseClassifier::new(v_star);
    let phase: Vec<Phase> = (0..blocks)
        .map(|b| classifier.classify(in_contact[b], rate[b]))
        .collect();
    // The first contact ends when the probe is back above the first contact point (by
    // position: a load-cell zero shift may keep the force above the release threshold),
    // after it has been below it: a contact flagged by the force a block before the
    // probe passes the fitted point is not over at its first block (an independent
    // generator's clean one-speed loading, flagged so, was read as a first contact ended
    // at once and a second one whose point a `contact_point_offset` shifted).
    let first_block = in_contact.iter().position(|c| *c).unwrap_or(first / block);
    let first_contact_end = (first_block..blocks)
        .find(|b| depth[*b] > 0.0)
        .and_then(|inside| (inside..blocks).find(|b| depth[*b] <= 0.0))
        .unwrap_or(blocks);
    let offset_step = load_cell_step(&force, &in_contact, first_contact_end);
    let noise_n = noise_raw / (block.div_ceil(measurement_samples) as f64).sqrt();
    let surface_switch = surface_switch(&depth, &force, noise_n, first_contact_end);
    let raw_depth: Vec<f64> = position_m[..blocks * block]
        .iter()
        .map(|x| x - x_c)
        .collect();
    let kink_steps = kink_steps(&kink, &rate, &raw_depth, block, dt);
    Prepared {
        cv_block: None,
        noise_fraction: None,
        mass_in_free_space: false,
        dt,
        time_s: (0..blocks).map(|b| avg(time_s, b)).collect(),
        depth_m: depth,
        rate_m_per_s: rate,
        fourth_order_rate,
        accel_m_per_s2: accel,
        left_out,
        leading_left_out,
        trailing_left_out,
        kink_steps,
        native_raw_index: Vec::new(),
        force_n: force,
        contact: in_contact,
        phase,
        force_offset_n: offset,
        contact_position_m: x_c,
        noise_n,
        raw_depth_m: raw_depth,
        raw_depth_prefix: std::iter::once(0.0)
            .chain(position_m[..blocks * block].iter().scan(0.0, |acc, x| {
                *acc += x - x_c;
                Some(*acc)
            }))
            .collect(),
        block_min_depth_m: (0..blocks)
            .map(|b| {
                position_m[b * block..(b + 1) * block]
                    .iter()
                    .copied()
                    .fold(f64::INFINITY, f64::min)
                    - x_c
            })
            .collect(),
        block_max_depth_m: (0..blocks)
            .map(|b| {
                position_m[b * block..(b + 1) * block]
                    .iter()
                    .copied()
                    .fold(f64::NEG_INFINITY, f64::max)
                    - x_c
            })
            .collect(),
        block,
        measurement_samples,
        short_contact_s,
        first_contact_end,
        surface_switch,
        offset_step,
        hold_damping: false,
        offset_unidentified: false,
        hold_tare: false,
        position_sign: 1.0,
    }
}

/// Where a load-cell zero shift after the first contact takes effect: the first fitting
/// sample of the later level. A zero that shifts with the load (a cable, a re-tare, the
/// cell's hysteresis, a bump) need not shift the moment the probe leaves the first
/// contact: it may shift anywhere in the free space after it, in the stretch that follows
/// or after a later contact, and the samples before the shift still read the old zero.
/// The free-space force (`force` where `contact` is false, in time order) is split in two
/// at each free sample from `first_contact_end` on, and the split of the largest
/// between-means contrast (S_j − j·S/n)²·n / (j·(n − j)) — the least-squares single change
/// point (Hinkley, Biometrika 57, 1970) — is taken where it lowers the BIC of that
/// two-level fit against the split at `first_contact_end` by more than
/// [`STEP_BIC_DROP`], the location counted as a parameter, on the free force's effective
/// samples ([`super::scoring::effective_fraction`] of its detrended stretches): the
/// search otherwise fits a coloured noise's wander. A split between the last free sample
/// of one stretch and the first of the next puts the step at the onset of the contact
/// between them (its whole stretch read the old zero). `first_contact_end` where the best
/// split does not pass, or where the record has no free sample after the first contact or
/// none before it (the step then falls at the lift-off), and where its stretches hold too
/// few samples to measure the noise's colour on ([`super::scoring::NOISE_SAMPLES`]).
/// (Until 2026-11-29 only the stretch after the first contact was searched: an
/// independent generator's steps after the second to the thirtieth contact were read as
/// a drift or refused.)
///
/// `force` and `contact` are per fitting sample (equal lengths); returns an index in
/// `first_contact_end..=len`.
pub fn load_cell_step(force: &[f64], contact: &[bool], first_contact_end: usize) -> usize {
    let n = force.len().min(contact.len());
    if first_contact_end >= n {
        return first_contact_end;
    }
    let free: Vec<usize> = (0..n).filter(|&b| !contact[b]).collect();
    let m = free.len() as f64;
    let total: f64 = free.iter().map(|&b| force[b]).sum();
    let mean = total / m;
    let rss0: f64 = free.iter().map(|&b| (force[b] - mean).powi(2)).sum();
    if rss0.is_nan() || rss0 <= 0.0 {
        return first_contact_end; // a constant free force: no step to place
    }
    let (mut best, mut best_contrast, mut at_lift_off, mut prefix) =
        (first_contact_end, 0.0, None, 0.0);
    for (j, &b) in free.iter().enumerate() {
        // Split before free sample j (block b): j samples at the old zero. (The first
        // free sample the detector frees at or after the lift-off: its release may lag
        // the position's, a shifted zero can hold the force above the release threshold.)
        if j > 0 && b >= first_contact_end {
            let k = j as f64;
            let contrast = (prefix - k * total / m).powi(2) * m / (k * (m - k));
            at_lift_off.get_or_insert(contrast);
            if contrast > best_contrast {
                best_contrast = contrast;
                // At the onset of a contact between the two free samples.
                best = (free[j - 1] + 1).max(first_contact_end);
            }
        }
        prefix += force[b];
    }
    let Some(at_lift_off) = at_lift_off else {
        return first_contact_end;
    };
    // The free force's effective samples, as the workflow counts the sensor noise's.
    let fraction = match super::scoring::free_stretches_fraction(&force[..n], &contact[..n]) {
        Some((fraction, samples)) if samples >= super::scoring::NOISE_SAMPLES => fraction,
        // Too little free space to measure the noise's colour on: a coloured noise's
        // wander cannot be told from a shift (a 1.3 s, 100 Hz load-unload record with
        // AR(1) noise, ρ = 0.96, took a 0.2 % NRMSE gain for one).
        _ => return first_contact_end,
    };
    let n_eff = (m * fraction).max(2.0);
    let (rss_lift_off, rss_best) = (rss0 - at_lift_off, rss0 - best_contrast);
    let moved = if rss_best > 0.0 {
        n_eff * (rss_lift_off / rss_best).ln() > STEP_BIC_DROP + n_eff.ln()
    } else {
        // A noise-free step, beyond the rounding of the sums.
        best_contrast - at_lift_off > 1e-9 * rss0
    };
    if moved {
        best
    } else {
        first_contact_end
    }
}

/// The time left out at the start of a record that begins in contact \[s\] on fitting
/// samples `dt_s` apart ([`Prepared::left_out`]): 50 ms, or 5 samples where they are
/// longer than 10 ms (the longest delay the catalogue searched until 2026-11-29).
pub fn leading_left_out_s(dt_s: f64) -> f64 {
    (5.0 * dt_s).max(0.05)
}

/// Where a `contact_point_offset`'s later surface takes over: the first fitting sample
/// read from it. The catalogue's offset moves the surface once; an instrument's may move
/// after any contact (a re-zeroed stage, a sample that slipped), not only the first. The
/// contacts are the runs of force above 5 noise deviations of a fitting sample that reach
/// a fifth of the record's largest force; each that begins after free space has an onset
/// depth, the depth at its first sample. The onset depths are split in two groups at the
/// single change point of their means (least squares, as [`load_cell_step`]); the split
/// moves the surface after a later contact than the first only when it explains the
/// onset depths [`SURFACE_SWITCH_RSS_FACTOR`] times better than a switch after the first
/// contact does and its shift stands [`SURFACE_SWITCH_Z`] standard errors clear of zero.
/// The switch then falls at the shallowest depth of the free stretch after the last
/// contact of the first group (the probe at its furthest from both surfaces).
/// `first_contact_end` otherwise, and with fewer than three onsets (the first contact's
/// switch is then the only one there is, or the onsets cannot show a later one).
///
/// `depth`, `force` per fitting sample \[m, N\], `noise_n` a fitting sample's noise
/// deviation \[N\]; returns an index in `first_contact_end..=len`.
pub fn surface_switch(
    depth: &[f64],
    force: &[f64],
    noise_n: f64,
    first_contact_end: usize,
) -> usize {
    let n = depth.len().min(force.len());
    let peak = force[..n].iter().copied().fold(0.0, f64::max);
    let threshold = 5.0 * noise_n;
    // (A NaN noise compares with nothing: no contact to find either.)
    if first_contact_end >= n || peak.partial_cmp(&threshold) != Some(std::cmp::Ordering::Greater) {
        return first_contact_end;
    }
    // Contacts: (first, end) of each run above the threshold that reaches peak/5.
    let mut contacts: Vec<(usize, usize)> = Vec::new();
    let mut b = 0;
    while b < n {
        if force[b] > threshold {
            let first = b;
            let mut top = 0.0f64;
            while b < n && force[b] > threshold {
                top = top.max(force[b]);
                b += 1;
            }
            if top >= 0.2 * peak {
                contacts.push((first, b));
            }
        } else {
            b += 1;
        }
    }
    // Onset depths of the contacts that begin after free space, with their contact index.
    let onsets: Vec<(usize, f64)> = contacts
        .iter()
        .enumerate()
        .filter(|(_, (first, _))| *first > 0)
        .map(|(k, (first, _))| (k, depth[*first]))
        .collect();
    let m = onsets.len();
    if m < 3 {
        return first_contact_end;
    }
    // RSS of two means split before onset j (j = 0: one mean).
    let total: f64 = onsets.iter().map(|o| o.1).sum();
    let squares: f64 = onsets.iter().map(|o| o.1 * o.1).sum();
    let mut prefix = 0.0;
    let rss_at: Vec<f64> = (0..m)
        .map(|j| {
            let rss = if j == 0 {
                squares - total * total / m as f64
            } else {
                let (k, rest) = (j as f64, (m - j) as f64);
                squares - prefix * prefix / k - (total - prefix) * (total - prefix) / rest
            };
            prefix += onsets[j].1;
            rss.max(0.0)
        })
        .collect();
    let Some((best, rss_best)) = (1..m)
        .map(|j| (j, rss_at[j]))
        .min_by(|a, b| a.1.total_cmp(&b.1))
    else {
        return first_contact_end;
    };
    // The switch after the first contact: before the second onset where the first
    // contact has one, with all onsets after it where the record begins in contact.
    let current = if onsets[0].0 == 0 { 1 } else { 0 };
    // The last contact of the first group: a later one than the first?
    let last_before = onsets[best - 1].0;
    if best == current || last_before == 0 {
        return first_contact_end;
    }
    let (k, rest) = (best as f64, (m - best) as f64);
    let before = onsets[..best].iter().map(|o| o.1).sum::<f64>() / k;
    let after = onsets[best..].iter().map(|o| o.1).sum::<f64>() / rest;
    let variance = rss_best / (m as f64 - 2.0).max(1.0);
    let z2 = (after - before).powi(2) / (variance * (1.0 / k + 1.0 / rest)).max(f64::MIN_POSITIVE);
    let clear = rss_best * SURFACE_SWITCH_RSS_FACTOR <= rss_at[current]
        && z2 >= SURFACE_SWITCH_Z * SURFACE_SWITCH_Z;
    if !clear {
        return first_contact_end;
    }
    // The shallowest point of the free stretch between the two contacts.
    let (gap_start, gap_end) = (contacts[last_before].1, contacts[last_before + 1].0);
    (gap_start..gap_end)
        .min_by(|&a, &b| depth[a].total_cmp(&depth[b]))
        .unwrap_or(gap_start)
        .max(first_contact_end)
}

/// How many times smaller the onset depths' residual must be with the surface moving
/// after a later contact than after the first ([`surface_switch`]).
pub const SURFACE_SWITCH_RSS_FACTOR: f64 = 4.0;

/// Standard errors by which the two groups' mean onset depths must differ
/// ([`surface_switch`]).
pub const SURFACE_SWITCH_Z: f64 = 5.0;

/// BIC drop \[-\] beyond its location's own parameter by which a load-cell step placed
/// within the free stretch must beat one at the lift-off ([`load_cell_step`]): the
/// workflow's default threshold for naming an effect (`Options::min_bic_drop`).
pub const STEP_BIC_DROP: f64 = 10.0;

/// Fewest raw samples of a log.
pub const MIN_SAMPLES: usize = 200;
/// Fewest fitting samples (the block shrinks for short logs).
const MIN_BLOCKS: usize = 100;

impl Prepared {
    /// Time of fitting sample `i` since the log's first sample \[s\]: the regressor of a
    /// drifting load-cell zero.
    pub fn since_start_s(&self, i: usize) -> f64 {
        self.time_s[i] - self.time_s[0]
    }

    /// [`Prepared::offset_step`] as time since the log's first sample \[s\].
    pub fn offset_step_s(&self) -> f64 {
        self.offset_step as f64 * self.dt
    }

    /// [`Prepared::surface_switch`] where it falls after a later contact than the first
    /// (after the first, a contact-point shift keeps its own refinement at the first
    /// contact's end, `first_contact_end_at`): `None` otherwise.
    pub fn later_surface_switch(&self) -> Option<usize> {
        (self.surface_switch > self.first_contact_end).then_some(self.surface_switch)
    }

    /// [`Prepared::later_surface_switch`] as time since the log's first sample \[s\].
    pub fn later_surface_switch_s(&self) -> Option<f64> {
        self.later_surface_switch().map(|i| i as f64 * self.dt)
    }

    /// The fitting sample nearest `t_s` seconds from the log's first sample, at most the
    /// length: where a spec's `contact_shift_at_s` or `later_force_offset_at_s` falls
    /// when it is run over another record's motion.
    fn sample_at_s(&self, t_s: f64) -> usize {
        ((t_s / self.dt).round().max(0.0) as usize).min(self.len())
    }

    /// Places [`Prepared::surface_switch`] at `t_s` seconds from the log's first sample
    /// (`sample_at_s`).
    pub fn set_surface_switch_s(&mut self, t_s: f64) {
        self.surface_switch = self.sample_at_s(t_s);
    }

    /// Places [`Prepared::offset_step`] at `t_s` seconds from the log's first sample
    /// (`sample_at_s`; the length: no shift within the log).
    pub fn set_offset_step_s(&mut self, t_s: f64) {
        self.offset_step = self.sample_at_s(t_s);
    }

    /// The first fitting sample, from the first one flagged in contact on, whose depth is
    /// at or above `surface_m` (this log's penetration axis): the length if none.
    /// [`Prepared::first_contact_end`] is this at the prepared contact position (0).
    /// For a surface shallower than the flagged onset it is where the probe leaves that
    /// surface; for a deeper one it is the flagged onset itself (the contact-point
    /// offset's caller takes the later of this and `first_contact_end`).
    pub(crate) fn first_contact_end_at(&self, surface_m: f64) -> usize {
        let n = self.len();
        let Some(onset) = self.contact.iter().position(|c| *c) else {
            return n;
        };
        (onset..n)
            .find(|&b| self.depth_m[b] <= surface_m)
            .unwrap_or(n)
    }

    /// Depth \[m\] on this log's penetration axis of the first fitting sample whose force
    /// exceeds 5 noise deviations of one fitting sample: where the record's first contact
    /// begins, to within the depth the law needs to reach that force. `None` without one.
    pub fn first_onset_depth_m(&self) -> Option<f64> {
        let threshold = 5.0 * self.noise_n;
        (0..self.len())
            .find(|&b| self.force_n[b] > threshold)
            .map(|b| self.depth_m[b])
    }

    /// Index of the first fitting sample: 0.25 s (at least 5 samples) before the first
    /// contact, so that the onset and some free space (for the tare) are inside the fit
    /// but not a long approach.
    pub fn fit_start(&self) -> usize {
        let first = self.contact.iter().position(|c| *c).unwrap_or(0);
        first.saturating_sub(((0.25 / self.dt) as usize).max(5))
    }

    /// Whether every fitting sample from `start` on is in contact (a fit window that never
    /// leaves contact).
    pub fn in_contact_from(&self, start: usize) -> bool {
        self.contact[start..].iter().all(|c| *c)
    }

    /// Mean of the linearly interpolated raw δ over `block` raw samples starting at the
    /// fractional raw index `x0` (clamped to the record) \[m\].
    pub fn raw_block_mean(&self, x0: f64) -> f64 {
        let raw = self.raw_depth_m.len();
        let b = self.block;
        let x0 = x0.clamp(0.0, (raw - b) as f64);
        let k = x0 as usize; // x0 ≥ 0: the floor
        let f = x0 - k as f64;
        let p = &self.raw_depth_prefix;
        let mean = |a: usize| (p[(a + b).min(raw)] - p[a.min(raw)]) / b as f64;
        if f == 0.0 || k + 1 + b > raw {
            mean(k)
        } else {
            (1.0 - f) * mean(k) + f * mean(k + 1)
        }
    }

    /// Keeps the log up to the end of the first `phase` segment after the first contact
    /// (ended by another phase lasting 0.25 s; a loading segment also ends where the
    /// force first reaches 99.5 % of its peak)
    /// (`Phase::Loading`: the first loading curve alone, the part of an indentation a
    /// stiffness law describes before plastic flow and creep). Returns `false` and leaves
    /// the log unchanged when there is no such segment or fewer than 100 fitting samples
    /// would remain.
    pub fn keep_until_end_of(&mut self, phase: Phase) -> bool {
        let first = self.contact.iter().position(|c| *c).unwrap_or(0);
        let Some(begin) = (first..self.len()).find(|&i| self.phase[i] == phase) else {
            return false;
        };
        // The segment ends where another phase lasts at least 0.25 s: a sample-long
        // "hold" where a slow indenter's speed dips below the threshold does not end it.
        let persist = ((0.25 / self.dt) as usize).max(1);
        let mut end = self.len();
        let mut other = 0;
        for i in begin..self.len() {
            other = if self.phase[i] == phase { 0 } else { other + 1 };
            if other >= persist {
                end = i + 1 - other;
                break;
            }
        }
        if phase == Phase::Loading {
            // A creeping hold under constant load keeps moving in: the loading curve
            // ends where the force first reaches 99.5 % of its peak.
            let peak = self
                .force_n
                .iter()
                .copied()
                .fold(f64::NEG_INFINITY, f64::max);
            if let Some(top) = (begin..end).find(|&i| self.force_n[i] >= 0.995 * peak) {
                end = top + 1;
            }
        }
        if end < MIN_BLOCKS || end - self.fit_start() < MIN_BLOCKS {
            return false;
        }
        for v in [
            &mut self.time_s,
            &mut self.depth_m,
            &mut self.rate_m_per_s,
            &mut self.accel_m_per_s2,
            &mut self.force_n,
            &mut self.block_min_depth_m,
            &mut self.block_max_depth_m,
        ] {
            v.truncate(end);
        }
        self.contact.truncate(end);
        if end < self.left_out.len() && self.trailing_left_out > 0 {
            // The new last sample has its neighbour: it counts.
            let last = self.left_out.len() - 1;
            self.left_out[last] = false;
            self.trailing_left_out = 0;
        }
        self.left_out.truncate(end);
        self.kink_steps.retain(|k| k.last_block < end);
        self.phase.truncate(end);
        self.raw_depth_m.truncate(end * self.block);
        self.raw_depth_prefix.truncate(end * self.block + 1);
        self.first_contact_end = self.first_contact_end.min(end);
        self.offset_step = load_cell_step(&self.force_n, &self.contact, self.first_contact_end);
        self.surface_switch = surface_switch(
            &self.depth_m,
            &self.force_n,
            self.noise_n,
            self.first_contact_end,
        );
        true
    }

    /// Which samples of the fit window from `start` count (not the [`Prepared::left_out`] ones), or
    /// `None` when all do.
    pub fn counted_from(&self, start: usize) -> Option<Vec<bool>> {
        let out = &self.left_out[start.min(self.left_out.len())..];
        out.iter()
            .any(|k| *k)
            .then(|| out.iter().map(|k| !k).collect())
    }

    /// Samples of the fit window from `start` that count.
    pub fn samples_counted_from(&self, start: usize) -> usize {
        self.len().saturating_sub(start)
            - self.left_out[start.min(self.left_out.len())..]
                .iter()
                .filter(|k| **k)
                .count()
    }

    /// Samples left out for a kink of the motion (the rest of [`Prepared::left_out`] are
    /// the [`Prepared::leading_left_out`] and [`Prepared::trailing_left_out`] ones).
    pub fn kinks(&self) -> usize {
        self.left_out.iter().filter(|k| **k).count()
            - (self.leading_left_out + self.trailing_left_out).min(self.left_out.len())
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.time_s.len()
    }

    /// `true` when empty.
    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// A 1 kHz log of `position(t)` over `seconds` (contact at 0, a linear spring of
    /// 1 kN/m; also the scoring's tests').
    pub(in crate::diagnose) fn log(seconds: f64, position: impl Fn(f64) -> f64) -> Prepared {
        let t: Vec<f64> = (0..(seconds * 1e3) as usize)
            .map(|i| i as f64 * 1e-3)
            .collect();
        let x: Vec<f64> = t.iter().map(|&t| position(t)).collect();
        let f: Vec<f64> = x.iter().map(|&x| 1e3 * x.max(0.0)).collect();
        prepare_known(&t, &x, &f, 0.0, 0.0, 1e-3, 1).expect("prepared")
    }

    /// A record's typical contact is the contact run that holds its median in-contact
    /// sample: a position flickering across the surface on a hold adds many short runs
    /// but little weight, and the blocks shorten only where the contacts themselves are
    /// short (40 ms impacts: 2 ms blocks; 100 ms and 300 ms taps keep 5 ms).
    #[test]
    fn fitting_samples_shorten_only_for_short_contacts() {
        let runs = |pattern: &[(bool, usize)]| -> Vec<bool> {
            pattern
                .iter()
                .flat_map(|(c, n)| std::iter::repeat_n(*c, *n))
                .collect()
        };
        assert_eq!(typical_contact_samples(&runs(&[(false, 10)])), None);
        // One 2 s contact and 200 one-sample flickers at the surface.
        let mut flicker = vec![(false, 100), (true, 2000), (false, 50)];
        for _ in 0..200 {
            flicker.extend([(true, 1), (false, 3)]);
        }
        assert_eq!(typical_contact_samples(&runs(&flicker)), Some(2000));
        // Contacts of 30, 40, 40, 50 samples: the median sample lies in a 40-sample one.
        let impacts = runs(&[
            (false, 500),
            (true, 30),
            (false, 500),
            (true, 40),
            (false, 500),
            (true, 40),
            (false, 500),
            (true, 50),
            (false, 500),
        ]);
        assert_eq!(typical_contact_samples(&impacts), Some(40));
        // Prepared at 1 kHz: 40 ms impacts on 2 ms blocks; 300 ms taps on 5 ms blocks.
        let prepared = |contact_s: f64| {
            log(8.0, |t| {
                let phase = t % 1.0;
                if phase < contact_s {
                    1e-3 * (std::f64::consts::PI * phase / contact_s).sin()
                } else {
                    -1e-3
                }
            })
        };
        assert_eq!(prepared(0.04).block, SHORT_BLOCK_SAMPLES);
        assert_eq!(prepared(0.1).block, 5);
        assert_eq!(prepared(0.3).block, 5);
    }

    /// Taps at `hz`, `samples` at 1 kHz from t = 0, 0.2 mm out of contact to 1 mm deep:
    /// x = −0.2 + 0.6·(1 − cos ωt) mm, with its exact rate and acceleration
    /// (t \[s\], x \[m\], ẋ \[m/s\], ẍ \[m/s²\]).
    pub(in crate::diagnose) fn taps(hz: f64, samples: usize) -> [Vec<f64>; 4] {
        let w = 2.0 * std::f64::consts::PI * hz;
        let t: Vec<f64> = (0..samples).map(|i| i as f64 * 1e-3).collect();
        let along = |f: &dyn Fn(f64) -> f64| t.iter().map(|&t| f(t)).collect::<Vec<f64>>();
        let x = along(&|t| -0.2e-3 + 0.6e-3 * (1.0 - (w * t).cos()));
        let v = along(&|t| 0.6e-3 * w * (w * t).sin());
        let a = along(&|t| 0.6e-3 * w * w * (w * t).cos());
        [t, x, v, a]
    }

    /// A reversal within a fitting sample is found where it lies, to half a raw sample, with
    /// the rates on either side (a delayed model's step there, `KinkStep`).
    #[test]
    fn a_reversal_is_found_where_it_lies_with_the_rates_on_either_side() {
        let turn = 10.0123;
        let triangle = log(20.0, |t| 1e-3 - 1e-4 * (t - turn).abs());
        assert!(triangle.block > 1, "{}", triangle.block);
        assert_eq!(triangle.kink_steps.len(), 1, "{:?}", triangle.kink_steps);
        let k = triangle.kink_steps[0];
        assert!((k.raw_index - turn * 1e3).abs() <= 0.5, "{k:?}");
        assert!((k.rate_before - 1e-4).abs() < 1e-9, "{k:?}");
        assert!((k.rate_after + 1e-4).abs() < 1e-9, "{k:?}");
        assert!(triangle.left_out[k.first_block + 1..k.last_block]
            .iter()
            .all(|o| *o));
        assert!(!triangle.left_out[k.first_block] && !triangle.left_out[k.last_block]);
    }

    /// A record that begins in contact leaves out as many leading fitting samples as the
    /// first 50 ms span ([`leading_left_out_s`]), whatever the block; one that begins out of
    /// contact leaves none; one that ends in contact leaves its last sample out, unless it
    /// is cut at the end of a phase; the kinks are counted apart from them.
    #[test]
    fn a_record_that_begins_in_contact_leaves_out_its_first_50_ms() {
        let pressed = log(4.0, |t| 1e-3 + 0.5e-3 * (6.0 * t).sin());
        let leading = pressed.leading_left_out;
        assert_eq!(leading, (0.05 / pressed.dt).round() as usize);
        assert!(pressed.left_out[..leading].iter().all(|out| *out));
        let trailing = pressed.trailing_left_out;
        assert_eq!(
            pressed.kinks(),
            pressed.left_out[leading..].iter().filter(|k| **k).count() - trailing
        );
        assert_eq!(
            pressed.samples_counted_from(0),
            pressed.len() - leading - trailing - pressed.kinks()
        );
        let approached = log(4.0, |t| 1e-3 * (t - 1.0));
        assert_eq!(approached.leading_left_out, 0);
        // Both end in contact: their last sample is left out, and not as a kink.
        for ends_pressed in [&pressed, &approached] {
            assert_eq!(ends_pressed.trailing_left_out, 1);
            assert!(ends_pressed.left_out[ends_pressed.len() - 1]);
        }
        assert_eq!(approached.kinks(), 0);
        let lifted = log(4.0, |t| 1e-3 * (1.0 - (t - 2.0).abs()));
        assert_eq!(lifted.trailing_left_out, 0);
        assert!(!lifted.left_out[lifted.len() - 1]);
        // Cut at the end of its loading, a ramp-and-hold keeps its new last sample: that
        // one has its neighbour.
        let mut held = log(6.0, |t| 1e-3 * (t - 1.0).clamp(0.0, 2.0));
        assert_eq!(held.trailing_left_out, 1);
        let whole = held.len();
        assert!(held.keep_until_end_of(Phase::Loading));
        assert!(held.len() < whole, "{} of {whole}", held.len());
        assert_eq!(held.trailing_left_out, 0);
        assert!(!held.left_out[held.len() - 1]);
        assert_eq!(held.kinks(), held.left_out.iter().filter(|k| **k).count());
        assert!(!approached.left_out[0]);
    }

    /// A first contact flagged a block before the probe passes the contact point (the
    /// position's noise: three of the block's five samples just past it, the block's mean
    /// still short of it) has not ended at that block: a ramp in that never leaves has no
    /// later contact.
    #[test]
    fn a_contact_flagged_before_the_probe_passes_the_point_has_not_ended_there() {
        let mut flagged = log(3.0, |t| 1e-3 * (t - 1.0));
        assert_eq!(flagged.block, 5);
        assert_eq!(flagged.first_contact_end, flagged.len());
        let t: Vec<f64> = (0..3000).map(|i| i as f64 * 1e-3).collect();
        let mut x: Vec<f64> = t.iter().map(|&t| 1e-3 * (t - 1.0)).collect();
        for xi in &mut x[995..998] {
            *xi = 0.5e-6;
        }
        let f: Vec<f64> = x.iter().map(|&x| 1e3 * x.max(0.0)).collect();
        flagged = prepare_known(&t, &x, &f, 0.0, 0.0, 1e-3, 1).expect("prepared");
        let first = flagged.contact.iter().position(|c| *c).expect("a contact");
        assert_eq!(first, 199);
        assert!(flagged.depth_m[first] <= 0.0, "{}", flagged.depth_m[first]);
        assert_eq!(flagged.first_contact_end, flagged.len());
    }

    /// A load-cell zero that shifts in the free space after the first contact is placed
    /// where it shifts, not at the lift-off, in the stretch after the first contact or
    /// after a later one; with no stretch, at the lift-off.
    #[test]
    fn a_load_cell_step_is_placed_where_the_free_force_changes_level() {
        // Free 0..100, contact 100..200, free 200..400 (the step at 330), contact
        // 400..500, free 500..600: a 0.05 N step under ±0.01 N of alternating noise.
        let contact: Vec<bool> = (0..600)
            .map(|i| (100..200).contains(&i) || (400..500).contains(&i))
            .collect();
        let force: Vec<f64> = (0..600)
            .map(|i| {
                let noise = if i % 2 == 0 { 0.01 } else { -0.01 };
                let level = if i >= 330 { 0.05 } else { 0.0 };
                if contact[i] {
                    5.0
                } else {
                    level + noise
                }
            })
            .collect();
        assert_eq!(load_cell_step(&force, &contact, 200), 330);
        // A step at the next touch: all of the stretch reads the old zero.
        let late: Vec<f64> = (0..600)
            .map(|i| if i >= 400 && !contact[i] { 0.05 } else { 0.0 })
            .collect();
        assert_eq!(load_cell_step(&late, &contact, 200), 400);
        // The detector releasing 10 samples after the position (a shifted zero holds the
        // force above its threshold): the stretch begins where it frees.
        let lagging: Vec<bool> = (0..600)
            .map(|i| contact[i] || (200..210).contains(&i))
            .collect();
        assert_eq!(load_cell_step(&force, &lagging, 200), 330);
        // A step after the second contact, in the last stretch, is placed there too.
        let after_second: Vec<f64> = (0..600)
            .map(|i| {
                let noise = if i % 2 == 0 { 0.01 } else { -0.01 };
                match (contact[i], i >= 530) {
                    (true, _) => 5.0,
                    (false, later) => noise + if later { 0.05 } else { 0.0 },
                }
            })
            .collect();
        assert_eq!(load_cell_step(&after_second, &contact, 200), 530);
        // A constant free force has no step to place.
        assert_eq!(load_cell_step(&vec![0.0; 600], &contact, 200), 200);
        // A record that never leaves its first contact has no stretch.
        assert_eq!(load_cell_step(&force, &contact, 600), 600);
    }

    #[test]
    fn a_surface_that_moves_after_a_later_contact_switches_there() {
        // Six triangular taps of 100 samples from 1 mm above to 1 mm below the prepared
        // contact point, a 1000 N/m spring whose surface is `surface(tap)`, ±0.002 N of
        // alternating noise (a fitting sample's deviation 0.01 N).
        let taps = |surface: &dyn Fn(usize) -> f64| -> (Vec<f64>, Vec<f64>) {
            (0..600)
                .map(|i| {
                    let t = (i % 100) as f64;
                    let depth = -1e-3 + 2e-3 * (1.0 - (t - 50.0).abs() / 50.0);
                    let noise = if i % 2 == 0 { 0.002 } else { -0.002 };
                    (depth, 1000.0 * (depth - surface(i / 100)).max(0.0) + noise)
                })
                .unzip()
        };
        // The surface 0.3 mm deeper from the fourth tap on: the switch at the probe's
        // highest point before it (the fourth tap's first sample).
        let (depth, force) = taps(&|tap| if tap >= 3 { 3e-4 } else { 0.0 });
        assert_eq!(surface_switch(&depth, &force, 0.01, 80), 300);
        // Moved after the first tap: the first contact's switch, as before.
        let (depth, force) = taps(&|tap| if tap >= 1 { 3e-4 } else { 0.0 });
        assert_eq!(surface_switch(&depth, &force, 0.01, 80), 80);
        // Not moved: the same.
        let (depth, force) = taps(&|_| 0.0);
        assert_eq!(surface_switch(&depth, &force, 0.01, 80), 80);
        // Beginning in contact (the first tap's onset not seen): still after the fourth.
        let (depth, force) = taps(&|tap| if tap >= 3 { 3e-4 } else { 0.0 });
        let (depth, force) = (&depth[40..], &force[40..]);
        assert_eq!(surface_switch(depth, force, 0.01, 40), 260);
        // Two onsets cannot show a later move than the first contact's.
        assert_eq!(surface_switch(&depth[..200], &force[..200], 0.01, 40), 40);
    }
}
