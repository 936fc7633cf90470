//! The board: every pin, peripheral and constant of the motor-controller board, with
//! units. The application never touches registers; it gets a [`Board`] from [`setup`]
//! and uses its four parts: sensors (raw ADC and encoder codes), the 1 kHz sample timer,
//! the telemetry port and the watchdog.
//!
//! Two implementations of the same interface: the STM32F405 board through
//! stm32f4xx-hal (default), and QEMU `netduinoplus2` (`qemu` feature), where the clock tree
//! is not modelled, the timer runs at 1 GHz, telemetry goes to USART1 and the sensors
//! are a simulated plant.

use estimator_core::sensors::{EncoderUnwrapper, LoadCellCalibration};
use estimator_core::{ModelKind, RawSample};

/// Sample rate of the estimator task \[Hz\].
pub const SAMPLE_RATE_HZ: u32 = 1000;
/// Sample time \[s\].
pub const SAMPLE_TIME_S: f32 = 1.0 / SAMPLE_RATE_HZ as f32;
/// Load cell (±33 N) through the amplifier into the 12-bit ADC: ADC counts → N.
pub const LOAD_CELL: LoadCellCalibration = LoadCellCalibration {
    reference_v: 3.3,
    full_scale_code: 4095,
    offset_v: 1.65,
    sensitivity_v_per_n: 0.05,
};
/// Encoder counts per metre after ×4 quadrature decoding (1 µm per count).
pub const ENCODER_COUNTS_PER_M: f32 = 1.0e6;
/// A telemetry frame every this many samples (50 Hz).
pub const TELEMETRY_DIVIDER: u32 = 20;
/// A defmt log line every this many samples (1 Hz).
pub const LOG_DIVIDER: u32 = 1000;
/// Independent watchdog timeout \[ms\]: the 1 kHz task feeds it.
#[cfg_attr(feature = "qemu", allow(dead_code))]
pub const WATCHDOG_MS: u32 = 50;
/// Telemetry UART baud rate \[bit/s\].
#[cfg_attr(feature = "qemu", allow(dead_code))]
pub const TELEMETRY_BAUD: u32 = 921_600;
/// Model the firmware estimates.
pub const ESTIMATOR: ModelKind = ModelKind::HuntCrossley;

/// Raw codes of one sample, as the peripherals give them.
#[derive(Clone, Copy, Default)]
pub struct RawCodes {
    /// ADC code of the load cell.
    pub adc: u16,
    /// 16-bit encoder counter.
    pub encoder: u16,
}

/// Raw codes → SI, once per sample, with the board's calibration.
pub struct Conversion {
    encoder: EncoderUnwrapper,
    counts_per_m_scale: f32,
}

impl Conversion {
    /// The conversion; the first encoder read is position 0.
    pub fn new() -> Self {
        let encoder = match EncoderUnwrapper::try_new(ENCODER_COUNTS_PER_M, 0.0) {
            Ok(e) => e,
            Err(_) => panic!("ENCODER_COUNTS_PER_M must be > 0"),
        };
        // The QEMU self-check `qemu-broken-estimator` miscalibrates the encoder by 2×.
        let counts_per_m_scale = if cfg!(feature = "qemu-broken-estimator") {
            2.0
        } else {
            1.0
        };
        Conversion {
            encoder,
            counts_per_m_scale,
        }
    }

    /// The sample in SI.
    #[inline]
    pub fn raw_sample(&mut self, codes: RawCodes) -> RawSample {
        let (force_n, saturated) = LOAD_CELL.force_n(codes.adc);
        RawSample {
            position_m: self.encoder.position_m(codes.encoder) * self.counts_per_m_scale,
            force_n,
            saturated,
        }
    }
}

#[cfg(not(feature = "qemu"))]
pub use self::hardware::*;
#[cfg(feature = "qemu")]
pub use self::qemu::*;

/// The STM32F405 board through stm32f4xx-hal: 8 MHz HSE → 168 MHz, load cell on PA0
/// (ADC1 IN0), encoder on TIM3 (PA6/PA7, 16-bit counter), sample timer TIM2, telemetry on
/// USART2 TX (PA2), independent watchdog.
#[cfg(not(feature = "qemu"))]
mod hardware {
    use super::*;
    use embedded_hal::digital::OutputPin;
    use stm32f4xx_hal::{
        adc::{config::AdcConfig, config::SampleTime, Adc},
        gpio::{Analog, Output, Pin},
        pac,
        prelude::*,
        qei::Qei,
        rcc::Config,
        serial::{Serial, Tx},
        timer::{CounterHz, Event, Flag},
        watchdog::IndependentWatchdog,
    };

    /// Load cell ADC and encoder.
    pub struct Sensors {
        adc: Adc<pac::ADC1>,
        load_cell: Pin<'A', 0, Analog>,
        encoder: Qei<pac::TIM3>,
    }

    impl Sensors {
        /// One conversion of the load cell and one read of the encoder counter.
        #[inline]
        pub fn read(&mut self) -> RawCodes {
            use stm32f4xx_hal::hal_02::Qei as _;
            RawCodes {
                adc: self.adc.convert(&self.load_cell, SampleTime::Cycles_84),
                encoder: self.encoder.count(),
            }
        }
    }

    /// TIM2 at 1 kHz.
    pub struct SampleTimer(CounterHz<pac::TIM2>);

    impl SampleTimer {
        /// Acknowledges this period's interrupt.
        #[inline]
        pub fn clear(&mut self) {
            self.0.clear_flags(Flag::Update);
        }

        /// `true` if the next period has already begun (deadline missed).
        #[inline]
        pub fn overran(&self) -> bool {
            self.0.flags().contains(Flag::Update)
        }
    }

    /// Telemetry UART.
    pub type TelemetryPort = Tx<pac::USART2>;

    /// Independent watchdog.
    pub struct Watchdog(IndependentWatchdog);

    impl Watchdog {
        /// Feeds it.
        #[inline]
        pub fn feed(&mut self) {
            self.0.feed();
        }
    }

    /// Status LED (PB2): lit while in contact.
    pub type StatusLed = Pin<'B', 2, Output>;

    /// The board's parts.
    pub struct Board {
        /// Sensors.
        pub sensors: Sensors,
        /// Sample timer.
        pub timer: SampleTimer,
        /// Telemetry UART.
        pub telemetry: TelemetryPort,
        /// Watchdog.
        pub watchdog: Watchdog,
        /// Status LED.
        pub led: StatusLed,
    }

    /// Clocks, pins and peripherals.
    pub fn setup(dp: pac::Peripherals) -> Board {
        let mut rcc = dp.RCC.freeze(
            Config::hse(8.MHz())
                .sysclk(168.MHz())
                .pclk1(42.MHz())
                .pclk2(84.MHz()),
        );
        let gpioa = dp.GPIOA.split(&mut rcc);
        let gpiob = dp.GPIOB.split(&mut rcc);
        let adc = Adc::new(dp.ADC1, true, AdcConfig::default(), &mut rcc);
        let encoder = Qei::new(dp.TIM3, (gpioa.pa6, gpioa.pa7), &mut rcc);
        let telemetry = match Serial::tx(
            dp.USART2,
            gpioa.pa2,
            stm32f4xx_hal::serial::Config::default().baudrate(TELEMETRY_BAUD.bps()),
            &mut rcc,
        ) {
            Ok(tx) => tx,
            Err(_) => panic!("telemetry UART config"),
        };
        let mut timer = dp.TIM2.counter_hz(&mut rcc);
        if timer.start(SAMPLE_RATE_HZ.Hz()).is_err() {
            panic!("sample timer config");
        }
        timer.listen(Event::Update);
        let mut watchdog = IndependentWatchdog::new(dp.IWDG);
        watchdog.start(WATCHDOG_MS.millis());
        let mut led = gpiob.pb2.into_push_pull_output();
        let _ = OutputPin::set_low(&mut led);
        Board {
            sensors: Sensors {
                adc,
                load_cell: gpioa.pa0.into_analog(),
                encoder,
            },
            timer: SampleTimer(timer),
            telemetry,
            watchdog: Watchdog(watchdog),
            led,
        }
    }
}

/// QEMU `netduinoplus2`: registers through the PAC only (no RCC setup), TIM2 clocked at
/// 1 GHz by QEMU, telemetry on USART1 (QEMU's first serial port), sensors simulated.
#[cfg(feature = "qemu")]
mod qemu {
    use super::*;
    use stm32f4::stm32f405 as pac;

    pub use crate::sim::SimPlant as Sensors;

    /// QEMU's STM32 timers count at 1 GHz.
    const QEMU_TIMER_CLOCK_HZ: u32 = 1_000_000_000;

    /// TIM2 at 1 kHz.
    pub struct SampleTimer(pac::TIM2);

    impl SampleTimer {
        /// Acknowledges this period's interrupt.
        #[inline]
        pub fn clear(&mut self) {
            self.0.sr().modify(|_, w| w.uif().clear_bit());
        }

        /// `true` if the next period has already begun (deadline missed).
        #[inline]
        pub fn overran(&self) -> bool {
            self.0.sr().read().uif().bit_is_set()
        }

        /// Stops the interrupts (end of the smoke run).
        pub fn stop(&mut self) {
            self.0.dier().modify(|_, w| w.uie().clear_bit());
        }
    }

    /// USART1, blocking writes.
    pub struct TelemetryPort(pac::USART1);

    impl embedded_io::ErrorType for TelemetryPort {
        type Error = core::convert::Infallible;
    }

    impl embedded_io::Write for TelemetryPort {
        fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
            for &b in buf {
                while self.0.sr().read().txe().bit_is_clear() {}
                self.0.dr().write(|w| w.dr().set(u16::from(b)));
            }
            Ok(buf.len())
        }

        fn flush(&mut self) -> Result<(), Self::Error> {
            Ok(())
        }
    }

    /// The watchdog is not modelled by QEMU; feeding it is a no-op there.
    pub struct Watchdog;

    impl Watchdog {
        /// No-op under QEMU.
        #[inline]
        pub fn feed(&mut self) {}
    }

    /// No LED under QEMU.
    pub struct StatusLed;

    impl embedded_hal::digital::ErrorType for StatusLed {
        type Error = core::convert::Infallible;
    }

    impl embedded_hal::digital::OutputPin for StatusLed {
        fn set_low(&mut self) -> Result<(), Self::Error> {
            Ok(())
        }
        fn set_high(&mut self) -> Result<(), Self::Error> {
            Ok(())
        }
    }

    /// The board's parts.
    pub struct Board {
        /// Sensors (simulated plant).
        pub sensors: Sensors,
        /// Sample timer.
        pub timer: SampleTimer,
        /// Telemetry UART.
        pub telemetry: TelemetryPort,
        /// Watchdog (no-op).
        pub watchdog: Watchdog,
        /// Status LED (none).
        pub led: StatusLed,
    }

    /// Timer, UART and the simulated plant.
    pub fn setup(dp: pac::Peripherals) -> Board {
        dp.RCC.apb1enr().modify(|_, w| w.tim2en().set_bit());
        dp.RCC.apb2enr().modify(|_, w| w.usart1en().set_bit());
        let tim = dp.TIM2;
        let ticks = QEMU_TIMER_CLOCK_HZ / SAMPLE_RATE_HZ;
        tim.psc().write(|w| w.psc().set(999));
        tim.arr().write(|w| w.arr().set(ticks / 1000 - 1));
        tim.dier().write(|w| w.uie().set_bit());
        tim.egr().write(|w| w.ug().set_bit());
        tim.sr().modify(|_, w| w.uif().clear_bit());
        tim.cr1().modify(|_, w| w.cen().set_bit());
        let usart = dp.USART1;
        usart.cr1().write(|w| w.ue().set_bit().te().set_bit());
        Board {
            sensors: Sensors::new(),
            timer: SampleTimer(tim),
            telemetry: TelemetryPort(usart),
            watchdog: Watchdog,
            led: StatusLed,
        }
    }
}
