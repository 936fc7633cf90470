//! Per-sample status flags.
//!
//! Every `step` in this crate returns a [`Status`] next to its numbers. A flag never means
//! "the numbers are garbage": each one names a situation that the 1 kHz loop handled with a
//! defined recovery (skip the update, hold the last estimate, reset the covariance), so the
//! caller can always use the estimate it was handed and decide what to tell the operator.

bitflags::bitflags! {
    /// Bit set describing what happened during one sample.
    ///
    /// The recovery attached to each flag is documented on the flag. Flags from the
    /// pipeline stages are OR-ed together, so a pipeline output carries every condition
    /// met on the way (contact detection, estimator guards, covariance handling).
    #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
    #[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
    #[cfg_attr(feature = "serde", serde(transparent))]
    pub struct Status: u32 {
        /// The probe is not in contact: the estimator was not updated and the last
        /// estimate is held.
        const NO_CONTACT = 1 << 0;
        /// A sample held NaN or ±∞: the update was skipped, the last estimate is held.
        const NON_FINITE_INPUT = 1 << 1;
        /// Depth δ was at or below the configured minimum before a logarithm
        /// (Hunt-Crossley Γ2, Hammerstein Γ1): that stage was skipped.
        const GUARD_DEPTH = 1 << 2;
        /// Force F was at or below the configured minimum before a logarithm: that stage
        /// was skipped.
        const GUARD_FORCE = 1 << 3;
        /// The damping term is out of the range the regression needs: k̂ + λ̂·δ̇ ≤ 0 in the
        /// double stage (Γ2, eq. 31: the logarithm is undefined, Γ2 skipped), or
        /// |λ̂/k̂·δ̇| beyond the single stage's linearisation bound (the ratio is projected
        /// back to the bound before the update).
        const GUARD_IMPEDANCE = 1 << 4;
        /// The covariance trace hit its bound: forgetting was reduced for this sample so
        /// that P cannot wind up while excitation is missing (anti-windup).
        const COVARIANCE_BOUNDED = 1 << 5;
        /// The covariance became non-finite or lost positive definiteness and was reset to
        /// its initial value c·I; θ̂ was kept.
        const COVARIANCE_RESET = 1 << 6;
        /// The regression parameters do not map to physical ones (e.g. a non-positive
        /// Zener time constant): the last physical parameters are held.
        const NONPHYSICAL = 1 << 7;
        /// Hammerstein: the elastic-response stage Γ1 was updated (δ̇ > δ̇*, eq. 41-42).
        const ELASTIC_STAGE_ACTIVE = 1 << 8;
        /// Contact began at this sample (impact detected).
        const CONTACT_ONSET = 1 << 9;
        /// Contact was lost at this sample.
        const CONTACT_LOST = 1 << 10;
        /// Contact was detected before the force offset (tare) had settled: the offset in
        /// use comes from fewer samples than configured.
        const TARE_INCOMPLETE = 1 << 11;
        /// The sample was missing (dropped by the acquisition): the filters coasted on
        /// the previous sample and no update was made.
        const SAMPLE_DROPPED = 1 << 12;
        /// A raw input sat at its sensor limit (ADC full scale): the update was skipped.
        const SATURATED = 1 << 13;
        /// The residual monitor found the innovation outside its expected band for longer
        /// than the configured time: the model is missing an effect.
        const MODEL_MISMATCH = 1 << 14;
        /// The regressor carried too little excitation for this update to be informative
        /// (e.g. Γ2 with ln δ ≈ 0): the update was skipped.
        const LOW_EXCITATION = 1 << 15;
        /// Contact has begun but its contact point is still being refined (the force has
        /// not yet reached twice the onset threshold): depths are provisional, so the
        /// estimator is held. Only for models with a power-law onset.
        const CONTACT_PENDING = 1 << 16;
        /// The caller paused estimation (e.g. to fit only the loading phase of a test, or
        /// an operator command): the estimator was not updated, the last estimate is held.
        const ESTIMATION_PAUSED = 1 << 17;
        /// The force offset (tare) has not been confirmed by a free-space stretch of the
        /// record (the probe moving while the force stays flat, or a lift-off): it is the
        /// configured prior (a stored calibration zero, or 0). Forces and estimates are
        /// relative to that prior until a lift-off is seen or a tare is commanded
        /// ([`crate::Pipeline::request_tare`]).
        const OFFSET_UNCERTAIN = 1 << 18;
        /// A free-space stretch moved the force offset by more than the onset threshold
        /// (the provisional offset was a contact force, or the load cell's zero shifted):
        /// the estimator was restarted, since everything it learned was measured from the
        /// wrong zero, and the contact state is re-evaluated with the new offset.
        const OFFSET_CORRECTED = 1 << 19;
    }
}

impl Status {
    /// `true` when the sample was processed without any condition that skipped or
    /// degraded the parameter update (contact onset/loss are informational and ignored).
    pub fn is_nominal(self) -> bool {
        let informational = Status::CONTACT_ONSET | Status::ELASTIC_STAGE_ACTIVE;
        (self - informational).is_empty()
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for Status {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(f, "Status({=u32:#x})", self.bits())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nominal_ignores_informational_flags() {
        assert!(Status::empty().is_nominal());
        assert!(Status::CONTACT_ONSET.is_nominal());
        assert!(!Status::NO_CONTACT.is_nominal());
        assert!(!(Status::CONTACT_ONSET | Status::GUARD_FORCE).is_nominal());
    }
}
