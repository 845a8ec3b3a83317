//! The STM32F103's I2C1 in master mode, as RM0008 §26 describes it, with
//! the errata ES096 behaviours the firmware must survive, over the
//! simulator's chips (`sim::SimBus`'s wire-level steps).
//!
//! Time: a transfer advances in bus time. One SCL period comes from CCR
//! and the peripheral's clock PCLK1 (RM0008 §26.6.8: standard mode
//! 2·CCR·T_PCLK1; fast mode 3·CCR·T_PCLK1 with DUTY = 0, 25·CCR·T_PCLK1
//! with DUTY = 1; rise times are not added), the clock RCC gives it
//! ([`I2c1::set_pclk1_hz`]), not the one CR2.FREQ claims: at PCLK1 =
//! 36 MHz, CCR = 0x801E gives 2.5 µs per bit; the same CCR at 32 MHz
//! (the HSI fallback's APB1) 2.8125 µs. A START takes one period,
//! an address or data byte nine, a STOP one. Flags appear when the byte
//! ends; the caller advances time with [`I2c1::advance`] (and every
//! register access does). While another device holds SCL low, a START,
//! STOP or byte on the wire stands still (clock synchronisation).
//!
//! Master sequences (RM0008 §26.3.3): START → SB (EV5), cleared by reading
//! SR1 then writing the address to DR; ADDR (EV6) cleared by reading SR1
//! then SR2, SCL held low until then; AF on an address or data NACK (SCL
//! held low until STOP or START). Transmitter: TXE while DR is empty, BTF
//! when the shift register has sent its byte and DR is still empty (SCL
//! held low). Receiver: a byte ends with the (N)ACK, then RXNE; a second
//! byte arriving with RXNE still set stays in the shift register, BTF is
//! set and SCL is held low until DR is read. ACK decides the byte being
//! received when it ends (POS = 0), or the byte after it (POS = 1: the
//! decision for byte k is the ACK bit when byte k−1 ended, or when the
//! address was acknowledged for the first byte). STOP and a repeated START
//! are generated after the current byte, or at once when SCL is held low
//! waiting for software. CR1.STOP is cleared by hardware when the STOP
//! condition has been sent; a read-modify-write of CR1 that straddles that
//! moment writes STOP = 1 again, a second STOP (the manual's warning),
//! which fires right after the next START.
//!
//! Errata ES096 §2.13 "Wrong data read into data register" (master
//! receiver, the N = 2 and N > 2 endings): with byte N−1 in DR and byte N
//! in the shift register, software must read byte N−1 between setting
//! STOP and the STOP condition on the bus (one SCL period when SCL is held
//! low on BTF; the end of byte N plus one period when STOP is set while
//! byte N is still arriving). Late, byte N is shifted one bit left and
//! the last DR read returns it so: a handler preempted inside that window
//! reads a wrong last byte, as the silicon does.
//!
//! Errata ES096 §2.13.2 "Some software events must be managed before the
//! current byte is being transferred": an EV7 (RXNE, byte k in DR) not
//! served before the next byte k+1 has been transferred can read "the same
//! data twice" or "miss" data. The errata names the outcomes, not the
//! mechanism or the window; the model's (an assumption, see
//! [`Ev7Race`]): a DR read in the last SCL period of byte k+1 (its ACK
//! pulse, when the receiver moves the byte out of the shift register)
//! races that move. In the period's first half the hardware has already
//! decided on the stale RXNE: byte k+1 stays in the shift register with
//! BTF set and SCL held low, but DR still holds byte k with RXNE clear, so
//! the next DR read returns byte k again (read twice). In its second half
//! the byte is loaded into DR but the read's RXNE clear lands after the
//! load: RXNE stays clear and byte k+1 is overwritten by byte k+2 unseen
//! (missed). A DR read while SCL is held low on BTF (nothing on the wire)
//! or before that last period is in time.
//!
//! BUSY (SR2): set when the peripheral sees SDA or SCL low, cleared when it
//! sees a STOP, and set for the master's own transfers. The peripheral sees
//! the pins through its analog filter whatever their GPIO mode, so a chip
//! holding SDA low keeps BUSY set and a START waits for the bus. The pins
//! can be GPIO (open drain) to clock SCL by hand. Errata ES096 §2.13.7: the
//! analog filter can stick low ([`PeripheralFault::BusyLockup`]); BUSY then
//! stays set through PE and SWRST until each line has been driven low and
//! high again as GPIO (the errata's sequence), after which a SWRST clears
//! BUSY. Spurious BERR (errata): [`PeripheralFault::SpuriousBerr`] sets
//! BERR during the next byte and changes nothing else.
//!
//! ```
//! use emulator::i2c1::{cr1, reg, sr1, I2c1, PinMode};
//! use sim::{SimBus, SimClock, SimConfig};
//!
//! let bus = SimBus::new(&SimClock::new(), SimConfig { bus_hz: None, ..SimConfig::default() });
//! let mut i2c = I2c1::new(bus);
//! let af = PinMode::AlternateOpenDrain;
//! i2c.set_pins(af, af, 0);
//! i2c.set_pclk1_hz(36_000_000, 0);
//! i2c.write(reg::CR2, 36, 0); // FREQ: PCLK1 = 36 MHz
//! i2c.write(reg::CCR, 0x801E, 0); // fast mode, 400 kHz
//! i2c.write(reg::CR1, cr1::PE | cr1::START, 0);
//! assert_eq!(i2c.read(reg::SR1, 2_499) & sr1::SB, 0);
//! assert_eq!(i2c.read(reg::SR1, 2_500) & sr1::SB, sr1::SB); // one SCL period later
//! ```
//!
//! Not modelled: slave mode, 10-bit addresses, SMBus/PEC, DMA, NOSTRETCH,
//! OVR, TRISE's effect on timing, line contention with a push-pull pin, the
//! intermediate bit levels of a byte in flight.

use sim::SimBus;
use sim::SimBusError;

/// How a DR read racing the end of the byte on the wire (errata ES096
/// §2.13.2, the late EV7) comes out, by where in that byte's last SCL
/// period it lands. The errata says only "reading the same data twice or
/// missing data"; the window (the ACK pulse) and its split into halves are
/// this model's assumption, stated so a test can aim at each.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ev7Race {
    /// First half: the byte on the wire stays in the shift register (BTF)
    /// while DR keeps the byte just read, RXNE clear: read twice.
    ReadTwice,
    /// Second half: the byte on the wire is loaded into DR with RXNE left
    /// clear: the next byte overwrites it (missed).
    Missed,
}

/// Register offsets (RM0008 §26.6).
pub mod reg {
    /// Control register 1.
    pub const CR1: u32 = 0x00;
    /// Control register 2.
    pub const CR2: u32 = 0x04;
    /// Own address register 1.
    pub const OAR1: u32 = 0x08;
    /// Own address register 2.
    pub const OAR2: u32 = 0x0C;
    /// Data register.
    pub const DR: u32 = 0x10;
    /// Status register 1.
    pub const SR1: u32 = 0x14;
    /// Status register 2.
    pub const SR2: u32 = 0x18;
    /// Clock control register.
    pub const CCR: u32 = 0x1C;
    /// Rise time register.
    pub const TRISE: u32 = 0x20;
}

/// CR1 bits.
pub mod cr1 {
    /// Peripheral enable.
    pub const PE: u16 = 1 << 0;
    /// START request.
    pub const START: u16 = 1 << 8;
    /// STOP request.
    pub const STOP: u16 = 1 << 9;
    /// Acknowledge enable.
    pub const ACK: u16 = 1 << 10;
    /// ACK applies to the next byte.
    pub const POS: u16 = 1 << 11;
    /// Software reset.
    pub const SWRST: u16 = 1 << 15;
}

/// CR2 bits.
pub mod cr2 {
    /// Peripheral clock frequency (MHz) field.
    pub const FREQ_MASK: u16 = 0x3F;
    /// Error interrupt enable.
    pub const ITERREN: u16 = 1 << 8;
    /// Event interrupt enable.
    pub const ITEVTEN: u16 = 1 << 9;
    /// Buffer interrupt enable.
    pub const ITBUFEN: u16 = 1 << 10;
}

/// SR1 bits.
pub mod sr1 {
    /// Start bit generated (EV5).
    pub const SB: u16 = 1 << 0;
    /// Address sent and acknowledged (EV6).
    pub const ADDR: u16 = 1 << 1;
    /// Byte transfer finished, SCL held low.
    pub const BTF: u16 = 1 << 2;
    /// Data register not empty (receiver).
    pub const RXNE: u16 = 1 << 6;
    /// Data register empty (transmitter).
    pub const TXE: u16 = 1 << 7;
    /// Bus error (misplaced START/STOP).
    pub const BERR: u16 = 1 << 8;
    /// Arbitration lost.
    pub const ARLO: u16 = 1 << 9;
    /// Acknowledge failure.
    pub const AF: u16 = 1 << 10;
    /// Bits software clears by writing 0.
    pub const RC_W0: u16 = 0xDF00;
}

/// SR2 bits.
pub mod sr2 {
    /// Master mode.
    pub const MSL: u16 = 1 << 0;
    /// Bus busy.
    pub const BUSY: u16 = 1 << 1;
    /// Transmitter.
    pub const TRA: u16 = 1 << 2;
}

/// How GPIOB configures one of the bus pins (PB6 = SCL, PB7 = SDA).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PinMode {
    /// Alternate function open drain: the I2C peripheral drives the line.
    AlternateOpenDrain,
    /// GPIO output, open drain; `high` = ODR bit (released).
    GpioOutputOpenDrain {
        /// ODR bit.
        high: bool,
    },
    /// GPIO output, push-pull; contention is not modelled, a high output
    /// reads as a released line.
    GpioOutputPushPull {
        /// ODR bit.
        high: bool,
    },
    /// Input (floating or pulled): the line is released.
    Input,
}

impl PinMode {
    fn gpio_drive(self) -> Option<bool> {
        match self {
            PinMode::AlternateOpenDrain => None,
            PinMode::GpioOutputOpenDrain { high } | PinMode::GpioOutputPushPull { high } => {
                Some(high)
            }
            PinMode::Input => Some(true),
        }
    }
}

/// Faults of the peripheral itself (the wire's faults are `sim::Fault`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PeripheralFault {
    /// Errata ES096 §2.13.7: the analog filter output sticks low, BUSY is
    /// set and no START can be sent until the errata's GPIO sequence and a
    /// SWRST.
    BusyLockup,
    /// Errata ES096: a spurious bus error in master mode; BERR is set during
    /// the next byte, the transfer goes on normally.
    SpuriousBerr,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    /// Not master (or master with nothing under way).
    Idle,
    /// START condition on the wire; SB at `done`.
    Start { done: u64 },
    /// SB set, SCL held low: waiting for the address in DR.
    AwaitAddress,
    /// Address byte on the wire.
    Address { byte: u8, start: u64, done: u64 },
    /// ADDR set, SCL held low until SR1 then SR2 are read.
    AddrHold,
    /// Data byte being sent.
    TxByte { byte: u8, start: u64, done: u64 },
    /// Transmitter after ADDR: nothing sent yet, DR empty, SCL held low.
    TxIdle,
    /// Transmitter: byte sent, DR empty (BTF), SCL held low.
    TxStall,
    /// Data byte being received.
    RxByte { start: u64, done: u64 },
    /// Receiver: DR and shift register full (BTF), SCL held low.
    RxStall,
    /// NACK received (AF), SCL held low until STOP or START.
    Nacked,
    /// STOP condition on the wire; done at `done`.
    Stop { done: u64 },
    /// The pins were taken away mid-transfer: the peripheral waits for an
    /// SCL it can no longer drive, until SWRST or a peripheral reset.
    Lost,
}

/// The I2C1 peripheral (master mode) with the simulator's bus behind it.
#[derive(Debug)]
pub struct I2c1 {
    bus: SimBus,
    now_ns: u64,
    /// The peripheral's clock (APB1).
    pclk1_hz: u32,
    cr1: u16,
    cr2: u16,
    oar1: u16,
    oar2: u16,
    ccr: u16,
    trise: u16,
    /// Sticky SR1 flags: SB, ADDR and the error flags.
    flags: u16,
    msl: bool,
    tra: bool,
    busy: bool,
    phase: Phase,
    dr_rx: Option<u8>,
    shift_rx: Option<u8>,
    dr_tx: Option<u8>,
    dr_last: u8,
    /// SR1 was read while SB / ADDR was set (first half of their clear sequences).
    sb_armed: bool,
    addr_armed: bool,
    /// POS = 1: the (N)ACK decided for the next byte.
    pos_ack: bool,
    /// PE cleared during a transfer: takes effect when back to idle.
    pe_off_pending: bool,
    scl_pin: PinMode,
    sda_pin: PinMode,
    /// Bus line levels (SCL, SDA) at the last line update.
    lines: (bool, bool),
    /// Line levels as the peripheral sees them through its filter.
    seen: (bool, bool),
    /// Errata lock-up: the filter output of (SCL, SDA) is tied low.
    filter_stuck: [bool; 2],
    /// While stuck: the line has been low since (its next rise unlocks it).
    seen_low_while_stuck: [bool; 2],
    spurious_berr: bool,
    /// A transmitter's BTF stays set until the START or STOP requested on
    /// it has gone out (RM0008 SR1.BTF: cleared by hardware after a start
    /// or a stop condition in transmission).
    btf_held: bool,
    /// Another master owns the bus (after arbitration loss) until then.
    other_master_until: Option<u64>,
    /// Last bytes shifted by the errata's late read (see
    /// [`I2c1::late_last_byte_reads`]).
    late_last_bytes: u64,
    /// A DR read raced the byte on the wire: its outcome when it ends.
    ev7_race: Option<Ev7Race>,
    /// Late-EV7 races since power-on (see [`I2c1::late_ev7_reads`]).
    ev7_races: u64,
    /// When the byte now in DR got there (RXNE set).
    rxne_since_ns: u64,
}

impl I2c1 {
    /// The peripheral at its reset state, pins as inputs, with `bus` behind
    /// it, on a 36 MHz PCLK1 (the board's 72 MHz tree; see
    /// [`I2c1::set_pclk1_hz`]). Build `bus` with `SimConfig { bus_hz: None,
    /// .. }`: the emulator owns time.
    pub fn new(bus: SimBus) -> Self {
        let mut s = Self {
            bus,
            now_ns: 0,
            pclk1_hz: 36_000_000,
            cr1: 0,
            cr2: 0,
            oar1: 0,
            oar2: 0,
            ccr: 0,
            trise: 0x0002,
            flags: 0,
            msl: false,
            tra: false,
            busy: false,
            phase: Phase::Idle,
            dr_rx: None,
            shift_rx: None,
            dr_tx: None,
            dr_last: 0,
            sb_armed: false,
            addr_armed: false,
            pos_ack: false,
            pe_off_pending: false,
            scl_pin: PinMode::Input,
            sda_pin: PinMode::Input,
            lines: (true, true),
            seen: (true, true),
            filter_stuck: [false; 2],
            seen_low_while_stuck: [false; 2],
            spurious_berr: false,
            btf_held: false,
            other_master_until: None,
            late_last_bytes: 0,
            ev7_race: None,
            ev7_races: 0,
            rxne_since_ns: 0,
        };
        s.now_ns = s.bus.clock().now_ns();
        s.sync_lines();
        s
    }

    /// The bus behind the peripheral (fault injection, truth).
    pub fn bus(&self) -> &SimBus {
        &self.bus
    }

    /// How many times since power-on a receiver's last byte was shifted
    /// one bit left because byte N−1 was still in DR when the STOP reached
    /// the bus (errata ES096 "Wrong data read into data register"): each
    /// is a wrong byte handed to software.
    pub fn late_last_byte_reads(&self) -> u64 {
        self.late_last_bytes
    }

    /// How many DR reads since power-on raced the end of the byte on the
    /// wire (errata ES096 §2.13.2's late EV7): each read a byte twice or
    /// lost one (see the module documentation).
    pub fn late_ev7_reads(&self) -> u64 {
        self.ev7_races
    }

    /// Master receiver with a byte waiting in DR (RXNE): `Some(when it
    /// got there)`, in ns. `None` otherwise.
    pub fn rx_byte_waiting_since(&self) -> Option<u64> {
        (matches!(self.phase, Phase::RxByte { .. } | Phase::RxStall) && self.dr_rx.is_some())
            .then_some(self.rxne_since_ns)
    }

    /// Master receiver holding SCL low on BTF (byte N−1 in DR, byte N in
    /// the shift register): the moment the errata's closing window opens
    /// when software sets STOP.
    pub fn receiver_on_btf(&self) -> bool {
        self.phase == Phase::RxStall && self.dr_rx.is_some() && self.shift_rx.is_some()
    }

    /// Injects a fault of the peripheral.
    pub fn inject(&mut self, fault: PeripheralFault, now_ns: u64) {
        self.advance(now_ns);
        match fault {
            PeripheralFault::BusyLockup => {
                self.filter_stuck = [true; 2];
                self.seen_low_while_stuck = [false; 2];
                self.sync_lines();
            }
            PeripheralFault::SpuriousBerr => self.spurious_berr = true,
        }
    }

    /// Whether the event interrupt (I2C1_EV) is requested now (CR2.ITEVTEN,
    /// and ITBUFEN for TXE/RXNE).
    pub fn event_irq(&self) -> bool {
        let sr1 = self.sr1_value();
        let ev = sr1 & (sr1::SB | sr1::ADDR | sr1::BTF) != 0;
        let buf = sr1 & (sr1::TXE | sr1::RXNE) != 0 && self.cr2 & cr2::ITBUFEN != 0;
        self.cr2 & cr2::ITEVTEN != 0 && (ev || buf)
    }

    /// Whether the error interrupt (I2C1_ER) is requested now (CR2.ITERREN).
    pub fn error_irq(&self) -> bool {
        self.cr2 & cr2::ITERREN != 0 && self.flags & (sr1::BERR | sr1::ARLO | sr1::AF) != 0
    }

    // ---------------------------------------------------------------- time

    /// The peripheral's clock PCLK1 becomes `hz` at `now_ns` (RCC's APB1
    /// prescaler or SYSCLK changed); a byte already on the wire keeps its
    /// timing.
    pub fn set_pclk1_hz(&mut self, hz: u32, now_ns: u64) {
        if hz != self.pclk1_hz {
            self.advance(now_ns);
            self.pclk1_hz = hz.max(1);
        }
    }

    /// One SCL period in ns from CCR and PCLK1 (at least 1 ns).
    pub fn bit_ns(&self) -> u64 {
        let ccr = u64::from(self.ccr & 0x0FFF).max(1);
        let clocks = if self.ccr & 0x8000 == 0 {
            2 * ccr
        } else if self.ccr & 0x4000 == 0 {
            3 * ccr
        } else {
            25 * ccr
        };
        (clocks * 1_000_000_000 / u64::from(self.pclk1_hz)).max(1)
    }

    /// Bus progress up to `now_ns`.
    pub fn advance(&mut self, now_ns: u64) {
        self.hold_while_scl_low(now_ns);
        // Events are processed in time order; each one can schedule the next.
        for _ in 0..10_000 {
            match self.next_event_ns() {
                Some(t) if t <= now_ns => {
                    let t = t.max(self.now_ns);
                    self.now_ns = t;
                    self.bus.clock().advance_to_ns(t);
                    self.fire(t);
                }
                _ => break,
            }
        }
        if now_ns > self.now_ns {
            self.now_ns = now_ns;
        }
        self.bus.clock().advance_to_ns(self.now_ns);
        self.sync_lines();
        self.try_start();
    }

    /// SCL held low by another device (a stuck line, a chip stretching):
    /// the master's clock generator counts a high period only once it sees
    /// SCL high (clock synchronisation, RM0008 §26.3.1; no timeout outside
    /// SMBus), so a START, STOP or byte on the wire stands still for as
    /// long as the line is held, and no flag comes. The line's level at the
    /// start of the interval stands for all of it.
    fn hold_while_scl_low(&mut self, now_ns: u64) {
        if now_ns <= self.now_ns || !self.pins_af() || !self.bus.wire_scl_pulled_low() {
            return;
        }
        let held = now_ns - self.now_ns;
        match &mut self.phase {
            Phase::Start { done } | Phase::Stop { done } => *done += held,
            Phase::Address { start, done, .. }
            | Phase::TxByte { start, done, .. }
            | Phase::RxByte { start, done } => {
                *start += held;
                *done += held;
            }
            _ => {}
        }
    }

    /// When the peripheral's state next changes by itself.
    pub fn next_event_ns(&self) -> Option<u64> {
        let phase = match self.phase {
            Phase::Start { done }
            | Phase::Address { done, .. }
            | Phase::TxByte { done, .. }
            | Phase::RxByte { done, .. }
            | Phase::Stop { done } => Some(done),
            _ => None,
        };
        match (phase, self.other_master_until) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    fn fire(&mut self, t: u64) {
        if self.other_master_until.is_some_and(|u| u <= t) {
            self.other_master_until = None;
            // The other master's STOP.
            self.busy = false;
            self.sync_lines();
            self.try_start();
        }
        match self.phase {
            Phase::Start { done } if done <= t => self.start_done(),
            Phase::Address { byte, done, .. } if done <= t => self.address_done(byte),
            Phase::TxByte { byte, done, .. } if done <= t => self.tx_done(byte),
            Phase::RxByte { done, .. } if done <= t => self.rx_done(),
            Phase::Stop { done } if done <= t => self.stop_done(),
            _ => {}
        }
    }

    fn pins_af(&self) -> bool {
        self.scl_pin == PinMode::AlternateOpenDrain && self.sda_pin == PinMode::AlternateOpenDrain
    }

    fn take_spurious_berr(&mut self) {
        if std::mem::take(&mut self.spurious_berr) {
            self.flags |= sr1::BERR;
        }
    }

    // ------------------------------------------------------------ sequences

    fn bus_free(&self) -> bool {
        !self.busy && self.other_master_until.is_none()
    }

    /// A requested START goes out when the peripheral is enabled and idle
    /// and the bus is free.
    fn try_start(&mut self) {
        if self.phase == Phase::Idle
            && self.cr1 & cr1::START != 0
            && self.cr1 & cr1::PE != 0
            && !self.pe_off_pending
            && self.bus_free()
        {
            self.begin_start();
        }
    }

    fn begin_start(&mut self) {
        self.busy = true;
        self.phase = Phase::Start {
            done: self.now_ns + self.bit_ns(),
        };
    }

    fn start_done(&mut self) {
        self.btf_held = false;
        self.cr1 &= !cr1::START;
        self.msl = true;
        self.flags |= sr1::SB;
        self.sb_armed = false;
        self.phase = Phase::AwaitAddress;
        if self.cr1 & cr1::STOP != 0 {
            // STOP requested before or during the START: sent right after it.
            self.begin_stop();
        }
    }

    fn address_done(&mut self, byte: u8) {
        self.take_spurious_berr();
        let read = byte & 1 != 0;
        // With the pins not connected the ACK slot reads the pull-up: NACK.
        let result = self.pins_af().then(|| self.bus.wire_start(byte));
        self.tra = !read;
        match result {
            Some(Ok(())) => {
                self.flags |= sr1::ADDR;
                self.addr_armed = false;
                self.pos_ack = self.cr1 & cr1::ACK != 0;
                self.phase = Phase::AddrHold;
            }
            Some(Err(SimBusError::ArbitrationLoss)) => {
                // Another master won: this one drops to slave mode and the
                // bus stays busy until the winner's STOP (a 3-byte transfer).
                self.flags |= sr1::ARLO;
                self.msl = false;
                self.tra = false;
                self.phase = Phase::Idle;
                self.other_master_until = Some(self.now_ns + 29 * self.bit_ns());
            }
            Some(Err(SimBusError::Bus)) => {
                self.flags |= sr1::BERR | sr1::AF;
                self.phase = Phase::Nacked;
            }
            Some(Err(SimBusError::Nack(_))) | None => {
                self.flags |= sr1::AF;
                self.phase = Phase::Nacked;
            }
        }
        self.after_byte_requests();
    }

    /// ADDR cleared: the data phase starts.
    fn addr_cleared(&mut self) {
        if self.phase != Phase::AddrHold {
            return;
        }
        if self.tra {
            self.phase = Phase::TxIdle;
            if !self.after_byte_requests() && self.dr_tx.is_some() {
                self.tx_next();
            }
        } else {
            self.begin_rx_byte();
        }
    }

    /// STOP / repeated START requested while SCL is held low waiting for
    /// software: sent now. Returns whether one was started.
    fn after_byte_requests(&mut self) -> bool {
        if !matches!(
            self.phase,
            Phase::TxIdle | Phase::TxStall | Phase::RxStall | Phase::Nacked
        ) {
            return false;
        }
        if self.cr1 & (cr1::STOP | cr1::START) == 0 {
            return false;
        }
        self.btf_held = self.phase == Phase::TxStall;
        if self.cr1 & cr1::STOP != 0 {
            self.begin_stop();
        } else {
            self.begin_start();
        }
        true
    }

    fn tx_next(&mut self) {
        if let Some(byte) = self.dr_tx.take() {
            self.phase = Phase::TxByte {
                byte,
                start: self.now_ns,
                done: self.now_ns + 9 * self.bit_ns(),
            };
        } else {
            self.phase = Phase::TxStall;
        }
    }

    fn tx_done(&mut self, byte: u8) {
        self.take_spurious_berr();
        match self.bus.wire_write(byte) {
            Ok(()) => {
                self.phase = Phase::TxStall;
                if !self.after_byte_requests() {
                    self.tx_next();
                }
            }
            Err(e) => {
                if e == SimBusError::Bus {
                    self.flags |= sr1::BERR;
                }
                self.flags |= sr1::AF;
                self.phase = Phase::Nacked;
                self.after_byte_requests();
            }
        }
    }

    fn begin_rx_byte(&mut self) {
        self.phase = Phase::RxByte {
            start: self.now_ns,
            done: self.now_ns + 9 * self.bit_ns(),
        };
    }

    fn rx_done(&mut self) {
        self.take_spurious_berr();
        let ack_bit = self.cr1 & cr1::ACK != 0;
        let ack = if self.cr1 & cr1::POS != 0 {
            std::mem::replace(&mut self.pos_ack, ack_bit)
        } else {
            ack_bit
        };
        let byte = match self.bus.wire_read(ack) {
            Ok(b) => b,
            Err(_) => {
                self.flags |= sr1::BERR;
                0xFF
            }
        };
        match self.ev7_race.take() {
            // The hold decided on the stale RXNE: DR keeps the byte read.
            Some(Ev7Race::ReadTwice) => self.shift_rx = Some(byte),
            // Loaded, but the read's RXNE clear came after.
            Some(Ev7Race::Missed) => self.dr_last = byte,
            None if self.dr_rx.is_none() => {
                self.dr_rx = Some(byte);
                self.rxne_since_ns = self.now_ns;
            }
            None => self.shift_rx = Some(byte),
        }
        self.phase = Phase::RxStall;
        if !self.after_byte_requests() && self.shift_rx.is_none() {
            self.begin_rx_byte();
        }
    }

    fn begin_stop(&mut self) {
        self.phase = Phase::Stop {
            done: self.now_ns + self.bit_ns(),
        };
    }

    fn stop_done(&mut self) {
        self.btf_held = false;
        self.corrupt_unread_last_byte();
        if self.pins_af() {
            self.bus.wire_stop();
        }
        self.cr1 &= !cr1::STOP;
        self.msl = false;
        self.tra = false;
        self.busy = false;
        self.phase = Phase::Idle;
        self.flags &= !(sr1::SB | sr1::ADDR);
        if self.pe_off_pending {
            self.disable();
        }
        self.sync_lines();
        self.try_start();
    }

    /// Errata ES096 §2.13 "Wrong data read into data register": in master
    /// receiver mode, closing with STOP while byte N−1 waits in DR and
    /// byte N in the shift register (BTF), byte N is shifted one bit to
    /// the left when the STOP condition reaches the bus before software
    /// has read byte N−1; reading byte N then returns the wrong value.
    /// The bit shifted in is taken as 0 (the errata does not say).
    fn corrupt_unread_last_byte(&mut self) {
        if self.dr_rx.is_some() {
            if let Some(n) = self.shift_rx.as_mut() {
                *n <<= 1;
                self.late_last_bytes += 1;
            }
        }
    }

    /// The wire loses the master mid-transfer: a chip shifting out a read
    /// byte keeps its place and may hold SDA low.
    fn abandon_wire(&mut self) {
        let bit = self.bit_ns();
        match self.phase {
            Phase::TxByte { start, .. } | Phase::RxByte { start, .. } => {
                let bits = ((self.now_ns.saturating_sub(start)) / bit).min(8);
                self.bus.wire_abandon(u8::try_from(bits).unwrap_or(8));
            }
            Phase::AddrHold | Phase::TxIdle | Phase::TxStall | Phase::RxStall | Phase::Nacked => {
                self.bus.wire_abandon(0);
            }
            // The chips saw a START (or STOP): they wait for an address.
            Phase::Stop { .. }
            | Phase::Start { .. }
            | Phase::AwaitAddress
            | Phase::Address { .. } => self.bus.wire_stop(),
            Phase::Idle | Phase::Lost => {}
        }
    }

    fn in_transfer(&self) -> bool {
        !matches!(self.phase, Phase::Idle | Phase::Lost)
    }

    /// Register and state reset (SWRST or RCC): lines released by the peripheral.
    fn reset_state(&mut self) {
        if self.in_transfer() && self.pins_af() {
            self.abandon_wire();
        }
        self.cr1 = 0;
        self.cr2 = 0;
        self.oar1 = 0;
        self.oar2 = 0;
        self.ccr = 0;
        self.trise = 0x0002;
        self.flags = 0;
        self.msl = false;
        self.tra = false;
        self.busy = false;
        self.phase = Phase::Idle;
        self.dr_rx = None;
        self.shift_rx = None;
        self.dr_tx = None;
        self.dr_last = 0;
        self.sb_armed = false;
        self.addr_armed = false;
        self.pe_off_pending = false;
        self.spurious_berr = false;
        self.btf_held = false;
        self.ev7_race = None;
    }

    /// RCC APB1RSTR.I2C1RST: every register back to its reset value.
    pub fn peripheral_reset(&mut self) {
        self.reset_state();
        self.sync_lines();
    }

    fn disable(&mut self) {
        self.pe_off_pending = false;
        // A transfer whose pins were taken away never ends by itself;
        // disabling the peripheral drops it.
        if self.phase == Phase::Lost {
            self.phase = Phase::Idle;
        }
        self.cr1 &= !(cr1::PE | cr1::START | cr1::STOP | cr1::ACK | cr1::POS);
        self.flags &= !(sr1::SB | sr1::ADDR);
        // RM0008 SR1: RxNE, TxE and BTF are cleared by hardware when PE = 0.
        self.ev7_race = None;
        self.dr_rx = None;
        self.shift_rx = None;
        self.dr_tx = None;
        self.msl = false;
        self.tra = false;
    }

    // ---------------------------------------------------------------- lines

    /// The peripheral's own drive of (SCL, SDA), as seen on AF pins.
    fn peripheral_drive(&self) -> (bool, bool) {
        match self.phase {
            Phase::Idle | Phase::Lost => (true, true),
            // Holding SCL low while software handles an event.
            Phase::AwaitAddress
            | Phase::AddrHold
            | Phase::TxIdle
            | Phase::TxStall
            | Phase::RxStall
            | Phase::Nacked => (false, true),
            _ => (true, true),
        }
    }

    /// Brings line levels, the filter's view and BUSY up to date (outside
    /// byte-level transfers, which the wire engine handles).
    fn sync_lines(&mut self) {
        if self.in_transfer() && self.pins_af() {
            let (scl, _) = self.peripheral_drive();
            self.lines = (scl, true);
            return;
        }
        let scl_out = self.scl_pin.gpio_drive().unwrap_or(true);
        let sda_out = self.sda_pin.gpio_drive().unwrap_or(true);
        let lines = self.bus.wire_lines(scl_out, sda_out);
        self.lines = lines;
        let prev = self.seen;
        // The errata: a stuck filter output follows its line again after
        // the line's next transition, i.e. once it has been low and rises.
        // That jump is not a STOP to the peripheral: BUSY stays set until
        // SWRST.
        let mut unlocked = false;
        for (k, level) in [lines.0, lines.1].into_iter().enumerate() {
            let (Some(stuck), Some(low)) = (
                self.filter_stuck.get_mut(k),
                self.seen_low_while_stuck.get_mut(k),
            ) else {
                continue;
            };
            if *stuck {
                if !level {
                    *low = true;
                } else if *low {
                    *stuck = false;
                    unlocked = true;
                }
            }
        }
        let [scl_stuck, sda_stuck] = self.filter_stuck;
        self.seen = (lines.0 && !scl_stuck, lines.1 && !sda_stuck);
        if unlocked {
            self.busy = true;
            return;
        }
        if !self.seen.0 || !self.seen.1 {
            self.busy = true;
        } else if prev.0 && !prev.1 {
            // SDA rose while SCL stayed high: a STOP.
            self.busy = false;
        }
    }

    /// Configures PB6 (SCL) / PB7 (SDA) as GPIOB has them now. Taking a pin
    /// away from the peripheral mid-transfer leaves the chips where they
    /// are on the wire.
    pub fn set_pins(&mut self, scl: PinMode, sda: PinMode, now_ns: u64) {
        self.advance(now_ns);
        let was_af = self.pins_af();
        self.scl_pin = scl;
        self.sda_pin = sda;
        if was_af && !self.pins_af() && self.in_transfer() {
            self.abandon_wire();
            self.phase = Phase::Lost;
        }
        self.sync_lines();
        self.try_start();
    }

    /// SCL level (wired-AND of every driver), as GPIOB IDR reads it.
    pub fn scl_high(&mut self, now_ns: u64) -> bool {
        self.advance(now_ns);
        self.lines.0
    }

    /// SDA level (wired-AND of every driver), as GPIOB IDR reads it.
    pub fn sda_high(&mut self, now_ns: u64) -> bool {
        self.advance(now_ns);
        self.lines.1
    }

    // ------------------------------------------------------------ registers

    fn sr1_value(&self) -> u16 {
        let mut v = self.flags;
        if self.dr_rx.is_some() {
            v |= sr1::RXNE;
        }
        let btf = match self.phase {
            Phase::TxStall => self.tra && self.msl,
            Phase::Start { .. } | Phase::Stop { .. } if self.btf_held => true,
            _ => self.shift_rx.is_some(),
        };
        if btf {
            v |= sr1::BTF;
        }
        // RM0008 SR1.TxE: not set during the address phase, nor after a NACK.
        let tx_phase = matches!(
            self.phase,
            Phase::AddrHold | Phase::TxIdle | Phase::TxByte { .. } | Phase::TxStall
        );
        if self.tra && self.msl && tx_phase && self.dr_tx.is_none() {
            v |= sr1::TXE;
        }
        v
    }

    fn sr2_value(&self) -> u16 {
        let mut v = 0;
        if self.msl {
            v |= sr2::MSL;
        }
        if self.busy || self.in_transfer() {
            v |= sr2::BUSY;
        }
        if self.tra && self.msl {
            v |= sr2::TRA;
        }
        v
    }

    /// Reads the register at `offset`, with the read's side effects.
    pub fn read(&mut self, offset: u32, now_ns: u64) -> u16 {
        self.advance(now_ns);
        match offset {
            reg::CR1 => self.cr1,
            reg::CR2 => self.cr2,
            reg::OAR1 => self.oar1,
            reg::OAR2 => self.oar2,
            reg::DR => self.read_dr(),
            reg::SR1 => {
                let v = self.sr1_value();
                self.sb_armed = v & sr1::SB != 0;
                self.addr_armed = v & sr1::ADDR != 0;
                v
            }
            reg::SR2 => {
                let v = self.sr2_value();
                if std::mem::take(&mut self.addr_armed) && self.flags & sr1::ADDR != 0 {
                    self.flags &= !sr1::ADDR;
                    self.addr_cleared();
                }
                v
            }
            reg::CCR => self.ccr,
            reg::TRISE => self.trise,
            _ => 0,
        }
    }

    fn read_dr(&mut self) -> u16 {
        let stale = self.dr_rx.is_none() && self.shift_rx.is_some();
        if let Some(b) = self.dr_rx.take() {
            self.ev7_race = self.ev7_race_of_read_now();
            self.dr_last = b;
        }
        if self.dr_rx.is_none() && (stale || self.ev7_race.is_none()) {
            // DR refilled from the shift register: after a read on BTF, or
            // the second read of a byte read twice (DR still held it).
            self.dr_rx = self.shift_rx.take();
            if self.dr_rx.is_some() {
                self.rxne_since_ns = self.now_ns;
            }
            if self.phase == Phase::RxStall && self.dr_rx.is_some() {
                // BTF released: the next byte is clocked in.
                if !self.after_byte_requests() {
                    self.begin_rx_byte();
                }
            }
        }
        u16::from(self.dr_last)
    }

    /// Errata ES096 §2.13.2, the late EV7: a DR read (RXNE set) in the
    /// last SCL period of the byte on the wire races its move out of the
    /// shift register; which half decides the outcome (see [`Ev7Race`]).
    fn ev7_race_of_read_now(&mut self) -> Option<Ev7Race> {
        let Phase::RxByte { done, .. } = self.phase else {
            return None;
        };
        let bit = self.bit_ns();
        let into = self.now_ns.checked_sub(done.saturating_sub(bit))?;
        self.ev7_races += 1;
        Some(if into < bit / 2 {
            Ev7Race::ReadTwice
        } else {
            Ev7Race::Missed
        })
    }

    /// Writes `value` to the register at `offset`.
    pub fn write(&mut self, offset: u32, value: u16, now_ns: u64) {
        self.advance(now_ns);
        if self.cr1 & cr1::SWRST != 0 && offset != reg::CR1 {
            return;
        }
        match offset {
            reg::CR1 => self.write_cr1(value),
            reg::CR2 => self.cr2 = value & 0x1F3F,
            reg::OAR1 => self.oar1 = value & 0x83FF,
            reg::OAR2 => self.oar2 = value & 0x00FF,
            reg::DR => self.write_dr(value),
            reg::SR1 => self.flags &= value | !sr1::RC_W0,
            // CCR and TRISE can only be written with PE = 0.
            reg::CCR if self.cr1 & cr1::PE == 0 => self.ccr = value & 0xCFFF,
            reg::TRISE if self.cr1 & cr1::PE == 0 => self.trise = value & 0x003F,
            _ => {}
        }
        self.try_start();
    }

    fn write_dr(&mut self, value: u16) {
        let byte = (value & 0xFF) as u8;
        self.dr_last = byte;
        if self.phase == Phase::AwaitAddress {
            if std::mem::take(&mut self.sb_armed) {
                self.flags &= !sr1::SB;
                self.phase = Phase::Address {
                    byte,
                    start: self.now_ns,
                    done: self.now_ns + 9 * self.bit_ns(),
                };
            }
            return;
        }
        if self.tra && self.msl {
            self.dr_tx = Some(byte);
            if matches!(self.phase, Phase::TxIdle | Phase::TxStall)
                && self.cr1 & (cr1::STOP | cr1::START) == 0
            {
                self.tx_next();
            }
        }
    }

    fn write_cr1(&mut self, value: u16) {
        if value & cr1::SWRST != 0 {
            if self.cr1 & cr1::SWRST == 0 {
                self.reset_state();
            }
            self.cr1 = cr1::SWRST;
            self.busy = false;
            return;
        }
        if self.cr1 & cr1::SWRST != 0 {
            // Out of reset: the peripheral sees the lines afresh.
            self.cr1 = 0;
            self.seen = (true, true);
            self.sync_lines();
        }
        // CR1.STOP is one request bit: writing 1 while it is pending is the
        // same request. RM0008's "second STOP" comes from a read-modify-
        // write whose read saw STOP = 1 and whose write lands after the
        // hardware cleared it: that write is a new request, sent right
        // after the next START.
        let stop_on_wire = matches!(self.phase, Phase::Stop { .. });
        let mut new = value & 0xBFFB;
        if stop_on_wire {
            new |= cr1::STOP;
        }
        let was_pe = self.cr1 & cr1::PE != 0;
        self.cr1 = new;
        if was_pe && new & cr1::PE == 0 {
            if self.in_transfer() {
                self.pe_off_pending = true;
                self.cr1 |= cr1::PE;
            } else {
                self.disable();
            }
        }
        self.after_byte_requests();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sim::{Fault, SimClock, SimConfig};

    /// I2C1 on the simulated bus at 400 kHz (36 MHz APB1, fast mode), a
    /// START requested at t = 0; `cr2_irqs` adds interrupt enables.
    fn started(cr2_irqs: u16) -> I2c1 {
        let bus = SimBus::new(
            &SimClock::new(),
            SimConfig {
                bus_hz: None,
                ..SimConfig::default()
            },
        );
        let mut i2c = I2c1::new(bus);
        let af = PinMode::AlternateOpenDrain;
        i2c.set_pins(af, af, 0);
        i2c.write(reg::CR2, 36 | cr2_irqs, 0);
        i2c.write(reg::CCR, 0x801E, 0);
        i2c.write(reg::CR1, cr1::PE | cr1::START, 0);
        i2c
    }

    #[test]
    fn btf_stays_set_until_the_repeated_start_has_gone_out() {
        let mut i2c = started(cr2::ITEVTEN);
        let bit = i2c.bit_ns();
        let mut t = bit;
        assert_ne!(i2c.read(reg::SR1, t) & sr1::SB, 0);
        i2c.write(reg::DR, 0x68 << 1, t);
        t += 9 * bit;
        assert_ne!(i2c.read(reg::SR1, t) & sr1::ADDR, 0);
        let _ = i2c.read(reg::SR2, t);
        i2c.write(reg::DR, 0x75, t);
        t += 9 * bit;
        assert_ne!(i2c.read(reg::SR1, t) & sr1::BTF, 0);
        i2c.write(reg::CR1, cr1::PE | cr1::START, t);
        // The repeated START takes one SCL period; BTF (and its event
        // interrupt) stays until it is on the wire.
        assert_ne!(i2c.read(reg::SR1, t + bit - 1) & sr1::BTF, 0);
        assert!(i2c.event_irq());
        let sr1 = i2c.read(reg::SR1, t + bit);
        assert_eq!(sr1 & (sr1::BTF | sr1::SB), sr1::SB, "sr1 {sr1:#x}");
    }

    #[test]
    fn scl_held_low_mid_byte_stops_the_byte_and_its_flags() {
        let mut i2c = started(0);
        let bit = i2c.bit_ns();
        let mut t = bit;
        assert_ne!(i2c.read(reg::SR1, t) & sr1::SB, 0);
        i2c.write(reg::DR, 0x68 << 1, t);
        // Four bits into the address byte a chip holds SCL low for 1 ms.
        t += 4 * bit;
        i2c.advance(t);
        i2c.bus().inject(Fault::SclStuckLow);
        for _ in 0..100 {
            t += 10_000;
            let sr1 = i2c.read(reg::SR1, t);
            assert_eq!(sr1 & (sr1::ADDR | sr1::AF | sr1::BERR), 0, "sr1 {sr1:#x}");
        }
        i2c.bus().clear_faults();
        // The five bits left, then ADDR.
        t += 5 * bit - 1;
        assert_eq!(i2c.read(reg::SR1, t) & sr1::ADDR, 0);
        t += 1;
        assert_ne!(i2c.read(reg::SR1, t) & sr1::ADDR, 0);
    }
}
