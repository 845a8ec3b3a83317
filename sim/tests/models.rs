//! Register-level behaviour of the chip models, straight from the datasheets.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use embedded_hal::delay::DelayNs;
use embedded_hal::i2c::{Error, ErrorKind, I2c, NoAcknowledgeSource};
use sim::ak8963::reg as ak;
use sim::mpu9250::reg as mpu;
use sim::physics::G0_MPS2;
use sim::*;

const MPU: u8 = 0x68;
const MS: u8 = 0x77;
const AK: u8 = 0x0C;

fn rig(config: SimConfig) -> (SimClock, SimBus, SimDelay) {
    let clock = SimClock::new();
    let bus = SimBus::new(&clock, config);
    let delay = clock.delay();
    (clock, bus, delay)
}

fn ideal() -> SimConfig {
    SimConfig {
        errors: SensorErrors::ideal(),
        ..SimConfig::default()
    }
}

fn rd(bus: &mut SimBus, addr: u8, reg: u8) -> u8 {
    let mut b = [0];
    bus.write_read(addr, &[reg], &mut b).unwrap();
    b[0]
}

fn wr(bus: &mut SimBus, addr: u8, reg: u8, v: u8) {
    bus.write(addr, &[reg, v]).unwrap();
}

fn burst14(bus: &mut SimBus) -> [i16; 7] {
    let mut b = [0u8; 14];
    bus.write_read(MPU, &[mpu::ACCEL_XOUT_H], &mut b).unwrap();
    core::array::from_fn(|i| i16::from_be_bytes([b[2 * i], b[2 * i + 1]]))
}

#[test]
fn mpu_reset_values_and_who_am_i() {
    let (_c, mut bus, _d) = rig(ideal());
    assert_eq!(rd(&mut bus, MPU, mpu::WHO_AM_I), 0x71);
    assert_eq!(rd(&mut bus, MPU, mpu::PWR_MGMT_1), 0x01);
    assert_eq!(rd(&mut bus, MPU, mpu::GYRO_CONFIG), 0x00);
    assert_eq!(rd(&mut bus, MPU, mpu::INT_PIN_CFG), 0x00);
}

#[test]
fn mpu_reset_bit_self_clears_after_simulated_time() {
    let (_c, mut bus, mut d) = rig(ideal());
    wr(&mut bus, MPU, mpu::GYRO_CONFIG, 0x18);
    wr(&mut bus, MPU, mpu::PWR_MGMT_1, 0x80);
    assert_eq!(rd(&mut bus, MPU, mpu::PWR_MGMT_1) & 0x80, 0x80);
    assert_eq!(
        rd(&mut bus, MPU, mpu::GYRO_CONFIG),
        0x00,
        "registers back to reset values"
    );
    d.delay_ms(2);
    assert_eq!(rd(&mut bus, MPU, mpu::PWR_MGMT_1), 0x01);
}

#[test]
fn mpu_at_rest_reads_plus_one_g_on_z_big_endian() {
    let (_c, mut bus, mut d) = rig(ideal());
    d.delay_ms(5);
    let s = burst14(&mut bus);
    assert_eq!(&s[0..3], &[0, 0, 16384]);
    // 15 °C ISA at sea level: (15 − 21)·333.87 = −2003.
    assert_eq!(s[3], -2003);
    assert_eq!(&s[4..7], &[0, 0, 0]);
    // ±16 g full scale: 2048 LSB/g.
    wr(&mut bus, MPU, mpu::ACCEL_CONFIG, 0x18);
    d.delay_ms(2);
    assert_eq!(burst14(&mut bus)[2], 2048);
}

#[test]
fn mpu_gyro_scale_and_saturation() {
    // Body yaw rate +90 °/s (FRD z down) → MPU z = −90 °/s.
    let cfg = SimConfig {
        trajectory: Trajectory::ConstantRate {
            omega_body_rps: [0.0, 0.0, 90f64.to_radians()],
        },
        ..ideal()
    };
    let (_c, mut bus, mut d) = rig(cfg);
    d.delay_ms(3);
    let s = burst14(&mut bus);
    assert!((s[6] as f64 - (-90.0 * 131.0)).abs() <= 2.0, "{s:?}");
    // 1500 °/s about x saturates at ±250 °/s full scale.
    let cfg = SimConfig {
        trajectory: Trajectory::ConstantRate {
            omega_body_rps: [1500f64.to_radians(), 0.0, 0.0],
        },
        ..ideal()
    };
    let (_c, mut bus, mut d) = rig(cfg);
    d.delay_ms(3);
    assert_eq!(burst14(&mut bus)[4], 32767);
    wr(&mut bus, MPU, mpu::GYRO_CONFIG, 0x18); // ±2000 °/s
    d.delay_ms(2);
    assert!((burst14(&mut bus)[4] as f64 - 1500.0 * 16.4).abs() <= 2.0);
}

#[test]
fn mpu_sample_rate_divider_and_data_ready() {
    let (clock, mut bus, mut d) = rig(ideal());
    wr(&mut bus, MPU, mpu::CONFIG, 3); // DLPF 41 Hz, 1 kHz internal
    wr(&mut bus, MPU, mpu::SMPLRT_DIV, 4); // 200 Hz
    wr(&mut bus, MPU, mpu::INT_PIN_CFG, 0x20); // latched
    wr(&mut bus, MPU, mpu::INT_ENABLE, 0x01);
    d.delay_ms(20);
    let _ = rd(&mut bus, MPU, mpu::INT_STATUS);
    let n0 = bus.state().mpu.sample_count();
    let t0 = clock.now_ns();
    assert!(!bus.data_ready());
    let mut count = 0;
    while clock.now_ns() < t0 + 1_000_000_000 {
        d.delay_us(100);
        if bus.data_ready() {
            count += 1;
            assert_eq!(rd(&mut bus, MPU, mpu::INT_STATUS) & 1, 1);
            assert!(
                !bus.data_ready(),
                "reading INT_STATUS clears the latched INT"
            );
        }
    }
    assert!((199..=201).contains(&count), "{count}");
    assert!((199..=201).contains(&(bus.state().mpu.sample_count() - n0)));
    // Non-latched: 50 µs pulse.
    wr(&mut bus, MPU, mpu::INT_PIN_CFG, 0x00);
    let t = bus.advance_to_next_mpu_sample();
    assert!(bus.data_ready());
    clock.advance_to_ns(t + 60_000);
    assert!(!bus.data_ready());
}

#[test]
fn ak8963_only_answers_in_bypass() {
    let (_c, mut bus, _d) = rig(ideal());
    let mut b = [0];
    let e = bus.write_read(AK, &[ak::WIA], &mut b).unwrap_err();
    assert_eq!(
        e.kind(),
        ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address)
    );
    wr(&mut bus, MPU, mpu::INT_PIN_CFG, 0x02);
    assert_eq!(rd(&mut bus, AK, ak::WIA), 0x48);
    wr(&mut bus, MPU, mpu::USER_CTRL, 0x20); // I2C master on: bypass ineffective
    assert!(bus.write_read(AK, &[ak::WIA], &mut b).is_err());
}

fn ak_setup(config: SimConfig) -> (SimClock, SimBus, SimDelay) {
    let (c, mut bus, d) = rig(config);
    wr(&mut bus, MPU, mpu::INT_PIN_CFG, 0x02);
    (c, bus, d)
}

#[test]
fn ak8963_fuse_rom_only_in_fuse_mode() {
    let (_c, mut bus, _d) = ak_setup(ideal());
    let mut asa = [0u8; 3];
    bus.write_read(AK, &[0x10], &mut asa).unwrap();
    assert_eq!(asa, [0, 0, 0]);
    wr(&mut bus, AK, ak::CNTL1, 0x0F);
    bus.write_read(AK, &[0x10], &mut asa).unwrap();
    assert_eq!(asa, sim::ak8963::DEFAULT_ASA);
    // Auto-increment wraps 0x12 → 0x10.
    let mut six = [0u8; 6];
    bus.write_read(AK, &[0x10], &mut six).unwrap();
    assert_eq!(&six[3..], &sim::ak8963::DEFAULT_ASA);
}

fn read_mag(bus: &mut SimBus) -> (u8, [i16; 3], u8) {
    let mut b = [0u8; 8];
    bus.write_read(AK, &[ak::ST1], &mut b).unwrap();
    let v = core::array::from_fn(|i| i16::from_le_bytes([b[1 + 2 * i], b[2 + 2 * i]]));
    (b[0], v, b[7])
}

#[test]
fn ak8963_measures_the_field_little_endian_with_asa() {
    let (_c, mut bus, mut d) = ak_setup(ideal());
    wr(&mut bus, AK, ak::CNTL1, 0x16); // 16-bit, continuous 2
    d.delay_ms(12);
    let (st1, v, st2) = read_mag(&mut bus);
    assert_eq!(st1 & 1, 1);
    assert_eq!(st2, 0x10, "BITM set, no HOFL");
    // Level, north: field NED (25, 0, 43.3) µT → body same → MPU (25, 0, −43.3) → AK (0, 25, 43.3).
    let adj = bus.state().ak.asa_factor();
    let ut = [0, 1, 2].map(|i| v[i] as f64 * 0.15 * adj[i]);
    assert!(
        ut[0].abs() < 0.2 && (ut[1] - 25.0).abs() < 0.2 && (ut[2] - 43.301).abs() < 0.2,
        "{ut:?}"
    );
    // 14-bit.
    wr(&mut bus, AK, ak::CNTL1, 0x00);
    wr(&mut bus, AK, ak::CNTL1, 0x06);
    d.delay_ms(12);
    let (_, v14, st2) = read_mag(&mut bus);
    assert_eq!(st2, 0x00);
    assert!((v14[2] as f64 * 0.6 * adj[2] - 43.301).abs() < 0.7);
}

#[test]
fn ak8963_drdy_dor_and_protection() {
    let (_c, mut bus, mut d) = ak_setup(ideal());
    wr(&mut bus, AK, ak::CNTL1, 0x16);
    assert_eq!(rd(&mut bus, AK, ak::ST1), 0);
    d.delay_ms(8);
    assert_eq!(rd(&mut bus, AK, ak::ST1), 0x01);
    d.delay_ms(10); // a second sample while the first is unread
    assert_eq!(rd(&mut bus, AK, ak::ST1), 0x03, "DOR");
    let (_, _, _) = read_mag(&mut bus);
    assert_eq!(
        rd(&mut bus, AK, ak::ST1),
        0x00,
        "reading data + ST2 clears DRDY/DOR"
    );
    // Start reading data but do not read ST2: a new measurement is skipped.
    let mut b = [0u8; 6];
    d.delay_ms(10);
    bus.write_read(AK, &[ak::HXL], &mut b).unwrap();
    d.delay_ms(10);
    assert_eq!(
        rd(&mut bus, AK, ak::ST1),
        0x02,
        "skipped while protected: DOR, no DRDY"
    );
    let _ = rd(&mut bus, AK, ak::ST2);
    d.delay_ms(10);
    assert_eq!(rd(&mut bus, AK, ak::ST1) & 1, 1);
}

#[test]
fn ak8963_single_mode_returns_to_power_down_and_soft_reset() {
    let (_c, mut bus, mut d) = ak_setup(ideal());
    wr(&mut bus, AK, ak::CNTL1, 0x11);
    d.delay_ms(10);
    assert_eq!(rd(&mut bus, AK, ak::CNTL1), 0x10);
    assert_eq!(rd(&mut bus, AK, ak::ST1), 0x01);
    wr(&mut bus, AK, ak::CNTL1, 0x16);
    wr(&mut bus, AK, ak::CNTL2, 0x01);
    assert_eq!(rd(&mut bus, AK, ak::CNTL1), 0x00);
    assert_eq!(rd(&mut bus, AK, ak::CNTL2), 0x00);
}

#[test]
fn ak8963_overflow_sets_hofl() {
    let (_c, mut bus, mut d) = ak_setup(ideal());
    wr(&mut bus, AK, ak::CNTL1, 0x16);
    bus.inject(magnet_pass([3000.0, 2000.0, 0.0], 0.0, 1e9));
    d.delay_ms(12);
    assert_eq!(read_mag(&mut bus).2 & 0x08, 0x08);
    bus.clear_faults();
    d.delay_ms(10);
    assert_eq!(read_mag(&mut bus).2 & 0x08, 0x00);
}

fn ms_prom(bus: &mut SimBus) -> [u16; 8] {
    core::array::from_fn(|i| {
        let mut b = [0u8; 2];
        bus.write_read(MS, &[0xA0 + 2 * i as u8], &mut b).unwrap();
        u16::from_be_bytes(b)
    })
}

fn ms_convert(bus: &mut SimBus, d: &mut SimDelay, cmd: u8, wait_us: u32) -> u32 {
    bus.write(MS, &[cmd]).unwrap();
    d.delay_us(wait_us);
    let mut b = [0u8; 3];
    bus.write_read(MS, &[0x00], &mut b).unwrap();
    u32::from_be_bytes([0, b[0], b[1], b[2]])
}

#[test]
fn ms5611_prom_crc_and_isa_at_altitude() {
    let cfg = SimConfig {
        env: Environment {
            ground_altitude_m: 1000.0,
            ..Environment::default()
        },
        ..ideal()
    };
    let (_c, mut bus, mut d) = rig(cfg);
    bus.write(MS, &[0x1E]).unwrap();
    let mut b = [0u8; 2];
    assert!(
        bus.write_read(MS, &[0xA2], &mut b).is_err(),
        "NACK while reloading PROM"
    );
    d.delay_us(2800);
    let prom = ms_prom(&mut bus);
    assert_eq!(sim::ms5611::crc4(&prom), (prom[7] & 0xF) as u8);
    let d1 = ms_convert(&mut bus, &mut d, 0x48, 9040);
    let d2 = ms_convert(&mut bus, &mut d, 0x58, 9040);
    let (p, t) = sim::ms5611::compensate(&prom, d1, d2);
    assert!((p as f64 - 89_874.6).abs() <= 2.0, "{p}");
    assert!((t - 850).abs() <= 1, "{t}");
}

#[test]
fn ms5611_adc_read_too_early_or_twice_is_zero() {
    let (_c, mut bus, mut d) = rig(ideal());
    assert_eq!(
        ms_convert(&mut bus, &mut d, 0x00, 0),
        0,
        "no conversion started"
    );
    assert_eq!(
        ms_convert(&mut bus, &mut d, 0x48, 8000),
        0,
        "OSR 4096 needs 9.04 ms"
    );
    // That early read spoiled the conversion.
    d.delay_ms(2);
    let mut b = [0u8; 3];
    bus.write_read(MS, &[0x00], &mut b).unwrap();
    assert_eq!(b, [0; 3]);
    assert_ne!(
        ms_convert(&mut bus, &mut d, 0x40, 600),
        0,
        "OSR 256 takes 0.6 ms"
    );
    bus.write_read(MS, &[0x00], &mut b).unwrap();
    assert_eq!(b, [0; 3], "a result is read once");
    // Unknown command: data NACK.
    let e = bus.write(MS, &[0x41]).unwrap_err();
    assert_eq!(
        e.kind(),
        ErrorKind::NoAcknowledge(NoAcknowledgeSource::Data)
    );
}

#[test]
fn ms5611_noise_matches_datasheet_resolution() {
    let (_c, mut bus, mut d) = rig(SimConfig::default());
    let prom = ms_prom(&mut bus);
    for (osr, expect_pa) in [(0u8, 6.5), (4u8, 1.2)] {
        let n = 300;
        let mut ps = Vec::new();
        for _ in 0..n {
            let d1 = ms_convert(&mut bus, &mut d, 0x40 + 2 * osr, 9100);
            let d2 = ms_convert(&mut bus, &mut d, 0x50 + 2 * osr, 9100);
            ps.push(sim::ms5611::compensate(&prom, d1, d2).0 as f64);
        }
        let m = ps.iter().sum::<f64>() / n as f64;
        let sd = (ps.iter().map(|p| (p - m).powi(2)).sum::<f64>() / n as f64).sqrt();
        assert!(
            sd > 0.7 * expect_pa && sd < 1.4 * expect_pa,
            "osr {osr}: {sd}"
        );
    }
}

#[test]
fn faults_nack_stuck_midtransfer_arbitration() {
    let (_c, mut bus, _d) = rig(ideal());
    let mut b = [0u8; 4];
    bus.inject(Fault::Nack {
        address: MPU,
        transactions: Some(2),
    });
    for _ in 0..2 {
        let e = bus.write_read(MPU, &[0x75], &mut b[..1]).unwrap_err();
        assert_eq!(
            e.kind(),
            ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address)
        );
    }
    assert!(
        bus.write_read(MS, &[0xA0], &mut b[..2]).is_ok(),
        "other chips unaffected"
    );
    assert_eq!(rd(&mut bus, MPU, 0x75), 0x71);
    bus.inject(Fault::StuckBus);
    assert_eq!(
        bus.write(MPU, &[0x6B, 0]).unwrap_err().kind(),
        ErrorKind::Bus
    );
    assert_eq!(bus.write(MS, &[0x48]).unwrap_err().kind(), ErrorKind::Bus);
    bus.clear_faults();
    bus.inject(Fault::BusErrorMidTransfer { after_bytes: 3 });
    let e = bus.write_read(MPU, &[0x75], &mut b).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Bus);
    assert_eq!(b[0], 0x71, "bytes before the glitch got through");
    assert!(bus.write_read(MPU, &[0x75], &mut b).is_ok(), "one-shot");
    bus.inject(Fault::ArbitrationLoss { transactions: 1 });
    assert_eq!(
        bus.write(MPU, &[0x75]).unwrap_err().kind(),
        ErrorKind::ArbitrationLoss
    );
    bus.inject(Fault::WrongChipId {
        chip: Chip::Mpu9250,
        id: 0x73,
    });
    assert_eq!(rd(&mut bus, MPU, 0x75), 0x73);
    bus.clear_faults();
    assert_eq!(rd(&mut bus, MPU, 0x75), 0x71);
}

#[test]
fn faults_freeze_reset_vibration() {
    let (_c, mut bus, mut d) = rig(SimConfig::default());
    d.delay_ms(3);
    bus.inject(Fault::Frozen(Chip::Mpu9250));
    let a = burst14(&mut bus);
    d.delay_ms(3);
    assert_eq!(burst14(&mut bus), a);
    bus.clear_faults();
    d.delay_ms(3);
    assert_ne!(burst14(&mut bus), a);
    wr(&mut bus, MPU, mpu::GYRO_CONFIG, 0x08);
    bus.inject(Fault::ChipReset(Chip::Mpu9250));
    assert_eq!(rd(&mut bus, MPU, mpu::GYRO_CONFIG), 0);
    bus.inject(Fault::Vibration(Vibration {
        accel_amplitude_mps2: 10.0,
        gyro_amplitude_dps: 0.0,
        frequency_hz: 180.0,
    }));
    let mut max = 0i32;
    for _ in 0..50 {
        d.delay_ms(1);
        max = max.max((burst14(&mut bus)[0] as i32).abs());
    }
    assert!(max as f64 > 0.8 * 10.0 / G0_MPS2 * 16384.0, "{max}");
}

#[test]
fn transfers_take_bus_time() {
    let (clock, mut bus, _d) = rig(SimConfig::default());
    let t0 = clock.now_ns();
    let mut b = [0u8; 14];
    bus.write_read(MPU, &[0x3B], &mut b).unwrap();
    // 2 addresses + 15 bytes at 400 kHz ≈ 0.39 ms.
    let dt = clock.now_ns() - t0;
    assert!((350_000..450_000).contains(&dt), "{dt}");
}

/// A motion at rest except for a roll rate (°/s) and a specific force on
/// body x (m/s²) given as functions of time: what the DLPF tests feed in.
fn tone_motion(rate_dps: fn(f64) -> f64, force_mps2: fn(f64) -> f64) -> Trajectory {
    Trajectory::Motion(std::rc::Rc::new(move |t_s| {
        let mut s = Trajectory::at_rest().sample(t_s);
        s.omega_body_rps[0] = rate_dps(t_s).to_radians();
        s.specific_force_body_mps2[0] = force_mps2(t_s);
        s
    }))
}

/// Least-squares amplitude and phase (rad) of a sine of `f_hz` in `(t, y)`.
fn fit_sine(points: &[(f64, f64)], f_hz: f64) -> (f64, f64) {
    let (mut ss, mut cc, mut sc, mut ys, mut yc) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for &(t, y) in points {
        let (s, c) = (2.0 * std::f64::consts::PI * f_hz * t).sin_cos();
        ss += s * s;
        cc += c * c;
        sc += s * c;
        ys += y * s;
        yc += y * c;
    }
    let det = ss * cc - sc * sc;
    let p = (ys * cc - yc * sc) / det;
    let q = (yc * ss - ys * sc) / det;
    ((p * p + q * q).sqrt(), q.atan2(p))
}

/// Reads gyro x (°/s) and accelerometer x (m/s²) at every output sample
/// for `seconds`, with the given CONFIG, ACCEL_CONFIG2 and SMPLRT_DIV.
fn record(traj: Trajectory, regs: (u8, u8, u8), seconds: f64) -> Vec<(f64, f64, f64)> {
    let (clock, mut bus, _d) = rig(SimConfig {
        trajectory: traj,
        ..ideal()
    });
    wr(&mut bus, MPU, mpu::PWR_MGMT_1, 0x00);
    wr(&mut bus, MPU, mpu::CONFIG, regs.0);
    wr(&mut bus, MPU, mpu::ACCEL_CONFIG2, regs.1);
    wr(&mut bus, MPU, mpu::SMPLRT_DIV, regs.2);
    let mut out = Vec::new();
    while clock.now_s() < seconds {
        bus.advance_to_next_mpu_sample();
        let r = burst14(&mut bus);
        // ±250 °/s: 131 LSB per °/s; ±2 g: 16384 LSB per g; body x = MPU x.
        let t = bus.truth_at_last_mpu_sample().unwrap().t_s;
        let a = f64::from(r[0]) / 16384.0 * G0_MPS2;
        out.push((t, f64::from(r[4]) / 131.0, a));
    }
    out
}

#[test]
fn mpu_dlpf_delays_slow_motion_by_the_register_maps_delay() {
    // Register map rev 1.6: DLPF_CFG 3 = 41 Hz, 5.9 ms; A_DLPF_CFG 3 =
    // 44.8 Hz, 4.88 ms; DLPF_CFG 6 = 5 Hz, 33.48 ms; A_DLPF_CFG 6 = 5.05 Hz,
    // 32.48 ms. A tone at a twentieth of the bandwidth or less: its phase
    // lag is the delay (to 0.3 % for a first-order low-pass). Tolerance
    // 0.3 ms.
    fn one_hz() -> Trajectory {
        tone_motion(
            |t| 100.0 * (2.0 * std::f64::consts::PI * t).sin(),
            |t| 5.0 * (2.0 * std::f64::consts::PI * t).sin(),
        )
    }
    fn quarter_hz() -> Trajectory {
        tone_motion(
            |t| 100.0 * (0.5 * std::f64::consts::PI * t).sin(),
            |t| 5.0 * (0.5 * std::f64::consts::PI * t).sin(),
        )
    }
    let cases = [
        (3u8, 5.9, 4.88, one_hz(), 1.0),
        (6, 33.48, 32.48, quarter_hz(), 0.25),
    ];
    for (cfg, gyro_ms, accel_ms, traj, f_hz) in cases {
        let rec = record(traj, (cfg, cfg, 0), 1.0 + 2.0 / f_hz);
        let rec = &rec[1000..];
        let g: Vec<_> = rec.iter().map(|&(t, g, _)| (t, g)).collect();
        let a: Vec<_> = rec.iter().map(|&(t, _, a)| (t, a)).collect();
        let (_, pg) = fit_sine(&g, f_hz);
        let (_, pa) = fit_sine(&a, f_hz);
        let to_ms = |p: f64| -p / (2.0 * std::f64::consts::PI * f_hz) * 1e3;
        assert!(
            (to_ms(pg) - gyro_ms).abs() < 0.3,
            "gyro {cfg}: {} ms",
            to_ms(pg)
        );
        assert!(
            (to_ms(pa) - accel_ms).abs() < 0.3,
            "accel {cfg}: {} ms",
            to_ms(pa)
        );
    }
}

#[test]
fn mpu_sample_rate_divider_decimates_and_aliases() {
    // DLPF_CFG 1 (184 Hz at 1 kHz), SMPLRT_DIV 4: 200 samples a second,
    // each the filter's output at that instant. A 180 Hz rotation passes
    // the filter at about 0.7 of its amplitude and, sampled at 200 Hz,
    // appears at |180 − 200| = 20 Hz: the register map's divider does not
    // filter, so a frame's vibration above 100 Hz folds down.
    let rec = record(
        tone_motion(
            |t| 50.0 * (2.0 * std::f64::consts::PI * 180.0 * t).sin(),
            |_| 0.0,
        ),
        (1, 1, 4),
        2.0,
    );
    let dts: Vec<f64> = rec.windows(2).map(|w| w[1].0 - w[0].0).collect();
    assert!(
        dts.iter().all(|dt| (dt - 0.005).abs() < 1e-9),
        "{:?}",
        &dts[..3]
    );
    let g: Vec<_> = rec[50..].iter().map(|&(t, g, _)| (t, g)).collect();
    let (alias, _) = fit_sine(&g, 20.0);
    let (other, _) = fit_sine(&g, 37.0);
    assert!(alias > 0.6 * 50.0 && alias < 0.8 * 50.0, "{alias}");
    assert!(other < 1.0, "{other}");
}

#[test]
fn mpu_noise_passes_the_dlpf_with_its_noise_bandwidth() {
    // White noise through the 41 Hz low-pass: variance density² × π/2 ×
    // 41 Hz (a first-order low-pass's noise bandwidth), within 10 %.
    let errors = SensorErrors::datasheet(3);
    let density = errors.gyro_dps.noise_density;
    let (clock, mut bus, _d) = rig(SimConfig {
        errors,
        ..SimConfig::default()
    });
    wr(&mut bus, MPU, mpu::PWR_MGMT_1, 0x00);
    wr(&mut bus, MPU, mpu::CONFIG, 3);
    let mut x = Vec::new();
    while clock.now_s() < 20.0 {
        bus.advance_to_next_mpu_sample();
        x.push(f64::from(burst14(&mut bus)[4]) / 131.0);
    }
    let mean = x.iter().sum::<f64>() / x.len() as f64;
    let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / x.len() as f64;
    let expect = density * density * 41.0 * std::f64::consts::FRAC_PI_2;
    assert!((var / expect - 1.0).abs() < 0.1, "{var} vs {expect}");
}
