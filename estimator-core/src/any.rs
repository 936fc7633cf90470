//! Run-time choice of estimator: one enum over all of them, so the host tools and the
//! firmware can select a model from a setting without heap or trait objects.

use crate::error::ConfigError;
use crate::estimator::{ContactSample, Estimate, Estimator, SampleUpdate, Scaling};
use crate::hammerstein::{Hammerstein1, Hammerstein2, HammersteinConfig};
use crate::hunt_crossley::{
    HuntCrossleyConfig, HuntCrossleyEstimator, HuntCrossleyParameters,
    SingleStageHuntCrossleyConfig, SingleStageHuntCrossleyEstimator,
};
use crate::kelvin_voigt::{KelvinVoigtConfig, KelvinVoigtEstimator, KelvinVoigtParameters};
use crate::zener::{ZenerConfig, ZenerEstimator, ZenerParameters};

/// The estimators of this crate, by model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ModelKind {
    /// Kelvin-Voigt, eq. (1).
    KelvinVoigt,
    /// Zener, eqs. (2), (18)-(19).
    Zener,
    /// Hunt-Crossley double stage, eqs. (3), (25)-(37).
    HuntCrossley,
    /// Hunt-Crossley single stage (log-linear RLS, Haddadi & Hashtrudi-Zaad 2012).
    HuntCrossleySingleStage,
    /// Hammerstein, filter order 1, eqs. (38)-(42).
    Hammerstein1,
    /// Hammerstein, filter order 2.
    Hammerstein2,
}

impl ModelKind {
    /// All kinds, in a fixed order.
    pub const ALL: [ModelKind; 6] = [
        ModelKind::KelvinVoigt,
        ModelKind::Zener,
        ModelKind::HuntCrossley,
        ModelKind::HuntCrossleySingleStage,
        ModelKind::Hammerstein1,
        ModelKind::Hammerstein2,
    ];

    /// Command-line / file name of the model (kebab case).
    pub fn name(self) -> &'static str {
        match self {
            ModelKind::KelvinVoigt => "kelvin-voigt",
            ModelKind::Zener => "zener",
            ModelKind::HuntCrossley => "hunt-crossley",
            ModelKind::HuntCrossleySingleStage => "hunt-crossley-single-stage",
            ModelKind::Hammerstein1 => "hammerstein",
            ModelKind::Hammerstein2 => "hammerstein2",
        }
    }

    /// Parses [`ModelKind::name`].
    pub fn from_name(name: &str) -> Option<ModelKind> {
        ModelKind::ALL.into_iter().find(|k| k.name() == name)
    }
}

/// Maximum Hammerstein filter order carried by [`AnyParameters`].
pub const MAX_FILTER_ORDER: usize = 2;

/// Parameters of any model, SI units, named as in the paper.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AnyParameters {
    /// κ \[N/m\], λ \[N·s/m\].
    KelvinVoigt(KelvinVoigtParameters),
    /// κ1, κ2 \[N/m\], λ \[N·s/m\].
    Zener(ZenerParameters),
    /// k \[N/m^n\], λ \[N·s/m^(n+1)\], n.
    HuntCrossley(HuntCrossleyParameters),
    /// γ1 \[N/m^γ2\], γ2, a1..a_order, b1..b_order (unused entries are 0).
    Hammerstein {
        /// γ1 \[N/m^γ2\].
        gamma1: f32,
        /// γ2.
        gamma2: f32,
        /// Filter order r (1 or 2).
        order: u8,
        /// a1..ar.
        a: [f32; MAX_FILTER_ORDER],
        /// b1..br.
        b: [f32; MAX_FILTER_ORDER],
    },
}

const FILTER_A: [&str; MAX_FILTER_ORDER] = ["a1", "a2"];
const FILTER_B: [&str; MAX_FILTER_ORDER] = ["b1", "b2"];

impl AnyParameters {
    /// Number of named parameters.
    pub fn len(&self) -> usize {
        match self {
            AnyParameters::KelvinVoigt(_) => 2,
            AnyParameters::Zener(_) | AnyParameters::HuntCrossley(_) => 3,
            AnyParameters::Hammerstein { order, .. } => 2 + 2 * *order as usize,
        }
    }

    /// Always `false`: every model has parameters (for clippy's `len_without_is_empty`).
    pub fn is_empty(&self) -> bool {
        false
    }

    /// The `i`-th parameter as (paper name, SI value), `None` past the end. Names:
    /// kelvin-voigt `kappa`, `lambda`; zener `kappa1`, `kappa2`, `lambda`; hunt-crossley
    /// `k`, `lambda`, `n`; hammerstein `gamma1`, `gamma2`, `a1`..`ar`, `b1`..`br`.
    pub fn get(&self, i: usize) -> Option<(&'static str, f32)> {
        match *self {
            AnyParameters::KelvinVoigt(p) => {
                [("kappa", p.kappa), ("lambda", p.lambda)].get(i).copied()
            }
            AnyParameters::Zener(p) => [
                ("kappa1", p.kappa1),
                ("kappa2", p.kappa2),
                ("lambda", p.lambda),
            ]
            .get(i)
            .copied(),
            AnyParameters::HuntCrossley(p) => [("k", p.k), ("lambda", p.lambda), ("n", p.n)]
                .get(i)
                .copied(),
            AnyParameters::Hammerstein {
                gamma1,
                gamma2,
                order,
                a,
                b,
            } => {
                let r = order as usize;
                match i {
                    0 => Some(("gamma1", gamma1)),
                    1 => Some(("gamma2", gamma2)),
                    i if i < 2 + r => Some((FILTER_A[i - 2], a[i - 2])),
                    i if i < 2 + 2 * r => Some((FILTER_B[i - 2 - r], b[i - 2 - r])),
                    _ => None,
                }
            }
        }
    }

    /// Iterator over (name, value).
    pub fn iter(&self) -> impl Iterator<Item = (&'static str, f32)> + '_ {
        (0..self.len()).filter_map(move |i| self.get(i))
    }
}

fn hammerstein_any<const R: usize>(
    p: &crate::hammerstein::HammersteinParameters<R>,
) -> AnyParameters {
    let mut a = [0.0; MAX_FILTER_ORDER];
    let mut b = [0.0; MAX_FILTER_ORDER];
    let r = R.min(MAX_FILTER_ORDER);
    a[..r].copy_from_slice(&p.a[..r]);
    b[..r].copy_from_slice(&p.b[..r]);
    AnyParameters::Hammerstein {
        gamma1: p.gamma1,
        gamma2: p.gamma2,
        order: R as u8,
        a,
        b,
    }
}

/// Settings applied to an estimator's default config by [`AnyEstimator::try_new`]: the
/// values a host derives from the record at hand (units, noise-dependent guards).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct EstimatorSettings {
    /// Internal units.
    pub scaling: Scaling,
    /// Replaces every RLS stage's forgetting policy when given.
    pub forgetting: Option<crate::rls::Forgetting>,
    /// Logarithm guard on δ \[m\] (Hunt-Crossley Γ2, Hammerstein Γ1); `None` keeps the
    /// model's default, which is the paper's rig's (20 µm).
    pub min_depth_m: Option<f32>,
    /// Logarithm guard on F \[N\]; `None` keeps the rig's default (0.2 N Hunt-Crossley,
    /// 0.1 N Hammerstein).
    pub min_force_n: Option<f32>,
    /// Hammerstein δ̇* \[m/s\]; `None` keeps the default (10 mm/s, for the paper's
    /// 30 mm/s ramp).
    pub min_depth_rate_m_per_s: Option<f32>,
    /// Hold the damping coefficient at 0 (Kelvin-Voigt and Hunt-Crossley λ) when the
    /// record cannot determine it; ignored by the other models.
    pub hold_damping: bool,
    /// Start from these parameters (SI) instead of the defaults (see
    /// [`Estimator::start_from`]); ignored when they are of another model.
    pub initial: Option<AnyParameters>,
    /// Weighting of the log-domain residual of the single-stage Hunt-Crossley estimator
    /// (`None` keeps its default, the literature's uniform weighting).
    pub log_weighting: Option<crate::hunt_crossley::LogWeighting>,
}

/// Any estimator of this crate (the size of the largest variant).
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(clippy::large_enum_variant)]
pub enum AnyEstimator {
    /// See [`KelvinVoigtEstimator`].
    KelvinVoigt(KelvinVoigtEstimator),
    /// See [`ZenerEstimator`].
    Zener(ZenerEstimator),
    /// See [`HuntCrossleyEstimator`].
    HuntCrossley(HuntCrossleyEstimator),
    /// See [`SingleStageHuntCrossleyEstimator`].
    HuntCrossleySingleStage(SingleStageHuntCrossleyEstimator),
    /// See [`Hammerstein1`].
    Hammerstein1(Hammerstein1),
    /// See [`Hammerstein2`].
    Hammerstein2(Hammerstein2),
}

impl AnyEstimator {
    /// Builds the default-configured estimator of `kind` with the given internal units
    /// (see [`Scaling`]) and the rig's default guards.
    ///
    /// # Errors
    /// [`ConfigError`] if `scaling` is invalid.
    pub fn try_default(kind: ModelKind, scaling: Scaling) -> Result<Self, ConfigError> {
        Self::try_new(
            kind,
            &EstimatorSettings {
                scaling,
                ..EstimatorSettings::default()
            },
        )
    }

    /// Builds the estimator of `kind` from its default config with `settings` applied.
    ///
    /// # Errors
    /// [`ConfigError`] naming the bad setting.
    pub fn try_new(kind: ModelKind, settings: &EstimatorSettings) -> Result<Self, ConfigError> {
        let scaling = settings.scaling;
        scaling.validate()?;
        if let Some(f) = settings.forgetting {
            f.validate()?;
        }
        let set = |rls: &mut crate::rls::RlsConfig| {
            if let Some(f) = settings.forgetting {
                rls.forgetting = f;
            }
        };
        let guard = |value: Option<f32>, default: f32| value.unwrap_or(default);
        let mut estimator = match kind {
            ModelKind::KelvinVoigt => {
                let mut c = KelvinVoigtConfig {
                    scaling,
                    hold_damping: settings.hold_damping,
                    ..KelvinVoigtConfig::default()
                };
                set(&mut c.rls);
                AnyEstimator::KelvinVoigt(KelvinVoigtEstimator::try_new(c)?)
            }
            ModelKind::Zener => {
                let mut c = ZenerConfig {
                    scaling,
                    ..ZenerConfig::default()
                };
                set(&mut c.rls);
                AnyEstimator::Zener(ZenerEstimator::try_new(c)?)
            }
            ModelKind::HuntCrossley => {
                let mut c = HuntCrossleyConfig {
                    scaling,
                    hold_damping: settings.hold_damping,
                    ..HuntCrossleyConfig::default()
                };
                c.guards.min_depth_m = guard(settings.min_depth_m, c.guards.min_depth_m);
                c.guards.min_force_n = guard(settings.min_force_n, c.guards.min_force_n);
                set(&mut c.stage1);
                set(&mut c.stage2);
                AnyEstimator::HuntCrossley(HuntCrossleyEstimator::try_new(c)?)
            }
            ModelKind::HuntCrossleySingleStage => {
                let mut c = SingleStageHuntCrossleyConfig {
                    scaling,
                    hold_damping: settings.hold_damping,
                    ..SingleStageHuntCrossleyConfig::default()
                };
                if let Some(w) = settings.log_weighting {
                    c.weighting = w;
                }
                c.guards.min_depth_m = guard(settings.min_depth_m, c.guards.min_depth_m);
                c.guards.min_force_n = guard(settings.min_force_n, c.guards.min_force_n);
                set(&mut c.rls);
                AnyEstimator::HuntCrossleySingleStage(SingleStageHuntCrossleyEstimator::try_new(c)?)
            }
            ModelKind::Hammerstein1 | ModelKind::Hammerstein2 => {
                let mut c = HammersteinConfig {
                    scaling,
                    ..HammersteinConfig::default()
                };
                c.min_depth_m = guard(settings.min_depth_m, c.min_depth_m);
                c.min_force_n = guard(settings.min_force_n, c.min_force_n);
                c.min_depth_rate_m_per_s =
                    guard(settings.min_depth_rate_m_per_s, c.min_depth_rate_m_per_s);
                set(&mut c.elastic_stage);
                set(&mut c.filter_stage);
                if kind == ModelKind::Hammerstein1 {
                    AnyEstimator::Hammerstein1(Hammerstein1::try_new(c)?)
                } else {
                    AnyEstimator::Hammerstein2(Hammerstein2::try_new(c)?)
                }
            }
        };
        if let Some(initial) = &settings.initial {
            estimator.start_from(initial);
        }
        Ok(estimator)
    }

    /// The model this estimator fits.
    pub fn kind(&self) -> ModelKind {
        match self {
            AnyEstimator::KelvinVoigt(_) => ModelKind::KelvinVoigt,
            AnyEstimator::Zener(_) => ModelKind::Zener,
            AnyEstimator::HuntCrossley(_) => ModelKind::HuntCrossley,
            AnyEstimator::HuntCrossleySingleStage(_) => ModelKind::HuntCrossleySingleStage,
            AnyEstimator::Hammerstein1(_) => ModelKind::Hammerstein1,
            AnyEstimator::Hammerstein2(_) => ModelKind::Hammerstein2,
        }
    }
}

/// Calls `$body` with `$e` bound to the inner estimator, and converts its parameters.
macro_rules! dispatch {
    ($self:expr, $e:ident => $body:expr, $conv:ident) => {
        match $self {
            AnyEstimator::KelvinVoigt($e) => $conv($body, |p| AnyParameters::KelvinVoigt(*p)),
            AnyEstimator::Zener($e) => $conv($body, |p| AnyParameters::Zener(*p)),
            AnyEstimator::HuntCrossley($e) => $conv($body, |p| AnyParameters::HuntCrossley(*p)),
            AnyEstimator::HuntCrossleySingleStage($e) => {
                $conv($body, |p| AnyParameters::HuntCrossley(*p))
            }
            AnyEstimator::Hammerstein1($e) => $conv($body, hammerstein_any),
            AnyEstimator::Hammerstein2($e) => $conv($body, hammerstein_any),
        }
    };
}

fn convert<P>(p: P, f: impl FnOnce(&P) -> AnyParameters) -> AnyParameters {
    f(&p)
}

fn convert_estimate<P>(
    e: Estimate<P>,
    f: impl FnOnce(&P) -> AnyParameters,
) -> Estimate<AnyParameters> {
    Estimate {
        parameters: f(&e.parameters),
        predicted_force_n: e.predicted_force_n,
        status: e.status,
    }
}

impl Estimator for AnyEstimator {
    type Parameters = AnyParameters;

    fn update(&mut self, sample: &ContactSample) -> SampleUpdate {
        match self {
            AnyEstimator::KelvinVoigt(e) => e.update(sample),
            AnyEstimator::Zener(e) => e.update(sample),
            AnyEstimator::HuntCrossley(e) => e.update(sample),
            AnyEstimator::HuntCrossleySingleStage(e) => e.update(sample),
            AnyEstimator::Hammerstein1(e) => e.update(sample),
            AnyEstimator::Hammerstein2(e) => e.update(sample),
        }
    }

    /// One dispatch for the update and the conversion (the default method would dispatch
    /// twice); the results are those of `update` then `parameters`.
    fn step(&mut self, sample: &ContactSample) -> Estimate<AnyParameters> {
        dispatch!(self, e => e.step(sample), convert_estimate)
    }

    fn parameters(&self) -> AnyParameters {
        dispatch!(self, e => e.parameters(), convert)
    }

    fn standard_errors(&self) -> AnyParameters {
        dispatch!(self, e => e.standard_errors(), convert)
    }

    fn onset_exponent(&self) -> Option<f32> {
        match self {
            AnyEstimator::KelvinVoigt(e) => e.onset_exponent(),
            AnyEstimator::Zener(e) => e.onset_exponent(),
            AnyEstimator::HuntCrossley(e) => e.onset_exponent(),
            AnyEstimator::HuntCrossleySingleStage(e) => e.onset_exponent(),
            AnyEstimator::Hammerstein1(e) => e.onset_exponent(),
            AnyEstimator::Hammerstein2(e) => e.onset_exponent(),
        }
    }

    fn onset_damping_ratio(&self) -> f32 {
        match self {
            AnyEstimator::KelvinVoigt(e) => e.onset_damping_ratio(),
            AnyEstimator::Zener(e) => e.onset_damping_ratio(),
            AnyEstimator::HuntCrossley(e) => e.onset_damping_ratio(),
            AnyEstimator::HuntCrossleySingleStage(e) => e.onset_damping_ratio(),
            AnyEstimator::Hammerstein1(e) => e.onset_damping_ratio(),
            AnyEstimator::Hammerstein2(e) => e.onset_damping_ratio(),
        }
    }

    fn start_from(&mut self, parameters: &AnyParameters) {
        match (self, parameters) {
            (AnyEstimator::KelvinVoigt(e), AnyParameters::KelvinVoigt(p)) => e.start_from(p),
            (AnyEstimator::Zener(e), AnyParameters::Zener(p)) => e.start_from(p),
            (AnyEstimator::HuntCrossley(e), AnyParameters::HuntCrossley(p)) => e.start_from(p),
            (AnyEstimator::HuntCrossleySingleStage(e), AnyParameters::HuntCrossley(p)) => {
                e.start_from(p)
            }
            (AnyEstimator::Hammerstein1(e), AnyParameters::Hammerstein { gamma1, gamma2, .. }) => e
                .start_from(&crate::hammerstein::HammersteinParameters {
                    gamma1: *gamma1,
                    gamma2: *gamma2,
                    a: [0.0; 1],
                    b: [0.0; 1],
                }),
            (AnyEstimator::Hammerstein2(e), AnyParameters::Hammerstein { gamma1, gamma2, .. }) => e
                .start_from(&crate::hammerstein::HammersteinParameters {
                    gamma1: *gamma1,
                    gamma2: *gamma2,
                    a: [0.0; 2],
                    b: [0.0; 2],
                }),
            _ => {}
        }
    }

    fn start_contact(&mut self) {
        match self {
            AnyEstimator::KelvinVoigt(e) => e.start_contact(),
            AnyEstimator::Zener(e) => e.start_contact(),
            AnyEstimator::HuntCrossley(e) => e.start_contact(),
            AnyEstimator::HuntCrossleySingleStage(e) => e.start_contact(),
            AnyEstimator::Hammerstein1(e) => e.start_contact(),
            AnyEstimator::Hammerstein2(e) => e.start_contact(),
        }
    }

    fn reset(&mut self) {
        match self {
            AnyEstimator::KelvinVoigt(e) => e.reset(),
            AnyEstimator::Zener(e) => e.reset(),
            AnyEstimator::HuntCrossley(e) => e.reset(),
            AnyEstimator::HuntCrossleySingleStage(e) => e.reset(),
            AnyEstimator::Hammerstein1(e) => e.reset(),
            AnyEstimator::Hammerstein2(e) => e.reset(),
        }
    }
}
