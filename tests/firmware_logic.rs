//! The firmware's hardware-free logic (`flight`) against the simulated bus:
//! boot with missing or wrong chips (degraded mode), bus faults in flight
//! (counted, retried, recovered), a chip resetting itself in flight
//! (detected by the register read-back, re-initialised), calibration stored
//! and reloaded, a corrupt calibration page, stuck-bus recovery, and the
//! whole 1 kHz loop as the RTIC app runs it.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use e2e::{Rig, StuckSda};
use embedded_hal::delay::DelayNs;
use sensor_stack::boot::{AhrsMode, BiasStatus, Chip as BootChip, ProbeFailure, StartupGyroBias};
use sensor_stack::health::{recover_bus, SensorState};
use sensor_stack::pipeline::{ImuInput, Pipeline, PipelineConfig};
use sensor_stack::schedule::{DtClock, LoopStats, MicrosClock, SampleScheduler};
use sensor_stack::sensors::{MagRead, Sensors};
use sensor_stack::storage::{
    self, CalibrationRecord, DecodeError, LoadError, LoadOutcome, RamPage, ValidParts,
};
use sim::{Chip, Fault, SimBus, SimConfig};

const MPU: u8 = 0x68;
const MS: u8 = 0x77;
const AK: u8 = 0x0C;

fn boot(rig: &mut Rig) -> (Sensors<SimBus>, sensor_stack::boot::BootReport) {
    e2e::boot_sensors(rig)
}

/// Runs the 1 kHz loop like the `imu` task (plus the barometer poll of the
/// `baro` task) for `n` MPU samples on simulated time.
struct Loop {
    sched: SampleScheduler,
    dt: DtClock,
    us: MicrosClock,
    stats: LoopStats,
    cycles: u32,
    mags: u32,
    baros: u32,
    imu_fail: u32,
}

impl Loop {
    fn new() -> Self {
        Self {
            sched: SampleScheduler::new(10),
            dt: DtClock::new(72_000_000, 1_000),
            us: MicrosClock::new(72_000_000, 0),
            stats: LoopStats::new(0),
            cycles: 0,
            mags: 0,
            baros: 0,
            imu_fail: 0,
        }
    }

    fn run(&mut self, rig: &Rig, s: &mut Sensors<SimBus>, p: &mut Pipeline, n: u32) {
        let mut last_ns = rig.clock.now_ns();
        for _ in 0..n {
            let t = rig.bus.advance_to_next_mpu_sample();
            // A 72 MHz cycle counter derived from simulated time.
            self.cycles = self.cycles.wrapping_add(((t - last_ns) * 72 / 1000) as u32);
            last_ns = t;
            let now_us = self.us.now_us(self.cycles);
            let tick = self.sched.on_imu_sample();
            let dt_cycles = self.dt.step_cycles(self.cycles);
            let imu = s.read_imu();
            // As in the firmware: the magnetometer is read on its tick
            // whatever happened to the IMU read.
            let mag = if tick.read_mag {
                s.read_mag()
            } else {
                MagRead::NotReady
            };
            if let MagRead::Sample(m) = mag {
                p.mag_step(m.counts);
                self.mags += 1;
            }
            match imu {
                Some(raw) => {
                    if p.imu_step(&ImuInput {
                        accel: raw.accel,
                        gyro: raw.gyro,
                        dt_cycles,
                    }) {
                        p.control_step();
                    }
                }
                None => self.imu_fail += 1,
            }
            if let Some(m) = s.poll_baro(now_us) {
                p.baro_step(m.pressure_pa);
                self.baros += 1;
            }
            self.stats.record(5_000);
        }
    }
}

fn pipeline_for(
    s: &Sensors<SimBus>,
    report: &sensor_stack::boot::BootReport,
    cal: &CalibrationRecord,
) -> Pipeline {
    let caps = report.capabilities();
    let scale = s.mpu_scale();
    let cfg = PipelineConfig {
        gyro_dps_per_lsb: scale.dps_per_lsb,
        accel_g_per_lsb: scale.g_per_lsb,
        mag_ut_per_lsb: if report.mag.present() {
            s.mag_ut_per_lsb()
        } else {
            [0.15; 3]
        },
        ahrs_mode: caps.ahrs,
        altitude: caps.altitude,
        ..PipelineConfig::new()
    };
    Pipeline::new(cfg, cal).unwrap()
}

#[test]
fn full_boot_and_loop_at_rest() {
    let mut rig = Rig::new(SimConfig::default());
    let (mut s, report) = boot(&mut rig);
    assert!(report.failures().next().is_none(), "{report:?}");
    assert_eq!(report.capabilities().ahrs, AhrsMode::Marg);
    assert!(report.capabilities().altitude);

    // Start-up gyro bias from live samples.
    let scale = s.mpu_scale();
    let mut bias =
        StartupGyroBias::new(500, 1.0 / scale.dps_per_lsb, 1.0 / scale.g_per_lsb, 3).unwrap();
    let mut status = BiasStatus::GaveUp;
    for _ in 0..600 {
        rig.bus.advance_to_next_mpu_sample();
        let raw = s.read_imu().unwrap();
        status = bias.push(raw.gyro, raw.accel);
        if matches!(status, BiasStatus::Done(_)) {
            break;
        }
    }
    let BiasStatus::Done(b) = status else {
        panic!("bias not measured: {status:?}")
    };

    let mut p = pipeline_for(&s, &report, &CalibrationRecord::default());
    p.set_gyro_bias_counts(b);
    let mut lp = Loop::new();
    lp.run(&rig, &mut s, &mut p, 4_000);
    let o = p.outputs();
    assert_eq!(lp.imu_fail, 0);
    assert_eq!(o.imu_samples, 4_000);
    // Magnetometer at 100 Hz (one read every 10th sample), barometer ~100 Hz.
    assert!((390..=400).contains(&lp.mags), "mag samples {}", lp.mags);
    assert!(lp.baros > 300, "baro samples {}", lp.baros);
    // Level and still: roll/pitch ≈ 0, height ≈ 0.
    assert!(o.roll_deg.abs() < 2.0 && o.pitch_deg.abs() < 2.0, "{o:?}");
    assert!(
        o.altitude_m.abs() < 0.5 && o.vertical_speed_mps.abs() < 0.3,
        "{o:?}"
    );
    assert_eq!(s.mpu_health.counters().errors, 0);
    assert!(s.mpu_health.counters().ok >= 4_000);
    let r = lp.stats.report(lp.cycles);
    assert_eq!(r.runs, 4_000);
}

#[test]
fn missing_barometer_and_magnetometer_degrade() {
    let mut rig = Rig::new(SimConfig::default());
    rig.bus.inject(Fault::Nack {
        address: MS,
        transactions: None,
    });
    rig.bus.inject(Fault::Nack {
        address: AK,
        transactions: None,
    });
    let (mut s, report) = boot(&mut rig);
    assert_eq!(report.baro.status, Err(ProbeFailure::NoResponse));
    assert_eq!(report.baro.attempts, 3, "bounded retries");
    assert_eq!(report.mag.status, Err(ProbeFailure::NoResponse));
    assert!(report.mpu.present());
    let caps = report.capabilities();
    assert_eq!(caps.ahrs, AhrsMode::ImuOnly);
    assert!(!caps.altitude);
    assert_eq!(s.baro_health.state(), SensorState::Missing);
    // The stack keeps running with what is there.
    let mut p = pipeline_for(&s, &report, &CalibrationRecord::default());
    let mut lp = Loop::new();
    lp.run(&rig, &mut s, &mut p, 1_000);
    assert_eq!(lp.baros, 0);
    assert_eq!(lp.mags, 0);
    assert_eq!(p.outputs().imu_samples, 1_000);
    assert_eq!(p.outputs().altitude_m, 0.0);
    // Missing chips are never touched again.
    let (_, failed_before) = rig.bus.transaction_counts();
    lp.run(&rig, &mut s, &mut p, 100);
    let (_, failed_after) = rig.bus.transaction_counts();
    assert_eq!(failed_before, failed_after);
}

#[test]
fn wrong_chips_are_named() {
    let mut rig = Rig::new(SimConfig::default());
    rig.bus.inject(Fault::WrongChipId {
        chip: Chip::Mpu9250,
        id: 0x12,
    });
    rig.bus.inject(Fault::CorruptProm {
        word: 3,
        xor_mask: 0x0100,
    });
    let (_, report) = boot(&mut rig);
    assert_eq!(
        report.mpu.status,
        Err(ProbeFailure::WrongId { found: 0x12 })
    );
    assert_eq!(report.mag.status, Err(ProbeFailure::DependencyMissing));
    assert_eq!(report.baro.status, Err(ProbeFailure::BadProm));
    assert_eq!(report.capabilities().ahrs, AhrsMode::None);
    let named: Vec<_> = report.failures().map(|(c, _)| c).collect();
    assert_eq!(
        named,
        [BootChip::Mpu9250, BootChip::Ak8963, BootChip::Ms5611]
    );

    let mut rig = Rig::new(SimConfig::default());
    rig.bus.inject(Fault::WrongChipId {
        chip: Chip::Mpu9250,
        id: 0x70,
    });
    let (_, report) = boot(&mut rig);
    assert_eq!(report.mpu.status, Err(ProbeFailure::Mpu6500));
}

#[test]
fn transient_bus_faults_skip_the_sample_and_are_counted() {
    let mut rig = Rig::new(SimConfig::default());
    let (mut s, report) = boot(&mut rig);
    let mut p = pipeline_for(&s, &report, &CalibrationRecord::default());
    let mut lp = Loop::new();
    lp.run(&rig, &mut s, &mut p, 50);
    // One glitch: that sample is skipped and counted, never retried.
    let (t0, _) = rig.bus.transaction_counts();
    rig.bus
        .inject(Fault::BusErrorMidTransfer { after_bytes: 3 });
    rig.bus.advance_to_next_mpu_sample();
    assert!(s.read_imu().is_none());
    let (t1, _) = rig.bus.transaction_counts();
    assert_eq!(t1 - t0, 1, "exactly one transfer for a failed sample");
    assert_eq!(s.mpu_health.counters().retries, 0);
    assert_eq!(s.mpu_health.counters().errors, 1);
    lp.run(&rig, &mut s, &mut p, 1);
    assert_eq!(lp.imu_fail, 0);
    // A longer outage: samples are lost and counted; after 5 failed samples
    // a re-initialisation is scheduled; once the chip answers again it works.
    rig.bus.inject(Fault::Nack {
        address: MPU,
        transactions: Some(5),
    });
    lp.run(&rig, &mut s, &mut p, 5);
    assert_eq!(lp.imu_fail, 5);
    assert_eq!(s.mpu_health.counters().errors, 6);
    assert_eq!(s.mpu_health.state(), SensorState::Degraded);
    assert!(s.service_due());
    let rep = s.service(&mut rig.delay);
    assert_eq!(rep.reinit[0], Some(true));
    lp.run(&rig, &mut s, &mut p, 20);
    assert_eq!(lp.imu_fail, 5);
    assert_eq!(s.mpu_health.state(), SensorState::Ok);
    assert_eq!(s.mpu_health.counters().reinits, 1);
    assert_eq!(s.mpu_health.counters().retries, 0);
}

#[test]
fn chip_reset_in_flight_is_detected_and_reinitialised() {
    let mut rig = Rig::new(SimConfig::default());
    let (mut s, report) = boot(&mut rig);
    let mut p = pipeline_for(&s, &report, &CalibrationRecord::default());
    let mut lp = Loop::new();
    lp.run(&rig, &mut s, &mut p, 200);
    assert!(!s.check_configs());

    rig.bus.inject(Fault::ChipReset(Chip::Mpu9250));
    rig.bus.inject(Fault::ChipReset(Chip::Ak8963));
    // The periodic read-back finds the MPU's registers at their reset
    // values (the AK8963 behind its bypass is checked after the MPU is back).
    assert!(s.check_configs());
    assert_eq!(s.mpu_health.counters().resets_detected, 1);
    assert_eq!(s.mag_health.counters().resets_detected, 0);
    assert!(s.service_due());
    let rep = s.service(&mut rig.delay);
    assert_eq!(rep.reinit, [Some(true), None, None]);
    // Next round: the AK8963's CNTL1 reads power-down.
    assert!(s.check_configs());
    assert_eq!(s.mag_health.counters().resets_detected, 1);
    let rep = s.service(&mut rig.delay);
    assert_eq!(rep.reinit, [None, Some(true), None]);
    assert!(!s.check_configs());
    let mags_before = lp.mags;
    lp.run(&rig, &mut s, &mut p, 500);
    assert_eq!(lp.imu_fail, 0);
    assert!(lp.mags > mags_before + 40, "magnetometer measuring again");
    let o = p.outputs();
    assert!(o.roll_deg.abs() < 3.0 && o.pitch_deg.abs() < 3.0, "{o:?}");

    // The MS5611 resetting itself loses a conversion; the schedule recovers.
    let before = lp.baros;
    rig.bus.inject(Fault::ChipReset(Chip::Ms5611));
    lp.run(&rig, &mut s, &mut p, 500);
    assert!(
        lp.baros > before + 30,
        "pressure flowing again: {} → {}",
        before,
        lp.baros
    );
}

#[test]
fn stuck_bus_is_detected_recovered_and_chips_reinitialised() {
    let mut rig = Rig::new(SimConfig::default());
    let (mut s, report) = boot(&mut rig);
    let mut p = pipeline_for(&s, &report, &CalibrationRecord::default());
    let mut lp = Loop::new();
    lp.run(&rig, &mut s, &mut p, 100);
    assert!(!s.needs_bus_recovery());

    rig.bus.inject(Fault::StuckBus);
    // Every chip fails; the policy calls it a stuck bus once all present
    // chips failed 3 transactions in a row.
    lp.run(&rig, &mut s, &mut p, 60);
    s.check_configs();
    assert!(lp.imu_fail > 0);
    assert!(
        s.needs_bus_recovery(),
        "mpu {:?} mag {:?} baro {:?}",
        s.mpu_health,
        s.mag_health,
        s.baro_health
    );

    let mut pins = StuckSda::new(&rig.bus, 8);
    let r = recover_bus(&mut pins, &mut rig.delay).unwrap();
    assert_eq!(r.clocks, 8);
    assert!(pins.stop_seen, "STOP generated after SDA release");
    s.after_bus_recovery();
    assert_eq!(s.bus_recoveries(), 1);
    let rep = s.service(&mut rig.delay);
    assert_eq!(rep.reinit, [Some(true), Some(true), Some(true)]);
    let fails = lp.imu_fail;
    lp.run(&rig, &mut s, &mut p, 300);
    assert_eq!(lp.imu_fail, fails, "no more failures after recovery");
    assert_eq!(s.mpu_health.state(), SensorState::Ok);
    assert!(!s.needs_bus_recovery());
}

#[test]
fn calibration_stored_and_reloaded_drives_the_pipeline() {
    let mut rig = Rig::new(SimConfig::default());
    let (mut s, report) = boot(&mut rig);
    // Measure a gyro bias on the simulated board and store it with a mag
    // hard-iron offset.
    let scale = s.mpu_scale();
    let mut bias =
        StartupGyroBias::new(200, 1.0 / scale.dps_per_lsb, 1.0 / scale.g_per_lsb, 2).unwrap();
    let b = loop {
        rig.bus.advance_to_next_mpu_sample();
        let raw = s.read_imu().unwrap();
        if let BiasStatus::Done(b) = bias.push(raw.gyro, raw.accel) {
            break b;
        }
    };
    let rec = CalibrationRecord {
        valid: ValidParts(ValidParts::GYRO | ValidParts::MAG),
        gyro_bias_dps: b.map(|c| f32::from(c) * scale.dps_per_lsb),
        mag_offset_ut: [5.0, -3.0, 2.0],
        ..CalibrationRecord::default()
    };
    let mut page = RamPage::default();
    assert!(matches!(
        storage::load(&mut page),
        LoadOutcome::Defaults(_, LoadError::Decode(DecodeError::Blank))
    ));
    storage::save(&mut page, &rec).unwrap();
    // "Power cycle": a fresh load.
    let loaded = match storage::load(&mut page) {
        LoadOutcome::Loaded(r) => r,
        other => panic!("{other:?}"),
    };
    assert_eq!(loaded, rec);
    let p = pipeline_for(&s, &report, &loaded);
    let got = p.gyro_bias_counts();
    for i in 0..3 {
        assert!((got[i] - i32::from(b[i])).abs() <= 1, "{got:?} vs {b:?}");
    }
    let raw_ut = p.mag_counts_to_mpu_raw_ut([100, 100, 100]);
    let cal_ut = p.mag_counts_to_mpu_ut([100, 100, 100]);
    assert!((raw_ut[0] - cal_ut[0] - 5.0).abs() < 1e-4);
    assert!((raw_ut[1] - cal_ut[1] + 3.0).abs() < 1e-4);
}

#[test]
fn corrupt_calibration_page_falls_back_with_reason() {
    let mut page = RamPage::default();
    let rec = CalibrationRecord {
        accel_offset_g: [0.01, 0.02, -0.03],
        ..CalibrationRecord::default()
    };
    storage::save(&mut page, &rec).unwrap();
    page.bytes[40] ^= 0x04; // one bit of the payload rots
    match storage::load(&mut page) {
        LoadOutcome::Defaults(r, LoadError::Decode(DecodeError::CrcMismatch { .. })) => {
            assert_eq!(r, CalibrationRecord::default())
        }
        other => panic!("{other:?}"),
    }
    // A page written by something else entirely.
    page.bytes[..4].copy_from_slice(b"JUNK");
    assert!(matches!(
        storage::load(&mut page),
        LoadOutcome::Defaults(_, LoadError::Decode(DecodeError::BadMagic { .. }))
    ));
    // A torn write (power lost while programming).
    let mut page = RamPage {
        tear_after: Some(50),
        ..RamPage::default()
    };
    assert!(storage::save(&mut page, &rec).is_err());
    page.tear_after = None;
    assert!(matches!(
        storage::load(&mut page),
        LoadOutcome::Defaults(_, LoadError::Decode(_))
    ));
    // The stack still boots and runs on the defaults.
    let mut rig = Rig::new(SimConfig::default());
    let (mut s, report) = boot(&mut rig);
    let mut p = pipeline_for(&s, &report, storage::load(&mut page).record());
    let mut lp = Loop::new();
    lp.run(&rig, &mut s, &mut p, 100);
    rig.delay.delay_ms(1);
    assert_eq!(p.outputs().imu_samples, 100);
}
