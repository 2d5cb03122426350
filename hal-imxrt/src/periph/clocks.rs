//! Clock-root selection and clock gates for the peripherals this crate uses.
//!
//! Assumes the boot code already runs the core at 600 MHz with IPG at
//! 150 MHz (see [`crate::pure::clock`]).

use imxrt_ral as ral;
use ral::ccm;

/// Gate value "clock on in run and wait modes".
const ON: u32 = 0b11;

/// Select PERCLK = OSC/1 (24 MHz, PIT) and UART_CLK_ROOT = OSC/1 (24 MHz),
/// and open the gates of PIT, TMR1, TMR3, PWM1..4, XBARA1, LPUART6,
/// GPIO1..4 and RTWDOG (WDOG3).
///
/// The muxes are changed with the PIT and LPUART6 gates closed, as the
/// reference manual recommends for glitch-free switching.
pub fn configure(ccm: &ccm::CCM) {
    // Close the gates of the consumers of the roots we switch.
    ral::modify_reg!(ral::ccm, ccm, CCGR1, CG6: 0);
    ral::modify_reg!(ral::ccm, ccm, CCGR3, CG3: 0);
    // PERCLK_CLK_SEL = 1 (osc_clk), PERCLK_PODF = 0 (/1)
    ral::modify_reg!(ral::ccm, ccm, CSCMR1, PERCLK_CLK_SEL: 1, PERCLK_PODF: 0);
    // UART_CLK_SEL = 1 (osc_clk), UART_CLK_PODF = 0 (/1)
    ral::modify_reg!(ral::ccm, ccm, CSCDR1, UART_CLK_SEL: 1, UART_CLK_PODF: 0);
    // Gates (cell numbers from the imxrt-ral field docs: pit = CCGR1 CG6,
    // gpio1 = CCGR1 CG13, gpio2 = CCGR0 CG15, gpio3 = CCGR2 CG13,
    // xbar1 = CCGR2 CG11 (the J6 STEP route of pin 7; FlexPWM fault inputs),
    // gpio4 = CCGR3 CG6, lpuart6 = CCGR3 CG3, pwm1..4 = CCGR4 CG8..CG11,
    // wdog3 = CCGR5 CG2, timer1 = CCGR6 CG13, timer3 = CCGR6 CG15).
    ral::modify_reg!(ral::ccm, ccm, CCGR0, CG15: ON);
    ral::modify_reg!(ral::ccm, ccm, CCGR1, CG6: ON, CG13: ON);
    ral::modify_reg!(ral::ccm, ccm, CCGR2, CG11: ON, CG13: ON);
    ral::modify_reg!(ral::ccm, ccm, CCGR3, CG3: ON, CG6: ON);
    ral::modify_reg!(ral::ccm, ccm, CCGR4, CG8: ON, CG9: ON, CG10: ON, CG11: ON);
    ral::modify_reg!(ral::ccm, ccm, CCGR5, CG2: ON);
    ral::modify_reg!(ral::ccm, ccm, CCGR6, CG13: ON, CG15: ON);
}
