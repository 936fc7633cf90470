//! The board: every pin, peripheral and design constant, with units. The application
//! names no pin and no register; it gets a [`Board`] from [`setup`] and uses its parts:
//! the sampler (raw load-cell and encoder codes), the sample timer and period clock, the
//! UART halves, the watchdog, the settings flash and the status LED.
//!
//! One module per target, chosen by cargo feature (exactly one):
//! - `odrive-v3`: ODrive v3.5/v3.6 ([`odrive_v3`]),
//! - `vesc-6`: VESC 6 (HW 60) ([`vesc_6`]),
//! - `qemu`: QEMU `netduinoplus2` ([`qemu`]): simulated sensors, USART1, RAM "flash".
//!
//! Both real boards share the STM32F405 drivers of [`stm32`] (stm32f4xx-hal 0.23); the
//! sample timer and the period clock ([`timers`]) are the same register code on every
//! target, QEMU included.

use estimator_core::protocol::DeviceSettings;
use estimator_core::sensors::{EncoderUnwrapper, LoadCellCalibration};
use estimator_core::{ModelKind, RawSample};

#[cfg(not(any(feature = "odrive-v3", feature = "vesc-6", feature = "qemu")))]
compile_error!("select a target: --features odrive-v3, --features vesc-6 or --features qemu");
#[cfg(any(
    all(feature = "odrive-v3", feature = "vesc-6"),
    all(feature = "odrive-v3", feature = "qemu"),
    all(feature = "vesc-6", feature = "qemu")
))]
compile_error!("select exactly one target feature: odrive-v3, vesc-6 or qemu");

#[cfg(feature = "odrive-v3")]
pub mod odrive_v3;
#[cfg(feature = "qemu")]
pub mod qemu;
#[cfg(any(feature = "odrive-v3", feature = "vesc-6"))]
pub mod stm32;
pub mod timers;
#[cfg(feature = "vesc-6")]
pub mod vesc_6;

#[cfg(feature = "qemu")]
pub use qemu::*;
#[cfg(any(feature = "odrive-v3", feature = "vesc-6"))]
pub use stm32::*;

/// A panic message as the boot report carries it.
pub type PanicText = heapless::String<{ estimator_core::protocol::PANIC_MESSAGE_BYTES }>;

/// The target's parts, as [`setup`] hands them to the application.
pub struct Board {
    /// Load cell and encoder (QEMU: the simulated plant).
    pub sampler: Sampler,
    /// Sample timer.
    pub timer: timers::SampleTimer,
    /// Period clock.
    pub clock: timers::PeriodClock,
    /// UART transmit side.
    pub uart_tx: UartTx,
    /// UART receive side.
    pub uart_rx: UartRx,
    /// Watchdog (QEMU: none).
    pub watchdog: Watchdog,
    /// Settings flash (QEMU: RAM).
    pub flash: Flash,
    /// Status LED (or none).
    pub led: StatusLed,
    /// Why the MCU started.
    pub reset_cause: estimator_core::telemetry::ResetCause,
    /// Message of the panic before the last reset ("" if none; QEMU exits on a panic).
    pub panic_message: PanicText,
}

/// Sample rate of the estimator task \[Hz\].
pub const SAMPLE_RATE_HZ: u32 = 1000;
/// Sample time \[s\].
pub const SAMPLE_TIME_S: f32 = 1.0 / SAMPLE_RATE_HZ as f32;
/// ADC conversions of the load cell per sample, averaged (summed) in [`RawCodes::adc`].
pub const OVERSAMPLING: usize = 16;
/// Largest single 12-bit conversion.
pub const ADC_FULL_SCALE_CODE: u16 = 4095;
/// Largest oversampled code: the sum of [`OVERSAMPLING`] full-scale conversions.
pub const OVERSAMPLED_FULL_SCALE_CODE: u16 = ADC_FULL_SCALE_CODE * OVERSAMPLING as u16;
/// Default load cell (±33 N) through a 0-3.3 V amplifier (1.65 V at 0 N, 50 mV/N) into
/// the oversampled ADC code, until a two-point calibration replaces it.
pub const DEFAULT_LOAD_CELL: LoadCellCalibration = LoadCellCalibration {
    reference_v: 3.3,
    full_scale_code: OVERSAMPLED_FULL_SCALE_CODE,
    offset_v: 1.65,
    sensitivity_v_per_n: 0.05,
};
/// Default encoder counts per metre after ×4 quadrature decoding (1 µm per count).
pub const DEFAULT_ENCODER_COUNTS_PER_M: f32 = 1.0e6;
/// Default telemetry rate \[Hz\].
pub const DEFAULT_TELEMETRY_RATE_HZ: u16 = 50;
/// Default model.
pub const DEFAULT_MODEL: ModelKind = ModelKind::HuntCrossley;
/// Protocol UART baud rate \[bit/s\] (QEMU's chardev has none).
#[cfg_attr(feature = "qemu", allow(dead_code))]
pub const UART_BAUD: u32 = 921_600;
/// A defmt log line every this many samples (1 Hz).
pub const LOG_DIVIDER: u32 = 1000;
/// Independent watchdog timeout while the loop runs \[ms\].
pub const WATCHDOG_MS: u32 = 50;
/// Independent watchdog timeout around a flash write \[ms\]: a 128 KiB sector erase at
/// ×8 parallelism stalls every flash fetch for up to 4 s (STM32F405 datasheet, table
/// "Flash memory programming", t_ERASE128KB max at 2.1-2.7 V).
pub const WATCHDOG_FLASH_MS: u32 = 8000;
/// Sample-time constant of the load-cell mean used by the calibration (samples).
pub const CALIBRATION_MEAN_SAMPLES: f32 = 64.0;

/// The settings a fresh board starts with (no record in flash).
pub fn default_settings() -> DeviceSettings {
    DeviceSettings {
        model: DEFAULT_MODEL,
        forgetting: None,
        load_cell: DEFAULT_LOAD_CELL,
        // The QEMU self-check `qemu-broken-estimator` miscalibrates the encoder by 2×.
        encoder_counts_per_m: if cfg!(feature = "qemu-broken-estimator") {
            DEFAULT_ENCODER_COUNTS_PER_M / 2.0
        } else {
            DEFAULT_ENCODER_COUNTS_PER_M
        },
        telemetry_rate_hz: DEFAULT_TELEMETRY_RATE_HZ,
    }
}

/// Raw codes of one sample, as the peripherals give them.
#[derive(Clone, Copy, Default)]
pub struct RawCodes {
    /// Sum of the [`OVERSAMPLING`] load-cell conversions of this period (0 ..=
    /// [`OVERSAMPLED_FULL_SCALE_CODE`]); `None` if they did not arrive (DMA not complete,
    /// ADC overrun): the sample is dropped.
    pub adc: Option<u16>,
    /// At least one conversion sat at a rail (0 or 4095): the amplifier or the ADC
    /// saturated.
    pub adc_at_rail: bool,
    /// 16-bit encoder counter.
    pub encoder: u16,
}

/// Raw codes → SI, once per sample, with the settings in force.
pub struct Conversion {
    load_cell: LoadCellCalibration,
    encoder: EncoderUnwrapper,
    counts_per_m: f32,
    period_samples: u16,
}

impl Conversion {
    /// The conversion for `settings` (validated); the first encoder read is position 0.
    pub fn new(settings: &DeviceSettings) -> Self {
        Conversion {
            load_cell: settings.load_cell,
            encoder: encoder(settings.encoder_counts_per_m, 0.0),
            counts_per_m: settings.encoder_counts_per_m,
            period_samples: settings.telemetry_period_samples(),
        }
    }

    /// Takes new settings; the position continues from where it is (the next encoder
    /// read defines it), so a new scale does not make the probe jump.
    pub fn apply(&mut self, settings: &DeviceSettings) {
        let position_m = self.encoder.count() as f32 / self.counts_per_m;
        self.load_cell = settings.load_cell;
        self.encoder = encoder(settings.encoder_counts_per_m, position_m);
        self.counts_per_m = settings.encoder_counts_per_m;
        self.period_samples = settings.telemetry_period_samples();
    }

    /// Telemetry period in samples.
    pub fn period_samples(&self) -> u16 {
        self.period_samples
    }

    /// The sample in SI, and the amplifier output \[V\] (NaN when dropped or saturated).
    #[inline]
    pub fn raw_sample(&mut self, codes: RawCodes) -> (RawSample, f32) {
        let position_m = self.encoder.position_m(codes.encoder);
        let Some(code) = codes.adc else {
            let dropped = RawSample {
                position_m,
                force_n: f32::NAN,
                saturated: false,
            };
            return (dropped, f32::NAN);
        };
        let (force_n, at_limit) = self.load_cell.force_n(code);
        let saturated = at_limit || codes.adc_at_rail;
        let volts = if saturated {
            f32::NAN
        } else {
            f32::from(code) * self.load_cell.reference_v / f32::from(self.load_cell.full_scale_code)
        };
        (
            RawSample {
                position_m,
                force_n,
                saturated,
            },
            volts,
        )
    }
}

/// The unwrapper; the scale was validated with the settings, so the fallback (1 µm per
/// count) is never taken.
fn encoder(counts_per_m: f32, position_m: f32) -> EncoderUnwrapper {
    EncoderUnwrapper::try_new(counts_per_m, position_m)
        .or_else(|_| EncoderUnwrapper::try_new(DEFAULT_ENCODER_COUNTS_PER_M, 0.0))
        .unwrap_or_else(|_| unreachable_config())
}

/// A constant configuration failed validation: a build error in all but name, caught by
/// the first QEMU run.
#[cold]
fn unreachable_config() -> ! {
    panic!("firmware design constant rejected by the core")
}

/// Why the MCU started, from RCC_CSR (RM0090 §7.3.21), and clears the flags (RMVF) so the
/// next start reports its own cause. QEMU models no RCC: its CSR reads 0, "unknown".
pub fn reset_cause(rcc: &stm32f4::stm32f405::RCC) -> estimator_core::telemetry::ResetCause {
    use estimator_core::telemetry::ResetCause;
    let csr = rcc.csr().read();
    let cause = if csr.borrstf().bit_is_set() && csr.porrstf().bit_is_set() {
        ResetCause::PowerOn
    } else if csr.borrstf().bit_is_set() {
        ResetCause::BrownOut
    } else if csr.wdgrstf().bit_is_set() {
        ResetCause::IndependentWatchdog
    } else if csr.wwdgrstf().bit_is_set() {
        ResetCause::WindowWatchdog
    } else if csr.sftrstf().bit_is_set() {
        ResetCause::Software
    } else if csr.lpwrrstf().bit_is_set() {
        ResetCause::LowPower
    } else if csr.padrstf().bit_is_set() {
        ResetCause::Pin
    } else {
        ResetCause::Unknown
    };
    rcc.csr().modify(|_, w| w.rmvf().set_bit());
    cause
}
