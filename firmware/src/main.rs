//! Flight-controller sensor app for the STM32F103C8 "Blue Pill": a thin RTIC
//! 2 shell around the hardware-free logic in the `flight` crate.
//!
//! * Boot (`init`, a list of named steps in `boot.rs`): the watchdog first (a hang in
//!   boot resets), 72 MHz from the 8 MHz crystal or 64 MHz from HSI if it
//!   does not start within 20 ms, DWT cycle counter, pins, I2C1 on PB6/PB7
//!   at 400 kHz, a bus recovery before the first probe (a reset during a
//!   transfer can leave a slave holding SDA), probe of the MPU-9250 (after
//!   its 100 ms power-up), AK8963 and MS5611 with bounded retries; a
//!   missing chip degrades the stack (no barometer → no altitude, no
//!   magnetometer → IMU-only AHRS) and is re-probed later. Calibration from
//!   the flash page at `0x0800_FC00` (defaults + reason if blank or
//!   corrupt).
//! * `imu` (EXTI9_5 on PB5, priority 3): per MPU-9250 data-ready (1 kHz):
//!   starts the sample's read on the I2C1 interrupts and returns (`bus.rs`
//!   has the design). `i2c1_event`/`i2c1_error` (priority 5, the highest,
//!   as errata ES096 §2.13.2 asks) step the read; its end pends
//!   `sample_done` (CAN_RX1's vector, priority 3): the bytes parsed by the
//!   drivers (a failure is counted and the sample skipped, never retried),
//!   `sensor_stack::sample::SampleStep`, the flight controller, the ESC outputs.
//!   CPU per sample on the emulated board (`cargo fil -t hover -d 10`, one
//!   instruction per cycle): mean 5,605, worst 7,174 cycles of 72,000
//!   (cpu 7.7 %), against 34,953 / 57,156 (48.5 %) with the task waiting
//!   on the bus; the read itself takes 0.4 ms of bus time (0.72 ms on a
//!   magnetometer tick).
//! * `service` (priority 2, every ≤ 10 ms): the MS5611 schedule, the
//!   configuration checks every 50 ms, and one step of
//!   `Sensors::maintain`: a bus recovery when I2C1 saw BUSY while idle or
//!   every chip fails, one step of the MPU's re-initialisation (none
//!   waits: each holds `sensors` for less than a sample period) or another
//!   chip's, the MPU's 100 ms post-reset check, the re-check of a suspect
//!   MPU, or the re-probe of a missing chip (back-off 1 s doubling to
//!   32 s). Armed (`Sensors::set_armed`, from `sample_done`), the MPU is
//!   reset only once proven lost, and the other chips' re-initialisations
//!   and the re-probes wait for the disarm. A stuck bus is recovered within 11 ms of the first
//!   refused transfer.
//! * `log` (priority 1, 20 Hz): attitude, altitude, health, loop timing,
//!   stack high-water mark over defmt-RTT; the PA0 button and the
//!   calibration session (the calibration build's: saving a calibration
//!   too); the watchdog is fed only
//!   while sample steps complete, or while the outputs are off, disarmed,
//!   with the MPU out of the loop (`flight::outputguard`; the budgets are
//!   in `watchdog.rs`).
//! * `guard` (priority 4, every 5–6 ms): the output guard's check: no
//!   sample step for 50 ms while the outputs run → the off pulse on all
//!   four ESC outputs, "outputs: forced off: NoSamples" in the log, and the
//!   flight controller disarmed (`NoImuSamples`) at the next sample; while
//!   the MPU is re-initialised (the service task says so each round, and
//!   makes it suspect after 10 ms without a sample step), even thrust at
//!   the last collective after 10 ms and off only after 0.25 s. The
//!   receiver's task does the same at once for the arm switch off while
//!   armed ("outputs: forced off: ArmSwitchOff"), so neither needs a
//!   sample to arrive.
//! * `raw_log` (priority 1, spawned by `sample_done` in raw-log mode, 100 Hz): prints
//!   one raw-log row in `RAW_LOG_HEADER`'s column order.
//!
//! What the board does on a bad bus, and what the log says:
//! * bus stuck at power-up: recovered before the first probe ("I2C
//!   recovery at boot: ...").
//! * bus stuck in flight: every transfer is refused at once (BUSY), the
//!   samples are skipped, the service task recovers the bus and
//!   re-initialises the chips ("I2C stuck: recovered ...", "re-init ...").
//! * a chip missing at boot: the stack runs degraded ("probe ...: FAILED",
//!   "capabilities: ...") and re-probes it ("... still missing, next probe
//!   in N ms").
//! * a chip that appears later: "... appeared", and the capabilities line
//!   again; the AHRS switches to MARG / altitude comes on.
//! * the IMU stops (INT line or the chip gone quiet while healthy): the
//!   outputs go to the off pulse ≤ 60 ms after the last sample (when they
//!   ran), and the watchdog resets the board within 0.5–1 s (IWDG at LSI
//!   60/30 kHz).
//!
//! Button PA0 (to GND, internal pull-up): held at reset → accelerometer
//! six-position calibration; long press (≥ 1.5 s) → magnetometer
//! figure-eight; short press → raw-log mode on/off (CSV order of the BROAD
//! recordings, 100 Hz), or abort a calibration.
//!
//! * `crsf_rx` (USART1, priority 4): CRSF bytes from PA10 at 420 kbaud,
//!   which DMA1 channel 5 moves into a 128 B ring as they arrive, into
//!   `rc_input`'s parser and link monitor; it runs at the end of every
//!   burst (IDLE, the parser's frame boundary) and, pended by `crsf_dma`
//!   (DMA1_CHANNEL5, priority 4), at every half ring. Interrupts held off
//!   for up to 1.5 ms (defmt-rtt encodes each line with interrupts
//!   disabled) lose no byte. With the `ppm` feature instead `ppm_rx`
//!   (TIM4, priority 4): a PPM train on PB8 (TIM4_CH3 input capture at
//!   1 MHz, `ppm.rs`) into `rc_input`'s PPM decoder and the same link
//!   monitor and pilot state, so arming, failsafe and signal-loss
//!   detection are the same for both receivers.
//!
//! Safety: the ESC outputs (TIM3 CH1-4 on PA6, PA7, PB0, PB1) carry the
//! "off" pulse from the boot step right after the clock switch, whenever
//! disarmed, and after a watchdog reset (the boot path). On a panic the
//! handler writes the off pulse (`outputs::force_off`), turns the LED off,
//! logs the location over defmt and traps into HardFault, which writes the
//! off pulse again and waits for the watchdog reset. The flight controller
//! (`flight::flightctl`) runs in `sample_done` at 1 kHz on the pipeline's attitude,
//! gyro and altitude and the receiver's pilot input, and sets the outputs.
//! The props-off motor test runs from the transmitter's motor-test switch
//! (`flight::motortest`): "motor test: motor N (Position) at 8 %" in the
//! log.
//!
//! Settings: the channel map, the mode and motor-test switch channels, the
//! ESC protocol, the motor-test command and the magnetometer calibration
//! of the build are in `config.rs`.
//!
//! Flash: 59,592 B of the flash plan's 60 KiB code region, within the
//! flight builds' 58.25 KiB (`cargo fw && cargo xtask size`, release
//! profile at `opt-level = "z"`; ARCHITECTURE.md "Flash plan" has the
//! groups); static RAM 4.7 KiB; the `ppm` build (PPM instead of CRSF):
//! 58,548 B.
//! The flight build runs no calibration session (`config::Session`): the
//! six-position and magnetometer sessions and the flash save are the
//! calibration build's (`--features calibrate`, no flight controller),
//! 4.6 KiB the flight build keeps for what comes next.
//! To fit, the I2C master is our own register-level driver (`bus.rs`)
//! rather than the HAL's blocking one, the fixed-point textbook filter is
//! left out (`fc-ahrs` without its `textbook` feature: the firmware runs
//! the full filter), the trigonometry is a polynomial rather than libm's
//! (whose `sinf`/`cosf` reduce the argument in soft f64), neither
//! `memmove` nor a 64-bit division is linked, `mem.rs`'s 50 B of
//! `__aeabi_memcpy*`/`__aeabi_memclr*` save 1,560 B over
//! `compiler_builtins`' own, and the constructors are inlined so that the
//! constant configuration folds (1.2 KiB).
#![no_std]
#![no_main]
#![deny(unsafe_code)]

// The STM32F103CB build transmits telemetry on USART1's TX: it needs the
// CRSF receiver there, not PPM.
#[cfg(all(feature = "f103cb", feature = "ppm"))]
compile_error!("`f103cb` and `ppm` do not combine: the CB build's telemetry needs CRSF on USART1");

mod boot;
mod bus;
mod clocks;
mod config;
mod delay;
mod mem;
mod outputs;
// Each build uses one receiver (the `ppm` build the pilot state only of
// `receiver`); both modules stay compiled because RTIC's generated task
// contexts name the local resources' types outside their cfg.
#[cfg(builder)]
mod adc;
#[cfg(builder)]
mod builder;
#[cfg(builder)]
mod console;
#[cfg(builder)]
mod crsf_tx;
#[cfg_attr(not(feature = "ppm"), allow(dead_code))]
mod ppm;
#[cfg_attr(feature = "ppm", allow(dead_code))]
mod receiver;
mod report;
#[cfg(builder)]
mod rtt;

/// The STM32F103CB build's task locals, named in the C8 builds as units:
/// RTIC names a local resource's type in code that its `#[cfg]` does not
/// remove (as `ppm` and `receiver` are compiled in both receiver builds).
#[cfg(builder)]
mod cb {
    pub type Tx = crate::crsf_tx::CrsfTx;
    pub type Schedule = rc_input::TelemetryScheduler;
    pub type Battery = Option<crate::builder::BatteryTask>;
    pub type Console = crate::console::Console;
    pub type RateLog = crate::builder::RateLog;
}
#[cfg(not(builder))]
mod cb {
    pub type Tx = ();
    pub type Schedule = ();
    pub type Battery = ();
    pub type Console = ();
    pub type RateLog = ();
}
mod stack;
mod store;
mod watchdog;

#[cfg(not(builder))]
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

/// Panic: outputs to a safe state (the ESC off pulse, `outputs::force_off`;
/// LED off), the location over defmt (no `core::fmt`: the message is not
/// formatted, which keeps ~4 KiB of formatting code out of flash), then a
/// trap: probe-rs halts and shows the backtrace; without a probe the
/// HardFault handler waits for the watchdog reset.
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    outputs::force_off();
    led_off();
    match info.location() {
        Some(l) => defmt::error!("PANIC at {=str}:{=u32}", l.file(), l.line()),
        None => defmt::error!("PANIC"),
    }
    cortex_m::asm::udf()
}

/// HardFault (also reached from a panic): ESC off pulse, LED off, then
/// wait for the independent watchdog to reset the MCU (the reset boots
/// into the off pulse again).
#[allow(unsafe_code)]
#[cortex_m_rt::exception]
unsafe fn HardFault(_frame: &cortex_m_rt::ExceptionFrame) -> ! {
    outputs::force_off();
    led_off();
    loop {
        cortex_m::asm::nop();
    }
}

// The software tasks run on SPI1, SPI2 and USART3's vectors (one per
// priority: 1, 2 and the guard's 4): the app uses neither SPI nor USART3,
// and USART1 is the receiver's own interrupt.
#[rtic::app(device = stm32f1xx_hal::pac, dispatchers = [SPI1, SPI2, USART3])]
mod app {
    use crate::boot::*;
    #[cfg(builder)]
    use crate::builder;
    use crate::bus::{self, BusHandle};
    use crate::clocks::{self, Source};
    use crate::config::{self, Session};
    use crate::delay::{cpu_hz, AsmDelay};
    use crate::outputs::GuardedOutputs;
    #[cfg(not(feature = "ppm"))]
    use crate::receiver;
    use crate::receiver::{Pilot, RING_BYTES};
    use crate::report::{log_capabilities, log_pilot, log_status};
    use crate::stack;
    use crate::store::FlashPage;
    use crate::watchdog::{Watchdog, BOOT_MIN_TIMEOUT_MS, RUN_MIN_TIMEOUT_MS};
    use core::sync::atomic::{AtomicBool, Ordering};
    use cortex_m::peripheral::DWT;
    use flight::flightctl::{
        Event as FlightEvent, Events, FlightController, Motors, PilotInput, SystemStatus,
        VehicleState,
    };
    use flight::motortest::MotorPosition;
    use flight::outputguard::{ForceOffReason, TickAction, CHECK_PERIOD_US};
    use rc_input::LinkStatus;
    use rtic::Mutex;
    use rtic_monotonics::fugit::ExtU32;
    use rtic_monotonics::rtic_time::monotonic::TimerQueueBasedInstant;
    use rtic_monotonics::systick::prelude::*;
    use sensor_stack::boot::BiasStatus;
    use sensor_stack::calmode::{CalEvent, RawLogRow};
    use sensor_stack::health::SensorState;
    use sensor_stack::pipeline::Pipeline;
    use sensor_stack::sample::{SampleIn, SampleStep};
    use sensor_stack::schedule::{
        DtClock, LoopStats, MicrosClock, Periodic, SampleScheduler, IMU_RATE_HZ, MAG_DIVIDER,
    };
    use sensor_stack::sensors::{Maintenance, Sensors};
    use sensor_stack::storage::{self, CalibrationRecord, SaveError};
    use stm32f1xx_hal::{
        flash,
        gpio::{Edge, ExtiPin, Input, Output, PinState, PullUp, PushPull, PA0, PB5, PC13},
        pac,
        prelude::*,
    };

    systick_monotonic!(Mono, 1_000);

    /// The flight controller is armed: written by `sample_done` after each
    /// step, read by `service` for `Sensors::set_armed`.
    static ARMED: AtomicBool = AtomicBool::new(false);

    /// What the `imu` task knew when it started a sample's read, for the
    /// `sample_done` task that processes it.
    #[derive(Clone, Copy)]
    pub struct SampleStart {
        read_mag: bool,
        dt_cycles: u32,
        now_us: u32,
        /// CPU cycles the `imu` task took to start the read.
        start_cycles: u32,
    }

    /// The sample whose read is on the bus, and one whose data-ready came
    /// before that read was processed.
    #[derive(Default)]
    pub struct SampleStarts {
        running: Option<SampleStart>,
        waiting: Option<SampleStart>,
    }

    #[shared]
    struct Shared {
        sensors: Sensors<BusHandle>,
        started: SampleStarts,
        pipeline: Option<Pipeline>,
        clock: MicrosClock,
        stats: LoopStats,
        session: Session,
        bias: BiasStatus,
        pilot: Pilot,
        outputs: GuardedOutputs,
    }

    #[local]
    struct Local {
        led: PC13<Output<PushPull>>,
        mpu_int: PB5<Input<PullUp>>,
        button_pin: PA0<Input<PullUp>>,
        iwdg: Watchdog,
        flash: flash::Parts,
        record: CalibrationRecord,
        step: SampleStep,
        dt: DtClock,
        fc: Option<FlightController>,
        // Full paths: RTIC's generated task contexts name these types
        // outside the cfg that removes their imports from the other build.
        #[cfg(not(feature = "ppm"))]
        rx: crate::receiver::CrsfRx,
        #[cfg(feature = "ppm")]
        ppm: crate::ppm::PpmInput,
        #[cfg(builder)]
        tx: crate::cb::Tx,
        #[cfg(builder)]
        telemetry_schedule: crate::cb::Schedule,
        #[cfg(builder)]
        battery: crate::cb::Battery,
        /// The settings console (a unit in the C8 builds, which have
        /// none: named in the log task's locals in every build).
        console: crate::cb::Console,
        /// The raw log's rate columns (a unit in the C8 builds).
        rate_log: crate::cb::RateLog,
    }

    // RTIC's init locals take no cfg: the C8 builds keep the unused
    // telemetry buffer (64 B of RAM).
    #[init(local = [
        ring: [u8; RING_BYTES] = [0; RING_BYTES],
        tx_buf: [u8; 64] = [0; 64],
    ])]
    fn init(cx: init::Context) -> (Shared, Local) {
        stack::paint();
        #[cfg(builder)]
        let console_down = crate::rtt::init();
        let mut core = cx.core;
        let dp: pac::Peripherals = cx.device;
        let mut iwdg = Watchdog::start(dp.IWDG, BOOT_MIN_TIMEOUT_MS);
        // CYCCNT first: every wait from the crystal's start-up on is
        // measured on it (`delay.rs`).
        core.DCB.enable_trace();
        core.DWT.enable_cycle_counter();
        let mut flash = dp.FLASH.constrain();
        let (mut rcc, source) = clocks::start(dp.RCC, &mut flash.acr);
        // One constant per branch: SysTick's divisibility check folds away.
        match source {
            Source::Hse => Mono::start(core.SYST, crate::delay::CPU_HZ_HSE),
            Source::HsiFallback => Mono::start(core.SYST, crate::delay::CPU_HZ_HSI),
        }
        let mut afio = dp.AFIO.constrain(&mut rcc);
        let mut gpioa = dp.GPIOA.split(&mut rcc);
        let mut gpiob = dp.GPIOB.split(&mut rcc);
        let mut gpioc = dp.GPIOC.split(&mut rcc);
        // After the port splits (they reset GPIOA/B), before anything slow.
        let esc = start_outputs(dp.TIM3);
        // The Blue Pill LED is active low: start with it off.
        let led = gpioc
            .pc13
            .into_push_pull_output_with_state(&mut gpioc.crh, PinState::High);
        let button_pin = gpioa.pa0.into_pull_up_input(&mut gpioa.crl);
        log_boot(source);

        bus::init(&rcc);
        recover_bus_at_boot();
        let sensors = probe_sensors();
        let record = load_calibration(&mut flash);
        #[cfg(builder)]
        let params = load_params(&mut flash);
        #[cfg(builder)]
        let record = crate::builder::with_settings(record, &params);
        let pipeline = build_pipeline(
            &sensors,
            &sensors.capabilities(),
            &record,
            #[cfg(builder)]
            crate::builder::gyro_filter(&params),
        );
        let bias = start_gyro_bias(&sensors);
        let session = start_session(&button_pin);
        #[cfg(not(feature = "ppm"))]
        let rx = start_receiver(dp.USART1, dp.DMA1, cx.local.ring);
        #[cfg(builder)]
        let (tx, battery) = crate::builder::start(dp.ADC1, cx.local.tx_buf, &params);
        #[cfg(not(builder))]
        let _ = cx.local.tx_buf;
        // RTIC's init locals take no cfg: the ppm build keeps the unused
        // ring (128 B of RAM).
        #[cfg(feature = "ppm")]
        let (ppm, _) = (start_ppm(dp.TIM4), cx.local.ring);

        let mut exti = dp.EXTI;
        let mut mpu_int = gpiob.pb5.into_pull_up_input(&mut gpiob.crl);
        mpu_int.make_interrupt_source(&mut afio);
        mpu_int.trigger_on_edge(&mut exti, Edge::Rising);
        mpu_int.enable_interrupt(&mut exti);

        iwdg.set_timeout(RUN_MIN_TIMEOUT_MS);
        service::spawn().ok();
        log::spawn().ok();
        guard::spawn().ok();
        #[cfg(builder)]
        builder_task::spawn().ok();
        let now = DWT::cycle_count();
        // Counted from when CYCCNT started, at reset.
        let mut clock = MicrosClock::new(cpu_hz(), 0);
        let outputs = GuardedOutputs::new(esc, clock.now_us(now));
        (
            Shared {
                sensors,
                started: SampleStarts::default(),
                pipeline,
                clock,
                stats: LoopStats::new(now),
                session,
                bias: BiasStatus::GaveUp,
                #[cfg(not(builder))]
                pilot: Pilot::new(),
                #[cfg(builder)]
                pilot: Pilot::new().with_settings(&params),
                outputs,
            },
            Local {
                led,
                mpu_int,
                button_pin,
                iwdg,
                flash,
                record,
                step: SampleStep::new(bias),
                dt: DtClock::new(cpu_hz(), IMU_RATE_HZ),
                #[cfg(not(builder))]
                fc: start_flight_controller(),
                #[cfg(builder)]
                fc: start_flight_controller_with(&params),
                #[cfg(not(feature = "ppm"))]
                rx,
                #[cfg(feature = "ppm")]
                ppm,
                #[cfg(builder)]
                tx,
                #[cfg(builder)]
                telemetry_schedule: rc_input::TelemetryScheduler::new(
                    rc_input::telemetry::FrameSet::ALL,
                ),
                #[cfg(builder)]
                battery,
                #[cfg(builder)]
                console: crate::console::Console::new(console_down, params),
                #[cfg(not(builder))]
                console: (),
                #[cfg(builder)]
                rate_log: crate::builder::RateLog::new(),
                #[cfg(not(builder))]
                rate_log: (),
            },
        )
    }

    /// MPU-9250 data-ready (1 kHz): starts the sample's read on the I2C1
    /// interrupts and returns; `sample_done` processes it.
    #[task(binds = EXTI9_5, priority = 3,
           local = [mpu_int, dt, sched: SampleScheduler = SampleScheduler::new(MAG_DIVIDER)],
           shared = [sensors, clock, started])]
    fn imu(mut cx: imu::Context) {
        let t0 = DWT::cycle_count();
        cx.local.mpu_int.clear_interrupt_pending_bit();
        // Read inside the lock: the receive interrupt advances the same
        // clock, and a count taken before it preempts would be older than
        // the clock's and read as a 59 s jump.
        let now_us = cx.shared.clock.lock(|c| c.now_us(DWT::cycle_count()));
        let tick = cx.local.sched.on_imu_sample();
        let dt_cycles = cx.local.dt.step_cycles(t0);
        let mut start = SampleStart {
            read_mag: tick.read_mag,
            dt_cycles,
            now_us,
            start_cycles: 0,
        };
        let started = start_read(&mut cx.shared.sensors, tick.read_mag);
        start.start_cycles = DWT::cycle_count().wrapping_sub(t0);
        // Not started: the previous read is still on the bus (it began
        // late, behind the service task's transfers) or not yet processed;
        // `sample_done` starts this one when it has processed that.
        cx.shared.started.lock(|p| {
            if started {
                p.running = Some(start);
            } else {
                // A waiting sample that was never read gives this one its
                // time step (the gyro integrates over both) and its
                // magnetometer tick.
                if let Some(old) = p.waiting {
                    start.dt_cycles = start.dt_cycles.saturating_add(old.dt_cycles);
                    start.read_mag |= old.read_mag;
                }
                p.waiting = Some(start);
            }
        });
    }

    /// The sample's read ended (pended by the I2C1 handlers, or at once
    /// when nothing was to be read): parse and book it, run the pipeline
    /// and the flight controller, set the ESC outputs (through the output
    /// guard: a forced off first disarms the controller, and holds).
    #[task(binds = CAN_RX1, priority = 3,
           local = [step, fc, rate_log],
           shared = [sensors, pipeline, stats, session, bias, pilot, started, outputs])]
    fn sample_done(mut cx: sample_done::Context) {
        let t0 = DWT::cycle_count();
        let start = cx.shared.started.lock(|p| p.running.take());
        // Taken even without its start (never expected): the engine must
        // not stay finished, or no read would start again.
        let Some(Some((start, raw, mag, mpu_ok, handler_cycles))) = cx.shared.sensors.lock(|s| {
            bus::take_sample(|bytes, results, handler_cycles| {
                let start = start?;
                let (raw, mag) = s.finish_sample(start.read_mag, bytes, results);
                let mpu_ok = s.mpu_health.state() == SensorState::Ok;
                Some((start, raw, mag, mpu_ok, handler_cycles))
            })
        }) else {
            return;
        };
        let fresh = raw.is_some();
        if let Some(raw) = raw {
            let input = SampleIn {
                raw,
                mag,
                read_mag: start.read_mag,
                dt_cycles: start.dt_cycles,
                now_us: start.now_us,
            };
            estimate(&mut cx, &input);
        }
        let forced = cx.shared.outputs.lock(|o| o.take_forced());
        let disarmed = forced.and_then(|f| cx.local.fc.as_mut()?.force_disarm(f.disarm_cause()));
        let motors = fly(&mut cx, start.now_us, mpu_ok, fresh, disarmed);
        let armed = cx.local.fc.as_ref().is_some_and(FlightController::is_armed);
        ARMED.store(armed, Ordering::Relaxed);
        cx.shared
            .outputs
            .lock(|o| o.on_step(start.now_us, armed, &motors));
        // The sample's CPU time wherever it was spent: starting the read,
        // the I2C1 handlers, and this task.
        let cycles = start
            .start_cycles
            .wrapping_add(handler_cycles)
            .wrapping_add(DWT::cycle_count().wrapping_sub(t0));
        cx.shared.stats.lock(|s| s.record(cycles));
        start_waiting(&mut cx);
    }

    /// Starts the read of a data-ready that found the bus taken.
    fn start_waiting(cx: &mut sample_done::Context) {
        let Some(w) = cx.shared.started.lock(|p| p.waiting.take()) else {
            return;
        };
        if start_read(&mut cx.shared.sensors, w.read_mag) {
            cx.shared.started.lock(|p| p.running = Some(w));
        }
    }

    /// Starts a sample's read. With `sensors` held no blocking transfer is
    /// under way, and none can start before the lock is released.
    #[inline(never)]
    fn start_read(sensors: &mut impl rtic::Mutex<T = Sensors<BusHandle>>, read_mag: bool) -> bool {
        sensors.lock(|s| bus::start_sample(&s.plan_sample(read_mag)))
    }

    /// I2C1 event interrupt, the highest priority (ES096 §2.13.2: the
    /// master's events must be handled before the current byte ends):
    /// one step of the sample read.
    #[task(binds = I2C1_EV, priority = 5)]
    fn i2c1_event(_cx: i2c1_event::Context) {
        bus::on_irq();
    }

    /// I2C1 error interrupt (NACK, arbitration loss, bus error, overrun).
    #[task(binds = I2C1_ER, priority = 5)]
    fn i2c1_error(_cx: i2c1_error::Context) {
        bus::on_irq();
    }

    /// One sample through the pipeline; feeds the calibration session, the
    /// gyro-bias status and the raw log.
    fn estimate(cx: &mut sample_done::Context, input: &SampleIn) {
        let wants = cx.shared.session.lock(|c| c.wants());
        let step = &mut *cx.local.step;
        let out = cx
            .shared
            .pipeline
            .lock(|p| p.as_mut().map(|p| step.run(p, input, wants)));
        let Some(out) = out else { return };
        cx.shared.session.lock(|c| {
            if let Some(m) = out.mag_ut {
                c.push_mag(m);
            }
            if let Some(a) = out.accel_g {
                c.push_accel(a);
            }
        });
        cx.shared.bias.lock(|b| *b = out.bias);
        // A row is dropped if the previous one is still being sent.
        if let Some(r) = out.row {
            raw_log::spawn(r).ok();
        }
    }

    /// One flight-controller step on the latest pilot input and estimate;
    /// the motor commands for the ESC timer (off without a controller or an
    /// estimate). `disarmed`: the event of a disarm the output guard forced
    /// before the step, logged with the step's.
    fn fly(
        cx: &mut sample_done::Context,
        now_us: u32,
        mpu_ok: bool,
        fresh: bool,
        disarmed: Option<FlightEvent>,
    ) -> Motors {
        let pilot = cx.shared.pilot.lock(|p| pilot_input(p, now_us));
        // The AHRS's drag model holds in the air only: the controller's
        // verdict of the previous step (1 ms late) is the AHRS's next. (The
        // calibration build never flies and leaves the model out.)
        #[cfg(not(feature = "calibrate"))]
        let in_flight = cx.local.fc.as_ref().is_some_and(|fc| fc.in_flight());
        let state = cx.shared.pipeline.lock(|p| {
            p.as_mut().map(|p| {
                #[cfg(not(feature = "calibrate"))]
                p.set_in_flight(in_flight);
                (vehicle_state(p, fresh), p.accel_calibrated())
            })
        });
        let vehicle = state.map(|(v, _)| v);
        let status = SystemStatus {
            sensors_healthy: mpu_ok,
            gyro_bias_done: cx.shared.bias.lock(|b| matches!(b, BiasStatus::Done(_))),
            calibration_running: cx.shared.session.lock(|c| {
                matches!(
                    c.mode(),
                    sensor_stack::calmode::Mode::MagCal | sensor_stack::calmode::Mode::AccelCal
                )
            }),
            accel_calibrated: state.is_some_and(|(_, cal)| cal),
        };
        #[cfg(all(not(feature = "calibrate"), not(builder)))]
        let out = match (cx.local.fc.as_mut(), vehicle) {
            (Some(fc), Some(v)) => Some(fc.step(now_us, &pilot, &status, &v)),
            _ => None,
        };
        #[cfg(builder)]
        let out = match (cx.local.fc.as_mut(), vehicle) {
            (Some(fc), Some(v)) => Some(builder::flight_step(
                fc,
                cx.local.rate_log,
                (now_us, &pilot, &status, &v),
            )),
            _ => None,
        };
        // Nothing calls the controller's step, so none of it is linked.
        #[cfg(feature = "calibrate")]
        let out = {
            let _ = (cx.local.fc.as_mut(), vehicle, status);
            None::<flight::flightctl::FlightOutput>
        };
        // Taken apart in place: a copy of the whole output is a `memcpy`.
        let Some(o) = out else {
            return Motors::Off;
        };
        let mut events = o.events;
        if let Some(e) = disarmed {
            events.push(e);
        }
        if !events.is_empty() {
            flight_log::spawn(events, pilot).ok();
        }
        o.motors
    }

    /// The flight controller's view of the pilot at `now_us`.
    fn pilot_input(p: &mut Pilot, now_us: u32) -> PilotInput {
        p.input(now_us)
    }

    /// A channel frame's arm switch and link to the output guard, which
    /// forces the off pulse at once on the arm switch off while armed.
    fn guard_pilot(outputs: &mut impl rtic::Mutex<T = GuardedOutputs>, pilot: &PilotInput) {
        if let Some(r) = outputs.lock(|o| o.on_pilot(pilot.arm_switch, pilot.link_ok)) {
            log_forced_off(r);
        }
    }

    /// Says why the output guard forced the off pulse (the arm switch is
    /// the pilot's normal disarm, seen by the receiver before a sample).
    fn log_forced_off(r: ForceOffReason) {
        match r {
            ForceOffReason::NoSamples => defmt::error!("outputs: forced off: {}", r),
            ForceOffReason::ArmSwitchOff => defmt::warn!("outputs: forced off: {}", r),
        }
    }

    /// The output guard's periodic check (priority 4: above the sensor
    /// tasks and the `sensors` lock's ceiling, so neither a blocking
    /// maintenance step nor a stuck sample chain holds it up): the off
    /// pulse when no sample step came for 50 ms while the outputs ran.
    /// Every 5–6 ms (the 1 kHz monotonic's delay rounds up a tick).
    #[task(priority = 4, shared = [clock, outputs])]
    async fn guard(mut cx: guard::Context) {
        loop {
            let now_us = cx.shared.clock.lock(|c| c.now_us(DWT::cycle_count()));
            match cx.shared.outputs.lock(|o| o.on_tick(now_us)) {
                Some(TickAction::ForceOff(r)) => log_forced_off(r),
                Some(TickAction::Level) => {
                    defmt::warn!("outputs: even thrust while the MPU-9250 is re-initialised")
                }
                None => {}
            }
            Mono::delay(ExtU32::millis(CHECK_PERIOD_US / 1_000)).await;
        }
    }

    /// DMA1 channel 5: half or all of the receive ring written (priority
    /// 4, above the 1 kHz tasks; below the I2C1 handlers, whose steps are a
    /// few register accesses, up to one bit time, 2.5 µs, at a block's
    /// end). Pends `crsf_rx`, which hands the bytes over.
    #[cfg(not(feature = "ppm"))]
    #[task(binds = DMA1_CHANNEL5, priority = 4)]
    fn crsf_dma(_cx: crsf_dma::Context) {
        receiver::on_dma_half_or_complete();
    }

    /// USART1 IDLE, or pended by `crsf_dma` (priority 4, above the 1 kHz
    /// tasks so that the sample's processing never holds up emptying the
    /// ring: half the ring, 1.5 ms, is the latency it tolerates): the bytes
    /// the DMA wrote since the last run into the CRSF parser, frames into
    /// the pilot state (an IDLE is a handover, not a frame boundary).
    #[cfg(not(feature = "ppm"))]
    #[task(binds = USART1, priority = 4, local = [rx], shared = [clock, pilot, outputs])]
    fn crsf_rx(mut cx: crsf_rx::Context) {
        let now_us = cx.shared.clock.lock(|c| c.now_us(DWT::cycle_count()));
        let rx = cx.local.rx;
        let pilot = &mut cx.shared.pilot;
        let mut channels = false;
        rx.on_interrupt(now_us, |ev| {
            channels |= matches!(ev, rc_input::Event::Channels(_));
            pilot.lock(|p| p.on_event(ev, now_us))
        });
        let input = pilot.lock(|p| {
            p.update_counters(rx.stats(), rx.errors());
            channels.then(|| pilot_input(p, now_us))
        });
        if let Some(i) = input {
            guard_pilot(&mut cx.shared.outputs, &i);
            // The receiver listens for telemetry after each frame it sends.
            #[cfg(builder)]
            telemetry_tx::spawn(now_us).ok();
        }
    }

    /// One CRSF telemetry frame after a channel frame, if the scheduler
    /// has one due and the last one has left (priority 2: the 1 kHz
    /// sample outranks it; the receiver queues what it is given until its
    /// telemetry slot).
    #[cfg(builder)]
    #[task(priority = 2, local = [tx, telemetry_schedule])]
    async fn telemetry_tx(cx: telemetry_tx::Context, now_us: u32) {
        let (tx, sched) = (cx.local.tx, cx.local.telemetry_schedule);
        let snap = builder::telemetry();
        tx.send(|buf| sched.on_rc_frame(now_us, &snap, buf).unwrap_or(0));
    }

    /// 10 Hz: the battery (ADC, monitor, low-battery rule), the telemetry
    /// snapshot, and the settings console's lines.
    #[cfg(builder)]
    #[task(priority = 1, local = [battery],
           shared = [pipeline, pilot, clock])]
    async fn builder_task(mut cx: builder_task::Context) {
        loop {
            let now_us = cx.shared.clock.lock(|c| c.now_us(DWT::cycle_count()));
            let pilot = cx.shared.pilot.lock(|p| pilot_input(p, now_us));
            // Copied under the lock (its ceiling is the 1 kHz step's), the
            // angles worked out after it.
            let est = cx.shared.pipeline.lock(|p| {
                p.as_ref()
                    .map(|p| (p.quaternion_q30(), p.altitude_estimate()))
            });
            let (euler, alt) = est.map_or(([0; 3], None), |(q, alt)| {
                (sensor_stack::angles::euler_q16(q), alt)
            });
            let frame = cx.local.battery.as_mut().and_then(|b| {
                if let Some(ev) = b.step(&pilot, alt.is_some()) {
                    builder::log_battery_event(ev, b.status());
                }
                builder::battery_frame(&b.status())
            });
            let snap = builder::snapshot(euler, alt, frame);
            builder::set_telemetry(snap);
            Mono::delay(ExtU32::millis(battery::SAMPLE_PERIOD_MS)).await;
        }
    }

    /// TIM4 capture on PB8 (priority 4, where `crsf_rx` is in the CRSF
    /// build): one edge into the PPM decoder, a completed frame into the
    /// pilot state exactly as a CRSF channel frame goes.
    ///
    /// RTIC 2.4 sets the NVIC priority of, and unmasks, the interrupt of a
    /// hardware task its cfg leaves out (8 B in the CRSF build): TIM4 there,
    /// USART1 and DMA1_CHANNEL5 in the `ppm` build are unmasked, but their
    /// peripherals are never clocked or given an interrupt enable, so they
    /// never pend.
    #[cfg(feature = "ppm")]
    #[task(binds = TIM4, priority = 4, local = [ppm], shared = [clock, pilot, outputs])]
    fn ppm_rx(mut cx: ppm_rx::Context) {
        let now_us = cx.shared.clock.lock(|c| c.now_us(DWT::cycle_count()));
        let frame = cx.local.ppm.on_interrupt(now_us);
        let counters = cx.local.ppm.counters();
        let input = cx.shared.pilot.lock(|p| {
            p.ppm = counters;
            let f = frame?;
            p.on_event(rc_input::Event::Channels(f), now_us);
            Some(pilot_input(p, now_us))
        });
        if let Some(i) = input {
            guard_pilot(&mut cx.shared.outputs, &i);
        }
    }

    /// The flight controller's view of the vehicle, in the pipeline's own
    /// fixed-point forms. Without a fresh sample there is no gyro: the
    /// controller keeps the last commands for a single miss and disarms
    /// when samples stay away.
    fn vehicle_state(p: &Pipeline, fresh: bool) -> VehicleState {
        let mut v = VehicleState::from_pipeline(p);
        if !fresh {
            v.gyro_rps_q16 = None;
        }
        v
    }

    /// The flight controller's events (arming, refusals with their reason,
    /// disarms with their cause, failsafe, motor test).
    #[task(priority = 1)]
    async fn flight_log(_cx: flight_log::Context, events: Events, pilot: PilotInput) {
        for e in events.iter() {
            let started = match e {
                FlightEvent::MotorTestStarted(m) => MotorPosition::of(m).map(|p| (m, p)),
                _ => None,
            };
            match (e, started) {
                (_, Some((m, p))) => defmt::warn!(
                    "motor test: motor {=u8} ({}) at {=u8} % (props off!)",
                    m + 1,
                    p,
                    (config::MOTOR_TEST_COMMAND * 100.0) as u8
                ),
                (FlightEvent::ArmRefused(r), _) => defmt::warn!(
                    "flight: arm refused: {} (throttle stick {=f32})",
                    r,
                    pilot.sticks.throttle
                ),
                // ARMED, disarmed with its cause, failsafe, ...: in words
                // (`flight::arming::Event`'s log format).
                (other, _) => defmt::warn!("flight: {}", other),
            }
        }
    }

    /// One raw-log row, positionally in `RawLogRow::columns` order (the
    /// order of `RAW_LOG_HEADER`).
    #[task(priority = 1)]
    async fn raw_log(_cx: raw_log::Context, r: RawLogRow) {
        let c = r.columns();
        #[cfg(not(builder))]
        defmt::println!(
            "{=f32},{=f32},{=f32},{=f32},{=f32},{=f32},{=f32},{=f32},{=f32},{=f32},nan,nan,nan,nan,0",
            c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], c[8], c[9]
        );
        // The CB build adds the rate loop's columns (`RATE_LOG_COLUMNS`).
        #[cfg(builder)]
        {
            let k = builder::rate_block();
            defmt::println!(
                "{=f32},{=f32},{=f32},{=f32},{=f32},{=f32},{=f32},{=f32},{=f32},{=f32},nan,nan,nan,nan,0,{=f32},{=f32},{=f32},{=f32},{=f32},{=f32}",
                c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], c[8], c[9],
                k[0], k[1], k[2], k[3], k[4], k[5]
            );
        }
    }

    /// Barometer schedule, configuration checks and one maintenance step
    /// per round (bus recovery, re-initialisation, re-probing).
    #[task(priority = 2, shared = [sensors, pipeline, clock, outputs])]
    async fn service(mut cx: service::Context) {
        let mut check = Periodic::new(
            cx.shared.clock.lock(|c| c.now_us(DWT::cycle_count())),
            50_000,
        );
        loop {
            let now_us = cx.shared.clock.lock(|c| c.now_us(DWT::cycle_count()));
            let (m, deadline) = cx.shared.sensors.lock(|s| {
                // Armed, the MPU is reset only once proven lost.
                s.set_armed(ARMED.load(Ordering::Relaxed));
                (s.poll_baro(now_us), s.baro_deadline_us())
            });
            if let Some(m) = m {
                cx.shared
                    .pipeline
                    .lock(|p| p.as_mut().map(|p| p.baro_step(m.pressure_pa)));
            }
            if check.poll(now_us) && cx.shared.sensors.lock(|s| s.check_configs()) {
                defmt::warn!(
                    "configuration read-back mismatch: a chip reset itself; re-initialising"
                );
            }
            let now_ms = Mono::now().ticks();
            let step = cx.shared.sensors.lock(|s| {
                if bus::take_busy_seen() > 0 || bus::busy_while_idle() {
                    s.request_bus_recovery();
                }
                s.maintain(now_ms, &mut AsmDelay)
            });
            on_maintenance(
                step,
                now_ms,
                &mut cx.shared.sensors,
                &mut cx.shared.pipeline,
            );
            mpu_bridge(&mut cx.shared.sensors, &mut cx.shared.outputs, now_us);
            // ≤ 10 ms between rounds: the bound on how late a recovery starts.
            let wait_us = match deadline {
                Some(d) => (d.wrapping_sub(now_us) as i32).clamp(1_000, 10_000) as u32,
                None => 10_000,
            };
            Mono::delay(ExtU32::millis(wait_us.div_ceil(1_000))).await;
        }
    }

    /// The MPU's re-initialisation and the output guard: the guard bridges
    /// it (`flight::outputguard`); samples stopped for 10 ms while armed
    /// make the MPU suspect at once (a chip that reset itself stops its
    /// data-ready interrupt), not at the next 50 ms configuration check.
    fn mpu_bridge(
        sensors: &mut impl rtic::Mutex<T = Sensors<BusHandle>>,
        outputs: &mut impl rtic::Mutex<T = GuardedOutputs>,
        now_us: u32,
    ) {
        let recovering = sensors.lock(|s| s.mpu_recovering());
        let since_us = outputs.lock(|o| o.set_mpu_recovering(recovering, now_us));
        sensors.lock(|s| s.mpu_sample_gap(since_us));
    }

    /// Carries out and logs what a maintenance step asked for or did.
    fn on_maintenance(
        step: Maintenance,
        now_ms: u32,
        sensors: &mut impl rtic::Mutex<T = Sensors<BusHandle>>,
        pipeline: &mut impl rtic::Mutex<T = Option<Pipeline>>,
    ) {
        match step {
            Maintenance::Idle | Maintenance::MpuResetStep => {}
            Maintenance::RecoverBus => {
                let (r, n) = sensors.lock(|s| {
                    let r = bus::recover();
                    match r {
                        Ok(_) => s.after_bus_recovery(),
                        Err(_) => s.bus_recovery_failed(now_ms),
                    }
                    (r, s.bus_recoveries())
                });
                match r {
                    Ok(rep) => defmt::warn!(
                        "I2C stuck: recovered after {=u8} SCL clock(s), BUSY unlocked, I2C1 reset (recovery {=u32})",
                        rep.clocks,
                        n
                    ),
                    Err(e) => defmt::error!("I2C stuck: recovery failed: {} (recovery {=u32})", e, n),
                }
            }
            Maintenance::Reinitialised { chip, ok: true } => {
                defmt::info!("re-init {}: passed", chip)
            }
            Maintenance::Reinitialised { chip, ok: false } => {
                defmt::info!("re-init {}: FAILED", chip)
            }
            Maintenance::Settled { ok: true } => {
                defmt::info!("MPU-9250 check (WHO_AM_I, PWR_MGMT_1, config): passed")
            }
            Maintenance::Settled { ok: false } => {
                defmt::info!("MPU-9250 check (WHO_AM_I, PWR_MGMT_1, config): FAILED")
            }
            Maintenance::StillMissing { chip, retry_in_ms } => {
                defmt::info!(
                    "{} still missing, next probe in {=u32} ms",
                    chip,
                    retry_in_ms
                )
            }
            Maintenance::Appeared(chip) => {
                let (caps, mag_scale) = sensors.lock(|s| (s.capabilities(), s.mag_ut_per_lsb()));
                pipeline.lock(|p| {
                    if let Some(p) = p {
                        p.set_mag_ut_per_lsb(mag_scale);
                        p.set_capabilities(caps.ahrs, caps.altitude);
                    }
                });
                defmt::warn!("{} appeared: initialised and in use", chip);
                log_capabilities(&caps);
            }
        }
    }

    /// 20 Hz: watchdog, button and calibration session, live log, LED.
    #[task(priority = 1, local = [led, button_pin, iwdg, flash, record, console],
           shared = [sensors, pipeline, stats, session, bias, pilot, clock, outputs])]
    async fn log(mut cx: log::Context) {
        let mut link = LinkStatus::NeverReceived;
        let mut tick: u32 = 0;
        #[cfg(builder)]
        let mut restart_in: Option<u8> = None;
        loop {
            tick = tick.wrapping_add(1);
            // Fed while sample steps complete, or while the outputs are off
            // and disarmed with the MPU out of the loop (missing, failed,
            // being re-initialised: the service task keeps the board
            // alive); never while they run without samples
            // (`flight::outputguard`).
            let mpu_ok = cx
                .shared
                .sensors
                .lock(|s| s.mpu_health.state() == SensorState::Ok);
            let now_us = cx.shared.clock.lock(|c| c.now_us(DWT::cycle_count()));
            if cx
                .shared
                .outputs
                .lock(|o| o.may_feed_watchdog(now_us, mpu_ok))
            {
                cx.local.iwdg.feed();
            }

            // The loop period is 50 ms: enough resolution for the button.
            let pressed = cx.local.button_pin.is_low();
            let record = &mut *cx.local.record;
            let (pressed_ev, polled_ev, mode) = cx.shared.session.lock(|c| {
                (
                    c.on_button(tick.wrapping_mul(50), pressed),
                    c.poll(record),
                    c.mode(),
                )
            });
            for ev in [pressed_ev, polled_ev].into_iter().flatten() {
                on_cal_event(ev, cx.local.flash, record, &mut cx.shared.pipeline);
            }

            link = log_pilot(tick, link, &mut cx.shared.pilot, &mut cx.shared.clock);
            if mode == sensor_stack::calmode::Mode::Normal {
                log_status(
                    tick,
                    &mut cx.shared.sensors,
                    &mut cx.shared.pipeline,
                    &mut cx.shared.stats,
                    &mut cx.shared.bias,
                );
            }
            #[cfg(builder)]
            {
                restart_in = console_round(cx.local.console, cx.local.flash, restart_in);
            }
            // Heartbeat: 1 Hz normally, 5 Hz while calibrating.
            let calibrating = matches!(
                mode,
                sensor_stack::calmode::Mode::MagCal | sensor_stack::calmode::Mode::AccelCal
            );
            if tick.is_multiple_of(if calibrating { 2 } else { 10 }) {
                cx.local.led.toggle();
            }
            Mono::delay(ExtU32::millis(50)).await;
        }
    }

    /// One round of the settings console (STM32F103CB build). A restart
    /// after `save` comes two rounds (100 ms) later, so the probe reads the
    /// reply out of RAM before the reset clears it, and never while armed
    /// (`save` is refused armed, but the pilot may arm in between): then
    /// the saved values apply at the next power-up. Returns the restart
    /// still pending.
    #[cfg(builder)]
    fn console_round(
        console: &mut crate::console::Console,
        flash: &mut flash::Parts,
        restart_in: Option<u8>,
    ) -> Option<u8> {
        let armed = ARMED.load(Ordering::Relaxed);
        match restart_in {
            Some(0) if armed => {
                defmt::warn!(
                    "settings: armed: no restart; the saved values apply at the next power-up"
                )
            }
            Some(0) => cortex_m::peripheral::SCB::sys_reset(),
            _ => {}
        }
        let pending = restart_in.and_then(|n| n.checked_sub(1));
        let after = console.poll(flash, armed, builder::filtered_counts());
        if after == crate::console::After::Restart {
            return Some(1);
        }
        pending
    }

    /// The raw log's header: `RAW_LOG_HEADER`, and in the STM32F103CB
    /// build `RATE_LOG_COLUMNS` after it, as interned literals (a `{=str}`
    /// argument would put its 125 bytes in flash); the emulated board's
    /// raw-log tests check they agree.
    #[inline(always)]
    fn log_raw_header() {
        #[cfg(not(builder))]
        defmt::println!(
            "t_s,gyr_x_rad_s,gyr_y_rad_s,gyr_z_rad_s,acc_x_m_s2,acc_y_m_s2,acc_z_m_s2,mag_x_ut,mag_y_ut,mag_z_ut,ref_qw,ref_qx,ref_qy,ref_qz,moving"
        );
        #[cfg(builder)]
        defmt::println!(
            "t_s,gyr_x_rad_s,gyr_y_rad_s,gyr_z_rad_s,acc_x_m_s2,acc_y_m_s2,acc_z_m_s2,mag_x_ut,mag_y_ut,mag_z_ut,ref_qw,ref_qx,ref_qy,ref_qz,moving,sp_roll_rate_dps,gyro_roll_dps,sp_pitch_rate_dps,gyro_pitch_dps,sp_yaw_rate_dps,gyro_yaw_dps"
        );
    }

    /// Logs a calibration event; a finished calibration is saved to flash
    /// (erase and program stall the CPU ~20–40 ms; samples are missed) and
    /// applied.
    // Out of line: measured smaller than inlined into the log task.
    #[inline(never)]
    fn on_cal_event(
        ev: CalEvent,
        flash: &mut flash::Parts,
        record: &CalibrationRecord,
        pipeline: &mut impl rtic::Mutex<T = Option<Pipeline>>,
    ) {
        match ev {
            CalEvent::ModeChanged { from, to } => {
                defmt::info!("mode {} -> {}", from, to);
                #[cfg(builder)]
                builder::set_raw_log(to == sensor_stack::calmode::Mode::RawLog);
                if to == sensor_stack::calmode::Mode::RawLog {
                    log_raw_header();
                }
            }
            CalEvent::Unavailable { .. } => crate::boot::log_not_in_this_build(),
            // Only a calibration build's sessions report (the flight
            // build's `CALIBRATION_BUILD` is false: none of this is linked).
            _ if !config::CALIBRATION_BUILD => {}
            CalEvent::MagProgress(p) => defmt::info!(
                "mag cal: {=u8}% ({=u8}/{=u8} directions, {=u32} samples): keep turning",
                p.percent,
                p.bins_hit,
                p.bins_needed,
                p.samples
            ),
            CalEvent::AccelProgress(p) => match config::MOUNTING.next_face(p.done) {
                Some(face) => defmt::info!(
                    "accel cal: {=u8} of 6 faces done; next: {}, and hold it still",
                    p.captured,
                    face
                ),
                None => defmt::info!("accel cal: all 6 faces done"),
            },
            CalEvent::MagRefused(e) => {
                defmt::warn!("mag cal: fit refused: {}; keep turning", e)
            }
            CalEvent::AccelRestarted => defmt::warn!("accel cal: implausible result, restarting"),
            CalEvent::MagDone { offset_ut } => {
                defmt::info!(
                    "mag cal done: offset {} µT, within 1 µT (3 standard errors)",
                    crate::report::Dec3(offset_ut)
                );
                save_calibration(flash, record, pipeline);
            }
            CalEvent::AccelDone { offset_g, scale } => {
                defmt::info!(
                    "accel cal done: offset {} g, scale {}",
                    crate::report::Dec3(offset_g),
                    crate::report::Dec3(scale)
                );
                save_calibration(flash, record, pipeline);
            }
        }
    }

    fn save_calibration(
        flash: &mut flash::Parts,
        record: &CalibrationRecord,
        pipeline: &mut impl rtic::Mutex<T = Option<Pipeline>>,
    ) {
        match storage::save(&mut FlashPage::new(flash), record) {
            Ok(()) => defmt::info!("calibration saved to flash"),
            Err(SaveError::Invalid(f)) => defmt::error!("calibration not saved: implausible {}", f),
            Err(SaveError::VerifyFailed) => defmt::error!("calibration save: read-back mismatch"),
            Err(SaveError::Storage(_)) => defmt::error!("calibration save: flash error"),
        }
        pipeline.lock(|p| p.as_mut().map(|p| p.set_calibration(record)));
    }
}
