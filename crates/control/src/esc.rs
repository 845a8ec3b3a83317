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
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EscProtocol {
    /// Standard servo-style PWM, 1000–2000 µs.
    Pwm,
    /// OneShot125, 125–250 µs.
    OneShot125,
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
        let tick_hz = u64::from(timer_clock_hz) / (u64::from(prescaler) + 1);
        let period_ticks = tick_hz / u64::from(rate_hz);
        if period_ticks > 65_536 {
            return Err(EscError::PeriodTooLong);
        }
        let ticks = |ns: u32| (u64::from(ns) * tick_hz + 500_000_000) / 1_000_000_000;
        let min_ticks = ticks(protocol.min_pulse_ns());
        let span_ticks = ticks(protocol.max_pulse_ns()) - min_ticks;
        if span_ticks < u64::from(MIN_STEPS) {
            return Err(EscError::ResolutionTooLow);
        }
        // Fits u32: both are below the 65 536-tick period.
        Ok(Self {
            protocol,
            prescaler,
            tick_hz: tick_hz as u32,
            period_ticks: period_ticks as u32,
            min_ticks: min_ticks as u32,
            span_ticks: span_ticks as u32,
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
        let per = u64::from(timer_clock_hz) / u64::from(rate_hz);
        let psc = per
            .div_ceil(65_536)
            .saturating_sub(1)
            .min(u64::from(u16::MAX));
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
