//! The firmware's bus-fault handling (`sensor_stack::sensors` maintenance,
//! `sensor_stack::health` recovery) against the simulated bus, driven the way
//! the RTIC app drives it: one IMU read per MPU data-ready, one
//! maintenance step every 10 ms (the `service` task), a bus recovery
//! through the open-drain pin model when a step asks for one.
//!
//! Faults: SDA held low at power-up and in flight, a chip absent at boot
//! and plugged in later, and a NACK storm.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use e2e::{Rig, StuckSda};
use sensor_stack::boot::{AhrsMode, BootReport, Chip, ProbeFailure};
use sensor_stack::health::{recover_bus, unlock_busy_flag, SensorState};
use sensor_stack::sensors::{Maintenance, Sensors};
use sim::{Fault, SimBus, SimConfig};

const MPU: u8 = 0x68;
const MS: u8 = 0x77;

/// Period of the firmware's service task (its longest wait between rounds).
const SERVICE_PERIOD_MS: u64 = 10;

fn boot(rig: &mut Rig) -> (Sensors<SimBus>, BootReport) {
    e2e::boot_sensors(rig)
}

/// What happened over a stretch of simulated time.
#[derive(Default, Debug)]
struct Log {
    /// (simulated ms at the start of the step, step) for every non-idle
    /// maintenance step.
    steps: Vec<(u64, Maintenance)>,
    samples_ok: u32,
    samples_failed: u32,
    /// Longest simulated time one maintenance step held the bus, ms.
    longest_step_ms: f64,
    /// SCL clocks of the last recovery.
    clocks: u8,
}

impl Log {
    fn first(&self, pred: impl Fn(&Maintenance) -> bool) -> Option<u64> {
        self.steps.iter().find(|(_, m)| pred(m)).map(|(t, _)| *t)
    }
    fn count(&self, pred: impl Fn(&Maintenance) -> bool) -> usize {
        self.steps.iter().filter(|(_, m)| pred(m)).count()
    }
}

fn now_ms(rig: &Rig) -> u64 {
    rig.clock.now_ns() / 1_000_000
}

/// Runs the board for `ms` of simulated time: the IMU read on each MPU
/// sample (or every ms if the MPU is silent) with the magnetometer on
/// every 10th, the barometer schedule and a maintenance step every
/// [`SERVICE_PERIOD_MS`]. A recovery frees a slave that holds SDA for
/// `hold` clocks.
fn run(rig: &mut Rig, s: &mut Sensors<SimBus>, ms: u64, hold: u8, log: &mut Log) {
    let end = now_ms(rig) + ms;
    let mut next_service = now_ms(rig);
    let mut n = 0u32;
    while now_ms(rig) < end {
        n += 1;
        let before = rig.clock.now_ns();
        rig.bus.advance_to_next_mpu_sample();
        if rig.clock.now_ns() == before || rig.clock.now_ns() - before > 1_100_000 {
            // The MPU is not sampling (missing or in reset): 1 ms ticks.
            rig.clock.advance_to_ns(before + 1_000_000);
        }
        match s.read_sample(n.is_multiple_of(10)).0 {
            Some(_) => log.samples_ok += 1,
            None => log.samples_failed += 1,
        }
        if now_ms(rig) >= next_service {
            next_service = now_ms(rig) + SERVICE_PERIOD_MS;
            s.poll_baro(rig.clock.now_us() as u32);
            let t0 = rig.clock.now_ns();
            let step = s.maintain(now_ms(rig) as u32, &mut rig.delay);
            let held = (rig.clock.now_ns() - t0) as f64 * 1e-6;
            log.longest_step_ms = log.longest_step_ms.max(held);
            if step == Maintenance::RecoverBus {
                let mut pins = StuckSda::new(&rig.bus, hold);
                let r = recover_bus(&mut pins, &mut rig.delay)
                    .and_then(|r| unlock_busy_flag(&mut pins, &mut rig.delay).map(|()| r));
                match r {
                    Ok(r) => {
                        log.clocks = r.clocks;
                        s.after_bus_recovery();
                    }
                    Err(_) => s.bus_recovery_failed(now_ms(rig) as u32),
                }
            }
            if step != Maintenance::Idle {
                log.steps.push((t0 / 1_000_000, step));
            }
        }
    }
}

#[test]
fn stuck_sda_at_power_up_is_freed_before_the_first_probe() {
    // A reset in the middle of a read: the slave still drives SDA low.
    let mut rig = Rig::new(SimConfig::default());
    rig.bus.inject(Fault::StuckBus);
    // The firmware's boot step: recovery unconditionally, then probing.
    let mut pins = StuckSda::new(&rig.bus, 7);
    let r = recover_bus(&mut pins, &mut rig.delay).unwrap();
    unlock_busy_flag(&mut pins, &mut rig.delay).unwrap();
    assert_eq!(r.clocks, 7);
    assert!(pins.stop_seen);
    let (s, report) = boot(&mut rig);
    assert!(report.failures().next().is_none(), "{report:?}");
    assert_eq!(s.capabilities().ahrs, AhrsMode::Marg);
    assert!(s.capabilities().altitude);
}

#[test]
fn stuck_sda_at_power_up_without_recovery_is_caught_by_the_re_probe() {
    let mut rig = Rig::new(SimConfig::default());
    rig.bus.inject(Fault::StuckBus);
    let (mut s, report) = boot(&mut rig);
    // Everything looks missing...
    assert_eq!(report.mpu.status, Err(ProbeFailure::NoResponse));
    assert_eq!(report.mag.status, Err(ProbeFailure::DependencyMissing));
    assert_eq!(report.baro.status, Err(ProbeFailure::NoResponse));
    assert_eq!(s.capabilities().ahrs, AhrsMode::None);
    // ...so the first re-probe (1 s) frees the bus first, then finds them.
    let mut log = Log::default();
    let t0 = now_ms(&rig);
    run(&mut rig, &mut s, 3_000, 9, &mut log);
    let rec = log.first(|m| *m == Maintenance::RecoverBus).unwrap();
    assert!(
        (t0 + 1_000..=t0 + 1_020).contains(&rec),
        "recovery at {rec}"
    );
    assert_eq!(log.clocks, 9);
    let mpu = log
        .first(|m| *m == Maintenance::Appeared(Chip::Mpu9250))
        .unwrap();
    let baro = log
        .first(|m| *m == Maintenance::Appeared(Chip::Ms5611))
        .unwrap();
    let mag = log
        .first(|m| *m == Maintenance::Appeared(Chip::Ak8963))
        .unwrap();
    assert!(mpu > rec && baro > rec, "{:?}", log.steps);
    // The AK8963 sits behind the MPU's bypass: only after the MPU settled.
    let settled = log
        .first(|m| *m == Maintenance::Settled { ok: true })
        .unwrap();
    assert!(settled >= mpu + 100 && mag > settled, "{:?}", log.steps);
    assert_eq!(log.count(|m| *m == Maintenance::RecoverBus), 1);
    assert_eq!(s.capabilities().ahrs, AhrsMode::Marg);
    assert!(s.capabilities().altitude);
    assert_eq!(s.mpu_health.state(), SensorState::Ok);
    // Samples flow again.
    let ok_before = log.samples_ok;
    run(&mut rig, &mut s, 200, 0, &mut log);
    assert!(log.samples_ok - ok_before >= 195, "{log:?}");
}

#[test]
fn stuck_sda_in_flight_is_recovered_within_the_service_period() {
    let mut rig = Rig::new(SimConfig::default());
    let (mut s, _) = boot(&mut rig);
    let mut log = Log::default();
    run(&mut rig, &mut s, 200, 0, &mut log);
    assert_eq!(log.samples_failed, 0);

    // Detected by the health policy alone: every chip fails in a row.
    rig.bus.inject(Fault::StuckBus);
    let t_fault = now_ms(&rig);
    let mut log = Log::default();
    run(&mut rig, &mut s, 500, 8, &mut log);
    // Every present chip must fail 3 times in a row; the magnetometer is
    // read every 10 ms, so ≤ 30 ms + one service period. (On the board the
    // I2C peripheral's BUSY flag triggers it sooner: below.)
    let rec = log.first(|m| *m == Maintenance::RecoverBus).unwrap();
    assert!(
        rec - t_fault <= 3 * 10 + SERVICE_PERIOD_MS,
        "{} ms",
        rec - t_fault
    );
    assert_eq!(log.clocks, 8);
    // Then one chip per step: MPU, its post-reset check 100 ms later, the
    // AK8963 and the MS5611.
    let mpu = log
        .first(|m| {
            *m == Maintenance::Reinitialised {
                chip: Chip::Mpu9250,
                ok: true,
            }
        })
        .unwrap_or_else(|| panic!("{:?}", log.steps));
    let settled = log
        .first(|m| *m == Maintenance::Settled { ok: true })
        .unwrap();
    assert!(settled >= mpu + 100, "{:?}", log.steps);
    assert!(log
        .first(|m| *m
            == Maintenance::Reinitialised {
                chip: Chip::Ak8963,
                ok: true
            })
        .is_some());
    assert!(log
        .first(|m| *m
            == Maintenance::Reinitialised {
                chip: Chip::Ms5611,
                ok: true
            })
        .is_some());
    // Samples were skipped only from the fault to the end of the MPU's
    // settling: ≈ 3 service periods + the re-init's three steps (one per
    // service period) + 100 ms, some ms counted twice by this loop.
    assert!(log.samples_failed <= 300, "{log:?}");
    assert_eq!(s.bus_recoveries(), 1);
    assert_eq!(s.mpu_health.counters().retries, 0);
    // One maintenance step never holds the bus for long: the MPU's steps
    // never wait; the MS5611's reset waits 2.8 ms.
    assert!(log.longest_step_ms < 5.0, "{} ms", log.longest_step_ms);

    // Detected by the I2C peripheral (BUSY while idle): the very next step.
    rig.bus.inject(Fault::StuckBus);
    s.request_bus_recovery();
    assert_eq!(
        s.maintain(now_ms(&rig) as u32, &mut rig.delay),
        Maintenance::RecoverBus
    );
}

#[test]
fn chip_absent_at_boot_is_re_probed_with_back_off_and_used_when_it_appears() {
    let mut rig = Rig::new(SimConfig::default());
    rig.bus.inject(Fault::Nack {
        address: MS,
        transactions: None,
    });
    let (mut s, report) = boot(&mut rig);
    assert_eq!(report.baro.status, Err(ProbeFailure::NoResponse));
    assert!(!s.capabilities().altitude);
    let t0 = now_ms(&rig);
    let mut log = Log::default();
    run(&mut rig, &mut s, 8_000, 0, &mut log);
    let misses: Vec<(u64, u32)> = log
        .steps
        .iter()
        .filter_map(|(t, m)| match m {
            Maintenance::StillMissing {
                chip: Chip::Ms5611,
                retry_in_ms,
            } => Some((t - t0, *retry_in_ms)),
            _ => None,
        })
        .collect();
    // Probed at 1 s, then 2, 4 s later: back-off doubles.
    assert_eq!(misses.len(), 3, "{misses:?}");
    assert_eq!(
        misses.iter().map(|m| m.1).collect::<Vec<_>>(),
        [2_000, 4_000, 8_000]
    );
    for (w, expect) in misses.windows(2).zip([2_000, 4_000]) {
        let gap = w[1].0 - w[0].0;
        assert!((expect..expect + 20).contains(&gap), "{misses:?}");
    }
    // The IMU kept running meanwhile.
    assert_eq!(log.samples_failed, 0);

    // Plugged in: found at the next probe (≤ 8 s away), then used.
    rig.bus.clear_faults();
    let mut log = Log::default();
    run(&mut rig, &mut s, 8_000, 0, &mut log);
    assert!(log
        .first(|m| *m == Maintenance::Appeared(Chip::Ms5611))
        .is_some());
    assert!(s.capabilities().altitude);
    assert_eq!(s.baro_health.state(), SensorState::Ok);
    let mut got = 0;
    for _ in 0..100 {
        rig.clock.advance_ns(1_000_000);
        if s.poll_baro(rig.clock.now_us() as u32).is_some() {
            got += 1;
        }
    }
    assert!(got > 0, "barometer readings after it appeared");
}

#[test]
fn mpu_absent_at_boot_then_present_brings_the_magnetometer_with_it() {
    let mut rig = Rig::new(SimConfig::default());
    rig.bus.inject(Fault::Nack {
        address: MPU,
        transactions: None,
    });
    let (mut s, report) = boot(&mut rig);
    assert_eq!(report.mpu.status, Err(ProbeFailure::NoResponse));
    assert_eq!(report.mag.status, Err(ProbeFailure::DependencyMissing));
    assert!(report.baro.present());
    assert_eq!(s.capabilities().ahrs, AhrsMode::None);
    rig.bus.clear_faults();
    let mut log = Log::default();
    run(&mut rig, &mut s, 2_000, 0, &mut log);
    let mpu = log
        .first(|m| *m == Maintenance::Appeared(Chip::Mpu9250))
        .unwrap();
    let mag = log
        .first(|m| *m == Maintenance::Appeared(Chip::Ak8963))
        .unwrap();
    assert!(mag >= mpu + 100, "{:?}", log.steps);
    assert_eq!(s.capabilities().ahrs, AhrsMode::Marg);
    // No bus recovery: the barometer answered all along.
    assert_eq!(log.count(|m| *m == Maintenance::RecoverBus), 0);
}

#[test]
fn nack_storm_costs_one_transfer_per_sample_and_ends_in_recovery() {
    let mut rig = Rig::new(SimConfig::default());
    let (mut s, _) = boot(&mut rig);
    let mut log = Log::default();
    run(&mut rig, &mut s, 100, 0, &mut log);
    // 300 ms of NACKs from the MPU (a loose connector, EMI).
    rig.bus.inject(Fault::Nack {
        address: MPU,
        transactions: None,
    });
    let (_, failed0) = rig.bus.transaction_counts();
    let errors0 = s.mpu_health.counters().errors;
    let mut log = Log::default();
    run(&mut rig, &mut s, 300, 0, &mut log);
    let (_, failed1) = rig.bus.transaction_counts();
    let read_errors = s.mpu_health.counters().errors - errors0;
    // Every NACKed transfer was one skipped sample or one failed
    // (re-)initialisation attempt (its first transfer): no retry loops.
    assert_eq!(s.mpu_health.counters().retries, 0);
    let failed_inits = log.count(|m| {
        matches!(
            m,
            Maintenance::Reinitialised {
                chip: Chip::Mpu9250,
                ok: false
            } | Maintenance::StillMissing {
                chip: Chip::Mpu9250,
                ..
            }
        )
    });
    assert!(failed_inits >= 1, "{:?}", log.steps);
    assert_eq!(
        u64::from(read_errors) + failed_inits as u64,
        failed1 - failed0,
        "{:?}",
        log.steps
    );
    // After 5 failed re-initialisations the MPU is out of the loop: the
    // storm stops costing bus time (every sample is skipped, ~300, but
    // only those up to the fifth failed re-initialisation tried the bus:
    // at most one service period of samples per attempt).
    assert_eq!(s.mpu_health.state(), SensorState::Failed);
    assert!(
        read_errors <= 6 * SERVICE_PERIOD_MS as u32,
        "{read_errors} reads tried"
    );
    assert!(log.samples_failed >= 290, "{log:?}");
    // The storm never looked like a stuck bus: the other chips answered.
    assert_eq!(log.count(|m| *m == Maintenance::RecoverBus), 0);

    // Over: the next re-probe (1 s after it failed) brings it back.
    rig.bus.clear_faults();
    let mut log = Log::default();
    run(&mut rig, &mut s, 1_200, 0, &mut log);
    assert!(
        log.first(|m| *m == Maintenance::Appeared(Chip::Mpu9250))
            .is_some(),
        "{:?}",
        log.steps
    );
    assert_eq!(s.mpu_health.state(), SensorState::Ok);
    let ok_before = log.samples_ok;
    run(&mut rig, &mut s, 200, 0, &mut log);
    assert!(log.samples_ok - ok_before >= 195);
}

#[test]
fn a_bus_that_cannot_be_freed_is_retried_with_back_off() {
    let mut rig = Rig::new(SimConfig::default());
    let (mut s, _) = boot(&mut rig);
    let mut log = Log::default();
    run(&mut rig, &mut s, 100, 0, &mut log);
    // SDA shorted low: no number of SCL clocks frees it.
    rig.bus.inject(Fault::StuckBus);
    let mut log = Log::default();
    run(&mut rig, &mut s, 3_000, u8::MAX, &mut log);
    let tries: Vec<u64> = log
        .steps
        .iter()
        .filter(|(_, m)| *m == Maintenance::RecoverBus)
        .map(|(t, _)| *t)
        .collect();
    // 20, 40, 80, ... ms apart, capped at 1 s: a handful in 3 s, not 300.
    assert!((6..=10).contains(&tries.len()), "{tries:?}");
    let gaps: Vec<u64> = tries.windows(2).map(|w| w[1] - w[0]).collect();
    assert!(gaps.windows(2).all(|g| g[1] >= g[0]), "{gaps:?}");
    assert!(
        gaps.iter().all(|g| *g <= 1_000 + SERVICE_PERIOD_MS),
        "{gaps:?}"
    );
    assert!(gaps.first().is_some_and(|g| *g >= 20), "{gaps:?}");
    // After the first failed recovery nothing else is tried on the dead bus.
    assert!(
        log.steps
            .iter()
            .skip_while(|(_, m)| *m != Maintenance::RecoverBus)
            .all(|(_, m)| *m == Maintenance::RecoverBus),
        "{:?}",
        log.steps
    );
    assert_eq!(s.bus_recoveries() as usize, tries.len());

    // The short goes away: the next attempt frees the bus and all is well.
    rig.bus.clear_faults();
    let mut log = Log::default();
    run(&mut rig, &mut s, 1_500, 0, &mut log);
    assert!(log
        .first(|m| *m == Maintenance::Settled { ok: true })
        .is_some());
    assert_eq!(s.mpu_health.state(), SensorState::Ok);
}
