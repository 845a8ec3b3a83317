//! Instruction-count benchmarks on the emulated Cortex-M3.
//!
//! Every case runs its function a few times, each call between two marker
//! calls, [`bench_start`](suite::bench_start) and
//! [`bench_end`](suite::bench_end). Before a case's calls the binary prints
//! `BENCH <name> <calls>` through semihosting. `cargo xtask bench` runs the
//! binary in QEMU with one instruction per translation block and an execution
//! trace, counts the instructions between each pair of markers, assigns the
//! counts to the cases in order, and subtracts the `baseline` case (the
//! markers and the `black_box` plumbing with no work between them).
//!
//! Inputs pass through `core::hint::black_box` after the start marker and the
//! results (and the filter state) before the end marker, so the optimiser can
//! neither precompute the work nor move it outside the markers.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod rt;

#[cfg(target_os = "none")]
#[allow(unsafe_code)] // `no_mangle` markers (found by name in the ELF) and a volatile write
mod suite {
    use core::hint::black_box;

    use bench::{RawSample, SampleGen, SiSample, DT_S};
    use cortex_m as _;
    use cortex_m_semihosting::hprintln;

    /// Calls per case for our code, for the (slower) peers, and for VQF
    /// (f64: ~100k instructions a call). Odd, so the median is one call.
    const CALLS: usize = 7;
    const PEER_CALLS: usize = 5;
    const VQF_CALLS: usize = 3;
    /// Warm-up calls before the measured ones (outside the markers, but the
    /// trace still records them, so few), with the board still.
    const WARM_CALLS: usize = 4;

    static mut MARK: u32 = 0;

    /// Start marker. Its body differs from [`bench_end`]'s so the linker
    /// cannot merge the two into one address.
    #[unsafe(no_mangle)]
    #[inline(never)]
    pub extern "C" fn bench_start() {
        // SAFETY: single-threaded; a volatile write the optimiser must keep.
        unsafe { core::ptr::write_volatile(&raw mut MARK, 0x5354_4152) };
    }

    /// End marker.
    #[unsafe(no_mangle)]
    #[inline(never)]
    pub extern "C" fn bench_end() {
        // SAFETY: as above.
        unsafe { core::ptr::write_volatile(&raw mut MARK, 0x454E_4421) };
    }

    /// Runs `f(state, input)` once per input, each call between the markers.
    #[inline(always)]
    fn case<S, I, R>(name: &str, state: &mut S, inputs: &[I], f: impl FnMut(&mut S, &I) -> R) {
        case_full(name, state, inputs, |_, _| {}, f, |_| true);
    }

    /// [`case`], and prints `FAIL <name>` when a result does not satisfy
    /// `ok` (e.g. a filter update that did not take the path the row is
    /// meant to measure); `cargo xtask bench` then fails.
    #[inline(always)]
    fn case_checked<S, I, R>(
        name: &str,
        state: &mut S,
        inputs: &[I],
        f: impl FnMut(&mut S, &I) -> R,
        ok: impl Fn(&R) -> bool,
    ) {
        case_full(name, state, inputs, |_, _| {}, f, ok);
    }

    /// The general form: `setup(state, input)` runs before each call,
    /// outside the markers.
    #[inline(always)]
    fn case_full<S, I, R>(
        name: &str,
        state: &mut S,
        inputs: &[I],
        mut setup: impl FnMut(&mut S, &I),
        mut f: impl FnMut(&mut S, &I) -> R,
        ok: impl Fn(&R) -> bool,
    ) {
        hprintln!("BENCH {} {}", name, inputs.len());
        let mut all_ok = true;
        for input in inputs {
            setup(state, input);
            bench_start();
            let s = black_box(&mut *state);
            let i = black_box(input);
            let r = black_box(f(s, i));
            black_box(s);
            bench_end();
            all_ok &= ok(&r);
        }
        if !all_ok {
            hprintln!("FAIL {}: a call did not take the measured path", name);
        }
    }

    /// Filter inputs: a warm-up sample (the generator's first, gyro zeroed:
    /// the board held still where the measured motion starts) and `N`
    /// nominal samples (no disturbances) that follow it.
    fn filter_inputs<const N: usize>(seed: u32) -> (RawSample, [RawSample; N]) {
        let mut g = SampleGen::new(seed, false);
        let mut warm = g.next_sample();
        warm.gyro = [0; 3];
        (warm, core::array::from_fn(|_| g.next_sample()))
    }

    /// `N` nominal samples (no disturbances), SI units.
    fn samples<const N: usize>(seed: u32) -> [SiSample; N] {
        let mut g = SampleGen::new(seed, false);
        core::array::from_fn(|_| g.next_sample().to_si())
    }

    /// Runs every case in a fixed order (the order `cargo xtask bench`
    /// reads the `BENCH` lines in).
    #[unsafe(no_mangle)]
    extern "C" fn bench_main() -> ! {
        let unit = [(); CALLS];

        // Harness overhead, subtracted from every other case.
        case("baseline", &mut (), &unit, |_, _| ());
        // Self-test of the counting: exactly 100 instructions. Spelled out
        // line by line (not `.rept`): LLVM sizes inline asm by its lines
        // when it chooses branch encodings.
        macro_rules! nop10 {
            () => {
                "nop\nnop\nnop\nnop\nnop\nnop\nnop\nnop\nnop\nnop\n"
            };
        }
        case("selftest_100_nops", &mut (), &unit, |_, _| {
            // SAFETY: no operands, no side effects.
            unsafe {
                core::arch::asm!(
                    concat!(
                        nop10!(),
                        nop10!(),
                        nop10!(),
                        nop10!(),
                        nop10!(),
                        nop10!(),
                        nop10!(),
                        nop10!(),
                        nop10!(),
                        nop10!()
                    ),
                    options(nomem, nostack)
                )
            }
        });

        ms5611_cases();
        calibration_cases();
        filter_cases();
        control_cases();
        ahrs_cases();
        pipeline_cases();
        flight_control_cases();
        rc_cases();
        peer_cases();

        hprintln!("BENCH done 0");
        super::rt::exit(true)
    }

    /// The 1 kHz flight-control step (armed, flying) and its parts.
    fn flight_control_cases() {
        use control::loops::Quat;

        let q: [Quat; CALLS] = core::array::from_fn(|k| {
            Quat::from_euler(0.05 * k as f32 - 0.1, 0.02 * k as f32, 0.3 * k as f32)
        });
        level_and_mixer_cases(&q);
        rate_mixer_cases();
        flight_controller_cases(&q);
    }

    /// Names of the budgeted fixed-point rate-loop rows (see xtask's budgets).
    const RATE_MIX_Q_NAME: &str =
        "control::rateq rate loop + mixer, fixed (f32 in, Q16/Q30; unsaturated)";
    const RATE_MIX_Q_SAT_NAME: &str =
        "control::rateq rate loop + mixer, fixed (f32 in, Q16/Q30; saturated)";

    /// (setpoint, gyro) pairs for the rate-loop rows: roll setpoints of
    /// `big` × 0.5..1.1 rad/s against a slowly turning gyro.
    fn rate_inputs(
        big: f32,
    ) -> [(
        control::controllers::BodyRates,
        control::controllers::BodyRates,
    ); CALLS] {
        use control::controllers::BodyRates;
        core::array::from_fn(|k| {
            let k = k as f32;
            (
                BodyRates {
                    roll_rps: big * (0.5 + 0.1 * k),
                    pitch_rps: -0.3 * big,
                    yaw_rps: 0.2 + 0.01 * k,
                },
                BodyRates {
                    roll_rps: 0.1 * k - 0.2,
                    pitch_rps: 0.05,
                    yaw_rps: -0.02 * k,
                },
            )
        })
    }

    /// The per-sample rate loop and mixer, `f32` and fixed point, on the
    /// same inputs: rate setpoints and gyro rates as the flight controller
    /// holds them (`f32` rad/s), the fixed rows including the conversions
    /// to Q16 and the motor commands back to `f32`.
    fn rate_mixer_cases() {
        use control::controllers::BodyRates;
        use control::fixed::f32_to_q;
        use control::loops::{RateConfig, RateController};
        use control::mixer::{Mixer, MixerConfig};
        use control::rateq::{MixerQ, RateControllerQ};

        let (calm, hard) = (rate_inputs(0.4), rate_inputs(8.0));
        let (Ok(rf), Ok(mf), Ok(rq), Ok(mq)) = (
            RateController::new(RateConfig::default()),
            Mixer::new(MixerConfig::default()),
            RateControllerQ::new(&RateConfig::default(), DT_S),
            MixerQ::new(&MixerConfig::default()),
        ) else {
            return;
        };
        for (inputs, thr, sat, name_f, name_q) in [
            (
                &calm,
                0.5f32,
                false,
                "control rate loop + mixer, f32 (RateController::update + Mixer::mix; unsaturated)",
                RATE_MIX_Q_NAME,
            ),
            (
                &hard,
                0.9,
                true,
                "control rate loop + mixer, f32 (RateController::update + Mixer::mix; saturated)",
                RATE_MIX_Q_SAT_NAME,
            ),
        ] {
            let mut st = (rf, mf);
            let _ = st.0.update(&inputs[0].0, &inputs[0].1, DT_S); // D history
            case_checked(
                name_f,
                &mut st,
                inputs,
                |(r, m), (sp, g)| {
                    let t = r.update(sp, g, DT_S).unwrap_or_default();
                    m.mix(thr, &t)
                },
                |o| o.as_ref().is_ok_and(|o| o.saturated() == sat),
            );
            let mut st = (rq, mq);
            let q16 = |b: &BodyRates| [b.roll_rps, b.pitch_rps, b.yaw_rps].map(|v| f32_to_q(v, 16));
            let _ = st.0.update(q16(&inputs[0].0), q16(&inputs[0].1));
            let thr_q30 = f32_to_q(thr, 30);
            case_checked(
                name_q,
                &mut st,
                inputs,
                |(r, m), (sp, g)| {
                    let t = r.update(q16(sp), q16(g));
                    let o = m.mix(thr_q30, t);
                    (o.saturated(), o.motor_commands())
                },
                |o| o.0 == sat && o.1.iter().all(|&c| c > 0.0 && c <= 1.0),
            );
        }
    }

    /// The angle-mode outer loop and the mixer, the flight controller's
    /// costliest parts.
    fn level_and_mixer_cases(q: &[control::loops::Quat; CALLS]) {
        use control::controllers::TorqueCommand;
        use control::loops::{LevelConfig, LevelController, TiltQuat};
        use control::mixer::{Mixer, MixerConfig};
        use control::shaping::TiltSetpoint;

        if let Ok(mut level) = LevelController::new(LevelConfig::default()) {
            let tilt = TiltSetpoint {
                roll_rad: 0.2,
                pitch_rad: -0.1,
            };
            if let Ok(tq) = TiltQuat::new(&tilt) {
                case(
                    "control::loops::LevelController::rate_setpoint_q (1 kHz form)",
                    &mut level,
                    q,
                    |l, q| l.rate_setpoint_q(q, &tq, 0.5),
                );
            }
        }
        level_q_case(q);
        if let Ok(mut mixer) = Mixer::new(MixerConfig::default()) {
            let tq: [TorqueCommand; CALLS] = core::array::from_fn(|k| TorqueCommand {
                roll: 0.02 * k as f32 - 0.06,
                pitch: 0.01 * k as f32,
                yaw: 0.1 - 0.02 * k as f32,
            });
            case_checked(
                "control::mixer::Mixer::mix (unsaturated)",
                &mut mixer,
                &tq,
                |m, t| m.mix(0.5, t),
                |r| r.as_ref().is_ok_and(|o| !o.saturated()),
            );
            let sat: [TorqueCommand; CALLS] = core::array::from_fn(|k| TorqueCommand {
                roll: 0.1 * k as f32 - 0.3,
                pitch: 0.05 * k as f32 + 0.4,
                yaw: 0.6 - 0.1 * k as f32,
            });
            case_checked(
                "control::mixer::Mixer::mix (saturated)",
                &mut mixer,
                &sat,
                |m, t| m.mix(0.9, t),
                |r| r.as_ref().is_ok_and(|o| o.saturated()),
            );
        }
    }

    /// The self-level loop in fixed point on the same attitudes (converted
    /// to Q30 outside the measured call, as the pipeline holds them).
    fn level_q_case(q: &[control::loops::Quat; CALLS]) {
        use control::levelq::{LevelControllerQ, QuatQ30, TiltQ30};
        use control::loops::{LevelConfig, TiltQuat};
        use control::shaping::TiltSetpoint;

        let tilt = TiltSetpoint {
            roll_rad: 0.2,
            pitch_rad: -0.1,
        };
        let (Ok(mut level), Ok(tq)) = (
            LevelControllerQ::new(&LevelConfig::default()),
            TiltQuat::new(&tilt),
        ) else {
            return;
        };
        let tq = TiltQ30::new(&tq);
        let q30: [QuatQ30; CALLS] = core::array::from_fn(|k| QuatQ30::from_quat(&q[k]));
        case_checked(
            LEVEL_Q_NAME,
            &mut level,
            &q30,
            |l, q| l.rate_setpoint_q16(q, &tq),
            |r| r.is_ok(),
        );
    }

    /// Name of the budgeted fixed-point self-level row.
    const LEVEL_Q_NAME: &str = "control::levelq::LevelControllerQ::rate_setpoint_q16 (fixed)";

    /// `FlightController::step` armed and flying, in angle and acro mode.
    fn flight_controller_cases(q: &[control::loops::Quat; CALLS]) {
        use control::controllers::BodyRates;
        use control::loops::Quat;
        use control::shaping::Sticks;
        use flight::flightctl::{
            FlightController, FlightMode, FlightState, Motors, PilotInput, SystemStatus,
            VehicleState,
        };

        // (mode, row, throttle, roll stick, a new pilot frame every step):
        // the third drives the mixer into saturation (full throttle and a
        // full roll demand); the last moves the roll stick every step, so
        // each step shapes the sticks (a CRSF frame every 4-7 ms does).
        for (mode, name, throttle, roll, new_frames) in [
            (FlightMode::Angle, FC_ANGLE_NAME, 0.5, 0.3, false),
            (
                FlightMode::Acro,
                "flight::FlightController::step (armed, acro)",
                0.5,
                0.3,
                false,
            ),
            (FlightMode::Angle, FC_ANGLE_SATURATED_NAME, 0.95, 1.0, false),
            (FlightMode::Angle, FC_ANGLE_NEW_FRAME_NAME, 0.5, 0.3, true),
        ] {
            let Ok(mut fc) = FlightController::new(settings::flight_config()) else {
                continue;
            };
            let status = SystemStatus {
                sensors_healthy: true,
                gyro_bias_done: true,
                calibration_running: false,
                accel_calibrated: true,
            };
            let mut pilot = PilotInput {
                sticks: Sticks::default(),
                arm_switch: false,
                mode,
                link_ok: true,
                motor_test_switch: false,
            };
            let still = VehicleState::from_f32(&Quat::IDENTITY, &BodyRates::default(), None);
            // Arm (switch off → on), then fly at hover throttle.
            let mut now_us = 0u32;
            for k in 0..(2 + WARM_CALLS) {
                pilot.arm_switch = k > 0;
                pilot.sticks.throttle = if k > 1 { throttle } else { 0.0 };
                now_us += 1000;
                let _ = fc.step(now_us, &pilot, &status, &still);
            }
            pilot.sticks.roll = roll;
            let inputs: [(u32, VehicleState, PilotInput); CALLS] = core::array::from_fn(|k| {
                let mut p = pilot;
                if new_frames {
                    p.sticks.roll = roll + 0.01 * k as f32;
                }
                (
                    now_us + 1000 * (k as u32 + 1),
                    // Built before the timed calls: the firmware hands the
                    // pipeline's Q30/Q16 values over as they are.
                    VehicleState::from_f32(
                        &q[k],
                        &BodyRates {
                            roll_rps: 0.1 * k as f32,
                            pitch_rps: -0.05,
                            yaw_rps: 0.02,
                        },
                        None,
                    ),
                    p,
                )
            });
            case_checked(
                name,
                &mut fc,
                &inputs,
                |fc, (t, v, p)| fc.step(*t, p, &status, v),
                |o| o.state == FlightState::Armed && matches!(o.motors, Motors::Run(_)),
            );
        }
    }

    /// Names of the budgeted flight-control rows (see xtask's budgets).
    const FC_ANGLE_NAME: &str = "flight::FlightController::step (armed, angle)";
    const FC_ANGLE_SATURATED_NAME: &str =
        "flight::FlightController::step (armed, angle, mixer saturated)";
    const FC_ANGLE_NEW_FRAME_NAME: &str =
        "flight::FlightController::step (armed, angle, new pilot frame)";

    /// The gyro path's filters on three axes of a Q16 rad/s gyro, per
    /// sample, as the firmware runs them: the board's gyro filter
    /// (`settings::GYRO_FILTER`: a PT1 low-pass and a notch per axis,
    /// `sensor_stack::gyro_filter::GyroFilter`) and a PT1 on each axis' D
    /// term (the rate PIDs' D low-pass, at its 40 Hz default).
    fn filter_cases() {
        use filters::{Pt1, Pt1Q};
        use sensor_stack::gyro_filter::GyroFilter;
        let Ok(pt1) = Pt1::new(40.0, 1000.0) else {
            hprintln!("FAIL filters: a design was refused");
            return;
        };
        struct Path {
            gyro: GyroFilter,
            d: [Pt1Q; 3],
        }
        let mut p = Path {
            gyro: GyroFilter::new(&settings::GYRO_FILTER_DESIGN),
            d: [Pt1Q::new(&pt1); 3],
        };
        let s: [SiSample; CALLS] = samples(17);
        let gyro: [[i32; 3]; CALLS] = s.map(|s| s.gyro_rps.map(|w| (w * 65_536.0) as i32));
        case(FILTERS_NAME, &mut p, &gyro, |p, g| {
            let mut out = p.gyro.apply(*g);
            for (d, y) in p.d.iter_mut().zip(out.iter_mut()) {
                *y = d.apply(*y);
            }
            out
        });
    }

    /// Name of the budgeted gyro-path filter row (see xtask's budgets).
    const FILTERS_NAME: &str =
        "filters: gyro path per sample (the board's gyro filter, 3 x D-term PT1)";

    fn calibration_cases() {
        use calibration::{AccelCalibration, GyroBias, MagCalibration};
        let s: [SiSample; CALLS] = samples(11);
        let mut gyro = GyroBias {
            bias: [0.011, -0.007, 0.003],
        };
        case("calibration::GyroBias::apply", &mut gyro, &s, |c, s| {
            c.apply(s.gyro_rps)
        });
        let mut accel = AccelCalibration {
            offset: [0.12, -0.08, 0.21],
            scale: [1.003, 0.998, 1.011],
        };
        case(
            "calibration::AccelCalibration::apply",
            &mut accel,
            &s,
            |c, s| c.apply(s.accel_mps2),
        );
        let mut mag = MagCalibration {
            offset: [3.5, -7.25, 11.0],
            soft_iron: [
                [1.02, 0.013, -0.021],
                [0.013, 0.97, 0.008],
                [-0.021, 0.008, 1.01],
            ],
        };
        case(
            "calibration::MagCalibration::apply",
            &mut mag,
            &s,
            |c, s| c.apply(s.mag_ut),
        );
        // The same correction folded with 0.15 µT counts into 1/16 µT, as
        // `flight`'s mag_step applies it.
        let m = mag.soft_iron.map(|r| r.map(|v| v * 0.15 * 16.0));
        let mut mag_q =
            calibration::MagCalibrationQ16::from_affine(m, mag.offset.map(|o| o / 0.15))
                .unwrap_or_default();
        let counts: [[i32; 3]; CALLS] = s.map(|s| s.mag_ut.map(|u| (u / 0.15) as i32));
        case(
            "calibration::MagCalibrationQ16::apply (pipeline form)",
            &mut mag_q,
            &counts,
            |c, m| c.apply(*m),
        );
    }

    fn ms5611_cases() {
        use ms5611::{compensate, Prom};
        let prom = Prom::from_coefficients(bench::check::MS5611_DATASHEET_C);
        // Around the datasheet's example (20.07 °C, 1000.09 mbar): the
        // first-order path (no low-temperature correction), as in flight.
        let mut rng = bench::Rng::new(51);
        let raw: [(u32, u32); CALLS] = core::array::from_fn(|_| {
            (
                9_085_466u32.wrapping_add_signed(rng.symmetric(20_000)),
                8_569_150 + rng.symmetric(20_000).unsigned_abs(),
            )
        });
        case("ms5611::compensate", &mut (), &raw, |_, &(d1, d2)| {
            compensate(&prom, d1, d2)
        });
    }

    fn control_cases() {
        use control::baro::{altitude_m, CheapBaro};
        use control::pid::{Pid, PidConfig};
        // Pressures around 960 hPa, integer pascals as the MS5611 delivers.
        let mut rng = bench::Rng::new(21);
        let p_pa: [i32; CALLS] = core::array::from_fn(|_| 96_000 + rng.symmetric(2_000));
        let p0_pa = 98_000.0f32;
        case(
            "control::baro::altitude_m (exact)",
            &mut (),
            &p_pa,
            |_, &p| altitude_m(p as f32, p0_pa),
        );
        if let Ok(mut cheap) = CheapBaro::new(p0_pa) {
            case(
                "control::baro::CheapBaro::height_m",
                &mut cheap,
                &p_pa,
                |b, &p| b.height_m(p),
            );
        }
        let cfg = PidConfig::new(0.8, 0.3, 0.05)
            .with_d_cutoff_hz(30.0)
            .with_output_limits(-0.5, 0.5)
            .with_integral_limits(-0.2, 0.2);
        if let Ok(mut pid) = Pid::new(cfg) {
            // One warm-up step so the derivative has a previous measurement.
            let _ = pid.update(0.1, 0.0, DT_S);
            let meas: [f32; CALLS] = core::array::from_fn(|k| 0.01 * k as f32 - 0.02);
            case("control::pid::Pid::update", &mut pid, &meas, |pid, &m| {
                pid.update(0.1, m, DT_S)
            });
        }
    }

    /// Pilot input: the CRSF receive interrupt's worst byte (the one that
    /// completes a frame: CRC, unpacking, µs conversion) and a typical one,
    /// the PPM sync that completes a frame, and the stick mapping.
    fn rc_cases() {
        use rc_input::crsf::{encode_rc_channels, ADDRESS_FLIGHT_CONTROLLER};
        use rc_input::{ChannelMap, CrsfParser, PpmDecoder, RcFrame};
        let mut rng = bench::Rng::new(61);
        let frames: [[u8; 26]; CALLS] = core::array::from_fn(|_| {
            let ticks: [u16; 16] =
                core::array::from_fn(|_| (992 + rng.symmetric(800)).clamp(172, 1811) as u16);
            encode_rc_channels(ADDRESS_FLIGHT_CONTROLLER, &ticks)
        });
        let feed = |p: &mut CrsfParser, bytes: &[u8]| {
            p.clear();
            for (i, &b) in bytes.iter().enumerate() {
                let _ = p.push(b, 24 * i as u32);
            }
        };
        let mut parser = CrsfParser::new();
        case_full(
            "rc_input::CrsfParser::push (byte completing an RC frame)",
            &mut parser,
            &frames,
            |p, f| feed(p, &f[..25]),
            |p, f| p.push(f[25], 600),
            |r| r.is_some(),
        );
        case_full(
            "rc_input::CrsfParser::push (byte inside a frame)",
            &mut parser,
            &frames,
            |p, f| feed(p, &f[..12]),
            |p, f| p.push(f[12], 288),
            |r| r.is_none(),
        );
        let channels: [[u32; 8]; CALLS] =
            core::array::from_fn(|_| core::array::from_fn(|_| (1500 + rng.symmetric(480)) as u32));
        let mut ppm = PpmDecoder::new();
        case_full(
            "rc_input::PpmDecoder::push_interval_us (sync completing 8 channels)",
            &mut ppm,
            &channels,
            |d, ch| {
                d.clear();
                for _ in 0..3 {
                    let _ = d.push_interval_us(10_000);
                    for &c in ch {
                        let _ = d.push_interval_us(c);
                    }
                }
            },
            |d, _| d.push_interval_us(10_000),
            |r| r.is_some(),
        );
        let rc: [RcFrame; CALLS] = channels.map(|ch| {
            let mut us = [1500u16; 16];
            for (u, c) in us.iter_mut().zip(ch) {
                *u = c as u16;
            }
            RcFrame::new(us, 8)
        });
        let map = ChannelMap::DEFAULT;
        case_checked(
            "rc_input::ChannelMap::sticks + arm_switch",
            &mut (),
            &rc,
            |_, f| (map.sticks(f), map.arm_switch(f)),
            |(s, a)| s.is_ok() && a.is_ok(),
        );
    }

    fn ahrs_cases() {
        use bench::{features_on, plain, FixedSample};
        let (warm_raw, raw) = filter_inputs::<CALLS>(31);
        let s = raw.map(|r| r.to_si());
        let fx: [FixedSample; CALLS] = raw.map(|r| r.to_fixed());

        // Steady state: no start-up gain ramp (`startup_s` = 0; the filters
        // start aligned by `from_accel_mag`), everything else as configured.
        // (Warming up through a 3 s ramp would cost millions of traced
        // instructions; large warm-up steps make the ramp's β·dt unstable.)
        let steady = |mut c: fc_ahrs::Config| {
            c.startup_s = 0.0;
            c
        };
        for (on, cfg) in [(true, steady(features_on())), (false, steady(plain()))] {
            f32_filter_cases(on, cfg, &warm_raw.to_si(), &s);
            fixed_filter_cases(filter_names(on), cfg, &warm_raw.to_fixed(), &fx);
        }
        let multirotor = [
            "fc_ahrs::MadgwickFixed MARG (multirotor)",
            "fc_ahrs::MadgwickFixed IMU (multirotor)",
        ];
        fixed_filter_cases(
            multirotor,
            steady(bench::multirotor()),
            &warm_raw.to_fixed(),
            &fx,
        );
    }

    /// The fixed-point filter's MARG and IMU row names, rejection on (`on`) or
    /// the textbook filter.
    fn filter_names(on: bool) -> [&'static str; 2] {
        [
            filter_name(
                on,
                "fc_ahrs::MadgwickFixed MARG (rejection on)",
                "fc_ahrs::MadgwickFixed MARG (textbook)",
            ),
            filter_name(
                on,
                "fc_ahrs::MadgwickFixed IMU (rejection on)",
                "fc_ahrs::MadgwickFixed IMU (textbook)",
            ),
        ]
    }

    /// Row name for the filter with rejection on (`on`) or the textbook one.
    fn filter_name(on: bool, on_name: &'static str, plain_name: &'static str) -> &'static str {
        if on {
            on_name
        } else {
            plain_name
        }
    }

    // The f32 and fixed-point functions repeat each other's shape on purpose:
    // the filters take different input types, and each is one pair of rows
    // of BENCHMARKS.md's table.
    /// The f32 filter, MARG and IMU: warmed up on `w`, measured on `s`.
    fn f32_filter_cases(on: bool, cfg: fc_ahrs::Config, w: &SiSample, s: &[SiSample; CALLS]) {
        use fc_ahrs::{Madgwick, UpdatePath};
        let mut f = Madgwick::from_accel_mag(cfg, w.accel_mps2, w.mag_ut);
        for _ in 0..WARM_CALLS {
            f.update_marg(w.gyro_rps, w.accel_mps2, w.mag_ut, DT_S);
        }
        let mut imu = f.clone();
        case_checked(
            filter_name(
                on,
                "fc_ahrs::Madgwick f32 MARG (rejection on)",
                "fc_ahrs::Madgwick f32 MARG (textbook)",
            ),
            &mut f,
            s,
            |f, s| f.update_marg(s.gyro_rps, s.accel_mps2, s.mag_ut, DT_S),
            |st| st.path == UpdatePath::Marg,
        );
        case_checked(
            filter_name(
                on,
                "fc_ahrs::Madgwick f32 IMU (rejection on)",
                "fc_ahrs::Madgwick f32 IMU (textbook)",
            ),
            &mut imu,
            s,
            |f, s| f.update_imu(s.gyro_rps, s.accel_mps2, DT_S),
            |st| st.path == UpdatePath::Imu,
        );
    }

    /// The fixed-point filter on raw counts, MARG and IMU (rows `names`):
    /// warmed up on `w`, measured on `fx`.
    fn fixed_filter_cases(
        names: [&'static str; 2],
        cfg: fc_ahrs::Config,
        w: &bench::FixedSample,
        fx: &[bench::FixedSample; CALLS],
    ) {
        use fc_ahrs::fixed::{dt_us_to_q31, FixedConfig, MadgwickFixed};
        use fc_ahrs::UpdatePath;
        let dt_q31 = dt_us_to_q31(1000);
        let fcfg = FixedConfig::from_config(&bench::counts_config(cfg));
        let mut f = MadgwickFixed::from_accel_mag(fcfg, w.accel, w.mag);
        for _ in 0..WARM_CALLS {
            f.update_marg(w.gyro_rps_q20, w.accel, w.mag, dt_q31);
        }
        let mut imu = f.clone();
        case_checked(
            names[0],
            &mut f,
            fx,
            |f, s| f.update_marg(s.gyro_rps_q20, s.accel, s.mag, dt_q31),
            |st| st.path == UpdatePath::Marg,
        );
        case_checked(
            names[1],
            &mut imu,
            fx,
            |f, s| f.update_imu(s.gyro_rps_q20, s.accel, dt_q31),
            |st| st.path == UpdatePath::Imu,
        );
    }

    /// `sensor_stack::pipeline::Pipeline` as the firmware schedules it (default
    /// features: the fixed-point AHRS): per 10 ms, ten 1 kHz `imu_step`s,
    /// one magnetometer and one barometer sample and one `control_step`.
    fn pipeline_cases() {
        use sensor_stack::pipeline::Pipeline;
        let (warm, frames) = pipeline_frames();

        // The board's pipeline (its gyro filter among it).
        let mut cfg = settings::pipeline_config();
        // Our generator's scales (±8 g: 4096 counts/g; ±1000 °/s).
        cfg.accel_g_per_lsb = 1.0 / bench::ACCEL_LSB_PER_G as f32;
        cfg.gyro_dps_per_lsb = 10.0 / bench::GYRO_LSB_PER_DPS_X10 as f32;
        // Steady state (see `ahrs_cases`).
        cfg.ahrs.startup_s = 0.0;
        let Ok(mut p) = Pipeline::new(cfg, &Default::default()) else {
            hprintln!("FAIL sensor_stack::pipeline::Pipeline::new refused the configuration");
            return;
        };
        // The take-off pressure reference first, so the vertical estimator
        // and the altitude hold run in the measured control steps.
        for _ in 0..sensor_stack::pipeline::P0_AVERAGE_SAMPLES {
            p.baro_step(96_000);
        }
        for f in &warm {
            run_frame(&mut p, f);
        }
        if p.outputs().baro_samples == 0 {
            hprintln!("FAIL flight pipeline: no barometer reference after the warm-up");
        }
        case(FRAME_NAME, &mut p, &frames, |p, f| {
            run_frame(p, f);
            p.outputs()
        });
        pipeline_step_cases(&mut p, &frames);
        hprintln!("NOTE pipeline AHRS: {}", sensor_stack::pipeline::AHRS_KIND);
    }

    const FRAMES: usize = 3;
    const SAMPLES_PER_FRAME: usize = 10;
    const WARM_FRAMES: usize = 2;
    /// One 10 ms frame: ten IMU samples, one magnetometer sample (AK8963
    /// frame, counts), one pressure (Pa).
    type Frame = (
        [sensor_stack::pipeline::ImuInput; SAMPLES_PER_FRAME],
        [i16; 3],
        i32,
    );

    /// One frame as the firmware schedules it: the magnetometer and the
    /// barometer, ten IMU steps, and the control step they ask for.
    fn run_frame(p: &mut sensor_stack::pipeline::Pipeline, f: &Frame) {
        p.mag_step(f.1);
        p.baro_step(f.2);
        let mut control = false;
        for s in &f.0 {
            control |= p.imu_step(s);
        }
        if control {
            p.control_step();
        }
    }

    /// Warm-up and measured frames from the generator, in the sensors' own
    /// frames as the drivers deliver them.
    fn pipeline_frames() -> ([Frame; WARM_FRAMES], [Frame; FRAMES]) {
        use sensor_stack::pipeline::ImuInput;
        // Our generator's body-FRD counts → the sensors' own frames (default
        // mounting: body = (x, −y, −z) of the MPU; AK8963: x_ak = y_mpu,
        // y_ak = x_mpu, z_ak = −z_mpu).
        let to_input = |r: &RawSample| ImuInput {
            accel: [
                r.accel[0],
                r.accel[1].saturating_neg(),
                r.accel[2].saturating_neg(),
            ],
            gyro: [
                r.gyro[0],
                r.gyro[1].saturating_neg(),
                r.gyro[2].saturating_neg(),
            ],
            dt_cycles: 72_000,
        };
        let to_ak = |r: &RawSample| [r.mag[1].saturating_neg(), r.mag[0], r.mag[2]];
        let mut g = SampleGen::new(61, false);
        let mut rng = bench::Rng::new(62);
        let mut frame = || -> Frame {
            let raw: [RawSample; SAMPLES_PER_FRAME] = core::array::from_fn(|_| g.next_sample());
            (
                raw.map(|r| to_input(&r)),
                to_ak(&raw[0]),
                96_000 + rng.symmetric(30),
            )
        };
        let warm: [Frame; WARM_FRAMES] = core::array::from_fn(|_| frame());
        let frames: [Frame; FRAMES] = core::array::from_fn(|_| frame());
        (warm, frames)
    }

    /// The pipeline's steps one by one, on the frames' samples.
    fn pipeline_step_cases(p: &mut sensor_stack::pipeline::Pipeline, frames: &[Frame; FRAMES]) {
        use sensor_stack::pipeline::ImuInput;
        let inputs: [ImuInput; CALLS] = core::array::from_fn(|k| frames[k % FRAMES].0[k / FRAMES]);
        case(
            "sensor_stack::Pipeline::imu_step (1 kHz, MARG)",
            p,
            &inputs,
            |p, s| p.imu_step(s),
        );
        let mags: [[i16; 3]; FRAMES] = frames.map(|f| f.1);
        case(
            "sensor_stack::Pipeline::mag_step (100 Hz)",
            p,
            &mags,
            |p, m| p.mag_step(*m),
        );
        let baros: [i32; FRAMES] = frames.map(|f| f.2);
        case(
            "sensor_stack::Pipeline::baro_step (100 Hz)",
            p,
            &baros,
            |p, b| p.baro_step(*b),
        );
        // Each control step after its ten IMU steps (run outside the markers).
        case_full(
            "sensor_stack::Pipeline::control_step (100 Hz)",
            p,
            frames,
            |p, f| {
                for s in &f.0 {
                    p.imu_step(s);
                }
            },
            |p, _| p.control_step(),
            |_| true,
        );
    }

    /// Name of the 10 ms frame case (`cargo xtask bench` derives the
    /// per-sample row from it).
    const FRAME_NAME: &str = "flight pipeline: 10 ms frame (10 IMU + mag + baro + control)";

    fn peer_cases() {
        let (warm_raw, raw) = filter_inputs::<PEER_CALLS>(41);
        let s = raw.map(|r| r.to_si());
        let warm = [warm_raw.to_si(); WARM_CALLS];
        peer_ahrs_cases(&s, &warm);
        peer_imu_fusion_cases(&s, &warm);
        peer_vqf_cases(&s, &warm);
    }

    /// `ahrs` 0.8 (nalgebra, f32): Madgwick, MARG and IMU.
    fn peer_ahrs_cases(s: &[SiSample; PEER_CALLS], warm: &[SiSample; WARM_CALLS]) {
        use peer_ahrs::{Ahrs, Madgwick};
        use peer_nalgebra::Vector3;
        let v = Vector3::from;
        let warmed = || {
            let mut f = Madgwick::new(DT_S, 0.1f32);
            for w in warm {
                let _ = f.update(&v(w.gyro_rps), &v(w.accel_mps2), &v(w.mag_ut));
            }
            f
        };
        let (mut f, mut imu) = (warmed(), warmed());
        case("peer ahrs 0.8 Madgwick f32 MARG", &mut f, s, |f, s| {
            f.update(&v(s.gyro_rps), &v(s.accel_mps2), &v(s.mag_ut))
                .copied()
        });
        case("peer ahrs 0.8 Madgwick f32 IMU", &mut imu, s, |f, s| {
            f.update_imu(&v(s.gyro_rps), &v(s.accel_mps2)).copied()
        });
    }

    /// `imu-fusion` 0.2 (x-io Fusion port, f32): the AHRS core only.
    fn peer_imu_fusion_cases(s: &[SiSample; PEER_CALLS], warm: &[SiSample; WARM_CALLS]) {
        use imu_fusion::{FusionAhrs, FusionAhrsSettings, FusionConvention, FusionVector};
        const DEG_PER_RAD: f32 = 57.295_78;
        let gyr = |s: &SiSample| {
            let [x, y, z] = s.gyro_rps;
            FusionVector::new(x * DEG_PER_RAD, y * DEG_PER_RAD, z * DEG_PER_RAD)
        };
        let acc = |s: &SiSample| {
            let [x, y, z] = s.accel_mps2.map(|a| a / bench::G_MPS2);
            FusionVector::new(x, y, z)
        };
        let mag = |s: &SiSample| {
            let [x, y, z] = s.mag_ut;
            FusionVector::new(x, y, z)
        };
        // NED convention (our body frame is FRD), rejection active as in
        // x-io's examples (10°, recovery after 5 s); warmed up past its
        // fixed 3 s initialisation (the board is still and the filter
        // starts aligned, so large steps are harmless here).
        let settings = || FusionAhrsSettings {
            convention: FusionConvention::NED,
            gain: 0.5,
            gyr_range: 2000.0,
            acc_rejection: 10.0,
            mag_rejection: 10.0,
            recovery_trigger_period: 5000,
        };
        let warmed = |mag_too: bool| {
            let mut f = FusionAhrs::new();
            f.update_settings(settings());
            for w in warm {
                if mag_too {
                    f.update(gyr(w), acc(w), mag(w), 0.9);
                } else {
                    f.update_no_mag(gyr(w), acc(w), 0.9);
                }
            }
            f
        };
        let (mut f, mut imu) = (warmed(true), warmed(false));
        if f.flags().initializing || imu.flags().initializing {
            hprintln!("FAIL imu-fusion still initialising after the warm-up");
        }
        // Unit conversions happen before the start marker.
        let conv: [(FusionVector, FusionVector, FusionVector); PEER_CALLS] =
            core::array::from_fn(|k| (gyr(&s[k]), acc(&s[k]), mag(&s[k])));
        case(
            "peer imu-fusion 0.2 f32 MARG",
            &mut f,
            &conv,
            |f, &(g, a, m)| f.update(g, a, m, DT_S),
        );
        case(
            "peer imu-fusion 0.2 f32 IMU",
            &mut imu,
            &conv,
            |f, &(g, a, _)| f.update_no_mag(g, a, DT_S),
        );
    }

    /// `vqf-rs` 0.3 (VQF, f64 internals), default parameters.
    fn peer_vqf_cases(s: &[SiSample; PEER_CALLS], warm: &[SiSample; WARM_CALLS]) {
        use vqf_rs::VQF;
        let f64x3 = |v: [f32; 3]| v.map(f64::from);
        let warmed = || {
            let mut f = VQF::new(f64::from(DT_S), None, None, None);
            for w in warm.iter().take(1) {
                f.update(
                    f64x3(w.gyro_rps),
                    f64x3(w.accel_mps2),
                    Some(f64x3(w.mag_ut)),
                );
            }
            f
        };
        let (mut f, mut imu) = (warmed(), warmed());
        let conv: [([f64; 3], [f64; 3], [f64; 3]); VQF_CALLS] = core::array::from_fn(|k| {
            (
                f64x3(s[k].gyro_rps),
                f64x3(s[k].accel_mps2),
                f64x3(s[k].mag_ut),
            )
        });
        case(
            "peer vqf-rs 0.3 f64 MARG",
            &mut f,
            &conv,
            |f, &(g, a, m)| {
                f.update(g, a, Some(m));
                f.quat_9d()
            },
        );
        case(
            "peer vqf-rs 0.3 f64 IMU",
            &mut imu,
            &conv,
            |f, &(g, a, _)| {
                f.update(g, a, None);
                f.quat_6d()
            },
        );
    }
}

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!("bench runs on thumbv7m-none-eabi under qemu-system-arm: use `cargo xtask bench`");
}
