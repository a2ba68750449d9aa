//! The clock tree, on embassy-stm32's RCC driver, from the plan in
//! `lm_fw_nucleo_h743_logic::clocks` (dividers and their compile-time
//! checks live there).
//!
//! The crystal comes first: the ST-LINK's 8 MHz MCO into PF0/PH0-OSC_IN,
//! HSE in bypass. embassy-stm32's `init` waits for HSERDY without a
//! timeout (rcc/h.rs: `while !RCC.cr().read().hserdy() {}`), so a board
//! whose ST-LINK clock is not connected would hang there. [`probe_hse`]
//! therefore tries HSE on the registers first, with a bounded wait, and
//! [`config`] asks embassy for HSE only when it started.

use embassy_stm32::pac::RCC;
use embassy_stm32::rcc::{
    AHBPrescaler, APBPrescaler, HSIPrescaler, Hse, HseMode, Hsi48Config, Pll, PllDiv, PllMul,
    PllPreDiv, PllSource, Sysclk, VoltageScale, mux,
};
use embassy_stm32::time::Hertz;
use embassy_stm32::{Config, Peri, peripherals};
use lm_fw_nucleo_h743_logic::clocks as plan;

/// Which oscillator the board runs from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum Source {
    /// HSE from the ST-LINK's crystal: PLLs, exact reference and USB clock.
    Crystal,
    /// HSI: HSE did not start.
    InternalRc,
}

impl Source {
    /// The plan's numbers for this oscillator.
    pub const fn plan(self) -> plan::Plan {
        match self {
            Self::Crystal => plan::CRYSTAL,
            Self::InternalRc => plan::INTERNAL_RC,
        }
    }

    /// What `Info.clock` reports (`lmhost info`).
    pub const fn wire(self) -> lm_proto::ClockSource {
        match self {
            Self::Crystal => lm_proto::ClockSource::Crystal,
            Self::InternalRc => lm_proto::ClockSource::InternalRc,
        }
    }
}

/// Starts HSE in bypass mode and waits at most
/// [`plan::HSE_READY_POLLS`] reads for it; leaves it running if it is
/// ready (embassy then finds it so), else switches it off again.
///
/// Raw RCC registers because embassy-stm32 offers no bounded HSE start
/// (see the module comment). RM0433 "Reset and clock control", RCC_CR: HSEBYP may be written
/// only while HSEON is 0; HSERDY follows HSEON once the clock runs. Runs
/// before `embassy_stm32::init`, on the reset clock (HSI), alone.
pub fn probe_hse() -> Source {
    let cr = RCC.cr();
    cr.modify(|w| w.set_hseon(false));
    cr.modify(|w| w.set_hsebyp(true));
    cr.modify(|w| w.set_hseon(true));
    for _ in 0..plan::HSE_READY_POLLS {
        if cr.read().hserdy() {
            return Source::Crystal;
        }
    }
    cr.modify(|w| w.set_hseon(false));
    // A clock that never started leaves HSERDY low; one that came up just
    // now drops it within six HSE cycles of HSEON going low.
    while cr.read().hserdy() {}
    cr.modify(|w| w.set_hsebyp(false));
    Source::InternalRc
}

/// embassy-stm32's configuration for `source`: the plan's dividers on the
/// crystal, HSI at 64 MHz everywhere on the fallback. VOS1 in both
/// (400 MHz core at most); SPI1's kernel clock is per_ck = HSI in both, so
/// SCK is 16 MHz either way; USART3 runs from pclk1 (the HAL's default).
pub fn config(source: Source) -> Config {
    let mut config = Config::default();
    let r = &mut config.rcc;
    r.hsi = Some(HSIPrescaler::DIV1);
    r.csi = false;
    r.voltage_scale = VoltageScale::Scale1;
    r.mux.persel = mux::Persel::HSI;
    r.mux.spi123sel = mux::Saisel::PER;
    match source {
        Source::Crystal => {
            r.hse = Some(Hse {
                freq: Hertz(plan::HSE_HZ),
                mode: HseMode::Bypass,
            });
            r.hsi48 = None;
            r.pll1 = Some(pll(plan::PLL1));
            r.pll2 = Some(pll(plan::PLL2));
            r.pll3 = Some(pll(plan::PLL3));
            r.sys = Sysclk::PLL1_P;
            r.d1c_pre = ahb(plan::CORE_DIV);
            r.ahb_pre = ahb(plan::AHB_DIV);
            r.apb1_pre = apb(plan::APB_DIV);
            r.apb2_pre = apb(plan::APB_DIV);
            r.apb3_pre = apb(plan::APB_DIV);
            r.apb4_pre = apb(plan::APB_DIV);
            r.mux.usbsel = mux::Usbsel::PLL3_Q;
        }
        Source::InternalRc => {
            r.hse = None;
            // USB's 48 MHz from HSI48, trimmed to the host's start-of-frame
            // packets by the CRS (RM0433, "Clock recovery system (CRS)").
            r.hsi48 = Some(Hsi48Config {
                sync_from_usb: true,
            });
            r.pll1 = None;
            r.pll2 = None;
            r.pll3 = None;
            r.sys = Sysclk::HSI;
            r.mux.usbsel = mux::Usbsel::HSI48;
        }
    }
    config
}

/// One PLL from the plan (RCC_PLLCKSELR DIVMx holds M, RCC_PLLxDIVR holds
/// N − 1 and each output divider − 1: RM0433, RCC_PLLCKSELR and
/// RCC_PLLxDIVR).
fn pll(p: plan::Pll) -> Pll {
    let div = |d: Option<u32>| d.map(|d| PllDiv::from_bits((d - 1) as u8));
    Pll {
        source: PllSource::HSE,
        prediv: PllPreDiv::from_bits(p.m as u8),
        mul: PllMul::from_bits((p.n - 1) as u16),
        fracn: None,
        divp: div(p.p),
        divq: div(p.q),
        divr: div(p.r),
    }
}

fn ahb(div: u32) -> AHBPrescaler {
    match div {
        1 => AHBPrescaler::DIV1,
        2 => AHBPrescaler::DIV2,
        _ => panic!("AHB prescaler not in the plan"),
    }
}

fn apb(div: u32) -> APBPrescaler {
    match div {
        1 => APBPrescaler::DIV1,
        2 => APBPrescaler::DIV2,
        _ => panic!("APB prescaler not in the plan"),
    }
}

/// Logs the clock source and the plan's clocks (info), and the clocks
/// embassy recorded (debug).
pub fn log(source: Source, rcc: &Peri<'_, peripherals::RCC>) {
    let plan = source.plan();
    let clocks = embassy_stm32::rcc::clocks(rcc);
    match source {
        Source::Crystal => defmt::info!(
            "clock: crystal (HSE {=u32} Hz bypass, the ST-LINK's MCO); core {=u32} Hz, \
             USART3 {=u32} Hz, TIM2 {=u32} Hz, reference {=u32} Hz on MCO2",
            plan::HSE_HZ,
            plan.core_hz,
            plan.usart3_hz,
            plan.tim2_hz,
            plan::MCO2_HZ
        ),
        Source::InternalRc => defmt::warn!(
            "clock: HSE did not start within {=u32} polls: internal RC (HSI {=u32} Hz, \
             ~1 %); no reference output, USB from HSI48 + CRS",
            plan::HSE_READY_POLLS,
            plan::HSI_HZ
        ),
    }
    defmt::debug!("embassy clocks: {}", clocks);
}
