//! `init`'s boot steps, in the order `init` calls them: each sets up one
//! thing, logs what it found, and returns it for the app's resources.
//!
//! They stay out of line (`#[inline(never)]`): inlined, their results are
//! moved through init's frame once more each (0.1 KiB of flash).

use crate::bus::{self, BusHandle};
use crate::clocks::Source;
use crate::config::{Session, ESC_PROTOCOL, MOUNTING};
use crate::delay::{cpu_hz, AsmDelay};
use crate::outputs::EscOutputs;
#[cfg(feature = "ppm")]
use crate::ppm::PpmInput;
#[cfg(not(feature = "ppm"))]
use crate::receiver::{self, CrsfRx, RING_BYTES};
use crate::report::log_capabilities;
use crate::store::FlashPage;
use control::esc::EscTimer;
use embedded_hal::delay::DelayNs;
use flight::flightctl::FlightController;
use sensor_stack::boot::{Capabilities, StartupGyroBias};
use sensor_stack::pipeline::{Pipeline, PipelineConfig};
use sensor_stack::schedule::IMU_RATE_HZ;
use sensor_stack::sensors::Sensors;
use sensor_stack::storage::{self, CalibrationRecord, LoadError, LoadOutcome};
use stm32f1xx_hal::{
    flash,
    gpio::{Input, PullUp, PA0},
    pac,
};

/// Boot step: the ESC outputs at the off pulse. The timer clock is
/// APB1 × 2 = SYSCLK (APB1 runs at SYSCLK / 2).
#[inline(never)]
pub fn start_outputs(tim: pac::TIM3) -> EscOutputs {
    let timer = match EscTimer::for_clock(ESC_PROTOCOL, ESC_PROTOCOL.default_rate_hz(), cpu_hz()) {
        Ok(t) => t,
        // Both protocols fit TIM3 at 64 and 72 MHz (control's tests);
        // a failure here is a build configuration error.
        Err(e) => defmt::panic!("ESC timer: {}", e),
    };
    let esc = EscOutputs::start(tim, timer);
    // In 32-bit integers: `EscTimer::period_ns`/`pulse_ns` divide in u64,
    // which would link a ~0.9 KiB library routine for this line. The
    // timer ticks at a whole number of kHz (1 MHz for PWM, 8 MHz for
    // OneShot125), so the off pulse comes out in whole µs.
    defmt::info!(
        "outputs: {} on TIM3 CH1-4 (PA6 PA7 PB0 PB1), {=u32} Hz, off pulse {=u32} us",
        ESC_PROTOCOL,
        timer.tick_hz() / timer.period_ticks().max(1),
        u32::from(timer.off_compare()) * 1_000 / (timer.tick_hz() / 1_000).max(1)
    );
    esc
}

/// Boot step (STM32F103CB build): the parameter table's values from the
/// A/B pages, or the defaults (with each page's reason) when neither
/// holds a valid record.
#[cfg(builder)]
#[inline(never)]
pub fn load_params(flash: &mut flash::Parts) -> params::ParamSet {
    let outcome = params::store::load(&mut crate::store::ParamPages::new(flash));
    match &outcome {
        params::store::LoadOutcome::Stored { page, record } => defmt::info!(
            "settings: loaded from PARAMS_{} (save {=u32})",
            if *page == params::store::Page::A {
                "A"
            } else {
                "B"
            },
            record.sequence
        ),
        params::store::LoadOutcome::Defaults { .. } => {
            defmt::info!("settings: defaults (no saved settings)")
        }
    }
    outcome.set()
}

/// Boot step (STM32F103CB build): the flight controller with the
/// parameter table's tuning over the board's settings; an invalid
/// combination falls back to the board's settings, then to none.
#[cfg(builder)]
#[inline(never)]
pub fn start_flight_controller_with(p: &params::ParamSet) -> Option<FlightController> {
    match FlightController::new(p.flight_config(settings::flight_config())) {
        Ok(fc) => {
            defmt::info!("flight controller: ready, disarmed (settings applied)");
            Some(fc)
        }
        Err(e) => {
            defmt::error!(
                "flight controller: settings refused ({}); board defaults",
                e
            );
            start_flight_controller()
        }
    }
}

/// Boot step: the flight controller (disarmed). Without one (an invalid
/// configuration) the motors stay off.
#[cfg(not(feature = "calibrate"))]
#[inline(never)]
pub fn start_flight_controller() -> Option<FlightController> {
    match FlightController::new(settings::flight_config()) {
        Ok(fc) => {
            defmt::info!(
                "flight controller: ready, disarmed; arm channel {=u8}, mode channel {=u8}, motor-test channel {=u8}",
                crate::config::channel_map().arm_channel() + 1,
                crate::config::MODE_CHANNEL + 1,
                crate::config::MOTOR_TEST_CHANNEL + 1
            );
            Some(fc)
        }
        Err(e) => {
            defmt::error!("flight controller: {}; motors stay off", e);
            None
        }
    }
}

/// The calibration build has no flight controller: the motors stay off.
#[cfg(feature = "calibrate")]
pub fn start_flight_controller() -> Option<FlightController> {
    defmt::warn!("flight controller: not built (calibration build); motors stay off");
    None
}

/// Boot step: the PPM receiver on PB8 (TIM4_CH3); TIM4's clock is
/// APB1 × 2 = SYSCLK, like TIM3's.
#[cfg(feature = "ppm")]
#[inline(never)]
pub fn start_ppm(tim: pac::TIM4) -> PpmInput {
    let ppm = PpmInput::start(tim, cpu_hz());
    defmt::info!(
        "receiver: PPM on PB8 (TIM4_CH3 input capture, 5 V tolerant), rising edges, 1 us resolution, signal loss after {=u32} ms",
        rc_input::PPM_TIMEOUT_US / 1_000
    );
    ppm
}

/// Boot step: the CRSF receiver on USART1 RX (PA10); APB2 runs at SYSCLK.
#[cfg(not(feature = "ppm"))]
#[inline(never)]
pub fn start_receiver(
    usart: pac::USART1,
    dma: pac::DMA1,
    ring: &'static mut [u8; RING_BYTES],
) -> CrsfRx {
    let rx = CrsfRx::start(usart, dma, ring, cpu_hz());
    defmt::info!(
        "receiver: CRSF on USART1 RX (PA10), {=u32} baud, DMA1 channel 5 into a {=u16} B ring",
        receiver::CRSF_BAUD,
        RING_BYTES as u16
    );
    rx
}

/// Boot step: the boot line, with the clock source.
pub fn log_boot(source: Source) {
    if source == Source::HsiFallback {
        defmt::warn!("boot: 8 MHz crystal did not start within 20 ms; running on HSI at 64 MHz");
    }
    defmt::info!(
        "boot: {=u32} MHz ({}), I2C1 400 kHz on PB6/PB7, MPU INT on PB5, AHRS: {=str}; a stuck I2C bus is recovered (SCL clocked, STOP, BUSY unlocked), a missing chip is re-probed every 1-32 s, a chip that returns is re-initialised and used",
        cpu_hz() / 1_000_000,
        source,
        sensor_stack::pipeline::AHRS_KIND
    );
}

/// Boot step: free the bus unconditionally (a reset in the middle of a
/// transfer leaves a slave driving SDA about as often as not).
pub fn recover_bus_at_boot() {
    match bus::recover() {
        Ok(r) if r.clocks > 0 => {
            defmt::warn!(
                "I2C recovery at boot: SDA released after {=u8} SCL clock(s)",
                r.clocks
            )
        }
        Ok(_) => {}
        Err(e) => defmt::error!("I2C recovery at boot failed: {}", e),
    }
}

/// Boot step: probe and configure the three chips.
#[inline(never)]
pub fn probe_sensors() -> Sensors<BusHandle> {
    let (sensors, report) = Sensors::boot(
        BusHandle,
        BusHandle,
        BusHandle,
        &mut AsmDelay,
        settings::sensors_config(),
    );
    for r in [report.mpu, report.mag, report.baro] {
        match r.status {
            Ok(()) => defmt::info!("probe {}: ok ({=u8} attempt(s))", r.chip, r.attempts),
            Err(f) => defmt::error!(
                "probe {}: FAILED after {=u8} attempt(s): {}; re-probed in the background",
                r.chip,
                r.attempts,
                f
            ),
        }
    }
    log_capabilities(&sensors.capabilities());
    sensors
}

/// Boot step: the calibration record from flash (defaults and the
/// reason if blank or corrupt), with the board's mounting from
/// `config.rs`.
#[inline(never)]
pub fn load_calibration(flash: &mut flash::Parts) -> CalibrationRecord {
    let mut record = match storage::load(&mut FlashPage::new(flash)) {
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
    };
    record.mounting = MOUNTING;
    record
}

/// Boot step: the processing pipeline for the chips found.
#[inline(never)]
pub fn build_pipeline(
    sensors: &Sensors<BusHandle>,
    caps: &Capabilities,
    record: &CalibrationRecord,
    #[cfg(builder)] gyro_filter: sensor_stack::gyro_filter::GyroFilterDesign,
) -> Option<Pipeline> {
    let scale = sensors.mpu_scale();
    let cfg = PipelineConfig {
        cpu_hz: cpu_hz(),
        gyro_dps_per_lsb: scale.dps_per_lsb,
        accel_g_per_lsb: scale.g_per_lsb,
        mag_ut_per_lsb: sensors.mag_ut_per_lsb(),
        ahrs_mode: caps.ahrs,
        altitude: caps.altitude,
        #[cfg(builder)]
        gyro_filter,
        ..settings::pipeline_config()
    };
    let p = Pipeline::new(cfg, record).ok();
    if p.is_none() {
        defmt::error!("pipeline: invalid configuration; no processing");
    }
    p
}

/// Boot step: the start-up gyro bias (1 s still, within the first 5 s of
/// samples; measured one sample at a time in `sample_done`).
#[inline(never)]
pub fn start_gyro_bias(sensors: &Sensors<BusHandle>) -> Option<StartupGyroBias> {
    let scale = sensors.mpu_scale();
    StartupGyroBias::new(
        IMU_RATE_HZ,
        1.0 / scale.dps_per_lsb,
        1.0 / scale.g_per_lsb,
        5,
    )
    .ok()
}

/// Boot step: the button held at reset starts the accelerometer
/// calibration.
#[inline(never)]
pub fn start_session(button: &PA0<Input<PullUp>>) -> Session {
    // Let the internal pull-up charge the line (~100 µs) before sampling.
    AsmDelay.delay_us(100);
    let session = Session::new(button.is_low());
    if session.mode() == sensor_stack::calmode::Mode::AccelCal {
        defmt::info!("button held at boot: accelerometer six-position calibration");
    }
    if session.refused_at_boot() {
        log_not_in_this_build();
    }
    session
}

/// The flight build runs no calibration session: where they are.
pub fn log_not_in_this_build() {
    defmt::warn!(
        "calibration: not in the flight build; flash the calibration build (cargo embed --release --features calibrate), calibrate, then flash the flight build"
    );
}
