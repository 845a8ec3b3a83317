//! ADC1 (RM0008 §11): power-up, self-calibration, single and continuous
//! regular conversions of one channel, an injected group of up to four
//! channels with its offsets, EOC/JEOC and their interrupt on ADC1_2
//! (IRQ 18, §10.1.2 table 63).
//!
//! Behaviour taken from the manual (§11.3, §11.4, §11.12) and the
//! STM32F103x8 datasheet's ADC characteristics (DS5319 §5.3.18, table 46):
//! * The first write of ADON = 1 wakes the ADC from power-down; it may
//!   start converting t_STAB (1 µs) later (§11.3.1). ADON written 1 again,
//!   with no other CR2 bit changed, starts a regular conversion (§11.12.3).
//!   ADON = 0 powers it down and stops what it was doing.
//! * Calibration (§11.4): CAL set at least two ADC clock cycles after power
//!   up runs for t_CAL = 83 ADC clock cycles, then hardware clears CAL.
//!   RSTCAL is cleared by hardware once the calibration registers are
//!   initialised; the manual gives no duration, here one ADC clock cycle.
//! * ADCCLK is PCLK2 / ADCPRE (RCC_CFGR, §7.3.2) and must not exceed
//!   14 MHz (§11.1): a faster clock while the ADC is powered stops the
//!   board.
//! * A conversion takes the channel's sample time (SMPR1/SMPR2: 1.5 to
//!   239.5 cycles) plus 12.5 cycles (§11.6). The input is sampled at the
//!   end of the sample phase: 12 bits of VREF+ = 3.3 V, ideal transfer
//!   (code = ⌊V · 4096 / VREF+⌋, clamped to 0..4095).
//! * Regular conversion (§11.3.4–11.3.6): started by ADON set again or by
//!   SWSTART with EXTTRIG and EXTSEL = SWSTART (0b111); SWSTART reads 0 once
//!   the conversion has started. EOC sets at the end, DR holds the result
//!   (right or left aligned, §11.5); a DR read or writing 0 clears EOC.
//!   CONT restarts the conversion at the end of each one.
//! * Injected group (§11.3.10, §11.12.8): JSWSTART with JEXTTRIG and
//!   JEXTSEL = JSWSTART (0b111) converts JL + 1 channels, for JL = 0 only
//!   JSQ4, for JL = 3 JSQ1..JSQ4; the k-th result, less JOFRk, goes to
//!   JDRk as a signed value (sign extended right aligned; left aligned
//!   shifted by 3, §11.5); JEOC sets at the end of the group, and clears
//!   only by writing 0. An injected trigger during a regular conversion
//!   interrupts it; the regular conversion runs again after the injected
//!   group. A regular trigger during an injected group waits for its end.
//! * STRT/JSTRT set when a conversion starts; all five SR flags clear by
//!   writing 0 (rc_w0).
//!
//! The pin: a channel's value is meaningful only with its pin in analog
//! input mode (§9.1.11: in the other input modes the Schmitt trigger and
//! the pull resistors load the pin, as an output the driver sets its
//! level). The board tells the model which channels' pins are analog
//! inputs; sampling a channel whose pin is not (or which has no pin on the
//! 48-pin package, channels 10–15) stops the board, like an access to an
//! unclocked peripheral: on silicon a plausible but wrong reading.
//!
//! Misuse that stops the board (undefined on silicon): a conversion
//! started before t_STAB, during calibration or with the ADC off;
//! calibration started less than two ADC clock cycles after power-up.
//!
//! Not modelled (stop the board with an error if switched on): the
//! analog watchdog (AWDEN/JAWDEN), scan of more than one regular channel,
//! discontinuous modes, JAUTO, dual mode, DMA (CR2.DMA), external triggers
//! other than SWSTART/JSWSTART, the temperature sensor and VREFINT
//! (TSVREFE, channels 16–17), an injected group of more than one channel
//! without SCAN. Calibration's effect on the value: a host-set offset that
//! calibration removes (0 unless set; the manual gives no figure).

/// Register offsets (RM0008 §11.12.15, table 70).
pub mod reg {
    /// Status register.
    pub const SR: u32 = 0x00;
    /// Control register 1.
    pub const CR1: u32 = 0x04;
    /// Control register 2.
    pub const CR2: u32 = 0x08;
    /// Sample time register 1 (channels 10–17).
    pub const SMPR1: u32 = 0x0C;
    /// Sample time register 2 (channels 0–9).
    pub const SMPR2: u32 = 0x10;
    /// Injected channel data offset register `n` (1..=4).
    pub const fn jofr(n: u32) -> u32 {
        0x14 + 4 * (n - 1)
    }
    /// Watchdog high threshold register.
    pub const HTR: u32 = 0x24;
    /// Watchdog low threshold register.
    pub const LTR: u32 = 0x28;
    /// Regular sequence register 1 (L, SQ13–SQ16).
    pub const SQR1: u32 = 0x2C;
    /// Regular sequence register 2 (SQ7–SQ12).
    pub const SQR2: u32 = 0x30;
    /// Regular sequence register 3 (SQ1–SQ6).
    pub const SQR3: u32 = 0x34;
    /// Injected sequence register.
    pub const JSQR: u32 = 0x38;
    /// Injected data register `n` (1..=4).
    pub const fn jdr(n: u32) -> u32 {
        0x3C + 4 * (n - 1)
    }
    /// Regular data register.
    pub const DR: u32 = 0x4C;
}

/// SR bits.
pub mod sr {
    /// Analog watchdog flag.
    pub const AWD: u32 = 1 << 0;
    /// End of conversion (regular).
    pub const EOC: u32 = 1 << 1;
    /// End of injected group conversion.
    pub const JEOC: u32 = 1 << 2;
    /// Injected conversion started.
    pub const JSTRT: u32 = 1 << 3;
    /// Regular conversion started.
    pub const STRT: u32 = 1 << 4;
}

/// CR1 bits.
pub mod cr1 {
    /// EOC interrupt enable.
    pub const EOCIE: u32 = 1 << 5;
    /// Analog watchdog interrupt enable.
    pub const AWDIE: u32 = 1 << 6;
    /// JEOC interrupt enable.
    pub const JEOCIE: u32 = 1 << 7;
    /// Scan mode.
    pub const SCAN: u32 = 1 << 8;
}

/// CR2 bits.
pub mod cr2 {
    /// A/D converter on (and, written 1 again, start of conversion).
    pub const ADON: u32 = 1 << 0;
    /// Continuous conversion.
    pub const CONT: u32 = 1 << 1;
    /// Calibration (set by software, cleared by hardware at its end).
    pub const CAL: u32 = 1 << 2;
    /// Reset calibration.
    pub const RSTCAL: u32 = 1 << 3;
    /// DMA for the regular channels.
    pub const DMA: u32 = 1 << 8;
    /// Left alignment.
    pub const ALIGN: u32 = 1 << 11;
    /// Injected group trigger selection (3 bits; 0b111 = JSWSTART).
    pub const JEXTSEL_JSWSTART: u32 = 7 << 12;
    /// External trigger for the injected group enabled.
    pub const JEXTTRIG: u32 = 1 << 15;
    /// Regular group trigger selection (3 bits; 0b111 = SWSTART).
    pub const EXTSEL_SWSTART: u32 = 7 << 17;
    /// External trigger for the regular group enabled.
    pub const EXTTRIG: u32 = 1 << 20;
    /// Start the injected group (with JEXTTRIG and JEXTSEL = JSWSTART).
    pub const JSWSTART: u32 = 1 << 21;
    /// Start the regular group (with EXTTRIG and EXTSEL = SWSTART).
    pub const SWSTART: u32 = 1 << 22;
    /// Temperature sensor and VREFINT enable.
    pub const TSVREFE: u32 = 1 << 23;
}

/// VREF+ on the Blue Pill (tied to VDDA = 3.3 V).
pub const VREF_V: f64 = 3.3;
/// Highest ADC clock (RM0008 §11.1).
pub const MAX_ADCCLK_HZ: u32 = 14_000_000;
/// Power-up time t_STAB (DS5319 table 46, maximum).
pub const T_STAB_NS: f64 = 1_000.0;
/// Calibration time t_CAL in ADC clock cycles (DS5319 table 46).
pub const CAL_CYCLES: f64 = 83.0;
/// ADC clock cycles between power-up and a calibration start (§11.4).
pub const CAL_POWER_ON_CYCLES: f64 = 2.0;
/// RSTCAL's duration in ADC clock cycles (the manual gives none).
pub const RSTCAL_CYCLES: f64 = 1.0;
/// Sample times of SMPx codes 0..7, ADC clock cycles (§11.12.4).
pub const SAMPLE_CYCLES: [f64; 8] = [1.5, 7.5, 13.5, 28.5, 41.5, 55.5, 71.5, 239.5];
/// Conversion time after the sample phase, ADC clock cycles (§11.6).
pub const CONVERSION_CYCLES: f64 = 12.5;
/// External input channels (ADC12_IN0..15).
pub const INPUTS: usize = 16;

/// Why the ADC stops the board.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum AdcError {
    /// A feature the model does not have.
    Unmodelled(String),
    /// ADCCLK above 14 MHz.
    Clock(String),
    /// A use against the manual's sequence (undefined result on silicon).
    Misuse(String),
}

impl std::fmt::Display for AdcError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Unmodelled(s) | Self::Clock(s) | Self::Misuse(s) => f.write_str(s),
        }
    }
}

/// A conversion in progress.
#[derive(Clone, Copy, Debug)]
struct Conversion {
    channel: usize,
    sample_at: f64,
    end: f64,
    /// The code sampled at `sample_at`.
    code: Option<u16>,
}

/// The injected group in progress.
#[derive(Clone, Copy, Debug)]
struct Group {
    /// Channels in conversion order.
    channels: [usize; 4],
    len: usize,
    /// Index of the conversion running.
    rank: usize,
    conv: Conversion,
}

/// The ADC's state.
#[derive(Clone, Debug)]
pub struct Adc {
    adc_hz: u32,
    sr: u32,
    cr1: u32,
    cr2: u32,
    smpr: [u32; 2],
    jofr: [u32; 4],
    htr: u32,
    ltr: u32,
    sqr: [u32; 3],
    jsqr: u32,
    jdr: [u32; 4],
    dr: u32,
    /// When ADON woke the ADC (ns).
    powered_at: Option<f64>,
    cal_end: Option<f64>,
    rstcal_end: Option<f64>,
    regular: Option<Conversion>,
    /// A regular trigger waiting for the injected group's end.
    regular_waiting: bool,
    injected: Option<Group>,
    calibrated: bool,
    inputs_v: [f64; INPUTS],
    analog: [bool; INPUTS],
    uncalibrated_offset_lsb: i32,
    fault: Option<AdcError>,
    regular_done: u64,
    injected_done: u64,
    calibrations: u64,
}

/// SR bits software can clear (rc_w0).
const SR_FLAGS: u32 = sr::AWD | sr::EOC | sr::JEOC | sr::JSTRT | sr::STRT;
/// CR2 bits the model has.
const CR2_MODELLED: u32 = cr2::ADON
    | cr2::CONT
    | cr2::CAL
    | cr2::RSTCAL
    | cr2::ALIGN
    | cr2::JEXTSEL_JSWSTART
    | cr2::JEXTTRIG
    | cr2::EXTSEL_SWSTART
    | cr2::EXTTRIG
    | cr2::JSWSTART
    | cr2::SWSTART;

impl Adc {
    /// Reset state (every register 0, powered down) on an ADC clock of
    /// `adc_hz`; no input driven (0 V), no pin in analog mode.
    pub fn new(adc_hz: u32) -> Self {
        Self {
            adc_hz,
            sr: 0,
            cr1: 0,
            cr2: 0,
            smpr: [0; 2],
            jofr: [0; 4],
            htr: 0x0FFF,
            ltr: 0,
            sqr: [0; 3],
            jsqr: 0,
            jdr: [0; 4],
            dr: 0,
            powered_at: None,
            cal_end: None,
            rstcal_end: None,
            regular: None,
            regular_waiting: false,
            injected: None,
            calibrated: false,
            inputs_v: [0.0; INPUTS],
            analog: [false; INPUTS],
            uncalibrated_offset_lsb: 0,
            fault: None,
            regular_done: 0,
            injected_done: 0,
            calibrations: 0,
        }
    }

    /// Peripheral or MCU reset: registers to reset values, powered down;
    /// the inputs (outside the chip), the pins' modes (the board's) and
    /// the uncalibrated offset (the chip's) stay.
    pub fn reset(&mut self) {
        *self = Self {
            inputs_v: self.inputs_v,
            analog: self.analog,
            uncalibrated_offset_lsb: self.uncalibrated_offset_lsb,
            ..Self::new(self.adc_hz)
        };
    }

    /// The ADC clock (RCC: PCLK2 / ADCPRE) from `now_ns` on; above 14 MHz
    /// while powered stops the board. A conversion under way keeps the
    /// timing it started with.
    pub fn set_clock_hz(&mut self, hz: u32, now_ns: u64) {
        self.advance(now_ns);
        self.adc_hz = hz;
        if self.powered_at.is_some() {
            self.check_clock();
        }
    }

    /// The voltage on input `channel` (0..16) from `now_ns` on (a
    /// conversion whose sample phase ended before keeps its sample).
    pub fn set_input_v(&mut self, channel: usize, volts: f64, now_ns: u64) {
        self.advance(now_ns);
        if let Some(v) = self.inputs_v.get_mut(channel) {
            *v = volts;
        }
    }

    /// The voltage on input `channel`.
    pub fn input_v(&self, channel: usize) -> Option<f64> {
        self.inputs_v.get(channel).copied()
    }

    /// Whether input `channel`'s pin is in analog input mode (the board,
    /// from GPIO's CRL/CRH).
    pub fn set_pin_analog(&mut self, channel: usize, analog: bool) {
        if let Some(a) = self.analog.get_mut(channel) {
            *a = analog;
        }
    }

    /// The offset (LSB) an uncalibrated ADC adds to every code; a
    /// calibration removes it, a power-down brings it back.
    pub fn set_uncalibrated_offset_lsb(&mut self, lsb: i32) {
        self.uncalibrated_offset_lsb = lsb;
    }

    /// Regular and injected conversions completed, and calibrations, since
    /// reset.
    pub fn counts(&self) -> (u64, u64, u64) {
        (self.regular_done, self.injected_done, self.calibrations)
    }

    /// Whether a calibration completed since the last power-up.
    pub fn calibrated(&self) -> bool {
        self.calibrated
    }

    /// The error that stops the board, once.
    pub fn take_fault(&mut self) -> Option<AdcError> {
        self.fault.take()
    }

    fn fail(&mut self, e: AdcError) {
        if self.fault.is_none() {
            self.fault = Some(e);
        }
    }

    fn cycle_ns(&self) -> f64 {
        1e9 / f64::from(self.adc_hz.max(1))
    }

    fn check_clock(&mut self) {
        if self.adc_hz > MAX_ADCCLK_HZ {
            self.fail(AdcError::Clock(format!(
                "ADC1 clock {} Hz above the {MAX_ADCCLK_HZ} Hz maximum (RM0008 §11.1; RCC_CFGR.ADCPRE)",
                self.adc_hz
            )));
        }
    }

    /// The interrupt line (ADC1_2): EOC with EOCIE, JEOC with JEOCIE.
    pub fn irq(&self) -> bool {
        (self.sr & sr::EOC != 0 && self.cr1 & cr1::EOCIE != 0)
            || (self.sr & sr::JEOC != 0 && self.cr1 & cr1::JEOCIE != 0)
    }

    /// When the next conversion whose end raises the interrupt line ends
    /// (ns), for the scheduler. Everything else the ADC does shows only in
    /// its registers, which bring it up to date when they are read.
    pub fn next_event_ns(&self) -> Option<u64> {
        let regular = self
            .regular
            .filter(|_| self.cr1 & cr1::EOCIE != 0 && self.injected.is_none())
            .map(|c| c.end);
        // The injected group's end also restarts a regular conversion.
        let eoc_after =
            self.cr1 & cr1::EOCIE != 0 && (self.regular.is_some() || self.regular_waiting);
        let injected = self
            .injected
            .filter(|_| self.cr1 & cr1::JEOCIE != 0 || eoc_after)
            .map(|g| g.conv.end);
        [regular, injected]
            .into_iter()
            .flatten()
            .min_by(f64::total_cmp)
            .map(|t| t.ceil() as u64)
    }
}

/// What happens next inside the ADC.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Step {
    CalEnd(f64),
    RstCalEnd(f64),
    InjectedSample(f64),
    InjectedEnd(f64),
    RegularSample(f64),
    RegularEnd(f64),
}

impl Step {
    fn at(self) -> f64 {
        match self {
            Self::CalEnd(t)
            | Self::RstCalEnd(t)
            | Self::InjectedSample(t)
            | Self::InjectedEnd(t)
            | Self::RegularSample(t)
            | Self::RegularEnd(t) => t,
        }
    }
}

impl Adc {
    /// The earliest thing due inside the ADC.
    fn next_step(&self) -> Option<Step> {
        let inj = self.injected.map(|g| g.conv);
        let conv_steps = |c: Option<Conversion>, sample: fn(f64) -> Step, end: fn(f64) -> Step| {
            c.map(|c| match c.code {
                None => sample(c.sample_at),
                Some(_) => end(c.end),
            })
        };
        [
            self.cal_end.map(Step::CalEnd),
            self.rstcal_end.map(Step::RstCalEnd),
            conv_steps(inj, Step::InjectedSample, Step::InjectedEnd),
            // A regular conversion interrupted by the injected group does
            // not advance meanwhile.
            conv_steps(self.regular, Step::RegularSample, Step::RegularEnd)
                .filter(|_| self.injected.is_none()),
        ]
        .into_iter()
        .flatten()
        .min_by(|a, b| a.at().total_cmp(&b.at()))
    }

    /// Brings the ADC to `now_ns`: samples taken, conversions and
    /// calibrations ended, in time order.
    pub fn advance(&mut self, now_ns: u64) {
        let now = now_ns as f64;
        while let Some(step) = self.next_step().filter(|s| s.at() <= now) {
            match step {
                Step::CalEnd(_) => {
                    self.cal_end = None;
                    self.cr2 &= !cr2::CAL;
                    self.calibrated = true;
                    self.calibrations += 1;
                }
                Step::RstCalEnd(_) => {
                    self.rstcal_end = None;
                    self.cr2 &= !cr2::RSTCAL;
                }
                Step::InjectedSample(_) => {
                    if let Some(mut g) = self.injected {
                        g.conv.code = Some(self.sample(g.conv.channel));
                        self.injected = Some(g);
                    }
                }
                Step::RegularSample(_) => {
                    if let Some(mut c) = self.regular {
                        c.code = Some(self.sample(c.channel));
                        self.regular = Some(c);
                    }
                }
                Step::InjectedEnd(t) => self.end_injected(t),
                Step::RegularEnd(t) => self.end_regular(t),
            }
        }
    }

    /// The code of input `channel` now: 12 bits of VREF+, ideal transfer,
    /// clamped; an uncalibrated ADC adds its offset.
    fn sample(&mut self, channel: usize) -> u16 {
        if !self.analog.get(channel).copied().unwrap_or(false) {
            self.fail(AdcError::Misuse(format!(
                "ADC1 sampled channel {channel} with its pin not in analog input mode, or without a pin on this package (RM0008 §9.1.11, §11.3)"
            )));
        }
        let v = self.inputs_v.get(channel).copied().unwrap_or(0.0);
        let ideal = (v / VREF_V * 4096.0).floor();
        let offset = if self.calibrated {
            0.0
        } else {
            f64::from(self.uncalibrated_offset_lsb)
        };
        (ideal + offset).clamp(0.0, 4095.0) as u16
    }

    /// The conversion of `channel` from `t` (ns) at its sample time.
    fn conversion(&self, channel: usize, t: f64) -> Conversion {
        let (reg, shift) = if channel >= 10 {
            (0, 3 * (channel - 10))
        } else {
            (1, 3 * channel)
        };
        let code = (self.smpr[reg] >> shift) as usize & 7;
        let sample_at = t + SAMPLE_CYCLES[code] * self.cycle_ns();
        Conversion {
            channel,
            sample_at,
            end: sample_at + CONVERSION_CYCLES * self.cycle_ns(),
            code: None,
        }
    }

    fn end_regular(&mut self, t: f64) {
        let Some(c) = self.regular.take() else {
            return;
        };
        let code = u32::from(c.code.unwrap_or(0));
        self.dr = if self.cr2 & cr2::ALIGN != 0 {
            code << 4
        } else {
            code
        };
        self.sr |= sr::EOC;
        self.regular_done += 1;
        if self.cr2 & cr2::CONT != 0 {
            self.start_regular(t);
        }
    }

    fn end_injected(&mut self, t: f64) {
        let Some(mut g) = self.injected.take() else {
            return;
        };
        let rank = g.rank;
        let code = i32::from(g.conv.code.unwrap_or(0));
        let diff = code - (self.jofr[rank] & 0xFFF) as i32;
        let v = if self.cr2 & cr2::ALIGN != 0 {
            diff << 3
        } else {
            diff
        };
        self.jdr[rank] = u32::from(v as i16 as u16);
        self.injected_done += 1;
        g.rank += 1;
        if g.rank < g.len {
            g.conv = self.conversion(g.channels[g.rank], t);
            self.injected = Some(g);
            return;
        }
        self.sr |= sr::JEOC;
        // The interrupted (or waiting) regular conversion runs now.
        if let Some(c) = self.regular {
            self.regular = Some(self.conversion(c.channel, t));
        } else if std::mem::take(&mut self.regular_waiting) {
            self.start_regular(t);
        }
    }
}

/// CR1 bits of features the model does not have: JAUTO, DISCEN, JDISCEN,
/// DUALMOD, JAWDEN, AWDEN.
const CR1_UNMODELLED: u32 = (1 << 10) | (1 << 11) | (1 << 12) | (0xF << 16) | (1 << 22) | (1 << 23);

impl Adc {
    /// Whether a conversion may start at `t` (ns): powered for t_STAB, not
    /// calibrating, ADCCLK within its maximum.
    fn ready(&mut self, t: f64, what: &str) -> bool {
        self.check_clock();
        let why = match self.powered_at {
            None => Some("with the ADC powered down (ADON = 0)".to_owned()),
            Some(p) if t - p < T_STAB_NS => Some(format!(
                "{:.0} ns after power-up, before t_STAB = {T_STAB_NS:.0} ns (RM0008 §11.3.1)",
                t - p
            )),
            _ if self.cal_end.is_some() || self.rstcal_end.is_some() => {
                Some("during calibration (RM0008 §11.4)".to_owned())
            }
            _ => None,
        };
        if let Some(why) = why {
            self.fail(AdcError::Misuse(format!("ADC1 {what} started {why}")));
        }
        self.fault.is_none()
    }

    /// A regular trigger at `t`: SQ1 converts, unless the injected group
    /// runs (then after it) or a regular conversion already does.
    fn start_regular(&mut self, t: f64) {
        if !self.ready(t, "regular conversion") {
            return;
        }
        let len = (self.sqr[0] >> 20) & 0xF;
        if len > 0 && self.cr1 & cr1::SCAN != 0 {
            self.fail(AdcError::Unmodelled(format!(
                "ADC1 regular scan of {} channels (SQR1.L = {len}) not modelled",
                len + 1
            )));
            return;
        }
        let channel = (self.sqr[2] & 0x1F) as usize;
        if channel >= INPUTS {
            self.fail(AdcError::Unmodelled(format!(
                "ADC1 channel {channel} (temperature sensor, VREFINT) not modelled"
            )));
            return;
        }
        if self.injected.is_some() {
            self.regular_waiting = true;
        } else if self.regular.is_none() {
            self.regular = Some(self.conversion(channel, t));
            self.sr |= sr::STRT;
        }
    }

    /// An injected trigger at `t`: the group in JSQR converts, interrupting
    /// a regular conversion.
    fn start_injected(&mut self, t: f64) {
        if self.injected.is_some() || !self.ready(t, "injected conversion") {
            return;
        }
        let jl = ((self.jsqr >> 20) & 3) as usize;
        if jl > 0 && self.cr1 & cr1::SCAN == 0 {
            self.fail(AdcError::Unmodelled(format!(
                "ADC1 injected group of {} channels without SCAN not modelled",
                jl + 1
            )));
            return;
        }
        let mut channels = [0usize; 4];
        for (k, c) in channels.iter_mut().enumerate().take(jl + 1) {
            // JL + 1 conversions end at JSQ4 (§11.12.12).
            let jsq = 3 - jl + k;
            *c = ((self.jsqr >> (5 * jsq)) & 0x1F) as usize;
        }
        if let Some(&c) = channels[..=jl].iter().find(|&&c| c >= INPUTS) {
            self.fail(AdcError::Unmodelled(format!(
                "ADC1 channel {c} (temperature sensor, VREFINT) not modelled"
            )));
            return;
        }
        self.injected = Some(Group {
            channels,
            len: jl + 1,
            rank: 0,
            conv: self.conversion(channels[0], t),
        });
        self.sr |= sr::JSTRT;
    }

    /// ADON: wakes the ADC (0 → 1), starts a regular conversion (1 written
    /// again, no other bit changed), powers it down (1 → 0).
    fn write_adon(&mut self, old: u32, v: u32, t: f64) {
        match (old & cr2::ADON != 0, v & cr2::ADON != 0) {
            (false, true) => {
                self.powered_at = Some(t);
                self.check_clock();
            }
            (true, true) if (v ^ old) & !cr2::ADON == 0 => self.start_regular(t),
            (true, false) => {
                self.powered_at = None;
                self.regular = None;
                self.regular_waiting = false;
                self.injected = None;
                self.cal_end = None;
                self.rstcal_end = None;
                self.calibrated = false;
            }
            _ => {}
        }
    }

    /// CAL or RSTCAL set at `t`.
    fn start_calibration(&mut self, rstcal: bool, t: f64) {
        let cycles = self.powered_at.map_or(0.0, |p| (t - p) / self.cycle_ns());
        if cycles < CAL_POWER_ON_CYCLES {
            let what = if rstcal { "RSTCAL" } else { "CAL" };
            self.fail(AdcError::Misuse(format!(
                "ADC1 {what} set {cycles:.1} ADC clock cycles after power-up; RM0008 §11.4 asks for ADON = 1 for at least two"
            )));
        } else if rstcal {
            self.rstcal_end = Some(t + RSTCAL_CYCLES * self.cycle_ns());
        } else {
            self.cal_end = Some(t + CAL_CYCLES * self.cycle_ns());
        }
    }

    fn write_cr2(&mut self, v: u32, t: f64) {
        let unmodelled = if v & !CR2_MODELLED != 0 {
            Some("CR2.DMA, TSVREFE or a reserved bit")
        } else if v & cr2::EXTTRIG != 0 && v & cr2::EXTSEL_SWSTART != cr2::EXTSEL_SWSTART {
            Some("regular external trigger other than SWSTART")
        } else if v & cr2::JEXTTRIG != 0 && v & cr2::JEXTSEL_JSWSTART != cr2::JEXTSEL_JSWSTART {
            Some("injected external trigger other than JSWSTART")
        } else {
            None
        };
        if let Some(u) = unmodelled {
            self.fail(AdcError::Unmodelled(format!(
                "ADC1 {u} not modelled (CR2 {v:#x})"
            )));
            return;
        }
        let old = self.cr2;
        // CAL and RSTCAL: software sets them, hardware clears them.
        let hw_bits = old & (cr2::CAL | cr2::RSTCAL);
        self.cr2 = v | hw_bits;
        self.write_adon(old, v, t);
        if self.cr2 & cr2::ADON == 0 {
            self.cr2 &= !(cr2::CAL | cr2::RSTCAL);
        }
        for (bit, rst) in [(cr2::RSTCAL, true), (cr2::CAL, false)] {
            if v & bit != 0 && old & bit == 0 {
                self.start_calibration(rst, t);
            }
        }
        let sw = |trig, start| v & (trig | start) == trig | start;
        if sw(cr2::EXTTRIG, cr2::SWSTART) {
            self.cr2 &= !cr2::SWSTART;
            self.start_regular(t);
        }
        if sw(cr2::JEXTTRIG, cr2::JSWSTART) {
            self.cr2 &= !cr2::JSWSTART;
            self.start_injected(t);
        }
    }

    /// Register read at `offset`; `None`: not a register.
    pub fn read(&mut self, offset: u32, now_ns: u64) -> Option<u32> {
        self.advance(now_ns);
        Some(match offset {
            reg::SR => self.sr,
            reg::CR1 => self.cr1,
            reg::CR2 => self.cr2,
            reg::SMPR1 => self.smpr[0],
            reg::SMPR2 => self.smpr[1],
            0x14..=0x20 => self.jofr[(offset - 0x14) as usize / 4],
            reg::HTR => self.htr,
            reg::LTR => self.ltr,
            reg::SQR1 => self.sqr[0],
            reg::SQR2 => self.sqr[1],
            reg::SQR3 => self.sqr[2],
            reg::JSQR => self.jsqr,
            0x3C..=0x48 => self.jdr[(offset - 0x3C) as usize / 4],
            reg::DR => {
                // A DR read clears EOC (§11.12.1).
                self.sr &= !sr::EOC;
                self.dr
            }
            _ => return None,
        })
    }

    /// Register write at `offset`. `None`: not a register; `Some(Err)`: a
    /// feature the model lacks, or a use the manual forbids.
    pub fn write(&mut self, offset: u32, v: u32, now_ns: u64) -> Option<Result<(), AdcError>> {
        self.advance(now_ns);
        let t = now_ns as f64;
        match offset {
            // rc_w0: writing 0 clears a flag, 1 leaves it.
            reg::SR => self.sr &= v | !SR_FLAGS,
            reg::CR1 if v & CR1_UNMODELLED != 0 => self.fail(AdcError::Unmodelled(format!(
                "ADC1 CR1 {v:#x}: analog watchdog, discontinuous, JAUTO or dual mode not modelled"
            ))),
            reg::CR1 => self.cr1 = v & 0x00FF_FFFF,
            reg::CR2 => self.write_cr2(v & 0x00FF_FFFF, t),
            reg::SMPR1 => self.smpr[0] = v & 0x00FF_FFFF,
            reg::SMPR2 => self.smpr[1] = v & 0x3FFF_FFFF,
            0x14..=0x20 => self.jofr[(offset - 0x14) as usize / 4] = v & 0xFFF,
            reg::HTR => self.htr = v & 0xFFF,
            reg::LTR => self.ltr = v & 0xFFF,
            reg::SQR1 => self.sqr[0] = v & 0x00FF_FFFF,
            reg::SQR2 => self.sqr[1] = v & 0x3FFF_FFFF,
            reg::SQR3 => self.sqr[2] = v & 0x3FFF_FFFF,
            reg::JSQR => self.jsqr = v & 0x003F_FFFF,
            // The data registers are read-only.
            0x3C..=0x48 | reg::DR => {}
            _ => return None,
        }
        Some(self.fault.take().map_or(Ok(()), Err))
    }
}
