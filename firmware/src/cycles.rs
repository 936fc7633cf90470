//! Counting instructions (QEMU) or core cycles (board) with SysTick.
//!
//! SysTick free-runs from its 24-bit reload at the core clock. On the board one count is
//! one core cycle (168 MHz). Under QEMU with `-icount shift=0` one instruction takes 1 ns
//! of guest time and SysTick still counts at 168 MHz, so instructions = counts·1000/168
//! (../shared/FIRMWARE-NOTES.md; DWT CYCCNT reads 0 there). Spans must stay below the
//! 24-bit wrap (0.1 s).

use cortex_m::peripheral::{syst::SystClkSource, SYST};

/// Core clock \[Hz\] SysTick counts at.
pub const CORE_CLOCK_HZ: u32 = 168_000_000;

/// Starts SysTick free-running (no interrupt).
pub fn start(syst: &mut SYST) {
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(0x00FF_FFFF);
    syst.clear_current();
    syst.enable_counter();
}

/// Current SysTick value (counts down).
#[inline(always)]
pub fn now() -> u32 {
    SYST::get_current()
}

/// SysTick counts from `start` to `end` (both from [`now`]).
#[inline(always)]
pub fn counts(start: u32, end: u32) -> u32 {
    start.wrapping_sub(end) & 0x00FF_FFFF
}

/// Counts → instructions under QEMU `-icount shift=0` (1 ns each), or core cycles on the
/// board (1 count each).
pub fn to_units(counts: u32) -> u32 {
    if cfg!(feature = "qemu") {
        // counts·1e9/168e6 = counts·125/21, in u32 for counts < 2^24 (no u64 division).
        const _: () = assert!(CORE_CLOCK_HZ == 168_000_000);
        (counts & 0x00FF_FFFF) * 125 / 21
    } else {
        counts
    }
}

/// What [`to_units`] returns.
#[cfg_attr(not(feature = "qemu"), allow(dead_code))]
pub const UNIT: &str = if cfg!(feature = "qemu") {
    "instructions"
} else {
    "cycles"
};

/// Min / mean / max of a per-sample cost.
#[derive(Clone, Copy, Default)]
pub struct Stats {
    min: u32,
    max: u32,
    sum: u64,
    n: u32,
}

impl Stats {
    /// Adds one measurement (units of [`to_units`]).
    pub fn record(&mut self, value: u32) {
        if self.n == 0 || value < self.min {
            self.min = value;
        }
        self.max = self.max.max(value);
        self.sum += u64::from(value);
        self.n += 1;
    }

    /// (min, mean, max).
    pub fn summary(&self) -> (u32, u32, u32) {
        let mean = if self.n == 0 {
            0
        } else {
            (self.sum / u64::from(self.n)) as u32
        };
        (self.min, mean, self.max)
    }
}
