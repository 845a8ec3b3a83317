//! ESC outputs: TIM3 CH1–CH4 on PA6, PA7, PB0, PB1 (RM0008 §9.3.7, no
//! remap; clear of I2C1 on PB6/PB7), edge-aligned PWM mode 1 with the
//! compare registers preloaded so a new command starts with the next frame
//! and never cuts a pulse short. The pulse widths and the timer set-up come
//! from `control::esc::EscTimer`; this module only writes registers.
//!
//! The "off" pulse is on the pins from the first boot step after the clock
//! switch, before anything that can take time (sensor probing), and the
//! panic and HardFault paths write it again (`force_off`).
//!
//! At run time every task writes the outputs through [`GuardedOutputs`]:
//! the flight controller's motors after each sample step, and the off
//! pulse `flight::outputguard` forces from the receiver's task (the arm
//! switch off) and from the periodic guard task (no sample step for
//! 50 ms), whatever the IMU does. The rules, their bounds and the
//! watchdog's are in `flight::outputguard`.

use control::esc::EscTimer;
use core::sync::atomic::{AtomicU16, Ordering};
use flight::flightctl::Motors;
use flight::outputguard::{ForceOffReason, OutputGuard, OutputVerdict, TickAction};
use stm32f1xx_hal::pac;

/// Compare value of the off pulse, published for the fault paths (0: the
/// outputs were never started).
static OFF_COMPARE: AtomicU16 = AtomicU16::new(0);

/// The four ESC channels, in motor order 1–4.
pub struct EscOutputs {
    tim: pac::TIM3,
    timer: EscTimer,
}

impl EscOutputs {
    /// Clocks TIM3, puts the off pulse on all four channels, starts the
    /// counter and hands the pins to the timer (pins switch last, so the
    /// first edge on them is the start of an off pulse).
    pub fn start(tim: pac::TIM3, timer: EscTimer) -> Self {
        // SAFETY: RCC APB1ENR/APB2ENR read-modify-writes in init, before
        // any task runs; the HAL's `Rcc` is not used for these bits.
        #[allow(unsafe_code)]
        let rcc = unsafe { &*pac::RCC::ptr() };
        rcc.apb1enr().modify(|_, w| w.tim3en().set_bit());
        rcc.apb2enr()
            .modify(|_, w| w.iopaen().set_bit().iopben().set_bit());
        let off = timer.off_compare();
        tim.psc().write(|w| w.psc().set(timer.prescaler()));
        tim.arr().write(|w| w.arr().set(timer.auto_reload()));
        for ch in 0..4 {
            tim.ccr(ch).write(|w| w.ccr().set(off));
        }
        // OCxM = 110 (PWM mode 1), OCxPE = 1, CCxS = 00 (output).
        const PWM1_PRELOAD: u32 = 0x68;
        let ccmr = PWM1_PRELOAD | (PWM1_PRELOAD << 8);
        // SAFETY: CCMR1/2 output-compare layout, value from RM0008 §15.4.7.
        #[allow(unsafe_code)]
        unsafe {
            tim.ccmr1_output().write(|w| w.bits(ccmr));
            tim.ccmr2_output().write(|w| w.bits(ccmr));
            // CC1E..CC4E, active high.
            tim.ccer().write(|w| w.bits(0x1111));
        }
        // UG loads PSC, ARR and CCRx into their shadows before counting.
        tim.egr().write(|w| w.ug().set_bit());
        tim.cr1().write(|w| w.arpe().set_bit().cen().set_bit());
        OFF_COMPARE.store(off, Ordering::Relaxed);
        pins_to_timer();
        Self { tim, timer }
    }

    /// The timer set-up in use.
    pub fn timer(&self) -> &EscTimer {
        &self.timer
    }

    /// Writes four compare values (from the next frame on).
    pub fn write(&mut self, compare: [u16; 4]) {
        for (ch, c) in compare.into_iter().enumerate() {
            self.tim.ccr(ch).write(|w| w.ccr().set(c));
        }
    }

    /// Even thrust: every channel at the mean of the four compare values
    /// in use (the quad-X mixer's torques cancel in it; the pulse width is
    /// linear in the command).
    pub fn level(&mut self) {
        let sum: u32 = (0..4)
            .map(|ch| u32::from(self.tim.ccr(ch).read().ccr().bits()))
            .sum();
        self.write([(sum / 4) as u16; 4]);
    }

    /// The off pulse on all four channels.
    pub fn off(&mut self) {
        self.write([self.timer.off_compare(); 4]);
    }

    /// The flight controller's motors: mixer motor index `i` on channel
    /// `i + 1` (`Motors::Off`: the off pulse).
    pub fn set(&mut self, motors: &Motors) {
        match motors {
            Motors::Off => self.off(),
            Motors::Run(_) => self.write(motors.compares(&self.timer)),
        }
    }
}

/// The ESC outputs behind the output guard: the one resource through
/// which the tasks write them.
pub struct GuardedOutputs {
    esc: EscOutputs,
    guard: OutputGuard,
}

impl GuardedOutputs {
    /// The started outputs (at the off pulse), guarded from `now_us`.
    pub fn new(esc: EscOutputs, now_us: u32) -> Self {
        Self {
            esc,
            guard: OutputGuard::new(now_us),
        }
    }

    /// Start of a sample step: the reason the outputs were forced off, if
    /// the flight controller still has to be disarmed for it.
    pub fn take_forced(&mut self) -> Option<ForceOffReason> {
        self.guard.take_forced()
    }

    /// End of a sample step at `now_us`: the controller's motors, or the
    /// off pulse while the guard holds them off.
    pub fn on_step(&mut self, now_us: u32, armed: bool, motors: &Motors) {
        let run = matches!(motors, Motors::Run(_));
        match self.guard.on_step(now_us, armed, run) {
            OutputVerdict::Run => self.esc.set(motors),
            OutputVerdict::ForceOff(_) => self.esc.off(),
        }
    }

    /// A receiver frame's arm switch and link state: the off pulse at once
    /// if the guard says so (its reason returned, to log).
    pub fn on_pilot(&mut self, arm_switch: bool, link_ok: bool) -> Option<ForceOffReason> {
        let r = self.guard.on_pilot(arm_switch, link_ok);
        if r.is_some() {
            self.esc.off();
        }
        r
    }

    /// The periodic check at `now_us`: even thrust while an MPU reset is
    /// bridged, the off pulse if no sample step came for too long while
    /// the outputs ran (the action returned, to log).
    pub fn on_tick(&mut self, now_us: u32) -> Option<TickAction> {
        let a = self.guard.on_tick(now_us);
        match a {
            Some(TickAction::Level) => self.esc.level(),
            Some(TickAction::ForceOff(_)) => self.esc.off(),
            None => {}
        }
        a
    }

    /// The sensor stack's word on the MPU's re-initialisation
    /// (`flight::outputguard`); returns the µs since the last sample step.
    pub fn set_mpu_recovering(&mut self, recovering: bool, now_us: u32) -> u32 {
        self.guard.set_mpu_recovering(recovering);
        self.guard.since_step_us(now_us)
    }

    /// Whether the watchdog may be fed (`flight::outputguard`).
    pub fn may_feed_watchdog(&self, now_us: u32, mpu_in_loop: bool) -> bool {
        self.guard.may_feed_watchdog(now_us, mpu_in_loop)
    }
}

/// PA6/PA7 (CRL nibbles 6, 7) and PB0/PB1 (CRL nibbles 0, 1): alternate
/// function push-pull, 2 MHz (an ESC signal edge needs no more; slower
/// edges radiate less into the receiver).
fn pins_to_timer() {
    const AF_PP_2MHZ: u32 = 0b1010;
    // SAFETY: read-modify-write of the four pins' nibbles in init, before
    // any task runs; no other code owns these pins.
    #[allow(unsafe_code)]
    unsafe {
        let gpioa = &*pac::GPIOA::ptr();
        gpioa.crl().modify(|r, w| {
            w.bits((r.bits() & 0x00FF_FFFF) | (AF_PP_2MHZ << 24) | (AF_PP_2MHZ << 28))
        });
        let gpiob = &*pac::GPIOB::ptr();
        gpiob
            .crl()
            .modify(|r, w| w.bits((r.bits() & 0xFFFF_FF00) | AF_PP_2MHZ | (AF_PP_2MHZ << 4)));
    }
}

/// Fault paths (panic, HardFault): the off pulse on all four channels.
///
/// Writes the off compare value rather than stopping the timer: an ESC
/// that stops seeing pulses reacts after its own signal-loss timeout, and
/// some hold the last throttle until then; the off pulse is the one input
/// every ESC obeys within a frame, and the pins stay driven instead of
/// floating. (The preload means the pulse in flight finishes first: at
/// most one more frame, 2.5 ms at 400 Hz.) Nothing is written if the
/// outputs were never started: then the pins are still inputs.
pub fn force_off() {
    let off = OFF_COMPARE.load(Ordering::Relaxed);
    if off == 0 {
        return;
    }
    // SAFETY: only the CCR registers of a timer `start` configured; on a
    // fault path nothing else runs any more.
    #[allow(unsafe_code)]
    let tim = unsafe { &*pac::TIM3::ptr() };
    for ch in 0..4 {
        tim.ccr(ch).write(|w| w.ccr().set(off));
    }
}
