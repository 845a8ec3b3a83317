//! Per-sensor health bookkeeping and the recovery policy, as pure logic.
//!
//! The firmware reports each bus transaction's outcome to a
//! [`SensorHealth`]; the returned [`Action`] says whether to retry, to
//! re-initialise the chip, or to stop trying. [`needs_bus_recovery`] decides
//! when every device is failing at once (a stuck bus), and
//! [`recover_bus`] is the stuck-bus procedure itself over a small
//! pin-toggling trait ([`RecoveryPins`]).

use embedded_hal::delay::DelayNs;

/// Overall state of one sensor.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SensorState {
    /// Working; the last transaction succeeded.
    Ok,
    /// Working with recent errors (retries or re-initialisations under way).
    Degraded,
    /// Not found at boot; never used.
    Missing,
    /// Re-initialisation failed repeatedly; the sensor's data is not used.
    Failed,
}

/// Event counters of one sensor (saturating).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HealthCounters {
    /// Successful transactions.
    pub ok: u32,
    /// Failed transactions (bus error, NACK, timeout).
    pub errors: u32,
    /// Transactions repeated after an error.
    pub retries: u32,
    /// Re-initialisations performed.
    pub reinits: u32,
    /// Chip resets detected (configuration read-back mismatch).
    pub resets_detected: u32,
    /// Data overruns reported by the sensor (e.g. AK8963 DOR, FIFO overflow).
    pub overflows: u32,
    /// Reads that found no new data.
    pub not_ready: u32,
}

/// Tunable thresholds of the recovery policy.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HealthPolicy {
    /// Retries of one failed transaction before it is given up.
    pub max_retries: u8,
    /// Consecutive failed transactions (after retries) that trigger a
    /// re-initialisation.
    pub reinit_after_errors: u16,
    /// Consecutive failed re-initialisations after which the sensor is
    /// declared [`SensorState::Failed`].
    pub fail_after_reinits: u16,
    /// Consecutive failed transactions of every present sensor that
    /// trigger stuck-bus recovery ([`needs_bus_recovery`]).
    pub bus_recovery_after_errors: u16,
}

impl Default for HealthPolicy {
    fn default() -> Self {
        Self {
            max_retries: 2,
            reinit_after_errors: 5,
            fail_after_reinits: 5,
            bus_recovery_after_errors: 3,
        }
    }
}

/// What the caller should do after reporting an outcome.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Action {
    /// Nothing: carry on.
    None,
    /// Re-initialise the chip (it reset itself or keeps failing).
    Reinit,
    /// The sensor is failed or missing: do not use its data.
    Disable,
}

/// Health of one sensor: state, counters, and the policy's memory.
///
/// ```
/// use sensor_stack::health::{Action, HealthPolicy, SensorHealth, SensorState};
/// let mut h = SensorHealth::new(HealthPolicy::default());
/// let r: Result<u8, ()> = h.with_retries(|| Ok(7));
/// assert_eq!(r, Ok(7));
/// assert_eq!(h.state(), SensorState::Ok);
/// assert_eq!(h.config_mismatch(), Action::Reinit);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SensorHealth {
    policy: HealthPolicy,
    state: SensorState,
    counters: HealthCounters,
    consecutive_errors: u16,
    failed_reinits: u16,
}

impl SensorHealth {
    /// A present, healthy sensor.
    pub const fn new(policy: HealthPolicy) -> Self {
        Self {
            policy,
            state: SensorState::Ok,
            counters: HealthCounters {
                ok: 0,
                errors: 0,
                retries: 0,
                reinits: 0,
                resets_detected: 0,
                overflows: 0,
                not_ready: 0,
            },
            consecutive_errors: 0,
            failed_reinits: 0,
        }
    }

    /// A working sensor that keeps the counters of an earlier life (a chip
    /// that was missing and answered a re-probe).
    pub const fn with_counters(policy: HealthPolicy, counters: HealthCounters) -> Self {
        let mut h = Self::new(policy);
        h.counters = counters;
        h
    }

    /// A sensor that was not found at boot.
    pub const fn missing(policy: HealthPolicy) -> Self {
        let mut h = Self::new(policy);
        h.state = SensorState::Missing;
        h
    }

    /// Current state.
    pub fn state(&self) -> SensorState {
        self.state
    }

    /// Counters.
    pub fn counters(&self) -> &HealthCounters {
        &self.counters
    }

    /// Failed transactions since the last success.
    pub fn consecutive_errors(&self) -> u16 {
        self.consecutive_errors
    }

    /// The policy in use.
    pub fn policy(&self) -> &HealthPolicy {
        &self.policy
    }

    /// `true` if the sensor's data may be used (Ok or Degraded).
    pub fn usable(&self) -> bool {
        matches!(self.state, SensorState::Ok | SensorState::Degraded)
    }

    /// Records a successful transaction.
    pub fn success(&mut self) {
        self.counters.ok = self.counters.ok.saturating_add(1);
        self.consecutive_errors = 0;
        if self.state == SensorState::Degraded {
            self.state = SensorState::Ok;
        }
    }

    /// Records a failed transaction (after its retries). Returns
    /// [`Action::Reinit`] once `reinit_after_errors` failures in a row
    /// accumulate (and every further `reinit_after_errors`).
    pub fn error(&mut self) -> Action {
        self.counters.errors = self.counters.errors.saturating_add(1);
        self.consecutive_errors = self.consecutive_errors.saturating_add(1);
        match self.state {
            SensorState::Missing | SensorState::Failed => return Action::Disable,
            SensorState::Ok => self.state = SensorState::Degraded,
            SensorState::Degraded => {}
        }
        let n = self.policy.reinit_after_errors.max(1);
        if self.consecutive_errors.is_multiple_of(n) {
            Action::Reinit
        } else {
            Action::None
        }
    }

    /// Records a repeated transaction.
    pub fn retry(&mut self) {
        self.counters.retries = self.counters.retries.saturating_add(1);
    }

    /// Records a read that found no new data (not an error).
    pub fn not_ready(&mut self) {
        self.counters.not_ready = self.counters.not_ready.saturating_add(1);
    }

    /// Records a data overrun reported by the sensor (not an error).
    pub fn overflow(&mut self) {
        self.counters.overflows = self.counters.overflows.saturating_add(1);
    }

    /// Records that a configuration read-back did not match what was
    /// written: the chip reset itself. Always asks for a re-initialisation.
    pub fn config_mismatch(&mut self) -> Action {
        self.counters.resets_detected = self.counters.resets_detected.saturating_add(1);
        match self.state {
            SensorState::Missing | SensorState::Failed => Action::Disable,
            _ => {
                self.state = SensorState::Degraded;
                Action::Reinit
            }
        }
    }

    /// Records the result of a re-initialisation. After
    /// `fail_after_reinits` failures in a row the sensor is `Failed`.
    pub fn reinit_done(&mut self, success: bool) -> Action {
        self.counters.reinits = self.counters.reinits.saturating_add(1);
        if success {
            self.failed_reinits = 0;
            self.consecutive_errors = 0;
            if self.state != SensorState::Missing {
                self.state = SensorState::Ok;
            }
            return Action::None;
        }
        self.failed_reinits = self.failed_reinits.saturating_add(1);
        if self.failed_reinits >= self.policy.fail_after_reinits {
            self.state = SensorState::Failed;
            Action::Disable
        } else {
            Action::None
        }
    }

    /// Gives a `Failed` sensor another chance (e.g. after a bus recovery):
    /// it becomes `Degraded` and is re-initialised by the caller.
    pub fn revive(&mut self) {
        if self.state == SensorState::Failed {
            self.state = SensorState::Degraded;
            self.failed_reinits = 0;
            self.consecutive_errors = 0;
        }
    }

    /// Records the outcome of one attempt, without retrying: the 1 kHz
    /// path counts a failed read and skips the sample. Returns the result
    /// unchanged; the [`Action`] for an error is available from
    /// [`pending_action`](Self::pending_action).
    pub fn record<T, E>(&mut self, r: Result<T, E>) -> Result<T, E> {
        match &r {
            Ok(_) => self.success(),
            Err(_) => {
                self.error();
            }
        }
        r
    }

    /// Runs `op` up to `1 + max_retries` times, counting retries, and
    /// records the final outcome ([`success`](Self::success) or
    /// [`error`](Self::error)). Returns the last result; the
    /// [`Action`] for a final error is available from
    /// [`pending_action`](Self::pending_action).
    pub fn with_retries<T, E>(&mut self, mut op: impl FnMut() -> Result<T, E>) -> Result<T, E> {
        let mut attempt = 0u8;
        loop {
            match op() {
                Ok(v) => {
                    self.success();
                    return Ok(v);
                }
                Err(e) => {
                    if attempt >= self.policy.max_retries {
                        self.error();
                        return Err(e);
                    }
                    attempt = attempt.saturating_add(1);
                    self.retry();
                }
            }
        }
    }

    /// The action the current error streak calls for: `Reinit` when the
    /// streak is a positive multiple of `reinit_after_errors`, `Disable`
    /// when missing or failed, otherwise `None`.
    pub fn pending_action(&self) -> Action {
        match self.state {
            SensorState::Missing | SensorState::Failed => Action::Disable,
            _ => {
                let n = self.policy.reinit_after_errors.max(1);
                if self.consecutive_errors > 0 && self.consecutive_errors.is_multiple_of(n) {
                    Action::Reinit
                } else {
                    Action::None
                }
            }
        }
    }
}

/// When an armed craft may reset a chip: only once it is proven lost.
///
/// A reset of the MPU-9250 costs its samples for the reset itself and
/// the 100 ms settle after it, longer than the flight controller can fly
/// without a gyro; a bus glitch that corrupts one read-back, or a burst of
/// NACKs, is over long before that. So, while armed, a suspect chip is
/// re-checked at most every [`recheck_spacing_ms`](Self::recheck_spacing_ms),
/// and reset only when
/// * it answers wrong (a configuration register or WHO_AM_I that reads
///   back wrong) on [`confirm_rereads`](Self::confirm_rereads) re-checks in
///   a row: a chip that reset itself reads wrong every time, a glitch does
///   not; or
/// * it answers nothing (NACK, bus error) on
///   [`lost_after_rechecks`](Self::lost_after_rechecks) re-checks in a row
///   (at least 20 × 5 ms = 100 ms): a chip that does not answer loses
///   nothing by a reset attempt.
///
/// Failed reads never reset the chip by their count while armed. Disarmed,
/// the first wrong or missing answer resets it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ResetPolicy {
    /// Re-checks in a row that must read wrong before the chip counts as
    /// reset (2: with the read that made it suspect, three wrong answers).
    pub confirm_rereads: u8,
    /// Re-checks in a row without any answer after which the chip is lost
    /// (20).
    pub lost_after_rechecks: u8,
    /// Shortest time between two re-checks, ms (5: a glitch that lasts a
    /// few ms cannot confirm a mismatch by itself).
    pub recheck_spacing_ms: u32,
}

impl Default for ResetPolicy {
    fn default() -> Self {
        Self {
            confirm_rereads: 2,
            lost_after_rechecks: 20,
            recheck_spacing_ms: 5,
        }
    }
}

/// What a re-check of a suspect chip concluded ([`ResetGate`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ResetVerdict {
    /// Not proven: check again when [`ResetGate::due`] says so.
    Recheck,
    /// Proven lost (or disarmed): reset the chip.
    Reset,
}

/// The [`ResetPolicy`]'s memory for one chip: whether a re-check is
/// pending and when, and how many re-checks in a row answered wrong or
/// not at all.
///
/// ```
/// use sensor_stack::health::{ResetGate, ResetPolicy, ResetVerdict};
/// let mut g = ResetGate::new(ResetPolicy::default());
/// g.suspect(0);
/// assert!(g.due(0));
/// assert_eq!(g.failed(0, true, true), ResetVerdict::Recheck);
/// assert!(!g.due(4) && g.due(5));
/// assert_eq!(g.failed(5, true, true), ResetVerdict::Reset); // wrong again
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ResetGate {
    policy: ResetPolicy,
    wrong: u8,
    silent: u8,
    next_ms: Option<u32>,
}

impl ResetGate {
    /// Nothing suspected.
    pub const fn new(policy: ResetPolicy) -> Self {
        Self {
            policy,
            wrong: 0,
            silent: 0,
            next_ms: None,
        }
    }

    /// Something (a failed read streak, a read-back mismatch, a bus
    /// recovery) makes the chip suspect: a re-check is due now unless one
    /// is already scheduled.
    pub fn suspect(&mut self, now_ms: u32) {
        self.next_ms.get_or_insert(now_ms);
    }

    /// `true` when a re-check is pending and its time has come.
    pub fn due(&self, now_ms: u32) -> bool {
        self.next_ms
            .is_some_and(|t| (now_ms.wrapping_sub(t) as i32) >= 0)
    }

    /// `true` while a re-check is pending.
    pub fn pending(&self) -> bool {
        self.next_ms.is_some()
    }

    /// `true` while the last re-check was answered wrong (the chip is
    /// there but not as configured: it reset itself).
    pub fn answered_wrong(&self) -> bool {
        self.wrong > 0
    }

    /// The re-check failed: `answered` if the chip answered wrong
    /// (configuration or WHO_AM_I), not if it answered nothing. Disarmed,
    /// or once the policy's count of such re-checks in a row is reached,
    /// [`ResetVerdict::Reset`] (and the gate is cleared); else another
    /// re-check is scheduled.
    pub fn failed(&mut self, now_ms: u32, armed: bool, answered: bool) -> ResetVerdict {
        let (n, limit) = if answered {
            self.silent = 0;
            self.wrong = self.wrong.saturating_add(1);
            (self.wrong, self.policy.confirm_rereads)
        } else {
            self.wrong = 0;
            self.silent = self.silent.saturating_add(1);
            (self.silent, self.policy.lost_after_rechecks)
        };
        if !armed || n >= limit {
            *self = Self::new(self.policy);
            return ResetVerdict::Reset;
        }
        self.next_ms = Some(now_ms.wrapping_add(self.policy.recheck_spacing_ms));
        ResetVerdict::Recheck
    }

    /// The re-check read everything right: the suspicion is dropped.
    pub fn right_answer(&mut self) {
        *self = Self::new(self.policy);
    }
}

/// `true` when every present (not `Missing`) sensor has failed at least
/// `bus_recovery_after_errors` transactions in a row: the bus itself is
/// stuck, not one chip. Returns `false` if no sensor is present.
pub fn needs_bus_recovery(sensors: &[&SensorHealth]) -> bool {
    let mut any = false;
    for s in sensors {
        if s.state == SensorState::Missing {
            continue;
        }
        any = true;
        if s.consecutive_errors < s.policy.bus_recovery_after_errors {
            return false;
        }
    }
    any
}

/// The two I2C lines driven by hand as open-drain GPIO during recovery.
/// "High" means released (pulled up by the resistors); "low" means driven.
pub trait RecoveryPins {
    /// Releases (`true`) or drives low (`false`) SCL.
    fn set_scl(&mut self, high: bool);
    /// Releases (`true`) or drives low (`false`) SDA.
    fn set_sda(&mut self, high: bool);
    /// Reads SCL.
    fn scl_is_high(&mut self) -> bool;
    /// Reads SDA.
    fn sda_is_high(&mut self) -> bool;
}

/// Outcome of a successful [`recover_bus`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RecoveryReport {
    /// SCL pulses it took for SDA to be released (0 if it was already
    /// free); nine pulses are always given.
    pub clocks: u8,
}

/// Why [`recover_bus`] could not free the bus (the log says it in words).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RecoveryError {
    /// SCL stays low even when released (short or a slave stretching forever).
    SclStuckLow,
    /// SDA still low after [`MAX_RECOVERY_CLOCKS`] pulses.
    SdaStuckLow,
    /// SDA did not follow the pin when driven low (a short to the supply
    /// or the pin is not in open-drain output mode).
    SdaNotDriven,
    /// SCL did not follow the pin when driven low.
    SclNotDriven,
}

#[cfg(feature = "defmt")]
impl defmt::Format for RecoveryError {
    fn format(&self, f: defmt::Formatter) {
        match self {
            Self::SclStuckLow => defmt::write!(
                f,
                "SCL stays low when released (a short, or a slave stretching it)"
            ),
            Self::SdaStuckLow => defmt::write!(
                f,
                "SDA still low after 16 SCL clocks (a short, or a slave holding it)"
            ),
            Self::SdaNotDriven => {
                defmt::write!(f, "SDA does not follow the pin (a short to the supply?)")
            }
            Self::SclNotDriven => {
                defmt::write!(f, "SCL does not follow the pin (a short to the supply?)")
            }
        }
    }
}

/// Upper bound on SCL pulses (9 suffice for a slave mid-byte; margin for a
/// slave that ACKs once more).
pub const MAX_RECOVERY_CLOCKS: u8 = 16;
/// SCL pulses that always complete a slave's byte and its acknowledge slot.
pub const FULL_BYTE_CLOCKS: u8 = 9;
/// Half period of the hand-made clock, µs (≈ 100 kHz).
pub const RECOVERY_HALF_PERIOD_US: u32 = 5;

/// Frees a stuck I2C bus (NXP UM10204 §3.1.16): with SDA released, clock SCL
/// at least [`FULL_BYTE_CLOCKS`] times and until the slave that holds SDA low
/// lets go (up to [`MAX_RECOVERY_CLOCKS`]), then generate a STOP (SDA low → high while SCL
/// is high). Leaves both lines released. The caller then re-creates the I2C
/// peripheral (the STM32F1 I2C cell needs a reset after such an event,
/// errata 2.13.7).
pub fn recover_bus<P: RecoveryPins, D: DelayNs>(
    pins: &mut P,
    delay: &mut D,
) -> Result<RecoveryReport, RecoveryError> {
    pins.set_sda(true);
    pins.set_scl(true);
    delay.delay_us(RECOVERY_HALF_PERIOD_US);
    // Allow clock stretching for a bounded time (~1 ms).
    let mut waited = 0u32;
    while !pins.scl_is_high() {
        if waited >= 200 {
            return Err(RecoveryError::SclStuckLow);
        }
        delay.delay_us(RECOVERY_HALF_PERIOD_US);
        waited = waited.saturating_add(1);
    }
    // Stopping at the first high SDA is not enough: a slave shifting out
    // a 1 bit releases SDA, and the STOP's SCL-low edge then moves it onto
    // its next bit, which may be a 0. Nine pulses with SDA released take any
    // slave through the rest of its byte and a NACK, wherever it was left.
    let mut released_after: Option<u8> = None;
    let mut pulses = 0u8;
    loop {
        if pins.sda_is_high() {
            released_after.get_or_insert(pulses);
            if pulses >= FULL_BYTE_CLOCKS {
                break;
            }
        }
        if pulses >= MAX_RECOVERY_CLOCKS {
            return Err(RecoveryError::SdaStuckLow);
        }
        pins.set_scl(false);
        delay.delay_us(RECOVERY_HALF_PERIOD_US);
        pins.set_scl(true);
        delay.delay_us(RECOVERY_HALF_PERIOD_US);
        pulses = pulses.saturating_add(1);
    }
    let clocks = released_after.unwrap_or(pulses);
    // STOP: SCL low, SDA low, SCL high, SDA high.
    pins.set_scl(false);
    delay.delay_us(RECOVERY_HALF_PERIOD_US);
    pins.set_sda(false);
    delay.delay_us(RECOVERY_HALF_PERIOD_US);
    pins.set_scl(true);
    delay.delay_us(RECOVERY_HALF_PERIOD_US);
    pins.set_sda(true);
    delay.delay_us(RECOVERY_HALF_PERIOD_US);
    if !pins.sda_is_high() {
        return Err(RecoveryError::SdaStuckLow);
    }
    Ok(RecoveryReport { clocks })
}

/// Unlocks the STM32F1 I2C cell's BUSY flag when its analog noise
/// filters latched a wrong level (errata ES096 2.13.7: BUSY stays set
/// although both lines are high, and neither SWRST nor a reset clears
/// it). Forces one transition through each filter and checks each level
/// on the input register, in the errata's order: both released and high;
/// SDA low; SCL low; SCL high; SDA high (a START then a STOP on the wire,
/// harmless to the slaves). With the pins as open-drain GPIO and the I2C
/// peripheral disabled; the caller then sets SWRST, clears it and
/// reprograms the peripheral.
pub fn unlock_busy_flag<P: RecoveryPins, D: DelayNs>(
    pins: &mut P,
    delay: &mut D,
) -> Result<(), RecoveryError> {
    pins.set_scl(true);
    pins.set_sda(true);
    delay.delay_us(RECOVERY_HALF_PERIOD_US);
    if !pins.scl_is_high() {
        return Err(RecoveryError::SclStuckLow);
    }
    if !pins.sda_is_high() {
        return Err(RecoveryError::SdaStuckLow);
    }
    pins.set_sda(false);
    delay.delay_us(RECOVERY_HALF_PERIOD_US);
    if pins.sda_is_high() {
        return Err(RecoveryError::SdaNotDriven);
    }
    pins.set_scl(false);
    delay.delay_us(RECOVERY_HALF_PERIOD_US);
    if pins.scl_is_high() {
        return Err(RecoveryError::SclNotDriven);
    }
    pins.set_scl(true);
    delay.delay_us(RECOVERY_HALF_PERIOD_US);
    if !pins.scl_is_high() {
        return Err(RecoveryError::SclStuckLow);
    }
    pins.set_sda(true);
    delay.delay_us(RECOVERY_HALF_PERIOD_US);
    if !pins.sda_is_high() {
        return Err(RecoveryError::SdaStuckLow);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn policy() -> HealthPolicy {
        HealthPolicy::default()
    }

    #[test]
    fn retries_are_bounded_and_counted() {
        let mut h = SensorHealth::new(policy());
        let mut calls = 0;
        let r: Result<(), u8> = h.with_retries(|| {
            calls += 1;
            Err(1)
        });
        assert_eq!(r, Err(1));
        assert_eq!(calls, 3);
        assert_eq!(h.counters().retries, 2);
        assert_eq!(h.counters().errors, 1);
        assert_eq!(h.state(), SensorState::Degraded);
        // A transient error is absorbed by a retry.
        let mut calls = 0;
        let r: Result<u8, u8> = h.with_retries(|| {
            calls += 1;
            if calls == 1 {
                Err(0)
            } else {
                Ok(5)
            }
        });
        assert_eq!(r, Ok(5));
        assert_eq!(h.state(), SensorState::Ok);
        assert_eq!(h.counters().retries, 3);
        assert_eq!(h.consecutive_errors(), 0);
    }

    #[test]
    fn reinit_after_consecutive_errors_then_fail() {
        let mut h = SensorHealth::new(policy());
        for _ in 0..4 {
            assert_eq!(h.error(), Action::None);
        }
        assert_eq!(h.error(), Action::Reinit);
        assert_eq!(h.pending_action(), Action::Reinit);
        for _ in 0..4 {
            assert_eq!(h.reinit_done(false), Action::None);
        }
        assert_eq!(h.reinit_done(false), Action::Disable);
        assert_eq!(h.state(), SensorState::Failed);
        assert!(!h.usable());
        assert_eq!(h.error(), Action::Disable);
        h.revive();
        assert_eq!(h.state(), SensorState::Degraded);
        assert_eq!(h.reinit_done(true), Action::None);
        assert_eq!(h.state(), SensorState::Ok);
        assert_eq!(h.counters().reinits, 6);
    }

    #[test]
    fn config_mismatch_requests_reinit() {
        let mut h = SensorHealth::new(policy());
        assert_eq!(h.config_mismatch(), Action::Reinit);
        assert_eq!(h.counters().resets_detected, 1);
        assert_eq!(h.state(), SensorState::Degraded);
        let mut m = SensorHealth::missing(policy());
        assert_eq!(m.config_mismatch(), Action::Disable);
    }

    #[test]
    fn armed_reset_needs_confirmed_wrong_answers_spaced_apart() {
        let mut g = ResetGate::new(ResetPolicy::default());
        assert!(!g.pending() && !g.due(0));
        g.suspect(100);
        g.suspect(150); // already scheduled: keeps its time
        assert!(g.due(100));
        // A glitch: one wrong re-read, then a right one.
        assert_eq!(g.failed(100, true, true), ResetVerdict::Recheck);
        assert!(!g.due(104) && g.due(105));
        g.right_answer();
        assert!(!g.pending());
        // A reset chip: wrong on both re-reads.
        g.suspect(200);
        assert_eq!(g.failed(200, true, true), ResetVerdict::Recheck);
        assert_eq!(g.failed(205, true, true), ResetVerdict::Reset);
        assert!(!g.pending(), "a verdict clears the gate");
        // A silent re-check between two wrong ones breaks the row.
        g.suspect(300);
        assert_eq!(g.failed(300, true, true), ResetVerdict::Recheck);
        assert_eq!(g.failed(305, true, false), ResetVerdict::Recheck);
        assert_eq!(g.failed(310, true, true), ResetVerdict::Recheck);
        // Disarmed: the first wrong or missing answer resets.
        g.suspect(400);
        assert_eq!(g.failed(400, false, true), ResetVerdict::Reset);
        g.suspect(400);
        assert_eq!(g.failed(400, false, false), ResetVerdict::Reset);
    }

    #[test]
    fn armed_reset_after_twenty_silent_rechecks_only() {
        let mut g = ResetGate::new(ResetPolicy::default());
        let t0 = u32::MAX - 10; // across the clock's wrap
        g.suspect(t0);
        let mut t = t0;
        for _ in 0..19 {
            assert!(g.due(t));
            assert_eq!(g.failed(t, true, false), ResetVerdict::Recheck);
            t = t.wrapping_add(5);
        }
        assert_eq!(g.failed(t, true, false), ResetVerdict::Reset);
        assert_eq!(t.wrapping_sub(t0), 95, "at least 100 ms with the first");
    }

    #[test]
    fn bus_recovery_only_when_all_present_fail() {
        let mut a = SensorHealth::new(policy());
        let mut b = SensorHealth::new(policy());
        let missing = SensorHealth::missing(policy());
        for _ in 0..3 {
            a.error();
        }
        assert!(!needs_bus_recovery(&[&a, &b, &missing]));
        for _ in 0..3 {
            b.error();
        }
        assert!(needs_bus_recovery(&[&a, &b, &missing]));
        b.success();
        assert!(!needs_bus_recovery(&[&a, &b, &missing]));
        assert!(!needs_bus_recovery(&[&missing]));
    }

    /// A bus with a slave that holds SDA low for `hold` more SCL falling edges.
    struct StuckSlave {
        scl: bool,
        sda_master: bool,
        hold: u8,
        scl_short: bool,
        log: [u8; 64],
        n: usize,
    }

    impl StuckSlave {
        fn new(hold: u8) -> Self {
            Self {
                scl: true,
                sda_master: true,
                hold,
                scl_short: false,
                log: [0; 64],
                n: 0,
            }
        }
        fn push(&mut self, e: u8) {
            if self.n < self.log.len() {
                self.log[self.n] = e;
                self.n += 1;
            }
        }
    }

    impl RecoveryPins for StuckSlave {
        fn set_scl(&mut self, high: bool) {
            if self.scl && !high && self.hold > 0 {
                self.hold -= 1; // slave shifts one bit per falling edge
            }
            self.scl = high;
            self.push(if high { b'C' } else { b'c' });
        }
        fn set_sda(&mut self, high: bool) {
            self.sda_master = high;
            self.push(if high { b'D' } else { b'd' });
        }
        fn scl_is_high(&mut self) -> bool {
            self.scl && !self.scl_short
        }
        fn sda_is_high(&mut self) -> bool {
            self.sda_master && self.hold == 0
        }
    }

    struct NoDelay;
    impl DelayNs for NoDelay {
        fn delay_ns(&mut self, _ns: u32) {}
    }

    #[test]
    fn recovery_clocks_until_sda_released_then_stop() {
        let mut bus = StuckSlave::new(7);
        assert_eq!(
            recover_bus(&mut bus, &mut NoDelay),
            Ok(RecoveryReport { clocks: 7 })
        );
        // Ends with a STOP: SCL low, SDA low, SCL high, SDA high.
        assert_eq!(&bus.log[bus.n - 4..bus.n], b"cdCD");
        assert!(bus.scl && bus.sda_master);
        let mut free = StuckSlave::new(0);
        assert_eq!(
            recover_bus(&mut free, &mut NoDelay),
            Ok(RecoveryReport { clocks: 0 })
        );
    }

    /// A slave left by a master reset in the middle of the byte it was
    /// sending: it drives the remaining bits (MSB first) on SDA, one per SCL
    /// falling edge, then releases SDA for the acknowledge slot and goes
    /// idle if the master did not acknowledge; it only ever sees the STOP
    /// once it is idle.
    struct MidByteSlave {
        scl: bool,
        sda_master: bool,
        bits: [bool; 8],
        next: usize,
        stop_seen: bool,
    }

    impl MidByteSlave {
        fn driving_low(&self) -> bool {
            self.bits.get(self.next).is_some_and(|b| !*b)
        }
    }

    impl RecoveryPins for MidByteSlave {
        fn set_scl(&mut self, high: bool) {
            if self.scl && !high && self.next < 9 {
                self.next += 1;
            }
            self.scl = high;
        }
        fn set_sda(&mut self, high: bool) {
            let sda_before = self.sda_master && !self.driving_low();
            self.sda_master = high;
            if self.scl && high && !sda_before && self.next >= 8 {
                self.stop_seen = true;
            }
        }
        fn scl_is_high(&mut self) -> bool {
            self.scl
        }
        fn sda_is_high(&mut self) -> bool {
            self.sda_master && !self.driving_low()
        }
    }

    #[test]
    fn recovery_takes_a_slave_through_its_whole_byte_before_the_stop() {
        // 0x5A = 0101_1010, left after its first bit: SDA reads 1 after one
        // clock, but the slave still has 0s to send.
        for start in 0..8 {
            let mut bus = MidByteSlave {
                scl: true,
                sda_master: true,
                bits: [false, true, false, true, true, false, true, false],
                next: start,
                stop_seen: false,
            };
            let r = recover_bus(&mut bus, &mut NoDelay);
            assert!(r.is_ok(), "left at bit {start}: {r:?}");
            assert!(bus.stop_seen, "left at bit {start}: the STOP reached it");
            assert!(bus.sda_is_high() && bus.scl_is_high());
        }
    }

    #[test]
    fn busy_unlock_follows_the_errata_order() {
        let mut bus = StuckSlave::new(0);
        assert_eq!(unlock_busy_flag(&mut bus, &mut NoDelay), Ok(()));
        // Release both, SDA low, SCL low, SCL high, SDA high (ES096 2.13.7).
        assert_eq!(&bus.log[..bus.n], b"CDdcCD");
        assert!(bus.scl && bus.sda_master);
        // A slave still holding SDA: refused before any edge is forced.
        let mut held = StuckSlave::new(3);
        assert_eq!(
            unlock_busy_flag(&mut held, &mut NoDelay),
            Err(RecoveryError::SdaStuckLow)
        );
        assert_eq!(&held.log[..held.n], b"CD");
        let mut short = StuckSlave::new(0);
        short.scl_short = true;
        assert_eq!(
            unlock_busy_flag(&mut short, &mut NoDelay),
            Err(RecoveryError::SclStuckLow)
        );
    }

    #[test]
    fn record_counts_one_attempt_without_retry() {
        let mut h = SensorHealth::new(policy());
        assert_eq!(h.record::<(), u8>(Err(3)), Err(3));
        assert_eq!(h.counters().errors, 1);
        assert_eq!(h.counters().retries, 0);
        assert_eq!(h.record::<u8, u8>(Ok(1)), Ok(1));
        assert_eq!(h.consecutive_errors(), 0);
    }

    #[test]
    fn recovery_gives_up_bounded() {
        let mut bus = StuckSlave::new(200);
        assert_eq!(
            recover_bus(&mut bus, &mut NoDelay),
            Err(RecoveryError::SdaStuckLow)
        );
        let mut short = StuckSlave::new(1);
        short.scl_short = true;
        assert_eq!(
            recover_bus(&mut short, &mut NoDelay),
            Err(RecoveryError::SclStuckLow)
        );
    }
}
