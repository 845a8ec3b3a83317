//! Flight-controller sensor app for the STM32F103C8 "Blue Pill": a thin RTIC
//! 2 shell around the hardware-free logic in the `flight` crate.
//!
//! * Boot: 72 MHz from the 8 MHz HSE, DWT cycle counter, I2C1 on PB6/PB7 at
//!   400 kHz, probe of the MPU-9250, AK8963 and MS5611 with bounded retries
//!   (`flight::sensors::Sensors::boot`); a missing chip degrades the stack
//!   (no barometer → no altitude, no magnetometer → IMU-only AHRS).
//!   Calibration from the flash page at `0x0800_FC00` (defaults + reason if
//!   blank or corrupt).
//! * `imu` (EXTI9_5 on PB5, priority 3): per MPU-9250 data-ready (1 kHz):
//!   burst read, `Pipeline::imu_step` with dt from DWT CYCCNT, magnetometer
//!   every 10th sample, control step at 100 Hz, loop timing.
//! * `baro` (priority 2): polls the MS5611 schedule at its deadlines (never
//!   blocks), checks chip configuration every 50 ms (a chip that reset
//!   itself is re-initialised), recovers a stuck bus (SCL clocked by hand,
//!   I2C1 reset).
//! * `log` (priority 1, 20 Hz): attitude, altitude, health, loop timing,
//!   stack high-water mark over defmt-RTT; the PA0 button; calibration
//!   progress and saving; the watchdog (IWDG 250 ms) is fed only while the
//!   IMU loop makes progress.
//!
//! Button PA0 (to GND, internal pull-up): held at reset → accelerometer
//! six-position calibration; long press (≥ 1.5 s) → magnetometer
//! figure-eight; short press → raw-log mode on/off (CSV order of the BROAD
//! recordings, 100 Hz), or abort a calibration.
//!
//! Safety: there are no motor outputs yet (controller outputs are only
//! logged). On a panic the handler turns the LED off, logs the location
//! over defmt and traps into HardFault, which waits for the watchdog reset.
//!
//! Flash: 48,452 B of the 48 KiB budget (`cargo fw && cargo xtask size`,
//! release profile at `opt-level = "z"`); static RAM 3.8 KiB. To fit, the
//! I2C master is our own register-level driver (`bus.rs`) rather than the
//! HAL's blocking one, and the magnetometer calibration on the board is the
//! per-axis min/max (the `MagCal` type below: one line selects the full
//! ellipsoid fit, ~6.4 KiB more, which does not fit the budget yet).
#![no_std]
#![no_main]
#![deny(unsafe_code)]

mod bus;
mod delay;
mod stack;
mod store;

use defmt_rtt as _;

/// Turns the LED (PC13, active low) off.
fn led_off() {
    // SAFETY: BSRR is GPIOC's write-only set/reset register; setting only
    // PC13 is atomic and touches no other pin. Used on the fault paths,
    // where nothing else runs any more.
    #[allow(unsafe_code)]
    unsafe {
        (*stm32f1xx_hal::pac::GPIOC::ptr())
            .bsrr()
            .write(|w| w.bits(1 << 13))
    };
}

/// Panic: outputs to a safe state (LED off; there are no motor outputs
/// yet), the location over defmt (no `core::fmt`: the message is not
/// formatted, which keeps ~4 KiB of formatting code out of flash), then a
/// trap: probe-rs halts and shows the backtrace; without a probe the
/// HardFault handler waits for the watchdog reset.
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    led_off();
    match info.location() {
        Some(l) => defmt::error!("PANIC at {=str}:{=u32}", l.file(), l.line()),
        None => defmt::error!("PANIC"),
    }
    cortex_m::asm::udf()
}

/// HardFault (also reached from a panic): LED off, then wait for the
/// independent watchdog to reset the MCU.
#[allow(unsafe_code)]
#[cortex_m_rt::exception]
unsafe fn HardFault(_frame: &cortex_m_rt::ExceptionFrame) -> ! {
    led_off();
    loop {
        cortex_m::asm::nop();
    }
}

#[rtic::app(device = stm32f1xx_hal::pac, dispatchers = [USART1, USART2])]
mod app {
    use crate::bus::{self, BusHandle};
    use crate::delay::{AsmDelay, CPU_HZ};
    use crate::stack;
    use crate::store::FlashPage;
    use cortex_m::peripheral::DWT;
    use flight::boot::{BiasStatus, StartupGyroBias};
    use flight::calmode::{AccelCalMode, Button, Mode, RawLogRow, RAW_LOG_DIVIDER, RAW_LOG_HEADER};

    /// Magnetometer calibration used on the board: per-axis min/max.
    /// `flight::calmode::MagCalMode` (the ellipsoid fit with integer
    /// moments and an f32 solve) is the full alternative: swap this one
    /// line (6.4 KiB more flash: 55,056 B, over the 48 KiB budget).
    type MagCal = flight::calmode::MagMinMaxMode;

    fn new_mag_cal() -> Option<MagCal> {
        MagCal::standard().ok()
    }
    use flight::health::{HealthCounters, SensorState};
    use flight::pipeline::{ImuInput, Pipeline, PipelineConfig, G_MPS2};
    use flight::schedule::{
        DtClock, LoopStats, MicrosClock, Periodic, SampleScheduler, WatchdogGate, IMU_RATE_HZ,
        MAG_DIVIDER,
    };
    use flight::sensors::{MagRead, Sensors, SensorsConfig};
    use flight::storage::{self, CalibrationRecord, LoadError, LoadOutcome, SaveError, ValidParts};
    use rtic_monotonics::fugit::ExtU32;
    use rtic_monotonics::systick::prelude::*;
    use stm32f1xx_hal::{
        flash,
        gpio::{Edge, ExtiPin, Input, Output, PinState, PullUp, PushPull, PA0, PB5, PC13},
        pac,
        prelude::*,
        rcc,
        watchdog::IndependentWatchdog,
    };

    systick_monotonic!(Mono, 1_000);

    /// Calibration sessions in progress (fed by `imu`, finished by `log`).
    pub struct CalState {
        mag: Option<MagCal>,
        accel: Option<AccelCalMode>,
    }

    /// Things `imu` reports to `log`.
    #[derive(Default)]
    pub struct Status {
        bias: Option<BiasStatus>,
    }

    #[shared]
    struct Shared {
        sensors: Sensors<BusHandle>,
        pipeline: Option<Pipeline>,
        clock: MicrosClock,
        stats: LoopStats,
        mode: Mode,
        cal: CalState,
        status: Status,
    }

    #[local]
    struct Local {
        led: PC13<Output<PushPull>>,
        mpu_int: PB5<Input<PullUp>>,
        button_pin: PA0<Input<PullUp>>,
        iwdg: IndependentWatchdog,
        flash: flash::Parts,
        record: CalibrationRecord,
        bias: Option<StartupGyroBias>,
        accel_g_per_lsb: f32,
        imu_present: bool,
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        stack::paint();
        let mut core = cx.core;
        let dp: pac::Peripherals = cx.device;
        let mut flash = dp.FLASH.constrain();
        // 8 MHz HSE -> PLL x9 -> 72 MHz SYSCLK; APB1 (I2C1) at its 36 MHz maximum.
        // The register values are written out (what `rcc::Config::hse(8 MHz)
        // .sysclk(72 MHz).pclk1(36 MHz)` computes) so the clock-tree search
        // code is not linked.
        let clocks = rcc::RawConfig {
            hse: Some(8_000_000),
            hse_bypass: false,
            pllmul: Some(9 - 2),
            hpre: rcc::HPre::Div1,
            ppre1: rcc::PPre::Div2,
            ppre2: rcc::PPre::Div1,
            usbpre: rcc::UsbPre::Div1_5,
            adcpre: rcc::AdcPre::Div6,
            allow_overclock: false,
        };
        let mut rcc = dp.RCC.constrain().freeze(clocks, &mut flash.acr);
        // DWT CYCCNT: AHRS dt, loop timing, and the HAL's I2C timeouts.
        core.DCB.enable_trace();
        core.DWT.enable_cycle_counter();
        let mut afio = dp.AFIO.constrain(&mut rcc);
        Mono::start(core.SYST, rcc.clocks.sysclk().to_Hz());

        let mut gpioa = dp.GPIOA.split(&mut rcc);
        let mut gpiob = dp.GPIOB.split(&mut rcc);
        let mut gpioc = dp.GPIOC.split(&mut rcc);
        // The Blue Pill LED is active low: start with it off.
        let led = gpioc
            .pc13
            .into_push_pull_output_with_state(&mut gpioc.crh, PinState::High);
        let button_pin = gpioa.pa0.into_pull_up_input(&mut gpioa.crl);

        // I2C1 on PB6 (SCL) / PB7 (SDA), 400 kHz fast mode, driven by
        // `bus`'s register-level master: every wait is bounded by a DWT
        // timeout, so a stuck bus returns an error instead of hanging.
        bus::init(&rcc);
        defmt::info!(
            "boot: 72 MHz, I2C1 400 kHz on PB6/PB7, MPU INT on PB5, AHRS: {=str}",
            flight::pipeline::AHRS_KIND
        );

        let (sensors, report) = Sensors::boot(
            BusHandle,
            BusHandle,
            BusHandle,
            &mut AsmDelay,
            SensorsConfig::default(),
        );
        for r in [report.mpu, report.mag, report.baro] {
            match r.status {
                Ok(()) => defmt::info!("probe {}: ok ({=u8} attempt(s))", r.chip, r.attempts),
                Err(f) => defmt::error!(
                    "probe {}: FAILED after {=u8} attempt(s): {}",
                    r.chip,
                    r.attempts,
                    f
                ),
            }
        }
        let caps = report.capabilities();
        defmt::info!(
            "capabilities: AHRS {} (ImuOnly: heading drifts), altitude {=bool}",
            caps.ahrs,
            caps.altitude
        );

        let record = {
            let mut page = FlashPage::new(&mut flash);
            match storage::load(&mut page) {
                LoadOutcome::Loaded(r) => {
                    defmt::info!("calibration loaded from flash (parts {=u16:#x})", r.valid.0);
                    r
                }
                LoadOutcome::Defaults(r, LoadError::Decode(reason)) => {
                    defmt::warn!("calibration: using defaults ({})", reason);
                    r
                }
                LoadOutcome::Defaults(r, LoadError::Storage(_)) => {
                    defmt::warn!("calibration: using defaults (flash read error)");
                    r
                }
            }
        };

        let scale = sensors.mpu_scale();
        let mag_scale = if report.mag.present() {
            sensors.mag_ut_per_lsb()
        } else {
            [0.15; 3]
        };
        let cfg = PipelineConfig {
            cpu_hz: CPU_HZ,
            gyro_dps_per_lsb: scale.dps_per_lsb,
            accel_g_per_lsb: scale.g_per_lsb,
            mag_ut_per_lsb: mag_scale,
            ahrs_mode: caps.ahrs,
            altitude: caps.altitude,
            ..PipelineConfig::new()
        };
        let pipeline = match Pipeline::new(cfg, &record) {
            Ok(p) => Some(p),
            Err(_) => {
                defmt::error!("pipeline: invalid configuration; no processing");
                None
            }
        };
        // Start-up gyro bias: 1 s still, up to 5 windows (measured in `imu`,
        // one sample at a time, never blocking).
        let bias = StartupGyroBias::new(
            IMU_RATE_HZ,
            1.0 / scale.dps_per_lsb,
            1.0 / scale.g_per_lsb,
            5,
        )
        .ok();

        let mut exti = dp.EXTI;
        let mut mpu_int = gpiob.pb5.into_pull_up_input(&mut gpiob.crl);
        mpu_int.make_interrupt_source(&mut afio);
        mpu_int.trigger_on_edge(&mut exti, Edge::Rising);
        mpu_int.enable_interrupt(&mut exti);

        // Button held at reset: accelerometer calibration.
        // Let the internal pull-up charge the line (~100 µs) before sampling.
        cortex_m::asm::delay(7_200);
        let mode = Mode::at_boot(button_pin.is_low());
        let mut cal = CalState {
            mag: None,
            accel: None,
        };
        if mode == Mode::AccelCal {
            cal.accel = AccelCalMode::new(Default::default()).ok();
            defmt::info!("button held at boot: accelerometer six-position calibration");
        }

        let mut iwdg = IndependentWatchdog::new(dp.IWDG);
        iwdg.start(stm32f1xx_hal::time::MilliSeconds::from_ticks(250));

        let now = DWT::cycle_count();
        baro::spawn().ok();
        log::spawn().ok();
        (
            Shared {
                sensors,
                pipeline,
                clock: MicrosClock::new(CPU_HZ, now),
                stats: LoopStats::new(now),
                mode,
                cal,
                status: Status::default(),
            },
            Local {
                led,
                mpu_int,
                button_pin,
                iwdg,
                flash,
                record,
                bias,
                accel_g_per_lsb: scale.g_per_lsb,
                imu_present: report.mpu.present(),
            },
        )
    }

    /// MPU-9250 data-ready (1 kHz): the whole per-sample path.
    #[task(binds = EXTI9_5, priority = 3,
           local = [mpu_int, bias, accel_g_per_lsb,
                    sched: SampleScheduler = SampleScheduler::new(MAG_DIVIDER),
                    dt: DtClock = DtClock::new(CPU_HZ, IMU_RATE_HZ),
                    raw_div: u16 = 0],
           shared = [sensors, pipeline, clock, stats, mode, cal, status])]
    fn imu(cx: imu::Context) {
        let t0 = DWT::cycle_count();
        cx.local.mpu_int.clear_interrupt_pending_bit();
        let imu::SharedResources {
            mut sensors,
            mut pipeline,
            mut clock,
            mut stats,
            mut mode,
            mut cal,
            mut status,
            ..
        } = cx.shared;
        let now_us = clock.lock(|c| c.now_us(t0));
        let tick = cx.local.sched.on_imu_sample();
        let dt_cycles = cx.local.dt.step_cycles(t0);
        let (raw, mag) = sensors.lock(|s| {
            let raw = s.read_imu();
            let mag = if tick.read_mag {
                s.read_mag()
            } else {
                MagRead::NotReady
            };
            (raw, mag)
        });
        let mode = mode.lock(|m| *m);
        if let Some(raw) = raw {
            // Start-up gyro bias (non-blocking, one sample at a time).
            let b = cx
                .local
                .bias
                .as_mut()
                .map_or(BiasStatus::GaveUp, |e| e.push(raw.gyro, raw.accel));
            if let BiasStatus::Done(bias) = b {
                let first = status.lock(|s| {
                    let first = !matches!(s.bias, Some(BiasStatus::Done(_)));
                    s.bias = Some(b);
                    first
                });
                if first {
                    pipeline.lock(|p| {
                        if let Some(p) = p {
                            p.set_gyro_bias_counts(bias);
                        }
                    });
                }
            } else {
                status.lock(|s| s.bias = Some(b));
            }

            let input = ImuInput {
                accel: raw.accel,
                gyro: raw.gyro,
                dt_cycles,
            };
            let g_per_lsb = *cx.local.accel_g_per_lsb;
            let row = pipeline.lock(|p| {
                let p = p.as_mut()?;
                if let MagRead::Sample(m) = mag {
                    p.mag_step(m.counts);
                    if mode == Mode::MagCal {
                        let ut = p.mag_counts_to_mpu_raw_ut(m.counts);
                        cal.lock(|c| c.mag.as_mut().map(|f| f.push(ut)));
                    }
                }
                if p.imu_step(&input) {
                    p.control_step();
                }
                if tick.read_mag && mode == Mode::AccelCal {
                    let a = raw.accel.map(|c| f32::from(c) * g_per_lsb);
                    cal.lock(|c| c.accel.as_mut().map(|f| f.push(a)));
                }
                if mode != Mode::RawLog {
                    return None;
                }
                *cx.local.raw_div += 1;
                if *cx.local.raw_div < RAW_LOG_DIVIDER {
                    return None;
                }
                *cx.local.raw_div = 0;
                // Calibrated values, MPU frame.
                let bias = p.gyro_bias_counts();
                let k_g = p.config().gyro_dps_per_lsb * (core::f32::consts::PI / 180.0);
                let acc = p.calibrate_accel_counts(raw.accel);
                let mag_ut = match mag {
                    MagRead::Sample(m) => p.mag_counts_to_mpu_ut(m.counts),
                    _ => [f32::NAN; 3],
                };
                let mut gyr_rps = [0.0; 3];
                for ((o, &g), &b) in gyr_rps.iter_mut().zip(&raw.gyro).zip(&bias) {
                    *o = i32::from(g).saturating_sub(b) as f32 * k_g;
                }
                Some(RawLogRow {
                    t_s: now_us as f32 * 1e-6,
                    gyr_rps,
                    acc_mps2: acc.map(|c| c as f32 * g_per_lsb * G_MPS2),
                    mag_ut,
                })
            });
            if let Some(row) = row {
                // A row is dropped if the previous one is still being sent.
                raw_log::spawn(row).ok();
            }
        }
        let t1 = DWT::cycle_count();
        stats.lock(|s| s.record(t1.wrapping_sub(t0)));
    }

    /// One raw-log row (CSV order of `RAW_LOG_HEADER`).
    #[task(priority = 1)]
    async fn raw_log(_cx: raw_log::Context, r: RawLogRow) {
        defmt::println!(
            "{=f32},{=f32},{=f32},{=f32},{=f32},{=f32},{=f32},{=f32},{=f32},{=f32},nan,nan,nan,nan,0",
            r.t_s, r.gyr_rps[0], r.gyr_rps[1], r.gyr_rps[2], r.acc_mps2[0], r.acc_mps2[1], r.acc_mps2[2],
            r.mag_ut[0], r.mag_ut[1], r.mag_ut[2]
        );
    }

    /// Barometer schedule, configuration checks, re-initialisation and
    /// stuck-bus recovery.
    #[task(priority = 2, shared = [sensors, pipeline, clock])]
    async fn baro(cx: baro::Context) {
        let baro::SharedResources {
            mut sensors,
            mut pipeline,
            mut clock,
            ..
        } = cx.shared;
        let mut check = Periodic::new(clock.lock(|c| c.now_us(DWT::cycle_count())), 50_000);
        loop {
            let now_us = clock.lock(|c| c.now_us(DWT::cycle_count()));
            let (m, deadline) = sensors.lock(|s| (s.poll_baro(now_us), s.baro_deadline_us()));
            if let Some(m) = m {
                pipeline.lock(|p| p.as_mut().map(|p| p.baro_step(m.pressure_pa)));
            }
            if check.poll(now_us) {
                let (mismatch, due, stuck) =
                    sensors.lock(|s| (s.check_configs(), s.service_due(), s.needs_bus_recovery()));
                if mismatch {
                    defmt::warn!(
                        "configuration read-back mismatch: a chip reset itself; re-initialising"
                    );
                }
                if stuck {
                    let r = sensors.lock(|s| {
                        let r = bus::recover();
                        s.after_bus_recovery();
                        r
                    });
                    match r {
                        Ok(rep) => defmt::warn!(
                            "I2C stuck: recovered after {=u8} SCL clock(s), I2C1 reset",
                            rep.clocks
                        ),
                        Err(e) => defmt::error!("I2C stuck: recovery failed: {}", e),
                    }
                }
                if due || stuck {
                    let rep = sensors.lock(|s| s.service(&mut AsmDelay));
                    defmt::info!("re-init (MPU, AK8963, MS5611): {}", rep.reinit);
                }
            }
            let wait_us = match deadline {
                Some(d) => (d.wrapping_sub(now_us) as i32).clamp(1_000, 10_000) as u32,
                None => 10_000,
            };
            Mono::delay(ExtU32::millis(wait_us.div_ceil(1_000))).await;
        }
    }

    fn log_health(name: &str, state: SensorState, c: &HealthCounters) {
        defmt::info!(
            "{=str}: {} ok={=u32} err={=u32} retry={=u32} reinit={=u32} reset={=u32} ovf={=u32} notready={=u32}",
            name, state, c.ok, c.errors, c.retries, c.reinits, c.resets_detected, c.overflows, c.not_ready
        );
    }

    /// 20 Hz: live log, button, calibration progress/saving, watchdog, LED.
    #[task(priority = 1, local = [led, button_pin, iwdg, flash, record, imu_present],
           shared = [sensors, pipeline, stats, mode, cal, status])]
    async fn log(cx: log::Context) {
        let log::LocalResources {
            led,
            button_pin,
            iwdg,
            flash,
            record,
            imu_present,
            ..
        } = cx.local;
        let log::SharedResources {
            mut sensors,
            mut pipeline,
            mut stats,
            mut mode,
            mut cal,
            mut status,
            ..
        } = cx.shared;
        let mut button = Button::new();
        let mut gate = WatchdogGate::new();
        let mut tick: u32 = 0;
        let mut last_reinits = 0u32;
        loop {
            tick = tick.wrapping_add(1);
            // The loop period is 50 ms: enough resolution for the button.
            let now_ms = tick.wrapping_mul(50);

            // Watchdog: fed only while the IMU loop makes progress (or a
            // re-initialisation is under way; or there is no IMU at all).
            let (samples, reinits) = (
                pipeline.lock(|p| p.as_ref().map_or(0, |p| p.outputs().imu_samples)),
                sensors.lock(|s| s.mpu_health.counters().reinits),
            );
            let no_loop = !*imu_present || pipeline.lock(|p| p.is_none());
            if gate.should_feed(samples) || no_loop || reinits != last_reinits {
                iwdg.feed();
            }
            last_reinits = reinits;

            // Button → mode.
            if let Some(press) = button.update(now_ms, button_pin.is_low()) {
                let old = mode.lock(|m| *m);
                let new = old.on_press(press);
                cal.lock(|c| {
                    c.mag = if new == Mode::MagCal {
                        new_mag_cal()
                    } else {
                        None
                    };
                    c.accel = if new == Mode::AccelCal {
                        AccelCalMode::new(Default::default()).ok()
                    } else {
                        None
                    };
                });
                mode.lock(|m| *m = new);
                defmt::info!("mode {} -> {}", old, new);
                if new == Mode::RawLog {
                    defmt::println!("{=str}", RAW_LOG_HEADER);
                }
            }

            let m = mode.lock(|m| *m);
            let mut save = false;
            match m {
                Mode::MagCal => {
                    let snap = cal.lock(|c| c.mag.clone());
                    if let Some(f) = snap {
                        let p = f.progress();
                        if tick.is_multiple_of(10) {
                            defmt::info!("mag cal: {=u8}% ({=u8}/{=u8} directions, {=u32} samples): keep turning", p.percent, p.bins_hit, p.bins_needed, p.samples);
                        }
                        if f.ready() {
                            match f.finish() {
                                Ok(c) => {
                                    record.mag_offset_ut = c.offset;
                                    record.mag_soft_iron = c.soft_iron;
                                    record.valid.0 |= ValidParts::MAG;
                                    defmt::info!("mag cal done: offset {} µT", c.offset);
                                    save = true;
                                }
                                Err(_) => defmt::warn!("mag cal: fit refused, keep turning"),
                            }
                        }
                    }
                }
                Mode::AccelCal => {
                    let snap = cal.lock(|c| c.accel.clone());
                    if let Some(f) = snap {
                        if tick.is_multiple_of(20) {
                            let p = f.progress();
                            defmt::info!(
                                "accel cal: {=u8}/6 positions, next {}",
                                p.captured,
                                p.next
                            );
                        }
                        if f.ready() {
                            match f.finish() {
                                Ok(c) => {
                                    record.accel_offset_g = c.offset;
                                    record.accel_scale = c.scale;
                                    record.valid.0 |= ValidParts::ACCEL;
                                    defmt::info!(
                                        "accel cal done: offset {} g, scale {}",
                                        c.offset,
                                        c.scale
                                    );
                                    save = true;
                                }
                                Err(_) => {
                                    defmt::warn!("accel cal: implausible result, restarting");
                                    cal.lock(|c| {
                                        c.accel = AccelCalMode::new(Default::default()).ok()
                                    });
                                }
                            }
                        }
                    }
                }
                Mode::Normal | Mode::RawLog => {}
            }
            if save {
                // Flash erase/program stalls the CPU for ~20–40 ms (samples
                // are missed; only done after a calibration).
                let mut page = FlashPage::new(flash);
                match storage::save(&mut page, record) {
                    Ok(()) => defmt::info!("calibration saved to flash"),
                    Err(SaveError::Invalid(f)) => {
                        defmt::error!("calibration not saved: implausible {}", f)
                    }
                    Err(SaveError::VerifyFailed) => {
                        defmt::error!("calibration save: read-back mismatch")
                    }
                    Err(SaveError::Storage(_)) => defmt::error!("calibration save: flash error"),
                }
                pipeline.lock(|p| p.as_mut().map(|p| p.set_calibration(record)));
                cal.lock(|c| {
                    c.mag = None;
                    c.accel = None;
                });
                mode.lock(|m| *m = Mode::Normal);
            }

            if m == Mode::Normal {
                if let Some(o) = pipeline.lock(|p| p.as_ref().map(|p| p.outputs())) {
                    defmt::info!(
                        "att r={=f32} p={=f32} y={=f32} deg | alt={=f32} m vz={=f32} m/s | thr={=f32} tq={}",
                        o.roll_deg, o.pitch_deg, o.yaw_deg, o.altitude_m, o.vertical_speed_mps, o.throttle, o.torque
                    );
                }
                if tick.is_multiple_of(20) {
                    let r = stats.lock(|s| s.report(DWT::cycle_count()));
                    defmt::info!(
                        "loop: {=u32} runs, imu task mean {=u32} cyc worst {=u32} cyc, cpu {=u32}.{=u32}%",
                        r.runs, r.mean_cycles, r.worst_cycles, r.load_permille / 10, r.load_permille % 10
                    );
                    let (a, b, c) = sensors.lock(|s| {
                        (
                            (s.mpu_health.state(), *s.mpu_health.counters()),
                            (s.mag_health.state(), *s.mag_health.counters()),
                            (s.baro_health.state(), *s.baro_health.counters()),
                        )
                    });
                    log_health("mpu", a.0, &a.1);
                    log_health("mag", b.0, &b.1);
                    log_health("baro", c.0, &c.1);
                    let bias = status.lock(|s| s.bias);
                    defmt::info!("gyro bias: {}", bias);
                }
                if tick.is_multiple_of(100) {
                    let (used, size) = stack::high_water();
                    defmt::info!("stack high-water {=usize} of {=usize} bytes", used, size);
                }
            }
            // Heartbeat: 1 Hz normally, 5 Hz while calibrating.
            let period = if matches!(m, Mode::MagCal | Mode::AccelCal) {
                2
            } else {
                10
            };
            if tick.is_multiple_of(period) {
                led.toggle();
            }
            Mono::delay(ExtU32::millis(50)).await;
        }
    }
}
