//! Shared helpers for the end-to-end tests in this folder: a simulated board
//! (clock, bus, delay) and small statistics.

use embedded_hal::delay::DelayNs;
use sensor_stack::boot::BootReport;
use sensor_stack::health::RecoveryPins;
use sensor_stack::sensors::{Sensors, SensorsConfig};
use sim::{SensorErrors, SimBus, SimClock, SimConfig, SimDelay, Trajectory};

/// A simulated board: one clock, one bus with the three chips, one delay.
pub struct Rig {
    /// Simulated time.
    pub clock: SimClock,
    /// The bus (clone it for each driver).
    pub bus: SimBus,
    /// A delay advancing `clock`.
    pub delay: SimDelay,
}

impl Rig {
    /// A board built from `config`.
    pub fn new(config: SimConfig) -> Self {
        let clock = SimClock::new();
        let bus = SimBus::new(&clock, config);
        let delay = clock.delay();
        Self { clock, bus, delay }
    }
}

/// The firmware's boot probing (`Sensors::boot`, default configuration)
/// on `rig`'s bus.
pub fn boot_sensors(rig: &mut Rig) -> (Sensors<SimBus>, BootReport) {
    Sensors::boot(
        rig.bus.clone(),
        rig.bus.clone(),
        rig.bus.clone(),
        &mut rig.delay,
        SensorsConfig::default(),
    )
}

/// Mean and standard deviation.
pub fn mean_sd(xs: &[f64]) -> (f64, f64) {
    let n = xs.len().max(1) as f64;
    let m = xs.iter().sum::<f64>() / n;
    let v = xs.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / n;
    (m, v.sqrt())
}

/// Per-axis mean of 3-vectors.
pub fn mean3(xs: &[[f64; 3]]) -> [f64; 3] {
    let n = xs.len().max(1) as f64;
    let mut m = [0.0; 3];
    for x in xs {
        for i in 0..3 {
            m[i] += x[i] / n;
        }
    }
    m
}

/// `f32` triple → `f64` triple.
pub fn f64x3(v: [f32; 3]) -> [f64; 3] {
    v.map(f64::from)
}

/// Open-drain PB6/PB7 model for the bus recovery: a slave holding SDA low
/// shifts one bit per SCL falling edge; once it lets go and a STOP
/// (SDA rising while SCL is high) is seen, the simulated bus's faults are
/// cleared (the stuck transfer is over).
pub struct StuckSda<'a> {
    bus: &'a SimBus,
    scl: bool,
    sda: bool,
    /// SCL falling edges until the slave releases SDA.
    pub hold: u8,
    /// SCL falling edges seen.
    pub clocks: u8,
    /// A STOP was generated after SDA was released.
    pub stop_seen: bool,
}

impl<'a> StuckSda<'a> {
    /// A slave on `bus` that holds SDA for `hold` more clocks.
    pub fn new(bus: &'a SimBus, hold: u8) -> Self {
        Self {
            bus,
            scl: true,
            sda: true,
            hold,
            clocks: 0,
            stop_seen: false,
        }
    }
}

impl RecoveryPins for StuckSda<'_> {
    fn set_scl(&mut self, high: bool) {
        if self.scl && !high {
            self.clocks += 1;
            self.hold = self.hold.saturating_sub(1);
        }
        self.scl = high;
    }
    fn set_sda(&mut self, high: bool) {
        if high && !self.sda && self.scl && self.hold == 0 {
            self.stop_seen = true;
            self.bus.clear_faults();
        }
        self.sda = high;
    }
    fn scl_is_high(&mut self) -> bool {
        self.scl
    }
    fn sda_is_high(&mut self) -> bool {
        self.sda && self.hold == 0
    }
}

/// Magnetometer samples (µT, MPU frame, AK8963 read through the MPU-9250's
/// bypass every 10 ms) for `seconds` of `trajectory` with `errors`. A test
/// helper: a driver error panics, failing the test that called it.
#[allow(clippy::expect_used, clippy::panic)]
pub fn mag_samples(
    errors: SensorErrors,
    trajectory: Trajectory,
    seed: u64,
    seconds: f64,
) -> Vec<[f32; 3]> {
    let mut rig = Rig::new(SimConfig {
        trajectory,
        errors,
        seed,
        ..SimConfig::default()
    });
    let mut imu = mpu9250::Mpu9250::new(rig.bus.clone(), mpu9250::Address::Ad0Low);
    imu.set_bypass(true).expect("bypass");
    imu.init(&mut rig.delay, &mpu9250::Config::default())
        .expect("MPU-9250 init");
    let mut mag = ak8963::Ak8963::new(rig.bus.clone());
    mag.init(&mut rig.delay, &ak8963::Config::default())
        .expect("AK8963 init");
    let mut out = Vec::new();
    while rig.clock.now_s() < seconds {
        rig.delay.delay_ms(10);
        match mag.read() {
            Ok(s) => out.push(s.field_mpu_ut()),
            Err(ak8963::Error::NotReady) => {}
            Err(e) => panic!("AK8963 read: {e:?}"),
        }
    }
    out
}
