//! Zener (standard linear solid) estimator: the ARX form of eqs. (18)-(19).
//!
//! Eq. (18): F(h) = −θ1·F(h−1) + θ2·δ(h) + θ3·δ(h−1) with
//! θ1 = (κ1+κ2)/λ·T − 1, θ2 = κ1, θ3 = κ1κ2/λ·T − κ1.
//!
//! At T = 1 ms the three regressors of (18) are almost collinear (δ(h) ≈ δ(h−1) and
//! F(h−1) ≈ F(h)), which an f32 RLS cannot resolve. The estimator therefore runs RLS on
//! the same equation rearranged exactly (the "delta form" of (18)):
//!
//! ```text
//! F(h) − F(h−1) = −a·T·F(h−1) + κ1·(δ(h) − δ(h−1)) + c·T·δ(h−1)
//! a = (θ1 + 1)/T = (κ1+κ2)/λ,   c = (θ2 + θ3)/T = κ1κ2/λ
//! ```
//!
//! which has the same least-squares solution but well separated regressors.
//! [`ZenerEstimator::arx_parameters`] returns θ1..θ3 of (18).
//!
//! Mapping back to physical parameters. Eq. (18) is a forward-Euler discretisation; read
//! literally its mapping is off by O(a·T/2) when the data come from a continuous
//! material. The mapping here uses the three invariants of any discretisation of (2):
//! the instantaneous gain κ1 = θ2, the static gain κ∞ = κ1κ2/(κ1+κ2) = c/a (the DC gain of
//! the ARX model), and the pole, mapped exactly (z = e^{sT}): a = −ln(−θ1)/T. Then
//! κ2 = κ1·κ∞/(κ1 − κ∞) and λ = (κ1 + κ2)/a. A θ̂ without such a mapping
//! (pole outside (0, 1), κ∞ ∉ (0, κ1)) holds the last physical values and sets
//! [`Status::NONPHYSICAL`].

use nalgebra::Vector3;

use crate::error::{positive, ConfigError};
use crate::estimator::{finite_or, ContactSample, Estimator, SampleUpdate, Scaling};
use crate::rls::{Rls, RlsConfig};
use crate::Status;

/// Zener parameters, eq. (2) and Fig. 2b.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ZenerParameters {
    /// Series (instantaneous) spring κ1 \[N/m\].
    pub kappa1: f32,
    /// Parallel spring κ2 \[N/m\].
    pub kappa2: f32,
    /// Damper λ \[N·s/m\].
    pub lambda: f32,
}

/// Configuration of [`ZenerEstimator`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct ZenerConfig {
    /// Sample time T \[s\] (1e-3 in the paper).
    pub sample_time_s: f32,
    /// Internal units.
    pub scaling: Scaling,
    /// RLS settings for θ = \[a, κ1, c\] in internal units.
    pub rls: RlsConfig,
}

impl Default for ZenerConfig {
    fn default() -> Self {
        ZenerConfig {
            sample_time_s: 1.0e-3,
            scaling: Scaling::default(),
            rls: RlsConfig {
                initial_covariance: 1.0e4,
                forgetting: crate::rls::Forgetting::Fixed { beta: 0.9995 },
                ..RlsConfig::default()
            },
        }
    }
}

impl ZenerConfig {
    /// Validates the config.
    ///
    /// # Errors
    /// [`ConfigError`] naming the bad field.
    pub fn validate(&self) -> Result<(), ConfigError> {
        positive("sample_time_s", self.sample_time_s)?;
        self.scaling.validate()?;
        self.rls.validate()
    }
}

/// Online Zener estimator (eqs. 2, 18-19, 23).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ZenerEstimator {
    config: ZenerConfig,
    rls: Rls<3>,
    previous_depth: f32,
    previous_force: f32,
    physical: ZenerParameters,
}

impl ZenerEstimator {
    /// Builds the estimator with θ̂(0) = 0.
    ///
    /// # Errors
    /// [`ConfigError`] if the config is invalid.
    pub fn try_new(config: ZenerConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        Ok(ZenerEstimator {
            config,
            rls: Rls::try_new(&config.rls)?,
            previous_depth: 0.0,
            previous_force: 0.0,
            physical: ZenerParameters::default(),
        })
    }

    /// θ1, θ2, θ3 of eq. (18), in SI (θ2, θ3 in N/m).
    pub fn arx_parameters(&self) -> [f32; 3] {
        let t = self.config.sample_time_s;
        let th = self.rls.theta();
        let k = self.config.scaling.force_n / self.config.scaling.length_m;
        [th[0] * t - 1.0, th[1] * k, (th[2] * t - th[1]) * k]
    }

    /// Maps θ = \[a, κ1, c\] (internal units) to physical parameters, or `None`.
    fn map(&self, th: &Vector3<f32>) -> Option<ZenerParameters> {
        let t = self.config.sample_time_s;
        let unit = self.config.scaling.force_n / self.config.scaling.length_m;
        let (a_euler, kappa1, c) = (th[0], th[1], th[2]);
        let pole = 1.0 - a_euler * t;
        if !(pole > 0.0 && pole < 1.0 && kappa1 > 0.0) {
            return None;
        }
        let a = -libm::logf(pole) / t;
        let k_inf = c / a_euler;
        if !(k_inf > 0.0 && k_inf < kappa1) {
            return None;
        }
        let kappa2 = kappa1 * k_inf / (kappa1 - k_inf);
        let lambda = (kappa1 + kappa2) / a;
        let p = ZenerParameters {
            kappa1: kappa1 * unit,
            kappa2: kappa2 * unit,
            lambda: lambda * unit,
        };
        (p.kappa1.is_finite() && p.kappa2.is_finite() && p.lambda.is_finite()).then_some(p)
    }
}

impl Estimator for ZenerEstimator {
    type Parameters = ZenerParameters;

    fn update(&mut self, sample: &ContactSample) -> SampleUpdate {
        let s = self.config.scaling;
        let t = self.config.sample_time_s;
        let (d, _, f) = s.to_internal(sample);
        let phi = Vector3::new(
            -t * self.previous_force,
            d - self.previous_depth,
            t * self.previous_depth,
        );
        let y = f - self.previous_force;
        let predicted = self.previous_force + self.rls.predict(&phi);
        let mut status = Status::empty();
        if !sample.is_finite() {
            return SampleUpdate {
                predicted_force_n: finite_or(predicted * s.force_n, 0.0),
                status: Status::NON_FINITE_INPUT,
            };
        }
        let beta = self
            .config
            .rls
            .forgetting
            .beta((f - predicted).abs() * s.force_n);
        status |= self.rls.update(&phi, y, beta).status;
        self.previous_depth = d;
        self.previous_force = f;
        match self.map(self.rls.theta()) {
            Some(p) => self.physical = p,
            None => status |= Status::NONPHYSICAL,
        }
        SampleUpdate {
            predicted_force_n: finite_or(predicted * s.force_n, 0.0),
            status,
        }
    }

    fn parameters(&self) -> ZenerParameters {
        self.physical
    }

    fn standard_errors(&self) -> ZenerParameters {
        // Delta method by finite differences of the mapping around θ̂.
        let th = *self.rls.theta();
        let se = self.rls.standard_errors();
        let Some(p0) = self.map(&th) else {
            return ZenerParameters {
                kappa1: f32::INFINITY,
                kappa2: f32::INFINITY,
                lambda: f32::INFINITY,
            };
        };
        let mut var = [0.0f32; 3];
        for i in 0..3 {
            let mut th_i = th;
            let h = if se[i] > 0.0 {
                se[i]
            } else {
                1e-6 * th[i].abs().max(1e-6)
            };
            th_i[i] += h;
            if let Some(p) = self.map(&th_i) {
                let ds = [
                    p.kappa1 - p0.kappa1,
                    p.kappa2 - p0.kappa2,
                    p.lambda - p0.lambda,
                ];
                let scale = if se[i] > 0.0 { 1.0 } else { 0.0 };
                for j in 0..3 {
                    var[j] += (ds[j] * scale) * (ds[j] * scale);
                }
            }
        }
        ZenerParameters {
            kappa1: libm::sqrtf(var[0]),
            kappa2: libm::sqrtf(var[1]),
            lambda: libm::sqrtf(var[2]),
        }
    }

    fn start_contact(&mut self) {
        self.previous_depth = 0.0;
        self.previous_force = 0.0;
    }

    /// Starts the ARX coefficients at the model `p`: θ = \[a, κ1, c\] with the pole
    /// 1 − a·T = e^{−(κ1+κ2)·T/λ} (the relaxation rate at a held depth, mapped exactly as
    /// [`ZenerEstimator`] maps it back), κ1, and c = κ∞·a, κ∞ = κ1κ2/(κ1 + κ2). Parameters
    /// that are not all positive and finite are ignored.
    fn start_from(&mut self, p: &ZenerParameters) {
        let t = self.config.sample_time_s;
        let unit = self.config.scaling.force_n / self.config.scaling.length_m;
        let (k1, k2, lambda) = (p.kappa1, p.kappa2, p.lambda);
        if !(k1 > 0.0 && k2 > 0.0 && lambda > 0.0) {
            return;
        }
        let a_euler = -libm::expm1f(-(k1 + k2) / lambda * t) / t;
        let k_inf = k1 * k2 / (k1 + k2);
        let theta = Vector3::new(a_euler, k1 / unit, k_inf / unit * a_euler);
        if let Some(physical) = self.map(&theta) {
            self.rls.restart_from(theta);
            self.physical = physical;
        }
    }

    fn reset(&mut self) {
        self.rls.reset();
        self.previous_depth = 0.0;
        self.previous_force = 0.0;
        // The start ([`Estimator::start_from`]) if there is one, else no estimate yet.
        self.physical = self.map(self.rls.theta()).unwrap_or_default();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A start from known parameters (a host's whole-record fit) is the estimate until
    /// data move it, and where a reset returns; unphysical ones are ignored.
    #[test]
    fn starts_from_known_parameters_and_resets_there() {
        let start = ZenerParameters {
            kappa1: 3.2e4,
            kappa2: 3.4e4,
            lambda: 6.0e4,
        };
        let mut e = ZenerEstimator::try_new(ZenerConfig::default()).unwrap();
        assert_eq!(e.parameters(), ZenerParameters::default());
        e.start_from(&start);
        let close = |p: ZenerParameters| {
            [
                (p.kappa1, start.kappa1),
                (p.kappa2, start.kappa2),
                (p.lambda, start.lambda),
            ]
            .iter()
            .all(|(a, b)| ((a - b) / b).abs() < 1e-3)
        };
        assert!(close(e.parameters()), "{:?}", e.parameters());
        for i in 0..200 {
            let d = 1e-3 * (i as f32 * 0.05).sin().abs();
            e.update(&ContactSample {
                depth_m: d,
                depth_rate_m_per_s: 0.0,
                force_n: 50.0 * d,
            });
        }
        e.reset();
        assert!(close(e.parameters()), "{:?}", e.parameters());
        let mut fresh = ZenerEstimator::try_new(ZenerConfig::default()).unwrap();
        fresh.start_from(&ZenerParameters {
            kappa2: -1.0,
            ..start
        });
        assert_eq!(fresh.parameters(), ZenerParameters::default());
    }
}
