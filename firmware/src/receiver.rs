//! The CRSF receiver on USART1 RX (PA10) at 420 kbaud 8N1, received by
//! DMA1 channel 5 into a circular buffer: register set-up, handing new
//! bytes to the parser on the channel's half/complete interrupts and on the
//! USART's IDLE interrupt, and the pilot state the control loop reads.
//! Frame parsing, channel mapping and signal-loss timing are `rc_input`'s.
//!
//! Why DMA: a byte arrives every 23.8 µs and the USART holds one. defmt-rtt
//! encodes a whole log line with interrupts disabled, so a byte-per-
//! interrupt receiver overruns (ORE) whenever a line takes longer than a
//! byte time. The DMA takes each byte out of DR within a few bus cycles
//! whatever the CPU does, so ORE cannot happen; the CPU only has to empty
//! the ring before the DMA comes round to unread bytes. The handler runs at
//! every half ring (HT, TC) and at the end of every burst (IDLE), so a byte
//! waits at most half a ring before an interrupt asks for it, and the other
//! half is the interrupt latency it tolerates: [`RING_BYTES`] = 128 gives
//! 64 byte times, 1.52 ms, longer than any log line's critical section.
//!
//! Frame boundaries: the parser accepts a frame whose last byte arrived at
//! most [`rc_input::crsf::DEFAULT_MAX_FRAME_TIME_US`] (1 750 µs) after its
//! first, whatever the pauses inside it (a 26-byte channel frame may pause
//! 1.13 ms in all), and abandons a candidate that takes longer. IDLE (one
//! idle character, 23.8 µs, after a byte) is only a handover: a receiver
//! that pauses mid-frame raises it without splitting the frame. Each byte
//! is stamped with an upper bound of its arrival: the handover's time less
//! one byte time ([`rc_input::crsf::BYTE_TIME_NS`]) for each byte the DMA
//! wrote after it (each byte takes at least that on the wire). A span
//! between two handovers therefore reads long by at most the second
//! handover's latency, and short by the pauses inside one handover's
//! bytes; at priority 4 the latency is a few µs, and a defmt line's
//! critical section stays well under the 1.13 ms of slack a channel
//! frame has. A frame dropped for its time is counted (`dropped`), never
//! misparsed. The link monitor gets the handover's wall-clock time.
//!
//! IDLE's clear sequence is an SR read followed by a DR read (RM0008
//! §27.6.1), and the DMA owns DR. Assumption (not documented by ST): the
//! USART sees bus accesses, not masters, so the DMA's read of DR after the
//! handler's SR read completes the sequence as a CPU read would (the
//! emulator's USART model does so). The handler reads DR only when the SR
//! it just read shows IDLE without RXNE: with RXNE set a byte waits for the
//! DMA, a CPU read would take it (RXNE clears and the DMA request with it),
//! and the DMA's own read clears IDLE. If the assumption is wrong, IDLE
//! stays set, the interrupt runs once more right away and then reads DR
//! itself: one extra handover, no lost byte. What is left: a byte landing
//! in DR between the SR and DR loads (five instructions apart in the
//! release build, about 0.1 µs of the 23.8 µs byte time, and only when a
//! new frame starts exactly one idle character after the last); it is
//! then read by the CPU, not the DMA, and its frame fails its CRC.

use control::shaping::Sticks;
use core::sync::atomic::{compiler_fence, AtomicU32, Ordering};
use flight::flightctl::{FlightMode, PilotInput};
use rc_input::{ChannelMap, SwitchPosition};
use rc_input::{CrsfParser, CrsfStats, Event, LinkMonitor, LinkStatus, RcFrame};
use stm32f1xx_hal::pac;

use crate::config;

/// CRSF line rate (ExpressLRS/Crossfire receivers to a flight controller).
pub const CRSF_BAUD: u32 = rc_input::crsf::CRSF_BAUD;

/// The receive ring: a power of two (the write position is `RING_BYTES -
/// CNDTR`, the read position wraps with a mask).
pub const RING_BYTES: usize = 128;

const SR_FE: u16 = 1 << 1;
const SR_NE: u16 = 1 << 2;
const SR_ORE: u16 = 1 << 3;
const SR_IDLE: u16 = 1 << 4;
const SR_RXNE: u16 = 1 << 5;
const CR1_RE: u16 = 1 << 2;
const CR1_IDLEIE: u16 = 1 << 4;
const CR1_UE: u16 = 1 << 13;
const CR3_DMAR: u16 = 1 << 6;
/// The STM32F103CB build also transmits telemetry (`crsf_tx.rs`): TE in
/// CR1, DMAT in CR3 (RM0008 §27.6.4, §27.6.6).
#[cfg(builder)]
const TX_BITS: (u16, u16) = (1 << 3, 1 << 7);
#[cfg(not(builder))]
const TX_BITS: (u16, u16) = (0, 0);
/// DMA1 channel 5 (USART1_RX, RM0008 §13.3.7 table 78), index 4.
const CH5: usize = 4;
const CCR_EN: u32 = 1 << 0;
const CCR_TCIE: u32 = 1 << 1;
const CCR_HTIE: u32 = 1 << 2;
const CCR_CIRC: u32 = 1 << 5;
const CCR_MINC: u32 = 1 << 7;
const CCR_PL_VERY_HIGH: u32 = 3 << 12;

/// Receive errors the USART flagged (RM0008 §27.3.3), counted at each IDLE
/// event from the flags any SR read saw since the one before: a burst with
/// several bad bytes counts once. The bytes themselves went to the parser,
/// whose CRC check drops their frames.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, defmt::Format)]
pub struct UartErrors {
    /// Bursts with an overrun (ORE: a byte lost because DR was not emptied
    /// in time; with the DMA serving DR, only if the channel stopped).
    pub overruns: u32,
    /// Bursts with a framing error (FE: no stop bit, wrong baud rate or a
    /// line disturbance).
    pub framing: u32,
    /// Bursts with noise detected in a byte's samples (NE).
    pub noise: u32,
    /// Times the DMA passed both half-ring marks before the handover ran:
    /// interrupts held off for half a ring (1.5 ms) or more, for instance
    /// by a flash page erase (20-40 ms, the CPU stalls while the DMA goes
    /// on). Bytes may then have been overwritten before they were read; the
    /// parser resynchronises on the bytes that follow.
    pub late: u32,
    /// Bytes handed to the parser since boot (wrapping): with no link, zero
    /// says nothing reaches PA10 at all.
    pub bytes: u32,
}

/// [`UartErrors::late`], counted in the DMA interrupt.
static LATE: AtomicU32 = AtomicU32::new(0);

/// USART1 and DMA1 channel 5 receiving CRSF into the ring, with the parser
/// the bytes go to.
pub struct CrsfRx {
    usart: pac::USART1,
    dma: pac::DMA1,
    ring: &'static mut [u8; RING_BYTES],
    read_pos: usize,
    parser: CrsfParser,
    errors: UartErrors,
    /// SR bits (ORE/FE/NE among them) seen by the SR reads of this burst. A handover at a
    /// half-ring mark reads SR, and the DMA's next read of DR completes the
    /// flags' clear sequence (SR then DR, RM0008 §27.6.1): a flag seen
    /// then is gone by the burst's IDLE.
    seen: u16,
}

impl CrsfRx {
    /// Clocks USART1, GPIOA and DMA1, makes PA10 a pulled-up input (an
    /// unplugged receiver reads as an idle line, not noise), points DMA1
    /// channel 5 from USART1's DR into `ring` (circular, byte items, half
    /// and complete interrupts), sets 420 kbaud from `pclk2_hz` and enables
    /// the receiver with DMA requests and the IDLE interrupt.
    pub fn start(
        usart: pac::USART1,
        dma: pac::DMA1,
        ring: &'static mut [u8; RING_BYTES],
        pclk2_hz: u32,
    ) -> Self {
        // SAFETY: register writes in init, before any task runs: RCC enable
        // bits (read-modify-write), PA10's CRH nibble and ODR bit, DMA1
        // channel 5 (disabled at reset, so CNDTR/CPAR/CMAR are writable)
        // and USART1's BRR/CR3/CR1 with values from RM0008 §13.4 and §27.6.
        // The channel writes only into `ring`, which this struct owns for
        // the life of the program and reads with volatile reads.
        #[allow(unsafe_code)]
        unsafe {
            let rcc = &*pac::RCC::ptr();
            rcc.ahbenr().modify(|_, w| w.dma1en().set_bit());
            rcc.apb2enr()
                .modify(|_, w| w.iopaen().set_bit().usart1en().set_bit());
            let gpioa = &*pac::GPIOA::ptr();
            gpioa
                .crh()
                .modify(|r, w| w.bits((r.bits() & !(0xF << 8)) | (0b1000 << 8)));
            gpioa.bsrr().write(|w| w.bits(1 << 10));
            let ch = dma.ch(CH5);
            ch.par().write(|w| w.bits(usart.dr().as_ptr() as u32));
            ch.mar().write(|w| w.bits(ring.as_mut_ptr() as u32));
            ch.ndtr().write(|w| w.bits(RING_BYTES as u32));
            ch.cr().write(|w| {
                w.bits(CCR_MINC | CCR_CIRC | CCR_HTIE | CCR_TCIE | CCR_PL_VERY_HIGH | CCR_EN)
            });
            // BRR = f_PCLK / baud (16× oversampling, mantissa.fraction).
            let brr = (pclk2_hz + CRSF_BAUD / 2) / CRSF_BAUD;
            usart.brr().write(|w| w.bits(brr as u16));
            usart.cr3().write(|w| w.bits(CR3_DMAR | TX_BITS.1));
            usart
                .cr1()
                .write(|w| w.bits(CR1_UE | CR1_RE | CR1_IDLEIE | TX_BITS.0));
        }
        Self {
            usart,
            dma,
            ring,
            read_pos: 0,
            parser: CrsfParser::new(),
            seen: 0,
            errors: UartErrors {
                overruns: 0,
                framing: 0,
                noise: 0,
                late: 0,
                bytes: 0,
            },
        }
    }

    /// USART1's interrupt at `now_us`: IDLE, or pended by
    /// [`on_dma_half_or_complete`]. Notes the error flags; on IDLE counts
    /// those of the burst and clears them with IDLE (SR then DR, RM0008
    /// §27.6.1; no DR read while RXNE shows a byte waiting for the DMA: the
    /// module documentation says why); hands the new bytes to the parser,
    /// each stamped with an upper bound of its arrival time.
    pub fn on_interrupt(&mut self, now_us: u32, on_event: impl FnMut(Event)) {
        let sr = self.usart.sr().read().bits();
        if sr & (SR_IDLE | SR_RXNE) == SR_IDLE {
            let _ = self.usart.dr().read();
        }
        self.seen |= sr;
        if sr & SR_IDLE != 0 {
            self.count_errors();
        }
        self.hand_over(now_us, on_event);
    }

    /// Counts the error flags the SR reads of the burst saw.
    fn count_errors(&mut self) {
        let sr = self.seen;
        self.seen = 0;
        for (flag, count) in [
            (SR_ORE, &mut self.errors.overruns),
            (SR_FE, &mut self.errors.framing),
            (SR_NE, &mut self.errors.noise),
        ] {
            if sr & flag != 0 {
                *count = count.saturating_add(1);
            }
        }
    }

    /// Hands the bytes the DMA wrote since the last handover to the
    /// parser, the last stamped `now_us` and each earlier one a byte time
    /// before the one after it.
    fn hand_over(&mut self, now_us: u32, mut on_event: impl FnMut(Event)) {
        let left = self.dma.ch(CH5).ndtr().read().bits() as usize;
        let write_pos = RING_BYTES.wrapping_sub(left) & (RING_BYTES - 1);
        // The DMA's writes up to `write_pos` happened before CNDTR said so.
        compiler_fence(Ordering::Acquire);
        let mut after = write_pos.wrapping_sub(self.read_pos) & (RING_BYTES - 1);
        self.errors.bytes = self.errors.bytes.wrapping_add(after as u32);
        while self.read_pos != write_pos {
            let i = self.read_pos & (RING_BYTES - 1);
            // SAFETY: `i` is inside the ring; a volatile read because the
            // DMA, not this code, writes the ring.
            #[allow(unsafe_code)]
            let byte = unsafe { core::ptr::read_volatile(self.ring.as_ptr().add(i)) };
            self.read_pos = (i + 1) & (RING_BYTES - 1);
            after = after.saturating_sub(1);
            // At most 127 byte times (3.0 ms) back: no overflow.
            let back_us = after as u32 * rc_input::crsf::BYTE_TIME_NS / 1_000;
            if let Some(ev) = self.parser.push(byte, now_us.wrapping_sub(back_us)) {
                on_event(ev);
            }
        }
    }

    /// The parser's counters.
    pub fn stats(&self) -> &CrsfStats {
        self.parser.stats()
    }

    /// The USART's receive errors and late handovers.
    pub fn errors(&self) -> UartErrors {
        UartErrors {
            late: LATE.load(Ordering::Relaxed),
            ..self.errors
        }
    }
}

/// DMA1 channel 5's interrupt (half or all of the ring written): counts a
/// late handover when both marks were passed, clears the channel's flags
/// and pends USART1's interrupt, whose handler hands the bytes over (one
/// routine for both events: one copy of the parser's inlined code in
/// flash).
pub fn on_dma_half_or_complete() {
    // SAFETY: ISR is read-only; IFCR is write-only and a write of 1 to
    // CGIF5 clears channel 5's GIF, TC, HT and TE and nothing else (RM0008
    // §13.4.2): no read-modify-write, so neither races `CrsfRx`'s reads of
    // the channel.
    #[allow(unsafe_code)]
    let dma = unsafe { &*pac::DMA1::ptr() };
    let isr = dma.isr().read();
    if isr.htif5().bit_is_set() && isr.tcif5().bit_is_set() {
        LATE.fetch_add(1, Ordering::Relaxed);
    }
    dma.ifcr().write(|w| w.cgif5().set_bit());
    cortex_m::peripheral::NVIC::pend(pac::Interrupt::USART1);
}

/// What the pilot's receiver last said, shared from the receive interrupt
/// to the control loop and the log.
pub struct Pilot {
    /// The last channel frame.
    pub frame: Option<RcFrame>,
    /// The last channel frame through the board's channel map
    /// ([`map_frame`]), mapped once per frame rather than at every 1 kHz
    /// sample; `None` without a frame or when it lacks a stick or the arm
    /// switch.
    mapped: Option<PilotInput>,
    /// A frame came since `mapped` was made.
    remap: bool,
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
    /// The channel map and the mode and motor-test switch channels from
    /// the settings (the STM32F103CB build; the C8's are `config`'s
    /// constants).
    #[cfg(builder)]
    channels: (ChannelMap, u8, u8),
}

impl Pilot {
    /// No frame yet.
    pub const fn new() -> Self {
        Self {
            frame: None,
            mapped: None,
            remap: false,
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
                late: 0,
                bytes: 0,
            },
            #[cfg(feature = "ppm")]
            ppm: crate::ppm::PpmCounters::ZERO,
            #[cfg(builder)]
            channels: (
                config::channel_map(),
                config::MODE_CHANNEL,
                config::MOTOR_TEST_CHANNEL,
            ),
        }
    }

    /// With the settings' channels and link timeout (the STM32F103CB
    /// build). A set the receiver code refuses (a switch on a stick's
    /// channel, a timeout out of range) is logged and the board's
    /// defaults kept.
    #[cfg(builder)]
    pub fn with_settings(mut self, p: &params::ParamSet) -> Self {
        match p.channel_map() {
            Ok(map) => self.channels = (map, p.mode_channel(), p.motor_test_channel()),
            Err(e) => defmt::error!("settings: channels refused ({}); board defaults", e),
        }
        match LinkMonitor::new(p.link_timeout_us()) {
            Ok(link) => self.link = link,
            Err(e) => defmt::error!("settings: link timeout refused ({}); default", e),
        }
        self
    }

    /// The channel map and the mode and motor-test channels.
    #[cfg(builder)]
    fn channels(&self) -> (ChannelMap, u8, u8) {
        self.channels
    }

    /// The channel map and the mode and motor-test channels.
    #[cfg(not(builder))]
    fn channels(&self) -> (ChannelMap, u8, u8) {
        (
            config::channel_map(),
            config::MODE_CHANNEL,
            config::MOTOR_TEST_CHANNEL,
        )
    }

    /// A parsed frame at `now_us`.
    pub fn on_event(&mut self, event: Event, now_us: u32) {
        match event {
            Event::Channels(frame) => {
                self.frame = Some(frame);
                self.remap = true;
                self.link.on_frame(now_us);
            }
            Event::LinkStatistics(s) => {
                self.link_quality_pct = Some(s.uplink_link_quality_pct);
                self.link.on_link_quality(s.uplink_link_quality_pct);
            }
        }
    }

    /// The receiver's counters as they are now.
    pub fn update_counters(&mut self, stats: &CrsfStats, uart: UartErrors) {
        self.stats = *stats;
        self.uart = uart;
    }

    /// The link's state at `now_us`.
    pub fn status(&mut self, now_us: u32) -> LinkStatus {
        self.link.status(now_us)
    }
}

impl Pilot {
    /// The flight controller's view of the pilot at `now_us`: the last
    /// channel frame through the board's channel map and switches
    /// (`config`; [`map_frame`], once per frame), while the link is up; no
    /// link otherwise (also for a frame missing a stick or the arm switch).
    pub fn input(&mut self, now_us: u32) -> PilotInput {
        if core::mem::take(&mut self.remap) {
            let (map, mode, test) = self.channels();
            self.mapped = self
                .frame
                .as_ref()
                .and_then(|f| map_frame(f, &map, mode, test));
        }
        let link_up = !self.link.is_lost(now_us);
        match self.mapped {
            Some(input) if link_up => input,
            _ => PilotInput::default(),
        }
    }
}

/// A channel frame as the flight controller sees it, with the link up:
/// sticks and the arm switch through `map`, the flight mode from
/// `mode_channel` (low: angle, middle: altitude hold, high: acro; angle if
/// absent), the motor-test switch from `motor_test_channel` (high: on; off
/// if absent). `None` for a frame missing a stick or the arm switch.
fn map_frame(
    frame: &RcFrame,
    map: &ChannelMap,
    mode_channel: u8,
    motor_test_channel: u8,
) -> Option<PilotInput> {
    let (Ok(s), Ok(arm_switch)) = (map.sticks(frame), map.arm_switch(frame)) else {
        return None;
    };
    let mode = match ChannelMap::switch(frame, mode_channel) {
        Ok(SwitchPosition::Middle) => FlightMode::AltitudeHold,
        Ok(SwitchPosition::High) => FlightMode::Acro,
        _ => FlightMode::Angle,
    };
    Some(PilotInput {
        sticks: Sticks {
            roll: s.roll,
            pitch: s.pitch,
            yaw: s.yaw,
            throttle: s.throttle,
        },
        arm_switch,
        mode,
        link_ok: true,
        motor_test_switch: ChannelMap::switch(frame, motor_test_channel)
            == Ok(SwitchPosition::High),
    })
}
