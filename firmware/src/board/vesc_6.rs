//! VESC 6 (HW 60, STM32F405RGT6, 8 MHz HSE).
//!
//! | function | pin | peripheral | VESC name |
//! |---|---|---|---|
//! | load-cell amplifier in (0-3.3 V) | PA5 | ADC1 IN5 | ADC_EXT (COMM header "ADC1") |
//! | encoder A / B | PC6 / PC7 | TIM3 CH1 / CH2, AF2, filter 6 | HALL1 / HALL2 = ENC A / B (sensor port) |
//! | protocol UART TX / RX | PB10 / PB11 | USART3, AF7 | COMM header TX / RX |
//! | gate driver held off | PB5 low | GPIO | ENABLE_GATE (DRV8301 EN_GATE) |
//! | status LED | PB0 | GPIO | LED_GREEN |
//!
//! Checked against vedderb/bldc at commit b9d287b3b8323f4b02618b02dc55e57d54a84996:
//! - `hwconf/trampa/vesc6/hw_60.h` (defines `HW60_IS_MK1` and includes the core header),
//! - `hwconf/trampa/vesc6/hw_60_core.h` (`HW_ADC_EXT_GPIO/PIN` = GPIOA 5, ADC vector
//!   "6: IN5 ADC_EXT1"; `HW_UART_DEV SD3`, `GPIO_AF_USART3`, TX PB10, RX PB11;
//!   `HW_HALL_ENC_*` PC6, PC7, PC8 with `HW_ENC_TIM TIM3`, `GPIO_AF_TIM3`;
//!   `ENABLE_GATE()` on PB5; `LED_GREEN` PB0, `LED_RED` PB1),
//! - `hwconf/trampa/vesc6/hw_60_core.c` (`hw_init_gpio`: PA5 analog; `hw_setup_adc_channels`:
//!   ADC1 rank 3 `ADC_Channel_5`),
//! - `encoder/enc_abi.c` (`TIM_EncoderMode_TI12`, input filter `6 << 4 | 6 << 12` in
//!   CCMR1),
//! - `hwconf/mcuconf.h` (HSE 8 MHz, PLLM 8, PLLN 336, PLLP 2, PPRE1 /4, PPRE2 /2).
//!
//! Conflict between sources: `motor/mcpwm_foc.c` runs the ADCs at `ADC_Prescaler_Div2`
//! (84 / 2 = 42 MHz), above the 36 MHz of the STM32F405 datasheet; this firmware uses
//! PCLK2/4 = 21 MHz as the ODrive firmware does.
//!
//! Variants: the MK3-MK6 headers (`hw_60_mk3.h` …) add a power latch on PC5
//! (`HW_SHUTDOWN_HOLD_ON`, held high by `HW_EARLY_INIT`) and, on MK6, a 3.3/5 V sensor-port
//! selector on PA4; this module follows HW 60 (MK1) and drives neither: on a board with
//! the power button, the latch must be held by the button while testing.

use stm32f4xx_hal::{pac, prelude::*, qei::Qei, serial::Serial};

use super::stm32::{self, AdcBuffer, Sampler, StatusLed};
use super::Board;

/// Name in the boot report.
pub const BOARD_NAME: &str = "vesc-6";
/// The protocol UART (COMM header).
pub type Uart = pac::USART3;
/// TIM3 input filter ICxF of the vendor's firmware (`enc_abi.c`): f_DTS/4, N = 6.
const ENCODER_FILTER: u8 = 6;

/// Clocks, pins and peripherals.
pub fn setup(dp: pac::Peripherals, adc_buffer: &'static mut AdcBuffer) -> Board {
    let mut start = stm32::start(dp.RCC, dp.IWDG, &dp.DBGMCU);
    let gpioa = dp.GPIOA.split(&mut start.rcc);
    let gpiob = dp.GPIOB.split(&mut start.rcc);
    let gpioc = dp.GPIOC.split(&mut start.rcc);
    // The DRV8301 stays disabled: this firmware never drives the motor.
    let mut enable_gate = gpiob.pb5.into_push_pull_output();
    enable_gate.set_low();
    let load_cell = gpioa.pa5.into_analog();
    let encoder = Qei::new(dp.TIM3, (gpioc.pc6, gpioc.pc7), &mut start.rcc);
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
    let serial = Serial::new(
        dp.USART3,
        (gpiob.pb10, gpiob.pb11),
        stm32::uart_config(),
        rcc,
    )
    .unwrap_or_else(|_| super::unreachable_config());
    let mut green = gpiob.pb0.into_push_pull_output().erase();
    green.set_low();
    let led = StatusLed::new(Some(green));
    stm32::finish(start, sampler, serial, (dp.TIM2, dp.TIM5), dp.FLASH, led)
}
