//! The live log's lines that read several resources: the receiver's link
//! and channels, attitude, loop timing, sensor health, the stack. The
//! tasks call them; they only lock, read and print.

use crate::bus::BusHandle;
use crate::receiver::Pilot;
use crate::stack;
use cortex_m::peripheral::DWT;
use rc_input::LinkStatus;
use sensor_stack::boot::{AhrsMode, BiasStatus, Capabilities};
use sensor_stack::health::{HealthCounters, SensorState};
use sensor_stack::pipeline::Pipeline;
use sensor_stack::schedule::{LoopStats, MicrosClock};
use sensor_stack::sensors::Sensors;

/// The chips' capabilities (at boot and when a chip appears).
pub fn log_capabilities(caps: &Capabilities) {
    defmt::info!(
        "capabilities: AHRS {}, altitude {=bool}",
        caps.ahrs,
        caps.altitude
    );
    if caps.ahrs == AhrsMode::ImuOnly {
        defmt::warn!("no magnetometer: heading drifts with the gyro");
    }
}

/// One chip's health line.
pub fn log_health(name: &str, state: SensorState, c: &HealthCounters) {
    defmt::info!(
        "{=str}: {} ok={=u32} err={=u32} reinit={=u32} reset={=u32} ovf={=u32} notready={=u32}",
        name,
        state,
        c.ok,
        c.errors,
        c.reinits,
        c.resets_detected,
        c.overflows,
        c.not_ready
    );
}

/// The receiver's link state on every change; channels and counters
/// every second while frames arrive.
pub fn log_pilot(
    tick: u32,
    last: LinkStatus,
    pilot: &mut impl rtic::Mutex<T = Pilot>,
    clock: &mut impl rtic::Mutex<T = MicrosClock>,
) -> LinkStatus {
    let now_us = clock.lock(|c| c.now_us(DWT::cycle_count()));
    let (status, frame, stats, uart, lq) = pilot.lock(|p| {
        (
            p.status(now_us),
            p.frame,
            p.stats,
            p.uart,
            p.link_quality_pct,
        )
    });
    if status != last {
        match status {
            LinkStatus::Ok => defmt::info!("rc: link up"),
            LinkStatus::Recovering => defmt::info!(
                "rc: frames again, link up after {=u32} ms of them",
                rc_input::LINK_RECOVERY_US / 1_000
            ),
            other => defmt::warn!("rc: link lost ({})", other),
        }
    }
    if tick.is_multiple_of(20) && status != LinkStatus::Ok {
        log_no_link(pilot);
    }
    #[cfg(feature = "ppm")]
    let _ = (stats, uart, lq);
    #[cfg(feature = "ppm")]
    if tick.is_multiple_of(20) && status == LinkStatus::Ok {
        if let Some(f) = frame {
            let c = f.channels();
            let n = pilot.lock(|p| p.ppm);
            defmt::info!(
                "rc: ch1-8 {} us | ppm frames {=u32} dropped {=u32} (bad_pulse {=u32} bad_count {=u32} unconfirmed {=u32}) overcapture {=u32}",
                c.get(..8).unwrap_or(c),
                n.decoder.frames,
                n.decoder.dropped(),
                n.decoder.bad_pulse,
                n.decoder.bad_count,
                n.decoder.unconfirmed,
                n.overcaptures
            );
        }
    }
    #[cfg(not(feature = "ppm"))]
    if tick.is_multiple_of(20) && status == LinkStatus::Ok {
        if let Some(f) = frame {
            let c = f.channels();
            defmt::info!(
                "rc: ch1-8 {} us | {} | frames {=u32} crc_err {=u32} dropped {=u32} | uart ore {=u32} fe {=u32} late {=u32}",
                c.get(..8).unwrap_or(c),
                Lq(lq),
                stats.rc_frames,
                stats.crc_errors,
                stats.dropped(),
                uart.overruns,
                uart.framing,
                uart.late
            );
        }
    }
    status
}

/// Every second without a link: what reaches the receiver's pin, so a
/// silent or miswired receiver, or one on the wrong protocol or baud rate,
/// can be told apart from the log.
#[cfg(not(feature = "ppm"))]
fn log_no_link(pilot: &mut impl rtic::Mutex<T = Pilot>) {
    let (s, u) = pilot.lock(|p| (p.stats, p.uart));
    if u.bytes == 0 {
        defmt::warn!(
            "rc: no link: no bytes at all on PA10 (USART1 RX): check the receiver's TX wire to PA10, the common ground, its power and binding"
        );
    } else {
        defmt::warn!(
            "rc: no link: PA10 (USART1 RX) since boot: bytes {=u32} frames {=u32} crc_err {=u32} fe {=u32} | CRSF at 420000 baud is expected: bytes with no frames and with framing errors (fe) mean another protocol or baud rate, frames with crc_err a noisy line",
            u.bytes,
            s.rc_frames,
            s.crc_errors,
            u.framing
        );
    }
}

/// Every second without a link: what reaches PB8, so a silent or
/// miswired PPM receiver can be told apart from the log.
#[cfg(feature = "ppm")]
fn log_no_link(pilot: &mut impl rtic::Mutex<T = Pilot>) {
    let n = pilot.lock(|p| p.ppm);
    let d = n.decoder;
    if d.frames == 0 && d.dropped() == 0 && n.overcaptures == 0 {
        defmt::warn!(
            "rc: no link: no PPM pulses at all on PB8 (TIM4_CH3): check the receiver's PPM wire to PB8, the common ground, its power and binding"
        );
    } else {
        defmt::warn!(
            "rc: no link: PB8 (TIM4_CH3) since boot: frames {=u32} dropped {=u32} (bad_pulse {=u32} bad_count {=u32}) | a PPM sum signal is expected",
            d.frames,
            d.dropped(),
            d.bad_pulse,
            d.bad_count
        );
    }
}

/// The link quality in the channel line: the receiver's figure from its
/// link-statistics frames, or that it sends none.
#[cfg(not(feature = "ppm"))]
struct Lq(Option<u8>);

#[cfg(not(feature = "ppm"))]
impl defmt::Format for Lq {
    fn format(&self, f: defmt::Formatter) {
        match self.0 {
            Some(p) => defmt::write!(f, "lq {=u8} %", p),
            None => defmt::write!(f, "lq unknown (no link-statistics frames)"),
        }
    }
}

/// A number printed with 2 or 3 decimals (`r=-0.05`, `alt=1.753`, not
/// `r=-0.0542043`): defmt has no float precision hint, so it goes as a
/// scaled integer. Rounded to nearest, saturating (NaN → 0).
pub struct Dec {
    /// The value · 100 (2 decimals) or · 1000 (3).
    scaled: i32,
    /// Three decimals, else two.
    milli: bool,
}

impl Dec {
    /// `x` with three decimals if `milli`, else two.
    #[inline(never)]
    pub fn new(x: f32, milli: bool) -> Self {
        let k = if milli { 1000.0 } else { 100.0 };
        let r = if x < 0.0 { -0.5 } else { 0.5 };
        Self {
            scaled: (x * k + r) as i32,
            milli,
        }
    }
}

/// Three values with three decimals each, `[x, y, z]`.
pub struct Dec3(pub [f32; 3]);

impl defmt::Format for Dec3 {
    fn format(&self, f: defmt::Formatter) {
        let [x, y, z] = self.0.map(|v| Dec::new(v, true));
        defmt::write!(f, "[{}, {}, {}]", x, y, z);
    }
}

impl defmt::Format for Dec {
    fn format(&self, f: defmt::Formatter) {
        let a = self.scaled.unsigned_abs();
        if self.scaled < 0 {
            defmt::write!(f, "-");
        }
        if self.milli {
            defmt::write!(f, "{=u32}.{=u32:03}", a / 1000, a % 1000);
        } else {
            defmt::write!(f, "{=u32}.{=u32:02}", a / 100, a % 100);
        }
    }
}

/// The live log: attitude every call; loop timing, health, bus counters
/// and the gyro bias every second; the stack every 5 s.
pub fn log_status(
    tick: u32,
    sensors: &mut impl rtic::Mutex<T = Sensors<BusHandle>>,
    pipeline: &mut impl rtic::Mutex<T = Option<Pipeline>>,
    stats: &mut impl rtic::Mutex<T = LoopStats>,
    bias: &mut impl rtic::Mutex<T = BiasStatus>,
) {
    if let Some(o) = pipeline.lock(|p| p.as_ref().map(|p| p.outputs())) {
        defmt::info!(
            "att r={} p={} y={} deg | alt={} m vz={} m/s",
            Dec::new(o.roll_deg, false),
            Dec::new(o.pitch_deg, false),
            Dec::new(o.yaw_deg, false),
            Dec::new(o.altitude_m, true),
            Dec::new(o.vertical_speed_mps, true)
        );
    }
    if tick.is_multiple_of(20) {
        let r = stats.lock(|s| s.report(DWT::cycle_count()));
        defmt::info!(
            "loop: {=u32} runs, imu task mean {=u32} cyc worst {=u32} cyc, cpu {=u32}.{=u32}%",
            r.runs,
            r.mean_cycles,
            r.worst_cycles,
            r.load_permille / 10,
            r.load_permille % 10
        );
        let (a, b, c, n) = sensors.lock(|s| {
            (
                (s.mpu_health.state(), *s.mpu_health.counters()),
                (s.mag_health.state(), *s.mag_health.counters()),
                (s.baro_health.state(), *s.baro_health.counters()),
                s.bus_recoveries(),
            )
        });
        log_health("mpu", a.0, &a.1);
        log_health("mag", b.0, &b.1);
        log_health("baro", c.0, &c.1);
        let b = bias.lock(|b| *b);
        defmt::info!("i2c recoveries: {=u32} | gyro bias: {}", n, b);
    }
    if tick.is_multiple_of(100) {
        let (used, size) = stack::high_water();
        defmt::info!("stack high-water {=usize} of {=usize} bytes", used, size);
    }
}
