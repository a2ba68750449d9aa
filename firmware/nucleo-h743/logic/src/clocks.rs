//! The clock plan, as numbers, and its checks.
//!
//! On the crystal: the ST-LINK's 8 MHz MCO drives the H743's HSE input in
//! bypass mode (PF0/PH0-OSC_IN; UM2407 §7.5.1 "MCO from ST-LINK
//! (Default)"; UM1974 describes the same for MB1137); PLL1 makes
//! the 400 MHz core clock (VOS1), 200 MHz AXI/AHB, 100 MHz APBs; PLL2 P the
//! driver boards' 10.24 MHz reference on MCO2; PLL3 Q USB's 48 MHz. The
//! 1 MHz timebase divides the 200 MHz APB1 timer clock by 200.
//!
//! On the internal RC oscillator (HSE did not start): everything at HSI's
//! 64 MHz, no PLL, the timebase divides it by 64, USB runs from HSI48
//! trimmed by the host's start-of-frame packets (CRS), and there is no
//! reference output.
//!
//! Every limit below is RM0433's ("Reset and clock control"): PLL input
//! ranges and VCO ranges, DIVN/DIVM/DIVP ranges, the VOS1 bus maxima. The
//! checks run at compile time (`const _: () = ...` at the end of this
//! file), so a wrong divider fails the build of the firmware and of these
//! tests alike; [`check_plan`] is the same check callable from a test.

/// The ST-LINK's MCO into PF0/PH0-OSC_IN (HSE bypass), Hz: 8 MHz on both
/// boards (UM2407 §7.5.1; on MB1137, UM1974's HSE clock section).
pub const HSE_HZ: u32 = 8_000_000;
/// The internal RC oscillator, HSIDIV /1, Hz.
pub const HSI_HZ: u32 = 64_000_000;
/// USB's kernel clock, Hz (either PLL3 Q or HSI48).
pub const USB_HZ: u32 = 48_000_000;
/// The driver boards' shared reference: 40 kHz carrier × 256 counts
/// (`firmware/DRIVER.md`, "Clock"), multiplied by 8 in their PLL.
pub const DRIVER_REF_HZ: u32 = 10_240_000;
/// The player's timebase: the 32-bit counter `lm_fw_core::serve` reads.
pub const TIMER_HZ: u32 = 1_000_000;
/// SPI1's kernel clock: per_ck, which is HSI on both plans, so the SPI
/// clock does not change when HSE is missing (`firmware/DRIVER.md`, "Bus").
pub const SPI_KERNEL_HZ: u32 = HSI_HZ;
/// SPI1's SCK, Hz: the kernel clock / 4.
pub const SPI_SCK_HZ: u32 = 16_000_000;
/// The fastest SCK the driver gateware samples safely: f_clk / 4 at its
/// default 81.92 MHz (`firmware/DRIVER.md`, "Bus").
pub const DRIVER_MAX_SCK_HZ: u32 = 20_480_000;
/// Reads of RCC_CR.HSERDY before the board gives up on HSE and stays on
/// HSI: 10⁶ reads of a register in the D3 domain at 64 MHz, some tens to a
/// few hundred milliseconds of start-up on a board without the clock; the
/// ST-LINK's MCO runs before it releases the target's reset, so a present
/// clock is ready at the first reads.
pub const HSE_READY_POLLS: u32 = 1_000_000;

/// One PLL's dividers, as RM0433 names them (DIVMx, DIVNx, DIVPx, DIVQx,
/// DIVRx); `None` leaves that output off. No fractional part.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pll {
    /// Input divider DIVM, 1..=63.
    pub m: u32,
    /// Multiplier DIVN, 4..=512.
    pub n: u32,
    /// P output divider, 1..=128 (PLL1: even only).
    pub p: Option<u32>,
    /// Q output divider, 1..=128.
    pub q: Option<u32>,
    /// R output divider, 1..=128.
    pub r: Option<u32>,
}

/// PLL1: 8 MHz / 4 = 2 MHz × 400 = 800 MHz (wide VCO) / 2 = 400 MHz sys_ck.
pub const PLL1: Pll = Pll {
    m: 4,
    n: 400,
    p: Some(2),
    q: None,
    r: None,
};
/// PLL2: 8 MHz / 5 = 1.6 MHz × 256 = 409.6 MHz (medium VCO, the only one
/// allowed below 2 MHz input) / 40 = 10.24 MHz on MCO2, exactly.
pub const PLL2: Pll = Pll {
    m: 5,
    n: 256,
    p: Some(40),
    q: None,
    r: None,
};
/// PLL3: 8 MHz / 4 = 2 MHz × 240 = 480 MHz (wide VCO) / 10 = 48 MHz USB.
pub const PLL3: Pll = Pll {
    m: 4,
    n: 240,
    p: None,
    q: Some(10),
    r: None,
};

/// D1CPRE: sys_ck to the core, /1.
pub const CORE_DIV: u32 = 1;
/// HPRE: sys_ck to AXI/AHB, /2 on the crystal plan.
pub const AHB_DIV: u32 = 2;
/// D1PPRE, D2PPRE1, D2PPRE2, D3PPRE: AHB to the APBs, /2 on the crystal plan.
pub const APB_DIV: u32 = 2;

/// sys_ck and the Cortex-M7 on the crystal, Hz.
pub const SYS_HZ: u32 = pll_output(HSE_HZ, PLL1, PLL1.p);
/// AXI/AHB on the crystal, Hz.
pub const AHB_HZ: u32 = SYS_HZ / AHB_DIV;
/// APB1 on the crystal: USART3's kernel clock (pclk1), Hz.
pub const APB1_HZ: u32 = AHB_HZ / APB_DIV;
/// TIM2's clock on the crystal: with TIMPRE = 0 and APB1 divided by 2 it is
/// twice pclk1 (RM0433, RCC "Timer clock"), Hz.
pub const APB1_TIMER_HZ: u32 = timer_clock(AHB_HZ, APB_DIV);
/// MCO2's output on the crystal, Hz.
pub const MCO2_HZ: u32 = pll_output(HSE_HZ, PLL2, PLL2.p);
/// USB's kernel clock on the crystal, Hz.
pub const PLL3_Q_HZ: u32 = pll_output(HSE_HZ, PLL3, PLL3.q);

/// The clocks the peripherals see, on one oscillator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Plan {
    /// The Cortex-M7, Hz.
    pub core_hz: u32,
    /// AXI/AHB, Hz.
    pub ahb_hz: u32,
    /// USART3's kernel clock (pclk1), Hz.
    pub usart3_hz: u32,
    /// TIM2's clock (the 1 MHz timebase's input), Hz.
    pub tim2_hz: u32,
    /// SPI1's kernel clock, Hz.
    pub spi_hz: u32,
    /// The reference on MCO2, Hz, if there is one.
    pub reference_hz: Option<u32>,
}

/// The plan on the crystal.
pub const CRYSTAL: Plan = Plan {
    core_hz: SYS_HZ / CORE_DIV,
    ahb_hz: AHB_HZ,
    usart3_hz: APB1_HZ,
    tim2_hz: APB1_TIMER_HZ,
    spi_hz: SPI_KERNEL_HZ,
    reference_hz: Some(MCO2_HZ),
};

/// The plan on HSI: no PLL, no prescaler, no reference.
pub const INTERNAL_RC: Plan = Plan {
    core_hz: HSI_HZ,
    ahb_hz: HSI_HZ,
    usart3_hz: HSI_HZ,
    tim2_hz: timer_clock(HSI_HZ, 1),
    spi_hz: SPI_KERNEL_HZ,
    reference_hz: None,
};

/// A PLL output: `input / m × n / div`, Hz (0 for an output that is off).
pub const fn pll_output(input_hz: u32, pll: Pll, div: Option<u32>) -> u32 {
    match div {
        Some(d) => (input_hz as u64 / pll.m as u64 * pll.n as u64 / d as u64) as u32,
        None => 0,
    }
}

/// TIMx on APB1 with TIMPRE = 0: the AHB clock when APB1 is divided by 1
/// or 2, else twice pclk1 (RM0433, RCC "Timer clock").
pub const fn timer_clock(ahb_hz: u32, apb_div: u32) -> u32 {
    if apb_div <= 2 {
        ahb_hz
    } else {
        ahb_hz / apb_div * 2
    }
}

/// Which VCO range a PLL runs in (RM0433, RCC_PLLCFGR.PLLxVCOSEL).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Vco {
    /// 150..=420 MHz: required when the PLL input is below 2 MHz.
    Medium,
    /// 192..=836 MHz: only for a PLL input of 2 MHz or more.
    Wide,
}

/// Checks one PLL against RM0433's limits on its input, VCO and dividers;
/// returns the VCO range it must use.
pub const fn check_pll(input_hz: u32, pll: Pll, is_pll1: bool) -> Result<Vco, &'static str> {
    if pll.m < 1 || pll.m > 63 {
        return Err("DIVM must be 1..=63");
    }
    if !input_hz.is_multiple_of(pll.m) {
        return Err("the PLL input must divide exactly");
    }
    let reference = input_hz / pll.m;
    if reference < 1_000_000 || reference > 16_000_000 {
        return Err("the PLL input must be 1..=16 MHz (PLLxRGE)");
    }
    if pll.n < 4 || pll.n > 512 {
        return Err("DIVN must be 4..=512");
    }
    let vco = reference as u64 * pll.n as u64;
    let range = if reference >= 2_000_000 && vco >= 192_000_000 && vco <= 836_000_000 {
        Vco::Wide
    } else if vco >= 150_000_000 && vco <= 420_000_000 {
        Vco::Medium
    } else {
        return Err("VCO outside 150..=420 MHz (medium) and 192..=836 MHz (wide, input >= 2 MHz)");
    };
    let divs = [pll.p, pll.q, pll.r];
    let mut i = 0;
    while i < divs.len() {
        if let Some(d) = divs[i]
            && (d < 1 || d > 128)
        {
            return Err("PLL output dividers must be 1..=128");
        }
        i += 1;
    }
    if is_pll1
        && let Some(p) = pll.p
        && !p.is_multiple_of(2)
    {
        return Err("DIVP1 must be even");
    }
    Ok(range)
}

/// USART3's divider as the HAL programs it (embassy-stm32 0.6
/// `find_and_set_brr` for a USART on H7: the smallest prescaler PRESC for
/// which BRR = round(f / PRESC / baud) fits 16 bits, 16× oversampling for
/// BRR >= 16, 8× for 8 <= BRR < 16; RM0433, USART "Baud rate
/// generation").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct UsartDivider {
    /// PRESC divider (1, 2, 4, ..., 256).
    pub presc: u32,
    /// USARTDIV in units of the prescaled clock.
    pub brr: u32,
    /// 8× oversampling.
    pub over8: bool,
}

/// PRESC's dividers in register order (RM0433, USART_PRESC).
const USART_PRESC: [u32; 12] = [1, 2, 4, 6, 8, 10, 12, 16, 32, 64, 128, 256];

/// The divider for `baud` from `kernel_hz`, or `None` if none fits.
pub const fn usart_divider(kernel_hz: u32, baud: u32) -> Option<UsartDivider> {
    if baud == 0 {
        return None;
    }
    let mut i = 0;
    while i < USART_PRESC.len() {
        let presc = USART_PRESC[i];
        let clock = kernel_hz / presc;
        let brr = clock / baud + ((clock % baud) + baud / 2) / baud;
        if brr < 16 {
            if brr * 2 >= 16 {
                return Some(UsartDivider {
                    presc,
                    brr,
                    over8: true,
                });
            }
            return None;
        }
        if brr < 0x1_0000 {
            return Some(UsartDivider {
                presc,
                brr,
                over8: false,
            });
        }
        i += 1;
    }
    None
}

/// The rate USART3 really runs at for `baud`, or `None` if it cannot.
pub const fn actual_baud(kernel_hz: u32, baud: u32) -> Option<u32> {
    match usart_divider(kernel_hz, baud) {
        Some(d) => Some(kernel_hz / d.presc / d.brr),
        None => None,
    }
}

/// How far the real rate is off `baud`, in parts per million.
pub const fn baud_error_ppm(kernel_hz: u32, baud: u32) -> Option<u32> {
    match actual_baud(kernel_hz, baud) {
        Some(real) => {
            let diff = real.abs_diff(baud) as u64;
            Some((diff * 1_000_000 / baud as u64) as u32)
        }
        None => None,
    }
}

/// The largest rate error the host link accepts: 2 % (a UART frame of 10
/// bits tolerates about 4 % between both ends together).
pub const MAX_BAUD_ERROR_PPM: u32 = 20_000;
/// The host link's rate range: lmhost's `--baud` down to 1200, up to the
/// 4 Mbaud USART3 takes at 16× oversampling from HSI's 64 MHz.
pub const BAUD_RANGE: core::ops::RangeInclusive<u32> = 1200..=4_000_000;

/// `LM_BAUD` (decimal) as a number.
pub const fn parse_baud(s: &str) -> Result<u32, &'static str> {
    let b = s.as_bytes();
    if b.is_empty() {
        return Err("LM_BAUD is empty");
    }
    let mut v: u32 = 0;
    let mut i = 0;
    while i < b.len() {
        if !b[i].is_ascii_digit() {
            return Err("LM_BAUD must be a decimal number of baud");
        }
        v = v * 10 + (b[i] - b'0') as u32;
        if v > 100_000_000 {
            return Err("LM_BAUD is too large");
        }
        i += 1;
    }
    Ok(v)
}

/// Checks a host link rate: in [`BAUD_RANGE`] and within
/// [`MAX_BAUD_ERROR_PPM`] on both plans' USART3 clocks.
pub const fn check_baud(baud: u32) -> Result<(), &'static str> {
    if baud < *BAUD_RANGE.start() || baud > *BAUD_RANGE.end() {
        return Err("LM_BAUD must be 1200..=4000000");
    }
    let clocks = [CRYSTAL.usart3_hz, INTERNAL_RC.usart3_hz];
    let mut i = 0;
    while i < clocks.len() {
        match baud_error_ppm(clocks[i], baud) {
            Some(e) if e <= MAX_BAUD_ERROR_PPM => {}
            Some(_) => return Err("LM_BAUD is more than 2 % off on one of the clocks"),
            None => return Err("USART3 cannot make LM_BAUD on one of the clocks"),
        }
        i += 1;
    }
    Ok(())
}

/// The host link's rate: `LM_BAUD` when the firmware was built, else
/// 115 200 (lmhost's default `--baud`).
pub const BAUD: u32 = match option_env!("LM_BAUD") {
    Some(s) => match parse_baud(s) {
        Ok(b) => b,
        Err(e) => panic!("{}", e),
    },
    None => 115_200,
};

/// SPI's clock divider as the HAL picks it for a requested frequency
/// (embassy-stm32 0.6 `compute_baud_rate`: the ratio kernel / requested,
/// rounded into MBR's powers of two 2..=256), and the SCK that results.
pub const fn spi_sck(kernel_hz: u32, requested_hz: u32) -> Option<u32> {
    if requested_hz == 0 {
        return None;
    }
    let div = match kernel_hz / requested_hz {
        0 => return None,
        1..=2 => 2,
        3..=5 => 4,
        6..=11 => 8,
        12..=23 => 16,
        24..=39 => 32,
        40..=95 => 64,
        96..=191 => 128,
        _ => 256,
    };
    Some(kernel_hz / div)
}

/// The prescaler a TIMx needs to count at [`TIMER_HZ`] from `timer_hz`, if
/// it divides exactly (the HAL's time driver sets PSC = timer clock / tick
/// rate − 1 and truncates, so exactness is ours to check; any 32-bit clock
/// over 1 MHz fits PSC's 16 bits).
pub const fn timebase_prescaler(timer_hz: u32) -> Option<u32> {
    if timer_hz == 0 || !timer_hz.is_multiple_of(TIMER_HZ) {
        return None;
    }
    Some(timer_hz / TIMER_HZ)
}

/// Every check of the plan: both PLL plans, the VOS1 bus maxima, the
/// exact outputs, the timebase and SPI on both oscillators, `LM_BAUD`.
pub const fn check_plan() -> Result<(), &'static str> {
    match check_pll(HSE_HZ, PLL1, true) {
        Ok(Vco::Wide) => {}
        Ok(Vco::Medium) => return Err("PLL1 is planned on the wide VCO"),
        Err(e) => return Err(e),
    }
    match check_pll(HSE_HZ, PLL2, false) {
        Ok(Vco::Medium) => {}
        Ok(Vco::Wide) => return Err("PLL2 is planned on the medium VCO"),
        Err(e) => return Err(e),
    }
    if let Err(e) = check_pll(HSE_HZ, PLL3, false) {
        return Err(e);
    }
    if SYS_HZ != 400_000_000 || CRYSTAL.core_hz > 400_000_000 {
        return Err("the core runs at 400 MHz, VOS1's maximum");
    }
    if AHB_HZ > 200_000_000 || APB1_HZ > 100_000_000 {
        return Err("VOS1 allows 200 MHz AXI/AHB and 100 MHz APB");
    }
    if MCO2_HZ != DRIVER_REF_HZ
        || HSE_HZ as u64 / PLL2.m as u64 * PLL2.n as u64 != DRIVER_REF_HZ as u64 * 40
    {
        return Err("the driver reference must be 10.24 MHz exactly");
    }
    if PLL3_Q_HZ != USB_HZ || !(HSE_HZ / PLL3.m * PLL3.n).is_multiple_of(USB_HZ) {
        return Err("USB needs 48 MHz exactly");
    }
    let plans = [CRYSTAL, INTERNAL_RC];
    let mut i = 0;
    while i < plans.len() {
        if timebase_prescaler(plans[i].tim2_hz).is_none() {
            return Err("TIM2's clock must divide to 1 MHz exactly");
        }
        match spi_sck(plans[i].spi_hz, SPI_SCK_HZ) {
            Some(sck) if sck == SPI_SCK_HZ && sck <= DRIVER_MAX_SCK_HZ => {}
            _ => return Err("SPI1's SCK must be 16 MHz exactly, at most the driver's f_clk / 4"),
        }
        i += 1;
    }
    check_baud(BAUD)
}

const _: () = match check_plan() {
    Ok(()) => {}
    Err(e) => panic!("{}", e),
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_plan_passes_its_checks() {
        assert_eq!(check_plan(), Ok(()));
        assert_eq!(CRYSTAL.core_hz, 400_000_000);
        assert_eq!(CRYSTAL.ahb_hz, 200_000_000);
        assert_eq!(CRYSTAL.usart3_hz, 100_000_000);
        assert_eq!(CRYSTAL.tim2_hz, 200_000_000);
        assert_eq!(CRYSTAL.reference_hz, Some(10_240_000));
        assert_eq!(PLL3_Q_HZ, 48_000_000);
        assert_eq!(INTERNAL_RC.tim2_hz, 64_000_000);
        assert_eq!(INTERNAL_RC.reference_hz, None);
    }

    #[test]
    fn pll_checks_catch_each_limit() {
        let ok = PLL1;
        assert_eq!(check_pll(HSE_HZ, ok, true), Ok(Vco::Wide));
        assert_eq!(check_pll(HSE_HZ, PLL2, false), Ok(Vco::Medium));
        // Input below 1 MHz, not an exact division, DIVM out of range.
        assert!(check_pll(HSE_HZ, Pll { m: 16, ..ok }, true).is_err());
        assert!(check_pll(HSE_HZ, Pll { m: 3, ..ok }, true).is_err());
        assert!(check_pll(HSE_HZ, Pll { m: 64, ..ok }, true).is_err());
        // 2 MHz × 420 = 840 MHz: above the wide VCO's 836 MHz.
        assert!(check_pll(HSE_HZ, Pll { n: 420, ..ok }, true).is_err());
        // 1.6 MHz × 300 = 480 MHz: a sub-2 MHz input may not use the wide VCO.
        assert!(check_pll(HSE_HZ, Pll { n: 300, ..PLL2 }, false).is_err());
        // Odd DIVP1, a divider above 128, DIVN below 4.
        assert!(check_pll(HSE_HZ, Pll { p: Some(3), ..ok }, true).is_err());
        assert_eq!(
            check_pll(HSE_HZ, Pll { p: Some(3), ..ok }, false),
            Ok(Vco::Wide)
        );
        assert!(check_pll(HSE_HZ, Pll { q: Some(129), ..ok }, true).is_err());
        assert!(check_pll(HSE_HZ, Pll { n: 3, ..ok }, true).is_err());
    }

    #[test]
    fn usart_divider_matches_the_hal_and_rm0433() {
        // 100 MHz / 115200 = 868.05 -> 868: 115207 Bd, 16x oversampling.
        let d = usart_divider(100_000_000, 115_200).unwrap();
        assert_eq!((d.presc, d.brr, d.over8), (1, 868, false));
        assert_eq!(actual_baud(100_000_000, 115_200), Some(115_207));
        assert_eq!(baud_error_ppm(100_000_000, 115_200), Some(60));
        // 64 MHz / 115200 = 555.56 -> 556 (rounded, not truncated).
        assert_eq!(usart_divider(64_000_000, 115_200).unwrap().brr, 556);
        // 1200 Bd from 100 MHz: BRR 83333 does not fit 16 bits, PRESC /2 does.
        let d = usart_divider(100_000_000, 1200).unwrap();
        assert_eq!((d.presc, d.brr), (2, 41_667));
        // 4 Mbaud from 64 MHz: BRR 16, still 16x; 8 Mbaud: 8x oversampling.
        assert!(!usart_divider(64_000_000, 4_000_000).unwrap().over8);
        assert!(usart_divider(64_000_000, 8_000_000).unwrap().over8);
        assert_eq!(usart_divider(64_000_000, 9_000_000), None);
        assert_eq!(usart_divider(64_000_000, 0), None);
    }

    #[test]
    fn baud_rates_are_checked_on_both_clocks() {
        for baud in [1200, 9600, 115_200, 230_400, 921_600, 2_000_000, 4_000_000] {
            assert_eq!(check_baud(baud), Ok(()), "{baud}");
        }
        // 3 Mbaud: 100 MHz / 33 = 3.03 Mbaud (1 %), 64 MHz / 21 = 3.05 (1.6 %).
        assert_eq!(check_baud(3_000_000), Ok(()));
        // 3.5 Mbaud: 64 MHz / 18 = 3.56 Mbaud, 1.6 %; 100 MHz / 29 = 3.45, 1.5 %.
        assert_eq!(check_baud(3_500_000), Ok(()));
        // 3.3 Mbaud: 64 MHz / 19 = 3.37 Mbaud, 2.1 % off: refused.
        assert!(check_baud(3_300_000).is_err());
        assert!(check_baud(1199).is_err());
        assert!(check_baud(4_000_001).is_err());
    }

    #[test]
    fn lm_baud_parses_decimal_only() {
        assert_eq!(parse_baud("2000000"), Ok(2_000_000));
        assert_eq!(parse_baud("115200"), Ok(115_200));
        assert!(parse_baud("").is_err());
        assert!(parse_baud("115k").is_err());
        assert!(parse_baud("-1").is_err());
        assert!(parse_baud("999999999999").is_err());
    }

    #[test]
    fn spi_and_timebase_dividers() {
        assert_eq!(spi_sck(64_000_000, 16_000_000), Some(16_000_000));
        // The HAL rounds a ratio of 5 down to /4: 25 MHz from 100 MHz would
        // be 25 MHz, too fast for the driver; our plan never asks for it.
        assert_eq!(spi_sck(100_000_000, 20_000_000), Some(25_000_000));
        assert_eq!(spi_sck(64_000_000, 0), None);
        assert_eq!(timebase_prescaler(200_000_000), Some(200));
        assert_eq!(timebase_prescaler(64_000_000), Some(64));
        assert_eq!(timebase_prescaler(64_500_000), None);
        assert_eq!(timebase_prescaler(0), None);
    }

    #[test]
    fn timer_clock_follows_timpre_0() {
        assert_eq!(timer_clock(200_000_000, 1), 200_000_000);
        assert_eq!(timer_clock(200_000_000, 2), 200_000_000);
        assert_eq!(timer_clock(200_000_000, 4), 100_000_000);
    }
}
