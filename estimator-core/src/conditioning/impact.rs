//! Impact detection (Sec. 5: "the penetration δ is measured by comparing the current motor
//! position with the position measured at the time of impact"): the contact state and the
//! contact point x_contact from which δ = x − x_contact is measured.

use crate::error::{check, positive, ConfigError};
use crate::fmath::{max, min};
use crate::Status;

use super::ContactState;

/// Which contact point δ is measured from after the first contact.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum RecontactPolicy {
    /// The position of the first impact, for the whole run (the paper, Sec. 5).
    FirstImpact,
    /// Each new impact defines a new contact point (follows a surface that moves, e.g.
    /// after plastic set or a change of object).
    #[default]
    EachImpact,
}

/// Where the material's surface is.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Surface {
    /// Found online at each impact from the force (the paper's rig).
    #[default]
    Detected,
    /// Known (e.g. a host's whole-record fit of the contact point): contact is geometric,
    /// δ = x − `position_m` > 0, except while the probe retracts faster than the material
    /// recovers (the force stays below the release threshold for `loss_samples` while δ
    /// decreases: the probe has separated from the surface).
    Known {
        /// Surface position \[m\], on the position axis (positive into the material).
        position_m: f32,
    },
}

/// Configuration of [`ImpactDetector`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct ImpactConfig {
    /// Minimum onset threshold on the tared force \[N\].
    pub onset_threshold_n: f32,
    /// The onset threshold is at least this many force-noise standard deviations.
    pub noise_multiplier: f32,
    /// The contact point is the last position at which the tared force was below this
    /// fraction of the onset threshold (back-tracks the detection delay); the release
    /// threshold is the same fraction of the onset threshold.
    pub contact_point_fraction: f32,
    /// Contact is lost after this many consecutive samples below the release threshold.
    pub loss_samples: u32,
    /// Contact point after re-contact (ignored with a known surface).
    pub recontact: RecontactPolicy,
    /// Detected online, or known.
    pub surface: Surface,
}

impl Default for ImpactConfig {
    fn default() -> Self {
        ImpactConfig {
            onset_threshold_n: 0.1,
            noise_multiplier: 6.0,
            contact_point_fraction: 0.25,
            loss_samples: 10,
            recontact: RecontactPolicy::EachImpact,
            surface: Surface::Detected,
        }
    }
}

impl ImpactConfig {
    /// Validates the config.
    ///
    /// # Errors
    /// [`ConfigError`] naming the bad field.
    pub fn validate(&self) -> Result<(), ConfigError> {
        positive("onset_threshold_n", self.onset_threshold_n)?;
        check(
            "noise_multiplier",
            self.noise_multiplier,
            |v| v >= 0.0,
            ">= 0",
        )?;
        check(
            "contact_point_fraction",
            self.contact_point_fraction,
            |v| v > 0.0 && v < 1.0,
            "(0, 1)",
        )?;
        if self.loss_samples == 0 {
            return Err(ConfigError::OutOfRange {
                field: "loss_samples",
                value: 0.0,
                expected: ">= 1",
            });
        }
        if let Surface::Known { position_m } = self.surface {
            check("surface.position_m", position_m, |_| true, "finite")?;
        }
        Ok(())
    }

    /// Onset threshold \[N\] for a force noise of `noise_n` \[N\].
    pub fn onset_threshold(&self, noise_n: f32) -> f32 {
        max(self.onset_threshold_n, self.noise_multiplier * noise_n)
    }

    /// Release threshold \[N\] for a force noise of `noise_n` \[N\].
    pub fn release_threshold(&self, noise_n: f32) -> f32 {
        self.contact_point_fraction * self.onset_threshold(noise_n)
    }
}

/// Result of one [`ImpactDetector::update`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImpactUpdate {
    /// State after this sample ([`ContactState::FreeSpace`] or [`ContactState::InContact`]).
    pub state: ContactState,
    /// [`Status::CONTACT_ONSET`], [`Status::CONTACT_LOST`] and/or [`Status::NO_CONTACT`].
    pub status: Status,
}

/// Contact state and contact point from the tared force (threshold with back-tracking, the
/// paper's impact detection) or from a known surface.
///
/// Impact: the tared force exceeds [`ImpactConfig::onset_threshold`]; the contact point is
/// the last position at which the force was still below the release threshold, which
/// removes most of the detection delay, never behind the shallowest free-space position
/// before it. Loss: `loss_samples` consecutive samples below the release threshold.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImpactDetector {
    config: ImpactConfig,
    state: ContactState,
    last_quiet_position_m: f32,
    contact_position_m: f32,
    first_contact_position_m: f32,
    has_first_contact: bool,
    below_count: u32,
    free_space_min_position_m: f32,
}

impl ImpactDetector {
    /// Builds the detector, out of contact.
    ///
    /// # Errors
    /// [`ConfigError`] if the config is invalid.
    pub fn try_new(config: ImpactConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        let contact_position_m = match config.surface {
            Surface::Detected => f32::NAN,
            Surface::Known { position_m } => position_m,
        };
        Ok(ImpactDetector {
            config,
            state: ContactState::FreeSpace,
            last_quiet_position_m: f32::NAN,
            contact_position_m,
            first_contact_position_m: f32::NAN,
            has_first_contact: false,
            below_count: 0,
            free_space_min_position_m: f32::INFINITY,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &ImpactConfig {
        &self.config
    }

    /// [`ContactState::InContact`] or [`ContactState::FreeSpace`].
    pub fn state(&self) -> ContactState {
        self.state
    }

    /// `true` in contact.
    pub fn in_contact(&self) -> bool {
        self.state == ContactState::InContact
    }

    /// Contact position x_contact of the current (or last) contact \[m\]; NaN before the
    /// first one (with a detected surface).
    pub fn contact_position_m(&self) -> f32 {
        self.contact_position_m
    }

    /// Shallowest position \[m\] the probe held in free space before the current contact: no
    /// contact point can lie behind it.
    pub fn free_space_min_position_m(&self) -> f32 {
        self.free_space_min_position_m
    }

    /// Moves the current contact point (an onset refinement, see
    /// [`super::refinement::OnsetRefiner`]); under [`RecontactPolicy::FirstImpact`] the first
    /// impact's point moves with it while it is the one in use. Non-finite values and a
    /// known surface are left alone.
    pub fn set_contact_position(&mut self, position_m: f32) {
        if !position_m.is_finite() || matches!(self.config.surface, Surface::Known { .. }) {
            return;
        }
        if self.has_first_contact && self.first_contact_position_m == self.contact_position_m {
            self.first_contact_position_m = position_m;
        }
        self.contact_position_m = position_m;
    }

    /// Ends a contact at once (a commanded tare: the probe is declared free).
    pub fn release(&mut self, position_m: f32) {
        self.state = ContactState::FreeSpace;
        self.below_count = 0;
        self.last_quiet_position_m = position_m;
        self.free_space_min_position_m = position_m;
    }

    /// Processes one sample: raw `position_m` \[m\] (positive into the material), the
    /// tared force \[N\], the probe's speed \[m/s\], the force noise σ \[N\], and whether a
    /// contact may be declared yet (`armed`: the tare has seen enough samples for σ to
    /// mean something).
    pub fn update(
        &mut self,
        position_m: f32,
        tared_force_n: f32,
        speed_m_per_s: f32,
        noise_n: f32,
        armed: bool,
    ) -> ImpactUpdate {
        let onset = self.config.onset_threshold(noise_n);
        let release = self.config.release_threshold(noise_n);
        let status = match self.config.surface {
            Surface::Known { position_m: x_c } => self.known_surface(
                position_m - x_c,
                tared_force_n,
                speed_m_per_s,
                onset,
                release,
            ),
            Surface::Detected => self.detected(position_m, tared_force_n, onset, release, armed),
        };
        ImpactUpdate {
            state: self.state,
            status: if self.in_contact() {
                status
            } else {
                status | Status::NO_CONTACT
            },
        }
    }

    fn known_surface(
        &mut self,
        depth_m: f32,
        tared_force_n: f32,
        speed_m_per_s: f32,
        onset: f32,
        release: f32,
    ) -> Status {
        if depth_m <= 0.0 {
            self.below_count = 0;
            if self.in_contact() {
                self.state = ContactState::FreeSpace;
                return Status::CONTACT_LOST;
            }
            return Status::empty();
        }
        if !self.in_contact() {
            // Back on the surface, or pressed again after a separation.
            if self.below_count == 0 || tared_force_n > onset {
                self.state = ContactState::InContact;
                self.below_count = 0;
                return Status::CONTACT_ONSET;
            }
            return Status::empty();
        }
        if speed_m_per_s < 0.0 && tared_force_n < release {
            self.below_count += 1;
            if self.below_count >= self.config.loss_samples {
                self.state = ContactState::FreeSpace;
                return Status::CONTACT_LOST;
            }
        } else if tared_force_n >= release {
            self.below_count = 0;
        }
        Status::empty()
    }

    fn detected(
        &mut self,
        position_m: f32,
        tared_force_n: f32,
        onset: f32,
        release: f32,
        armed: bool,
    ) -> Status {
        if self.in_contact() {
            if tared_force_n < release {
                self.below_count += 1;
                if self.below_count >= self.config.loss_samples {
                    self.state = ContactState::FreeSpace;
                    self.last_quiet_position_m = position_m;
                    self.free_space_min_position_m = position_m;
                    return Status::CONTACT_LOST;
                }
            } else {
                self.below_count = 0;
            }
            return Status::empty();
        }
        if armed && tared_force_n > onset {
            let back_tracked = if self.last_quiet_position_m.is_finite() {
                self.last_quiet_position_m
            } else {
                position_m
            };
            self.contact_position_m = match self.config.recontact {
                RecontactPolicy::FirstImpact if self.has_first_contact => {
                    self.first_contact_position_m
                }
                _ => back_tracked,
            };
            if !self.has_first_contact {
                self.first_contact_position_m = self.contact_position_m;
                self.has_first_contact = true;
            }
            self.state = ContactState::InContact;
            self.below_count = 0;
            return Status::CONTACT_ONSET;
        }
        self.free_space_min_position_m = min(self.free_space_min_position_m, position_m);
        if tared_force_n <= release {
            self.last_quiet_position_m = position_m;
        }
        Status::empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn detector(surface: Surface) -> ImpactDetector {
        ImpactDetector::try_new(ImpactConfig {
            surface,
            ..ImpactConfig::default()
        })
        .unwrap()
    }

    #[test]
    fn contact_point_is_backtracked_to_the_last_quiet_position() {
        let mut det = detector(Surface::Detected);
        // A 10 mm/s approach into a 5 N/mm spring whose surface is at x = 3.000 mm.
        let mut onset_at = None;
        for h in 0..600 {
            let x = 1.0e-5 * h as f32;
            let f = 5000.0 * (x - 3.0e-3).max(0.0);
            let u = det.update(x, f, 1e-2, 0.0, true);
            if u.status.contains(Status::CONTACT_ONSET) {
                onset_at = Some(h);
            }
        }
        assert!(onset_at.is_some());
        assert!(
            (det.contact_position_m() - 3.0e-3).abs() < 1.0e-5,
            "{}",
            det.contact_position_m()
        );
        assert_eq!(det.state(), ContactState::InContact);
    }

    #[test]
    fn contact_is_lost_and_found_again() {
        let mut det = detector(Surface::Detected);
        det.update(0.0, 0.0, 0.0, 0.0, true);
        det.update(1e-3, 1.0, 0.0, 0.0, true);
        assert!(det.in_contact());
        let mut lost = false;
        for _ in 0..20 {
            lost |= det
                .update(0.0, 0.0, 0.0, 0.0, true)
                .status
                .contains(Status::CONTACT_LOST);
        }
        assert!(lost && !det.in_contact());
        let u = det.update(2e-3, 1.0, 0.0, 0.0, true);
        assert!(u.status.contains(Status::CONTACT_ONSET));
        // Not armed: no contact.
        let mut det = detector(Surface::Detected);
        assert!(!det
            .update(0.0, 5.0, 0.0, 0.0, false)
            .status
            .contains(Status::CONTACT_ONSET));
    }

    #[test]
    fn a_known_surface_gives_geometric_contact_and_detects_separation() {
        let mut det = detector(Surface::Known { position_m: 1e-3 });
        assert_eq!(det.contact_position_m(), 1e-3);
        assert!(!det
            .update(0.9e-3, 0.0, 1e-3, 0.01, true)
            .state
            .eq(&ContactState::InContact));
        // Just past the surface with no force yet: in contact (no selection on the force).
        let u = det.update(1.001e-3, 0.0, 1e-3, 0.01, true);
        assert!(u.status.contains(Status::CONTACT_ONSET));
        for _ in 0..50 {
            det.update(1.5e-3, 2.0, 0.0, 0.01, true);
        }
        // Fast retraction: the force drops to zero while δ > 0 — separated after 10.
        let mut lost_at = None;
        for h in 0..20 {
            let u = det.update(1.4e-3, 0.0, -0.1, 0.01, true);
            if u.status.contains(Status::CONTACT_LOST) {
                lost_at = Some(h);
            }
        }
        assert_eq!(lost_at, Some(9));
        // Pressed again at the same depth: contact once the force is back above onset.
        assert!(!det
            .update(1.4e-3, 0.05, 0.0, 0.01, true)
            .state
            .eq(&ContactState::InContact));
        assert!(det
            .update(1.4e-3, 0.5, 0.0, 0.01, true)
            .status
            .contains(Status::CONTACT_ONSET));
        // Leaving geometrically ends the contact at once.
        assert!(det
            .update(0.99e-3, 0.0, -0.1, 0.01, true)
            .status
            .contains(Status::CONTACT_LOST));
    }
}
