//! The PPM receiver (feature `ppm`): PB8 = TIM4_CH3 (RM0008 §9.3.7, no
//! remap), a 5 V tolerant pin clear of I2C1 (PB6/PB7), the ESC timer
//! (TIM3), the button (PA0) and USART1 (PA9/PA10). TIM4 counts at 1 MHz,
//! free-running over 16 bits, and latches the counter on every rising edge
//! of PB8 (input capture, §15.3.5); the capture interrupt turns two
//! captures into an interval (`rc_input::CaptureIntervals`) and the
//! interval into channels (`rc_input::PpmDecoder`). Timing comes from the
//! capture hardware, so the interrupt's latency costs no precision.
//!
//! Polarity: a PPM train marks every channel with a separator pulse of
//! constant width, so the time between two rising edges equals the time
//! between the two falling edges: capturing rising edges decodes positive
//! PPM (idle low, high pulses, the common case) and negative PPM alike.

use rc_input::{CaptureIntervals, PpmDecoder, PpmStats, RcFrame};
use stm32f1xx_hal::pac;

/// The capture counter's rate: 1 µs per count, the unit of the decoder.
const CAPTURE_HZ: u32 = 1_000_000;

/// Counters of the PPM input; saturating.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, defmt::Format)]
pub struct PpmCounters {
    /// The decoder's frames and drops.
    pub decoder: PpmStats,
    /// Edges lost because a capture came before the previous one was read
    /// (CC3OF); the frame in progress is dropped.
    pub overcaptures: u32,
}

impl PpmCounters {
    /// Nothing counted yet.
    pub const ZERO: Self = Self {
        decoder: PpmStats {
            frames: 0,
            bad_pulse: 0,
            bad_count: 0,
            unconfirmed: 0,
        },
        overcaptures: 0,
    };
}

/// TIM4 channel 3 capturing PB8, and the decoding state.
pub struct PpmInput {
    tim: pac::TIM4,
    intervals: CaptureIntervals,
    decoder: PpmDecoder,
    overcaptures: u32,
}

impl PpmInput {
    /// Clocks TIM4 and GPIOB, makes PB8 an input with pull-down (an
    /// unplugged receiver reads as a steady low, no edges), sets the
    /// counter to 1 MHz from `timer_hz` (TIM4's kernel clock: 72 MHz, or
    /// 64 MHz on the HSI fallback) and starts capturing rising edges with
    /// the capture interrupt enabled.
    pub fn start(tim: pac::TIM4, timer_hz: u32) -> Self {
        // SAFETY: register writes in init, before any task runs: RCC
        // enable bits (read-modify-write), PB8's CRH nibble and its BRR bit
        // (atomic, touches no other pin); no other code owns TIM4 or PB8.
        #[allow(unsafe_code)]
        unsafe {
            let rcc = &*pac::RCC::ptr();
            rcc.apb1enr().modify(|_, w| w.tim4en().set_bit());
            rcc.apb2enr().modify(|_, w| w.iopben().set_bit());
            let gpiob = &*pac::GPIOB::ptr();
            // CNF = 10 (input with pull-up/down), MODE = 00; ODR8 = 0: down.
            gpiob
                .crh()
                .modify(|r, w| w.bits((r.bits() & !0xF) | 0b1000));
            gpiob.brr().write(|w| w.bits(1 << 8));
        }
        let psc = (timer_hz / CAPTURE_HZ).saturating_sub(1);
        tim.psc().write(|w| w.psc().set(psc as u16));
        tim.arr().write(|w| w.arr().set(0xFFFF));
        // CC3S = 01 (IC3 on TI3), IC3PSC = 00 (every edge), IC3F = 0000: a
        // glitch is a wrong interval, which the decoder drops with its frame.
        tim.ccmr2_input().write(|w| w.cc3s().ti3());
        // CC3P = 0: rising edges.
        tim.ccer().write(|w| w.cc3e().set_bit());
        // UG loads the prescaler before counting.
        tim.egr().write(|w| w.ug().set_bit());
        tim.sr()
            .write(|w| w.uif().clear_bit().cc3if().clear_bit().cc3of().clear_bit());
        tim.dier().write(|w| w.cc3ie().set_bit());
        tim.cr1().write(|w| w.cen().set_bit());
        Self {
            tim,
            intervals: CaptureIntervals::new(),
            decoder: PpmDecoder::new(),
            overcaptures: 0,
        }
    }

    /// The capture interrupt at coarse time `now_us`: reads CCR3 (which
    /// clears CC3IF), then CC3OF — in that order, as RM0008 §15.3.5
    /// recommends, so an over-capture between the two reads is not missed.
    /// After an over-capture the interval spans a lost edge: the frame in
    /// progress is dropped and the capture only starts the next interval.
    /// Returns a frame when this edge completed one.
    pub fn on_interrupt(&mut self, now_us: u32) -> Option<RcFrame> {
        if self.tim.sr().read().cc3if().bit_is_clear() {
            return None;
        }
        let capture = self.tim.ccr3().read().ccr().bits();
        if self.tim.sr().read().cc3of().bit_is_set() {
            self.tim.sr().write(|w| w.cc3of().clear_bit());
            self.overcaptures = self.overcaptures.saturating_add(1);
            self.decoder.clear();
            self.intervals.restart();
            self.intervals.push(capture, now_us);
            return None;
        }
        let interval_us = self.intervals.push(capture, now_us)?;
        self.decoder.push_interval_us(interval_us)
    }

    /// Counters so far.
    pub fn counters(&self) -> PpmCounters {
        PpmCounters {
            decoder: *self.decoder.stats(),
            overcaptures: self.overcaptures,
        }
    }
}
