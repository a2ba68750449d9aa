//! The clock tree, from the crystal: the ST-LINK's 8 MHz clock output
//! (its own crystal) drives the H743's HSE pin in bypass mode; PLL1 makes
//! the 400 MHz core clock from it, and TIM2 — the player's clock — counts
//! the 200 MHz APB1 timer clock divided to 1 MHz, so a dwell is as exact as
//! that crystal (±50 ppm or better; the internal HSI is trimmed to ±1 % at
//! 25 °C and drifts a few tenths of a percent more with temperature, RM0433
//! / DS12110). If HSE does not start within [`HSE_TIMEOUT`] polls, the
//! board stays on HSI (64 MHz) and [`Clocks::source`] says so.
//!
//! The dividers are constants checked at compile time against the limits
//! of RM0433 (PLL input 2-4 MHz, wide VCO 192-836 MHz, 400 MHz core at
//! VOS1, 200 MHz AXI/AHB, 100 MHz APB), so a wrong divider fails the build,
//! not the bench. SPI1 keeps its kernel clock on per_ck (HSI), unchanged.

use stm32h7::stm32h743v as pac;

/// The ST-LINK/V3's MCO into PH0 (HSE bypass).
/// TIM2 count rate: the player's clock.
pub const TIMER_HZ: u32 = 1_000_000;
pub const HSE_HZ: u32 = 8_000_000;
/// The internal RC oscillator after reset.
pub const HSI_HZ: u32 = 64_000_000;
/// PLL1 input divider: 8 MHz / 4 = 2 MHz reference (PLL1RGE 2-4 MHz).
pub const DIVM1: u32 = 4;
/// PLL1 multiplier: 2 MHz × 400 = 800 MHz VCO (wide range).
pub const DIVN1: u32 = 400;
/// PLL1 P divider: 400 MHz sys_ck.
pub const DIVP1: u32 = 2;
/// sys_ck and the core clock (D1CPRE /1).
pub const SYS_HZ: u32 = HSE_HZ / DIVM1 * DIVN1 / DIVP1;
/// AXI/AHB (HPRE /2).
pub const AHB_HZ: u32 = SYS_HZ / 2;
/// APB1 (D2PPRE1 /2): USART3's kernel clock.
pub const APB1_HZ: u32 = AHB_HZ / 2;
/// TIM2's clock: twice APB1 when APB1 is divided (TIMPRE = 0).
pub const TIM2_HZ: u32 = 2 * APB1_HZ;
/// PLL2 for the driver boards' shared 10.24 MHz reference (40 kHz × 256,
/// `firmware/DRIVER.md`) on MCO2 (PC9): 8 MHz / 5 = 1.6 MHz (PLL2RGE
/// 1-2 MHz) × 256 = 409.6 MHz (medium VCO, 150-420 MHz) / 40.
pub const DIVM2: u32 = 5;
/// PLL2 multiplier.
pub const DIVN2: u32 = 256;
/// PLL2 P divider.
pub const DIVP2: u32 = 40;
/// The reference the gateware multiplies by 8 (`gateware/hx8k.py`).
pub const DRIVER_REF_HZ: u32 = 10_240_000;

/// Polls of HSERDY before falling back to HSI (≥ 10 ms at 64 MHz; the
/// ST-LINK's MCO is running before the target leaves reset).
pub const HSE_TIMEOUT: u32 = 1_000_000;

const _: () = {
    let reference = HSE_HZ / DIVM1;
    assert!(HSE_HZ.is_multiple_of(DIVM1) && reference >= 2_000_000 && reference <= 4_000_000);
    let vco = reference as u64 * DIVN1 as u64;
    assert!(vco >= 192_000_000 && vco <= 836_000_000);
    assert!(DIVN1 >= 4 && DIVN1 <= 512 && DIVP1.is_multiple_of(2));
    assert!(SYS_HZ == 400_000_000, "VOS1 allows 400 MHz");
    assert!(AHB_HZ <= 200_000_000 && APB1_HZ <= 100_000_000);
    // TIM2 counts 1 MHz exactly, with a 16-bit prescaler.
    assert!(TIM2_HZ.is_multiple_of(TIMER_HZ) && TIM2_HZ / TIMER_HZ <= 65_536);
    assert!(HSI_HZ.is_multiple_of(TIMER_HZ));
    let ref2 = HSE_HZ / DIVM2;
    assert!(HSE_HZ.is_multiple_of(DIVM2) && ref2 >= 1_000_000 && ref2 <= 2_000_000);
    let vco2 = ref2 as u64 * DIVN2 as u64;
    assert!(vco2 >= 150_000_000 && vco2 <= 420_000_000);
    assert!(
        vco2 == DRIVER_REF_HZ as u64 * DIVP2 as u64,
        "10.24 MHz exactly"
    );
    assert!(DIVP2 <= 128);
};

/// Which oscillator the board runs from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Source {
    /// HSE from the ST-LINK's crystal, through PLL1.
    Crystal,
    /// HSI: HSE did not start.
    InternalRc,
}

/// The clocks the peripherals were set up with.
#[derive(Debug, Clone, Copy)]
pub struct Clocks {
    /// The oscillator (`Info.clock`).
    pub source: Source,
    /// USART3's kernel clock (APB1), Hz.
    pub usart_hz: u32,
    /// TIM2's clock, Hz.
    pub tim2_hz: u32,
}

/// Brings the board onto the crystal (or leaves it on HSI); call first.
pub fn init(pwr: &pac::PWR, rcc: &pac::RCC, flash: &pac::FLASH, gpioc: &pac::GPIOC) -> Clocks {
    let hsi = Clocks {
        source: Source::InternalRc,
        usart_hz: HSI_HZ,
        tim2_hz: HSI_HZ,
    };
    // HSE in bypass: the ST-LINK's MCO is a digital clock, not a crystal.
    rcc.cr().modify(|_, w| w.hsebyp().bypassed().hseon().on());
    let mut polls = 0;
    while !rcc.cr().read().hserdy().is_ready() {
        polls += 1;
        if polls >= HSE_TIMEOUT {
            rcc.cr().modify(|_, w| w.hseon().off());
            return hsi;
        }
    }
    // Supply from the LDO, VOS1 (400 MHz), then flash wait states for a
    // 200 MHz AXI clock at VOS1 (2 WS, WRHIGHFREQ 2) before speeding up.
    pwr.cr3()
        .modify(|_, w| w.scuen().set_bit().ldoen().set_bit().bypass().clear_bit());
    while pwr.csr1().read().actvosrdy().bit_is_clear() {}
    // SAFETY: 0b11 is VOS1 in D3CR.VOS.
    pwr.d3cr().modify(|_, w| unsafe { w.vos().bits(0b11) });
    while pwr.d3cr().read().vosrdy().bit_is_clear() {}
    // SAFETY: 2 wait states and WRHIGHFREQ 2 are valid values (RM0433 table 17).
    flash
        .acr()
        .modify(|_, w| unsafe { w.latency().bits(2).wrhighfreq().bits(2) });
    while flash.acr().read().latency().bits() != 2 {}

    rcc.pllckselr()
        // SAFETY: DIVM1 is 4 (checked above); 1..=63 are valid.
        .modify(|_, w| unsafe { w.pllsrc().hse().divm1().bits(DIVM1 as u8) });
    rcc.pllcfgr().modify(|_, w| {
        w.pll1rge()
            .range2()
            .pll1vcosel()
            .wide_vco()
            .pll1fracen()
            .reset()
            .divp1en()
            .enabled()
    });
    rcc.pll1divr()
        // SAFETY: the fields hold divider − 1; DIVN1 − 1 = 399 and DIVP1 − 1 = 1
        // are in range (checked above).
        .write(|w| unsafe {
            w.divn1()
                .bits((DIVN1 - 1) as u16)
                .divp1()
                .bits((DIVP1 - 1) as u8)
        });
    rcc.cr().modify(|_, w| w.pll1on().on());
    while !rcc.cr().read().pll1rdy().is_ready() {}

    // The driver boards' 10.24 MHz reference: PLL2 P on MCO2 (PC9, AF0).
    // SAFETY: DIVM2 = 5 is in 1..=63 (checked above).
    rcc.pllckselr()
        .modify(|_, w| unsafe { w.divm2().bits(DIVM2 as u8) });
    rcc.pllcfgr().modify(|_, w| {
        w.pll2rge()
            .range1()
            .pll2vcosel()
            .medium_vco()
            .divp2en()
            .enabled()
    });
    rcc.pll2divr()
        // SAFETY: divider − 1 values in range (checked above).
        .write(|w| unsafe {
            w.divn2()
                .bits((DIVN2 - 1) as u16)
                .divp2()
                .bits((DIVP2 - 1) as u8)
        });
    rcc.cr().modify(|_, w| w.pll2on().on());
    while !rcc.cr().read().pll2rdy().is_ready() {}
    // SAFETY: MCO2PRE 1 is "divide by 1".
    rcc.cfgr()
        .modify(|_, w| unsafe { w.mco2().pll2_p().mco2pre().bits(1) });
    rcc.ahb4enr().modify(|_, w| w.gpiocen().set_bit());
    gpioc.afrh().modify(|_, w| w.afr9().af0());
    gpioc
        .ospeedr()
        .modify(|_, w| w.ospeedr9().very_high_speed());
    gpioc.moder().modify(|_, w| w.moder9().alternate());

    rcc.d1cfgr()
        .modify(|_, w| w.d1cpre().div1().hpre().div2().d1ppre().div2());
    rcc.d2cfgr()
        .modify(|_, w| w.d2ppre1().div2().d2ppre2().div2());
    rcc.d3cfgr().modify(|_, w| w.d3ppre().div2());
    rcc.cfgr().modify(|_, w| w.sw().pll1());
    while !rcc.cfgr().read().sws().is_pll1() {}
    Clocks {
        source: Source::Crystal,
        usart_hz: APB1_HZ,
        tim2_hz: TIM2_HZ,
    }
}
