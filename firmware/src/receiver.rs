//! The CRSF receiver on USART1 RX (PA10) at 420 kbaud 8N1: register set-up,
//! the per-interrupt byte read with the manual's flag handling, and the
//! pilot state the control loop reads. Frame parsing, channel mapping and
//! signal-loss timing are `rc_input`'s.

use control::shaping::Sticks;
use flight::flightctl::{FlightMode, PilotInput};
use rc_input::{ChannelMap, SwitchPosition};
use rc_input::{CrsfParser, CrsfStats, Event, LinkMonitor, LinkStatus, RcFrame};
use stm32f1xx_hal::pac;

/// CRSF line rate (ExpressLRS/Crossfire receivers to a flight controller).
pub const CRSF_BAUD: u32 = rc_input::crsf::CRSF_BAUD;

const SR_FE: u16 = 1 << 1;
const SR_NE: u16 = 1 << 2;
const SR_ORE: u16 = 1 << 3;
const SR_RXNE: u16 = 1 << 5;
const CR1_RE: u16 = 1 << 2;
const CR1_RXNEIE: u16 = 1 << 5;
const CR1_UE: u16 = 1 << 13;

/// Receive errors the USART flagged (RM0008 §27.3.3).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, defmt::Format)]
pub struct UartErrors {
    /// Bytes lost because the previous one was not read in time (ORE).
    pub overruns: u32,
    /// Bytes with a framing error (FE: no stop bit, wrong baud rate or a
    /// line disturbance), dropped.
    pub framing: u32,
    /// Bytes with noise detected in their samples (NE), kept: the CRC
    /// decides.
    pub noise: u32,
}

/// USART1 configured as the CRSF receiver.
pub struct CrsfUart {
    usart: pac::USART1,
    errors: UartErrors,
}

impl CrsfUart {
    /// Clocks USART1 and GPIOA, makes PA10 a pulled-up input (an unplugged
    /// receiver reads as an idle line, not noise), sets 420 kbaud from
    /// `pclk2_hz` and enables the receiver with the RXNE interrupt.
    pub fn start(usart: pac::USART1, pclk2_hz: u32) -> Self {
        // SAFETY: register writes in init, before any task runs: RCC enable
        // bits (read-modify-write), PA10's CRH nibble and ODR bit, and
        // USART1's BRR/CR1 with values from RM0008 §27.6.
        #[allow(unsafe_code)]
        unsafe {
            let rcc = &*pac::RCC::ptr();
            rcc.apb2enr()
                .modify(|_, w| w.iopaen().set_bit().usart1en().set_bit());
            let gpioa = &*pac::GPIOA::ptr();
            gpioa
                .crh()
                .modify(|r, w| w.bits((r.bits() & !(0xF << 8)) | (0b1000 << 8)));
            gpioa.bsrr().write(|w| w.bits(1 << 10));
            // BRR = f_PCLK / baud (16× oversampling, mantissa.fraction).
            let brr = (pclk2_hz + CRSF_BAUD / 2) / CRSF_BAUD;
            usart.brr().write(|w| w.bits(brr as u16));
            usart.cr1().write(|w| w.bits(CR1_UE | CR1_RE | CR1_RXNEIE));
        }
        Self {
            usart,
            errors: UartErrors::default(),
        }
    }

    /// The next received byte, if any. Reads SR then DR, which also clears
    /// ORE/NE/FE (their clear sequence); an overrun is counted, a byte with
    /// a framing error is counted and dropped.
    pub fn read(&mut self) -> Option<u8> {
        let sr = self.usart.sr().read().bits();
        if sr & (SR_RXNE | SR_ORE) == 0 {
            return None;
        }
        let byte = self.usart.dr().read().bits() as u8;
        if sr & SR_ORE != 0 {
            self.errors.overruns = self.errors.overruns.saturating_add(1);
        }
        if sr & SR_NE != 0 {
            self.errors.noise = self.errors.noise.saturating_add(1);
        }
        if sr & SR_FE != 0 {
            self.errors.framing = self.errors.framing.saturating_add(1);
            return None;
        }
        Some(byte)
    }

    /// Receive errors so far.
    pub fn errors(&self) -> UartErrors {
        self.errors
    }
}

/// What the pilot's receiver last said, shared from the receive interrupt
/// to the control loop and the log.
pub struct Pilot {
    /// The last channel frame.
    pub frame: Option<RcFrame>,
    /// Signal-loss detection.
    pub link: LinkMonitor,
    /// Uplink link quality from the last link statistics, %.
    pub link_quality_pct: Option<u8>,
    /// The parser's counters (frames, CRC errors, drops).
    pub stats: CrsfStats,
    /// The USART's receive errors.
    pub uart: UartErrors,
    /// The PPM input's counters (the `ppm` build's receiver).
    #[cfg(feature = "ppm")]
    pub ppm: crate::ppm::PpmCounters,
}

impl Pilot {
    /// No frame yet.
    pub const fn new() -> Self {
        Self {
            frame: None,
            link: if cfg!(feature = "ppm") {
                LinkMonitor::ppm()
            } else {
                LinkMonitor::crsf()
            },
            link_quality_pct: None,
            stats: CrsfStats::ZERO,
            uart: UartErrors {
                overruns: 0,
                framing: 0,
                noise: 0,
            },
            #[cfg(feature = "ppm")]
            ppm: crate::ppm::PpmCounters::ZERO,
        }
    }

    /// A parsed frame at `now_us`.
    pub fn on_event(&mut self, event: Event, now_us: u32) {
        match event {
            Event::Channels(frame) => {
                self.frame = Some(frame);
                self.link.on_frame(now_us);
            }
            Event::LinkStatistics(s) => {
                self.link_quality_pct = Some(s.uplink_link_quality_pct);
                self.link.on_link_quality(s.uplink_link_quality_pct);
            }
        }
    }

    /// The link's state at `now_us`.
    pub fn status(&mut self, now_us: u32) -> LinkStatus {
        self.link.status(now_us)
    }
}

/// One receive interrupt's worth of bytes through the parser.
pub fn drain(
    uart: &mut CrsfUart,
    parser: &mut CrsfParser,
    mut now_us: impl FnMut() -> u32,
    mut on_event: impl FnMut(Event, u32, &CrsfStats, UartErrors),
) {
    while let Some(byte) = uart.read() {
        let t = now_us();
        if let Some(ev) = parser.push(byte, t) {
            on_event(ev, t, parser.stats(), uart.errors());
        }
    }
}

impl Pilot {
    /// The flight controller's view of the pilot at `now_us`: sticks and
    /// the arm switch through `map`, the flight mode from `mode_channel`
    /// (low: angle, middle: altitude hold, high: acro; angle if absent),
    /// the motor-test switch from `motor_test_channel` (high: on; off if
    /// absent), and whether the link is up. A frame missing a stick or the
    /// arm switch counts as no link.
    pub fn input(
        &mut self,
        now_us: u32,
        map: &ChannelMap,
        mode_channel: u8,
        motor_test_channel: u8,
    ) -> PilotInput {
        let link_up = !self.link.is_lost(now_us);
        let Some(frame) = self.frame.filter(|_| link_up) else {
            return PilotInput::default();
        };
        let (Ok(s), Ok(arm_switch)) = (map.sticks(&frame), map.arm_switch(&frame)) else {
            return PilotInput::default();
        };
        let mode = match ChannelMap::switch(&frame, mode_channel) {
            Ok(SwitchPosition::Middle) => FlightMode::AltitudeHold,
            Ok(SwitchPosition::High) => FlightMode::Acro,
            _ => FlightMode::Angle,
        };
        PilotInput {
            sticks: Sticks {
                roll: s.roll,
                pitch: s.pitch,
                yaw: s.yaw,
                throttle: s.throttle,
            },
            arm_switch,
            mode,
            link_ok: true,
            motor_test_switch: ChannelMap::switch(&frame, motor_test_channel)
                == Ok(SwitchPosition::High),
        }
    }
}
