//! QEMU `netduinoplus2` (an STM32F405): registers through the PAC, no clock tree (QEMU does
//! not model RCC; its timers count at 1 GHz), the protocol on USART1 (QEMU's first serial
//! port), sensors from the simulated plant, settings in a RAM "flash".
//!
//! What differs from the boards is only what QEMU cannot model: the sensors (no ADC DMA,
//! no encoder mode), the byte port (USART1 registers instead of the HAL's UART, always
//! ready to send) and the flash (QEMU's flash is read-only ROM). The sample timer, period
//! clock, framing, CRC, command parser, settings store and telemetry are the boards' code.

use estimator_core::protocol::BytePort;
use stm32f4::stm32f405 as pac;

use super::timers::{PeriodClock, SampleEvent, SampleTimer};
use super::{Board, PanicText, RawCodes};

/// Name in the boot report.
pub const BOARD_NAME: &str = "qemu";
/// QEMU's STM32 timers count at 1 GHz.
const TIMER_CLOCK_HZ: u32 = 1_000_000_000;

/// The simulated plant in place of the ADC and the encoder.
pub struct Sampler(crate::sim::SimPlant);

impl Sampler {
    /// This period's codes.
    #[inline]
    pub fn read(&mut self) -> RawCodes {
        self.0.read()
    }
}

/// USART1 transmit side: QEMU's USART takes a byte whenever TXE is set (always).
pub struct UartTx(pac::USART1);

impl BytePort for UartTx {
    fn try_write(&mut self, bytes: &[u8]) -> usize {
        let mut n = 0;
        for &b in bytes {
            if self.0.sr().read().txe().bit_is_clear() {
                break;
            }
            self.0.dr().write(|w| w.dr().set(u16::from(b)));
            n += 1;
        }
        n
    }
}

impl UartTx {
    /// Interrupt on TXE while bytes wait (`true`), or not.
    pub fn listen(&mut self, on: bool) {
        self.0.cr1().modify(|_, w| w.txeie().bit(on));
    }
}

/// USART1 receive side (RXNE interrupt). The transmit side owns the peripheral; this
/// half reads SR and DR only (a DR read is the receive register, a DR write the transmit
/// register: the halves do not interfere).
pub struct UartRx(());

impl UartRx {
    /// The next received byte, if any; `Some(Err(()))` for a byte with a framing, noise
    /// or overrun error.
    #[inline]
    pub fn read(&mut self) -> Option<Result<u8, ()>> {
        // SAFETY: read-only access to SR and the receive data register, see the type docs.
        let usart = unsafe { &*pac::USART1::ptr() };
        let sr = usart.sr().read();
        if sr.rxne().bit_is_clear() && sr.ore().bit_is_clear() {
            return None;
        }
        // Reading SR then DR clears the error flags (RM0090 §30.6.1).
        let byte = usart.dr().read().dr().bits() as u8;
        if sr.ore().bit_is_set() || sr.fe().bit_is_set() || sr.nf().bit_is_set() {
            Some(Err(()))
        } else {
            Some(Ok(byte))
        }
    }
}

/// QEMU models no watchdog: feeding and stretching it are no-ops.
pub struct Watchdog;

impl Watchdog {
    /// No-op under QEMU.
    #[inline]
    pub fn feed(&mut self) {}

    /// No-op under QEMU.
    pub fn set_timeout_ms(&mut self, _timeout_ms: u32) {}
}

/// No LED under QEMU.
pub struct StatusLed;

impl StatusLed {
    /// No-op.
    #[inline]
    pub fn set(&mut self, _on: bool) {}
}

/// Two 1 KiB pages of RAM with NOR-flash semantics (erase to 0xFF, writes only clear
/// bits), so that the boards' settings store runs unchanged; lost at reset, as QEMU has
/// no writable flash.
pub struct Flash(&'static mut [u8; 2 * RAM_PAGE_BYTES]);

const RAM_PAGE_BYTES: usize = 1024;

/// Static memory the target needs: the RAM "flash".
pub type Statics = [u8; 2 * RAM_PAGE_BYTES];
/// Its initial value (erased).
pub const STATICS_INIT: Statics = [0xFF; 2 * RAM_PAGE_BYTES];

/// Range of the settings store in [`Flash`] (offsets).
pub const SETTINGS_RANGE: core::ops::Range<u32> = 0..(2 * RAM_PAGE_BYTES) as u32;

impl embedded_storage::nor_flash::ErrorType for Flash {
    type Error = embedded_storage::nor_flash::NorFlashErrorKind;
}

impl embedded_storage::nor_flash::ReadNorFlash for Flash {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        let start = offset as usize;
        let source = self
            .0
            .get(start..start + bytes.len())
            .ok_or(Self::Error::OutOfBounds)?;
        bytes.copy_from_slice(source);
        Ok(())
    }

    fn capacity(&self) -> usize {
        self.0.len()
    }
}

impl embedded_storage::nor_flash::NorFlash for Flash {
    const WRITE_SIZE: usize = 1;
    const ERASE_SIZE: usize = RAM_PAGE_BYTES;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        self.0
            .get_mut(from as usize..to as usize)
            .ok_or(Self::Error::OutOfBounds)?
            .fill(0xFF);
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        let start = offset as usize;
        let target = self
            .0
            .get_mut(start..start + bytes.len())
            .ok_or(Self::Error::OutOfBounds)?;
        for (t, b) in target.iter_mut().zip(bytes) {
            *t &= *b;
        }
        Ok(())
    }
}

impl embedded_storage::nor_flash::MultiwriteNorFlash for Flash {}

/// Timers, UART and the simulated plant.
pub fn setup(dp: pac::Peripherals, flash_ram: &'static mut Statics) -> Board {
    let reset_cause = super::reset_cause(&dp.RCC);
    dp.RCC
        .apb1enr()
        .modify(|_, w| w.tim2en().set_bit().tim5en().set_bit());
    dp.RCC.apb2enr().modify(|_, w| w.usart1en().set_bit());
    let usart = dp.USART1;
    // Baud rate registers do not matter to QEMU's chardev.
    usart.cr1().write(|w| {
        w.ue()
            .set_bit()
            .te()
            .set_bit()
            .re()
            .set_bit()
            .rxneie()
            .set_bit()
    });
    flash_ram.fill(0xFF);
    Board {
        sampler: Sampler(crate::sim::SimPlant::new()),
        timer: SampleTimer::start(dp.TIM2, TIMER_CLOCK_HZ, SampleEvent::Update),
        clock: PeriodClock::start(dp.TIM5, TIMER_CLOCK_HZ),
        uart_rx: UartRx(()),
        uart_tx: UartTx(usart),
        watchdog: Watchdog,
        flash: Flash(flash_ram),
        led: StatusLed,
        reset_cause,
        panic_message: PanicText::new(),
    }
}
