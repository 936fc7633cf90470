//! The sample timer (TIM2) and the period clock (TIM5), the same register code on every
//! target (RM0090 §18, general-purpose timers TIM2 to TIM5, both 32-bit).
//!
//! - TIM2 counts microseconds and wraps every period; its update event is TRGO
//!   (CR2.MMS = 010), which starts the ADC's oversampled scan on the boards (ADC external
//!   trigger "TIM2_TRGO", RM0090 Table 69). The sample task runs on the TIM2 interrupt:
//!   on the boards at compare 1, [`READ_DELAY_US`] after the update, when the 16
//!   conversions (73 µs) are in memory; under QEMU, whose timer model raises no compare
//!   events, at the update itself.
//! - TIM5 free-runs at 1 MHz over its 32 bits (71 min). The sample task reads it each
//!   period: more than one period since the last run means periods were lost entirely
//!   (interrupts masked, a flash erase stalling the bus), which an overrun flag alone
//!   cannot see.
//!
//! Both timers run from the same timer clock, so they do not drift against each other.

use stm32f4::stm32f405 as pac;

/// Period of the sample timer \[µs\].
pub const PERIOD_US: u32 = 1_000_000 / super::SAMPLE_RATE_HZ;
/// Delay from the conversion trigger (TIM2 update) to the sample task (TIM2 compare 1)
/// on the boards \[µs\]: 16 conversions × (84 + 12) ADC clocks at 21 MHz = 73 µs, plus
/// margin.
pub const READ_DELAY_US: u32 = 100;

/// Which TIM2 event raises the sample interrupt.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum SampleEvent {
    /// Update (counter wrap): QEMU, which models no compare events.
    Update,
    /// Compare 1, [`READ_DELAY_US`] after the update: the boards.
    Compare1,
}

/// TIM2, the 1 kHz sample timer.
pub struct SampleTimer {
    tim: pac::TIM2,
    event: SampleEvent,
}

impl SampleTimer {
    /// Starts TIM2 at 1 µs per count from a `timer_clock_hz` input (its bus clock must be
    /// enabled), one period per [`PERIOD_US`], TRGO on update, interrupt on `event`.
    pub fn start(tim: pac::TIM2, timer_clock_hz: u32, event: SampleEvent) -> Self {
        let prescaler = timer_clock_hz / 1_000_000 - 1;
        tim.psc().write(|w| w.psc().set(prescaler as u16));
        tim.arr().write(|w| w.arr().set(PERIOD_US - 1));
        tim.cr2().write(|w| w.mms().update());
        tim.ccr1().write(|w| w.ccr().set(READ_DELAY_US));
        tim.dier().write(|w| match event {
            SampleEvent::Update => w.uie().set_bit(),
            SampleEvent::Compare1 => w.cc1ie().set_bit(),
        });
        // Load the prescaler now, then start without a pending interrupt.
        tim.egr().write(|w| w.ug().set_bit());
        tim.sr().write(|w| unsafe { w.bits(0) });
        tim.cr1().modify(|_, w| w.cen().set_bit());
        SampleTimer { tim, event }
    }

    /// Acknowledges this period's interrupt.
    #[inline]
    pub fn clear(&mut self) {
        // rc_w0 flags: writing 0 clears, writing 1 leaves a flag as it is.
        self.tim.sr().write(|w| match self.event {
            SampleEvent::Update => unsafe { w.bits(!1) },
            SampleEvent::Compare1 => unsafe { w.bits(!(1 << 1)) },
        });
    }

    /// `true` if the next period's interrupt is already pending (deadline missed).
    #[inline]
    pub fn overran(&self) -> bool {
        let sr = self.tim.sr().read();
        match self.event {
            SampleEvent::Update => sr.uif().bit_is_set(),
            SampleEvent::Compare1 => sr.cc1if().bit_is_set(),
        }
    }

    /// Stops the interrupts (end of the QEMU run).
    #[cfg_attr(not(feature = "qemu"), allow(dead_code))]
    pub fn stop(&mut self) {
        self.tim.dier().write(|w| unsafe { w.bits(0) });
    }
}

/// TIM5 free-running at 1 MHz: counts sample periods, including those no task saw.
pub struct PeriodClock {
    tim: pac::TIM5,
    last_us: Option<u32>,
}

impl PeriodClock {
    /// Starts TIM5 at 1 µs per count from `timer_clock_hz` (bus clock enabled).
    pub fn start(tim: pac::TIM5, timer_clock_hz: u32) -> Self {
        let prescaler = timer_clock_hz / 1_000_000 - 1;
        tim.psc().write(|w| w.psc().set(prescaler as u16));
        tim.arr().write(|w| w.arr().set(u32::MAX));
        tim.egr().write(|w| w.ug().set_bit());
        tim.cr1().modify(|_, w| w.cen().set_bit());
        PeriodClock { tim, last_us: None }
    }

    /// Call once per sample task: the whole periods that passed since the previous call
    /// without a task run (0 normally). Rounded to the nearest period, so interrupt
    /// latency jitter does not count.
    #[inline]
    pub fn lost_periods(&mut self) -> u32 {
        let now = self.tim.cnt().read().bits();
        let lost = match self.last_us {
            Some(last) => ((now.wrapping_sub(last) + PERIOD_US / 2) / PERIOD_US).saturating_sub(1),
            None => 0,
        };
        self.last_us = Some(now);
        lost
    }
}
