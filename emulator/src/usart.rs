//! USART receiver (RM0008 §27): BRR, CR1 UE/RE/RXNEIE/IDLEIE, SR with
//! RXNE, ORE, IDLE and FE and the manual's clear sequences, for bytes the
//! host puts on the RX line (8N1 frames at the line's own baud rate).
//!
//! Reception samples the line (§27.3.3, figures 279–280): the receiver,
//! at its own baud rate (f_PCLK / BRR, 16× oversampling, §27.3.4), waits
//! for a falling edge, takes it as a start bit when the line is still low
//! half a bit later, then samples the eight data bits (LSB first) and the
//! stop bit in the middle of each of its own bit times. The byte in DR is
//! what it sampled; a low stop bit sets FE (§27.3.3 "Framing error"); it
//! looks for the next falling edge after its stop-bit sample. A receiver
//! within the manual's tolerance of the line's rate (§27.3.5, 3.75 %)
//! therefore gets every byte right; one further off (a BRR computed for
//! another PCLK2) gets the bits its samples land on: wrong bytes, framing
//! errors, and start bits found inside data bits.
//!
//! Timing: a byte is in DR (RXNE) at the receiver's stop-bit sample,
//! `t + 9.5` of its bit times after the start edge `t`; the line idle for
//! one whole frame after that sets IDLE (only once after each RXNE,
//! §27.6.1). A byte that completes while RXNE is still set is lost and
//! sets ORE; DR keeps the unread byte (§27.3.3 "Overrun error").
//!
//! Receiver DMA (CR3.DMAR, §27.3.13): RXNE is then a request to the DMA
//! (USART1_RX is DMA1 channel 5), and the DMA's read of DR is a DR read
//! like the CPU's: it clears RXNE and, when an SR read came before it, the
//! flags that SR read saw (the USART sees only the bus access, not which
//! master made it). IDLE therefore still needs an SR read followed by a DR
//! read to clear (§27.6.1). With DMAR, EIE raises the interrupt on FE, NE
//! or ORE (§27.4, figure 296).
//!
//! Transmitter (§27.3.2, figure 282): setting TE (with UE) sends an idle
//! frame (ten bit times high) first. A DR write puts the byte in TDR
//! (clears TXE); TDR moves into the shift register as soon as that is
//! free, which sets TXE again, and the frame (start bit, eight data bits
//! LSB first, one stop bit: ten bit times at f_PCLK / BRR) goes out from
//! that instant. Back-to-back bytes follow each other without a gap while
//! TDR is refilled before the frame on the line ends. TC sets when a frame
//! containing data ends with TXE set; it clears by an SR read followed by
//! a DR write, or by writing 0 to it (§27.6.1). A DR write while TXE is
//! clear replaces the byte waiting in TDR (the one before it is lost). A
//! byte written while TE or UE is clear waits in TDR and goes out after
//! the idle frame that setting TE sends. Every data frame that reaches
//! the TX pin is in a line log of (start, end, byte) ([`TxByte`]); the
//! board tells the model whether the pin is wired (PA9 as alternate
//! function output, no remap).
//!
//! Transmitter DMA (CR3.DMAT, §27.3.13 "Transmission using DMA"): TXE is
//! a request to the DMA (USART1_TX is DMA1 channel 4); the DMA's write of
//! DR is a DR write like the CPU's (it clears TXE, and TC when an SR read
//! came before it). TC after the last byte, with TCIE, is the end of the
//! transfer on the line, as the manual's sequence uses it.
//!
//! Not modelled (stop the board with an error if switched on): clearing
//! TE or UE while a data frame is on the line (§27.3.2: it corrupts the
//! frame), send break, parity, 9-bit words, LIN, IrDA, smartcard,
//! half-duplex, hardware flow control, multiprocessor wake-up.

use std::collections::VecDeque;

/// Register offsets (RM0008 §27.6.8, table 190).
pub mod reg {
    /// Status register.
    pub const SR: u32 = 0x00;
    /// Data register.
    pub const DR: u32 = 0x04;
    /// Baud rate register.
    pub const BRR: u32 = 0x08;
    /// Control register 1.
    pub const CR1: u32 = 0x0C;
    /// Control register 2.
    pub const CR2: u32 = 0x10;
    /// Control register 3.
    pub const CR3: u32 = 0x14;
    /// Guard time and prescaler register.
    pub const GTPR: u32 = 0x18;
}

/// SR bits.
pub mod sr {
    /// Parity error.
    pub const PE: u32 = 1 << 0;
    /// Framing error.
    pub const FE: u32 = 1 << 1;
    /// Noise error.
    pub const NE: u32 = 1 << 2;
    /// Overrun error.
    pub const ORE: u32 = 1 << 3;
    /// Idle line detected.
    pub const IDLE: u32 = 1 << 4;
    /// Read data register not empty.
    pub const RXNE: u32 = 1 << 5;
    /// Transmission complete (set at reset).
    pub const TC: u32 = 1 << 6;
    /// Transmit data register empty (set at reset).
    pub const TXE: u32 = 1 << 7;
}

/// CR1 bits.
pub mod cr1 {
    /// Receiver enable.
    pub const RE: u32 = 1 << 2;
    /// Transmitter enable.
    pub const TE: u32 = 1 << 3;
    /// TC interrupt enable.
    pub const TCIE: u32 = 1 << 6;
    /// TXE interrupt enable.
    pub const TXEIE: u32 = 1 << 7;
    /// IDLE interrupt enable.
    pub const IDLEIE: u32 = 1 << 4;
    /// RXNE (and ORE) interrupt enable.
    pub const RXNEIE: u32 = 1 << 5;
    /// USART enable.
    pub const UE: u32 = 1 << 13;
}

/// CR3 bits.
pub mod cr3 {
    /// Error interrupt enable (FE, NE, ORE with DMAR).
    pub const EIE: u32 = 1 << 0;
    /// DMA enable receiver.
    pub const DMAR: u32 = 1 << 6;
    /// DMA enable transmitter.
    pub const DMAT: u32 = 1 << 7;
}

/// One data frame the transmitter put on the TX pin.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TxByte {
    /// The start bit's falling edge (ns).
    pub start_ns: u64,
    /// The end of the stop bit (ns): ten bit times after the start.
    pub end_ns: u64,
    /// The byte (8 data bits).
    pub byte: u8,
}

/// The frame in the transmit shift register.
#[derive(Clone, Copy, Debug)]
struct Shift {
    start: f64,
    end: f64,
    /// `None`: the idle frame.
    byte: Option<u8>,
    /// The TX pin was wired when the frame started.
    on_pin: bool,
}

/// Receiver tolerance to the line's baud rate (RM0008 §27.3.5, table 180):
/// within it the sampling above reads every bit right.
pub const RX_TOLERANCE: f64 = 0.0375;

/// A frame as the receiver samples it.
#[derive(Clone, Copy, Debug)]
struct Sampled {
    /// The start edge (ns).
    edge: f64,
    /// The stop-bit sample (ns): RXNE.
    stop_at: f64,
    byte: u8,
    stop_high: bool,
}

/// The USART's state.
#[derive(Clone, Debug)]
pub struct Usart {
    name: &'static str,
    pclk_hz: u32,
    sr: u32,
    dr: u8,
    brr: u32,
    cr1: u32,
    cr3: u32,
    /// Error and IDLE flags seen by the last SR read (the first half of
    /// their clear sequence).
    sr_read: u32,
    /// Bytes on the line: (start-bit time in ns, byte, line baud).
    line: VecDeque<(u64, u8, u32)>,
    /// When the line went idle after the last byte's stop bit.
    idle_from_ns: Option<u64>,
    /// Bytes received into DR, and lost to overrun.
    received: u64,
    overruns: u64,
    /// The receiver looks for a start edge after this time (ns).
    search_from: f64,
    /// TDR: the byte written and not yet in the shift register.
    tdr: Option<u8>,
    /// The frame being shifted out.
    shift: Option<Shift>,
    /// The last SR read saw TC (the first half of its clear sequence).
    tc_seen: bool,
    /// Whether the TX pin carries the transmitter's output.
    tx_pin: bool,
    /// Data frames that reached the pin, in order.
    tx_log: Vec<TxByte>,
    /// Data frames shifted out while the pin was not wired.
    tx_unseen: u64,
}

fn bit_ns(baud: u32) -> f64 {
    1e9 / f64::from(baud.max(1))
}

/// Bit `k` of an 8N1 frame of `byte`: start (0), data LSB first (1–8),
/// stop (9).
fn frame_bit(byte: u8, k: u32) -> bool {
    match k {
        0 => false,
        1..=8 => byte >> (k - 1) & 1 != 0,
        _ => true,
    }
}

impl Usart {
    /// Reset state (SR = 0x00C0, every other register 0) on a bus clock of
    /// `pclk_hz`.
    pub fn new(name: &'static str, pclk_hz: u32) -> Self {
        Self {
            name,
            pclk_hz,
            sr: sr::TC | sr::TXE,
            dr: 0,
            brr: 0,
            cr1: 0,
            cr3: 0,
            sr_read: 0,
            line: VecDeque::new(),
            idle_from_ns: None,
            received: 0,
            overruns: 0,
            search_from: 0.0,
            tdr: None,
            shift: None,
            tc_seen: false,
            tx_pin: true,
            tx_log: Vec::new(),
            tx_unseen: 0,
        }
    }

    /// Peripheral or MCU reset: registers to reset values; what is on the
    /// RX line stays on the line, the TX line log stays (a frame being
    /// shifted out is cut and not logged), the TX pin's wiring stays.
    pub fn reset(&mut self) {
        let line = std::mem::take(&mut self.line);
        let tx_log = std::mem::take(&mut self.tx_log);
        *self = Self {
            line,
            tx_log,
            tx_pin: self.tx_pin,
            tx_unseen: self.tx_unseen,
            ..Self::new(self.name, self.pclk_hz)
        };
    }

    /// Sets the bus clock (RCC prescalers).
    pub fn set_pclk_hz(&mut self, hz: u32) {
        self.pclk_hz = hz;
    }

    /// The receiver's baud rate from BRR (16× oversampling: f_PCLK / BRR).
    pub fn baud(&self) -> Option<f64> {
        (self.brr >= 16).then(|| f64::from(self.pclk_hz) / f64::from(self.brr))
    }

    fn receiving(&self) -> bool {
        self.cr1 & (cr1::UE | cr1::RE) == cr1::UE | cr1::RE
    }

    /// Puts `bytes` on the RX line back to back at `baud`, the first start
    /// bit at `start_ns` (or when the line is free, if later).
    pub fn inject(&mut self, bytes: &[u8], baud: u32, start_ns: u64) {
        let frame = 10.0 * bit_ns(baud);
        let mut t = self.line.back().map_or(start_ns, |&(s, _, b)| {
            start_ns.max(s + (10.0 * bit_ns(b)).ceil() as u64)
        });
        for &b in bytes {
            self.line.push_back((t, b, baud));
            t += frame.round() as u64;
        }
    }

    /// When the line has nothing queued any more (ns).
    pub fn line_free_ns(&self) -> Option<u64> {
        self.line
            .back()
            .map(|&(s, _, b)| s + (10.0 * bit_ns(b)).ceil() as u64)
    }

    /// Bytes received into DR and bytes lost to overrun since reset.
    pub fn counts(&self) -> (u64, u64) {
        (self.received, self.overruns)
    }

    /// The line's level at `t` (ns): idle high outside the frames.
    fn line_high(&self, t: f64) -> bool {
        for &(start, byte, baud) in &self.line {
            let bit = bit_ns(baud);
            let k = ((t - start as f64) / bit).floor();
            if k < 0.0 {
                return true;
            }
            if k < 10.0 {
                return frame_bit(byte, k as u32);
            }
        }
        true
    }

    /// The first falling edge on the line at or after `from` (ns).
    fn falling_edge_after(&self, from: f64) -> Option<f64> {
        self.line.iter().find_map(|&(start, byte, baud)| {
            let bit = bit_ns(baud);
            // The start bit follows idle or a stop bit (both high); a data
            // bit falls after a high bit.
            (0..9)
                .filter(|&k| k == 0 || (frame_bit(byte, k - 1) && !frame_bit(byte, k)))
                .map(|k| start as f64 + f64::from(k) * bit)
                .find(|&t| t >= from)
        })
    }

    /// The next frame the receiver takes from the line, if it is on.
    fn next_sampled(&self) -> Option<Sampled> {
        let rb = 1e9 / self.baud().filter(|_| self.receiving())?;
        let mut from = self.search_from;
        loop {
            let edge = self.falling_edge_after(from)?;
            if self.line_high(edge + 0.5 * rb) {
                // Not a start bit (§27.3.3: noise); look on from there.
                from = edge + 0.5 * rb;
                continue;
            }
            let byte = (0..8).fold(0u8, |b, i| {
                let high = self.line_high(edge + (f64::from(i) + 1.5) * rb);
                b | (u8::from(high) << i)
            });
            let stop_at = edge + 9.5 * rb;
            return Some(Sampled {
                edge,
                stop_at,
                byte,
                stop_high: self.line_high(stop_at),
            });
        }
    }

    /// Drops the frames that ended before `t` (ns).
    fn prune_line(&mut self, t: f64) {
        while let Some(&(start, _, baud)) = self.line.front() {
            if start as f64 + 10.0 * bit_ns(baud) >= t {
                return;
            }
            self.line.pop_front();
        }
    }

    /// Brings the USART to `now_ns`: every byte whose stop bit has been
    /// sampled lands in DR (or overruns), a quiet line sets IDLE, and the
    /// transmitter's frames that ended are on the line log.
    pub fn advance(&mut self, now_ns: u64) {
        self.advance_tx(now_ns);
        self.advance_rx(now_ns);
    }

    fn advance_rx(&mut self, now_ns: u64) {
        let now = now_ns as f64;
        if !self.receiving() {
            self.search_from = self.search_from.max(now);
            self.prune_line(now);
            return;
        }
        let rb = self.baud().map_or(0.0, |b| 1e9 / b);
        while let Some(f) = self.next_sampled() {
            if let Some(idle) = self.idle_from_ns {
                let idle_at = idle as f64 + 10.0 * rb;
                if f.edge >= idle_at && idle_at <= now {
                    self.set_idle();
                }
            }
            if f.stop_at.round() > now {
                break;
            }
            self.search_from = f.stop_at;
            self.receive(f.byte, f.stop_high);
            // Idle detection counts from the end of the stop bit.
            self.idle_from_ns = Some((f.edge + 10.0 * rb).round() as u64);
            self.prune_line(f.stop_at);
        }
        if let Some(idle) = self.idle_from_ns {
            // Idle detection is at the receiver's own rate.
            if idle + (10.0 * rb).round() as u64 <= now_ns {
                self.set_idle();
            }
        }
    }

    fn set_idle(&mut self) {
        if self.receiving() {
            self.sr |= sr::IDLE;
        }
        self.idle_from_ns = None;
    }

    fn receive(&mut self, byte: u8, framing_ok: bool) {
        if self.sr & sr::RXNE != 0 {
            self.sr |= sr::ORE;
            self.overruns += 1;
            return;
        }
        self.dr = byte;
        self.sr |= sr::RXNE;
        if !framing_ok {
            self.sr |= sr::FE;
        }
        self.received += 1;
    }

    /// When the next byte on the line lands in DR (or overruns).
    pub fn next_byte_ns(&self) -> Option<u64> {
        self.next_sampled().map(|f| f.stop_at.round() as u64)
    }

    /// The receiver's DMA request (USART1_RX: DMA1 channel 5): RXNE with
    /// CR3.DMAR.
    pub fn rx_dma_request(&self) -> bool {
        self.cr3 & cr3::DMAR != 0 && self.sr & sr::RXNE != 0
    }

    /// The DMA's read of DR: the same bus access as the CPU's.
    pub fn dma_read_dr(&mut self, now_ns: u64) -> u32 {
        self.read(reg::DR, now_ns).unwrap_or(0)
    }

    /// When the next byte lands in DR or IDLE sets, or the frame on the
    /// TX line ends (for the scheduler).
    pub fn next_event_ns(&self) -> Option<u64> {
        let byte = [self.next_byte_ns(), self.next_tx_ns()]
            .into_iter()
            .flatten()
            .min();
        let idle = self.idle_from_ns.and_then(|t| {
            self.baud()
                .map(|b| t + (10.0 * 1e9 / b).round() as u64)
                .filter(|_| self.receiving())
        });
        match (byte, idle) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// The interrupt line (RM0008 §27.4, figure 296): RXNE or ORE with
    /// RXNEIE, IDLE with IDLEIE, FE/NE/ORE with EIE and DMAR, TXE with
    /// TXEIE, TC with TCIE.
    pub fn irq(&self) -> bool {
        let tx = (self.cr1 & cr1::TXEIE != 0 && self.sr & sr::TXE != 0)
            || (self.cr1 & cr1::TCIE != 0 && self.sr & sr::TC != 0);
        let rx = self.cr1 & cr1::RXNEIE != 0 && self.sr & (sr::RXNE | sr::ORE) != 0;
        let idle = self.cr1 & cr1::IDLEIE != 0 && self.sr & sr::IDLE != 0;
        let err = self.cr3 & (cr3::EIE | cr3::DMAR) == cr3::EIE | cr3::DMAR
            && self.sr & (sr::FE | sr::NE | sr::ORE) != 0;
        rx || idle || err || tx
    }

    /// Register read at `offset`; `None`: not modelled.
    pub fn read(&mut self, offset: u32, now_ns: u64) -> Option<u32> {
        self.advance(now_ns);
        Some(match offset {
            reg::SR => {
                self.sr_read = self.sr & (sr::PE | sr::FE | sr::NE | sr::ORE | sr::IDLE);
                self.tc_seen = self.sr & sr::TC != 0;
                self.sr
            }
            reg::DR => {
                // A DR read clears RXNE, and the flags the SR read before it
                // saw (the clear sequences of §27.6.1).
                self.sr &= !(sr::RXNE | self.sr_read);
                self.sr_read = 0;
                u32::from(self.dr)
            }
            reg::BRR => self.brr,
            reg::CR1 => self.cr1,
            reg::CR3 => self.cr3,
            reg::CR2 | reg::GTPR => 0,
            _ => return None,
        })
    }

    /// Register write at `offset`. `None`: not modelled; `Some(Err)`: a
    /// feature the model does not have.
    pub fn write(&mut self, offset: u32, v: u32, now_ns: u64) -> Option<Result<(), String>> {
        self.advance(now_ns);
        let unsupported = |what: &str| Some(Err(format!("{}: {what} not modelled", self.name)));
        match offset {
            // RXNE may be cleared by writing 0; the error flags are read-only.
            reg::SR => {
                if v & sr::RXNE == 0 {
                    self.sr &= !sr::RXNE;
                }
                if v & sr::TC == 0 {
                    self.sr &= !sr::TC;
                }
            }
            reg::DR => self.write_dr(v as u8, now_ns),
            reg::BRR => self.brr = v & 0xFFFF,
            reg::CR1 => return Some(self.write_cr1(v, now_ns)),
            reg::CR2 => {
                if v & (3 << 12) != 0 || v & (1 << 14) != 0 {
                    return unsupported("stop bits other than 1, LIN");
                }
            }
            reg::CR3 => {
                if v & !(cr3::DMAR | cr3::DMAT | cr3::EIE) != 0 {
                    return unsupported(
                        "CR3 bits other than DMAR, DMAT and EIE (flow control, IrDA, smartcard, half-duplex)",
                    );
                }
                self.cr3 = v;
            }
            reg::GTPR => {
                if v != 0 {
                    return unsupported("GTPR (IrDA, smartcard)");
                }
            }
            _ => return None,
        }
        Some(Ok(()))
    }
}

impl Usart {
    /// A CR1 write: the features the model has, the receiver's and the
    /// transmitter's switching on.
    fn write_cr1(&mut self, v: u32, now_ns: u64) -> Result<(), String> {
        let allowed =
            cr1::UE | cr1::RE | cr1::TE | cr1::RXNEIE | cr1::IDLEIE | cr1::TXEIE | cr1::TCIE;
        if v & !allowed != 0 {
            return Err(format!(
                "{}: CR1 bits other than UE, RE, TE, RXNEIE, IDLEIE, TXEIE, TCIE (send break, parity, 9-bit, wake-up) not modelled",
                self.name
            ));
        }
        self.check_tx_switch(v)?;
        let was_on = self.transmitting();
        if !self.receiving() {
            // A receiver switched on looks for start bits from now.
            self.search_from = now_ns as f64;
        }
        if v & cr1::UE != 0 && self.brr < 16 {
            return Err(format!(
                "{}: enabled with BRR = {:#x} (below 16: no valid baud rate)",
                self.name, self.brr
            ));
        }
        self.cr1 = v & 0x3FFF;
        if !was_on && self.transmitting() {
            // §27.3.2: setting TE sends an idle frame first.
            self.start_frame(None, now_ns as f64);
        }
        Ok(())
    }

    fn transmitting(&self) -> bool {
        self.cr1 & (cr1::UE | cr1::TE) == cr1::UE | cr1::TE
    }

    /// Tells the model whether the TX pin carries its output (the board:
    /// PA9 configured as an alternate-function output, USART1 not
    /// remapped). Frames shifted out while it does not are not logged.
    pub fn set_tx_pin_connected(&mut self, wired: bool) {
        self.tx_pin = wired;
    }

    /// Data frames that reached the TX pin since power-on (kept across
    /// resets), in order.
    pub fn tx_log(&self) -> &[TxByte] {
        &self.tx_log
    }

    /// Takes the frames logged so far (the log starts empty again).
    pub fn take_tx_log(&mut self) -> Vec<TxByte> {
        std::mem::take(&mut self.tx_log)
    }

    /// Data frames shifted out while the TX pin was not wired.
    pub fn tx_unseen(&self) -> u64 {
        self.tx_unseen
    }

    /// The TX line's level at `now_ns` (call after [`Usart::advance`]):
    /// high when idle and during the idle frame, else the frame's bit.
    pub fn tx_line_high(&self, now_ns: u64) -> bool {
        let Some(Shift {
            start,
            end,
            byte: Some(b),
            ..
        }) = self.shift
        else {
            return true;
        };
        let k = ((now_ns as f64 - start) / ((end - start) / 10.0)).floor();
        !(0.0..10.0).contains(&k) || frame_bit(b, k as u32)
    }

    /// When the frame on the TX line ends (ns), if one is being sent.
    pub fn next_tx_ns(&self) -> Option<u64> {
        self.shift.map(|f| f.end.round() as u64)
    }

    /// The transmitter's DMA request (USART1_TX: DMA1 channel 4): TXE with
    /// CR3.DMAT.
    pub fn tx_dma_request(&self) -> bool {
        self.cr3 & cr3::DMAT != 0 && self.sr & sr::TXE != 0
    }

    /// The DMA's write of DR: the same bus access as the CPU's.
    pub fn dma_write_dr(&mut self, v: u32, now_ns: u64) {
        self.advance(now_ns);
        self.write_dr(v as u8, now_ns);
    }

    /// Clearing TE or UE while a data frame is on the line corrupts it
    /// (§27.3.2): not modelled.
    fn check_tx_switch(&self, cr1_new: u32) -> Result<(), String> {
        let stays_on = cr1_new & (cr1::UE | cr1::TE) == cr1::UE | cr1::TE;
        match self.shift {
            Some(Shift { byte: Some(b), .. }) if !stays_on => Err(format!(
                "{}: TE or UE cleared while byte {b:#04x} is on the TX line (RM0008 §27.3.2: the frame is corrupted)",
                self.name
            )),
            _ => Ok(()),
        }
    }

    /// A DR write: the byte goes to TDR (an SR read before it clears TC),
    /// then into the shift register if that is free.
    fn write_dr(&mut self, byte: u8, now_ns: u64) {
        if std::mem::take(&mut self.tc_seen) {
            self.sr &= !sr::TC;
        }
        self.tdr = Some(byte);
        self.sr &= !sr::TXE;
        self.load_shift(now_ns as f64);
    }

    /// TDR into a free shift register at `t` (ns): TXE sets, the frame
    /// starts.
    fn load_shift(&mut self, t: f64) {
        if self.shift.is_some() || !self.transmitting() {
            return;
        }
        if let Some(b) = self.tdr.take() {
            self.sr |= sr::TXE;
            self.start_frame(Some(b), t);
        }
    }

    fn start_frame(&mut self, byte: Option<u8>, t: f64) {
        let bit = self.baud().map_or(0.0, |b| 1e9 / b);
        self.shift = Some(Shift {
            start: t,
            end: t + 10.0 * bit,
            byte,
            on_pin: self.tx_pin,
        });
    }

    /// Ends the frames on the TX line up to `now_ns`, each followed at
    /// once by the byte waiting in TDR.
    fn advance_tx(&mut self, now_ns: u64) {
        while let Some(f) = self.shift.filter(|f| f.end.round() as u64 <= now_ns) {
            self.shift = None;
            if let Some(byte) = f.byte {
                if f.on_pin {
                    self.tx_log.push(TxByte {
                        start_ns: f.start.round() as u64,
                        end_ns: f.end.round() as u64,
                        byte,
                    });
                } else {
                    self.tx_unseen += 1;
                }
            }
            self.load_shift(f.end);
            if self.shift.is_none() && f.byte.is_some() && self.sr & sr::TXE != 0 {
                self.sr |= sr::TC;
            }
        }
    }
}
