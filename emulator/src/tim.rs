//! General-purpose timer (TIM2–TIM5, RM0008 §15): the time base (PSC, ARR
//! with ARPE, CNT, update events from overflow and EGR.UG loading the
//! preload registers into their shadows), the four output-compare channels
//! (CCMRx OCxM and OCxPE, CCRx, CCER CCxE/CCxP), input capture (§15.3.5)
//! and the update and capture interrupts.
//!
//! The counter is evaluated lazily from the kernel clock's tick count, so
//! the model costs nothing between register accesses; the level of each
//! channel's output at any time follows from the counter (`output_high`),
//! and an input edge handed to [`GpTimer::input`] at its time latches the
//! counter as it stood then.
//!
//! Modelled: upcounting, edge-aligned (CR1.DIR = 0, CMS = 00), continuous
//! (OPM = 0), internal clock (SMCR = 0), output compare modes frozen,
//! forced inactive/active and PWM mode 1/2; input capture with ICx mapped
//! on its own TIx (CCxS = 01), the digital input filter (ICxF: TIx sampled
//! at f_CK_INT or f_DTS/2..32, a level passed on after N = 2..8 equal
//! consecutive samples, which delays every edge alike and swallows pulses
//! shorter than N samples), every input prescaler (ICxPSC: every 1st, 2nd,
//! 4th or 8th active edge), either polarity (CCxP), CCxIF/CCxOF with their
//! clear sequences, the CCxG software capture and the capture interrupts
//! (CCxIE).
//!
//! Not modelled, and stopping the board with an error rather than running
//! with behaviour the manual does not give it: centre-aligned or down
//! counting, one-pulse, slave modes, DMA, the compare-match interrupts of
//! output channels, and ICx mapped on the neighbour's TIx or on TRC (CCxS
//! = 10 or 11).

// The offset, bit and mode tables below look alike because they transcribe
// RM0008's tables, one constant a line.
/// Register offsets (RM0008 §15.4.19, table 87).
pub mod reg {
    /// Control register 1.
    pub const CR1: u32 = 0x00;
    /// Control register 2.
    pub const CR2: u32 = 0x04;
    /// Slave mode control register.
    pub const SMCR: u32 = 0x08;
    /// DMA/interrupt enable register.
    pub const DIER: u32 = 0x0C;
    /// Status register.
    pub const SR: u32 = 0x10;
    /// Event generation register.
    pub const EGR: u32 = 0x14;
    /// Capture/compare mode register 1 (channels 1 and 2).
    pub const CCMR1: u32 = 0x18;
    /// Capture/compare mode register 2 (channels 3 and 4).
    pub const CCMR2: u32 = 0x1C;
    /// Capture/compare enable register.
    pub const CCER: u32 = 0x20;
    /// Counter.
    pub const CNT: u32 = 0x24;
    /// Prescaler.
    pub const PSC: u32 = 0x28;
    /// Auto-reload register.
    pub const ARR: u32 = 0x2C;
    /// Capture/compare register 1.
    pub const CCR1: u32 = 0x34;
    /// Capture/compare register 2.
    pub const CCR2: u32 = 0x38;
    /// Capture/compare register 3.
    pub const CCR3: u32 = 0x3C;
    /// Capture/compare register 4.
    pub const CCR4: u32 = 0x40;
}

/// CR1 bits.
pub mod cr1 {
    /// Counter enable.
    pub const CEN: u32 = 1 << 0;
    /// Update disable.
    pub const UDIS: u32 = 1 << 1;
    /// Update request source (only overflow sets UIF).
    pub const URS: u32 = 1 << 2;
    /// One-pulse mode.
    pub const OPM: u32 = 1 << 3;
    /// Direction (1: down).
    pub const DIR: u32 = 1 << 4;
    /// Centre-aligned mode selection (two bits).
    pub const CMS: u32 = 3 << 5;
    /// Auto-reload preload enable.
    pub const ARPE: u32 = 1 << 7;
}

/// Output-compare modes (CCMRx OCxM, RM0008 §15.4.7).
pub mod ocm {
    /// Frozen: the comparison has no effect on OCxREF.
    pub const FROZEN: u32 = 0b000;
    /// Force OCxREF low.
    pub const FORCE_INACTIVE: u32 = 0b100;
    /// Force OCxREF high.
    pub const FORCE_ACTIVE: u32 = 0b101;
    /// PWM mode 1: OCxREF high while CNT < CCRx (upcounting).
    pub const PWM1: u32 = 0b110;
    /// PWM mode 2: OCxREF low while CNT < CCRx (upcounting).
    pub const PWM2: u32 = 0b111;
}

/// The timer's state.
#[derive(Clone, Debug)]
pub struct GpTimer {
    name: &'static str,
    /// Kernel clock (CK_INT) in Hz.
    clock_hz: u32,
    cr1: u32,
    dier: u32,
    sr: u32,
    ccmr: [u32; 2],
    ccer: u32,
    psc: u32,
    arr: u32,
    ccr: [u32; 4],
    psc_shadow: u32,
    arr_shadow: u32,
    ccr_shadow: [u32; 4],
    cnt: u32,
    /// Kernel ticks counted by the prescaler since the counter last moved.
    psc_cnt: u64,
    /// Kernel tick up to which the counter has been brought.
    at_tick: u64,
    /// OCxREF kept by the frozen mode.
    frozen_ref: [bool; 4],
    /// Level of each channel's input TIx after the digital filter (what
    /// the edge detector sees).
    ti_high: [bool; 4],
    /// Level on each channel's pin, before the filter.
    ti_raw: [bool; 4],
    /// A level the filter passes on at a kernel tick, once the pin has
    /// held it for N samples (ICxF ≠ 0000).
    ti_pending: [Option<(u64, bool)>; 4],
    /// Active edges counted by each input prescaler since its last capture.
    ic_edges: [u8; 4],
}

/// Status register bits.
pub mod sr {
    /// Update interrupt flag.
    pub const UIF: u32 = 1 << 0;
    /// Capture/compare interrupt flag of channel `ch` (0..4).
    pub const fn ccif(ch: usize) -> u32 {
        1 << (1 + ch)
    }
    /// Over-capture flag of channel `ch` (0..4).
    pub const fn ccof(ch: usize) -> u32 {
        1 << (9 + ch)
    }
}

/// Ticks of a `hz` clock at `ns` since power-on.
fn ticks(ns: u64, hz: u32) -> u64 {
    (u128::from(ns) * u128::from(hz) / 1_000_000_000) as u64
}

/// Time (ns, rounded up) of tick `t` of a `hz` clock.
fn tick_ns(t: u64, hz: u32) -> u64 {
    (u128::from(t) * 1_000_000_000).div_ceil(u128::from(hz.max(1))) as u64
}

impl GpTimer {
    /// Reset state (RM0008 §15.4: every register 0, ARR included) with a
    /// kernel clock of `clock_hz`.
    pub fn new(name: &'static str, clock_hz: u32) -> Self {
        Self {
            name,
            clock_hz,
            cr1: 0,
            dier: 0,
            sr: 0,
            ccmr: [0; 2],
            ccer: 0,
            psc: 0,
            arr: 0,
            ccr: [0; 4],
            psc_shadow: 0,
            arr_shadow: 0,
            ccr_shadow: [0; 4],
            cnt: 0,
            psc_cnt: 0,
            at_tick: 0,
            frozen_ref: [false; 4],
            ti_high: [false; 4],
            ti_raw: [false; 4],
            ti_pending: [None; 4],
            ic_edges: [0; 4],
        }
    }

    /// Peripheral reset (RCC APB1RSTR, or the MCU reset), keeping the clock
    /// and the levels on the input pins (the world outside the timer).
    pub fn reset(&mut self) {
        let ti_raw = self.ti_raw;
        *self = Self::new(self.name, self.clock_hz);
        self.ti_raw = ti_raw;
        self.ti_high = ti_raw;
    }

    /// Changes the kernel clock (RCC prescalers) from `now_ns` on.
    pub fn set_clock_hz(&mut self, hz: u32, now_ns: u64) {
        if hz != self.clock_hz {
            self.advance(now_ns);
            self.clock_hz = hz;
            self.at_tick = ticks(now_ns, hz);
        }
    }

    /// Kernel clock in Hz.
    pub fn clock_hz(&self) -> u32 {
        self.clock_hz
    }

    fn running(&self) -> bool {
        // "The counter is blocked while the auto-reload value is null."
        self.cr1 & cr1::CEN != 0 && self.arr_shadow != 0
    }

    /// An update event: shadows loaded from the preload registers.
    fn load_shadows(&mut self) {
        self.psc_shadow = self.psc;
        self.arr_shadow = self.arr;
        self.ccr_shadow = self.ccr;
    }

    fn oc_mode(&self, ch: usize) -> u32 {
        (self.ccmr[ch / 2] >> (4 + 8 * (ch % 2))) & 7
    }

    /// CCxS of channel `ch`: 00 output, 01 input on TIx, 10/11 other inputs.
    fn cc_select(&self, ch: usize) -> u32 {
        (self.ccmr[ch / 2] >> (8 * (ch % 2))) & 3
    }

    /// Channel `ch` is an input capture on its own TIx (CCxS = 01).
    fn is_input(&self, ch: usize) -> bool {
        self.cc_select(ch) == 1
    }

    /// Active edges per capture (ICxPSC): 1, 2, 4 or 8.
    fn ic_divider(&self, ch: usize) -> u8 {
        1 << ((self.ccmr[ch / 2] >> (2 + 8 * (ch % 2))) & 3)
    }

    /// A capture on channel `ch` now: CCRx latches the counter, CCxIF is
    /// set, and CCxOF too if CCxIF was still set (§15.3.5: "the CCxOF flag
    /// is set when a new capture occurs while CCxIF is still high").
    fn capture(&mut self, ch: usize) {
        if self.sr & sr::ccif(ch) != 0 {
            self.sr |= sr::ccof(ch);
        }
        self.ccr[ch] = self.cnt;
        self.sr |= sr::ccif(ch);
    }

    /// The digital filter of input channel `ch` (ICxF, §15.4.7): the
    /// sampling period in kernel ticks (f_CK_INT, or f_DTS / 2..32 with
    /// f_DTS = f_CK_INT / 1, 2 or 4 from CR1.CKD) and the number N of equal
    /// consecutive samples a new level needs; `None` for ICxF = 0000 or an
    /// output channel.
    fn ic_filter(&self, ch: usize) -> Option<(u64, u64)> {
        if !self.is_input(ch) {
            return None;
        }
        let f = (self.ccmr[ch / 2] >> (4 + 8 * (ch % 2))) & 0xF;
        let dts = 1u64 << ((self.cr1 >> 8) & 3).min(2);
        Some(match f {
            0 => return None,
            1 => (1, 2),
            2 => (1, 4),
            3 => (1, 8),
            4 => (2 * dts, 6),
            5 => (2 * dts, 8),
            6 => (4 * dts, 6),
            7 => (4 * dts, 8),
            8 => (8 * dts, 6),
            9 => (8 * dts, 8),
            10 => (16 * dts, 5),
            11 => (16 * dts, 6),
            12 => (16 * dts, 8),
            13 => (32 * dts, 5),
            14 => (32 * dts, 6),
            _ => (32 * dts, 8),
        })
    }

    /// The level on the pin of channel `ch` (0..4) changes to `high` at
    /// `at_ns` (not before the last time the timer was brought to).
    ///
    /// Without a filter (ICxF = 0000) the edge detector sees the change at
    /// once. With one, the filter samples the pin every sampling period and
    /// passes a level on at the N-th consecutive sample that reads it
    /// (§15.3.5's example validates a transition after 8 consecutive
    /// samples at the new level taken at f_CK_INT, IC1F = 0011): every
    /// edge is delayed alike, and a pulse shorter than N samples never
    /// reaches the edge detector.
    ///
    /// An active edge of an enabled input-capture channel (rising with CCxP
    /// = 0, falling with CCxP = 1) counts in the input prescaler, and every
    /// 1st/2nd/4th/8th one captures the counter as it stands then (the
    /// input's resynchronisation, a few CK_INT cycles, is below one counter
    /// tick at any prescaler the firmware uses and is not modelled).
    pub fn input(&mut self, ch: usize, high: bool, at_ns: u64) {
        self.advance(at_ns);
        let Some(raw) = self.ti_raw.get_mut(ch) else {
            return;
        };
        if *raw == high {
            return;
        }
        *raw = high;
        let Some((period, n)) = self.ic_filter(ch) else {
            self.ti_pending[ch] = None;
            self.detect(ch, high);
            return;
        };
        if self.ti_pending[ch].take().is_some() || high == self.ti_high[ch] {
            // Back to the filtered level before N samples confirmed the
            // other one: nothing passes.
            return;
        }
        let first_sample = (self.at_tick / period + 1) * period;
        self.ti_pending[ch] = Some((first_sample + (n - 1) * period, high));
    }

    /// The filtered level of channel `ch` becomes `high` now: the edge
    /// detector, the input prescaler and the capture.
    fn detect(&mut self, ch: usize, high: bool) {
        let Some(level) = self.ti_high.get_mut(ch) else {
            return;
        };
        if *level == high {
            return;
        }
        *level = high;
        let e = self.ccer >> (4 * ch);
        let falling_active = e & 2 != 0;
        if !self.is_input(ch) || e & 1 == 0 || high == falling_active {
            return;
        }
        self.ic_edges[ch] += 1;
        if self.ic_edges[ch] >= self.ic_divider(ch) {
            self.ic_edges[ch] = 0;
            self.capture(ch);
        }
    }

    /// The earliest level the filters pass on: (kernel tick, channel).
    fn next_filtered(&self) -> Option<(u64, usize)> {
        (0..4)
            .filter_map(|ch| self.ti_pending[ch].map(|(t, _)| (t, ch)))
            .min()
    }

    /// When a filter next passes a level on (for the board's scheduler: a
    /// capture interrupt can follow).
    pub fn next_input_ns(&self) -> Option<u64> {
        self.next_filtered().map(|(t, _)| tick_ns(t, self.clock_hz))
    }

    fn oc_preload(&self, ch: usize) -> bool {
        self.ccmr[ch / 2] & (1 << (3 + 8 * (ch % 2))) != 0
    }

    /// Brings the counter to `now_ns`: prescaler and counter ticks,
    /// overflows (update events when UDIS = 0).
    pub fn advance(&mut self, now_ns: u64) {
        let now = ticks(now_ns, self.clock_hz);
        // Levels the filters pass on before `now`, each with the counter
        // as it stands at its tick.
        while let Some((t, ch)) = self.next_filtered().filter(|&(t, _)| t <= now) {
            self.advance_ticks(t);
            if let Some((_, high)) = self.ti_pending[ch].take() {
                self.detect(ch, high);
            }
        }
        self.advance_ticks(now);
    }

    /// Brings the counter to kernel tick `now`.
    fn advance_ticks(&mut self, now: u64) {
        if now <= self.at_tick {
            return;
        }
        let mut left = now - self.at_tick;
        self.at_tick = now;
        if !self.running() {
            return;
        }
        loop {
            let div = u64::from(self.psc_shadow) + 1;
            let to_overflow = u64::from(self.arr_shadow - self.cnt.min(self.arr_shadow)) * div
                + (div - self.psc_cnt);
            if left < to_overflow {
                let total = self.psc_cnt + left;
                self.cnt += (total / div) as u32;
                self.psc_cnt = total % div;
                return;
            }
            left -= to_overflow;
            self.cnt = 0;
            self.psc_cnt = 0;
            if self.cr1 & cr1::UDIS == 0 {
                self.sr |= 1;
                let before = (self.psc_shadow, self.arr_shadow);
                self.load_shadows();
                if !self.running() {
                    return;
                }
                if before == (self.psc_shadow, self.arr_shadow) {
                    // Periodic from here on: skip whole periods.
                    let period = (u64::from(self.arr_shadow) + 1) * div;
                    left %= period;
                }
            } else {
                let period = (u64::from(self.arr_shadow) + 1) * div;
                left %= period;
            }
        }
    }

    /// Time of the next update event (for the board's scheduler), if the
    /// update interrupt is enabled and the counter runs.
    pub fn next_update_ns(&self) -> Option<u64> {
        if !self.running() || self.dier & 1 == 0 || self.cr1 & cr1::UDIS != 0 {
            return None;
        }
        let div = u64::from(self.psc_shadow) + 1;
        let to_overflow =
            u64::from(self.arr_shadow - self.cnt.min(self.arr_shadow)) * div + (div - self.psc_cnt);
        Some(tick_ns(self.at_tick + to_overflow, self.clock_hz))
    }

    /// The timer's interrupt line: an update (UIE and UIF) or a capture
    /// (CCxIE and CCxIF); the over-capture flags have no enable of their own.
    pub fn irq(&self) -> bool {
        self.dier & self.sr & 0x1F != 0
    }

    /// OCxREF of channel `ch` (0..4) at the counter's current value.
    fn oc_ref(&self, ch: usize) -> bool {
        let high_while_below = self.cnt < self.ccr_shadow[ch];
        match self.oc_mode(ch) {
            ocm::FORCE_INACTIVE => false,
            ocm::FORCE_ACTIVE => true,
            ocm::PWM1 => high_while_below,
            ocm::PWM2 => !high_while_below,
            _ => self.frozen_ref[ch],
        }
    }

    /// Level of output OCx (channel `ch`, 0..4) at `now_ns`: OCxREF through
    /// the polarity (CCxP), low while the channel is disabled (CCxE = 0).
    /// An input-capture channel drives nothing: low.
    pub fn output_high(&mut self, ch: usize, now_ns: u64) -> bool {
        self.advance(now_ns);
        if self.cc_select(ch) != 0 {
            return false;
        }
        let e = self.ccer >> (4 * ch);
        e & 1 != 0 && (self.oc_ref(ch) != (e & 2 != 0))
    }

    /// Channel `ch`'s waveform as the shadow registers make it now:
    /// (period, time high) in ns, `None` while the counter is stopped or
    /// the channel is an input.
    pub fn pwm_ns(&self, ch: usize) -> Option<(u64, u64)> {
        if !self.running() || self.cc_select(ch) != 0 {
            return None;
        }
        let tick = (u64::from(self.psc_shadow) + 1) * 1_000_000_000;
        let hz = u64::from(self.clock_hz.max(1));
        let period_ticks = u64::from(self.arr_shadow) + 1;
        let e = self.ccer >> (4 * ch);
        let ref_high_ticks = match self.oc_mode(ch) {
            ocm::FORCE_INACTIVE => 0,
            ocm::FORCE_ACTIVE => period_ticks,
            ocm::PWM1 => u64::from(self.ccr_shadow[ch]).min(period_ticks),
            ocm::PWM2 => period_ticks - u64::from(self.ccr_shadow[ch]).min(period_ticks),
            _ => period_ticks * u64::from(self.frozen_ref[ch]),
        };
        let high_ticks = match (e & 1 != 0, e & 2 != 0) {
            (false, _) => 0,
            (true, false) => ref_high_ticks,
            (true, true) => period_ticks - ref_high_ticks,
        };
        Some((period_ticks * tick / hz, high_ticks * tick / hz))
    }

    /// Register read at `offset`; `None`: not modelled.
    pub fn read(&mut self, offset: u32, now_ns: u64) -> Option<u32> {
        self.advance(now_ns);
        Some(match offset {
            reg::CR1 => self.cr1,
            reg::CR2 | reg::SMCR => 0,
            reg::DIER => self.dier,
            reg::SR => self.sr,
            reg::EGR => 0,
            reg::CCMR1 => self.ccmr[0],
            reg::CCMR2 => self.ccmr[1],
            reg::CCER => self.ccer,
            reg::CNT => self.cnt,
            reg::PSC => self.psc,
            reg::ARR => self.arr,
            0x34..=0x40 => {
                let ch = ((offset - reg::CCR1) / 4) as usize;
                // §15.4.10: in input mode, reading CCRx clears CCxIF (not
                // CCxOF, which only a write of 0 clears).
                if self.is_input(ch) {
                    self.sr &= !sr::ccif(ch);
                }
                self.ccr[ch]
            }
            _ => return None,
        })
    }

    /// Register write (16-bit registers: the low half-word is used) at
    /// `offset`. `None`: not modelled; `Some(Err)`: a feature the model does
    /// not have was switched on.
    pub fn write(&mut self, offset: u32, v: u32, now_ns: u64) -> Option<Result<(), String>> {
        self.advance(now_ns);
        let v = v & 0xFFFF;
        let unsupported = |what: &str| Some(Err(format!("{}: {what} not modelled", self.name)));
        match offset {
            reg::CR1 => {
                if v & (cr1::OPM | cr1::DIR | cr1::CMS) != 0 {
                    return unsupported("one-pulse, down or centre-aligned counting");
                }
                self.cr1 = v & 0x3FF;
            }
            reg::CR2 | reg::SMCR => {
                if v != 0 {
                    return unsupported("CR2 (master mode, DMA) / SMCR (slave modes)");
                }
            }
            reg::DIER => {
                if v & !0x1F != 0 {
                    return unsupported("trigger interrupt and DMA requests");
                }
                if (0..4).any(|ch| v & (2 << ch) != 0 && !self.is_input(ch)) {
                    return unsupported("compare-match interrupts of output channels");
                }
                self.dier = v;
            }
            // rc_w0: writing 0 clears, writing 1 has no effect.
            reg::SR => self.sr &= v & 0x1E5F,
            reg::EGR => {
                if v & !0x1F != 0 {
                    return unsupported("trigger and COM event generation");
                }
                if (0..4).any(|ch| v & (2 << ch) != 0 && !self.is_input(ch)) {
                    return unsupported("compare event generation on output channels");
                }
                // CCxG on an input channel: a capture as if from the input
                // (§15.4.6), CCxOF included.
                for ch in 0..4 {
                    if v & (2 << ch) != 0 {
                        self.capture(ch);
                    }
                }
                if v & 1 != 0 {
                    // UG: counter and prescaler re-initialised, shadows loaded;
                    // UIF unless URS selects overflow only.
                    self.cnt = 0;
                    self.psc_cnt = 0;
                    self.load_shadows();
                    if self.cr1 & cr1::URS == 0 {
                        self.sr |= 1;
                    }
                }
            }
            reg::CCMR1 | reg::CCMR2 => {
                let i = ((offset - reg::CCMR1) / 4) as usize;
                // §15.4.7: CCxS is writable only while the channel is off
                // (CCxE = 0); otherwise the old selection stays.
                let mut v = v;
                for half in 0..2 {
                    let ch = 2 * i + half;
                    if self.ccer & (1 << (4 * ch)) != 0 {
                        let shift = 8 * half;
                        v = (v & !(3 << shift)) | (self.ccmr[i] & (3 << shift));
                    }
                }
                for half in 0..2 {
                    let ch = 2 * i + half;
                    let f = (v >> (8 * half)) & 0xFF;
                    match f & 3 {
                        0 => {}
                        1 => continue,
                        _ => {
                            return unsupported(
                                "input capture on TRC or the neighbour's TIx (CCxS = 10/11)",
                            )
                        }
                    }
                    if self.dier & (2 << ch) != 0 {
                        return unsupported("compare-match interrupts of output channels");
                    }
                    let m = (f >> 4) & 7;
                    if !matches!(
                        m,
                        ocm::FROZEN
                            | ocm::FORCE_INACTIVE
                            | ocm::FORCE_ACTIVE
                            | ocm::PWM1
                            | ocm::PWM2
                    ) {
                        return unsupported("output compare on match (OCxM 001–011)");
                    }
                }
                // A channel entering frozen mode keeps the OCxREF it had.
                let before: [bool; 2] = [self.oc_ref(2 * i), self.oc_ref(2 * i + 1)];
                self.ccmr[i] = v;
                for (half, level) in before.into_iter().enumerate() {
                    if self.oc_mode(2 * i + half) == ocm::FROZEN {
                        self.frozen_ref[2 * i + half] = level;
                    }
                }
                for half in 0..2 {
                    let ch = 2 * i + half;
                    if !self.oc_preload(ch) || self.is_input(ch) {
                        self.ccr_shadow[ch] = self.ccr[ch];
                    }
                }
            }
            reg::CCER => {
                self.ccer = v & 0x3333;
                // §15.4.7 ICxPSC: "the prescaler is reset as soon as CCxE = 0".
                for ch in 0..4 {
                    if self.ccer & (1 << (4 * ch)) == 0 {
                        self.ic_edges[ch] = 0;
                    }
                }
            }
            reg::CNT => {
                self.cnt = v;
                self.psc_cnt = 0;
            }
            reg::PSC => self.psc = v,
            reg::ARR => {
                self.arr = v;
                if self.cr1 & cr1::ARPE == 0 {
                    self.arr_shadow = v;
                }
            }
            0x34..=0x40 => {
                let ch = ((offset - reg::CCR1) / 4) as usize;
                // §15.4.13: read-only in input mode.
                if self.is_input(ch) {
                    return Some(Ok(()));
                }
                self.ccr[ch] = v;
                if !self.oc_preload(ch) {
                    self.ccr_shadow[ch] = v;
                }
            }
            0x48 | 0x4C => return unsupported("DMA burst (DCR/DMAR)"),
            _ => return None,
        }
        Some(Ok(()))
    }
}
