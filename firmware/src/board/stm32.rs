//! The STM32F405 drivers both real boards share, through stm32f4xx-hal 0.23. The board
//! modules ([`super::odrive_v3`], [`super::vesc_6`]) choose pins and peripherals; what is
//! done with them is here:
//!
//! - Clocks: 8 MHz HSE → 168 MHz SYSCLK, PCLK1 42 MHz (APB1 timers 84 MHz), PCLK2 84 MHz,
//!   as both vendors' clock trees (ODrive `Odrive.ioc` RCC.*, VESC `hwconf/mcuconf.h`).
//! - Load cell: ADC1 at PCLK2/4 = 21 MHz (datasheet maximum 36 MHz; the HAL default
//!   PCLK2/2 = 42 MHz is beyond it), 12 bit, a regular sequence of the load-cell channel
//!   16 times (84-cycle sampling, 4.6 µs each), started by TIM2 TRGO every period and
//!   collected by DMA2 stream 0 channel 0 (RM0090 Table 43, the ADC1 request; the HAL
//!   checks the pairing at compile time) into a static buffer. The sample task finds the
//!   16 codes in memory, re-arms the stream, and flags a period whose transfer did not
//!   complete as a dropped sample.
//! - Encoder: TIM3 in encoder mode TI12 (×4) through the HAL's `Qei`, then the input
//!   filter on both channels (the HAL leaves ICxF = 0); the 16-bit counter is unwrapped by
//!   the core.
//! - UART: 921 600 bit/s 8N1; received bytes and transmit-ready raise the UART interrupt,
//!   one byte per TXE, from the core's `TxQueue`, so a byte still shifting out (10.8 µs)
//!   is "accept 0 bytes", never a panic or a busy wait.
//! - Independent watchdog 50 ms, frozen while a debugger halts the core
//!   (DBGMCU_APB1_FZ.DBG_IWDG_STOP, the HAL's `stop_on_debug`), stretched around flash
//!   writes.
//! - Settings: flash sectors 10 and 11 (2 × 128 KiB at 0x080C_0000, RM0090 Table 5),
//!   which `memory.x` keeps out of the program's FLASH region.
//! - Panics: the `panic-location` crate writes "Panicked at file:line:column" to the
//!   1 KiB `PANDUMP` RAM region of `memory.x` in panic-persist's format and resets; the
//!   next start reads it back through panic-persist and reports it.

use estimator_core::protocol::BytePort;
use estimator_core::telemetry::ResetCause;
use stm32f4xx_hal::{
    adc::{
        config::{
            AdcConfig, Align, Clock, Continuous, Dma, Eoc, ExternalTrigger, Resolution, SampleTime,
            Scan, Sequence, TriggerMode,
        },
        Adc,
    },
    dma::{config::DmaConfig, PeripheralToMemory, Stream0, StreamsTuple, Transfer},
    flash::{FlashExt, LockedFlash},
    pac,
    prelude::*,
    qei::Qei,
    rcc::{Config, Enable, Rcc},
    serial::{self, Rx, RxListen, Serial, Tx, TxListen},
    watchdog::IndependentWatchdog,
};

use super::timers::{PeriodClock, SampleEvent, SampleTimer};
use super::{
    Board, PanicText, RawCodes, ADC_FULL_SCALE_CODE, OVERSAMPLING, UART_BAUD, WATCHDOG_MS,
};

#[cfg(feature = "odrive-v3")]
pub use super::odrive_v3::{setup, Uart, BOARD_NAME};
#[cfg(feature = "vesc-6")]
pub use super::vesc_6::{setup, Uart, BOARD_NAME};

/// ADC sampling time of each conversion: 84 cycles (4 µs at 21 MHz) settle a source of
/// tens of kΩ (RM0090 §13.5; datasheet R_AIN formula).
const ADC_SAMPLE_TIME: SampleTime = SampleTime::Cycles_84;

/// Oversampled load-cell conversions, one buffer the DMA fills each period.
pub type AdcBuffer = [u16; OVERSAMPLING];
/// Static memory the board needs: the ADC's DMA buffer.
pub type Statics = AdcBuffer;
/// Its initial value.
pub const STATICS_INIT: Statics = [0; OVERSAMPLING];
type AdcTransfer =
    Transfer<Stream0<pac::DMA2>, 0, Adc<pac::ADC1>, PeripheralToMemory, &'static mut AdcBuffer>;

/// Clocks (see the module docs).
fn clocks(rcc: pac::RCC) -> Rcc {
    rcc.freeze(
        Config::hse(8.MHz())
            .sysclk(168.MHz())
            .pclk1(42.MHz())
            .pclk2(84.MHz()),
    )
}

/// TIM2 (sample timer, interrupt at compare 1) and TIM5 (period clock) from the APB1
/// timer clock.
fn timers(tim2: pac::TIM2, tim5: pac::TIM5, rcc: &mut Rcc) -> (SampleTimer, PeriodClock) {
    pac::TIM2::enable(rcc);
    pac::TIM5::enable(rcc);
    let clock_hz = rcc.clocks.timclk1().raw();
    (
        SampleTimer::start(tim2, clock_hz, SampleEvent::Compare1),
        PeriodClock::start(tim5, clock_hz),
    )
}

/// The load cell (ADC1 + DMA2 stream 0, triggered by TIM2) and the encoder (TIM3).
pub struct Sampler {
    transfer: AdcTransfer,
    encoder: pac::TIM3,
}

impl Sampler {
    /// Configures ADC1 to convert `load_cell` 16 times at each TIM2 TRGO into `buffer` by
    /// DMA, and sets the input filter of the TIM3 quadrature decoder `encoder` to
    /// `encoder_filter` (TIMx_CCMR1.ICxF, RM0090 §18.4.7: 4 = f_DTS/2, N = 6; 6 = f_DTS/4,
    /// N = 6).
    pub fn new<P>(
        adc1: pac::ADC1,
        dma2: pac::DMA2,
        load_cell: &P,
        buffer: &'static mut AdcBuffer,
        encoder: Qei<pac::TIM3>,
        encoder_filter: u8,
        rcc: &mut Rcc,
    ) -> Self
    where
        P: embedded_hal_02::adc::Channel<pac::ADC1, ID = u8>,
    {
        let config = AdcConfig::default()
            .clock(Clock::Pclk2_div_4)
            .resolution(Resolution::Twelve)
            .align(Align::Right)
            .scan(Scan::Enabled)
            .continuous(Continuous::Single)
            .external_trigger(TriggerMode::RisingEdge, ExternalTrigger::Tim_2_trgo)
            .dma(Dma::Continuous)
            .end_of_conversion_interrupt(Eoc::Disabled);
        let mut adc = Adc::new(adc1, true, config, rcc);
        for rank in 0..OVERSAMPLING as u8 {
            adc.configure_channel(load_cell, Sequence::from(rank), ADC_SAMPLE_TIME);
        }
        let streams = StreamsTuple::new(dma2, rcc);
        let mut transfer = Transfer::init_peripheral_to_memory(
            streams.0,
            adc,
            buffer,
            None,
            DmaConfig::default()
                .memory_increment(true)
                .double_buffer(false),
        );
        transfer.start(|_| {});
        // The pins stay in their alternate function when dropped.
        let (tim3, _pins) = encoder.release();
        tim3.ccmr1_input()
            .modify(|_, w| unsafe { w.ic1f().bits(encoder_filter).ic2f().bits(encoder_filter) });
        Sampler {
            transfer,
            encoder: tim3,
        }
    }

    /// This period's codes: the sum of the 16 conversions (or `None` if their transfer
    /// did not complete), and the encoder counter. Re-arms the DMA for the next period.
    #[inline]
    pub fn read(&mut self) -> RawCodes {
        use stm32f4xx_hal::dma::traits::StreamISR;
        let complete = self.transfer.is_transfer_complete();
        // SAFETY: single-buffer transfer (double_buffer(false)), the case in which the HAL
        // documents neither a panic nor a corruption: the stream is stopped, the closure
        // reads the buffer, the same buffer is re-armed.
        let rearmed = unsafe {
            self.transfer.next_transfer_with(|buffer, _| {
                let mut sum = 0u32;
                let mut at_rail = false;
                for &code in buffer.iter() {
                    sum += u32::from(code);
                    at_rail |= code == 0 || code >= ADC_FULL_SCALE_CODE;
                }
                (buffer, (sum, at_rail))
            })
        };
        let fresh = complete && rearmed.is_ok();
        let (sum, at_rail) = rearmed.unwrap_or((0, false));
        if !fresh {
            recover_adc_overrun();
        }
        RawCodes {
            adc: if fresh { u16::try_from(sum).ok() } else { None },
            adc_at_rail: at_rail,
            encoder: self.encoder.cnt().read().bits() as u16,
        }
    }
}

/// After a period without a re-arm the ADC overran (its DMA request found the stream
/// off) and stopped requesting: clear OVR and toggle CR2.DMA to restart it (RM0090
/// §13.8.1).
#[cold]
fn recover_adc_overrun() {
    // SAFETY: ADC1's SR and the DMA bit of CR2 are touched only here, in the sample task
    // that owns the transfer (and so the ADC).
    let adc = unsafe { &*pac::ADC1::ptr() };
    if adc.sr().read().ovr().bit_is_set() {
        adc.sr().modify(|_, w| w.ovr().clear_bit());
        adc.cr2().modify(|_, w| w.dma().clear_bit());
        adc.cr2().modify(|_, w| w.dma().set_bit());
    }
}

/// UART transmit side: one byte per call while TXE is set.
pub struct UartTx(Tx<Uart>);

impl BytePort for UartTx {
    fn try_write(&mut self, bytes: &[u8]) -> usize {
        let mut n = 0;
        for &b in bytes {
            match embedded_hal_nb::serial::Write::write(&mut self.0, b) {
                Ok(()) => n += 1,
                Err(_) => break,
            }
        }
        n
    }
}

impl UartTx {
    /// Interrupt on TXE while bytes wait (`true`), or not.
    pub fn listen(&mut self, on: bool) {
        if on {
            self.0.listen();
        } else {
            self.0.unlisten();
        }
    }
}

/// UART receive side (RXNE interrupt).
pub struct UartRx(Rx<Uart>);

impl UartRx {
    /// The next received byte, if any; `Some(Err(()))` for a framing, noise or overrun
    /// error (the HAL clears the flag).
    #[inline]
    pub fn read(&mut self) -> Option<Result<u8, ()>> {
        match embedded_hal_nb::serial::Read::read(&mut self.0) {
            Ok(b) => Some(Ok(b)),
            Err(nb::Error::WouldBlock) => None,
            Err(nb::Error::Other(_)) => Some(Err(())),
        }
    }
}

/// The UART at [`UART_BAUD`], 8N1, interrupts on received bytes.
fn uart(serial: Serial<Uart>) -> (UartTx, UartRx) {
    let (tx, mut rx) = serial.split();
    rx.listen();
    (UartTx(tx), UartRx(rx))
}

/// Serial configuration of the protocol UART.
pub fn uart_config() -> serial::Config {
    serial::Config::default().baudrate(UART_BAUD.bps())
}

/// Independent watchdog.
pub struct Watchdog(IndependentWatchdog);

impl Watchdog {
    /// Starts it at [`WATCHDOG_MS`], frozen while a debugger halts the core.
    pub fn start(iwdg: pac::IWDG, dbgmcu: &pac::DBGMCU) -> Self {
        let mut watchdog = IndependentWatchdog::new(iwdg);
        watchdog.stop_on_debug(dbgmcu, true);
        watchdog.start(WATCHDOG_MS.millis());
        Watchdog(watchdog)
    }

    /// Feeds it.
    #[inline]
    pub fn feed(&mut self) {
        self.0.feed();
    }

    /// New timeout (the HAL waits for the prescaler and reload registers to update, a few
    /// 32 kHz LSI cycles).
    pub fn set_timeout_ms(&mut self, timeout_ms: u32) {
        self.0.start(timeout_ms.millis());
    }
}

/// Status LED, lit while in contact (or none).
pub struct StatusLed(Option<stm32f4xx_hal::gpio::ErasedPin<stm32f4xx_hal::gpio::Output>>);

impl StatusLed {
    /// The LED on `pin`, or none.
    pub fn new(pin: Option<stm32f4xx_hal::gpio::ErasedPin<stm32f4xx_hal::gpio::Output>>) -> Self {
        StatusLed(pin)
    }

    /// On or off.
    #[inline]
    pub fn set(&mut self, on: bool) {
        if let Some(pin) = &mut self.0 {
            if on {
                pin.set_high();
            } else {
                pin.set_low();
            }
        }
    }
}

/// The on-chip flash as an `embedded-storage` NOR flash, unlocked only for the duration
/// of each erase or write.
pub struct Flash(LockedFlash);

/// Settings store: flash sectors 10 and 11 (offsets from 0x0800_0000).
pub const SETTINGS_RANGE: core::ops::Range<u32> = 0x000C_0000..0x0010_0000;

impl embedded_storage::nor_flash::ErrorType for Flash {
    type Error = stm32f4xx_hal::flash::Error;
}

impl embedded_storage::nor_flash::ReadNorFlash for Flash {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        embedded_storage::nor_flash::ReadNorFlash::read(&mut self.0, offset, bytes)
    }

    fn capacity(&self) -> usize {
        self.0.len()
    }
}

impl embedded_storage::nor_flash::NorFlash for Flash {
    const WRITE_SIZE: usize = 1;
    const ERASE_SIZE: usize = 128 * 1024;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        embedded_storage::nor_flash::NorFlash::erase(&mut self.0.unlocked(), from, to)
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        embedded_storage::nor_flash::NorFlash::write(&mut self.0.unlocked(), offset, bytes)
    }
}

impl embedded_storage::nor_flash::MultiwriteNorFlash for Flash {}

impl Flash {
    /// The flash.
    pub fn new(flash: pac::FLASH) -> Self {
        Flash(LockedFlash::new(flash))
    }
}

/// The message kept from the panic before this start ("" if none): "Panicked at
/// file:line:column", written by the `panic-location` crate in panic-persist's format
/// (its `min-panic` form without `core::fmt`: see that crate for why).
fn panic_message() -> PanicText {
    let mut text = PanicText::new();
    for &b in panic_persist::get_panic_message_bytes().unwrap_or(&[]) {
        let c = if b.is_ascii() && !b.is_ascii_control() {
            b as char
        } else {
            '?'
        };
        if text.push(c).is_err() {
            break;
        }
    }
    text
}

/// What every board does first: the reset cause and the panic message (before anything
/// clears them), the watchdog, the clocks.
pub struct Start {
    /// Clocks.
    pub rcc: Rcc,
    reset_cause: ResetCause,
    panic_message: PanicText,
    watchdog: Watchdog,
}

/// Reset cause, panic message, watchdog, clocks.
pub fn start(rcc: pac::RCC, iwdg: pac::IWDG, dbgmcu: &pac::DBGMCU) -> Start {
    let reset_cause = super::reset_cause(&rcc);
    let panic_message = panic_message();
    let watchdog = Watchdog::start(iwdg, dbgmcu);
    Start {
        rcc: clocks(rcc),
        reset_cause,
        panic_message,
        watchdog,
    }
}

/// The parts a board module chose, with the shared ones, as the application's [`Board`]:
/// the UART split with its receive interrupt on, TIM2 and TIM5 started (last, so that the
/// first sample interrupt finds everything set up).
pub fn finish(
    mut start: Start,
    sampler: Sampler,
    serial: Serial<Uart>,
    (tim2, tim5): (pac::TIM2, pac::TIM5),
    flash: pac::FLASH,
    led: StatusLed,
) -> Board {
    let (uart_tx, uart_rx) = uart(serial);
    let (timer, clock) = timers(tim2, tim5, &mut start.rcc);
    Board {
        sampler,
        timer,
        clock,
        uart_tx,
        uart_rx,
        watchdog: start.watchdog,
        flash: Flash::new(flash),
        led,
        reset_cause: start.reset_cause,
        panic_message: start.panic_message,
    }
}
