//! FlexPWM (PWM1..4) model: four submodules per module.
//!
//! Modelled (i.MXRT1060 RM, eFlexPWM chapter): 16-bit counter from `INIT`
//! up to `VAL1` then reload, clocked by IPG (150 MHz = 4 CPU cycles) / 2^PRSC;
//! output A high from the `VAL2` compare to the `VAL3` compare, B with
//! `VAL4`/`VAL5` (edge-aligned, counter starting at `INIT`). Double
//! buffering: `INIT`, `VALx` and `CTRL[PRSC]` are written to buffers; a write
//! while the submodule's `LDOK` is set is **ignored**; buffers load at the
//! next full-cycle reload (`CTRL[FULL]`) when `LDOK` is set, or immediately
//! upon `LDOK` being set if `LDMOD = 1` (imxrt-ral `SMCTRL[LDMOD]` field
//! docs); `LDOK` then clears (`CLDOK` clears it by software). Setting `RUN`
//! loads nothing (the field docs name no such load; a model that loads on
//! `RUN` 0 -> 1 hides defect 3 of twin/README.md): the
//! counter starts from its current value with the active registers. `CTRL2[FORCE]` with `FRCEN` and
//! `FORCE_SEL = 0` re-initialises the counter to `INIT` (no buffer load).
//! `MASK` (with `UPDATE_MASK`: immediately; otherwise at the next reload)
//! forces an output to 0; `OUTEN` enables the pad driver.
//!
//! Fault protection with its **reset state**: four fault inputs per module
//! come from XBARA1 outputs (reset selection `LOGIC_LOW`); `FCTRL0[FLVL]`
//! = 0 (reset) means logic 0 is a fault; `SMDISMAP0` resets to `0xFFFF`
//! (every fault disables A and B). A fault sets `FSTS0[FFLAG]` while its input
//! is active (writing 1 clears it only if the input is inactive). Output
//! disabled while any mapped fault flag is set or its input is active;
//! re-enabled as soon as both are clear (the `FFULL`/`FHALF` recovery
//! timing and `FSAFE`/`FAUTO` differences are not modelled).
//!
//! Not modelled: complementary mode, dead time, half-cycle reloads, `LDFQ`,
//! fractional delay, input capture, DMA/interrupts, `WAITEN`,
//! `SWCOUT`/`DTSRCSEL` other than 0, center-aligned waveforms with a signed
//! `INIT`.
//!
//! `CTRL2[DBGEN]`: while [`FlexPwm::debug_halted`] (a debugger halts the
//! core, see `Twin::debug_halt`) a submodule with `DBGEN = 0` stops
//! counting; with `DBGEN = 1` it keeps running.
//!
//! Trigger output `PWM_OUT_TRIG0` (`TCTRL[PWAOT0] = 1`): the PWM_A
//! waveform itself, ahead of `MASK`, `OUTEN` and the fault logic (they act
//! on the pad outputs only), towards XBARA1. [`OutputLog`] index 2 counts
//! its rising edges when [`PadRoute::trig0`] says it reaches a pad.

/// One output's observed pulses.
#[derive(Clone, Debug, Default)]
pub struct OutputLog {
    /// Rising edges that reached the pad (PWM function selected, output
    /// enabled, not masked, not fault-disabled).
    pub pulses: u64,
    /// Time (cycles) of the last rising edge.
    pub last_rise: Option<u64>,
    /// Rising-edge times (kept if `record` is set; bounded).
    pub rises: Vec<u64>,
}

/// A submodule.
#[derive(Clone, Debug)]
pub struct Submodule {
    /// Active registers: INIT, VAL0..VAL5.
    pub init: u16,
    /// VAL0..VAL5.
    pub val: [u16; 6],
    /// Active prescaler (log2).
    pub prsc: u16,
    /// Buffered INIT.
    pub b_init: u16,
    /// Buffered VALx.
    pub b_val: [u16; 6],
    /// CTRL register as written (PRSC field = buffered value).
    pub ctrl: u16,
    /// CTRL2.
    pub ctrl2: u16,
    /// Other registers (OCTRL, TCTRL, DISMAP0/1, ...) by offset.
    pub other: [u16; 0x30],
    /// Counter value at `t_cnt`.
    pub cnt: u16,
    /// Time of `cnt` (cycles), always a counter-clock boundary when running.
    pub t_cnt: u64,
    /// Writes dropped because LDOK was set (diagnostic).
    pub dropped_writes: u64,
    /// Output logs A, B, and `PWM_OUT_TRIG0` (index 2).
    pub log: [OutputLog; 3],
    /// The counter was (re)initialised to INIT at `t_cnt` and the compare
    /// at INIT has not been evaluated yet.
    pub at_start: bool,
    /// `RUN` went 0 -> 1 and the first compare at the start has not been
    /// evaluated yet.
    pub just_started: bool,
    /// Starts (`RUN` 0 -> 1).
    pub starts: u64,
    /// Starts whose active period (`VAL1`, `PRSC`) differed from the
    /// buffered one written for it: the first period ran at a stale rate
    /// (defect 3 of twin/README.md). (active, buffered) period in cycles of the last.
    pub stale_starts: u64,
    /// The last stale start: (active, buffered) period in CPU cycles.
    pub last_stale: Option<(u64, u64)>,
    /// Rising edges at the very instant of a start (defect 4 of twin/README.md).
    pub rises_at_start: u64,
    /// Start times (cycles; the time of the last sync before the `RUN`
    /// write), bounded.
    pub start_times: Vec<u64>,
    /// `PWM_OUT_TRIG0` rising edges that reached a pad while PWM_A was
    /// masked (`MASK` does not gate the trigger path in this model).
    pub trig_rises_masked: u64,
}

impl Submodule {
    fn new() -> Self {
        let mut other = [0u16; 0x30];
        other[0x2C / 2] = 0xFFFF; // DISMAP0 reset
        other[0x2E / 2] = 0xFFFF; // DISMAP1 reset
        Submodule {
            init: 0,
            val: [0; 6],
            prsc: 0,
            b_init: 0,
            b_val: [0; 6],
            ctrl: 0x0400,
            ctrl2: 0,
            other,
            cnt: 0,
            t_cnt: 0,
            dropped_writes: 0,
            log: [OutputLog::default(), OutputLog::default(), OutputLog::default()],
            at_start: false,
            just_started: false,
            starts: 0,
            stale_starts: 0,
            last_stale: None,
            rises_at_start: 0,
            start_times: Vec::new(),
            trig_rises_masked: 0,
        }
    }
    /// DISMAP0.
    pub fn dismap0(&self) -> u16 {
        self.other[0x2C / 2]
    }
    fn cycles_per_count(&self) -> u64 {
        4u64 << self.prsc
    }
    /// `TCTRL[PWAOT0]`: PWM_A drives `PWM_OUT_TRIG0`.
    pub fn pwaot0(&self) -> bool {
        self.other[0x2A / 2] & (1 << 15) != 0
    }
    /// `CTRL2[DBGEN]`.
    pub fn dbgen(&self) -> bool {
        self.ctrl2 & (1 << 15) != 0
    }
    fn load(&mut self) {
        self.init = self.b_init;
        self.val = self.b_val;
        self.prsc = (self.ctrl >> 4) & 7;
    }
}

/// Per-pad output routing, supplied by the board at advance time.
#[derive(Clone, Copy, Debug, Default)]
pub struct PadRoute {
    /// The pad of output [A, B] of each submodule is muxed to this PWM.
    pub routed: [[bool; 2]; 4],
    /// `PWM_OUT_TRIG0` of each submodule reaches a pad (through XBARA1).
    pub trig0: [bool; 4],
}

/// One FlexPWM module.
#[derive(Clone, Debug)]
pub struct FlexPwm {
    /// Submodules 0..3.
    pub sm: [Submodule; 4],
    /// OUTEN.
    pub outen: u16,
    /// MASK (active copy).
    pub mask: u16,
    /// MASK as written (buffered unless UPDATE_MASK).
    pub mask_buf: u16,
    /// MCTRL (LDOK bits 0..3, RUN bits 8..11, IPOL).
    pub mctrl: u16,
    /// FCTRL0.
    pub fctrl: u16,
    /// FSTS0: FFLAG (3:0) and FFULL (7:4) / FHALF (15:12) as written.
    pub fsts: u16,
    /// Other module registers.
    pub other: [u16; 0x10],
    /// Fault input levels (from XBARA1), set by the board.
    pub fault_in: [bool; 4],
    /// Keep the rising-edge times of each output (tests).
    pub record: bool,
    /// A debugger halts the core (submodules with `DBGEN = 0` stop).
    pub debug_halted: bool,
}

impl FlexPwm {
    /// Reset state.
    pub fn new() -> Self {
        FlexPwm {
            sm: [Submodule::new(), Submodule::new(), Submodule::new(), Submodule::new()],
            outen: 0,
            mask: 0,
            mask_buf: 0,
            mctrl: 0,
            fctrl: 0,
            fsts: 0,
            other: [0; 0x10],
            fault_in: [false; 4],
            record: false,
            debug_halted: false,
        }
    }

    fn running(&self, s: usize) -> bool {
        self.mctrl & (1 << (8 + s)) != 0
    }
    fn ldok(&self, s: usize) -> bool {
        self.mctrl & (1 << s) != 0
    }

    /// Fault input `i` active (its level equals FLVL).
    fn fault_active(&self, i: usize) -> bool {
        let flvl = self.fctrl & (1 << (12 + i)) != 0; // FCTRL0[FLVL] bits 15:12
        self.fault_in[i] == flvl
    }

    /// Refresh fault flags from the input levels.
    fn update_faults(&mut self) {
        for i in 0..4 {
            if self.fault_active(i) {
                self.fsts |= 1 << i;
            }
        }
    }

    /// Output `b` (0 = A, 1 = B) of submodule `s` disabled by a fault.
    pub fn fault_disabled(&self, s: usize, b: usize) -> bool {
        let dis = self.sm[s].dismap0();
        let bits = if b == 0 { dis & 0xF } else { (dis >> 4) & 0xF };
        (0..4).any(|i| bits & (1 << i) != 0 && (self.fsts & (1 << i) != 0 || self.fault_active(i)))
    }

    fn output_live(&self, s: usize, b: usize, route: &PadRoute) -> bool {
        let en_bit = if b == 0 { 8 + s } else { 4 + s };
        self.outen & (1 << en_bit) != 0
            && self.mask & (1 << en_bit) == 0
            && !self.fault_disabled(s, b)
            && route.routed[s][b]
    }

    /// Run every submodule up to time `t`, counting rising edges that reach
    /// routed pads.
    pub fn advance(&mut self, t: u64, route: &PadRoute) {
        self.update_faults();
        for s in 0..4 {
            if !self.running(s) || (self.debug_halted && !self.sm[s].dbgen()) {
                self.sm[s].t_cnt = t;
                continue;
            }
            loop {
                let trig = route.trig0[s] && self.sm[s].pwaot0();
                let live = [self.output_live(s, 0, route), self.output_live(s, 1, route), trig];
                let masked_a = self.mask & (1 << (8 + s)) != 0;
                let before = self.sm[s].log[2].pulses;
                let record = self.record;
                let ldok = self.ldok(s);
                let sm = &mut self.sm[s];
                if sm.at_start {
                    if sm.t_cnt > t {
                        break;
                    }
                    sm.at_start = false;
                    let started = std::mem::take(&mut sm.just_started);
                    for (b, &on) in live.iter().enumerate() {
                        let c = if b == 2 { 0 } else { b };
                        if on && sm.val[2 + 2 * c] == sm.cnt && sm.val[3 + 2 * c] > sm.cnt {
                            note_rise(&mut sm.log[b], sm.t_cnt, record);
                            if started {
                                sm.rises_at_start += 1;
                            }
                        }
                    }
                }
                let cpc = sm.cycles_per_count();
                let top = sm.val[1];
                if top < sm.init {
                    // degenerate: counter wraps at 0xFFFF; treat as stopped
                    sm.t_cnt = t;
                    break;
                }
                // compare edges within the current period that lie ahead
                let elapsed = (t.saturating_sub(sm.t_cnt)) / cpc;
                let to_end = u64::from(top.wrapping_sub(sm.cnt)) + 1; // counts until reload
                if elapsed < to_end {
                    // stays within the period: count edges strictly after cnt up to cnt+elapsed
                    for (b, &on) in live.iter().enumerate() {
                        let c = if b == 2 { 0 } else { b };
                        let on_at = sm.val[2 + 2 * c];
                        if on && on_at > sm.cnt && u64::from(on_at - sm.cnt) <= elapsed && sm.val[3 + 2 * c] > on_at {
                            let tr = sm.t_cnt + u64::from(on_at - sm.cnt) * cpc;
                            note_rise(&mut sm.log[b], tr, record);
                        }
                    }
                    sm.cnt = sm.cnt.wrapping_add(elapsed as u16);
                    sm.t_cnt += elapsed * cpc;
                    if masked_a {
                        sm.trig_rises_masked += sm.log[2].pulses - before;
                    }
                    break;
                }
                // finish the period: edges after cnt up to top
                for (b, &on) in live.iter().enumerate() {
                    let c = if b == 2 { 0 } else { b };
                    let on_at = sm.val[2 + 2 * c];
                    if on && on_at > sm.cnt && on_at <= top && sm.val[3 + 2 * c] > on_at {
                        let tr = sm.t_cnt + u64::from(on_at - sm.cnt) * cpc;
                        note_rise(&mut sm.log[b], tr, record);
                    }
                }
                // reload at the period boundary
                sm.t_cnt += to_end * cpc;
                if ldok && sm.ctrl & 0x0400 != 0 {
                    sm.load();
                    self.mctrl &= !(1 << s);
                }
                self.mask = self.mask_buf;
                let sm = &mut self.sm[s];
                if masked_a {
                    sm.trig_rises_masked += sm.log[2].pulses - before;
                }
                sm.cnt = sm.init;
                sm.at_start = true;
            }
        }
    }

    /// A register read (offset within the module, 16-bit).
    pub fn read(&self, off: u32) -> u16 {
        if off < 0x180 {
            let s = (off / 0x60) as usize;
            let r = off % 0x60;
            let sm = &self.sm[s];
            return match r {
                0x00 => sm.cnt,
                0x02 => sm.b_init,
                0x04 => sm.ctrl2 & !0x0040, // FORCE reads 0
                0x06 => sm.ctrl & !0x0400 | (sm.ctrl & 0x0400),
                0x0A | 0x0E | 0x12 | 0x16 | 0x1A | 0x1E => sm.b_val[((r - 0x0A) / 4) as usize],
                _ => sm.other[(r / 2) as usize],
            };
        }
        match off {
            0x180 => self.outen,
            0x182 => self.mask_buf & 0x0FFF,
            0x188 => self.mctrl,
            0x18C => self.fctrl,
            0x18E => {
                let pins: u16 = (0..4).map(|i| u16::from(self.fault_in[i]) << (8 + i)).sum();
                // FFLAG 3:0, FFULL 7:4 (as written), FFPIN 11:8, FHALF 15:12
                (self.fsts & 0x00FF) | pins | (self.fsts & 0xF000)
            }
            _ => self.other[((off - 0x180) / 2) as usize & 0xF],
        }
    }

    /// A register write (16-bit).
    pub fn write(&mut self, off: u32, v: u16) {
        if off < 0x180 {
            let s = (off / 0x60) as usize;
            let r = off % 0x60;
            let ldok = self.ldok(s);
            let running = self.running(s);
            let sm = &mut self.sm[s];
            match r {
                0x00 => sm.cnt = v,
                0x02 => {
                    if ldok {
                        sm.dropped_writes += 1
                    } else {
                        sm.b_init = v
                    }
                }
                0x04 => {
                    sm.ctrl2 = v & !0x0040;
                    // FORCE (bit 6), local (FORCE_SEL = 0), FRCEN (bit 7)
                    if v & 0x0040 != 0 && v & 0x0038 == 0 && v & 0x0080 != 0 {
                        sm.cnt = sm.init;
                        sm.at_start = true;
                    }
                }
                0x06 => {
                    // PRSC (bits 6:4) is buffered
                    if ldok && (v ^ sm.ctrl) & 0x0070 != 0 {
                        sm.dropped_writes += 1;
                        sm.ctrl = (v & !0x0070) | (sm.ctrl & 0x0070);
                    } else {
                        sm.ctrl = v;
                    }
                    // LDMOD (bit 2) with LDOK: immediate load
                    if ldok && sm.ctrl & 0x0004 != 0 {
                        sm.load();
                        self.mctrl &= !(1 << s);
                    }
                }
                0x0A | 0x0E | 0x12 | 0x16 | 0x1A | 0x1E => {
                    if ldok {
                        sm.dropped_writes += 1;
                    } else {
                        sm.b_val[((r - 0x0A) / 4) as usize] = v;
                    }
                }
                _ => sm.other[(r / 2) as usize] = v,
            }
            let _ = running;
            return;
        }
        match off {
            0x180 => self.outen = v & 0x0FFF,
            0x182 => {
                self.mask_buf = v & 0x0FFF;
                if v & 0xF000 != 0 {
                    self.mask = self.mask_buf;
                }
            }
            0x188 => {
                let old = self.mctrl;
                let cldok = (v >> 4) & 0xF;
                let mut n = (v & 0xFF0F & !0x00F0) | (old & 0x000F);
                n |= v & 0x000F; // LDOK: write 1 to set
                n &= !cldok; // CLDOK clears
                self.mctrl = n;
                for s in 0..4 {
                    let started = old & (1 << (8 + s)) == 0 && n & (1 << (8 + s)) != 0;
                    let ldok = self.mctrl & (1 << s) != 0;
                    // LDMOD = 1: load upon LDOK being set (RUN loads nothing)
                    if ldok && self.sm[s].ctrl & 0x0004 != 0 {
                        self.sm[s].load();
                        self.mctrl &= !(1 << s);
                    }
                    if started {
                        let sm = &mut self.sm[s];
                        sm.at_start = true;
                        sm.just_started = true;
                        sm.starts += 1;
                        if sm.start_times.len() < 100_000 {
                            let at = sm.t_cnt;
                            sm.start_times.push(at);
                        }
                        let active = (u64::from(sm.val[1]) + 1) * (4 << sm.prsc);
                        let buffered = (u64::from(sm.b_val[1]) + 1) * (4 << ((sm.ctrl >> 4) & 7));
                        if active != buffered {
                            sm.stale_starts += 1;
                            sm.last_stale = Some((active, buffered));
                        }
                    }
                }
            }
            0x18C => self.fctrl = v,
            0x18E => {
                // FFLAG: w1c, only if the input is inactive
                for i in 0..4 {
                    if v & (1 << i) != 0 && !self.fault_active(i) {
                        self.fsts &= !(1 << i);
                    }
                }
                self.fsts = (self.fsts & 0x000F) | (v & 0xF0F0);
            }
            _ => self.other[((off - 0x180) / 2) as usize & 0xF] = v,
        }
    }

    /// Start time bookkeeping for submodules that just started (called by
    /// the board after a write, with the current time).
    pub fn settle_time(&mut self, t: u64) {
        for s in 0..4 {
            if !self.running(s) {
                self.sm[s].t_cnt = t;
            }
        }
    }
}

impl Default for FlexPwm {
    fn default() -> Self {
        Self::new()
    }
}

fn note_rise(log: &mut OutputLog, t: u64, record: bool) {
    log.pulses += 1;
    log.last_rise = Some(t);
    if record && log.rises.len() < 1_000_000 {
        log.rises.push(t);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ALL: PadRoute = PadRoute { routed: [[true; 2]; 4], trig0: [false; 4] };

    /// Submodule 0, output A: period `val1 + 1` counts, pulse `val3`.
    fn start(p: &mut FlexPwm, val1: u16, val3: u16) {
        p.write(0x0E, val1);
        p.write(0x16, val3);
        p.write(0x180, 1 << 8); // OUTEN PWMA_EN0
        p.write(0x06, 0x0404); // FULL, LDMOD = 1
        p.write(0x188, 1); // LDOK: loads now
        p.write(0x06, 0x0400); // LDMOD = 0
        p.write(0x188, 1 << 8); // RUN
        p.settle_time(0);
    }

    #[test]
    fn reset_state_faults_disable_outputs() {
        let mut p = FlexPwm::new();
        start(&mut p, 99, 10);
        p.advance(400 * 10, &ALL); // ten periods of 100 counts x 4 cycles
        assert_eq!(p.sm[0].log[0].pulses, 0, "FLVL = 0, inputs low: fault");
        assert!(p.fault_disabled(0, 0));
    }

    #[test]
    fn disarmed_faults_give_one_pulse_per_period() {
        let mut p = FlexPwm::new();
        p.write(0x18C, 0xF000); // FLVL = 1: logic 1 is a fault
        p.write(0x18E, 0x000F); // clear FFLAG
        start(&mut p, 99, 10);
        p.advance(400 * 10 - 1, &ALL);
        assert_eq!(p.sm[0].log[0].pulses, 10);
        // not routed to a pad: no pulse reaches the pin
        let mut q = FlexPwm::new();
        q.write(0x18C, 0xF000);
        q.write(0x18E, 0x000F);
        start(&mut q, 99, 10);
        q.advance(4000, &PadRoute::default());
        assert_eq!(q.sm[0].log[0].pulses, 0);
    }

    #[test]
    fn buffered_writes_ignored_while_ldok_set_and_load_at_reload() {
        let mut p = FlexPwm::new();
        p.write(0x18C, 0xF000);
        p.write(0x18E, 0x000F);
        start(&mut p, 99, 10);
        p.write(0x0E, 199);
        p.write(0x188, 1 | (1 << 8)); // LDOK (RUN kept) pending until the next reload
        p.write(0x0E, 299); // ignored
        assert_eq!(p.sm[0].dropped_writes, 1);
        assert_eq!(p.sm[0].val[1], 99, "active value unchanged before the reload");
        p.advance(400, &ALL); // end of the first period: reload
        assert_eq!(p.sm[0].val[1], 199);
        assert_eq!(p.mctrl & 1, 0, "LDOK cleared by the load");
        // CLDOK clears a pending LDOK; the buffer is writable again
        p.write(0x188, 1 | (1 << 8));
        p.write(0x188, (1 << 4) | (1 << 8));
        p.write(0x0E, 49);
        assert_eq!(p.sm[0].b_val[1], 49);
    }

    /// `MCTRL[CLDOK]`: writing 1 clears that submodule's `LDOK` only (other
    /// submodules' `LDOK` kept), reads 0; writing 0 to `LDOK` has no effect;
    /// after the clear the buffers take writes and nothing loads at the
    /// reload until `LDOK` is set again.
    #[test]
    fn cldok_clears_pending_ldok() {
        let mut p = FlexPwm::new();
        p.write(0x18C, 0xF000);
        p.write(0x18E, 0x000F);
        start(&mut p, 99, 10);
        p.write(0x0E, 199);
        p.write(0x188, 0b0011 | (1 << 8)); // LDOK for submodules 0 and 1
        assert_eq!(p.mctrl & 0xF, 0b0011);
        p.write(0x188, 1 << 8); // LDOK written 0: no effect
        assert_eq!(p.mctrl & 0xF, 0b0011);
        p.write(0x188, (1 << 4) | (1 << 8)); // CLDOK submodule 0
        assert_eq!(p.mctrl & 0xF, 0b0010, "only submodule 0's LDOK cleared");
        assert_eq!(p.read(0x188) & 0x00F0, 0, "CLDOK reads 0");
        assert_eq!(p.mctrl & (1 << 8), 1 << 8, "RUN kept");
        p.write(0x0E, 149); // accepted now
        assert_eq!(p.sm[0].dropped_writes, 0);
        assert_eq!(p.sm[0].b_val[1], 149);
        p.advance(400, &ALL); // reload with LDOK clear: no load
        assert_eq!(p.sm[0].val[1], 99);
        p.write(0x188, 1 | (1 << 8));
        p.advance(400 + 600, &ALL); // next reload loads the newest value
        assert_eq!(p.sm[0].val[1], 149);
        assert_eq!(p.mctrl & 1, 0);
    }

    #[test]
    fn force_reinitialises_counter_without_loading() {
        let mut p = FlexPwm::new();
        start(&mut p, 999, 10);
        p.advance(4 * 500, &ALL);
        assert_eq!(p.sm[0].cnt, 500);
        p.write(0x0E, 99);
        p.write(0x188, 1 | (1 << 8));
        p.write(0x04, 0x00C0); // FRCEN | FORCE, FORCE_SEL = 0
        assert_eq!(p.sm[0].cnt, 0);
        assert_eq!(p.sm[0].val[1], 999, "FORCE is not a reload");
    }

    /// `RUN` 0 -> 1 with `LDOK` set and `LDMOD = 0` loads nothing: the
    /// first period runs with the active values (a stale start is counted);
    /// the buffers load at the first reload.
    #[test]
    fn run_does_not_load_ldmod0_waits_for_the_reload() {
        let mut p = FlexPwm::new();
        p.write(0x18C, 0xF000);
        p.write(0x18E, 0x000F);
        start(&mut p, 999, 10);
        p.write(0x188, 0); // RUN = 0
        p.write(0x0E, 99);
        p.write(0x188, 1); // LDOK, LDMOD = 0
        p.write(0x04, 0x00C0); // FORCE
        p.write(0x188, 1 << 8); // RUN
        assert_eq!(p.sm[0].val[1], 999, "RUN is not a load");
        assert_eq!(p.sm[0].stale_starts, 1);
        assert_eq!(p.sm[0].last_stale, Some((4000, 400)));
        p.advance(4000, &ALL);
        assert_eq!(p.sm[0].val[1], 99, "loaded at the first reload");
    }

    /// `DBGEN = 0`: a halted core stops the counter; `DBGEN = 1` keeps it.
    #[test]
    fn dbgen_decides_whether_a_debug_halt_stops_the_counter() {
        for (dbgen, want) in [(false, 0), (true, 10)] {
            let mut p = FlexPwm::new();
            p.write(0x18C, 0xF000);
            p.write(0x18E, 0x000F);
            p.write(0x04, if dbgen { 0x8000 } else { 0 });
            start(&mut p, 99, 10);
            p.debug_halted = true;
            p.advance(4000 - 1, &ALL);
            assert_eq!(p.sm[0].log[0].pulses, want, "DBGEN = {dbgen}");
        }
    }

    /// `PWM_OUT_TRIG0` follows PWM_A ahead of `MASK` and `OUTEN`.
    #[test]
    fn trigger_output_ignores_mask_and_outen() {
        let mut p = FlexPwm::new();
        p.write(0x18C, 0xF000);
        p.write(0x18E, 0x000F);
        p.write(0x2A, 1 << 15); // TCTRL0 PWAOT0
        start(&mut p, 99, 10);
        p.write(0x182, (1 << 8) | (1 << 12)); // MASK A0, UPDATE_MASK
        let route = PadRoute { routed: [[false; 2]; 4], trig0: [true, false, false, false] };
        p.advance(4000 - 1, &route);
        assert_eq!(p.sm[0].log[0].pulses, 0);
        assert_eq!(p.sm[0].log[2].pulses, 10, "MASK does not gate the trigger");
    }
}
