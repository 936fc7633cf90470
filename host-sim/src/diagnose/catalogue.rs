//! The effect catalogue of the discrepancy workflow: the physical effects a contact model
//! may be missing ([`Effect`]), their nonlinear parameters ([`Knob`], searched) and the
//! parameters a fit reports ([`Param`], SI), with the scales their searches are bounded by.
//! The material laws (power law, exponential law, the relaxation mode's step) are the
//! core's own (`estimator_core::laws`), used by [`super::regressors`]; the mechanical
//! and measurement effects (delay, set, offsets, mass, friction) are built there.

use std::collections::BTreeSet;

use serde::{Deserialize, Serialize};

use super::data::Prepared;

/// A named effect a model may be missing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Effect {
    /// Elastic force ∝ δⁿ, n ≠ 1 (Hunt-Crossley's elastic part, eq. 3).
    PowerLawStiffness,
    /// Elastic force (m/b)(e^{bδ} − 1), the QLV exponential law (eqs. 11/13), alone or
    /// on the baseline's linear spring κδ ([`Nonlinear::linear_spring`]).
    ExponentialStiffness,
    /// Damping ∝ δ^q·δ̇ (Hunt-Crossley, eq. 3) instead of ∝ δ̇.
    DepthDependentDamping,
    /// One more exponential mode of the reduced relaxation function (QLV eq. 10/15,
    /// a Zener arm): a fraction c of the elastic force relaxes at rate ν.
    Relaxation,
    /// Load-cell bias left after the tare.
    ForceOffset,
    /// Error in the contact position (δ measured from the wrong point).
    ContactPointOffset,
    /// Probe/tissue mass: m·δ̈.
    Inertia,
    /// Lag of the force channel behind the position channel.
    TimeDelay,
    /// Force ∝ sign(δ̇) (Coulomb friction in contact).
    CoulombFriction,
    /// Permanent deformation: the contact point moves with the deepest indentation.
    PlasticSet,
    /// Drift of the load cell's zero: an offset that grows linearly in time over the
    /// record, in contact and out of it (a strain-gauge bridge warming up; the core's
    /// tare follows it between contacts, `conditioning::tare`).
    ForceDrift,
}

// `ALL[e as usize] == e`, checked when compiling (the design looks effects up by index).
const _: () = {
    let mut i = 0;
    while i < Effect::ALL.len() {
        assert!(
            Effect::ALL[i] as usize == i,
            "Effect::ALL in declaration order"
        );
        i += 1;
    }
};

impl Effect {
    /// All effects, in their declaration order (`ALL[e as usize] == e`).
    pub const ALL: [Effect; 11] = [
        Effect::PowerLawStiffness,
        Effect::ExponentialStiffness,
        Effect::DepthDependentDamping,
        Effect::Relaxation,
        Effect::ForceOffset,
        Effect::ContactPointOffset,
        Effect::Inertia,
        Effect::TimeDelay,
        Effect::CoulombFriction,
        Effect::PlasticSet,
        Effect::ForceDrift,
    ];

    /// The identifier used in reports and JSON.
    pub fn id(self) -> &'static str {
        match self {
            Effect::PowerLawStiffness => "power_law_stiffness",
            Effect::ExponentialStiffness => "exponential_stiffness",
            Effect::DepthDependentDamping => "depth_dependent_damping",
            Effect::Relaxation => "relaxation",
            Effect::ForceOffset => "force_offset",
            Effect::ContactPointOffset => "contact_point_offset",
            Effect::Inertia => "inertia",
            Effect::TimeDelay => "time_delay",
            Effect::CoulombFriction => "coulomb_friction",
            Effect::PlasticSet => "plastic_set",
            Effect::ForceDrift => "force_drift",
        }
    }

    /// Parses [`Effect::id`].
    pub fn from_id(id: &str) -> Option<Effect> {
        Effect::ALL.into_iter().find(|e| e.id() == id)
    }

    /// One line of physics.
    pub fn description(self) -> &'static str {
        match self {
            Effect::PowerLawStiffness => "elastic force ∝ δⁿ (Hunt-Crossley elastic part)",
            Effect::ExponentialStiffness => {
                "elastic force (m/b)(e^{bδ} − 1) (QLV exponential law), alone or with κδ"
            }
            Effect::DepthDependentDamping => "damping ∝ δ^q·δ̇ (Hunt-Crossley) instead of ∝ δ̇",
            Effect::Relaxation => {
                "stress relaxation: one more exponential mode (Zener arm, QLV eq. 15)"
            }
            Effect::ForceOffset => "load-cell bias",
            Effect::ContactPointOffset => "error in the contact position",
            Effect::Inertia => "probe/tissue mass m·δ̈",
            Effect::TimeDelay => "lag between the force and position channels",
            Effect::CoulombFriction => "force ∝ sign(δ̇)",
            Effect::PlasticSet => "permanent deformation: the unloading contact point moves",
            Effect::ForceDrift => "load-cell zero drift: an offset linear in time",
        }
    }

    /// Which of two effects the record cannot tell apart is named: the one that needs
    /// less of the motion (0 elastic laws: depth alone; 1 offsets and set: a contact;
    /// 2 relaxation: time under load; 3 rate effects: a speed that varies).
    pub fn precedence(self) -> u8 {
        match self {
            Effect::PowerLawStiffness | Effect::ExponentialStiffness => 0,
            Effect::ForceOffset
            | Effect::ForceDrift
            | Effect::ContactPointOffset
            | Effect::PlasticSet => 1,
            Effect::Relaxation => 2,
            Effect::DepthDependentDamping
            | Effect::Inertia
            | Effect::TimeDelay
            | Effect::CoulombFriction => 3,
        }
    }

    /// Whether the effect's force depends on the motion's rate (δ̇, δ̈, a delay) rather
    /// than on depth and time alone.
    pub fn is_rate_effect(self) -> bool {
        self.precedence() == 3
    }

    /// Effects that replace the same model piece cannot both be present.
    pub fn conflicts_with(self, other: Effect) -> bool {
        matches!(
            (self, other),
            (Effect::PowerLawStiffness, Effect::ExponentialStiffness)
                | (Effect::ExponentialStiffness, Effect::PowerLawStiffness)
        )
    }

    /// The parameters the effect adds to a model (those a report shows for it).
    pub fn own_parameters(self) -> &'static [Param] {
        match self {
            Effect::PowerLawStiffness => &[Param::N],
            Effect::ExponentialStiffness => &[Param::B],
            Effect::DepthDependentDamping => &[Param::Q],
            Effect::Relaxation => &[Param::RelaxedFraction, Param::RatePerS],
            Effect::ForceOffset => &[Param::ForceOffsetN],
            Effect::ContactPointOffset => &[Param::ContactShiftM],
            Effect::Inertia => &[Param::MassKg],
            Effect::TimeDelay => &[Param::DelayS],
            Effect::CoulombFriction => &[Param::CoulombN],
            Effect::PlasticSet => &[Param::PlasticFraction],
            Effect::ForceDrift => &[Param::ForceDriftNPerS],
        }
    }

    /// The knobs a fit that adds this effect searches: its own [`Effect::knob`], or for a
    /// mass the contact position. A mass's force m·δ̈ is a step where a contact begins at
    /// an acceleration (a tap at one frequency: δ̈ = −ω²·(δ − δ₀) there), which the model
    /// without it fits by an earlier contact point, tens of micrometres out of a local
    /// search's basin on 6-9 Hz taps.
    pub fn searched_knobs(self) -> Vec<Knob> {
        match self {
            Effect::Inertia => vec![Knob::ContactPosition],
            _ => self.knob().into_iter().collect(),
        }
    }

    /// The effect's nonlinear parameter, if any (found by search, not least squares).
    pub fn knob(self) -> Option<Knob> {
        match self {
            Effect::PowerLawStiffness => Some(Knob::Exponent),
            Effect::ExponentialStiffness => Some(Knob::StiffeningRate),
            Effect::DepthDependentDamping => Some(Knob::DampingExponent),
            Effect::Relaxation => Some(Knob::RelaxationRate),
            Effect::ContactPointOffset => Some(Knob::ContactShift),
            Effect::TimeDelay => Some(Knob::Delay),
            Effect::PlasticSet => Some(Knob::PlasticFraction),
            Effect::CoulombFriction => Some(Knob::SlipRate),
            Effect::ForceOffset | Effect::ForceDrift | Effect::Inertia => None,
        }
    }
}

/// A nonlinear parameter of the composite model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
pub enum Knob {
    /// Refinement of the first-impact contact position \[m\], part of every model: the
    /// detector's threshold point is biased by the onset shape, the damping step and any
    /// channel delay, and δ must be measured from the point each model implies.
    ContactPosition,
    /// Power-law exponent n.
    Exponent,
    /// Exponential stiffening rate b \[1/m\].
    StiffeningRate,
    /// Damping exponent q.
    DampingExponent,
    /// Relaxation rate ν \[1/s\].
    RelaxationRate,
    /// Force-channel delay \[s\].
    Delay,
    /// Contact position of the later contacts minus that of the first impact \[m\].
    ContactShift,
    /// Plastic-set fraction of the deepest indentation.
    PlasticFraction,
    /// Rate \[m/s\] over which Coulomb friction changes sign (F_c·tanh(δ̇/v_s)).
    SlipRate,
}

impl Knob {
    /// The value at which the knob's effect adds nothing to the model it joins (the
    /// nested model): n = 1 (the linear spring), q = 0 (plain damping), no delay, no
    /// shift of the later contacts, no set. `None` where the effect's size is a linear
    /// coefficient (relaxation, friction) or the nested model is a limit, not a value
    /// (exponential stiffening as b → 0), and for the contact position, part of every
    /// model.
    pub(super) fn nested_value(self) -> Option<f64> {
        match self {
            Knob::Exponent => Some(1.0),
            Knob::DampingExponent | Knob::Delay | Knob::ContactShift | Knob::PlasticFraction => {
                Some(0.0)
            }
            Knob::ContactPosition
            | Knob::StiffeningRate
            | Knob::RelaxationRate
            | Knob::SlipRate => None,
        }
    }

    /// Search bounds in the knob's units and whether to search on a log scale.
    pub(super) fn range(self, scale: &Scales) -> (f64, f64, bool) {
        let l = scale.depth_m;
        match self {
            Knob::ContactPosition => (-scale.contact_span * l, scale.contact_span * l, false),
            Knob::Exponent => (0.5, 3.5, false),
            Knob::StiffeningRate => (0.05 / l, 8.0 / l, true),
            Knob::DampingExponent => (0.1, 3.0, false),
            // From a mode slower than the record to one a few samples fast.
            Knob::RelaxationRate => (
                (0.3 / scale.duration_s).min(0.05),
                (0.2 / scale.dt_s).max(1.0),
                true,
            ),
            Knob::Delay => (
                -(2.0 * scale.dt_s).max(0.01),
                longest_delay_s(scale.dt_s),
                false,
            ),
            Knob::ContactShift => (-0.5 * l, 0.5 * l, false),
            Knob::PlasticFraction => (0.0, scale.plastic_max, false),
            Knob::SlipRate => (0.005 * scale.rate_m_per_s, 0.5 * scale.rate_m_per_s, true),
        }
    }

    /// Whether `value` lies within 0.1 % of its search range (on the search's own scale,
    /// logarithmic where [`Knob::range`] says so) from a bound of [`Knob::range`], or
    /// outside it (a start no search step moved), or is not finite: the fit ended where
    /// the search stopped it, not at a minimum of the RSS.
    pub(super) fn at_bound(self, value: f64, scale: &Scales) -> bool {
        self.bound_hit(value, scale).is_some()
    }

    /// Which bound [`Knob::at_bound`] found `value` at (a non-finite value counts as at
    /// the upper one; a value ≤ 0 on a logarithmic range as at the lower one).
    pub(super) fn bound_hit(self, value: f64, scale: &Scales) -> Option<Bound> {
        if !value.is_finite() {
            return Some(Bound::Upper);
        }
        let (lo, hi, log) = self.range(scale);
        let (x, lo, hi) = if log {
            (value.max(f64::MIN_POSITIVE).ln(), lo.ln(), hi.ln())
        } else {
            (value, lo, hi)
        };
        let margin = 1e-3 * (hi - lo);
        if x <= lo + margin {
            Some(Bound::Lower)
        } else if x >= hi - margin {
            Some(Bound::Upper)
        } else {
            None
        }
    }
}

/// A bound of a knob's search range ([`Knob::bound_hit`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Bound {
    /// The lower bound.
    Lower,
    /// The upper bound.
    Upper,
}

/// A reported parameter of a composite model (SI units), named as in the paper where it
/// has a symbol there.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Param {
    /// κ \[N/m\], linear stiffness (eq. 1), or the linear spring under an exponential law.
    Kappa,
    /// k \[N/m^n\], power-law coefficient (eq. 3).
    K,
    /// n, power-law exponent (eq. 3).
    N,
    /// m \[N/m\], initial slope of the exponential law (m/b)(e^{bδ} − 1) (QLV, eqs. 11/13).
    M,
    /// b \[1/m\], stiffening rate of the exponential law.
    B,
    /// λ \[N·s/m\] (eq. 1), or \[N·s/m^(q+1)\] with depth-dependent damping (eq. 3).
    Lambda,
    /// q, depth exponent of the damping λ·δ^q·δ̇ (eq. 3 has q = n).
    Q,
    /// c, fraction of the elastic force that relaxes (QLV eq. 15, a Zener arm).
    RelaxedFraction,
    /// ν \[1/s\], rate of that relaxation mode.
    RatePerS,
    /// The relaxing force already released at the fit window's first sample \[N\], beyond
    /// what a loading from there would have released: a record that begins in contact
    /// begins part-way through the mode's relaxation (its state z is not the fresh
    /// loading's), and the difference decays at ν, Δ·e^{−ν(t − t₀)} (QLV eqs. 9-10, the
    /// homogeneous solution). Fitted only where the window starts in contact.
    InitialRelaxingN,
    /// Probe/tissue mass \[kg\].
    MassKg,
    /// Coulomb friction force magnitude F_c \[N\].
    CoulombN,
    /// Load-cell bias that appears after the first contact \[N\] (somewhere in the free
    /// stretch that follows it: `Prepared::offset_step`).
    ForceOffsetN,
    /// Refinement of the tare \[N\] (part of every model).
    TareN,
    /// Drift of the load cell's zero \[N/s\] (from the record's first sample on).
    ForceDriftNPerS,
    /// Contact position of the later contacts minus the first impact's \[m\].
    ContactShiftM,
    /// Force-channel delay \[s\].
    DelayS,
    /// Plastic-set fraction of the deepest indentation.
    PlasticFraction,
    /// Coulomb slip rate v_s \[m/s\] (F_c·tanh(δ̇/v_s)).
    SlipRateMPerS,
    /// Position of the first impact's contact point on the penetration axis \[m\].
    ContactPositionM,
}

impl Param {
    /// The identifier used in reports, JSON and summaries.
    pub fn id(self) -> &'static str {
        match self {
            Param::Kappa => "kappa",
            Param::K => "k",
            Param::N => "n",
            Param::M => "m",
            Param::B => "b",
            Param::Lambda => "lambda",
            Param::Q => "q",
            Param::RelaxedFraction => "relaxed_fraction",
            Param::RatePerS => "rate_per_s",
            Param::InitialRelaxingN => "initial_relaxing_n",
            Param::MassKg => "mass_kg",
            Param::CoulombN => "coulomb_n",
            Param::ForceOffsetN => "force_offset_n",
            Param::TareN => "tare_n",
            Param::ForceDriftNPerS => "force_drift_n_per_s",
            Param::ContactShiftM => "contact_shift_m",
            Param::DelayS => "delay_s",
            Param::PlasticFraction => "plastic_fraction",
            Param::SlipRateMPerS => "slip_rate_m_per_s",
            Param::ContactPositionM => "contact_position_m",
        }
    }

    /// The parameter a knob's value is reported as (the contact knob is reported as the
    /// absolute [`Param::ContactPositionM`]).
    pub fn of_knob(knob: Knob) -> Param {
        match knob {
            Knob::ContactPosition => Param::ContactPositionM,
            Knob::Exponent => Param::N,
            Knob::StiffeningRate => Param::B,
            Knob::DampingExponent => Param::Q,
            Knob::RelaxationRate => Param::RatePerS,
            Knob::Delay => Param::DelayS,
            Knob::ContactShift => Param::ContactShiftM,
            Knob::PlasticFraction => Param::PlasticFraction,
            Knob::SlipRate => Param::SlipRateMPerS,
        }
    }
}

impl Serialize for Param {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.id())
    }
}

/// What the record determined of a fitted parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Determination {
    /// Fitted inside its search range (its standard error from the joint covariance of
    /// the coefficients and the knobs, a delay's from the RSS's profile, both per
    /// effective sample of a coloured noise).
    Determined,
    /// Held at a bound of its search range (`Knob::at_bound`): the record's optimum may
    /// lie beyond it (an exponent pushed to 3.5, a stiffening rate at 8/δ_max, a contact
    /// at the widest search), and a standard error at a point that is not its minimum
    /// would claim a precision the fit does not have.
    AtSearchBound,
    /// Fitted inside its search range, but its standard error is infinite: the RSS
    /// rises by less than the residual variance σ² from there to a bound of the range on
    /// one side (a delay's profile: a record with no edge or kink that shows it, under a
    /// law it does not trade with), or does not curve up along it at all (a knob's
    /// curvature where the joint covariance is not available). Any value on that side
    /// fits as well.
    Unresolved,
    /// Held at 0 because the record cannot identify it (the baseline's damping λ on a
    /// record that passes each depth at one speed: see the diagnosis's
    /// `not_identifiable`).
    Held,
    /// Only its product with the named parameter is determined: a relaxation mode slower
    /// than the record (ν at its slow bound min(0.3/T, 0.05 /s)) has the column
    /// z − u ≈ −ν·∫u dt, so its
    /// fraction c and rate ν trade at a fixed c·ν (eqs. 5-17 with ν·T ≪ 1).
    ProductOnly(Param),
    /// Only a combination with the named parameter is determined: on a record that never
    /// leaves contact under a linear elastic law, a shift Δ of the contact point changes
    /// the force by the constant κ·Δ, which the tare takes (κ·(δ − Δ) + F0 = κ·δ + (F0 −
    /// κ·Δ)), so the tare and the contact point trade along a line of equal fit.
    CombinationOnly(Param),
    /// Only the damping's combination λ − κ·τ with the named parameter (the delay τ or
    /// the damping λ) is determined: on a record that never leaves contact (or whose
    /// contact edges do not show the delay, [`Nonlinear::delay_as_damping`], or fix it
    /// within fewer than [`DELAY_RESOLVED_T`](super::solver::DELAY_RESOLVED_T) standard
    /// errors of 0: then the standard errors are kept) under a linear
    /// elastic law a delayed force is, to first order, a change of the damping,
    /// κ·δ(t − τ) + λ·δ̇(t − τ) ≈ κ·δ + (λ − κ·τ)·δ̇, and τ and λ part only at second order
    /// (a term (κτ²/2 − λτ)·δ̈ a few thousandths of the force; on an independent
    /// generator's sines the RSS varied by 0.04 % between delays of 2 and 5 ms).
    DampingCombination(Param),
}

/// A fitted parameter: SI value and standard error (NaN where not estimated, 0 for a
/// coefficient held at its physical bound), and whether the record determined it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Estimate {
    /// Which parameter.
    pub param: Param,
    /// Value, SI.
    pub value: f64,
    /// Standard error, SI.
    pub standard_error: f64,
    /// Whether the record determined the value.
    pub determination: Determination,
}

/// The longest force-channel delay the catalogue searches \[s\] on fitting samples
/// `dt_s` apart: 100 ms, or 5 samples where they are longer than 20 ms (the upper bound
/// of [`Knob::Delay`]'s range). (50 ms until 2026-11-29: two independent generators'
/// delays of 53-66 ms were reported at that bound, 11 of them.)
pub fn longest_delay_s(dt_s: f64) -> f64 {
    (5.0 * dt_s).max(0.1)
}

/// Typical magnitudes of a log, for scaling and search bounds.
#[derive(Debug, Clone, Copy)]
pub struct Scales {
    /// Deepest penetration \[m\].
    pub depth_m: f64,
    /// RMS penetration rate in contact \[m/s\].
    pub rate_m_per_s: f64,
    /// Length of the record \[s\].
    pub duration_s: f64,
    /// Sample time of the fitting samples \[s\].
    pub dt_s: f64,
    /// Half-width of the contact position's search range, as a fraction of
    /// [`Scales::depth_m`] ([`CONTACT_SPAN`]; widened by the solver when a fit ends at
    /// its bound).
    pub contact_span: f64,
    /// Upper bound of the plastic set's search range, a fraction of the deepest
    /// indentation ([`PLASTIC_MAX`]; widened by the solver when a fit ends at it on a
    /// record whose [`Scales::observed_set`] exceeds it).
    pub plastic_max: f64,
    /// The set the record's unloading shows without a model (`observed_set`: h_f/h_max),
    /// a fraction of [`Scales::depth_m`]: the plastic set's range is widened past
    /// [`PLASTIC_MAX`] only where it exceeds it.
    pub observed_set: f64,
}

/// Upper bound of the plastic-set fraction searched first: polymers and soft tissue keep
/// a set of a few to a few tens of per cent of the depth, and a narrow range keeps the
/// search's grid fine where they lie. A metal indented by a sharp tip keeps most of it
/// (h_f/h_max ≈ 0.7-0.9 for steel); where the record's own unloading shows a set beyond
/// this bound ([`Scales::observed_set`]), a fit that ends at it continues on
/// [0, [`MAX_PLASTIC_FRACTION`]].
pub const PLASTIC_MAX: f64 = 0.4;

/// Largest plastic-set fraction searched: a set equal to the whole depth leaves no
/// elastic recovery to fit.
pub const MAX_PLASTIC_FRACTION: f64 = 0.95;

/// Half-width of the contact position's search range around the detector's point, as a
/// fraction of the deepest penetration: the detector's threshold point is usually within
/// a few per cent of the depth, and a narrow range keeps the contact from trading against
/// the other knobs.
pub const CONTACT_SPAN: f64 = 0.2;

impl Scales {
    /// From the prepared log.
    pub fn of(data: &Prepared) -> Self {
        let depth = data
            .depth_m
            .iter()
            .copied()
            .fold(0.0f64, f64::max)
            .max(1e-12);
        let (mut s, mut n) = (0.0, 0usize);
        for (c, v) in data.contact.iter().zip(&data.rate_m_per_s) {
            if *c {
                s += v * v;
                n += 1;
            }
        }
        let rate = if n > 0 { (s / n as f64).sqrt() } else { depth };
        Scales {
            depth_m: depth,
            rate_m_per_s: rate.max(1e-12),
            duration_s: (data.len() as f64 * data.dt).max(data.dt),
            dt_s: data.dt,
            contact_span: CONTACT_SPAN,
            plastic_max: PLASTIC_MAX,
            observed_set: observed_set(data, depth),
        }
    }
}

/// The set the record's own unloading shows, as a fraction of the deepest penetration
/// `deepest_m`: after the deepest point, the depth at which the force first falls below
/// 5 % of its peak (0 where the record never unloads that far). A nanoindentation's
/// h_f/h_max, read without a model. (A damped material released as fast as it was
/// pressed shows a force-free depth too: a Hunt-Crossley ramp-and-hold of the structures
/// sweep, seed 3004, whose damping carries half the peak force, drops to 5 % at 0.93 of
/// its depth.)
fn observed_set(data: &Prepared, deepest_m: f64) -> f64 {
    let Some(at) = (0..data.len()).max_by(|a, b| data.depth_m[*a].total_cmp(&data.depth_m[*b]))
    else {
        return 0.0;
    };
    let peak = data.force_n.iter().copied().fold(0.0f64, f64::max);
    (at..data.len())
        .find(|&i| data.force_n[i] < 0.05 * peak)
        .map_or(0.0, |i| (data.depth_m[i] / deepest_m).clamp(0.0, 1.0))
}

/// Values of the nonlinear parameters.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Nonlinear {
    /// Contact position refinement \[m\] (added to the detector's first-impact point).
    pub contact_m: f64,
    /// Power-law exponent n.
    pub n: f64,
    /// Exponential stiffening rate b \[1/m\].
    pub b: f64,
    /// Damping exponent q.
    pub q: f64,
    /// Relaxation rate ν \[1/s\].
    pub nu: f64,
    /// Force-channel delay \[s\].
    pub delay_s: f64,
    /// Contact position of the later contacts minus the first impact's \[m\].
    pub contact_shift_m: f64,
    /// Plastic-set fraction p of the deepest indentation.
    pub plastic: f64,
    /// Coulomb slip rate v_s \[m/s\].
    pub slip_m_per_s: f64,
    /// Whether the exponential law keeps the baseline's linear spring
    /// (κδ + m(e^{bδ} − 1)/b) or replaces it (m(e^{bδ} − 1)/b): a structural choice, not
    /// searched; the workflow fits both and keeps the better by BIC.
    pub linear_spring: bool,
    /// Whether the delay was named from the lag of the force in contact alone (the
    /// current model's damping held at its bound 0, the contact edges not showing the
    /// delay): then, as on a record that never leaves contact, only the damping's
    /// combination λ − κ·τ is determined ([`Determination::DampingCombination`]). A
    /// property of how the record showed the delay, carried by every later fit; not searched.
    #[serde(default)]
    pub delay_as_damping: bool,
}

impl Default for Nonlinear {
    fn default() -> Self {
        Nonlinear {
            contact_m: 0.0,
            n: 1.0,
            b: 1.0,
            q: 0.0,
            nu: 1.0,
            delay_s: 0.0,
            contact_shift_m: 0.0,
            plastic: 0.0,
            slip_m_per_s: 1e-3,
            linear_spring: false,
            delay_as_damping: false,
        }
    }
}

impl Nonlinear {
    /// The value of a knob.
    pub fn get(&self, k: Knob) -> f64 {
        match k {
            Knob::ContactPosition => self.contact_m,
            Knob::Exponent => self.n,
            Knob::StiffeningRate => self.b,
            Knob::DampingExponent => self.q,
            Knob::RelaxationRate => self.nu,
            Knob::Delay => self.delay_s,
            Knob::ContactShift => self.contact_shift_m,
            Knob::PlasticFraction => self.plastic,
            Knob::SlipRate => self.slip_m_per_s,
        }
    }

    pub(super) fn set(&mut self, k: Knob, v: f64) {
        match k {
            Knob::ContactPosition => self.contact_m = v,
            Knob::Exponent => self.n = v,
            Knob::StiffeningRate => self.b = v,
            Knob::DampingExponent => self.q = v,
            Knob::RelaxationRate => self.nu = v,
            Knob::Delay => self.delay_s = v,
            Knob::ContactShift => self.contact_shift_m = v,
            Knob::PlasticFraction => self.plastic = v,
            Knob::SlipRate => self.slip_m_per_s = v,
        }
    }
}

/// The nonlinear parameters of a model: the contact position, then its effects' knobs.
pub fn knobs_of(effects: &BTreeSet<Effect>) -> Vec<Knob> {
    std::iter::once(Knob::ContactPosition)
        .chain(effects.iter().filter_map(|e| e.knob()))
        .collect()
}
