//! `model.json`: the diagnosis's final model as a typed specification, in SI, that
//! `host-sim simulate --model-spec` runs over a measured motion and
//! `host-sim estimate --model-spec` turns into the core's online estimator for that
//! structure where one exists.
//!
//! The force law is the workflow's composite model ([`super::regressors`]): the elastic law
//! (linear κδ, eq. 1; power law k·δⁿ, eq. 3; or κδ + m(e^{bδ} − 1)/b, QLV eqs. 11/13),
//! damping λ·δ^q·δ̇ (q = 0: eq. 1; eq. 3 otherwise), optionally one relaxation mode of
//! the elastic force (a Zener arm, eq. 2 / QLV eq. 15), mass, Coulomb friction, a force
//! channel delay, a plastic set, and the measurement's contact position and force
//! offset. Simulating a spec evaluates exactly the law the diagnosis fitted, so the
//! simulation is the diagnosis's own model and not a second implementation of it.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use anyhow::{bail, Context, Result};
use estimator_core::ModelKind;
use serde::{Deserialize, Serialize};

use super::catalogue::{Effect, Nonlinear, Param, Scales};
use super::data::Prepared;
use super::regressors::{self, Column};
use super::solver::Fit;

/// Identifies the file format; bumped when a field changes meaning.
pub const SCHEMA: &str = "contact-model-spec/1";

/// The elastic law F_e(δ) \[N\] of a spec, δ \[m\] from the contact point.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "law", rename_all = "snake_case")]
pub enum ElasticLaw {
    /// κ·δ (Kelvin-Voigt, eq. 1); κ \[N/m\].
    Linear {
        /// Stiffness κ \[N/m\].
        kappa: f64,
    },
    /// k·δⁿ (Hunt-Crossley, eq. 3).
    PowerLaw {
        /// k \[N/mⁿ\].
        k: f64,
        /// Exponent n.
        n: f64,
    },
    /// κδ + m(e^{bδ} − 1)/b (QLV exponential law, eqs. 11/13, on a linear spring).
    Exponential {
        /// Linear stiffness κ \[N/m\].
        kappa: f64,
        /// Initial slope m of the exponential part \[N/m\].
        m: f64,
        /// Stiffening rate b \[1/m\].
        b: f64,
    },
}

/// One relaxation mode: a fraction of the (instantaneous) elastic force relaxes at a rate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Relaxation {
    /// Fraction c ≥ 0 of the elastic force that relaxes (c < 1 for a mode the record
    /// resolves; a mode slower than the record fixes only c·ν, and c may exceed 1).
    pub relaxed_fraction: f64,
    /// Rate ν \[1/s\].
    pub rate_per_s: f64,
    /// Where the record begins in contact: the relaxing force already released at its
    /// first fitting sample beyond a fresh loading's \[N\], decaying at ν
    /// ([`Param::InitialRelaxingN`]); 0 (and absent from the file) otherwise.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub initial_relaxing_n: f64,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// Coulomb friction F_c·tanh(δ̇/v_s) in contact.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Coulomb {
    /// F_c \[N\].
    pub force_n: f64,
    /// v_s \[m/s\].
    pub slip_rate_m_per_s: f64,
}

/// A contact model with its parameters, as `model.json` holds it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelSpec {
    /// [`SCHEMA`].
    pub schema: String,
    /// The record it was identified on.
    pub source: String,
    /// The effects on top of Kelvin-Voigt (the structure).
    pub effects: Vec<Effect>,
    /// Elastic law.
    pub elastic: ElasticLaw,
    /// Damping coefficient λ \[N·s/m^(1+q)\].
    pub damping_lambda: f64,
    /// Damping exponent q (0: linear damping, eq. 1).
    pub damping_exponent: f64,
    /// Relaxation mode, if any.
    pub relaxation: Option<Relaxation>,
    /// Moving mass \[kg\], if modelled.
    pub mass_kg: Option<f64>,
    /// The mass acts out of contact too: a probe's mass beyond the load cell, m·δ̈ in the
    /// free space as well ([`Prepared::mass_in_free_space`]); absent: in contact only
    /// (a mass that moves with the material, as in specs written before it existed).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub mass_in_free_space: bool,
    /// Coulomb friction, if modelled.
    pub coulomb: Option<Coulomb>,
    /// Lag of the force channel behind the position \[s\], if modelled.
    pub delay_s: Option<f64>,
    /// Plastic set: the contact point moves by this fraction of the deepest indentation.
    pub plastic_fraction: Option<f64>,
    /// Sign that turns the file's position into penetration (+1: the position increases
    /// into the material).
    pub position_sign: f64,
    /// Contact position of the first impact \[m\], on the penetration axis (the file's
    /// position times `position_sign`).
    pub contact_position_m: f64,
    /// Contact position of the later contacts minus the first's \[m\], if modelled.
    pub contact_shift_m: Option<f64>,
    /// When the later contacts' position took over \[s\] from the record's first sample,
    /// where the surface moved after a later contact than the first
    /// ([`Prepared::surface_switch`]); absent: after the first contact (as in specs
    /// written before it existed). A time, as `later_force_offset_at_s`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact_shift_at_s: Option<f64>,
    /// Force offset \[N\] subtracted from the file's force (the load cell's zero).
    pub force_offset_n: f64,
    /// A further offset after the first contact \[N\] (a zero shift), if modelled.
    pub later_force_offset_n: Option<f64>,
    /// When that zero shift took effect \[s\] from the record's first sample (in the free
    /// stretch after the first contact; [`Prepared::offset_step`]), if modelled (absent
    /// from specs written before it existed: at the first contact's lift-off). A time,
    /// not a place in the motion: simulated over another record's motion, the shift
    /// falls at that time of it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub later_force_offset_at_s: Option<f64>,
    /// Drift of the load cell's zero \[N/s\] from the record's first sample on, if
    /// modelled (absent from specs written before it existed: none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub force_drift_n_per_s: Option<f64>,
    /// NRMSE \[%\] of this model on its source record (the diagnosis's final NRMSE).
    pub nrmse_percent: f64,
    /// The parameters the record did not determine, `{name: why}` (the diagnosis's
    /// `final_undetermined`, names as in its `final_parameters`): the spec holds the values
    /// the fit ended on, and simulating it reproduces the fit, but only what the reason
    /// names (a combination such as λ − κ·τ, a product, a bound) is the record's. Absent
    /// where every parameter was determined (and in specs written before it existed).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub undetermined: BTreeMap<String, String>,
}

/// A parameter of a fit, or an error naming it.
fn param(fit: &Fit, param: Param) -> Result<f64> {
    fit.parameter(param)
        .with_context(|| format!("the fit has no parameter {}", param.id()))
}

impl ModelSpec {
    /// The spec of `fit`, a model fitted to `data` (read from `source`).
    ///
    /// # Errors
    /// If the fit lacks a parameter its effects need (a bug, not bad input).
    pub fn of_fit(fit: &Fit, data: &Prepared, source: &str) -> Result<ModelSpec> {
        let has = |e: Effect| fit.effects.contains(&e);
        let elastic = if has(Effect::PowerLawStiffness) {
            ElasticLaw::PowerLaw {
                k: param(fit, Param::K)?,
                n: param(fit, Param::N)?,
            }
        } else if has(Effect::ExponentialStiffness) {
            ElasticLaw::Exponential {
                kappa: fit.parameter(Param::Kappa).unwrap_or(0.0),
                m: param(fit, Param::M)?,
                b: param(fit, Param::B)?,
            }
        } else {
            ElasticLaw::Linear {
                kappa: param(fit, Param::Kappa)?,
            }
        };
        let relaxation = if has(Effect::Relaxation) {
            Some(Relaxation {
                relaxed_fraction: param(fit, Param::RelaxedFraction)?,
                rate_per_s: param(fit, Param::RatePerS)?,
                initial_relaxing_n: fit.parameter(Param::InitialRelaxingN).unwrap_or(0.0),
            })
        } else {
            None
        };
        let coulomb = if has(Effect::CoulombFriction) {
            Some(Coulomb {
                force_n: param(fit, Param::CoulombN)?,
                slip_rate_m_per_s: param(fit, Param::SlipRateMPerS)?,
            })
        } else {
            None
        };
        Ok(ModelSpec {
            schema: SCHEMA.into(),
            source: source.into(),
            effects: fit.effects.clone(),
            elastic,
            damping_lambda: param(fit, Param::Lambda)?,
            damping_exponent: fit.parameter(Param::Q).unwrap_or(0.0),
            relaxation,
            mass_kg: fit.parameter(Param::MassKg),
            mass_in_free_space: fit.mass_in_free_space,
            coulomb,
            delay_s: fit.parameter(Param::DelayS),
            plastic_fraction: fit.parameter(Param::PlasticFraction),
            position_sign: data.position_sign,
            contact_position_m: param(fit, Param::ContactPositionM)?,
            contact_shift_m: fit.parameter(Param::ContactShiftM),
            contact_shift_at_s: fit
                .parameter(Param::ContactShiftM)
                .and_then(|_| data.later_surface_switch_s()),
            force_offset_n: data.force_offset_n + fit.parameter(Param::TareN).unwrap_or(0.0),
            later_force_offset_n: fit.parameter(Param::ForceOffsetN),
            later_force_offset_at_s: fit
                .parameter(Param::ForceOffsetN)
                .map(|_| data.offset_step_s()),
            force_drift_n_per_s: fit.parameter(Param::ForceDriftNPerS),
            nrmse_percent: fit.nrmse_percent,
            undetermined: fit
                .parameters
                .iter()
                .filter_map(|p| {
                    super::report::undetermined_reason(fit, p).map(|why| (p.param.id().into(), why))
                })
                .collect(),
        })
    }

    /// Reads and checks a `model.json`.
    ///
    /// # Errors
    /// If the file cannot be read, is not a spec of this [`SCHEMA`], or a parameter is
    /// missing, not finite or out of its physical range (each named with the file).
    pub fn read(path: &Path) -> Result<ModelSpec> {
        let text =
            std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
        let spec: ModelSpec = serde_json::from_str(&text)
            .with_context(|| format!("{}: not a model specification ({SCHEMA})", path.display()))?;
        spec.validate()
            .with_context(|| format!("{}: invalid model specification", path.display()))?;
        Ok(spec)
    }

    /// Checks the schema, that every parameter is finite and physical, and that the
    /// structure and the parameters agree.
    ///
    /// # Errors
    /// The first field that is not.
    pub fn validate(&self) -> Result<()> {
        if self.schema != SCHEMA {
            bail!("field schema: {:?}, expected {SCHEMA:?}", self.schema);
        }
        let finite = |name: &str, v: f64| -> Result<()> {
            if !v.is_finite() {
                bail!("field {name}: {v} is not a finite number");
            }
            Ok(())
        };
        let non_negative = |name: &str, v: f64| -> Result<()> {
            finite(name, v)?;
            if v < 0.0 {
                bail!("field {name}: {v} is negative (a passive material has {name} ≥ 0)");
            }
            Ok(())
        };
        let has = |e: Effect| self.effects.contains(&e);
        match self.elastic {
            ElasticLaw::Linear { kappa } => {
                non_negative("elastic.kappa", kappa)?;
                if has(Effect::PowerLawStiffness) || has(Effect::ExponentialStiffness) {
                    bail!("field elastic: linear, but effects name a stiffening law");
                }
            }
            ElasticLaw::PowerLaw { k, n } => {
                non_negative("elastic.k", k)?;
                non_negative("elastic.n", n)?;
                if !has(Effect::PowerLawStiffness) {
                    bail!("field elastic: power_law, but effects lack power_law_stiffness");
                }
            }
            ElasticLaw::Exponential { kappa, m, b } => {
                non_negative("elastic.kappa", kappa)?;
                non_negative("elastic.m", m)?;
                finite("elastic.b", b)?;
                if b <= 0.0 {
                    bail!("field elastic.b: {b} must be > 0");
                }
                if !has(Effect::ExponentialStiffness) {
                    bail!("field elastic: exponential, but effects lack exponential_stiffness");
                }
            }
        }
        non_negative("damping_lambda", self.damping_lambda)?;
        non_negative("damping_exponent", self.damping_exponent)?;
        if self.damping_exponent != 0.0 && !has(Effect::DepthDependentDamping) {
            bail!("field damping_exponent: nonzero, but effects lack depth_dependent_damping");
        }
        let present = |name: &str, effect: Effect, given: bool| -> Result<()> {
            if has(effect) != given {
                bail!(
                    "field {name}: {} but effects {} {}",
                    if given { "given" } else { "missing" },
                    if has(effect) { "name" } else { "lack" },
                    effect.id()
                );
            }
            Ok(())
        };
        present("relaxation", Effect::Relaxation, self.relaxation.is_some())?;
        if let Some(r) = self.relaxation {
            // c > 1 is allowed: a mode slower than the record fixes only c·ν (see
            // `diagnose::physical`).
            non_negative("relaxation.relaxed_fraction", r.relaxed_fraction)?;
            non_negative("relaxation.rate_per_s", r.rate_per_s)?;
            finite("relaxation.initial_relaxing_n", r.initial_relaxing_n)?;
        }
        present("mass_kg", Effect::Inertia, self.mass_kg.is_some())?;
        if self.mass_in_free_space && self.mass_kg.is_none() {
            bail!("field mass_in_free_space: true, but no mass_kg is given");
        }
        if let Some(m) = self.mass_kg {
            finite("mass_kg", m)?;
        }
        present("coulomb", Effect::CoulombFriction, self.coulomb.is_some())?;
        if let Some(c) = self.coulomb {
            non_negative("coulomb.force_n", c.force_n)?;
            non_negative("coulomb.slip_rate_m_per_s", c.slip_rate_m_per_s)?;
            if c.slip_rate_m_per_s == 0.0 {
                bail!("field coulomb.slip_rate_m_per_s: must be > 0");
            }
        }
        // A signed quantity: given exactly when its effect is named, and finite.
        let signed = |name: &str, effect: Effect, value: Option<f64>| -> Result<()> {
            present(name, effect, value.is_some())?;
            value.map_or(Ok(()), |v| finite(name, v))
        };
        signed("delay_s", Effect::TimeDelay, self.delay_s)?;
        present(
            "plastic_fraction",
            Effect::PlasticSet,
            self.plastic_fraction.is_some(),
        )?;
        if let Some(p) = self.plastic_fraction {
            non_negative("plastic_fraction", p)?;
            if p >= 1.0 {
                bail!("field plastic_fraction: must be < 1 (a set of the whole depth leaves no elastic recovery)");
            }
        }
        signed(
            "contact_shift_m",
            Effect::ContactPointOffset,
            self.contact_shift_m,
        )?;
        signed(
            "later_force_offset_n",
            Effect::ForceOffset,
            self.later_force_offset_n,
        )?;
        signed(
            "force_drift_n_per_s",
            Effect::ForceDrift,
            self.force_drift_n_per_s,
        )?;
        // When a modelled shift took effect: a time in the record, with its shift.
        let moment = |name: &str, t: Option<f64>, of: &str, shift: Option<f64>| -> Result<()> {
            let Some(t) = t else { return Ok(()) };
            if shift.is_none() {
                bail!("field {name}: given without {of}");
            }
            finite(name, t)?;
            if t < 0.0 {
                bail!("field {name}: {t} is negative (seconds from the record's first sample)");
            }
            Ok(())
        };
        moment(
            "contact_shift_at_s",
            self.contact_shift_at_s,
            "contact_shift_m",
            self.contact_shift_m,
        )?;
        moment(
            "later_force_offset_at_s",
            self.later_force_offset_at_s,
            "later_force_offset_n",
            self.later_force_offset_n,
        )?;
        if self.position_sign != 1.0 && self.position_sign != -1.0 {
            bail!(
                "field position_sign: {}, expected 1 or -1",
                self.position_sign
            );
        }
        finite("contact_position_m", self.contact_position_m)?;
        finite("force_offset_n", self.force_offset_n)?;
        Ok(())
    }

    /// The model's force \[N\] over `data` (prepared on the penetration axis with its own
    /// offset and contact point) from [`Prepared::fit_start`] on, with this spec's contact
    /// position and offsets: the same law and samples as the diagnosis's fit.
    pub fn force_n(&self, data: &Prepared) -> Vec<f64> {
        let effects: BTreeSet<Effect> = self.effects.iter().copied().collect();
        let scale = Scales::of(data);
        let l = scale.depth_m;
        let mut nl = Nonlinear::default();
        let shift = self.contact_shift_m.unwrap_or(0.0);
        // The fit's contact knob moves the later contacts' point; the first impact's
        // is that minus the shift.
        nl.contact_m = self.contact_position_m + shift - data.contact_position_m;
        nl.contact_shift_m = shift;
        let elastic = match self.elastic {
            ElasticLaw::Linear { kappa } => kappa,
            // Columns are L·(δ/L)ⁿ: coefficient k·L^(n−1).
            ElasticLaw::PowerLaw { k, n } => {
                nl.n = n;
                k * l.powf(n - 1.0)
            }
            ElasticLaw::Exponential { m, b, .. } => {
                nl.b = b;
                nl.linear_spring = true;
                m
            }
        };
        nl.q = self.damping_exponent;
        let damping = self.damping_lambda * l.powf(self.damping_exponent);
        if let Some(r) = self.relaxation {
            nl.nu = r.rate_per_s;
        }
        if let Some(c) = self.coulomb {
            nl.slip_m_per_s = c.slip_rate_m_per_s;
        }
        nl.delay_s = self.delay_s.unwrap_or(0.0);
        nl.plastic = self.plastic_fraction.unwrap_or(0.0);
        let coefficient = |column: Column| match column {
            Column::Elastic => elastic,
            Column::Damping => damping,
            Column::LinearSpring => match self.elastic {
                ElasticLaw::Exponential { kappa, .. } => kappa,
                _ => 0.0,
            },
            Column::Relaxing => self
                .relaxation
                .map_or(0.0, |r| r.relaxed_fraction * elastic),
            Column::RelaxingStart => self.relaxation.map_or(0.0, |r| r.initial_relaxing_n),
            Column::Inertia => self.mass_kg.unwrap_or(0.0),
            Column::Coulomb => self.coulomb.map_or(0.0, |c| c.force_n),
            Column::Tare => self.force_offset_n - data.force_offset_n,
            Column::ForceOffset => self.later_force_offset_n.unwrap_or(0.0),
            Column::ForceDrift => self.force_drift_n_per_s.unwrap_or(0.0),
        };
        // (Where the mass acts is the spec's, not the record's it runs over.)
        if data.mass_in_free_space != self.mass_in_free_space {
            let data = Prepared {
                mass_in_free_space: self.mass_in_free_space,
                ..data.clone()
            };
            return regressors::predict(&data, &effects, &nl, coefficient);
        }
        regressors::predict(data, &effects, &nl, coefficient)
    }

    /// The core's online estimator for this structure (the `estimate --model` name), or
    /// why there is none.
    ///
    /// # Errors
    /// The structure has no online estimator in the core; the message names the effects
    /// that have none and the nearest estimator.
    pub fn online_estimator(&self) -> Result<ModelKind> {
        // Hunt-Crossley's power law with n free covers depth-dependent damping on a
        // linear spring (n ≈ 1).
        let elastic_power = self.effects.contains(&Effect::PowerLawStiffness)
            || self.effects.contains(&Effect::DepthDependentDamping);
        let relaxes = self.effects.contains(&Effect::Relaxation);
        let without: Vec<&str> = self
            .effects
            .iter()
            .filter(|e| {
                !matches!(
                    e,
                    Effect::PowerLawStiffness
                        | Effect::DepthDependentDamping
                        | Effect::Relaxation
                        | Effect::ForceOffset
                        | Effect::ContactPointOffset
                )
            })
            .map(|e| e.id())
            .collect();
        let kind = match (elastic_power, relaxes) {
            (false, false) => ModelKind::KelvinVoigt,
            (true, false) => ModelKind::HuntCrossley,
            (false, true) => ModelKind::Zener,
            (true, true) => ModelKind::Hammerstein1,
        };
        let nearest = kind.name();
        if !without.is_empty() {
            bail!(
                "no online estimator in the core models {} (the nearest structure is \
                 `--model {nearest}`, which leaves them out)",
                without.join(", ")
            );
        }
        if self.effects.contains(&Effect::DepthDependentDamping) && relaxes {
            bail!(
                "no online estimator in the core models depth_dependent_damping together \
                 with relaxation (the nearest structure is `--model {nearest}`)"
            );
        }
        Ok(kind)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::data;
    use crate::diagnose::solver::{fit, Effort};
    use crate::generator;
    use estimator_core::conditioning::ImpactConfig;

    /// The spec of a fit evaluates to the fit's own prediction: the SI parameters and
    /// the absolute contact position and offset convert back exactly, for every effect.
    #[test]
    fn a_spec_reproduces_its_fit_for_every_effect() {
        let structures: [&[Effect]; 5] = [
            &[Effect::PowerLawStiffness, Effect::DepthDependentDamping],
            &[Effect::PowerLawStiffness, Effect::Relaxation],
            &[Effect::ExponentialStiffness, Effect::CoulombFriction],
            &[Effect::Inertia, Effect::TimeDelay, Effect::ForceOffset],
            &[
                Effect::ContactPointOffset,
                Effect::PlasticSet,
                Effect::ForceDrift,
            ],
        ];
        for (seed, effects) in structures.iter().enumerate() {
            let g = generator::generate(effects, 40 + seed as u64);
            let prepared = data::prepare(
                &g.log.time_s,
                &g.log.position_m,
                &g.log.force_n,
                ImpactConfig::default(),
            )
            .expect("a generated log prepares");
            let set: BTreeSet<Effect> = effects.iter().copied().collect();
            for linear_spring in [false, true] {
                let initial = Nonlinear {
                    linear_spring,
                    ..Nonlinear::default()
                };
                let knobs: Vec<_> = effects.iter().filter_map(|e| e.knob()).collect();
                let f = fit(&prepared, &set, &initial, &knobs, Effort::QUICK).expect("a fit");
                let spec = ModelSpec::of_fit(&f, &prepared, "generated").expect("a spec");
                spec.validate()
                    .expect("the spec of a physical fit is valid");
                let text = serde_json::to_string(&spec).expect("serialises");
                // (serde_json's default float parser may differ in the last bit.)
                let back: ModelSpec = serde_json::from_str(&text).expect("reads back");
                assert_eq!(back.effects, spec.effects);
                let force = back.force_n(&prepared);
                assert_eq!(force.len(), f.prediction.len());
                let range = f.prediction.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                let worst = force
                    .iter()
                    .zip(&f.prediction)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0f64, f64::max);
                assert!(
                    worst <= 1e-6 * range,
                    "{effects:?} (linear spring {linear_spring}): the spec's force differs \
                     from the fit's by {worst:e} N of {range:e}"
                );
            }
        }
    }

    fn valid() -> ModelSpec {
        ModelSpec {
            schema: SCHEMA.into(),
            source: "x.csv".into(),
            effects: vec![Effect::PowerLawStiffness, Effect::DepthDependentDamping],
            elastic: ElasticLaw::PowerLaw { k: 1e5, n: 1.5 },
            damping_lambda: 100.0,
            damping_exponent: 1.5,
            relaxation: None,
            mass_kg: None,
            mass_in_free_space: false,
            coulomb: None,
            delay_s: None,
            plastic_fraction: None,
            position_sign: 1.0,
            contact_position_m: 0.0,
            contact_shift_m: None,
            contact_shift_at_s: None,
            force_offset_n: 0.0,
            later_force_offset_n: None,
            later_force_offset_at_s: None,
            force_drift_n_per_s: None,
            nrmse_percent: 1.0,
            undetermined: BTreeMap::new(),
        }
    }

    #[test]
    fn bad_specs_name_the_field() {
        assert!(valid().validate().is_ok());
        type Spoil = fn(&mut ModelSpec);
        let cases: [(Spoil, &str); 11] = [
            (|s| s.schema = "other/1".into(), "field schema"),
            (
                |s| s.elastic = ElasticLaw::PowerLaw { k: -1.0, n: 1.5 },
                "field elastic.k",
            ),
            (|s| s.damping_lambda = f64::NAN, "field damping_lambda"),
            (
                |s| s.effects = vec![Effect::DepthDependentDamping],
                "field elastic",
            ),
            (
                |s| {
                    s.relaxation = Some(Relaxation {
                        relaxed_fraction: 0.3,
                        rate_per_s: 1.0,
                        initial_relaxing_n: 0.0,
                    })
                },
                "field relaxation",
            ),
            (|s| s.position_sign = 0.5, "field position_sign"),
            (
                |s| s.later_force_offset_at_s = Some(1.0),
                "field later_force_offset_at_s",
            ),
            (
                |s| {
                    s.effects.push(Effect::ForceOffset);
                    s.later_force_offset_n = Some(0.1);
                    s.later_force_offset_at_s = Some(-1.0);
                },
                "field later_force_offset_at_s",
            ),
            (
                |s| s.contact_shift_at_s = Some(1.0),
                "field contact_shift_at_s",
            ),
            (
                |s| {
                    s.effects.push(Effect::ContactPointOffset);
                    s.contact_shift_m = Some(1e-4);
                    s.contact_shift_at_s = Some(f64::NAN);
                },
                "field contact_shift_at_s",
            ),
            (|s| s.mass_in_free_space = true, "field mass_in_free_space"),
        ];
        for (spoil, field) in cases {
            let mut s = valid();
            spoil(&mut s);
            let e = s.validate().expect_err(field).to_string();
            assert!(e.contains(field), "{field}: {e}");
        }
    }

    #[test]
    fn the_online_estimator_follows_the_structure() {
        let mut s = valid();
        assert_eq!(s.online_estimator().unwrap(), ModelKind::HuntCrossley);
        s.effects = vec![Effect::PowerLawStiffness, Effect::Relaxation];
        assert_eq!(s.online_estimator().unwrap(), ModelKind::Hammerstein1);
        s.effects = vec![Effect::Relaxation, Effect::ForceOffset];
        assert_eq!(s.online_estimator().unwrap(), ModelKind::Zener);
        s.effects = vec![Effect::ContactPointOffset];
        assert_eq!(s.online_estimator().unwrap(), ModelKind::KelvinVoigt);
        s.effects = vec![Effect::ExponentialStiffness, Effect::TimeDelay];
        let e = s.online_estimator().unwrap_err().to_string();
        assert!(
            e.contains("exponential_stiffness, time_delay") && e.contains("kelvin-voigt"),
            "{e}"
        );
    }
}
