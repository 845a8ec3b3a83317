//! An armed craft and its MPU-9250's troubles, on the simulated bus: the
//! sensor stack (`sensor_stack::sensors`, told the craft is armed as the
//! firmware tells it) and the flight controller (`flight::flightctl`, fed
//! a non-finite gyro for every lost sample, as the firmware's
//! `vehicle_state` does), stepped on every MPU data-ready; a maintenance
//! step every 10 ms (the `service` task's longest period) and the
//! configuration check every 50 ms.
//!
//! Faults: a 30-sample NACK burst, a read-back glitch, a spontaneous chip
//! reset and a chip that stops answering; the first and the third also
//! under the policy before the stack knew about arming, which disarmed.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::cell::Cell;
use std::rc::Rc;

use control::levelq::QuatQ30;
use e2e::Rig;
use embedded_hal::i2c::{ErrorType, I2c, Operation};
use flight::flightctl::{
    DisarmCause, Event, FlightConfig, FlightController, Motors, PilotInput, SystemStatus,
    VehicleState,
};
use sensor_stack::sensors::{Maintenance, Sensors, SensorsConfig};
use sim::{Chip, Fault, SimBus, SimConfig};

const MPU: u8 = 0x68;
const SERVICE_PERIOD_MS: u64 = 10;
const CHECK_PERIOD_MS: u64 = 50;

/// The simulated bus with a read-back glitch: the next `corrupt` reads
/// of the MPU-9250's SMPLRT_DIV block come back with a flipped bit.
#[derive(Clone)]
struct GlitchBus {
    bus: SimBus,
    corrupt: Rc<Cell<u32>>,
}

impl ErrorType for GlitchBus {
    type Error = <SimBus as ErrorType>::Error;
}

impl I2c for GlitchBus {
    fn transaction(&mut self, address: u8, ops: &mut [Operation<'_>]) -> Result<(), Self::Error> {
        let config_read = address == MPU
            && matches!(ops.first(), Some(Operation::Write(w)) if w.first() == Some(&0x19));
        self.bus.transaction(address, ops)?;
        if config_read && self.corrupt.get() > 0 {
            self.corrupt.set(self.corrupt.get() - 1);
            if let Some(Operation::Read(r)) = ops.last_mut() {
                if let Some(b) = r.first_mut() {
                    *b ^= 0x04;
                }
            }
        }
        Ok(())
    }
}

struct Flight {
    rig: Rig,
    s: Sensors<GlitchBus>,
    corrupt: Rc<Cell<u32>>,
    fc: FlightController,
    pilot: PilotInput,
    next_service_ms: u64,
    next_check_ms: u64,
    /// Every non-idle maintenance step: (ms, step, simulated ms it held the bus).
    steps: Vec<(u64, Maintenance, f64)>,
    events: Vec<(u64, Event)>,
    /// Flight-controller steps that left the motors off.
    motors_off: u32,
    lost_samples: u32,
    /// Longest simulated bus time of one configuration check, ms.
    longest_check_ms: f64,
    /// The stack is told whether the craft is armed.
    armed_aware: bool,
    /// Time of the last flight-controller step, ms.
    last_step_ms: u64,
}

fn config(armed_aware: bool) -> FlightConfig {
    let mut c = FlightConfig::default();
    if !armed_aware {
        c.safety.bad_input_disarm_s = 0.1;
    }
    c
}

fn now_ms(rig: &Rig) -> u64 {
    rig.clock.now_ns() / 1_000_000
}

impl Flight {
    /// Boots the board and arms the flight controller at half throttle.
    fn armed() -> Self {
        Self::armed_with(true)
    }

    /// As [`armed`](Self::armed); `armed_aware: false` is the policy before
    /// the sensor stack knew about arming: the stack is never told, and the
    /// flight controller disarms after 0.1 s without a usable gyro.
    fn armed_with(armed_aware: bool) -> Self {
        let mut rig = Rig::new(SimConfig::default());
        let corrupt = Rc::new(Cell::new(0));
        let bus = GlitchBus {
            bus: rig.bus.clone(),
            corrupt: corrupt.clone(),
        };
        let (s, _) = Sensors::boot(
            bus.clone(),
            bus.clone(),
            bus,
            &mut rig.delay,
            SensorsConfig::default(),
        );
        let t = now_ms(&rig);
        let mut f = Self {
            rig,
            s,
            corrupt,
            fc: FlightController::new(config(armed_aware)).unwrap(),
            armed_aware,
            pilot: PilotInput {
                link_ok: true,
                ..Default::default()
            },
            next_service_ms: t,
            next_check_ms: t,
            steps: Vec::new(),
            events: Vec::new(),
            motors_off: 0,
            lost_samples: 0,
            longest_check_ms: 0.0,
            last_step_ms: t,
        };
        f.run(20);
        f.pilot.arm_switch = true;
        f.run(20);
        assert!(f.fc.is_armed(), "{:?}", f.events);
        f.pilot.sticks.throttle = 0.5;
        f.run(100);
        f.motors_off = 0;
        f.lost_samples = 0;
        f.steps.clear();
        f
    }

    /// Runs `ms` of simulated time: a flight-controller step on every MPU
    /// data-ready (none while it is silent: its INT is what clocks the
    /// loop), the service task's rounds.
    fn run(&mut self, ms: u64) {
        let end = now_ms(&self.rig) + ms;
        while now_ms(&self.rig) < end {
            let before = self.rig.clock.now_ns();
            self.rig.bus.advance_to_next_mpu_sample();
            let sampled =
                self.rig.clock.now_ns() > before && self.rig.clock.now_ns() - before <= 1_100_000;
            if !sampled {
                self.rig.clock.advance_to_ns(before + 1_000_000);
            } else if self.rig.bus.data_ready() {
                self.fly();
            }
            self.service();
        }
    }

    fn fly(&mut self) {
        let fresh = self.s.read_imu().is_some();
        if !fresh {
            self.lost_samples += 1;
        }
        let now_us = self.rig.clock.now_us() as u32;
        let vehicle = VehicleState {
            attitude_q30: QuatQ30::IDENTITY,
            gyro_rps_q16: fresh.then_some([0; 3]),
            altitude: None,
        };
        let status = SystemStatus {
            sensors_healthy: true,
            gyro_bias_done: true,
            calibration_running: false,
            accel_calibrated: true,
        };
        let out = self.fc.step(now_us, &self.pilot, &status, &vehicle);
        let t = now_ms(&self.rig);
        self.last_step_ms = t;
        self.events.extend(out.events.iter().map(|e| (t, e)));
        if out.motors == Motors::Off {
            self.motors_off += 1;
        }
        self.s.set_armed(self.armed_aware && self.fc.is_armed());
    }

    fn service(&mut self) {
        let t = now_ms(&self.rig);
        if t < self.next_service_ms {
            return;
        }
        self.next_service_ms = t + SERVICE_PERIOD_MS;
        // As the firmware's service task: told every round whether the
        // craft is armed, and how long the samples have been away.
        if self.armed_aware {
            self.s.set_armed(self.fc.is_armed());
            self.s
                .mpu_sample_gap(((t - self.last_step_ms) * 1_000) as u32);
        }
        if t >= self.next_check_ms {
            self.next_check_ms = t + CHECK_PERIOD_MS;
            let t0 = self.rig.clock.now_ns();
            self.s.check_configs();
            let held_ms = (self.rig.clock.now_ns() - t0) as f64 * 1e-6;
            self.longest_check_ms = self.longest_check_ms.max(held_ms);
        }
        let t0 = self.rig.clock.now_ns();
        let step = self.s.maintain(t as u32, &mut self.rig.delay);
        let held_ms = (self.rig.clock.now_ns() - t0) as f64 * 1e-6;
        assert_ne!(step, Maintenance::RecoverBus, "no stuck bus here");
        if step != Maintenance::Idle {
            self.steps.push((t, step, held_ms));
        }
    }

    fn disarms(&self) -> Vec<(u64, Event)> {
        self.events
            .iter()
            .filter(|(_, e)| matches!(e, Event::Disarmed(_)))
            .copied()
            .collect()
    }
}

#[test]
fn a_nack_burst_while_armed_resets_nothing_and_is_flown_through() {
    let mut f = Flight::armed();
    // 30 lost samples in a row, six times the disarmed re-init threshold.
    f.rig.bus.inject(Fault::Nack {
        address: MPU,
        transactions: Some(30),
    });
    f.run(500);
    assert!(f.lost_samples >= 25, "{}", f.lost_samples);
    assert_eq!(f.s.mpu_health.counters().reinits, 0, "{:?}", f.steps);
    assert!(f.fc.is_armed(), "{:?}", f.disarms());
    assert_eq!(f.motors_off, 0);
    // It was re-checked and kept.
    assert!(
        f.steps
            .iter()
            .any(|(_, m, _)| *m == Maintenance::Settled { ok: true }),
        "{:?}",
        f.steps
    );

    // The same burst disarmed: the chip is re-initialised as before.
    f.pilot.arm_switch = false;
    f.run(10);
    assert!(!f.fc.is_armed());
    f.rig.bus.inject(Fault::Nack {
        address: MPU,
        transactions: Some(30),
    });
    f.run(300);
    assert!(f.s.mpu_health.counters().reinits >= 1, "{:?}", f.steps);
}

#[test]
fn a_read_back_glitch_is_re_read_and_resets_nothing() {
    let mut f = Flight::armed();
    f.corrupt.set(1);
    f.run(300);
    assert_eq!(f.corrupt.get(), 0, "the glitch was read");
    assert_eq!(f.s.mpu_health.counters().reinits, 0, "{:?}", f.steps);
    assert_eq!(f.s.mpu_health.counters().resets_detected, 0);
    assert!(f
        .steps
        .iter()
        .any(|(_, m, _)| *m == Maintenance::Settled { ok: true }));
    assert_eq!(f.lost_samples, 0);
    assert!(f.fc.is_armed());
    // Two glitches in a row are still not three wrong answers.
    f.corrupt.set(2);
    f.run(300);
    assert_eq!(f.s.mpu_health.counters().reinits, 0, "{:?}", f.steps);
}

#[test]
fn a_chip_reset_in_flight_is_confirmed_then_reset_stepwise_without_a_disarm() {
    let mut f = Flight::armed();
    let t_fault = now_ms(&f.rig);
    f.rig.bus.inject(Fault::ChipReset(Chip::Mpu9250));
    f.run(600);
    let c = f.s.mpu_health.counters();
    assert_eq!(c.resets_detected, 1, "{:?}", f.steps);
    assert_eq!(c.reinits, 1, "{:?}", f.steps);
    assert!(f.fc.is_armed(), "{:?} {:?}", f.disarms(), f.steps);
    assert_eq!(f.motors_off, 0);
    // Confirmed by two re-checks after the read-back that found it.
    let checks = f
        .steps
        .iter()
        .filter(|(_, m, _)| *m == Maintenance::Settled { ok: false })
        .count();
    assert_eq!(checks, 2, "{:?}", f.steps);
    // Every step of the MPU's re-initialisation and check holds the bus
    // for less than one 1 kHz sample period (simulated bus time).
    for (t, m, held_ms) in &f.steps {
        assert!(*held_ms < 1.0, "{m:?} at {t} ms held {held_ms} ms");
    }
    assert!(f.longest_check_ms < 1.0, "{} ms", f.longest_check_ms);
    let longest = f.steps.iter().map(|s| s.2).fold(0.0, f64::max);
    println!(
        "longest MPU step {longest:.3} ms, configuration check {:.3} ms",
        f.longest_check_ms
    );
    let done = f
        .steps
        .iter()
        .find(|(_, m, _)| matches!(m, Maintenance::Reinitialised { ok: true, .. }))
        .map(|(t, _, _)| *t)
        .unwrap();
    println!("re-initialised {} ms after the reset", done - t_fault);
    // Samples away 10 ms: suspect; two wrong re-checks 5 ms apart on
    // the 10 ms service rounds; the reset and its configuration writes.
    assert!(done - t_fault <= 60, "{} ms", done - t_fault);
    // The samples flow again after the settle; the bridge covered the
    // loss: the flight controller steps on the INT line, which is silent
    // from the reset until the configuration is written again, then runs
    // through the 100 ms settle without samples.
    assert!((100..=110).contains(&f.lost_samples), "{}", f.lost_samples);
    assert!(f.events.iter().any(|(_, e)| *e == Event::InputRejected));
    let lost = f.lost_samples;
    f.run(100);
    assert_eq!(f.lost_samples, lost);
}

#[test]
fn a_silent_chip_is_reset_only_after_the_stated_time_and_the_bridge_ends() {
    let mut f = Flight::armed();
    let t_fault = now_ms(&f.rig);
    f.rig.bus.inject(Fault::Nack {
        address: MPU,
        transactions: None,
    });
    f.run(400);
    let first_reset = f
        .steps
        .iter()
        .find(|(_, m, _)| matches!(m, Maintenance::Reinitialised { .. }))
        .map(|(t, _, _)| *t)
        .unwrap_or_else(|| panic!("{:?}", f.steps));
    assert!(
        first_reset - t_fault >= 100,
        "reset attempted {} ms after the chip went silent",
        first_reset - t_fault
    );
    // No gyro for the bridge time: disarmed for a sensor fault at 0.25 s.
    let d = f.disarms();
    assert_eq!(d.len(), 1, "{d:?}");
    assert_eq!(d[0].1, Event::Disarmed(DisarmCause::SensorFault));
    let after = d[0].0 - t_fault;
    assert!((249..=252).contains(&after), "{after} ms");
}

#[test]
fn the_policy_before_disarmed_on_the_same_faults() {
    // A chip reset: found, reset at once, 0.1 s without a gyro.
    let mut f = Flight::armed_with(false);
    f.rig.bus.inject(Fault::ChipReset(Chip::Mpu9250));
    f.run(600);
    let d = f.disarms();
    assert_eq!(
        d.first().map(|e| e.1),
        Some(Event::Disarmed(DisarmCause::SensorFault)),
        "{d:?}"
    );
    // Five NACKs in a row: a reset and its settle.
    let mut f = Flight::armed_with(false);
    f.rig.bus.inject(Fault::Nack {
        address: MPU,
        transactions: Some(30),
    });
    f.run(600);
    assert!(f.s.mpu_health.counters().reinits >= 1);
    let d = f.disarms();
    assert_eq!(
        d.first().map(|e| e.1),
        Some(Event::Disarmed(DisarmCause::SensorFault)),
        "{d:?}"
    );
}

#[test]
fn a_reset_asked_for_just_before_arming_waits_for_the_proof() {
    let mut rig = Rig::new(SimConfig::default());
    let (mut s, _) = e2e::boot_sensors(&mut rig);
    rig.bus.inject(Fault::Nack {
        address: MPU,
        transactions: Some(5),
    });
    for _ in 0..5 {
        rig.bus.advance_to_next_mpu_sample();
        assert!(s.read_imu().is_none());
    }
    assert!(
        s.service_due(),
        "disarmed, five failed reads ask for a reset"
    );
    s.set_armed(true);
    let step = s.maintain(now_ms(&rig) as u32, &mut rig.delay);
    assert_eq!(step, Maintenance::Settled { ok: true });
    assert_eq!(s.mpu_health.counters().reinits, 0);
    rig.bus.advance_to_next_mpu_sample();
    assert!(s.read_imu().is_some());
}
