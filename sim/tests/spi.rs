//! The MPU-9250 and MS5611 models on SPI: the real drivers over `SimSpi` read
//! the same registers and samples as over the I2C bus, with the chips'
//! SPI framing.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use sim::*;

fn rig() -> (SimClock, SimBus, SimDelay) {
    let clock = SimClock::new();
    let bus = SimBus::new(
        &clock,
        SimConfig {
            errors: SensorErrors::ideal(),
            ..SimConfig::default()
        },
    );
    let delay = clock.delay();
    (clock, bus, delay)
}

#[test]
fn mpu9250_over_spi_and_i2c_reads_the_same_sample() {
    let (_clock, bus, mut delay) = rig();
    let mut over_spi =
        ::mpu9250::Mpu9250::new_with_spi(SimSpi::new(&bus, SpiChip::Mpu9250, 1_000_000));
    let config = ::mpu9250::Config::default();
    over_spi.init(&mut delay, &config).unwrap();
    // I2C_IF_DIS was written and reads back.
    over_spi.verify_config().unwrap();
    assert_eq!(bus.state().mpu.register(0x6A) & 0x10, 0x10);

    let mut over_i2c = ::mpu9250::Mpu9250::new(bus.clone(), ::mpu9250::Address::Ad0Low);
    for _ in 0..5 {
        bus.advance_to_next_mpu_sample();
        let a = over_spi.read_raw().unwrap();
        let b = over_i2c.read_raw().unwrap();
        assert_eq!(a, b);
        // Flat and at rest: about +1 g on z at ±4 g (8192 LSB/g).
        assert!((i32::from(a.accel[2]) - 8192).abs() < 200, "{a:?}");
    }
}

#[test]
fn ms5611_over_spi_reads_the_same_prom_and_pressure() {
    let (_clock, bus, mut delay) = rig();
    let mut over_spi =
        ::ms5611::Ms5611::new_with_spi(SimSpi::new(&bus, SpiChip::Ms5611, 1_000_000));
    let mut over_i2c = ::ms5611::Ms5611::new(bus.clone(), ::ms5611::Address::CsbLow);
    let prom_spi = over_spi.init(&mut delay).unwrap();
    let prom_i2c = over_i2c.init(&mut delay).unwrap();
    assert_eq!(prom_spi, prom_i2c);
    assert_eq!(prom_spi.words(), bus.state().ms.prom());
    let a = over_spi
        .measure(&mut delay, ::ms5611::Osr::Osr4096)
        .unwrap();
    let b = over_i2c
        .measure(&mut delay, ::ms5611::Osr::Osr4096)
        .unwrap();
    // Ideal sensor at rest: both transports see the same air.
    assert!((a.pressure_pa - b.pressure_pa).abs() <= 2, "{a:?} {b:?}");
    assert!((a.temperature_centi_c - b.temperature_centi_c).abs() <= 1);
}

/// The model's FIFO through the real driver on SPI: whole samples in order
/// (the newest equals the data registers), then an overflow after the host
/// sleeps too long, detected and reset, then clean samples again.
#[test]
fn mpu9250_fifo_over_spi() {
    let (clock, bus, mut delay) = rig();
    let mut imu = ::mpu9250::Mpu9250::new_with_spi(SimSpi::new(&bus, SpiChip::Mpu9250, 1_000_000));
    imu.init(&mut delay, &::mpu9250::Config::default()).unwrap();
    imu.set_fifo(true).unwrap();
    let start = bus.state().mpu.sample_count();
    for _ in 0..10 {
        bus.advance_to_next_mpu_sample();
    }
    let queued = bus.state().mpu.sample_count() - start;
    let mut out = [::mpu9250::RawSample::default(); 40];
    let n = imu.read_fifo(&mut out).unwrap();
    assert_eq!(n as u64, queued);
    assert_eq!(out[n - 1], imu.read_raw().unwrap());

    // 40 samples × 14 bytes > 512: the host missed its deadline.
    clock.advance_ns(40 * 1_000_000);
    assert!(matches!(
        imu.read_fifo(&mut out),
        Err(::mpu9250::Error::FifoOverflow { .. })
    ));
    assert_eq!(bus.state().mpu.fifo_len(), 0);
    for _ in 0..3 {
        bus.advance_to_next_mpu_sample();
    }
    let n = imu.read_fifo(&mut out).unwrap();
    assert!((2..=4).contains(&n), "{n}");
    assert_eq!(out[n - 1], imu.read_raw().unwrap());
}

/// The AK8963 behind the MPU-9250 on SPI: the real AK8963 driver runs its
/// init through slave 4, then slave 0 copies ST1..ST2 with every sample and
/// the block parses to the field the model is in.
#[test]
fn ak8963_through_the_internal_master_over_spi() {
    let (_clock, bus, mut delay) = rig();
    let mut imu = ::mpu9250::Mpu9250::new_with_spi(SimSpi::new(&bus, SpiChip::Mpu9250, 1_000_000));
    imu.init(&mut delay, &::mpu9250::Config::default()).unwrap();
    imu.set_i2c_master(true).unwrap();
    let mut mag = ::ak8963::Ak8963::new(imu.aux_bus(bus.clock().delay()));
    mag.init(&mut delay, &::ak8963::Config::default()).unwrap();
    let ut_per_lsb = mag.ut_per_lsb();
    assert_eq!(mag.asa(), bus.state().ak.asa());
    let _ = mag.release();
    imu.start_slave0_read(::mpu9250::SlaveRead::AK8963_STATUS_BLOCK)
        .unwrap();

    let mut fields = 0;
    for _ in 0..50 {
        bus.advance_to_next_mpu_sample();
        let mut block = [0u8; 8];
        let sample = imu.read_raw_with_external(&mut block).unwrap();
        assert!((i32::from(sample.accel[2]) - 8192).abs() < 200);
        match ::ak8963::parse_status_block(&block, ::ak8963::Resolution::Bits16) {
            Ok(raw) => {
                let b = ::ak8963::counts_to_ut(raw.counts, &ut_per_lsb);
                let norm = (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt();
                // The Earth's field: 20..70 µT anywhere.
                assert!((20.0..70.0).contains(&norm), "{b:?}");
                fields += 1;
            }
            Err(::ak8963::Rejected::NotReady) => {}
            Err(e) => panic!("{e:?}"),
        }
    }
    // 100 Hz magnetometer under 1 kHz samples: about 5 fresh fields in 50 ms.
    assert!((3..=6).contains(&fields), "{fields}");
}
