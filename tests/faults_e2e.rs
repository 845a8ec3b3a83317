//! Each injected fault gives the driver's typed error, and the driver
//! recovers once the fault clears.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use e2e::{f64x3, Rig};
use embedded_hal::delay::DelayNs;
use embedded_hal::i2c::NoAcknowledgeSource;
use mpu9250::{Address, Config, Mpu9250};
use ms5611::{Channel, Ms5611, Osr};
use sim::{Chip, Fault, SimBus, SimBusError, SimConfig, Vibration};

const MPU: u8 = 0x68;
const MS: u8 = 0x77;

fn mpu(rig: &Rig) -> Mpu9250<SimBus> {
    Mpu9250::new(rig.bus.clone(), Address::Ad0Low)
}

#[test]
fn mpu_nack_then_recovers() {
    let mut rig = Rig::new(SimConfig::default());
    let mut imu = mpu(&rig);
    rig.bus.inject(Fault::Nack {
        address: MPU,
        transactions: None,
    });
    let e = imu.init(&mut rig.delay, &Config::default()).unwrap_err();
    assert_eq!(
        e,
        mpu9250::Error::Bus(SimBusError::Nack(NoAcknowledgeSource::Address))
    );
    rig.bus.clear_faults();
    imu.init(&mut rig.delay, &Config::default()).unwrap();
    rig.delay.delay_ms(1);
    assert!(imu.read().is_ok());
    // A NACK for a couple of transactions: those reads fail, the next one works.
    rig.bus.inject(Fault::Nack {
        address: MPU,
        transactions: Some(2),
    });
    assert!(matches!(
        imu.read(),
        Err(mpu9250::Error::Bus(SimBusError::Nack(_)))
    ));
    assert!(matches!(
        imu.read(),
        Err(mpu9250::Error::Bus(SimBusError::Nack(_)))
    ));
    assert!(imu.read().is_ok());
}

#[test]
fn mpu_wrong_chip_ids() {
    let mut rig = Rig::new(SimConfig::default());
    let mut imu = mpu(&rig);
    rig.bus.inject(Fault::WrongChipId {
        chip: Chip::Mpu9250,
        id: 0x12,
    });
    assert_eq!(
        imu.init(&mut rig.delay, &Config::default()),
        Err(mpu9250::Error::WrongChipId(0x12))
    );
    rig.bus.inject(Fault::WrongChipId {
        chip: Chip::Mpu9250,
        id: 0x70,
    });
    assert_eq!(
        imu.init(&mut rig.delay, &Config::default()),
        Err(mpu9250::Error::Mpu6500Detected)
    );
    assert_eq!(imu.read(), Err(mpu9250::Error::NotInitialized));
    rig.bus.clear_faults();
    assert_eq!(
        imu.init(&mut rig.delay, &Config::default()),
        Ok(mpu9250::Variant::Mpu9250)
    );
}

#[test]
fn mpu_bus_error_mid_burst_and_stuck_bus() {
    let mut rig = Rig::new(SimConfig::default());
    let mut imu = mpu(&rig);
    imu.init(&mut rig.delay, &Config::default()).unwrap();
    rig.delay.delay_ms(1);
    // Glitch after the register address and 5 data bytes of the 14-byte burst.
    rig.bus
        .inject(Fault::BusErrorMidTransfer { after_bytes: 6 });
    assert_eq!(imu.read(), Err(mpu9250::Error::Bus(SimBusError::Bus)));
    let s = imu.read().unwrap();
    assert!((f64::from(s.accel_g[2]) - 1.0).abs() < 0.02);
    rig.bus.inject(Fault::StuckBus);
    for _ in 0..10 {
        rig.delay.delay_ms(1);
        assert_eq!(imu.read(), Err(mpu9250::Error::Bus(SimBusError::Bus)));
    }
    rig.bus.inject(Fault::ArbitrationLoss { transactions: 1 });
    rig.bus.clear_faults();
    assert!(imu.read().is_ok());
}

#[test]
fn mpu_resets_itself_in_flight_detected_and_reinitialised() {
    let mut rig = Rig::new(SimConfig::default());
    let mut imu = mpu(&rig);
    imu.init(&mut rig.delay, &Config::default()).unwrap();
    imu.verify_config().unwrap();
    rig.delay.delay_ms(5);
    rig.bus.inject(Fault::ChipReset(Chip::Mpu9250));
    let e = imu.verify_config().unwrap_err();
    assert!(matches!(e, mpu9250::Error::ConfigMismatch { .. }), "{e:?}");
    // After the reset the chip is at ±2 g: the driver's ±4 g scale would read 2 g.
    rig.delay.delay_ms(2);
    let wrong = imu.read().unwrap();
    assert!(
        (f64::from(wrong.accel_g[2]) - 2.0).abs() < 0.05,
        "{wrong:?}"
    );
    imu.init(&mut rig.delay, &Config::default()).unwrap();
    rig.delay.delay_ms(2);
    let s = imu.read().unwrap();
    assert!((f64::from(s.accel_g[2]) - 1.0).abs() < 0.02);
}

#[test]
fn mpu_frozen_data_then_live_again() {
    let mut rig = Rig::new(SimConfig::default());
    let mut imu = mpu(&rig);
    imu.init(&mut rig.delay, &Config::default()).unwrap();
    rig.delay.delay_ms(2);
    rig.bus.inject(Fault::Frozen(Chip::Mpu9250));
    let a = imu.read_raw().unwrap();
    for _ in 0..20 {
        rig.delay.delay_ms(1);
        assert!(imu.data_ready().unwrap(), "data-ready keeps firing");
        assert_eq!(imu.read_raw().unwrap(), a, "but the data is stale");
    }
    rig.bus.clear_faults();
    rig.delay.delay_ms(1);
    assert_ne!(imu.read_raw().unwrap(), a);
}

#[test]
fn vibration_spoils_gyro_calibration_until_it_stops() {
    let mut rig = Rig::new(SimConfig::default());
    let mut imu = mpu(&rig);
    imu.init(&mut rig.delay, &Config::default()).unwrap();
    rig.bus.inject(Fault::Vibration(Vibration {
        accel_amplitude_mps2: 3.0,
        gyro_amplitude_dps: 5.0,
        frequency_hz: 23.0,
    }));
    let e = imu.calibrate_gyro_bias(&mut rig.delay, 200).unwrap_err();
    assert!(matches!(e, mpu9250::Error::Moved(_)), "{e:?}");
    rig.bus.clear_faults();
    // The chip's DLPF (41 Hz, 5.9 ms delay) still outputs the last
    // vibration for a few of its time constants after the shaking stops.
    rig.delay.delay_ms(50);
    imu.calibrate_gyro_bias(&mut rig.delay, 200).unwrap();
    let b = f64x3(imu.gyro_bias_dps());
    assert!(b.iter().all(|v| v.abs() < 0.05), "{b:?}");
}

fn baro(rig: &Rig) -> Ms5611<SimBus> {
    Ms5611::new(rig.bus.clone(), ms5611::Address::CsbLow)
}

#[test]
fn ms5611_corrupted_prom_is_a_crc_error() {
    let mut rig = Rig::new(SimConfig::default());
    let mut b = baro(&rig);
    rig.bus.inject(Fault::CorruptProm {
        word: 3,
        xor_mask: 0x0100,
    });
    let e = b.init(&mut rig.delay).unwrap_err();
    assert!(matches!(e, ms5611::Error::PromCrc { .. }), "{e:?}");
    assert_eq!(
        b.measure(&mut rig.delay, Osr::Osr4096),
        Err(ms5611::Error::NotInitialised)
    );
    rig.bus.clear_faults();
    b.init(&mut rig.delay).unwrap();
    let m = b.measure(&mut rig.delay, Osr::Osr4096).unwrap();
    assert!((m.pressure_pa - 101_325).abs() < 10, "{m:?}");
}

#[test]
fn ms5611_blank_prom_detected() {
    let mut rig = Rig::new(SimConfig::default());
    let mut b = baro(&rig);
    // Every word reads 0xFFFF (no chip answering with pull-ups would read the same).
    let prom = rig.bus.state().ms.prom();
    for (w, v) in prom.iter().enumerate() {
        rig.bus.inject(Fault::CorruptProm {
            word: w,
            xor_mask: !v,
        });
    }
    let e = b.init(&mut rig.delay).unwrap_err();
    assert!(
        matches!(e, ms5611::Error::PromBlank | ms5611::Error::PromCrc { .. }),
        "{e:?}"
    );
}

#[test]
fn ms5611_nack_early_read_and_recovery() {
    let mut rig = Rig::new(SimConfig::default());
    let mut b = baro(&rig);
    b.init(&mut rig.delay).unwrap();
    rig.bus.inject(Fault::Nack {
        address: MS,
        transactions: Some(1),
    });
    assert_eq!(
        b.measure(&mut rig.delay, Osr::Osr4096),
        Err(ms5611::Error::Bus(SimBusError::Nack(
            NoAcknowledgeSource::Address
        )))
    );
    // Reading before the conversion time: the chip returns 0 → AdcNotReady.
    b.start_conversion(Channel::Pressure, Osr::Osr4096).unwrap();
    rig.delay.delay_us(2_000);
    assert_eq!(b.read_adc(), Err(ms5611::Error::AdcNotReady));
    // That read spoiled the conversion; a fresh measurement works.
    rig.delay.delay_ms(10);
    let m = b.measure(&mut rig.delay, Osr::Osr4096).unwrap();
    assert!((m.pressure_pa - 101_325).abs() < 10, "{m:?}");
    // The chip resets itself: PROM reload, then conversions work again.
    rig.bus.inject(Fault::ChipReset(Chip::Ms5611));
    assert!(b.measure(&mut rig.delay, Osr::Osr4096).is_ok());
}

#[test]
fn ms5611_frozen_returns_identical_readings() {
    let mut rig = Rig::new(SimConfig::default());
    let mut b = baro(&rig);
    b.init(&mut rig.delay).unwrap();
    let _ = b.measure(&mut rig.delay, Osr::Osr4096).unwrap();
    rig.bus.inject(Fault::Frozen(Chip::Ms5611));
    let m1 = b.measure(&mut rig.delay, Osr::Osr4096).unwrap();
    let m2 = b.measure(&mut rig.delay, Osr::Osr4096).unwrap();
    assert_eq!(m1, m2);
    rig.bus.clear_faults();
    let ms: Vec<_> = (0..5)
        .map(|_| b.measure(&mut rig.delay, Osr::Osr4096).unwrap())
        .collect();
    assert!(ms.iter().any(|m| *m != m1));
}

fn mag(rig: &mut Rig) -> (Mpu9250<SimBus>, ak8963::Ak8963<SimBus>) {
    let mut imu = mpu(rig);
    imu.set_bypass(true).unwrap();
    imu.init(&mut rig.delay, &Config::default()).unwrap();
    let mut m = ak8963::Ak8963::new(rig.bus.clone());
    m.init(&mut rig.delay, &ak8963::Config::default()).unwrap();
    (imu, m)
}

fn next_mag(
    rig: &mut Rig,
    m: &mut ak8963::Ak8963<SimBus>,
) -> Result<ak8963::Sample, ak8963::Error<SimBusError>> {
    loop {
        match m.read() {
            Err(ak8963::Error::NotReady) => rig.delay.delay_ms(1),
            r => return r,
        }
    }
}

#[test]
fn ak8963_unreachable_without_bypass() {
    let mut rig = Rig::new(SimConfig::default());
    let mut imu = mpu(&rig);
    imu.init(&mut rig.delay, &Config::default()).unwrap();
    let mut m = ak8963::Ak8963::new(rig.bus.clone());
    assert_eq!(
        m.init(&mut rig.delay, &ak8963::Config::default()),
        Err(ak8963::Error::Bus(SimBusError::Nack(
            NoAcknowledgeSource::Address
        )))
    );
    imu.set_bypass(true).unwrap();
    m.init(&mut rig.delay, &ak8963::Config::default()).unwrap();
}

#[test]
fn ak8963_wrong_id_overflow_magnet_and_recovery() {
    let mut rig = Rig::new(SimConfig::default());
    let (_imu, mut m) = mag(&mut rig);
    rig.bus.inject(Fault::WrongChipId {
        chip: Chip::Ak8963,
        id: 0x00,
    });
    assert_eq!(
        m.init(&mut rig.delay, &ak8963::Config::default()),
        Err(ak8963::Error::WrongId(0x00))
    );
    rig.bus.clear_faults();
    m.init(&mut rig.delay, &ak8963::Config::default()).unwrap();
    // HOFL.
    rig.bus.inject(Fault::MagOverflow);
    assert_eq!(next_mag(&mut rig, &mut m), Err(ak8963::Error::Overflow));
    rig.bus.clear_faults();
    rig.delay.delay_ms(10);
    assert!(
        next_mag(&mut rig, &mut m).is_ok(),
        "next measurement unblocked"
    );
    // A strong magnet passing by overflows the sensor for real, then goes away.
    let t = rig.clock.now_s();
    rig.bus
        .inject(sim::magnet_pass([4000.0, 3000.0, 0.0], t + 0.5, 0.4));
    let mut overflowed = false;
    let mut disturbed = false;
    while rig.clock.now_s() < t + 2.0 {
        match next_mag(&mut rig, &mut m) {
            Err(ak8963::Error::Overflow) => overflowed = true,
            Ok(s) => {
                let f = f64x3(s.field_mpu_ut());
                let n = (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt();
                disturbed |= n > 100.0;
            }
            Err(e) => panic!("{e:?}"),
        }
    }
    assert!(overflowed && disturbed);
    let f = f64x3(next_mag(&mut rig, &mut m).unwrap().field_mpu_ut());
    let n = (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt();
    assert!((n - 50.0).abs() < 3.0, "field back to the Earth's: {n}");
}

#[test]
fn ak8963_resets_itself_detected_and_reinitialised() {
    let mut rig = Rig::new(SimConfig::default());
    let (_imu, mut m) = mag(&mut rig);
    assert!(next_mag(&mut rig, &mut m).is_ok());
    rig.bus.inject(Fault::ChipReset(Chip::Ak8963));
    assert!(matches!(
        m.verify_config(),
        Err(ak8963::Error::ConfigMismatch { .. })
    ));
    rig.delay.delay_ms(20);
    assert_eq!(
        m.read(),
        Err(ak8963::Error::NotReady),
        "power-down after reset: no data"
    );
    m.init(&mut rig.delay, &ak8963::Config::default()).unwrap();
    assert!(next_mag(&mut rig, &mut m).is_ok());
}

#[test]
fn mpu_reset_drops_the_bypass_and_the_magnetometer() {
    let mut rig = Rig::new(SimConfig::default());
    let (mut imu, mut m) = mag(&mut rig);
    rig.bus.inject(Fault::ChipReset(Chip::Mpu9250));
    assert_eq!(
        m.read(),
        Err(ak8963::Error::Bus(SimBusError::Nack(
            NoAcknowledgeSource::Address
        )))
    );
    imu.init(&mut rig.delay, &Config::default()).unwrap(); // bypass state survives init
    assert!(next_mag(&mut rig, &mut m).is_ok());
}

#[test]
fn ak8963_frozen_data_is_stale() {
    let mut rig = Rig::new(SimConfig::default());
    let (_imu, mut m) = mag(&mut rig);
    let _ = next_mag(&mut rig, &mut m).unwrap();
    rig.bus.inject(Fault::Frozen(Chip::Ak8963));
    rig.delay.delay_ms(10);
    let a = next_mag(&mut rig, &mut m).unwrap();
    rig.delay.delay_ms(10);
    let b = next_mag(&mut rig, &mut m).unwrap();
    assert_eq!(a.field_ut, b.field_ut);
    rig.bus.clear_faults();
    rig.delay.delay_ms(10);
    assert_ne!(next_mag(&mut rig, &mut m).unwrap().field_ut, a.field_ut);
}
