//! The any-recording front end: what a record must be told before an estimator can run on
//! it — which way its position axis points into the material, the force offset and the
//! contact point — estimated from the WHOLE record, never from the assumption that it
//! starts out of contact.
//!
//! One joint least-squares fit ([`fit`]) of the offset, the contact point and the contact
//! law (Kelvin-Voigt, eq. 1, or Hunt-Crossley, eq. 3) on each orientation of the position
//! axis decides them all:
//! - the **axis** is the orientation on which the law fits (the force rises as the probe
//!   goes in); `--position-sign` overrides;
//! - the **offset** is determined by the samples behind the fitted contact point, where the
//!   force must be flat: wherever they are (an approach, brief or long lift-offs, a pause at
//!   the start). With fewer than [`MIN_FREE_SAMPLES`] of them, or with a force that follows
//!   the position there (the record never leaves contact: an offset and a contact point
//!   trade against each other), the offset is **not identifiable**: it is held at 0 or at
//!   `--force-offset-n` and flagged;
//! - the **contact point** is where the law's force starts, from the onsets the record
//!   shows (or extrapolated along the law when it never leaves contact).
//!
//! [`identifiability`] then says which of an estimator's parameters the record determines.

pub mod fit;
pub mod identifiability;
pub mod series;

use rayon::prelude::*;
use serde::Serialize;

use self::fit::{min_max, LawFamily, LawFit, OffsetTerm, Problem};
use self::identifiability::lag1_autocorrelation;
use self::series::Series;

/// Fewest native samples behind the contact point that can determine the offset.
pub const MIN_FREE_SAMPLES: usize = 20;

/// What the user fixed on the command line.
#[derive(Debug, Clone, Copy, Default)]
pub struct Options {
    /// +1: the position increases into the material; −1: it decreases; `None`: detect.
    pub position_sign: Option<f64>,
    /// The force offset \[N\], if known; `None`: estimate it where the record allows.
    pub force_offset_n: Option<f64>,
}

/// How the axis orientation was decided.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum AxisSource {
    /// `--position-sign`.
    Given,
    /// The contact law fits `rss_ratio` times better on this orientation than on the other
    /// (for a law other than Kelvin-Voigt's, the Kelvin-Voigt law's ratio where it is
    /// decisive: the law itself is then fitted on this orientation only).
    Detected {
        /// RSS on the other orientation ÷ RSS on this one.
        rss_ratio: f64,
    },
    /// No contact law with a positive stiffness fits the other orientation at all (the
    /// force falls as the position moves that way into the material; the Kelvin-Voigt
    /// law, as for `Detected`, where it decided for another law).
    OnlyOrientation,
}

/// Where the force offset came from.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "source")]
pub enum OffsetSource {
    /// The samples behind the contact point.
    FreeSpace {
        /// Native samples.
        samples: usize,
        /// Contiguous stretches of them.
        stretches: usize,
        /// The longest stretch, (start, end) \[s\].
        longest_s: (f64, f64),
        /// Native samples in contact where the material let go of the probe (a damped
        /// material left faster than it recovers: the law's force below zero, the force
        /// read at the offset). They pin the offset too; counted only where the points
        /// behind the contact point are too few, or too close to it, to pin it alone.
        released: usize,
    },
    /// `--force-offset-n`.
    Given,
    /// Not determined by the record: held (at 0 unless given), and flagged.
    NotIdentifiable {
        /// Why.
        reason: String,
    },
}

/// Where the contact point came from.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "source")]
pub enum ContactSource {
    /// Onsets in the record.
    Onsets {
        /// Contacts that start in the record.
        contacts: usize,
    },
    /// The record never shows an onset: extrapolated along the law.
    Extrapolated,
}

impl ContactSource {
    /// Contacts that start in the record (0 when extrapolated).
    pub fn onsets(&self) -> usize {
        match *self {
            ContactSource::Onsets { contacts } => contacts,
            ContactSource::Extrapolated => 0,
        }
    }
}

/// The front end's findings on a record.
#[derive(Debug, Clone, Serialize)]
pub struct FrontEnd {
    /// +1 if the position increases into the material, −1 if it decreases.
    pub position_sign: f64,
    /// The law describes the loading curve only (see [`analyse`]): fitted on the free
    /// space and the loading, and to be estimated during loading.
    pub loading_only: bool,
    /// How the orientation was decided.
    pub axis: AxisSource,
    /// Force offset \[N\] to subtract.
    pub force_offset_n: f64,
    /// Where it came from.
    pub offset: OffsetSource,
    /// Contact point on the record's own position axis \[m\].
    pub contact_position_m: f64,
    /// Where it came from.
    pub contact: ContactSource,
    /// The joint fit (on the oriented axis u = sign·x).
    #[serde(serialize_with = "serialize_law")]
    pub law: LawFit,
    /// The fitted points (block means of the native record).
    #[serde(skip)]
    pub series: Series,
    /// Measurement noise of the fitted points \[N\]: from the free-space samples when there
    /// are enough of them, else from second differences.
    pub noise_n: f64,
    /// Lag-1 autocorrelation of that noise (0 when estimated from second differences).
    pub noise_rho1: f64,
    /// Noise of the force samples as given (before any averaging) \[N\], from second
    /// differences ([`crate::setup::noise_level`] of the analysed force; the run options'
    /// note reports it, not the JSON).
    #[serde(skip)]
    pub sample_noise_n: f64,
    /// What was found and from which samples, in words.
    pub notes: Vec<String>,
    /// What the record could not determine, in words.
    pub warnings: Vec<String>,
}

/// The whole-record law in JSON: its family and SI coefficients.
fn serialize_law<S: serde::Serializer>(law: &LawFit, s: S) -> Result<S::Ok, S::Error> {
    use serde::ser::SerializeMap;
    let mut m = s.serialize_map(None)?;
    m.serialize_entry("family", law.family.describe())?;
    if law.family == LawFamily::Exponential {
        m.serialize_entry("exponential_rate_per_m", &law.rate_per_m)?;
    } else {
        m.serialize_entry("exponent", &law.exponent)?;
    }
    m.serialize_entry("stiffness", &law.stiffness)?;
    if law.family.has_relaxation() {
        m.serialize_entry("instantaneous_stiffness", &law.instantaneous_stiffness())?;
        m.serialize_entry("relaxation_rate_per_s", &law.rate_per_s)?;
    } else {
        m.serialize_entry("damping", &law.damping())?;
    }
    m.serialize_entry("rms_residual_n", &law.rms_n())?;
    m.end()
}

impl FrontEnd {
    /// `true` when the record determined the offset.
    pub fn offset_identifiable(&self) -> bool {
        matches!(self.offset, OffsetSource::FreeSpace { .. })
    }

    /// Noise of a fitted point \[N\] from the force's second differences alone
    /// ([`FrontEnd::sample_noise_n`] over the square root of the points' averaging): unlike
    /// [`FrontEnd::noise_n`], not raised by a law that misfits the record.
    pub fn point_noise_from_differences_n(&self) -> f64 {
        self.series.point_noise_n(self.sample_noise_n)
    }

    /// Penetration δ \[m\] of a raw position \[m\] (negative behind the contact point).
    pub fn depth_m(&self, position_m: f64) -> f64 {
        self.position_sign * position_m - self.law.contact_m
    }

    /// The fitted points' penetrations \[m\] and rates \[m/s\] on the oriented axis.
    pub fn series_depth_and_rate(&self) -> (Vec<f64>, Vec<f64>) {
        depth_and_rate(&self.series, self.position_sign, self.law.contact_m)
    }

    /// The fitted points' penetrations \[m\], rates \[m/s\] and the law's force \[N\]
    /// (offset excluded, unclamped).
    pub fn law_along(&self) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        law_along(&self.series, self.position_sign, &self.law)
    }

    /// Where the record's free space ends, on its own position axis \[m\]: the contact
    /// point, unless the probe rests in front of it more than it is behind it: free points
    /// (the law's force within 3 noise deviations of zero, as the front end counts its
    /// free space) in front of the point where the probe holds still (slower than
    /// [`crate::phases::LOADING_SPEED_FRACTION`] of its 99.9th-percentile speed)
    /// outnumber the free points behind it. A soft law's fit can place its contact point
    /// anywhere between such a rest and the surface at nearly one RSS (a power law's n at
    /// its bound 4, the point 2.6 µm behind a probe that rests 63 µm before the surface
    /// while the load cell's zero drifts, on an independent generator's taps). The edge
    /// is then midway between the deepest of those resting points and the shallowest
    /// point deeper than it where the law pushes. The law's own fit is not changed; a
    /// diagnosis flags its contact samples by this edge, so that the resting samples are
    /// free space, where the zero is seen alone. (Free points in front of the point
    /// where the probe moves, a random motion hovering in a soft law's first
    /// micrometres, are the law's, not a rest.)
    pub fn free_edge_m(&self) -> f64 {
        let (depth, rate, force) = self.law_along();
        let still = loading_speed(&self.series);
        let u = |i: usize| self.position_sign * self.series.position_m[i];
        let free = |i: usize| is_free_point(depth[i], force[i], self.noise_n);
        let (mut resting, mut behind, mut deepest) = (0usize, 0usize, f64::NEG_INFINITY);
        for i in (0..depth.len()).filter(|&i| free(i)) {
            if depth[i] <= 0.0 {
                behind += 1;
            } else if rate[i].abs() < still {
                resting += 1;
                deepest = deepest.max(u(i));
            }
        }
        if resting <= behind {
            return self.contact_position_m;
        }
        let pushes = (0..depth.len())
            .filter(|&i| !free(i) && u(i) > deepest)
            .map(u)
            .fold(f64::INFINITY, f64::min);
        if !pushes.is_finite() {
            return self.contact_position_m;
        }
        self.position_sign * 0.5 * (deepest + pushes)
    }

    /// The fitted law is linear (Kelvin-Voigt, eq. 1) and pushes at every point of the
    /// record (in front of the contact point, its force above zero): then its offset and
    /// contact point trade exactly (only F0 − κ·x_c enters the force), and κ and λ do not
    /// depend on either, whether or not the record determines the offset.
    pub fn linear_law_pushes_throughout(&self) -> bool {
        self.law.family == LawFamily::KelvinVoigt && {
            let (depth, _, force) = self.law_along();
            depth.iter().zip(&force).all(|(d, f)| *d > 0.0 && *f > 0.0)
        }
    }

    /// The law misses the contact by more than 5 noise deviations and 2 % of the force
    /// range (RMS over the points in contact), as [`analyse`] judges it before fitting the
    /// loading curve alone.
    pub fn misfits_contact(&self) -> bool {
        misfits(&self.series, self.position_sign, &self.law, self.noise_n)
    }
}

/// Why a record cannot be set up for estimation.
#[derive(Debug, thiserror::Error)]
pub enum FrontEndError {
    /// Every force value is the same.
    #[error("no contact: the force never changes (it is {value_n:e} N in all {samples} samples)")]
    ConstantForce {
        /// The value \[N\].
        value_n: f64,
        /// Samples.
        samples: usize,
    },
    /// Every position value is the same.
    #[error("the position never changes (it is {value_m:e} m in all {samples} samples): nothing relates force to penetration")]
    ConstantPosition {
        /// The value \[m\].
        value_m: f64,
        /// Samples.
        samples: usize,
    },
    /// The force changes, but not with the position.
    #[error(
        "no contact: the force does not follow the position (the best contact law explains {explained_percent:.1} % \
         of the force variation, and its force stays within {law_over_noise:.1} noise deviations); the record may \
         not touch the material"
    )]
    NoContact {
        /// Variance explained by the law beyond the offset \[%\].
        explained_percent: f64,
        /// Largest law force ÷ the residual σ.
        law_over_noise: f64,
    },
    /// The fit failed (degenerate record).
    #[error("the contact law could not be fitted to the record")]
    FitFailed,
}

/// Analyses a record: `time_s` \[s\] (increasing), `position_m` \[m\] and `force_n` \[N\]
/// (raw, offset included, compression positive), any rate, any length ≥ 2.
///
/// # Errors
/// [`FrontEndError`] for a constant force or position, a force that does not follow the
/// position, or a degenerate fit.
pub fn analyse(
    time_s: &[f64],
    position_m: &[f64],
    force_n: &[f64],
    family: LawFamily,
    options: &Options,
) -> Result<FrontEnd, FrontEndError> {
    analyse_oriented(time_s, position_m, force_n, family, options, None, false)
}

/// How many times smaller the exponential law's RMS residual must be than the better
/// of the Kelvin-Voigt and Hunt-Crossley laws' for `diagnose` to take its offset and
/// contact point ([`exponential_law_preferred`]). The power law is the paper's (eq. 3)
/// and the estimators'; on a record of another material (relaxation, a depth-dependent
/// damping of another exponent) the exponential law fits about as well or up to twice as
/// well (RMS ratios 1.0-1.9 on the structure sweep's power-law, Hunt-Crossley and QLV
/// logs), by a margin that moves the contact point by up to 0.3 mm: taken at any
/// margin, it cost 6 right diagnoses of those 800 and gained 1. On an exponential material the power law fails
/// plainly: its exponent runs to the range's end with the contact point behind the free
/// space, and the exponential law's RMS is 6.5-25 times smaller (the hidden-effect
/// sweep's exponential logs).
pub const EXPONENTIAL_RMS_FACTOR: f64 = 3.0;

/// The smaller factor [`EXPONENTIAL_RMS_FACTOR`] becomes where the other law explains
/// the record only by a contact point behind all of it (no free space, no onset) and
/// the exponential law finds the record's free space and contact onsets: an exponential
/// material whose surface moved after the first tap (its later contacts unmodelled)
/// leaves a ratio of 2.5 (hidden-effect seed 505).
pub const EXPONENTIAL_RMS_FACTOR_WITH_ONSETS: f64 = 1.5;

/// Whether the exponential law's front end (`exponential`) should replace `best`, the
/// better of the Kelvin-Voigt and Hunt-Crossley ones: its RMS residual at least
/// [`EXPONENTIAL_RMS_FACTOR`] times smaller, or [`EXPONENTIAL_RMS_FACTOR_WITH_ONSETS`]
/// times where only it sees the record's contact onsets.
pub fn exponential_law_preferred(best: &FrontEnd, exponential: &FrontEnd) -> bool {
    let ratio = best.law.rms_n() / exponential.law.rms_n().max(f64::MIN_POSITIVE);
    let only_it_sees_onsets = matches!(best.contact, ContactSource::Extrapolated)
        && matches!(exponential.contact, ContactSource::Onsets { .. });
    ratio >= EXPONENTIAL_RMS_FACTOR
        || (only_it_sees_onsets && ratio >= EXPONENTIAL_RMS_FACTOR_WITH_ONSETS)
}

/// [`AxisSource`]s that leave no doubt about the orientation: given, the only one a law
/// with a positive stiffness fits, or a fit at least this many times better than the other.
pub const DECISIVE_AXIS_RSS_RATIO: f64 = 2.0;

impl AxisSource {
    /// How a law's fits decided: `other_rss` is its RSS on the other orientation (`None`:
    /// no law with a positive stiffness fits there), `rss` on the chosen one.
    fn of_fits(rss: f64, other_rss: Option<f64>) -> Self {
        match other_rss {
            None => AxisSource::OnlyOrientation,
            Some(other) => AxisSource::Detected {
                rss_ratio: other / rss.max(f64::MIN_POSITIVE),
            },
        }
    }

    /// The orientation is given, or the fit told the two apart by at least
    /// [`DECISIVE_AXIS_RSS_RATIO`].
    pub fn is_decisive(&self) -> bool {
        match self {
            AxisSource::Given | AxisSource::OnlyOrientation => true,
            AxisSource::Detected { rss_ratio } => *rss_ratio >= DECISIVE_AXIS_RSS_RATIO,
        }
    }
}

/// [`analyse`], on the axis orientation `oriented` names if it does: the sign that
/// another law family's analysis of the same record decided and how it decided it
/// (reported as is). The other orientation is not fitted: where one family's fit
/// already tells the orientations apart, a further family only needs the contact law on
/// the right one (the wrong one costs as much or more: its laws misfit, and refit their
/// free points). `None`: as [`analyse`]. With `inertia` every fit of the law adds a mass
/// m·δ̈ in contact ([`Problem::with_inertia`]; `LawFit::mass_kg`).
///
/// # Errors
/// As [`analyse`].
pub fn analyse_oriented(
    time_s: &[f64],
    position_m: &[f64],
    force_n: &[f64],
    family: LawFamily,
    options: &Options,
    oriented: Option<(f64, AxisSource)>,
    inertia: bool,
) -> Result<FrontEnd, FrontEndError> {
    let samples = force_n.len();
    let (flo, fhi) = min_max(force_n);
    if fhi.partial_cmp(&flo) != Some(std::cmp::Ordering::Greater) {
        return Err(FrontEndError::ConstantForce {
            value_n: flo,
            samples,
        });
    }
    let (xlo, xhi) = min_max(position_m);
    if xhi.partial_cmp(&xlo) != Some(std::cmp::Ordering::Greater) {
        return Err(FrontEndError::ConstantPosition {
            value_m: xlo,
            samples,
        });
    }
    let series = Series::new(time_s, position_m, force_n);
    let series = if family.has_relaxation() {
        series
    } else {
        series.without_kinks()
    };
    let free_offset = OffsetTerm::Free;
    // The orientation and who decided it, where this law's own fits do not.
    let (oriented, decided_by) = match (oriented, options.position_sign) {
        (Some(o), _) => (Some(o), Some(AxisDecidedBy::OtherLaws)),
        (None, None) if family != LawFamily::KelvinVoigt => {
            let linear = linear_orientation(&series);
            (linear, linear.map(|_| AxisDecidedBy::KelvinVoigt))
        }
        (None, _) => (None, None),
    };
    let signs: Vec<f64> = match (oriented, options.position_sign) {
        (Some((s, _)), _) | (None, Some(s)) => vec![s.signum()],
        (None, None) => vec![1.0, -1.0],
    };
    let sample_noise_n = crate::setup::noise_level(force_n);
    let noise_n = series.point_noise_n(sample_noise_n);
    // Both orientations at once where neither is given or decided: each fit is independent
    // and the bulk of the front end.
    let mut fits: Vec<(f64, LawFit)> = signs
        .par_iter()
        .filter_map(|&s| {
            Problem::new(&series, s, family, free_offset)
                .with_inertia(inertia)
                .fit()
                .map(|f| (s, f))
        })
        .collect();
    fits.sort_by(|a, b| a.1.rss.total_cmp(&b.1.rss));
    let Some(&(sign, free_fit)) = fits.first() else {
        return Err(FrontEndError::FitFailed);
    };
    let axis = match (options.position_sign, fits.get(1)) {
        _ if let Some((_, decided)) = oriented => decided,
        (Some(_), _) => AxisSource::Given,
        (None, other) => AxisSource::of_fits(free_fit.rss, other.map(|(_, f)| f.rss)),
    };
    check_contact(&series, sign, &free_fit, noise_n)?;

    // A memoryless law that misfits the contact as a whole but fits the loading curve
    // (plastic unloading, creep or relaxation in a hold) is fitted, and estimated, on the
    // loading curve: its unloading is another law.
    let mut free_fit = free_fit;
    let mut series = series;
    let mut loading_only = None;
    let mut converged_free_points = false;
    let mut misfit = !family.has_relaxation() && misfits(&series, sign, &free_fit, noise_n);
    if misfit {
        // First the unilateral contact to convergence: a heavily damped law leaves the
        // surface for the whole retract, which one round of freeing does not see.
        if let Some(fit) = Problem::new(&series, sign, family, free_offset)
            .with_inertia(inertia)
            .converging_free_points()
            .fit()
            .filter(|f| !misfits(&series, sign, f, noise_n))
        {
            free_fit = fit;
            converged_free_points = true;
            misfit = false;
        }
    }
    if misfit {
        let keep = loading_curve(&series, sign);
        let subset = series.subset(&keep);
        if let Some(fit) = Problem::new(&subset, sign, family, free_offset)
            .with_inertia(inertia)
            .without_damping()
            .fit()
        {
            if let Some(rms) = loading_consistency(&series, sign, &fit, noise_n) {
                loading_only = Some(rms);
                series = subset;
                free_fit = fit;
            }
        }
    }

    let free = FreeSpace::of(&series, sign, &free_fit, noise_n);
    let offset_verdict = free.verdict();
    // The offsets tried: the given one, the free fit's, or where the record does not
    // determine it, the holds [`held_offsets_n`] offers (the one the law fits best).
    let (holds, offset) = match (options.force_offset_n, &offset_verdict) {
        (Some(given), _) => (vec![given], OffsetSource::Given),
        (None, Ok(source)) => (Vec::new(), source.clone()),
        (None, Err(reason)) => (
            held_offsets_n(&series, family),
            OffsetSource::NotIdentifiable {
                reason: reason.clone(),
            },
        ),
    };
    let law = if holds.is_empty() {
        free_fit
    } else {
        let fits: Vec<LawFit> = holds
            .iter()
            .filter_map(|&held| {
                let problem = Problem::new(&series, sign, family, OffsetTerm::Fixed(held))
                    .with_inertia(inertia);
                if loading_only.is_some() {
                    problem.without_damping()
                } else if converged_free_points {
                    problem.converging_free_points()
                } else {
                    problem
                }
                .fit()
            })
            .collect();
        // (The first of equal fits: 0 before the record's lowest level.)
        fits.into_iter()
            .reduce(|best, fit| if fit.rss < best.rss { fit } else { best })
            .ok_or(FrontEndError::FitFailed)?
    };
    let final_free = FreeSpace::of(&series, sign, &law, noise_n);
    let contacts = final_free.onsets;
    let (noise_n, noise_rho1) = final_free.noise().unwrap_or((noise_n, 0.0));
    let contact = if contacts > 0 {
        ContactSource::Onsets { contacts }
    } else {
        ContactSource::Extrapolated
    };
    let mut front = FrontEnd {
        position_sign: sign,
        loading_only: loading_only.is_some(),
        axis,
        force_offset_n: law.offset_n,
        offset,
        contact_position_m: sign * law.contact_m,
        contact,
        law,
        series,
        noise_n,
        noise_rho1,
        sample_noise_n,
        notes: Vec::new(),
        warnings: Vec::new(),
    };
    describe(&mut front, family, &offset_verdict, decided_by);
    if let Some((loading_rms, other_rms)) = loading_only {
        front.notes.push(format!(
            "the law fits the loading curve (residual {loading_rms:.3e} N) but not the rest of the contact \
             ({other_rms:.3e} N: plastic unloading, creep or relaxation): offset, contact point and law \
             from the free space and the loading curve, and the estimator updated during loading \
             (--phase overrides)"
        ));
    }
    Ok(front)
}

/// The orientation (sign, how decided) the Kelvin-Voigt law (eq. 1) decides on `series`,
/// where it is decisive ([`AxisSource::is_decisive`]), else `None`. A linear law tells
/// the orientations apart as well as the power and relaxation laws and for a tenth of
/// their cost: on 484 records (an independent generator's 440 logs of every recording
/// structure, 40 Instron compressions, the 4 shipped files) it was decisive on 483 and
/// chose the orientation the Hunt-Crossley fit chose on every one of them (the other
/// one: the two within 1.53×, Hunt-Crossley's within 2.35×); the Zener and Hammerstein
/// estimates of that generator's 160 relaxation and clean logs kept their orientation
/// on every one. The slower laws then fit
/// one orientation, not two (a Hunt-Crossley fit of the wrong one cost as much as the
/// right one's: a third of a `diagnose` front end, half of an `estimate`'s).
fn linear_orientation(series: &Series) -> Option<(f64, AxisSource)> {
    let mut fits: Vec<(f64, f64)> = [1.0, -1.0]
        .par_iter()
        .filter_map(|&s| {
            Problem::new(series, s, LawFamily::KelvinVoigt, OffsetTerm::Free)
                .fit()
                .map(|f| (s, f.rss))
        })
        .collect();
    fits.sort_by(|a, b| a.1.total_cmp(&b.1));
    let &(sign, rss) = fits.first()?;
    let axis = AxisSource::of_fits(rss, fits.get(1).map(|f| f.1));
    axis.is_decisive().then_some((sign, axis))
}

/// The smallest RMS residual \[N\] of the Kelvin-Voigt law (eq. 1), with a free offset
/// and contact point, on the record's fitted points, over both axis orientations (only
/// `position_sign`'s where given): (on the force as read, on the force negated); `None`
/// where the force or the position is constant or no law with a positive stiffness
/// fits. A tenth of a power law's cost each: enough to tell a record's force sign, where
/// the two readings differ by where the free space lies (at the force's lowest level,
/// compression positive), which a linear law sees as well as any (see
/// `files::Loaded::with_force_sign_of`). The points are built once: a point's force is a
/// mean, so the negated record's points are the points negated.
pub fn linear_law_rms_n(
    time_s: &[f64],
    position_m: &[f64],
    force_n: &[f64],
    position_sign: Option<f64>,
) -> (Option<f64>, Option<f64>) {
    let (flo, fhi) = min_max(force_n);
    let (xlo, xhi) = min_max(position_m);
    if fhi.partial_cmp(&flo) != Some(std::cmp::Ordering::Greater)
        || xhi.partial_cmp(&xlo) != Some(std::cmp::Ordering::Greater)
    {
        return (None, None);
    }
    let as_read = Series::new(time_s, position_m, force_n).without_kinks();
    let mut negated = as_read.clone();
    negated.force_n.iter_mut().for_each(|f| *f = -*f);
    let signs: &[f64] = match position_sign {
        Some(s) if s < 0.0 => &[-1.0],
        Some(_) => &[1.0],
        None => &[1.0, -1.0],
    };
    let best = |series: &Series| {
        signs
            .par_iter()
            .filter_map(|&s| {
                Problem::new(series, s, LawFamily::KelvinVoigt, OffsetTerm::Free)
                    .fit()
                    .map(|f| f.rms_n())
            })
            .reduce_with(f64::min)
    };
    rayon::join(|| best(&as_read), || best(&negated))
}

/// Which fits decided the axis orientation of a [`FrontEnd`] when its own law's did not.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum AxisDecidedBy {
    /// The Kelvin-Voigt and Hunt-Crossley analyses of the same record (`diagnose`'s
    /// exponential law, [`analyse_oriented`]'s `oriented`).
    OtherLaws,
    /// The Kelvin-Voigt fit on both orientations ([`linear_orientation`]).
    KelvinVoigt,
}

/// Speed \[m/s\] above which a point in contact is loading: the fraction
/// [`crate::phases::LOADING_SPEED_FRACTION`] of the 99.9th-percentile speed (as
/// [`crate::phases::speed_threshold`]).
fn loading_speed(series: &Series) -> f64 {
    let mut speeds: Vec<f64> = series.rate_m_per_s.iter().map(|v| v.abs()).collect();
    crate::phases::loading_speed_of(&mut speeds)
}

/// The slope of `f` on `u` about the means of each group (`groups`: a group index per
/// point) and its standard error (N/N_eff from the residual's lag-1 autocorrelation).
fn slope_about_means(u: &[f64], f: &[f64], groups: &[usize]) -> Slope {
    let n = u.len() as f64;
    let mut sums: std::collections::BTreeMap<usize, (f64, f64, f64)> = Default::default();
    for ((u, f), g) in u.iter().zip(f).zip(groups) {
        let e = sums.entry(*g).or_default();
        *e = (e.0 + u, e.1 + f, e.2 + 1.0);
    }
    let mean = |g: usize| {
        let (su, sf, c) = sums[&g];
        (su / c, sf / c)
    };
    let (mut sxx, mut sxf) = (0.0, 0.0);
    for ((u, f), g) in u.iter().zip(f).zip(groups) {
        let (mu, mf) = mean(*g);
        sxx += (u - mu) * (u - mu);
        sxf += (u - mu) * (f - mf);
    }
    let b = if sxx > 0.0 { sxf / sxx } else { 0.0 };
    let r: Vec<f64> = u
        .iter()
        .zip(f)
        .zip(groups)
        .map(|((u, f), g)| {
            let (mu, mf) = mean(*g);
            f - mf - b * (u - mu)
        })
        .collect();
    let rho = lag1_autocorrelation(&r).clamp(0.0, 0.999);
    let n_eff = (n * (1.0 - rho) / (1.0 + rho)).max(3.0);
    let s2 = r.iter().map(|e| e * e).sum::<f64>() / (n - sums.len() as f64 - 1.0).max(1.0);
    let se = if sxx > 0.0 {
        (s2 / sxx * n / n_eff).sqrt()
    } else {
        f64::INFINITY
    };
    (b, se)
}

/// The offsets \[N\] a record that does not determine its own may be held at, the one
/// its law fits best taken: 0 (a load cell zeroed before the test), and where the force
/// falls below 0, its lowest point's (a contact cannot push below its offset). A record
/// whose force is negative throughout (a tare of −38 N under 34 N of contact force,
/// never out of contact: an independent generator's record) fits no law held at 0, and
/// was then read as a compression-negative file and negated; one that dips below 0 puts
/// its shallowest points out of contact held there, which moves the contact point (and
/// with it a linear law's κ: 7 % on a never-leaves-contact record of the structure sweep)
/// to meet them. But a record may fall below its offset where the material pulls (an AFM
/// tip's adhesion on the retract: the shipped stress-relaxation record's lowest point,
/// −216 nN, is 100 nN below its pause), hence the choice by fit, 0 first on a tie; and a
/// relaxation law, whose front end lets the law pull where the record pulls (adhesion
/// after a relaxed hold), keeps 0: there the lowest point is the pull's (held there, the
/// shipped record's Hammerstein fit took γ2 = 5.0 at 3.1 % against 1.88 at 2.3 %).
fn held_offsets_n(series: &Series, family: LawFamily) -> Vec<f64> {
    let lowest = series.force_n.iter().copied().fold(0.0, f64::min);
    if lowest < 0.0 && !family.has_relaxation() {
        vec![0.0, lowest]
    } else {
        vec![0.0]
    }
}

/// The loading curve and the quiet points around it: points moving in faster than the
/// loading speed, and points that are not unloading and whose force lies in the lowest
/// tenth of the force range (free space, the start of a contact). Holds at high force and
/// unloading are left out.
fn loading_curve(series: &Series, sign: f64) -> Vec<bool> {
    let v = loading_speed(series);
    let (lo, hi) = min_max(&series.force_n);
    let quiet = lo + 0.1 * (hi - lo);
    series
        .rate_m_per_s
        .iter()
        .zip(&series.force_n)
        .map(|(r, f)| sign * r > v || (sign * r >= -v && *f < quiet))
        .collect()
}

/// Along `series` on the axis `sign`: the penetration below `fit`'s contact point \[m\], the
/// rate into the material \[m/s\] and the law's force there \[N\] (offset excluded,
/// unclamped), one entry per point.
fn law_along(series: &Series, sign: f64, fit: &LawFit) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let (depth, rate) = depth_and_rate(series, sign, fit.contact_m);
    let force = fit.predict(&depth, &rate, &accel_along(series, sign), &series.time_s);
    (depth, rate, force)
}

/// Along `series` on the axis `sign`: the acceleration into the material \[m/s²\].
pub(crate) fn accel_along(series: &Series, sign: f64) -> Vec<f64> {
    series.accel_m_per_s2.iter().map(|a| sign * a).collect()
}

/// Along `series` on the axis `sign`: the penetration below the contact point `contact_m`
/// (on that axis) \[m\] and the rate into the material \[m/s\].
fn depth_and_rate(series: &Series, sign: f64, contact_m: f64) -> (Vec<f64>, Vec<f64>) {
    (
        series
            .position_m
            .iter()
            .map(|x| sign * x - contact_m)
            .collect(),
        series.rate_m_per_s.iter().map(|v| sign * v).collect(),
    )
}

/// `true` when the law misses the contact by more than 5 noise deviations and 2 % of the
/// force range (RMS over the contact points).
fn misfits(series: &Series, sign: f64, fit: &LawFit, noise_n: f64) -> bool {
    let (depth, _, predicted) = law_along(series, sign, fit);
    let (mut ss, mut n) = (0.0, 0usize);
    for i in 0..depth.len() {
        if depth[i] > 0.0 {
            let r =
                series.force_n[i] - fit.offset_n - estimator_core::laws::unilateral(predicted[i]);
            ss += r * r;
            n += 1;
        }
    }
    let (lo, hi) = min_max(&series.force_n);
    let rms = (ss / n.max(1) as f64).sqrt();
    n > 0 && rms > 5.0 * noise_n && rms > 0.02 * (hi - lo)
}

/// `Some((loading RMS, other RMS))` \[N\] when the law's residual over the contact points
/// that are not loading (holds, unloading: at least a tenth of the contact) is more than
/// 3 times its residual over the loading points and more than 5 noise deviations.
fn loading_consistency(
    series: &Series,
    sign: f64,
    fit: &LawFit,
    noise_n: f64,
) -> Option<(f64, f64)> {
    let (depth, rate, predicted) = law_along(series, sign, fit);
    let v = loading_speed(series);
    let (mut loading, mut other) = ((0.0, 0usize), (0.0, 0usize));
    for i in 0..depth.len() {
        if depth[i] <= 0.0 {
            continue;
        }
        let r = series.force_n[i] - fit.offset_n - estimator_core::laws::unilateral(predicted[i]);
        let class = if rate[i] > v {
            &mut loading
        } else {
            &mut other
        };
        class.0 += r * r;
        class.1 += 1;
    }
    let rms = |(ss, n): (f64, usize)| (ss / n.max(1) as f64).sqrt();
    let (l, o) = (rms(loading), rms(other));
    (loading.1 >= 20 && 10 * other.1 >= loading.1 + other.1 && o > 3.0 * l && o > 5.0 * noise_n)
        .then_some((l, o))
}

/// Rejects a record whose force does not follow the position at all: the best law explains
/// less than 30 % of the force's variance, or its force stays within 5 noise deviations of
/// a point (`noise_n`, from second differences: the fit's own residual also holds whatever
/// the law misses, plastic flow or creep, and is no measure of the noise).
fn check_contact(
    series: &Series,
    sign: f64,
    fit: &LawFit,
    noise_n: f64,
) -> Result<(), FrontEndError> {
    let f = &series.force_n;
    let mean = f.iter().sum::<f64>() / f.len() as f64;
    let total: f64 = f.iter().map(|v| (v - mean) * (v - mean)).sum();
    let explained = 1.0 - fit.rss / total.max(f64::MIN_POSITIVE);
    let law_max = law_along(series, sign, fit)
        .2
        .iter()
        .map(|f| f.abs())
        .fold(0.0, f64::max);
    let sigma = noise_n.max(f64::MIN_POSITIVE);
    if explained < 0.3 || law_max < 5.0 * sigma {
        return Err(FrontEndError::NoContact {
            explained_percent: 100.0 * explained,
            law_over_noise: law_max / sigma,
        });
    }
    Ok(())
}

/// Whether a point at penetration `depth_m` \[m\], where the law's force (offset
/// excluded) is `law_force_n` \[N\], is free space for a front end whose points' noise is
/// `noise_n` \[N\]: behind the contact point, or so close to it that the law's force is
/// below 3 noise deviations (the one rule of [`FreeSpace`] and
/// [`FrontEnd::free_edge_m`]).
fn is_free_point(depth_m: f64, law_force_n: f64, noise_n: f64) -> bool {
    depth_m <= 0.0 || law_force_n.abs() < 3.0 * noise_n
}

/// A slope \[N/m\] and its standard error.
type Slope = (f64, f64);

/// The points behind a fit's contact point.
struct FreeSpace {
    /// Native samples behind the contact point.
    samples: usize,
    /// Contiguous stretches (start, end) \[s\].
    stretches: Vec<(f64, f64)>,
    /// Contacts that start within the record (a stretch followed by contact).
    onsets: usize,
    /// Slope of force on oriented position behind the contact point \[N/m\] and its
    /// standard error (effective sample size), pooled and within each free stretch, and
    /// the travel \[m\] it was measured over: over the free points at least a fifth of
    /// their reach behind it.
    slope: Option<(Slope, Slope, f64)>,
    block: usize,
    /// Force range of the record \[N\].
    force_range_n: f64,
    /// How far behind the contact point the free points reach \[m\].
    reach_m: f64,
    /// Native samples in front of the contact point where the material has let go of the
    /// probe: the law's (unclamped) force at least 5 noise deviations below zero, as when a
    /// damped material is left faster than it recovers, and the force read there within 3
    /// noise deviations of the offset ([`FreeSpace::released_points`]).
    released: usize,
    /// For a linear law (κ, no exponent): the depth at which contact would carry 5 noise
    /// deviations \[m\]; 0 for the power laws.
    visible_m: f64,
    /// Which points are free.
    behind: Vec<bool>,
    /// The force the law does not explain at each point \[N\]: the measured force less the
    /// law's (unilateral) contact force, which is 0 behind the contact point.
    unexplained: Vec<f64>,
}

impl FreeSpace {
    /// The free points of `fit` along `series`: behind the contact point, or so close to
    /// it that the law's force there is below 3 noise deviations (a probe resting at the
    /// surface before a test is free space, whatever side of the fitted point its noise
    /// puts it on). Their trend and noise are those of the force the law leaves
    /// unexplained: a steep power law's own rise within 3 noise deviations of zero (up to
    /// a fifth of the depth for n ≈ 2) is contact the fit accounts for, not a sign that
    /// the record never leaves contact.
    fn of(series: &Series, sign: f64, fit: &LawFit, noise_n: f64) -> FreeSpace {
        let (depth, _, predicted) = law_along(series, sign, fit);
        let behind: Vec<bool> = depth
            .iter()
            .zip(&predicted)
            .map(|(d, f)| is_free_point(*d, *f, noise_n))
            .collect();
        let unexplained: Vec<f64> = series
            .force_n
            .iter()
            .zip(depth.iter().zip(&predicted))
            .map(|(f, (d, p))| {
                if *d > 0.0 {
                    f - estimator_core::laws::unilateral(*p)
                } else {
                    *f
                }
            })
            .collect();
        let mut stretches = Vec::new();
        let mut onsets = 0;
        let mut start = None;
        for (i, &b) in behind.iter().enumerate() {
            match (b, start) {
                (true, None) => start = Some(i),
                (false, Some(s)) => {
                    stretches.push((series.time_s[s], series.time_s[i - 1]));
                    onsets += 1;
                    start = None;
                }
                _ => {}
            }
        }
        if let Some(s) = start {
            stretches.push((series.time_s[s], series.time_s[behind.len() - 1]));
        }
        let idx: Vec<usize> = (0..behind.len()).filter(|&i| behind[i]).collect();
        // The trend is measured where free space is free for certain: behind the contact
        // point by at least a fifth of the free points' reach. Contact force just behind
        // the fitted point (a surface that moved between contacts, a fitted point a little
        // too deep for some of them) is a misfit of the contact point, not a record that
        // never leaves contact, whose force follows the position all the way back.
        let reach = |i: usize| fit.contact_m - sign * series.position_m[i];
        let reach_m = idx.iter().map(|&i| reach(i)).fold(0.0, f64::max);
        let trend: Vec<usize> = idx
            .iter()
            .copied()
            .filter(|&i| reach(i) >= 0.2 * reach_m)
            .collect();
        // The force is compared with the position pooled over the free points and within
        // each free stretch (about its own means), and the record is taken to never leave
        // contact only where both show it. Pooled alone, a load cell's zero that drifts
        // in time puts each stretch at its own level, and where the operator hovers
        // nearer the surface each time the levels read as a slope on the position (an
        // independent generator's teleoperation record with a 0.03 N/s drift: 76 N/m, the
        // offset held at 0, one contact seen of eight); within each stretch alone, the
        // only motion is each approach's and retract's light contact that a misfit law
        // leaves (a relaxing, plastic ramp-and-hold read 611 N/m across its five
        // stretches). (A time trend beside the position, tried too, took a load-cell step
        // after the first contact for a slope: the hidden-effect sweep's force-offset logs
        // lost their offset.) In one stretch the two are the same.
        let mut stretch_of = vec![0usize; behind.len()];
        let mut id = 0;
        for i in 0..behind.len() {
            if behind[i] && i > 0 && !behind[i - 1] {
                id += 1;
            }
            stretch_of[i] = id;
        }
        let slope = (trend.len() >= 3).then(|| {
            let u: Vec<f64> = trend.iter().map(|&i| sign * series.position_m[i]).collect();
            let f: Vec<f64> = trend.iter().map(|&i| unexplained[i]).collect();
            let groups: Vec<usize> = trend.iter().map(|&i| stretch_of[i]).collect();
            let pooled = slope_about_means(&u, &f, &vec![0; u.len()]);
            let within = slope_about_means(&u, &f, &groups);
            let (lo, hi) = min_max(&u);
            (pooled, within, hi - lo)
        });
        let (flo, fhi) = min_max(&series.force_n);
        FreeSpace {
            samples: idx.len() * series.block,
            stretches,
            onsets,
            slope,
            block: series.block,
            force_range_n: fhi - flo,
            reach_m,
            // (The fit's own RMS where it exceeds the noise: coloured noise reads small in
            // second differences.)
            // (Memoryless laws only: a relaxation law's state lets go on every retract
            // from a relaxed hold, where the record's own force falls through adhesion
            // and the retract; the AFM stress-relaxation record's 478 such samples took
            // its offset to −205 nN against the pause's −117.)
            released: if fit.family.has_relaxation() {
                0
            } else {
                Self::released_points(
                    series,
                    &depth,
                    &predicted,
                    fit.offset_n,
                    noise_n.max(fit.rms_n()),
                ) * series.block
            },
            visible_m: if fit.family.has_exponent() {
                0.0
            } else {
                5.0 * noise_n / fit.instantaneous_stiffness().max(f64::MIN_POSITIVE)
            },
            behind,
            unexplained,
        }
    }

    /// Points of `series` in front of the contact point (`depth_m` > 0) where the law has
    /// let go (its force `predicted_n`, offset excluded, unclamped, at least 5 deviations
    /// `deviation_n` below zero), counted only where the force read there is flat at
    /// `offset_n` rather than following the law (its RMS about the offset within 0.3 of
    /// the law's RMS there). Such points pin the offset as free space does, whatever the
    /// contact point: moving the contact point back by s and the offset down by κ·s (the
    /// trade a linear law allows in contact) would read them κ·s low. Where the fit has
    /// instead taken that trade (a record that never leaves contact, its contact point too
    /// deep), the force at the points the law lets go still follows the law: 0.
    fn released_points(
        series: &Series,
        depth_m: &[f64],
        predicted_n: &[f64],
        offset_n: f64,
        deviation_n: f64,
    ) -> usize {
        let (mut count, mut ss_force, mut ss_law) = (0usize, 0.0, 0.0);
        for ((d, p), f) in depth_m.iter().zip(predicted_n).zip(&series.force_n) {
            if *d > 0.0 && *p <= -5.0 * deviation_n {
                count += 1;
                ss_force += (f - offset_n) * (f - offset_n);
                ss_law += p * p;
            }
        }
        if count > 0 && ss_force <= 0.09 * ss_law {
            count
        } else {
            0
        }
    }

    /// Measurement noise (σ \[N\], lag-1 autocorrelation) from the free-space points, each
    /// stretch about its own mean; `None` with fewer than 50 points.
    fn noise(&self) -> Option<(f64, f64)> {
        let behind = &self.behind;
        let mut deviations: Vec<Vec<f64>> = Vec::new();
        let mut current: Vec<f64> = Vec::new();
        for (i, &b) in behind.iter().enumerate() {
            if b {
                current.push(self.unexplained[i]);
            } else if !current.is_empty() {
                deviations.push(std::mem::take(&mut current));
            }
        }
        if !current.is_empty() {
            deviations.push(current);
        }
        let (mut ss, mut lag, mut count) = (0.0, 0.0, 0usize);
        for stretch in &mut deviations {
            let m = stretch.iter().sum::<f64>() / stretch.len() as f64;
            stretch.iter_mut().for_each(|v| *v -= m);
            ss += stretch.iter().map(|v| v * v).sum::<f64>();
            lag += stretch.windows(2).map(|w| w[0] * w[1]).sum::<f64>();
            count += stretch.len();
        }
        (count >= 50 && ss > 0.0).then(|| ((ss / count as f64).sqrt(), lag / ss))
    }

    /// The offset source, or why the record does not determine the offset.
    fn verdict(&self) -> Result<OffsetSource, String> {
        let min_samples = MIN_FREE_SAMPLES.max(self.block);
        // Released points pin the offset where too few points lie behind the contact
        // point, or too close to it, to pin it there.
        let released = self.released >= min_samples;
        if self.samples < min_samples && !released {
            return Err(format!(
                "only {} samples lie behind the contact point (the record never leaves contact), \
                 so an offset and a contact point trade against each other",
                self.samples
            ));
        }
        if self.reach_m < self.visible_m && !released {
            // A linear law's offset and contact point trade exactly against each other:
            // only points far enough behind the contact point that contact there would
            // show tell free space from a light touch.
            return Err(format!(
                "the points behind the fitted contact point reach only {:.3e} m behind it, \
                 where contact would carry less than 5 noise deviations ({:.3e} m): a linear \
                 law's offset and contact point trade against each other",
                self.reach_m, self.visible_m
            ));
        }
        if let Some(((b, se), within, travel)) = self.slope {
            // A trend that is both significant and material (2 % of the force range over
            // the free travel): contact force, not a load-cell wobble; pooled and within
            // the stretches both.
            let follows =
                |(b, se): (f64, f64)| b > 3.0 * se && b * travel > 0.02 * self.force_range_n;
            if travel > 0.0 && follows((b, se)) && follows(within) {
                return Err(format!(
                    "behind the fitted contact point the force still follows the position \
                     ({b:.3e} N/m ± {se:.1e} over {travel:.3e} m): the record never leaves contact"
                ));
            }
        }
        let longest = self
            .stretches
            .iter()
            .copied()
            .max_by(|a, b| (a.1 - a.0).total_cmp(&(b.1 - b.0)))
            .unwrap_or((0.0, 0.0));
        let behind_pins = self.samples >= min_samples && self.reach_m >= self.visible_m;
        Ok(OffsetSource::FreeSpace {
            samples: self.samples,
            stretches: self.stretches.len(),
            longest_s: longest,
            released: if behind_pins { 0 } else { self.released },
        })
    }
}

/// `decided_by`: the fits that decided the orientation, when this law's did not.
fn describe(
    front: &mut FrontEnd,
    family: LawFamily,
    offset_verdict: &Result<OffsetSource, String>,
    decided_by: Option<AxisDecidedBy>,
) {
    let direction = if front.position_sign > 0.0 {
        "increases"
    } else {
        "decreases"
    };
    let (detected, law, only) = match decided_by {
        Some(AxisDecidedBy::OtherLaws) => (
            "detected by the Kelvin-Voigt and Hunt-Crossley fits",
            "contact law",
            "",
        ),
        Some(AxisDecidedBy::KelvinVoigt) => (
            "detected",
            "Kelvin-Voigt law (eq. 1)",
            ", and this law was fitted this way only",
        ),
        None => ("detected", "contact law", ""),
    };
    front.notes.push(match front.axis {
        AxisSource::Given => format!("position axis: the position {direction} into the material (given)"),
        AxisSource::OnlyOrientation => format!(
            "position axis: the position {direction} into the material ({detected}: no {law} with a \
             positive stiffness fits the other way{only}; --position-sign overrides)"
        ),
        AxisSource::Detected { rss_ratio } => format!(
            "position axis: the position {direction} into the material ({detected}: the {law} fits \
             {rss_ratio:.3e}× better this way{only}; --position-sign overrides)"
        ),
    });
    if let AxisSource::Detected { rss_ratio } = front.axis {
        if rss_ratio < DECISIVE_AXIS_RSS_RATIO {
            front.warnings.push(format!(
                "the axis orientation is uncertain (the two orientations fit within a factor {rss_ratio:.2}); \
                 pass --position-sign"
            ));
        }
    }
    let total = (front.series.len() + front.series.kinks) * front.series.block;
    match (&front.offset, offset_verdict) {
        (
            OffsetSource::FreeSpace {
                samples,
                stretches,
                longest_s,
                released,
            },
            _,
        ) => front.notes.push(format!(
            "force offset {:.4e} N from the {samples} samples ({:.1} % of the record) behind the contact \
             point, in {stretches} stretch(es), the longest {:.3}-{:.3} s{}",
            front.force_offset_n,
            100.0 * *samples as f64 / total as f64,
            longest_s.0,
            longest_s.1,
            match released {
                0 => String::new(),
                r => format!(
                    ", and the {r} samples in contact where the material let go of the probe (the law's \
                     force below zero, the force read at the offset: a fast retract): too few points lie \
                     far enough behind the contact point to pin it alone"
                ),
            }
        )),
        (OffsetSource::Given, verdict) => front.notes.push(format!(
            "force offset {:.4e} N (given){}",
            front.force_offset_n,
            match verdict {
                Ok(_) => " ; the record's free space alone would have determined it".to_string(),
                Err(reason) => format!("; the record alone does not determine it: {reason}"),
            }
        )),
        (OffsetSource::NotIdentifiable { reason }, _) => {
            let below_zero = if front.force_offset_n < 0.0 {
                " (the force's lowest level: the record's force falls below 0, and a contact \
                 cannot push below its offset)"
            } else {
                ""
            };
            front.notes.push(format!(
                "force offset held at {:.4e} N{below_zero} (--force-offset-n sets it)",
                front.force_offset_n
            ));
            front.warnings.push(format!(
                "the force offset is not identifiable: {reason}; estimated with it held at {:.4e} N",
                front.force_offset_n
            ));
        }
    }
    let law = family.describe();
    let mass = match front.law.mass_kg {
        m if m > 0.0 => format!(" and a mass m·δ̈ in contact (m = {m:.3e} kg)"),
        _ => String::new(),
    };
    front.notes.push(format!(
        "contact point {:.6e} m on the file's position axis, from the joint least-squares fit of offset, \
         contact point and the {law} law{mass} to all {} samples ({} points, one per {} samples, each the mean of {}{}); {}",
        front.contact_position_m,
        total,
        front.series.len(),
        front.series.block,
        front.series.averaged,
        match front.series.kinks {
            0 => String::new(),
            k => format!(
                "; {k} left out, whose rate reads across a kink of the motion, where it is not defined"
            ),
        },
        match front.contact {
            ContactSource::Onsets { contacts } =>
                format!("the record shows {contacts} contact onset(s)"),
            ContactSource::Extrapolated =>
                "the record shows no onset: extrapolated along the law".to_string(),
        }
    ));
    if matches!(front.contact, ContactSource::Extrapolated) {
        front.warnings.push(
            "the contact point is extrapolated (the record never leaves contact): depths carry its error".into(),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use estimator_core::laws;

    /// A 1 kHz Hunt-Crossley record of `seconds` whose depth follows `depth(t)`.
    fn record(
        depth: impl Fn(f64) -> f64,
        seconds: f64,
        sign: f64,
        offset: f64,
    ) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let t: Vec<f64> = (0..(seconds * 1000.0) as usize)
            .map(|i| i as f64 * 1e-3)
            .collect();
        let x = t
            .iter()
            .map(|&t| sign * (1.5e-3 + depth(t)) + 0.02)
            .collect();
        let f = t
            .iter()
            .map(|&t| {
                let (d, v) = (depth(t), (depth(t + 1e-6) - depth(t - 1e-6)) / 2e-6);
                offset + laws::unilateral(laws::hunt_crossley(d, v, 3e4, 900.0, 1.3, 1.3))
            })
            .collect();
        (t, x, f)
    }

    #[test]
    fn a_record_that_starts_in_contact_with_brief_lift_offs() {
        let depth = |t: f64| 1.5e-3 + 1.7e-3 * (2.0 * std::f64::consts::PI * 0.7 * t).cos();
        for sign in [1.0, -1.0] {
            let (t, x, f) = record(depth, 10.0, sign, 14.0);
            let front = analyse(&t, &x, &f, LawFamily::HuntCrossley, &Options::default()).unwrap();
            assert_eq!(front.position_sign, sign);
            assert!(
                (front.force_offset_n - 14.0).abs() < 1e-3,
                "{:?}",
                front.notes
            );
            assert!((front.contact_position_m - (sign * 1.5e-3 + 0.02)).abs() < 2e-6);
            assert!(front.offset_identifiable());
            assert!((front.law.exponent - 1.3).abs() < 0.01);
        }
    }

    #[test]
    fn a_record_that_never_leaves_contact_holds_the_offset_and_says_so() {
        let depth = |t: f64| 2.5e-3 + 1.0e-3 * (2.0 * std::f64::consts::PI * 0.7 * t).cos();
        let (t, x, f) = record(depth, 10.0, 1.0, 3.0);
        let front = analyse(&t, &x, &f, LawFamily::HuntCrossley, &Options::default()).unwrap();
        assert!(!front.offset_identifiable(), "{:?}", front.offset);
        assert_eq!(front.force_offset_n, 0.0);
        assert!(!front.warnings.is_empty());
        let given = Options {
            force_offset_n: Some(3.0),
            ..Options::default()
        };
        let front = analyse(&t, &x, &f, LawFamily::HuntCrossley, &given).unwrap();
        assert_eq!(front.force_offset_n, 3.0);
        assert!(
            (front.contact_position_m - (1.5e-3 + 0.02)).abs() < 5e-6,
            "{}",
            front.contact_position_m
        );
        assert!(matches!(front.contact, ContactSource::Extrapolated));
    }

    /// An operator's taps (Kelvin-Voigt, one a second, 3 mm deep) each start from a hover
    /// nearer the surface than the last, and the load cell's zero drifts by 0.03 N/s:
    /// pooled across the free stretches, the drift read as the force following the
    /// position behind the contact point (124 N/m), and the record was taken to never
    /// leave contact (offset held at 0). With a trend in time beside it, the position's
    /// slope is nil.
    #[test]
    fn a_drifting_zero_under_hovers_ever_nearer_the_surface_is_free_space() {
        let hover = |t: f64| 3.0e-3 - 2.5e-3 * t / 12.0;
        // Half a second's press (a raised cosine), then half a second's hover.
        let press = |t: f64| {
            let phase = t.fract();
            if phase < 0.5 {
                0.5 - 0.5 * (4.0 * std::f64::consts::PI * phase).cos()
            } else {
                0.0
            }
        };
        let depth = |t: f64| -hover(t) + (3.0e-3 + hover(t)) * press(t);
        let t: Vec<f64> = (0..12_000).map(|i| i as f64 * 1e-3).collect();
        let x: Vec<f64> = t.iter().map(|&t| 0.03 - depth(t)).collect();
        let f: Vec<f64> = t
            .iter()
            .enumerate()
            .map(|(i, &t)| {
                let (d, v) = (depth(t), (depth(t + 1e-6) - depth(t - 1e-6)) / 2e-6);
                0.7 + 0.03 * t
                    + laws::unilateral(laws::kelvin_voigt(d, v, 2300.0, 35.0))
                    + 0.02 * (1.3 * i as f64).sin()
            })
            .collect();
        let front = analyse(&t, &x, &f, LawFamily::KelvinVoigt, &Options::default()).unwrap();
        assert_eq!(front.position_sign, -1.0);
        assert!(front.offset_identifiable(), "{:?}", front.offset);
        assert!(front.contact.onsets() >= 10, "{:?}", front.contact);
    }

    /// A Kelvin-Voigt record that never leaves contact under a load cell reading −38 N
    /// at rest: its force is negative throughout. Held at 0, no law fitted it (the front
    /// end failed, and the file was then read as compression-negative and negated); held
    /// at its lowest force it fits, the offset is flagged, and the linear law, pushing
    /// throughout, keeps κ and λ (its offset trades with the contact point alone).
    #[test]
    fn a_record_below_zero_throughout_is_held_at_its_lowest_force() {
        let w = 2.0 * std::f64::consts::PI * 0.4;
        let depth = |t: f64| 3.7e-3 + 2.6e-3 * (w * t).sin();
        let t: Vec<f64> = (0..10_000).map(|i| i as f64 * 1e-3).collect();
        let x: Vec<f64> = t.iter().map(|&t| 0.01 + depth(t)).collect();
        let f: Vec<f64> = t
            .iter()
            .enumerate()
            .map(|(i, &t)| {
                let (d, v) = (depth(t), (depth(t + 1e-6) - depth(t - 1e-6)) / 2e-6);
                -38.0
                    + laws::unilateral(laws::kelvin_voigt(d, v, 5600.0, 400.0))
                    + 0.02 * (1.3 * i as f64).sin()
            })
            .collect();
        let front = analyse(&t, &x, &f, LawFamily::KelvinVoigt, &Options::default()).unwrap();
        assert_eq!(front.position_sign, 1.0);
        assert!(!front.offset_identifiable(), "{:?}", front.offset);
        let lowest = f.iter().copied().fold(f64::INFINITY, f64::min);
        assert!(
            (front.force_offset_n - lowest).abs() < 0.05,
            "{} against {lowest}",
            front.force_offset_n
        );
        assert!(front.linear_law_pushes_throughout());
        assert!(
            (front.law.stiffness / 5600.0 - 1.0).abs() < 0.005,
            "{:?}",
            front.law
        );
        assert!(
            (front.law.second / 400.0 - 1.0).abs() < 0.02,
            "{:?}",
            front.law
        );
    }

    /// A steep power law (n = 2) under 0.45 N of noise rises within 3 noise deviations of
    /// zero over a fifth of its depth: those light-touch points count as free space, and
    /// the law's own rise there is not a sign that the record never leaves contact (it
    /// was, before the trend behind the contact point was taken of the force the law
    /// leaves unexplained).
    #[test]
    fn a_steep_law_s_light_touch_is_not_contact_the_fit_missed() {
        // At 303 Hz (every sample a point of the fit), strokes to 4 mm at 5, 2 and 18 mm/s
        // from 0.9 mm out, 0.5 s of free space between.
        let dt = 1.0 / 303.0;
        let mut x = Vec::new();
        for v in [5e-3, 2e-3, 18e-3] {
            let n = (4.9e-3 / v / dt) as usize;
            x.extend(std::iter::repeat_n(-0.9e-3, 150));
            x.extend((0..n).map(|i| -0.9e-3 + v * dt * i as f64));
            x.extend((0..n).map(|i| 4.0e-3 - v * dt * i as f64));
        }
        x.extend(std::iter::repeat_n(-0.9e-3, 150));
        let t: Vec<f64> = (0..x.len()).map(|i| i as f64 * dt).collect();
        let mut state = 7u64;
        let f: Vec<f64> = (0..x.len())
            .map(|i| {
                let v = (x[(i + 1).min(x.len() - 1)] - x[i.saturating_sub(1)]) / (2.0 * dt);
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let noise = 1.56 * ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5);
                let law = laws::hunt_crossley(x[i], v, 1.5e6, 4.5e7, 2.0, 2.0);
                7.8 + laws::unilateral(law) + noise
            })
            .collect();
        let front = analyse(&t, &x, &f, LawFamily::HuntCrossley, &Options::default()).unwrap();
        assert!(front.offset_identifiable(), "{:?}", front.offset);
        assert!(
            (front.force_offset_n - 7.8).abs() < 0.05,
            "{}",
            front.force_offset_n
        );
        // (1.5 % of the depth: one sample at 18 mm/s is 59 µm.)
        assert!(
            front.contact_position_m.abs() < 60e-6,
            "{}",
            front.contact_position_m
        );
        assert!(
            (front.law.exponent - 2.0).abs() < 0.05,
            "{}",
            front.law.exponent
        );
        assert!(front.noise_n < 0.55, "{}", front.noise_n);
    }

    /// Five Kelvin-Voigt taps of 2.6-3.8 mm at 6.8 mm/s on a surface that moved 0.69 mm
    /// towards the probe after the first, under AR(1) noise (φ = 0.95): the independent
    /// generator's D14, seed 203, rebuilt from its waypoints. The fitted contact point
    /// sits a little behind the later surface (the first tap pulls it deeper), so the
    /// later taps' first force (κ·δ and the damping's λ·v jump) lies just behind it; the
    /// free space farther back is flat. That is a misfit of the contact point, not a
    /// record that never leaves contact: before the trend was taken only where free space
    /// is free for certain, the offset was held at 0 and the contact point extrapolated.
    #[test]
    fn contact_just_behind_a_shifted_surface_is_not_a_record_that_never_leaves_contact() {
        // (time s, probe position relative to the first surface mm), joined by straight
        // lines with 10 ms rounded corners.
        let waypoints = [
            (0.0, -1.174),
            (0.324, -1.174),
            (0.951, 3.114),
            (1.579, -1.174),
            (1.9, -1.174),
            (2.592, 3.556),
            (3.284, -1.174),
            (3.639, -1.174),
            (4.371, 3.828),
            (5.103, -1.174),
            (5.264, -1.174),
            (5.833, 2.71),
            (6.401, -1.174),
            (6.789, -1.174),
            (7.342, 2.601),
            (7.894, -1.174),
            (8.14, -1.174),
        ];
        let dt = 7e-4;
        let at = |t: f64| -> f64 {
            let k = waypoints
                .windows(2)
                .position(|w| t <= w[1].0)
                .unwrap_or(waypoints.len() - 2);
            let ((t0, x0), (t1, x1)) = (waypoints[k], waypoints[k + 1]);
            1e-3 * (x0 + (x1 - x0) * ((t - t0) / (t1 - t0)).clamp(0.0, 1.0))
        };
        let position = |t: f64| {
            (0..10)
                .map(|j| at(t + (j as f64 - 4.5) * 1e-3))
                .sum::<f64>()
                / 10.0
        };
        let t: Vec<f64> = (0..(8.14 / dt) as usize).map(|i| i as f64 * dt).collect();
        let x: Vec<f64> = t.iter().map(|&t| position(t)).collect();
        // The surface moves at the first retract through -0.69 mm.
        let first_end = t
            .iter()
            .position(|&t| t > 1.0 && position(t) < -0.69e-3)
            .unwrap();
        let (mut state, mut ar) = (11u64, 0.0);
        let f: Vec<f64> = (0..x.len())
            .map(|i| {
                let surface = if i >= first_end { -0.69e-3 } else { 0.0 };
                let v = (position(t[i] + 1e-5) - position(t[i] - 1e-5)) / 2e-5;
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                // Uniform innovations of σ 0.09·√(1 − φ²) N.
                let white = 0.09
                    * (1.0f64 - 0.95 * 0.95).sqrt()
                    * 12f64.sqrt()
                    * ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5);
                ar = 0.95 * ar + white;
                let d = x[i] - surface;
                let law = if d > 0.0 {
                    laws::kelvin_voigt(d, v, 4370.0, 277.0)
                } else {
                    0.0
                };
                4.62 + laws::unilateral(law) + ar
            })
            .collect();
        let front = analyse(&t, &x, &f, LawFamily::KelvinVoigt, &Options::default()).unwrap();
        // The mechanism, at a fitted point 0.14 mm behind the later surface (the helper's
        // record put it 0.08 mm behind, with a trend of t = 3.6 over 1 mm; this noise
        // gives t = 4.8 over all the free points there, and 0.38 N over the free travel,
        // just short of 2 % of the range): the free points nearest the contact point carry
        // the later taps' first force, those farther back none.
        let series = Series::new(&t, &x, &f);
        let near = LawFit {
            contact_m: -0.55e-3,
            ..front.law
        };
        let free = FreeSpace::of(&series, 1.0, &near, front.noise_n);
        assert!(free.verdict().is_ok(), "{:?}", free.verdict());
        assert!(front.offset_identifiable(), "{:?}", front.offset);
        assert!(
            (front.force_offset_n - 4.62).abs() < 0.1,
            "{}",
            front.force_offset_n
        );
        assert!(matches!(front.contact, ContactSource::Onsets { .. }));
        assert!(
            (-0.8e-3..0.1e-3).contains(&front.contact_position_m),
            "{}",
            front.contact_position_m
        );
    }

    #[test]
    fn a_heavily_damped_kelvin_voigt_record_whose_retract_leaves_the_surface_is_fitted_whole() {
        // Triangles from 0.5 mm out of contact to 1.9 mm deep at 1.4 mm/s, κ = 6.7e3 N/m and
        // λ·v 1.5 times κ·δ_max: the force jumps at each onset and the probe leaves the
        // surface for the whole retract (F = 0 with δ > 0). From the first least-squares
        // solution, which holds the clipped retract as contact, one round of freeing the
        // points where the law pulls left λ about halved: the law misfit the contact, the
        // loading-only fallback fitted a line without damping (κ 2.1x, the contact point
        // behind the free space: "the record never leaves contact"; before
        // `Problem::converging_free_points`).
        let (kappa, lambda, d_max, gap, v) = (6.7e3, 1.37e4, 1.9e-3, 0.5e-3, 1.4e-3);
        let period = 2.0 * (d_max + gap) / v;
        let position = |t: f64| {
            let phase = ((t - 0.5).max(0.0) / period).fract();
            -gap + (d_max + gap) * (1.0 - (2.0 * phase - 1.0).abs())
        };
        let t: Vec<f64> = (0..(4.0 * period * 1000.0) as usize + 500)
            .map(|i| i as f64 * 1e-3)
            .collect();
        let x: Vec<f64> = t.iter().map(|&t| position(t)).collect();
        let f: Vec<f64> = t
            .iter()
            .enumerate()
            .map(|(i, &t)| {
                let rate = (position(t + 1e-6) - position(t - 1e-6)) / 2e-6;
                let noise = 0.02 * ((i as f64 * 12.9898).sin() * 43_758.545).fract();
                0.2 + laws::unilateral(laws::kelvin_voigt(x[i], rate, kappa, lambda)) + noise
            })
            .collect();
        let front = analyse(&t, &x, &f, LawFamily::KelvinVoigt, &Options::default()).unwrap();
        assert!(!front.loading_only, "{:?}", front.notes);
        assert!(front.offset_identifiable(), "{:?}", front.offset);
        assert!(matches!(
            front.contact,
            ContactSource::Onsets { contacts: 4 }
        ));
        let within_5_percent = |law: &LawFit| {
            assert!(
                (law.stiffness / kappa - 1.0).abs() < 0.05
                    && (law.damping() / lambda - 1.0).abs() < 0.05,
                "{law:?}"
            );
        };
        within_5_percent(&front.law);
        assert!(
            front.contact_position_m.abs() < 20e-6,
            "{}",
            front.contact_position_m
        );
        // With the offset given, the law is refitted with it held: the same convergence.
        let given = Options {
            force_offset_n: Some(0.21),
            ..Options::default()
        };
        let held = analyse(&t, &x, &f, LawFamily::KelvinVoigt, &given).unwrap();
        within_5_percent(&held.law);
    }

    /// A Kelvin-Voigt ramp-and-hold: from 1 mm out of contact at `speed` \[m/s\] to 4 mm
    /// deep, a 6 s hold, the retract at 1.3 times the speed; κ = 2e3 N/m, λ = 100 N·s/m,
    /// sampled at `rate_hz` with a noise-free position (as commanded) and 0.05 N of force
    /// noise. Returns (t, x, F) and the true contact position (x = 0).
    fn kelvin_voigt_ramp_and_hold(speed: f64, rate_hz: f64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let (kappa, lambda, depth, gap) = (2.0e3, 100.0, 4.0e-3, 1.0e-3);
        let ramp = (depth + gap) / speed;
        let back = ramp / 1.3;
        let (t0, t1, t2) = (0.5, 0.5 + ramp, 6.5 + ramp);
        let motion = |t: f64| -> (f64, f64) {
            if t < t0 {
                (-gap, 0.0)
            } else if t < t1 {
                (-gap + speed * (t - t0), speed)
            } else if t < t2 {
                (depth, 0.0)
            } else if t < t2 + back {
                (depth - 1.3 * speed * (t - t2), -1.3 * speed)
            } else {
                (-gap, 0.0)
            }
        };
        let n = ((t2 + back + 0.5) * rate_hz) as usize;
        let t: Vec<f64> = (0..n).map(|i| i as f64 / rate_hz).collect();
        let x: Vec<f64> = t.iter().map(|&t| motion(t).0).collect();
        let f: Vec<f64> = t
            .iter()
            .enumerate()
            .map(|(i, &t)| {
                let (d, v) = motion(t);
                let noise =
                    0.05 * (((i as f64 * 12.9898).sin() * 43_758.545).rem_euclid(1.0) - 0.5);
                1.0 + laws::unilateral(laws::kelvin_voigt(d, v, kappa, lambda)) + noise
            })
            .collect();
        (t, x, f)
    }

    #[test]
    fn a_fast_kelvin_voigt_ramp_into_a_hold_places_the_contact_point() {
        // The ramp is a few dozen of the record's points and the only ones that place the
        // contact point; the law jumps by λ·v there. Three things moved it by 0.1-0.4 mm
        // (κ 4-11 % off) on such records: the rate's 4 ms window smeared the ramp's corners
        // (λ·v errors on 8 samples each), the corner samples' rate is not defined (half the
        // speed: one 15-σ point), a run averaged across the contact point was fitted with
        // the law at its mean (full λ·v where it measured part of it), and the coarse grid
        // thinned the ramp with the hold.
        for (speed, rate_hz) in [(0.12, 2000.0), (0.08, 1000.0), (0.05, 5000.0)] {
            let (t, x, f) = kelvin_voigt_ramp_and_hold(speed, rate_hz);
            let front = analyse(&t, &x, &f, LawFamily::KelvinVoigt, &Options::default()).unwrap();
            let what = format!("{speed} m/s at {rate_hz} Hz: {:?}", front.law);
            assert!(front.contact_position_m.abs() < 15e-6, "{what}");
            assert!((front.law.stiffness / 2.0e3 - 1.0).abs() < 0.01, "{what}");
            assert!((front.law.damping() / 100.0 - 1.0).abs() < 0.05, "{what}");
            assert!((front.force_offset_n - 1.0).abs() < 0.01, "{what}");
        }
    }

    #[test]
    fn a_constant_force_and_a_force_without_contact_are_errors() {
        let t: Vec<f64> = (0..1000).map(|i| i as f64 * 1e-3).collect();
        let x: Vec<f64> = t.iter().map(|t| t * 1e-3).collect();
        let f = vec![0.25; 1000];
        let e = analyse(&t, &x, &f, LawFamily::KelvinVoigt, &Options::default()).unwrap_err();
        assert!(
            e.to_string()
                .starts_with("no contact: the force never changes"),
            "{e}"
        );
        // Noise only.
        let f: Vec<f64> = (0..1000)
            .map(|i| 0.25 + 1e-3 * ((i * 7919) % 13) as f64)
            .collect();
        let e = analyse(&t, &x, &f, LawFamily::KelvinVoigt, &Options::default()).unwrap_err();
        assert!(
            e.to_string()
                .starts_with("no contact: the force does not follow"),
            "{e}"
        );
    }
}
