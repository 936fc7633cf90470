//! Online contact-environment estimation, `no_std`, fixed size, no heap.
//!
//! Implements the contact models and online estimators of L. Biagiotti and
//! C. Melchiorri, "Environment Estimation in Teleoperation Systems" (equation numbers
//! below refer to that chapter):
//!
//! | model | equations | model type | estimator |
//! |---|---|---|---|
//! | Kelvin-Voigt | (1) | [`models::KelvinVoigt`] | [`kelvin_voigt::KelvinVoigtEstimator`] (RLS, 20-24) |
//! | Zener | (2) | [`models::Zener`] | [`zener::ZenerEstimator`] (ARX, 18-19) |
//! | Hunt-Crossley | (3) | [`models::HuntCrossley`] | [`hunt_crossley::HuntCrossleyEstimator`] (double stage, 25-37), [`hunt_crossley::SingleStageHuntCrossleyEstimator`] |
//! | quasi-linear viscoelastic | (5)-(17) | [`models::QuasiLinearViscoelastic`] | via its Hammerstein form |
//! | Hammerstein | (38), Fig. 4/7 | [`models::Hammerstein`] | [`hammerstein::HammersteinEstimator`] (two phase, 39-42) |
//!
//! The per-sample entry point is [`pipeline::Pipeline::step`]: raw position and force in,
//! tare / impact detection / state-variable filter, then the estimator. The firmware's
//! 1 kHz task and the host tools call exactly that.
//!
//! Units are SI at every public boundary (m, m/s, N, s). Inside, each estimator works in
//! units chosen by [`Scaling`] so that its parameters are of order one.
//!
//! Nothing here panics on data: non-finite samples, logarithms of non-positive values,
//! a covariance that winds up or turns indefinite each have a [`Status`] flag and a
//! defined recovery.
#![cfg_attr(not(any(test, feature = "std")), no_std)]
#![forbid(unsafe_code)]
#![deny(missing_docs)]

pub mod any;
pub mod conditioning;
pub mod error;
pub mod estimator;
mod fmath;
pub mod hammerstein;
pub mod hunt_crossley;
pub mod kelvin_voigt;
pub mod laws;
pub mod models;
pub mod monitor;
pub mod pipeline;
#[cfg(feature = "protocol")]
pub mod protocol;
pub mod rls;
pub mod sensors;
pub mod status;
pub mod telemetry;
pub mod zener;

pub use any::{AnyEstimator, AnyParameters, EstimatorSettings, ModelKind};
pub use error::ConfigError;
pub use estimator::{ContactSample, Estimate, Estimator, SampleUpdate, Scaling};
pub use pipeline::{
    Pipeline, PipelineConfig, PipelineOutput, PipelineUpdate, RawSample, SignalConditioning,
};
pub use status::Status;
