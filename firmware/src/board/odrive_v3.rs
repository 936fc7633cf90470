//! ODrive v3.5 / v3.6 (STM32F405RGT6, 8 MHz HSE).
//!
//! | function | pin | peripheral | ODrive name |
//! |---|---|---|---|
//! | load-cell amplifier in (0-3.3 V) | PA2 | ADC1 IN2 | GPIO3 (default mode ANALOG_IN) |
//! | encoder A / B | PB4 / PB5 | TIM3 CH1 / CH2, AF2, filter 4 | M0 ENC_A / ENC_B (J4 "M0 encoder" header) |
//! | protocol UART TX / RX | PA0 / PA1 | UART4, AF8 | GPIO1 / GPIO2 (UART_A) |
//! | gate drivers held off | PB12 low | GPIO | EN_GATE (both DRV8301) |
//! | status LED | none | | (no user LED on v3.x) |
//!
//! Checked against odriverobotics/ODrive at commit
//! f9b5419c820c6fb2f609322a5131cdf8c5f71657:
//! - `Firmware/Board/v3/Inc/main.h` (v3.5+ pin names: GPIO_1..5 on PA0, PA1, PA2, PA3,
//!   PC4; M0_ENC_A/B on PB4/PB5; EN_GATE on PB12),
//! - `Firmware/Board/v3/board.cpp` (`gpios[]` for HW_VERSION_MINOR 5/6;
//!   `alternate_functions`: GPIO1/2 `GPIO_AF8_UART4`, ENC0 `GPIO_AF2_TIM3`; `uart_a =
//!   &huart4`; encoders[0] on `htim3`),
//! - `Firmware/Board/v3/Inc/board.h` (`DEFAULT_GPIO_MODES`: GPIO1/2 UART_A, GPIO3-5
//!   ANALOG_IN),
//! - `Firmware/Board/v3/Src/tim.c` (`MX_TIM3_Init`: `TIM_ENCODERMODE_TI12`,
//!   `IC1Filter = IC2Filter = 4`),
//! - `Firmware/Board/v3/Src/adc.c` (`ADC_CLOCK_SYNC_PCLK_DIV4`),
//! - `Firmware/Board/v3/Src/usart.c` and `Odrive.ioc` (UART4 TX on DMA1 stream 4 /
//!   RX on stream 2, channel 4 — unused here, this firmware drives the UART by
//!   interrupt; RCC: HSE 8 MHz, SYSCLK 168 MHz, APB1 42 MHz, APB2 84 MHz).
//!
//! Earlier boards differ: on v3.1/v3.2 GPIO1 is PB2 (`gpios[]`), and v3.3/v3.4 have no
//! GPIO5; PA0-PA3 are the same from v3.3 on. The PA2 analog input and UART4 on PA0/PA1
//! hold for v3.3 to v3.6.

use stm32f4xx_hal::{pac, prelude::*, qei::Qei, serial::Serial};

use super::stm32::{self, AdcBuffer, Sampler, StatusLed};
use super::Board;

/// Name in the boot report.
pub const BOARD_NAME: &str = "odrive-v3";
/// The protocol UART (UART_A).
pub type Uart = pac::UART4;
/// TIM3 input filter ICxF of the vendor's firmware (`tim.c`): f_DTS/2, N = 6.
const ENCODER_FILTER: u8 = 4;

/// Clocks, pins and peripherals.
pub fn setup(dp: pac::Peripherals, adc_buffer: &'static mut AdcBuffer) -> Board {
    let mut start = stm32::start(dp.RCC, dp.IWDG, &dp.DBGMCU);
    let gpioa = dp.GPIOA.split(&mut start.rcc);
    let gpiob = dp.GPIOB.split(&mut start.rcc);
    // Both DRV8301 gate drivers stay disabled: this firmware never drives the motors.
    let mut en_gate = gpiob.pb12.into_push_pull_output();
    en_gate.set_low();
    let load_cell = gpioa.pa2.into_analog();
    // PB4 leaves reset as the JTAG NJTRST pin (AF0, pull-up); SWD does not need it.
    let encoder = Qei::new(
        dp.TIM3,
        (gpiob.pb4.into_floating_input(), gpiob.pb5),
        &mut start.rcc,
    );
    let rcc = &mut start.rcc;
    let sampler = Sampler::new(
        dp.ADC1,
        dp.DMA2,
        &load_cell,
        adc_buffer,
        encoder,
        ENCODER_FILTER,
        rcc,
    );
    let serial = Serial::new(dp.UART4, (gpioa.pa0, gpioa.pa1), stm32::uart_config(), rcc)
        .unwrap_or_else(|_| super::unreachable_config());
    let led = StatusLed::new(None);
    stm32::finish(start, sampler, serial, (dp.TIM2, dp.TIM5), dp.FLASH, led)
}
