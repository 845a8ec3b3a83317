//! What a builder expects before a second flight, in the STM32F103CB
//! build: the battery (ADC1 → `battery`'s monitor → the low-battery
//! descent the flight controller honours) and the state CRSF telemetry
//! reports. The rules are the crates' (`battery`, `rc_input::telemetry`);
//! this module only carries values between the tasks that own them.
//!
//! Between tasks: the flight step (priority 3) publishes its state in
//! [`FLIGHT`] and reads the descent request from [`BATTERY_DESCENT`]
//! (atomics: one word, one writer each); the builder task (priority 1,
//! 10 Hz) writes the request and the telemetry snapshot the telemetry
//! task (priority 2) sends from ([`set_telemetry`], [`telemetry`]: a copy
//! of 40 bytes in a critical section; not an RTIC resource, which would
//! be in the C8 builds too, whose flash has no room for it).

use battery::{
    BatteryAction, BatteryMonitor, Config, DescentConfig, DescentPhase, Event, FlightContext,
    Level, LowBatteryDescent, Status, SticksQ30,
};
use core::cell::Cell;
use core::sync::atomic::{AtomicBool, AtomicU16, AtomicU8, Ordering};
use critical_section::Mutex;
use flight::flightctl::{
    FlightController, FlightMode, FlightOutput, FlightState, PilotInput, SystemStatus, VehicleState,
};
use params::ParamSet;
use rc_input::telemetry::{
    Arming, Attitude, BaroAltitude, Battery, FlightMode as ModeFrame, ModeName, TelemetrySnapshot,
};
use sensor_stack::gyro_filter::GyroFilterDesign;
use sensor_stack::storage::CalibrationRecord;

use crate::adc::BatteryAdc;
use crate::crsf_tx::{CrsfTx, FRAME_BYTES};

/// The low-battery descent is asked for (builder → flight step).
pub static BATTERY_DESCENT: AtomicBool = AtomicBool::new(false);
/// The flight step's state (flight step → builder): [`FlightBits`].
pub static FLIGHT: AtomicU8 = AtomicU8::new(0);
/// The battery monitor's filtered ADC reading for the console's `vbat`
/// (builder → log task; 0: none yet).
static FILTERED_COUNTS: AtomicU16 = AtomicU16::new(0);

/// The monitor's filtered ADC reading, once it has one.
pub fn filtered_counts() -> Option<u16> {
    Some(FILTERED_COUNTS.load(Ordering::Relaxed)).filter(|&c| c > 0)
}

/// The snapshot telemetry sends from (builder task → telemetry task).
static TELEMETRY: Mutex<Cell<Option<TelemetrySnapshot>>> = Mutex::new(Cell::new(None));

/// Replaces the snapshot telemetry sends from.
pub fn set_telemetry(snap: TelemetrySnapshot) {
    critical_section::with(|cs| TELEMETRY.borrow(cs).set(Some(snap)));
}

/// The latest snapshot (the default one before the first).
pub fn telemetry() -> TelemetrySnapshot {
    critical_section::with(|cs| TELEMETRY.borrow(cs).get()).unwrap_or_default()
}

/// The raw log is on (log task → flight step): the rate block is summed
/// only then, its soft float kept off the 1 kHz step otherwise.
static RAW_LOG_ON: AtomicBool = AtomicBool::new(false);

/// The raw log was switched on or off.
pub fn set_raw_log(on: bool) {
    RAW_LOG_ON.store(on, Ordering::Relaxed);
}

/// The rate loop's last raw-log period: setpoint and gyro per axis (body
/// FRD, °/s, interleaved as the raw log's columns), flight step → raw-log
/// task.
static RATE_BLOCK: Mutex<Cell<[f32; 6]>> = Mutex::new(Cell::new([f32::NAN; 6]));

/// The rate loop's setpoint and the filtered gyro it controls, averaged
/// over each raw-log period (10 samples: a boxcar before the 100 Hz
/// decimation, so rotor vibration does not alias into the band the
/// analysis reads), for the raw log's rate columns (`cargo sim --analyse`).
pub struct RateLog {
    sum: [f32; 6],
    n: u16,
}

impl RateLog {
    /// Nothing summed.
    pub const fn new() -> Self {
        Self {
            sum: [0.0; 6],
            n: 0,
        }
    }

    /// One flight step: its rate setpoint (rad/s) and the gyro the loop
    /// saw (Q16 rad/s); each full period published for the raw log.
    pub fn push(&mut self, out: &FlightOutput, gyro_q16: Option<[i32; 3]>) {
        let Some(g) = gyro_q16.filter(|_| RAW_LOG_ON.load(Ordering::Relaxed)) else {
            return;
        };
        let sp = &out.rate_setpoint;
        let deg = 180.0 / core::f32::consts::PI;
        let q16 = |x: i32| x as f32 * (deg / 65_536.0);
        let v = [
            sp.roll_rps * deg,
            q16(g[0]),
            sp.pitch_rps * deg,
            q16(g[1]),
            sp.yaw_rps * deg,
            q16(g[2]),
        ];
        for (s, x) in self.sum.iter_mut().zip(v) {
            *s += x;
        }
        self.n += 1;
        if self.n >= sensor_stack::calmode::RAW_LOG_DIVIDER {
            let k = 1.0 / f32::from(self.n);
            let block = self.sum.map(|s| s * k);
            critical_section::with(|cs| RATE_BLOCK.borrow(cs).set(block));
            *self = Self::new();
        }
    }
}

/// The last published rate block (NaN before the first).
pub fn rate_block() -> [f32; 6] {
    critical_section::with(|cs| RATE_BLOCK.borrow(cs).get())
}

/// One flight-controller step with the builder's parts around it: the
/// low-battery descent request in, the flight state out for the builder
/// task, the rate loop's signals into the raw log's block.
pub fn flight_step(
    fc: &mut FlightController,
    rate_log: &mut RateLog,
    (now_us, pilot, status, v): (u32, &PilotInput, &SystemStatus, &VehicleState),
) -> FlightOutput {
    fc.set_battery_descent(BATTERY_DESCENT.load(Ordering::Relaxed));
    let o = fc.step(now_us, pilot, status, v);
    publish_flight(&o, fc.in_flight());
    rate_log.push(&o, v.gyro_rps_q16);
    o
}

/// [`FLIGHT`]'s bits.
struct FlightBits;

impl FlightBits {
    const ARMED: u8 = 1;
    const IN_FLIGHT: u8 = 2;
    const FAILSAFE: u8 = 4;
    const ALTHOLD: u8 = 8;
    const ACRO: u8 = 16;
}

/// Publishes a flight step's outcome for the builder task.
pub fn publish_flight(out: &FlightOutput, in_flight: bool) {
    let mut b = 0;
    if matches!(out.state, FlightState::Armed | FlightState::Failsafe(_)) {
        b |= FlightBits::ARMED;
    }
    if in_flight {
        b |= FlightBits::IN_FLIGHT;
    }
    if matches!(out.state, FlightState::Failsafe(_)) {
        b |= FlightBits::FAILSAFE;
    }
    match out.mode {
        FlightMode::AltitudeHold => b |= FlightBits::ALTHOLD,
        FlightMode::Acro => b |= FlightBits::ACRO,
        FlightMode::Angle => {}
    }
    FLIGHT.store(b, Ordering::Relaxed);
}

/// A stick in Q30 (the battery rule's form), saturating.
fn q30(x: f32) -> i32 {
    (x.clamp(-1.0, 1.0) * (1u32 << 30) as f32) as i32
}

/// The battery: ADC, monitor, and the pilot's override of the descent.
pub struct BatteryTask {
    adc: Option<BatteryAdc>,
    monitor: BatteryMonitor,
    descent: LowBatteryDescent,
    action: BatteryAction,
}

impl BatteryTask {
    /// With the ADC (`None`: it failed to calibrate; no battery then) and
    /// the battery settings.
    pub fn new(adc: Option<BatteryAdc>, cfg: Config, d: DescentConfig) -> Option<Self> {
        Some(Self {
            adc,
            monitor: BatteryMonitor::new(cfg).ok()?,
            descent: LowBatteryDescent::new(d).ok()?,
            action: BatteryAction::None,
        })
    }

    /// One 10 Hz step: the last conversion into the monitor (the next one
    /// started), the rule on the monitor's level, the pilot's input and
    /// the altitude estimate, the descent request published. The
    /// monitor's event, if any.
    pub fn step(&mut self, pilot: &PilotInput, altitude: bool) -> Option<Event> {
        // A new conversion into the monitor; the rule below runs every
        // step on its last level, so the pilot's sticks end a descent even
        // if the ADC stopped converting.
        let counts = self.adc.as_mut().and_then(BatteryAdc::poll);
        let event = counts.and_then(|c| self.monitor.update(c));
        let filtered = self.monitor.filtered_counts().unwrap_or(0);
        FILTERED_COUNTS.store(filtered, Ordering::Relaxed);
        let bits = FLIGHT.load(Ordering::Relaxed);
        let ctx = FlightContext {
            armed: bits & FlightBits::ARMED != 0,
            in_air: bits & FlightBits::IN_FLIGHT != 0,
            altitude_available: altitude,
            link_ok: pilot.link_ok,
        };
        let s = &pilot.sticks;
        let sticks = SticksQ30 {
            roll_q30: q30(s.roll),
            pitch_q30: q30(s.pitch),
            yaw_q30: q30(s.yaw),
            throttle_q30: q30(s.throttle),
        };
        let before = self.descent.phase();
        self.action = self
            .descent
            .update(self.monitor.status().level, &ctx, &sticks);
        log_phase(before, self.descent.phase());
        let descend = matches!(self.action, BatteryAction::Descend { .. });
        BATTERY_DESCENT.store(descend, Ordering::Relaxed);
        event
    }

    /// The monitor's status.
    pub fn status(&self) -> Status {
        self.monitor.status()
    }

    /// What the rule asks for now.
    pub fn action(&self) -> BatteryAction {
        self.action
    }
}

/// The battery for telemetry: filtered voltage, and the charge left by
/// the filtered cell voltage between 3.30 V (0 %) and 4.20 V (100 %),
/// linear (no current sensor: no current, no capacity used).
pub fn battery_frame(s: &Status) -> Option<Battery> {
    if s.level == Level::NoBattery {
        return None;
    }
    let cell = s.filtered_cell_mv.clamp(3300, 4200);
    Some(Battery {
        voltage_mv: s.filtered_mv,
        current_ma: 0,
        used_mah: 0,
        remaining_pct: ((cell - 3300) / 9) as u8,
    })
}

/// The snapshot telemetry sends: attitude (Q16 rad, from the Q30
/// quaternion), barometric height (cm, cm/s) if known, battery, mode.
pub fn snapshot(
    euler_q16: [i32; 3],
    altitude: Option<(f32, f32)>,
    battery: Option<Battery>,
) -> TelemetrySnapshot {
    let bits = FLIGHT.load(Ordering::Relaxed);
    let mode = if bits & FlightBits::FAILSAFE != 0 {
        ModeName::Failsafe
    } else if bits & FlightBits::ALTHOLD != 0 {
        ModeName::AltitudeHold
    } else if bits & FlightBits::ACRO != 0 {
        ModeName::Acro
    } else {
        ModeName::Angle
    };
    let arming = if bits & FlightBits::ARMED != 0 {
        Arming::Armed
    } else {
        Arming::Ready
    };
    TelemetrySnapshot {
        attitude: Attitude {
            roll_rad_q16: euler_q16[0],
            pitch_rad_q16: euler_q16[1],
            yaw_rad_q16: euler_q16[2],
        },
        baro: altitude.map(|(h, v)| BaroAltitude {
            altitude_cm: (h * 100.0) as i32,
            vertical_speed_cmps: (v * 100.0) as i32,
        }),
        battery,
        flight_mode: ModeFrame { mode, arming },
    }
}

/// Starts the builder's hardware in `init`, after the receiver (which
/// clocks USART1, GPIOA and DMA1 and enables the transmitter): the
/// telemetry transmitter and the battery's ADC. A failed ADC calibration
/// is logged and leaves the battery unread.
pub fn start(
    adc1: stm32f1xx_hal::pac::ADC1,
    tx_buf: &'static mut [u8; FRAME_BYTES],
    params: &ParamSet,
) -> (CrsfTx, Option<BatteryTask>) {
    let tx = CrsfTx::start(tx_buf);
    let adc = match BatteryAdc::start(adc1, crate::delay::cpu_hz()) {
        Ok(a) => Some(a),
        Err(e) => {
            defmt::error!("battery: ADC1 {}: the pack is not monitored", e);
            None
        }
    };
    let cfg = params.battery_config().unwrap_or_else(|e| {
        defmt::error!("battery: settings refused ({}); defaults used", e);
        Config::DEFAULT
    });
    let task = BatteryTask::new(adc, cfg, DescentConfig::DEFAULT);
    (tx, task)
}

/// Says when the low-battery descent starts and when the pilot takes
/// over (README "Flying": the rule).
fn log_phase(before: DescentPhase, now: DescentPhase) {
    match (before, now) {
        (DescentPhase::Idle, DescentPhase::Descending { .. }) => defmt::error!(
            "battery: low-battery descent: level, down at the failsafe rate; a roll, pitch or yaw stick past 20 % or the throttle moved 20 % takes over"
        ),
        (DescentPhase::Descending { .. }, DescentPhase::PilotControl) => {
            defmt::warn!("battery: the pilot took over the descent (warning only from now)")
        }
        _ => {}
    }
}

/// The calibration record with the settings' mounting and level trim
/// (`params::ParamSet::level_trim_mpu_g`: an accelerometer offset in the
/// MPU frame, added to the calibrated one).
pub fn with_settings(mut rec: CalibrationRecord, p: &ParamSet) -> CalibrationRecord {
    rec.mounting = p.mounting();
    let trim = p.level_trim_mpu_g(&rec.mounting);
    for (o, t) in rec.accel_offset_g.iter_mut().zip(trim) {
        *o += t;
    }
    rec
}

/// The rate loop's gyro filter from the settings, designed at boot for
/// the sample rate; the board's own (`settings`) if the design refuses
/// them (the table's ranges are meant to make that impossible).
pub fn gyro_filter(p: &ParamSet) -> GyroFilterDesign {
    match p.gyro_filter().design(settings::IMU_RATE_HZ) {
        Ok(d) => d,
        Err(e) => {
            defmt::error!("settings: gyro filter refused ({}); board default", e);
            settings::GYRO_FILTER_DESIGN
        }
    }
}

/// Says what the battery monitor saw, with the numbers a pilot checks.
pub fn log_battery_event(ev: Event, s: Status) {
    match ev {
        Event::Connected {
            cells,
            source,
            pack_mv,
        } => defmt::info!("battery: {=u8}S ({}) at {=u32} mV", cells, source, pack_mv),
        Event::Raised(Level::Critical) => defmt::error!(
            "battery: CRITICAL {=u32} mV/cell ({=u32} mV)",
            s.filtered_cell_mv,
            s.filtered_mv
        ),
        Event::Raised(level) => defmt::warn!(
            "battery: {} {=u32} mV/cell ({=u32} mV)",
            level,
            s.filtered_cell_mv,
            s.filtered_mv
        ),
        Event::Disconnected => defmt::info!("battery: disconnected"),
    }
}
