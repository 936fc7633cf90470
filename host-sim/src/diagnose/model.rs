//! Composite contact models for the discrepancy workflow: a Kelvin-Voigt baseline plus
//! named physical effects, each the core's own model piece (Hunt-Crossley power-law
//! elasticity and depth-dependent damping, the QLV exponential elastic response and its
//! relaxation modes) or a measurement/mechanical effect. Fitted in batch by variable
//! projection: for given nonlinear parameters (exponent, rate, delay, shift…) the force is
//! linear in its coefficients (ordinary least squares); the nonlinear parameters are found
//! by a bounded one-dimensional search each.

use std::collections::BTreeSet;

use estimator_core::laws;
use nalgebra::{DMatrix, DVector};
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
    pub const ALL: [Effect; 10] = [
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
        }
    }

    /// Which of two effects the record cannot tell apart is named: the one that needs
    /// less of the motion (0 elastic laws: depth alone; 1 offsets and set: a contact;
    /// 2 relaxation: time under load; 3 rate effects: a speed that varies).
    pub fn precedence(self) -> u8 {
        match self {
            Effect::PowerLawStiffness | Effect::ExponentialStiffness => 0,
            Effect::ForceOffset | Effect::ContactPointOffset | Effect::PlasticSet => 1,
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
            Effect::ForceOffset | Effect::Inertia => None,
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
    /// Search bounds in the knob's units and whether to search on a log scale.
    fn range(self, scale: &Scales) -> (f64, f64, bool) {
        let l = scale.depth_m;
        match self {
            Knob::ContactPosition => (-0.2 * l, 0.2 * l, false),
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
                (5.0 * scale.dt_s).max(0.05),
                false,
            ),
            Knob::ContactShift => (-0.25 * l, 0.25 * l, false),
            Knob::PlasticFraction => (0.0, 0.4, false),
            Knob::SlipRate => (0.005 * scale.rate_m_per_s, 0.5 * scale.rate_m_per_s, true),
        }
    }
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
    /// Probe/tissue mass \[kg\].
    MassKg,
    /// Coulomb friction force magnitude F_c \[N\].
    CoulombN,
    /// Load-cell bias that appears after the first contact \[N\].
    ForceOffsetN,
    /// Refinement of the tare \[N\] (part of every model).
    TareN,
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
            Param::MassKg => "mass_kg",
            Param::CoulombN => "coulomb_n",
            Param::ForceOffsetN => "force_offset_n",
            Param::TareN => "tare_n",
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

/// A fitted parameter: SI value and standard error (NaN where not estimated, 0 for a
/// coefficient held at its physical bound).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Estimate {
    /// Which parameter.
    pub param: Param,
    /// Value, SI.
    pub value: f64,
    /// Standard error, SI.
    pub standard_error: f64,
}

/// A regression column of the composite model: its coefficient is solved by least
/// squares for given [`Nonlinear`] values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Column {
    /// The elastic law (κδ, or L·(δ/L)ⁿ, or (e^{bδ} − 1)/b), coefficient κ, k·L^(n−1) or m.
    Elastic,
    /// The damping δ̇ (or L^q·(δ/L)^q·δ̇), coefficient λ or λ·L^q.
    Damping,
    /// The linear spring κδ under an exponential law.
    LinearSpring,
    /// The relaxing part of the elastic column (a first-order low-pass of it, negated).
    Relaxing,
    /// δ̈, coefficient the mass.
    Inertia,
    /// tanh(δ̇/v_s), coefficient F_c.
    Coulomb,
    /// 1, coefficient the tare refinement.
    Tare,
    /// 1 after the first contact, coefficient the later load-cell bias.
    ForceOffset,
}

impl Column {
    /// Whether the coefficient is non-negative physically: the elastic and the damping
    /// coefficient of a passive material (κ, k, m ≥ 0 and λ ≥ 0 at every step, the
    /// baseline included), a mass and a friction force's magnitude.
    fn non_negative(self) -> bool {
        matches!(
            self,
            Column::Elastic
                | Column::Damping
                | Column::LinearSpring
                | Column::Inertia
                | Column::Coulomb
        )
    }
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
}

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
        }
    }
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

    fn set(&mut self, k: Knob, v: f64) {
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

/// Columns of the regression, named.
struct Design {
    names: Vec<Column>,
    /// Column-major values over the fit window.
    columns: Vec<Vec<f64>>,
    /// Material force columns (gated by contact), as opposed to the offset.
    material: Vec<bool>,
    /// Contact gate per sample.
    gate: Vec<bool>,
}

impl Design {
    /// Σ β_j·column_j at sample `i` over the material columns (`material`) or the
    /// others.
    fn sum_at(&self, beta: &[f64], i: usize, material: bool) -> f64 {
        self.columns
            .iter()
            .zip(beta)
            .zip(&self.material)
            .filter(|(_, m)| **m == material)
            .map(|((c, b), _)| c[i] * b)
            .sum()
    }
}

/// Linear interpolation of `v` at fractional index `x`.
fn interp(v: &[f64], x: f64) -> f64 {
    if x <= 0.0 {
        return v[0];
    }
    // x > 0 here: truncation is the floor (`f64::floor` is a libm call on x86-64 without
    // SSE4.1, and this runs per raw sample of a block at a contact's edge).
    let i = x as usize;
    if i + 1 >= v.len() {
        return v[v.len() - 1];
    }
    let f = x - i as f64;
    v[i] * (1.0 - f) + v[i + 1] * f
}

fn design(
    data: &Prepared,
    start: usize,
    effects: &BTreeSet<Effect>,
    nl: &Nonlinear,
    scale: &Scales,
) -> Design {
    let n = data.len() - start;
    // (Looked up per sample: a table, not the set.)
    let present: [bool; Effect::ALL.len()] = Effect::ALL.map(|e| effects.contains(&e));
    let has = |e: Effect| present[e as usize];
    let shift = if has(Effect::TimeDelay) {
        nl.delay_s / data.dt
    } else {
        0.0
    };
    // Delayed motion: block averages of the raw depth over a window shifted by the delay
    // (exact for the linearly interpolated raw signal, from prefix sums), and their
    // differences; the undelayed signals are the prepared ones.
    let delayed: Option<[Vec<f64>; 3]> = (shift != 0.0).then(|| {
        let b = data.block as f64;
        let avg = |k: isize| data.raw_block_mean(k as f64 * b - shift * b);
        let dt = data.dt;
        let mut dd = Vec::with_capacity(n);
        let mut vv = Vec::with_capacity(n);
        let mut aa = Vec::with_capacity(n);
        for i in 0..n {
            let k = (start + i) as isize;
            let (m0, m1, p1) = (avg(k - 1), avg(k), avg(k + 1));
            dd.push(m1);
            vv.push((p1 - m0) / (2.0 * dt));
            aa.push((p1 - 2.0 * m1 + m0) / (dt * dt));
        }
        [dd, vv, aa]
    });
    let series = |which: usize, i: usize| match &delayed {
        Some(d) => d[which][i],
        None => [&data.depth_m, &data.rate_m_per_s, &data.accel_m_per_s2][which][start + i],
    };
    let l = scale.depth_m;
    let v0 = nl.slip_m_per_s;
    let coulomb_on = has(Effect::CoulombFriction);
    let mut deepest = f64::NEG_INFINITY;
    let mut gate = Vec::with_capacity(n);
    let (mut elastic, mut damping, mut inertia, mut coulomb, mut linear) = (
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::new(),
        Vec::new(),
        Vec::new(),
    );
    // Material terms of one instant: (in contact, elastic, damping, Coulomb) for the
    // depth δ_e below the (shifted, plastically set) contact point and rate v.
    let terms = |de: f64, v: f64| -> (f64, f64, f64, f64, f64) {
        if de <= 0.0 {
            return (0.0, 0.0, 0.0, 0.0, 0.0);
        }
        // The core's laws (estimator_core::laws), on δ scaled by the deepest
        // penetration L for conditioning: L·(δ/L)ⁿ and (e^{bδ} − 1)/b.
        // (ln(δ/L) once for both power laws: the same e^{n·ln x} as laws::power_law.)
        let x = de / l;
        let ln_x = if has(Effect::PowerLawStiffness) || has(Effect::DepthDependentDamping) {
            laws::ln_depth(x)
        } else {
            None
        };
        let e = if has(Effect::PowerLawStiffness) {
            laws::power_law_of_ln(ln_x, nl.n) * l
        } else if has(Effect::ExponentialStiffness) {
            laws::exponential_law(de, nl.b)
        } else {
            de
        };
        let dv = if has(Effect::DepthDependentDamping) {
            laws::power_law_of_ln(ln_x, nl.q) * v
        } else {
            v
        };
        (
            1.0,
            e,
            dv,
            if coulomb_on { (v / v0).tanh() } else { 0.0 },
            de,
        )
    };
    let block = data.block;
    let half = (block as f64 - 1.0) / 2.0;
    // Block means of the laws over a block of B > 1 raw samples in contact, from the
    // quadratic δ(u) = δ̄ + δ̇·u·T/B + ½δ̈·(u² − σ²)·(T/B)² through the block means (u the
    // raw sample's offset from the block's centre, σ² = (B² − 1)/12 its variance over the
    // block, δ̄, δ̇ and δ̈ the prepared depth, rate and acceleration): a curved law averaged
    // over a 16 ms block of a 2 Hz tap differs from its value at δ̄ by about the noise of
    // a block, a systematic error the fit would otherwise name inertia or a delay.
    // - elastic: the two-point rule at u = ±σ, where δ = δ̄ ± σ·δ̇·T/B (exact for a law
    //   quadratic in u; the linear spring's mean is δ̄ itself);
    // - damping: the mean of g(δ)·δ̇ is the increment of the antiderivative of g across the
    //   block, u = ±B/2, divided by T: δ̇ itself for λ·δ̇, L·Δ(δ/L)^{q+1}/((q + 1)·T) for
    //   λ·δ^q·δ̇ (q ≥ 0.1).
    let spread = ((block * block) as f64 - 1.0).max(0.0).sqrt() / 12f64.sqrt();
    let per_sample = data.dt / block as f64;
    let elastic_law = |de: f64| -> f64 {
        if has(Effect::PowerLawStiffness) {
            laws::power_law_of_ln(laws::ln_depth(de / l), nl.n) * l
        } else if has(Effect::ExponentialStiffness) {
            laws::exponential_law(de, nl.b)
        } else {
            de
        }
    };
    let curvature = (2.0 * (block * block) as f64 + 1.0) / 24.0 * per_sample * per_sample;
    // (elastic, damping) block means at mean depth δ̄ > 0, rate δ̇ and acceleration δ̈.
    // Where the spread s = σ·δ̇·T/B, the half-increment h = δ̇·T/2 and the shift
    // c = δ̈·(2B² + 1)/24·(T/B)² of the middle are below a tenth of δ̄ (and b·s below a
    // tenth), by the rules' Taylor series about δ̄, from one ln δ̄: f + ½f''·s² for the
    // elastic law (f'' = n(n − 1)·f/δ̄², b·(b·f + 1)), δ̇·g(δ̄ + c)·(1 + q(q − 1)·h²/(6(δ̄ + c)²))
    // for the damping; the next terms are ~(s/δ̄)⁴, below 10⁻⁵ of the law. Elsewhere (the
    // first blocks of a contact) by the rules themselves.
    let block_means = |mean: f64, rate: f64, accel: f64| -> (f64, f64) {
        let s = spread * rate * per_sample;
        let h = 0.5 * rate * data.dt;
        let c = accel * curvature;
        let small = |x: f64| x * x < 1e-2 * mean * mean;
        let ln_x = if has(Effect::PowerLawStiffness) || has(Effect::DepthDependentDamping) {
            laws::ln_depth(mean / l)
        } else {
            None
        };
        let elastic = if has(Effect::PowerLawStiffness) {
            if small(s) {
                let f = laws::power_law_of_ln(ln_x, nl.n) * l;
                f * (1.0 + 0.5 * nl.n * (nl.n - 1.0) * (s / mean) * (s / mean))
            } else {
                0.5 * (elastic_law(mean - s) + elastic_law(mean + s))
            }
        } else if has(Effect::ExponentialStiffness) {
            if small(s) && (nl.b * s) * (nl.b * s) < 1e-2 {
                let f = laws::exponential_law(mean, nl.b);
                f + 0.5 * nl.b * (nl.b * f + 1.0) * s * s
            } else {
                0.5 * (elastic_law(mean - s) + elastic_law(mean + s))
            }
        } else {
            mean
        };
        let damping = if has(Effect::DepthDependentDamping) {
            let q = nl.q;
            let middle = mean + c;
            if small(h) && small(c) {
                // ln(δ̄ + c) = ln δ̄ + ln(1 + c/δ̄), the latter to third order (|c/δ̄| < 0.1).
                let r = c / mean;
                let ln_middle = ln_x.map(|x| x + r - 0.5 * r * r + r * r * r / 3.0);
                let g = laws::power_law_of_ln(ln_middle, q);
                rate * g * (1.0 + q * (q - 1.0) * (h / middle) * (h / middle) / 6.0)
            } else {
                let q1 = q + 1.0;
                let integral = |d: f64| laws::power_law_of_ln(laws::ln_depth(d / l), q1) * l / q1;
                (integral(middle + h) - integral(middle - h)) / data.dt
            }
        } else {
            rate
        };
        (elastic, damping)
    };
    for i in 0..n {
        // δ from the refined first-impact point; later contacts from the shifted one.
        // (The knob moves the first contact's point, so that the shared refinement
        // follows the later contacts, which hold most of the record.)
        let mut reference = nl.contact_m;
        if has(Effect::ContactPointOffset) && start + i < data.first_contact_end {
            reference -= nl.contact_shift_m;
        }
        let d = series(0, i) - reference;
        let v = series(1, i);
        deepest = deepest.max(d);
        if has(Effect::PlasticSet) {
            reference += nl.plastic * deepest.max(0.0);
        }
        // A block in which the contact begins or ends is averaged sample by sample (the
        // damping step at impact and the onset shape do not average linearly).
        let b = if shift == 0.0 {
            start + i
        } else {
            // (⌊x⌋ clamped at 0: `as` saturates negatives to 0 and truncates the rest.)
            ((start + i) as f64 - shift) as usize
        };
        let (lo, hi) = (
            data.block_min_depth_m[b.min(data.len() - 1)],
            data.block_max_depth_m[(b + 1).min(data.len() - 1)],
        );
        let (lo, hi) = (
            lo.min(data.block_min_depth_m[(b + 1).min(data.len() - 1)]),
            hi.max(data.block_max_depth_m[b.min(data.len() - 1)]),
        );
        // So is a block in which the motion reverses when Coulomb friction is modelled.
        let reverses = has(Effect::CoulombFriction) && {
            let (a, b) = (
                series(1, i.saturating_sub(1)),
                series(1, (i + 1).min(n - 1)),
            );
            a * v <= 0.0 || b * v <= 0.0
        };
        let (g, e, dv, c, de) = if block > 1 && ((lo < reference && hi > reference) || reverses) {
            let mut sum = (0.0, 0.0, 0.0, 0.0, 0.0);
            for j in 0..block {
                let raw = ((start + i) * block + j) as f64 - shift * block as f64;
                let dj = interp(&data.raw_depth_m, raw) - reference;
                let vj = interp(&data.rate_m_per_s, (raw - half) / block as f64);
                let t = terms(dj, vj);
                sum = (
                    sum.0 + t.0,
                    sum.1 + t.1,
                    sum.2 + t.2,
                    sum.3 + t.3,
                    sum.4 + t.4,
                );
            }
            let k = block as f64;
            (sum.0 / k, sum.1 / k, sum.2 / k, sum.3 / k, sum.4 / k)
        } else if block > 1 {
            // A block inside or outside contact: the mean of the laws over its raw samples
            // (see `block_means`), not their value at the block's mean depth.
            let de = series(0, i) - reference;
            if de <= 0.0 {
                terms(de, v)
            } else {
                let (e, dv) = block_means(de, v, series(2, i));
                (
                    1.0,
                    e,
                    dv,
                    if coulomb_on { (v / v0).tanh() } else { 0.0 },
                    de,
                )
            }
        } else {
            let de = series(0, i) - reference;
            terms(de, v)
        };
        gate.push(g > 0.0);
        elastic.push(e);
        if has(Effect::ExponentialStiffness) && nl.linear_spring {
            linear.push(de);
        }
        damping.push(if data.hold_damping { 0.0 } else { dv });
        if has(Effect::Inertia) {
            inertia.push(g * series(2, i));
        }
        if has(Effect::CoulombFriction) {
            coulomb.push(c);
        }
    }
    let mut names = vec![Column::Elastic, Column::Damping];
    let mut columns = vec![elastic, damping];
    let mut material = vec![true, true];
    if has(Effect::ExponentialStiffness) && nl.linear_spring {
        // The exponential law on the baseline's linear spring (κδ + m(e^{bδ} − 1)/b):
        // alone, its initial slope m is tied to its curvature, and a material that starts
        // nearly linear and then stiffens (a compressed silicone: log-log slope 1.1 →
        // 2.3) is fitted by moving the contact point. Where the exponential alone fits,
        // the extra column trades against the contact point and the search can end in a
        // worse optimum; hence both variants are fitted (`Nonlinear::linear_spring`).
        names.push(Column::LinearSpring);
        columns.push(linear);
        material.push(true);
    }
    if has(Effect::Relaxation) {
        let alpha = -(-nl.nu * data.dt).exp_m1();
        let mut y = 0.0;
        let lp: Vec<f64> = columns[0]
            .iter()
            .zip(&gate)
            .map(|(u, g)| {
                y += alpha * (u - y);
                if *g {
                    -y
                } else {
                    0.0
                }
            })
            .collect();
        names.push(Column::Relaxing);
        columns.push(lp);
        material.push(true);
    }
    if has(Effect::Inertia) {
        names.push(Column::Inertia);
        columns.push(inertia);
        material.push(true);
    }
    if has(Effect::CoulombFriction) {
        names.push(Column::Coulomb);
        columns.push(coulomb);
        material.push(true);
    }
    // The tare refined (part of every model): the detector's tare averages a few
    // hundred free-space samples, an error the fit over thousands would otherwise
    // blame on an effect.
    names.push(Column::Tare);
    columns.push(vec![if data.hold_tare { 0.0 } else { 1.0 }; n]);
    material.push(false);
    if has(Effect::ForceOffset) {
        // A bias the tare before the first impact missed appeared after it: a zero
        // shift of the load cell after its first load.
        names.push(Column::ForceOffset);
        columns.push(
            (start..data.len())
                .map(|b| {
                    if b >= data.first_contact_end {
                        1.0
                    } else {
                        0.0
                    }
                })
                .collect(),
        );
        material.push(false);
    }
    Design {
        names,
        columns,
        material,
        gate,
    }
}

/// Result of one least-squares solve.
struct Solve {
    beta: Vec<f64>,
    covariance: DMatrix<f64>,
    rss: f64,
}

/// Most regression columns of any model.
const MAX_COLUMNS: usize = 8;

/// Least squares on columns scaled to unit RMS (normal equations, Cholesky with a tiny
/// ridge for rank-deficient columns such as an all-zero effect), with the
/// [`Column::non_negative`] coefficients held at 0 where the unconstrained solution makes them
/// negative (an active set: the most negative is held and the rest re-solved, until none
/// is negative; a held coefficient has standard error 0). Rows where `train` is false are
/// left out; the material columns are weighted by `touch` (0 where the probe has left the
/// surface; all 1 when empty).
fn least_squares(
    design: &Design,
    y: &[f64],
    train: Option<&[bool]>,
    touch: &[f64],
) -> Option<Solve> {
    let columns = &design.columns;
    let p = columns.len();
    assert!(p <= MAX_COLUMNS, "at most {MAX_COLUMNS} regression columns");
    // Row weights: 0 for rows left out, the touch weight on the material columns. The
    // weighted columns are formed once, and the normal equations are dot products of
    // contiguous columns.
    let n = y.len();
    let kept = |i: usize| train.is_none_or(|t| t[i]);
    let weighted: Vec<Vec<f64>> = columns
        .iter()
        .zip(&design.material)
        .map(|(c, &material)| {
            (0..n)
                .map(|i| {
                    if !kept(i) {
                        0.0
                    } else if material {
                        touch.get(i).copied().unwrap_or(1.0) * c[i]
                    } else {
                        c[i]
                    }
                })
                .collect()
        })
        .collect();
    // (Four partial sums: independent chains the compiler can keep in vector lanes.)
    let dot = |x: &[f64], z: &[f64]| {
        let mut acc = [0.0f64; 4];
        let (xc, zc) = (x.chunks_exact(4), z.chunks_exact(4));
        let tail: f64 = xc
            .remainder()
            .iter()
            .zip(zc.remainder())
            .map(|(a, b)| a * b)
            .sum();
        for (xs, zs) in xc.zip(zc) {
            for l in 0..4 {
                acc[l] += xs[l] * zs[l];
            }
        }
        (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
    };
    let mut a = [[0.0f64; MAX_COLUMNS]; MAX_COLUMNS];
    let mut b = [0.0f64; MAX_COLUMNS];
    for j in 0..p {
        b[j] = dot(&weighted[j], y);
        for k in j..p {
            a[j][k] = dot(&weighted[j], &weighted[k]);
        }
    }
    let yy: f64 = (0..n).filter(|&i| kept(i)).map(|i| y[i] * y[i]).sum();
    // Scale the columns to unit norm (conditioning), from the diagonal.
    let scales: Vec<f64> = (0..p)
        .map(|j| if a[j][j] > 0.0 { a[j][j].sqrt() } else { 1.0 })
        .collect();
    // An all-zero column (a term held at 0, an effect with no support) is held.
    let mut held = [false; MAX_COLUMNS];
    for (j, h) in held.iter_mut().enumerate().take(p) {
        *h = a[j][j] <= 0.0;
    }
    loop {
        let free = |j: usize| !held[j];
        let a = DMatrix::from_fn(p, p, |j, k| {
            if !free(j) || !free(k) {
                return if j == k { 1.0 } else { 0.0 };
            }
            let v = if j <= k { a[j][k] } else { a[k][j] };
            v / (scales[j] * scales[k]) + if j == k { 1e-10 } else { 0.0 }
        });
        let b = DVector::from_fn(p, |j, _| if free(j) { b[j] / scales[j] } else { 0.0 });
        let chol = a.clone().cholesky()?;
        let x = chol.solve(&b);
        let negative = (0..p)
            .filter(|&j| free(j) && design.names[j].non_negative() && x[j] < 0.0)
            .min_by(|&i, &j| x[i].total_cmp(&x[j]));
        if let Some(j) = negative {
            held[j] = true;
            continue;
        }
        let rss = (yy - 2.0 * x.dot(&b) + x.dot(&(&a * &x))).max(0.0);
        let inv = chol.inverse();
        let beta: Vec<f64> = (0..p).map(|j| x[j] / scales[j]).collect();
        let covariance = DMatrix::from_fn(p, p, |j, k| {
            if free(j) && free(k) {
                inv[(j, k)] / (scales[j] * scales[k])
            } else {
                0.0
            }
        });
        return Some(Solve {
            beta,
            covariance,
            rss,
        });
    }
}

/// A fitted model.
#[derive(Debug, Clone, Serialize)]
pub struct Fit {
    /// Effects on top of the Kelvin-Voigt baseline.
    pub effects: Vec<Effect>,
    /// Nonlinear parameters.
    #[serde(skip)]
    pub nonlinear: Nonlinear,
    /// Parameters, SI, in the report's order.
    pub parameters: Vec<Estimate>,
    /// Residual sum of squares \[N²\] over the fit window.
    pub rss: f64,
    /// Samples in the fit window.
    pub samples: usize,
    /// NRMSE \[%\] of the fit (range-normalised).
    pub nrmse_percent: f64,
    /// Variance accounted for \[%\].
    pub vaf_percent: f64,
    /// Bayesian information criterion with every sample counted (the workflow's
    /// decisions use [`crate::diagnose::delta_bic`], which counts effective samples).
    pub bic: f64,
    /// Free parameters: regression coefficients plus nonlinear knobs.
    pub free_parameters: usize,
    /// Blocked cross-validation RMSE \[N\] per fold.
    pub cv_rmse_per_fold: Vec<f64>,
    /// Their mean \[N\].
    pub cv_rmse: f64,
    /// Model force over the fit window \[N\].
    #[serde(skip)]
    pub prediction: Vec<f64>,
    /// First sample of the fit window.
    #[serde(skip)]
    pub start: usize,
}

impl Fit {
    /// Residual (measured − model) over the fit window.
    pub fn residual(&self, data: &Prepared) -> Vec<f64> {
        data.force_n[self.start..]
            .iter()
            .zip(&self.prediction)
            .map(|(m, p)| m - p)
            .collect()
    }

    /// A parameter's value, if the model has it.
    pub fn parameter(&self, param: Param) -> Option<f64> {
        self.parameters
            .iter()
            .find(|p| p.param == param)
            .map(|p| p.value)
    }

    /// The model's instantaneous elastic force F_e(δ) \[N\] at depth `depth_m` \[m\]
    /// from the contact point: κ·δ (eq. 1), k·δⁿ (eq. 3) or κδ + m(e^{bδ} − 1)/b (QLV, eqs.
    /// 11/13), by the core's laws; 0 for δ ≤ 0. With relaxation this is the
    /// instantaneous law; the relaxed one is (1 − c) times it.
    pub fn elastic_force_n(&self, depth_m: f64) -> f64 {
        let p = |param: Param| self.parameter(param).unwrap_or(0.0);
        if self.effects.contains(&Effect::PowerLawStiffness) {
            p(Param::K) * laws::power_law(depth_m, p(Param::N))
        } else if self.effects.contains(&Effect::ExponentialStiffness) {
            p(Param::Kappa) * depth_m.max(0.0)
                + p(Param::M) * laws::exponential_law(depth_m, p(Param::B))
        } else {
            p(Param::Kappa) * depth_m.max(0.0)
        }
    }
}

/// Number of blocked cross-validation folds.
pub const FOLDS: usize = 5;

/// Evaluates one model with fixed nonlinear parameters. A unilateral contact cannot
/// pull: where the material terms sum below zero the probe has left the surface and the
/// force is zero (the generator and the core's QLV clip the same way). The clipped set is
/// found by iteration, starting from the samples whose measured force is within 3 noise
/// levels of zero, then re-derived from the model's own unclipped prediction each time.
/// Returns (RSS, design with the clipped rows zeroed, solve, clipped mask).
fn evaluate(
    data: &Prepared,
    start: usize,
    effects: &BTreeSet<Effect>,
    nl: &Nonlinear,
    scale: &Scales,
    iterations: usize,
    warm: Option<&[f64]>,
) -> Option<(f64, Design, Solve, Vec<f64>)> {
    let n = data.len() - start;
    let y = &data.force_n[start..];
    let full = design(data, start, effects, nl, scale);
    // The iteration starts with the samples within 3 noise levels of zero separated, the
    // noise that of a block mean of independent 1 kHz samples (exactly so when the block
    // is a whole number of measurements; for a resampled log lower
    // than a block's own, `noise_n`: on the AFM relaxation file that higher start leaves
    // the relaxation search in a worse basin, 2.24 % instead of 2.04 %).
    let touch_start = 3.0 * data.noise_n / (data.measurement_samples.max(1) as f64).sqrt();
    // Weight of the material terms per sample: 1 in touch, 0 separated, between for a
    // sample in which the probe leaves the surface.
    let mut touch: Vec<f64> = match warm {
        Some(w) if w.len() == n => w.to_vec(),
        _ => (0..n)
            .map(|i| {
                if full.gate[i] && y[i] < touch_start {
                    0.0
                } else {
                    1.0
                }
            })
            .collect(),
    };
    let block = data.block.max(1);
    let mut result = None;
    for _ in 0..iterations.max(1) {
        let s = least_squares(&full, y, None, &touch)?;
        let m: Vec<f64> = (0..n).map(|i| full.sum_at(&s.beta, i, true)).collect();
        let next: Vec<f64> = (0..n).map(|i| touch_weight(&full, &m, i, block)).collect();
        let done = next.iter().zip(&touch).all(|(a, b)| (a - b).abs() < 1e-3);
        result = Some((s.rss, s, touch));
        touch = next;
        if done {
            break;
        }
    }
    // (Returned: the weights the next evaluation nearby should start from.)
    result.map(|(rss, s, used)| (rss, mask_rows(full, &used), s, touch))
}

/// The force \[N\] of a model with given coefficients over the record from
/// [`Prepared::fit_start`] on (the same samples as a [`Fit`]'s prediction): the design
/// [`fit`] regresses on, each column times `coefficient(column)` (the regression's own
/// columns and scaling: see [`crate::diagnose::spec`] for the SI conversion), with
/// the unilateral clipping of [`fit`]'s evaluation (material force only where the
/// material terms push). The record's damping and tare holds do not apply: the
/// coefficients are given.
pub fn predict(
    data: &Prepared,
    effects: &BTreeSet<Effect>,
    nl: &Nonlinear,
    coefficient: impl Fn(Column) -> f64,
) -> Vec<f64> {
    let start = data.fit_start();
    let scale = Scales::of(data);
    let mut free = data.clone();
    free.hold_damping = false;
    free.hold_tare = false;
    let full = design(&free, start, effects, nl, &scale);
    let n = data.len() - start;
    let beta: Vec<f64> = full.names.iter().map(|c| coefficient(*c)).collect();
    let m: Vec<f64> = (0..n).map(|i| full.sum_at(&beta, i, true)).collect();
    let block = data.block.max(1);
    (0..n)
        .map(|i| touch_weight(&full, &m, i, block) * m[i] + full.sum_at(&beta, i, false))
        .collect()
}

/// Weight of the material terms at sample `i` given their unclipped sum `m`: 1 out of
/// contact (the terms are 0 there), 0 where they pull, and in between for a sample in
/// which they change sign (the mean of max(0, m) over the sample's `block` raw samples,
/// m linear through the neighbours, over m).
fn touch_weight(design: &Design, m: &[f64], i: usize, block: usize) -> f64 {
    if !design.gate[i] {
        return 1.0;
    }
    if m[i] <= 0.0 {
        return 0.0;
    }
    let n = m.len();
    let slope = 0.5 * (m[(i + 1).min(n - 1)] - m[i.saturating_sub(1)]);
    if m[i] >= 0.5 * slope.abs() {
        // Positive over the whole sample: the mean of the line is its middle, m.
        return 1.0;
    }
    let mean: f64 = (0..block)
        .map(|j| (m[i] + ((j as f64 + 0.5) / block as f64 - 0.5) * slope).max(0.0))
        .sum::<f64>()
        / block as f64;
    (mean / m[i]).clamp(0.0, 1.0)
}

/// The design with the material columns weighted by `touch`.
fn mask_rows(full: Design, touch: &[f64]) -> Design {
    let mut columns = full.columns;
    for (c, m) in columns.iter_mut().zip(&full.material) {
        if *m {
            for (v, w) in c.iter_mut().zip(touch) {
                *v *= w;
            }
        }
    }
    Design {
        names: full.names,
        columns,
        material: full.material,
        gate: full.gate,
    }
}

/// How hard [`fit`] searches.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Effort {
    /// Intervals of the grid over a new knob's range (grid + 1 points; 0: no grid, the
    /// golden section brackets the initial value by ± `bracket`).
    pub grid: usize,
    /// Half-width of the golden-section bracket without a grid, as a fraction of the
    /// knob's range.
    pub bracket: f64,
    /// Golden-section iterations around the best grid point (the bracket shrinks by
    /// 0.618 each).
    pub golden: usize,
    /// Gauss-Newton iterations re-fitting the contact position at each point.
    pub contact_iterations: usize,
    /// On the grid, re-fit the contact from the detector's point too (not only from the
    /// current model's).
    pub both_starts: bool,
    /// Levenberg-Marquardt iterations on all knobs at the end.
    pub iterations: usize,
    /// Standard errors of the nonlinear parameters (3 evaluations each; NaN when off).
    pub uncertainties: bool,
}

impl Effort {
    /// A screening fit: enough to rank candidates.
    pub const QUICK: Effort = Effort {
        grid: 8,
        bracket: 0.0,
        golden: 0,
        contact_iterations: 1,
        both_starts: true,
        iterations: 8,
        uncertainties: false,
    };
    /// Refinement of a [`Effort::QUICK`] fit: golden section within one of its grid
    /// steps, then the full Levenberg-Marquardt.
    pub const REFINE: Effort = Effort {
        grid: 0,
        bracket: 0.125,
        golden: 10,
        contact_iterations: 2,
        both_starts: true,
        iterations: 40,
        uncertainties: true,
    };
    /// The fit that decides and is reported.
    pub const FULL: Effort = Effort {
        grid: 12,
        bracket: 0.0,
        golden: 10,
        contact_iterations: 2,
        both_starts: true,
        iterations: 40,
        uncertainties: true,
    };
}

/// Intervals of the grid over the contact position's range after a fit (see [`fit`]).
const CONTACT_GRID: usize = 16;

/// The nonlinear least-squares problem of one model: knobs mapped to [0, 1] (log scale
/// where the range spans decades), residuals from the variable projection.
struct Problem<'a> {
    data: &'a Prepared,
    start: usize,
    effects: &'a BTreeSet<Effect>,
    scale: Scales,
}

impl Problem<'_> {
    /// (Each evaluation starts its contact weights afresh: starting from the previous
    /// evaluation's makes the objective depend on the search path, which the searches
    /// measurably suffer from.)
    fn evaluate(&self, nl: &Nonlinear) -> Option<(f64, Design, Solve, Vec<f64>)> {
        evaluate(
            self.data,
            self.start,
            self.effects,
            nl,
            &self.scale,
            2,
            None,
        )
    }

    fn to_unit(&self, k: Knob, x: f64) -> f64 {
        let (lo, hi, log) = k.range(&self.scale);
        let x = x.clamp(lo, hi);
        if log {
            (x.ln() - lo.ln()) / (hi.ln() - lo.ln())
        } else {
            (x - lo) / (hi - lo)
        }
    }

    fn value_at_unit(&self, k: Knob, u: f64) -> f64 {
        let (lo, hi, log) = k.range(&self.scale);
        let u = u.clamp(0.0, 1.0);
        if log {
            (lo.ln() + u * (hi.ln() - lo.ln())).exp()
        } else {
            lo + u * (hi - lo)
        }
    }

    fn with(&self, base: &Nonlinear, knobs: &[Knob], u: &[f64]) -> Nonlinear {
        let mut nl = *base;
        for (k, v) in knobs.iter().zip(u) {
            nl.set(*k, self.value_at_unit(*k, *v));
        }
        nl
    }

    /// Residual y − ŷ over the fit window (the linear coefficients solved) and its RSS.
    fn residual(&self, nl: &Nonlinear) -> Option<(Vec<f64>, f64)> {
        let (rss, design, solve, _) = self.evaluate(nl)?;
        let y = &self.data.force_n[self.start..];
        let r = (0..y.len())
            .map(|i| {
                y[i] - design
                    .columns
                    .iter()
                    .zip(&solve.beta)
                    .map(|(c, b)| c[i] * b)
                    .sum::<f64>()
            })
            .collect();
        Some((r, rss))
    }

    /// Every law trades against the contact position, whose RSS has several minima (a
    /// contact at the end of its range, an early one, a late one), and a search can end
    /// in the wrong one: where a point of a [`CONTACT_GRID`] over its range, the other
    /// knobs of `nl` (RSS `rss`) held, fits better, the joint Levenberg-Marquardt on
    /// `knobs` runs again from there. Returns the best of the three.
    fn contact_grid(
        &self,
        nl: Nonlinear,
        rss: f64,
        knobs: &[Knob],
        iterations: usize,
    ) -> Nonlinear {
        let on_grid = (0..=CONTACT_GRID)
            .map(|g| {
                let mut trial = nl;
                let u = g as f64 / CONTACT_GRID as f64;
                trial.set(
                    Knob::ContactPosition,
                    self.value_at_unit(Knob::ContactPosition, u),
                );
                (self.rss(&trial), trial)
            })
            .min_by(|a, b| a.0.total_cmp(&b.0));
        match on_grid {
            Some((grid_rss, trial)) if grid_rss < rss => {
                let (again, again_rss) = self.levenberg_marquardt(trial, knobs, iterations);
                if again_rss <= grid_rss {
                    again
                } else {
                    trial
                }
            }
            _ => nl,
        }
    }

    fn rss(&self, nl: &Nonlinear) -> f64 {
        self.evaluate(nl).map_or(f64::INFINITY, |r| r.0)
    }

    /// Levenberg-Marquardt on `knobs` (forward-difference Jacobian in unit coordinates,
    /// bounds by clamping), at most `iterations` Jacobians.
    fn levenberg_marquardt(
        &self,
        start: Nonlinear,
        knobs: &[Knob],
        iterations: usize,
    ) -> (Nonlinear, f64) {
        let p = knobs.len();
        let Some((mut r, mut rss)) = self.residual(&start) else {
            return (start, f64::INFINITY);
        };
        let mut u: Vec<f64> = knobs
            .iter()
            .map(|k| self.to_unit(*k, start.get(*k)))
            .collect();
        let mut nl = start;
        let mut mu = 1e-3;
        // (A step of 1e-3 of the range, about a micrometre of contact position: the RSS
        // steps where single raw samples cross the contact point, and a finer
        // difference sees those steps instead of the slope.)
        const H: f64 = 1e-3;
        for _ in 0..iterations {
            // Jacobian of the residual.
            let mut jac = Vec::with_capacity(p);
            for j in 0..p {
                let step = if knobs[j] == Knob::ContactPosition {
                    H
                } else {
                    1e-4
                };
                let h = if u[j] + step <= 1.0 { step } else { -step };
                let mut uj = u.clone();
                uj[j] += h;
                let Some((rj, _)) = self.residual(&self.with(&nl, knobs, &uj)) else {
                    return (nl, rss);
                };
                jac.push(
                    rj.iter()
                        .zip(&r)
                        .map(|(a, b)| (a - b) / h)
                        .collect::<Vec<f64>>(),
                );
            }
            let a = DMatrix::from_fn(p, p, |j, k| {
                jac[j].iter().zip(&jac[k]).map(|(x, y)| x * y).sum::<f64>()
            });
            let g = DVector::from_fn(p, |j, _| {
                jac[j].iter().zip(&r).map(|(x, y)| x * y).sum::<f64>()
            });
            let mut improved = false;
            for _ in 0..if p == 1 { 3 } else { 8 } {
                let mut m = a.clone();
                for j in 0..p {
                    m[(j, j)] += mu * a[(j, j)].max(1e-12);
                }
                let Some(step) = m.cholesky().map(|c| c.solve(&(-&g))) else {
                    mu *= 4.0;
                    continue;
                };
                let trial_u: Vec<f64> = (0..p).map(|j| (u[j] + step[j]).clamp(0.0, 1.0)).collect();
                let trial = self.with(&nl, knobs, &trial_u);
                if let Some((tr, trss)) = self.residual(&trial) {
                    if trss < rss {
                        let gain = (rss - trss) / rss.max(1e-300);
                        u = trial_u;
                        nl = trial;
                        r = tr;
                        rss = trss;
                        mu = (mu / 3.0).max(1e-9);
                        improved = gain > 1e-7;
                        break;
                    }
                }
                mu *= 4.0;
            }
            if !improved {
                break;
            }
        }
        (nl, rss)
    }
}

/// Fits `effects` (on top of Kelvin-Voigt, with the contact-position refinement always
/// present) starting from the nonlinear values `initial`. Each knob in `global` (other
/// than the contact position) is searched over its whole range on a grid of 13 points,
/// the contact position re-fitted at each (it trades off against every shape parameter);
/// the contact position itself, when in `global`, is searched on a grid first. Then all
/// knobs of the model are fitted jointly by Levenberg-Marquardt. The final model is
/// solved with the unilateral-contact iterations and scored (NRMSE, VAF, BIC, blocked
/// CV).
pub fn fit(
    data: &Prepared,
    effects: &BTreeSet<Effect>,
    initial: &Nonlinear,
    global: &[Knob],
    effort: Effort,
) -> Option<Fit> {
    let start = data.fit_start();
    let scale = Scales::of(data);
    let problem = Problem {
        data,
        start,
        effects,
        scale,
    };
    let mut nl = *initial;
    let knobs = knobs_of(effects);
    let mut order: Vec<Knob> = global
        .iter()
        .copied()
        .filter(|k| knobs.contains(k))
        .collect();
    order.sort(); // the contact position first
    for k in order {
        // The RSS at unit value u of knob k, the contact position re-fitted.
        // Each knob trades off against the contact position (a stiffening law against a
        // later contact, a delay against an earlier one): the contact is re-fitted from
        // the current model's and from the detector's, and the better kept.
        let at = |u: f64, from: &Nonlinear, both: bool| {
            let mut trial = *from;
            trial.set(k, problem.value_at_unit(k, u));
            if k == Knob::ContactPosition {
                return (problem.rss(&trial), trial);
            }
            let (t, r) = problem.levenberg_marquardt(
                trial,
                &[Knob::ContactPosition],
                effort.contact_iterations,
            );
            if trial.contact_m == 0.0 || !both {
                return (r, t);
            }
            trial.contact_m = 0.0;
            let (t0, r0) = problem.levenberg_marquardt(
                trial,
                &[Knob::ContactPosition],
                effort.contact_iterations,
            );
            if r0 < r {
                (r0, t0)
            } else {
                (r, t)
            }
        };
        let mut best = (problem.to_unit(k, nl.get(k)), problem.rss(&nl), nl);
        for g in (0..=effort.grid).filter(|_| effort.grid > 0) {
            let u = g as f64 / effort.grid as f64;
            let (rss, trial) = at(u, &nl, effort.both_starts);
            if rss < best.1 {
                best = (u, rss, trial);
            }
        }
        let from = best.2;
        let at = |u: f64| at(u, &from, false);
        // Golden section around the best grid point: some knobs (delay, plastic set)
        // have an RSS with kinks at sample boundaries that a gradient method stalls on.
        let step = if effort.grid > 0 {
            1.0 / effort.grid as f64
        } else {
            effort.bracket
        };
        let (a, b) = ((best.0 - step).max(0.0), (best.0 + step).min(1.0));
        let [(_, f1), (_, f2)] =
            crate::frontend::fit::golden_section(a, b, effort.golden, at, |r| r.0);
        for (rss, trial) in [f1, f2] {
            if rss < best.1 {
                best = (0.0, rss, trial);
            }
        }
        nl = best.2;
    }
    let (nl, rss) = problem.levenberg_marquardt(nl, &knobs, effort.iterations);
    let nl = if effort.golden > 0 && knobs.contains(&Knob::ContactPosition) {
        problem.contact_grid(nl, rss, &knobs, effort.iterations)
    } else {
        nl
    };
    let scale = problem.scale;
    let (rss, design, solve, _) = evaluate(data, start, effects, &nl, &scale, 4, None)?;
    let y = &data.force_n[start..];
    let n = y.len();
    let prediction: Vec<f64> = (0..n)
        .map(|i| {
            design
                .columns
                .iter()
                .zip(&solve.beta)
                .map(|(c, b)| c[i] * b)
                .sum()
        })
        .collect();
    let range = y.iter().copied().fold(f64::NEG_INFINITY, f64::max)
        - y.iter().copied().fold(f64::INFINITY, f64::min);
    let nrmse = 100.0 * (rss / n as f64).sqrt() / range.max(1e-300);
    let mean = y.iter().sum::<f64>() / n as f64;
    let var = y.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>();
    let vaf = 100.0 * (1.0 - rss / var.max(1e-300));
    let k = design.columns.len() + knobs_of(effects).len();
    let bic = n as f64 * (rss / n as f64).max(1e-300).ln() + k as f64 * (n as f64).ln();
    let cv = cross_validate(&design, y);
    let sigma2 = rss / (n - design.columns.len()).max(1) as f64;
    let se: Vec<f64> = (0..solve.beta.len())
        .map(|j| (sigma2 * solve.covariance[(j, j)]).max(0.0).sqrt())
        .collect();
    let parameters = name_parameters(
        effects,
        &nl,
        &design,
        &solve,
        &se,
        sigma2,
        data,
        start,
        &scale,
        effort.uncertainties,
    );
    Some(Fit {
        effects: effects.iter().copied().collect(),
        nonlinear: nl,
        parameters,
        rss,
        samples: n,
        nrmse_percent: nrmse,
        vaf_percent: vaf,
        bic,
        free_parameters: k,
        cv_rmse: cv.iter().sum::<f64>() / cv.len().max(1) as f64,
        cv_rmse_per_fold: cv,
        prediction,
        start,
    })
}

/// Blocked cross-validation with the nonlinear parameters and contact gates fixed: the
/// linear coefficients are refitted without each contiguous fifth of the record and
/// tested on it.
fn cross_validate(design: &Design, y: &[f64]) -> Vec<f64> {
    let n = y.len();
    (0..FOLDS)
        .map(|f| {
            let (lo, hi) = (f * n / FOLDS, (f + 1) * n / FOLDS);
            let train: Vec<bool> = (0..n).map(|i| i < lo || i >= hi).collect();
            match least_squares(design, y, Some(&train), &[]) {
                Some(s) => {
                    let e: f64 = (lo..hi)
                        .map(|i| {
                            let p: f64 = design
                                .columns
                                .iter()
                                .zip(&s.beta)
                                .map(|(c, b)| c[i] * b)
                                .sum();
                            (y[i] - p) * (y[i] - p)
                        })
                        .sum();
                    (e / (hi - lo).max(1) as f64).sqrt()
                }
                None => f64::INFINITY,
            }
        })
        .collect()
}

/// SI values and standard errors of a fit's parameters.
#[allow(clippy::too_many_arguments)]
fn name_parameters(
    effects: &BTreeSet<Effect>,
    nl: &Nonlinear,
    design: &Design,
    solve: &Solve,
    se: &[f64],
    sigma2: f64,
    data: &Prepared,
    start: usize,
    scale: &Scales,
    uncertainties: bool,
) -> Vec<Estimate> {
    let has = |e: Effect| effects.contains(&e);
    let l = scale.depth_m;
    let col = |c: Column| design.names.iter().position(|n| *n == c);
    let knob_se =
        |knob: Knob| nonlinear_se(uncertainties, data, start, effects, nl, knob, sigma2, scale);
    let mut out = Vec::new();
    let mut push = |param: Param, value: f64, standard_error: f64| {
        out.push(Estimate {
            param,
            value,
            standard_error,
        });
    };
    let (e, se_e) = (solve.beta[0], se[0]);
    // Elastic columns were built as L·(δ/L)^n: coefficient c multiplies it, so
    // F = c·L^(1−n)·δⁿ, i.e. k = c·L^(1−n).
    if has(Effect::PowerLawStiffness) {
        let f = l.powf(1.0 - nl.n);
        push(Param::K, e * f, se_e * f);
        push(Param::N, nl.n, knob_se(Knob::Exponent));
    } else if has(Effect::ExponentialStiffness) {
        if let Some(j) = col(Column::LinearSpring) {
            push(Param::Kappa, solve.beta[j], se[j]);
        }
        push(Param::M, e, se_e);
        push(Param::B, nl.b, knob_se(Knob::StiffeningRate));
    } else {
        push(Param::Kappa, e, se_e);
    }
    let (d, se_d) = (solve.beta[1], se[1]);
    if has(Effect::DepthDependentDamping) {
        let f = l.powf(-nl.q);
        push(Param::Lambda, d * f, se_d * f);
        push(Param::Q, nl.q, knob_se(Knob::DampingExponent));
    } else {
        push(Param::Lambda, d, se_d);
    }
    if let Some(j) = col(Column::Relaxing) {
        let c = solve.beta[j] / e;
        let se_c = c.abs() * ((se[j] / solve.beta[j]).powi(2) + (se_e / e).powi(2)).sqrt();
        push(Param::RelaxedFraction, c, se_c);
        push(Param::RatePerS, nl.nu, knob_se(Knob::RelaxationRate));
    }
    for (column, param) in [
        (Column::Inertia, Param::MassKg),
        (Column::Coulomb, Param::CoulombN),
        (Column::ForceOffset, Param::ForceOffsetN),
        (Column::Tare, Param::TareN),
    ] {
        if let Some(j) = col(column) {
            push(param, solve.beta[j], se[j]);
        }
    }
    for knob in [
        Knob::ContactShift,
        Knob::Delay,
        Knob::PlasticFraction,
        Knob::SlipRate,
    ] {
        if knobs_of(effects).contains(&knob) {
            push(Param::of_knob(knob), nl.get(knob), knob_se(knob));
        }
    }
    push(
        Param::ContactPositionM,
        // The first impact's contact position (the later contacts' is this + shift).
        data.contact_position_m + nl.contact_m
            - if has(Effect::ContactPointOffset) {
                nl.contact_shift_m
            } else {
                0.0
            },
        knob_se(Knob::ContactPosition),
    );
    out
}

/// Standard error of a nonlinear parameter from the curvature of the RSS at the
/// optimum: var ≈ 2σ²/RSS'' (the linear coefficients re-solved at each point).
#[allow(clippy::too_many_arguments)]
fn nonlinear_se(
    uncertainties: bool,
    data: &Prepared,
    start: usize,
    effects: &BTreeSet<Effect>,
    nl: &Nonlinear,
    k: Knob,
    sigma2: f64,
    scale: &Scales,
) -> f64 {
    if !uncertainties {
        return f64::NAN;
    }
    let (lo, hi, _) = k.range(scale);
    let x0 = nl.get(k);
    let h = 1e-3 * (hi - lo).abs().max(x0.abs() * 1e-3);
    let rss = |x: f64| {
        let mut t = *nl;
        t.set(k, x);
        evaluate(data, start, effects, &t, scale, 2, None).map_or(f64::NAN, |r| r.0)
    };
    let curvature = (rss(x0 + h) - 2.0 * rss(x0) + rss(x0 - h)) / (h * h);
    if curvature > 0.0 {
        (2.0 * sigma2 / curvature).sqrt()
    } else {
        f64::INFINITY
    }
}

/// The nonlinear parameters of a model: the contact position, then its effects' knobs.
pub fn knobs_of(effects: &BTreeSet<Effect>) -> Vec<Knob> {
    std::iter::once(Knob::ContactPosition)
        .chain(effects.iter().filter_map(|e| e.knob()))
        .collect()
}
