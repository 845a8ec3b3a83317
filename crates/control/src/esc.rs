//! ESC output values: motor command 0..1 → pulse width → timer compare
//! value, for standard PWM and OneShot125, plus the "off" (disarmed) value.
//!
//! | protocol | pulse for 0..1 | off | frame rate (default, max) |
//! |---|---|---|---|
//! | [`EscProtocol::Pwm`] | 1000..2000 µs | 1000 µs | 400 Hz, ≤ 490 Hz |
//! | [`EscProtocol::OneShot125`] | 125..250 µs | 125 µs | 2 kHz, ≤ 3.9 kHz |
//!
//! The "off" pulse is the bottom of the range, which every ESC treats as
//! motor stopped (and needs to see at power-up to arm itself). The timer
//! runs in edge-aligned PWM mode with `ARR = period_ticks − 1` and a tick
//! of `timer_clock_hz / (prescaler + 1)`; the compare value is the pulse in
//! ticks. Both the firmware and the emulator use [`EscTimer`] so they agree
//! to the tick.
//!
//! ```
//! use control::esc::{EscProtocol, EscTimer};
//! // Blue Pill TIM3/TIM4 on APB1 ×2 = 72 MHz.
//! let t = EscTimer::for_clock(EscProtocol::Pwm, 400, 72_000_000)?;
//! assert_eq!(t.prescaler(), 2);           // 24 MHz tick
//! assert_eq!(t.auto_reload(), 59_999);     // 2.5 ms frame
//! assert_eq!(t.off_compare(), 24_000);     // 1000 µs
//! assert_eq!(t.compare(1.0), 48_000);      // 2000 µs
//! assert_eq!(t.pulse_ns(t.compare(0.5)), 1_500_000);
//! # Ok::<(), control::esc::EscError>(())
//! ```

/// The ESC signalling protocol.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EscProtocol {
    /// Standard servo-style PWM, 1000–2000 µs.
    Pwm,
    /// OneShot125, 125–250 µs.
    OneShot125,
}

#[cfg(feature = "defmt")]
impl defmt::Format for EscProtocol {
    fn format(&self, f: defmt::Formatter) {
        match self {
            Self::Pwm => defmt::write!(f, "standard PWM (1000-2000 us)"),
            Self::OneShot125 => defmt::write!(f, "OneShot125 (125-250 us)"),
        }
    }
}

impl EscProtocol {
    /// Pulse for command 0 (and "off"), ns.
    pub const fn min_pulse_ns(self) -> u32 {
        match self {
            Self::Pwm => 1_000_000,
            Self::OneShot125 => 125_000,
        }
    }

    /// Pulse for command 1, ns.
    pub const fn max_pulse_ns(self) -> u32 {
        2 * self.min_pulse_ns()
    }

    /// Highest frame rate, Hz: the period must exceed the longest pulse with
    /// room for the ESC to see the low gap (PWM: 490 Hz is the usual ESC
    /// limit; OneShot125: 256 µs period).
    pub const fn max_rate_hz(self) -> u32 {
        match self {
            Self::Pwm => 490,
            Self::OneShot125 => 3_900,
        }
    }

    /// The usual frame rate, Hz: 400 for PWM, 2000 for OneShot125.
    pub const fn default_rate_hz(self) -> u32 {
        match self {
            Self::Pwm => 400,
            Self::OneShot125 => 2_000,
        }
    }
}

/// Why an [`EscTimer`] was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EscError {
    /// Frame rate 0 or above the protocol's maximum.
    InvalidRate,
    /// Timer clock 0.
    InvalidClock,
    /// The period does not fit a 16-bit auto-reload at this prescaler.
    PeriodTooLong,
    /// The tick is too coarse: fewer than 500 steps between 0 and 1.
    ResolutionTooLow,
}

impl core::fmt::Display for EscError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::InvalidRate => "ESC frame rate is zero or above the protocol's maximum",
            Self::InvalidClock => "timer clock is zero",
            Self::PeriodTooLong => "ESC period does not fit the 16-bit timer at this prescaler",
            Self::ResolutionTooLow => "timer tick too coarse: under 500 steps of throttle",
        })
    }
}

impl core::error::Error for EscError {}

/// Fewest timer ticks between command 0 and command 1.
pub const MIN_STEPS: u32 = 500;

/// A validated timer set-up for one protocol: prescaler, auto-reload and the
/// command → compare mapping.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EscTimer {
    protocol: EscProtocol,
    prescaler: u16,
    tick_hz: u32,
    period_ticks: u32,
    min_ticks: u32,
    span_ticks: u32,
}

impl EscTimer {
    /// Set-up for an explicit prescaler (`PSC` register value; tick =
    /// `timer_clock_hz / (prescaler + 1)`). Errors: see [`EscError`].
    pub fn new(
        protocol: EscProtocol,
        rate_hz: u32,
        timer_clock_hz: u32,
        prescaler: u16,
    ) -> Result<Self, EscError> {
        if rate_hz == 0 || rate_hz > protocol.max_rate_hz() {
            return Err(EscError::InvalidRate);
        }
        if timer_clock_hz == 0 {
            return Err(EscError::InvalidClock);
        }
        let tick_hz = timer_clock_hz / (u32::from(prescaler) + 1);
        let period_ticks = tick_hz / rate_hz;
        if period_ticks > 65_536 {
            return Err(EscError::PeriodTooLong);
        }
        let min_ticks = ticks_for_us(protocol.min_pulse_ns() / 1_000, tick_hz);
        let span_ticks = ticks_for_us(protocol.max_pulse_ns() / 1_000, tick_hz) - min_ticks;
        if span_ticks < MIN_STEPS {
            return Err(EscError::ResolutionTooLow);
        }
        Ok(Self {
            protocol,
            prescaler,
            tick_hz,
            period_ticks,
            min_ticks,
            span_ticks,
        })
    }

    /// Set-up with the smallest prescaler (finest resolution) whose period
    /// fits 16 bits. Errors: see [`EscError`].
    pub fn for_clock(
        protocol: EscProtocol,
        rate_hz: u32,
        timer_clock_hz: u32,
    ) -> Result<Self, EscError> {
        if rate_hz == 0 || rate_hz > protocol.max_rate_hz() {
            return Err(EscError::InvalidRate);
        }
        if timer_clock_hz == 0 {
            return Err(EscError::InvalidClock);
        }
        // ticks per period = clock / ((psc + 1) · rate) <= 65 536.
        let per = timer_clock_hz / rate_hz;
        let psc = per
            .div_ceil(65_536)
            .saturating_sub(1)
            .min(u32::from(u16::MAX));
        Self::new(protocol, rate_hz, timer_clock_hz, psc as u16)
    }

    /// The protocol.
    pub fn protocol(&self) -> EscProtocol {
        self.protocol
    }

    /// `PSC` register value.
    pub fn prescaler(&self) -> u16 {
        self.prescaler
    }

    /// `ARR` register value (`period_ticks − 1`).
    pub fn auto_reload(&self) -> u16 {
        // period_ticks is 1..=65 536 by construction.
        (self.period_ticks.saturating_sub(1)).min(u32::from(u16::MAX)) as u16
    }

    /// Timer ticks per frame.
    pub fn period_ticks(&self) -> u32 {
        self.period_ticks
    }

    /// Compare value for a motor command: 0..1 (clamped) maps linearly to
    /// the protocol's pulse range; NaN gives the off value.
    pub fn compare(&self, command: f32) -> u16 {
        let c = if command.is_nan() {
            0.0
        } else {
            command.clamp(0.0, 1.0)
        };
        let t = self.min_ticks + (c * self.span_ticks as f32 + 0.5) as u32;
        t.min(u32::from(u16::MAX)) as u16
    }

    /// [`compare`](Self::compare) for a Q30 command (`1 << 30` = full
    /// throttle; clamped to 0..1): `min + round(c · span)` by one 32×32-bit
    /// `UMULL`, no soft-float. Equal to `compare(c as f32 / 2³⁰)` within
    /// one tick (the `f32` form rounds its product to 24 bits first).
    pub fn compare_q30(&self, command_q30: i32) -> u16 {
        let c = command_q30.clamp(0, 1 << 30) as u32;
        let t =
            self.min_ticks + ((u64::from(c) * u64::from(self.span_ticks) + (1 << 29)) >> 30) as u32;
        t.min(u32::from(u16::MAX)) as u16
    }

    /// Compare value of the "off" pulse (ESC disarmed / motor stopped).
    pub fn off_compare(&self) -> u16 {
        self.min_ticks.min(u32::from(u16::MAX)) as u16
    }

    /// Timer tick rate, Hz.
    pub fn tick_hz(&self) -> u32 {
        self.tick_hz
    }

    /// Pulse width of a compare value, ns (for logs and the emulator).
    pub fn pulse_ns(&self, compare: u16) -> u32 {
        let ns = u64::from(compare) * 1_000_000_000 / u64::from(self.tick_hz.max(1));
        ns.min(u64::from(u32::MAX)) as u32
    }

    /// Frame period, ns.
    pub fn period_ns(&self) -> u32 {
        let ns = u64::from(self.period_ticks) * 1_000_000_000 / u64::from(self.tick_hz.max(1));
        ns.min(u64::from(u32::MAX)) as u32
    }
}

/// `round(us · tick_hz / 10⁶)`, timer ticks in a pulse of `us` whole
/// microseconds (every protocol's pulses are), in 32-bit arithmetic: the
/// 64-bit division it replaces links a ~0.9 KiB library routine on the
/// Cortex-M3. With `tick_hz = q·10⁶ + r` the result is
/// `us·q + round(us·r / 10⁶)`, exact while `us·r < 2³²` (`us` ≤ 4,294; the
/// longest pulse is 2,000 µs).
fn ticks_for_us(us: u32, tick_hz: u32) -> u32 {
    let (q, r) = (tick_hz / 1_000_000, tick_hz % 1_000_000);
    us * q + (us * r + 500_000) / 1_000_000
}

/// Pulse width for a command, ns, independent of any timer: 0..1 (clamped,
/// NaN = off) → the protocol's range.
pub fn pulse_ns(protocol: EscProtocol, command: f32) -> u32 {
    let c = if command.is_nan() {
        0.0
    } else {
        command.clamp(0.0, 1.0)
    };
    let min = protocol.min_pulse_ns();
    min + (c * min as f32 + 0.5) as u32
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The 32-bit tick count equals the 64-bit `round(ns · tick_hz / 10⁹)`
    /// it replaces, for every protocol pulse at every prescaler of the
    /// Blue Pill's clocks and on a sweep of other tick rates.
    #[test]
    fn ticks_for_us_matches_the_64_bit_rounding() {
        let reference = |ns: u32, tick_hz: u32| {
            (u64::from(ns) * u64::from(tick_hz) + 500_000_000) / 1_000_000_000
        };
        let board = [8_000_000u32, 64_000_000, 72_000_000]
            .into_iter()
            .flat_map(|clk| (0..=u32::from(u16::MAX)).map(move |psc| clk / (psc + 1)));
        let sweep = (0..100_000u32).map(|i| i.wrapping_mul(2_654_435_761) % 200_000_000);
        for tick_hz in board.chain(sweep) {
            for ns in [125_000, 250_000, 1_000_000, 2_000_000] {
                assert_eq!(
                    u64::from(ticks_for_us(ns / 1_000, tick_hz)),
                    reference(ns, tick_hz),
                    "{ns} ns at {tick_hz} Hz"
                );
            }
        }
    }
}
