//! Signal conditioning of the paper's experiments (Sec. 5), in parts that each do one thing:
//!
//! - [`svf`]: the state-variable filter that gives δ̇ (and filtered δ and F);
//! - [`tare`]: the load cell's force offset and noise level, confirmed by free-space
//!   evidence rather than assumed from the first samples;
//! - [`impact`]: contact onset and loss, and the contact point x_contact (δ = x − x_contact),
//!   detected from the force or given as a known surface;
//! - [`refinement`]: the power-law extrapolation of a detected contact point.
//!
//! [`crate::Pipeline`] wires them together per sample.

pub mod impact;
pub mod refinement;
pub mod svf;
pub mod tare;

pub use impact::{ImpactConfig, ImpactDetector, ImpactUpdate, RecontactPolicy, Surface};
pub use refinement::{OnsetPair, OnsetRefiner, RefinementConfig, RisePoint};
pub use svf::{StateVariableFilter, StateVariableFilterConfig};
pub use tare::{ForceTare, OffsetPrior, TareConfig, TareUpdate};

/// Contact state of the probe.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ContactState {
    /// Collecting the start-up samples of the force offset; no contact seen yet.
    #[default]
    Taring,
    /// Out of contact.
    FreeSpace,
    /// In contact: δ is defined.
    InContact,
}
