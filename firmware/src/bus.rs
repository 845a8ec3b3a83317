//! The I2C1 bus shared by the three chips: a small register-level master
//! (polling, every wait bounded by a DWT timeout) and the stuck-bus
//! recovery.
//!
//! The HAL's `BlockingI2c` is not used: its transfer code (~1.5 KiB) and a
//! bounds check that links `core::fmt` (~0.7 KiB) cost more flash than
//! these few register sequences (RM0008 §26.3.3, with the STM32F10xx
//! errata's 1-, 2- and N-byte read endings).
//!
//! How it behaves on a bad bus (RM0008 §26.3, errata ES096 §2.13):
//! * BUSY set before START (a slave holds SDA, or the analog-filter
//!   lock-up of ES096 2.13.7): the transfer fails at once with
//!   [`BusError::Busy`] and [`take_busy_seen`] tells the service task,
//!   which runs [`recover`]; nothing in the 1 kHz path waits or retries.
//! * START not answered by SB: SWRST, reprogram, one more START (as the
//!   HAL does); then [`BusError::Timeout`].
//! * Every transfer ends by waiting (bounded) for CR1.STOP to clear, so
//!   CR1 is never written while a STOP is pending (RM0008 §26.6.1 note).
//! * An aborted read clears ACK before STOP (a slave transmitter that sees
//!   an ACK keeps driving SDA); STOP is requested once per abort.
//! * A lone BERR in master mode is cleared and the transfer goes on
//!   (ES096, "spurious bus error detection in master mode").
//!
//! Concurrency: all [`BusHandle`]s live in the single RTIC `sensors`
//! resource, and [`recover`] is only called with that resource locked, so
//! RTIC's priority ceiling serialises every I2C1 access and a transfer
//! runs with interrupts enabled (it only keeps the `imu` task, at the
//! ceiling, waiting: at most one transfer, 0.45 ms for the 14-byte burst
//! at 400 kHz, plus 0.1 ms on a timeout). Only the errata-critical
//! endings (ADDR clear followed by ACK/STOP programming; ES096, "some
//! software events must be managed before the current byte is being
//! transferred") run in a critical section of two or three register
//! accesses (< 1 µs at 72 MHz).

use core::sync::atomic::{AtomicU32, Ordering};
use cortex_m::peripheral::DWT;
use embedded_hal::delay::DelayNs;
use embedded_hal::i2c::{ErrorKind, ErrorType, I2c, NoAcknowledgeSource, Operation};
use flight::health::{recover_bus, unlock_busy_flag, RecoveryError, RecoveryPins, RecoveryReport};
use stm32f1xx_hal::pac;

use crate::delay::AsmDelay;

/// Longest wait for one bus event, CPU cycles: 100 µs, four byte times at
/// 400 kHz (the chips do not stretch the clock in the transfers used here).
fn timeout_cycles() -> u32 {
    crate::delay::cpu_hz() / 10_000
}

/// APB1 clock (I2C1's kernel clock), MHz: SYSCLK / 2 in both clock setups
/// (36 MHz from the crystal, 32 MHz on the HSI fallback).
fn pclk1_mhz() -> u32 {
    crate::delay::cpu_hz() / 2_000_000
}

// SR1 flags.
const SB: u16 = 1 << 0;
const ADDR: u16 = 1 << 1;
const BTF: u16 = 1 << 2;
const RXNE: u16 = 1 << 6;
const TXE: u16 = 1 << 7;
const BERR: u16 = 1 << 8;
const ARLO: u16 = 1 << 9;
const AF: u16 = 1 << 10;
const OVR: u16 = 1 << 11;
const SR1_ABORTS: u16 = ARLO | AF | OVR;
// SR2 flags.
const SR2_BUSY: u16 = 1 << 1;
// CR1 bits.
const CR1_PE: u16 = 1 << 0;
const CR1_START: u16 = 1 << 8;
const CR1_STOP: u16 = 1 << 9;
const CR1_ACK: u16 = 1 << 10;
const CR1_POS: u16 = 1 << 11;
const CR1_SWRST: u16 = 1 << 15;

/// Errors of a [`BusHandle`] transfer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum BusError {
    /// Address or data not acknowledged.
    Nack,
    /// SR2.BUSY was set with no transfer of ours under way: a slave holds
    /// SDA low or the analog filter locked up; the bus needs [`recover`].
    Busy,
    /// A DWT timeout expired (stuck bus, missing pull-ups).
    Timeout,
    /// Arbitration lost.
    Arbitration,
    /// Overrun / underrun.
    Overrun,
    /// An operation sequence this master does not do (only write, read and
    /// write-then-read are needed by the drivers).
    Unsupported,
}

impl embedded_hal::i2c::Error for BusError {
    fn kind(&self) -> ErrorKind {
        match self {
            Self::Nack => ErrorKind::NoAcknowledge(NoAcknowledgeSource::Unknown),
            Self::Busy => ErrorKind::Bus,
            Self::Arbitration => ErrorKind::ArbitrationLoss,
            Self::Overrun => ErrorKind::Overrun,
            _ => ErrorKind::Other,
        }
    }
}

/// Transfers refused because BUSY was set before START, since the last
/// [`take_busy_seen`].
static BUSY_SEEN: AtomicU32 = AtomicU32::new(0);
/// Returns and clears the count of transfers refused on BUSY: non-zero
/// means the bus needs [`recover`].
pub fn take_busy_seen() -> u32 {
    BUSY_SEEN.swap(0, Ordering::Relaxed)
}

fn i2c1() -> &'static pac::i2c1::RegisterBlock {
    // SAFETY: I2C1 is used only by this module: by `BusHandle`s, which all
    // live in the one RTIC `sensors` resource, by `recover`, called with
    // that resource locked, and by `init` before interrupts are enabled.
    // RTIC's priority ceiling therefore serialises every access.
    #[allow(unsafe_code)]
    unsafe {
        &*pac::I2C1::ptr()
    }
}

/// Resets I2C1 (SWRST) and programs it for fast mode at ≤ 400 kHz.
fn configure(i2c: &pac::i2c1::RegisterBlock) {
    let mhz = pclk1_mhz();
    // Fast mode, duty 2:1 (t_low = 2 t_high): CCR = PCLK1 / (3 · 400 kHz),
    // rounded up so the bus never runs faster than 400 kHz (30 at 36 MHz;
    // 27, 395 kHz, at 32 MHz).
    let ccr = (1 << 15) | (mhz * 1_000_000).div_ceil(3 * 400_000);
    // Fast-mode maximum rise time 300 ns: TRISE = 300 ns · PCLK1 + 1.
    let trise = mhz * 300 / 1_000 + 1;
    // SAFETY (all raw writes below): RM0008 §26.6 field values: FREQ =
    // PCLK1 in MHz (2..=36), CCR and TRISE as computed, then PE.
    #[allow(unsafe_code)]
    unsafe {
        i2c.cr1().write(|w| w.bits(CR1_SWRST));
        i2c.cr1().write(|w| w.bits(0));
        i2c.cr2().write(|w| w.bits(mhz as u16));
        i2c.ccr().write(|w| w.bits(ccr as u16));
        i2c.trise().write(|w| w.bits(trise as u16));
        i2c.cr1().write(|w| w.bits(CR1_PE));
    }
}

/// CRL nibble for PB6/PB7: general-purpose output, open drain, 2 MHz.
const CRL_GPIO_OD: u32 = 0b0110;
/// CRL nibble for PB6/PB7: alternate function, open drain, 50 MHz.
const CRL_AF_OD: u32 = 0b1111;
const CRL_PB67_MASK: u32 = 0xFF00_0000;

fn set_pb67_mode(gpiob: &pac::gpiob::RegisterBlock, nibble: u32) {
    // SAFETY: read-modify-write of CRL, only the PB6/PB7 nibbles change.
    // After `init` nothing else writes GPIOB's CRL (PB5, the other CRL
    // pin in use, is configured once in `init`), so the RMW cannot race.
    #[allow(unsafe_code)]
    gpiob.crl().modify(|r, w| unsafe {
        w.bits((r.bits() & !CRL_PB67_MASK) | (nibble << 24) | (nibble << 28))
    });
}

fn gpiob() -> &'static pac::gpiob::RegisterBlock {
    // SAFETY: only PB6/PB7 are touched through this (BSRR bits, CRL
    // nibbles), pins nothing else in the firmware uses.
    #[allow(unsafe_code)]
    unsafe {
        &*pac::GPIOB::ptr()
    }
}

/// Enables and configures I2C1 on PB6 (SCL) / PB7 (SDA), 400 kHz. Call in
/// `init` after the clocks (APB1 = SYSCLK / 2) and GPIOB are enabled, and
/// before any transfer.
pub fn init(rcc: &pac::RCC) {
    rcc.apb1enr().modify(|_, w| w.i2c1en().set_bit());
    rcc.apb1rstr().modify(|_, w| w.i2c1rst().set_bit());
    rcc.apb1rstr().modify(|_, w| w.i2c1rst().clear_bit());
    set_pb67_mode(gpiob(), CRL_AF_OD);
    configure(i2c1());
}

/// Waits until all of `flags` are set in SR1. ARLO, AF and OVR abort
/// (flags cleared, the caller ends the transfer); a lone BERR is only
/// cleared (ES096: spurious in master mode); after
/// [`timeout_cycles`], [`BusError::Timeout`].
#[inline(never)]
fn wait(i2c: &pac::i2c1::RegisterBlock, flags: u16) -> Result<(), BusError> {
    let t0 = DWT::cycle_count();
    loop {
        let sr1 = i2c.sr1().read().bits();
        let errors = sr1 & (SR1_ABORTS | BERR);
        if errors != 0 {
            // SAFETY: writing 0 clears the rc_w0 error flags; the other
            // SR1 bits are read-only.
            #[allow(unsafe_code)]
            i2c.sr1().write(|w| unsafe { w.bits(!errors) });
            if sr1 & AF != 0 {
                return Err(BusError::Nack);
            }
            if sr1 & ARLO != 0 {
                return Err(BusError::Arbitration);
            }
            if sr1 & OVR != 0 {
                return Err(BusError::Overrun);
            }
        }
        if sr1 & flags == flags {
            return Ok(());
        }
        if DWT::cycle_count().wrapping_sub(t0) > timeout_cycles() {
            return Err(BusError::Timeout);
        }
    }
}

fn cr1_set(i2c: &pac::i2c1::RegisterBlock, bits: u16) {
    // SAFETY: sets control bits of CR1 (START/STOP/ACK/POS) as RM0008's
    // master sequences prescribe.
    #[allow(unsafe_code)]
    i2c.cr1().modify(|r, w| unsafe { w.bits(r.bits() | bits) });
}

fn cr1_clear(i2c: &pac::i2c1::RegisterBlock, bits: u16) {
    // SAFETY: as above, clearing.
    #[allow(unsafe_code)]
    i2c.cr1().modify(|r, w| unsafe { w.bits(r.bits() & !bits) });
}

fn read_dr(i2c: &pac::i2c1::RegisterBlock) -> u8 {
    i2c.dr().read().bits() as u8
}

fn busy(i2c: &pac::i2c1::RegisterBlock) -> bool {
    i2c.sr2().read().bits() & SR2_BUSY != 0
}

/// START, waiting for SB; on a timeout, SWRST + reprogram and one more
/// START (a START that never comes means the cell is confused, as after a
/// misplaced STOP).
fn start_condition(i2c: &pac::i2c1::RegisterBlock) -> Result<(), BusError> {
    cr1_set(i2c, CR1_START);
    match wait(i2c, SB) {
        Err(BusError::Timeout) => {
            configure(i2c);
            cr1_set(i2c, CR1_START);
            wait(i2c, SB)
        }
        r => r,
    }
}

/// (Repeated) START, then the address byte; returns once ADDR is set
/// (not yet cleared: the read endings differ in when they clear it).
fn start(i2c: &pac::i2c1::RegisterBlock, addr_byte: u8) -> Result<(), BusError> {
    start_condition(i2c)?;
    // SAFETY: DR takes the 8-bit address byte.
    #[allow(unsafe_code)]
    i2c.dr().write(|w| unsafe { w.bits(u16::from(addr_byte)) });
    wait(i2c, ADDR)
}

/// Clears ADDR (read SR1 then SR2).
fn clear_addr(i2c: &pac::i2c1::RegisterBlock) {
    let _ = i2c.sr1().read().bits();
    let _ = i2c.sr2().read().bits();
}

/// Waits (bounded) until the hardware has sent a requested STOP: CR1 must
/// not be written while STOP is pending (RM0008 §26.6.1).
fn wait_stop_sent(i2c: &pac::i2c1::RegisterBlock) -> Result<(), BusError> {
    let t0 = DWT::cycle_count();
    while i2c.cr1().read().bits() & CR1_STOP != 0 {
        if DWT::cycle_count().wrapping_sub(t0) > timeout_cycles() {
            return Err(BusError::Timeout);
        }
    }
    Ok(())
}

/// Master write; ends with STOP requested if `stop_after`, else leaves the
/// bus held (BTF) for a repeated START.
fn write(
    i2c: &pac::i2c1::RegisterBlock,
    address: u8,
    bytes: &[u8],
    stop_after: bool,
) -> Result<(), BusError> {
    start(i2c, address << 1)?;
    clear_addr(i2c);
    for &b in bytes {
        wait(i2c, TXE)?;
        // SAFETY: DR takes one data byte.
        #[allow(unsafe_code)]
        i2c.dr().write(|w| unsafe { w.bits(u16::from(b)) });
    }
    wait(i2c, BTF)?;
    if stop_after {
        cr1_set(i2c, CR1_STOP);
    }
    Ok(())
}

/// Master read, STOP requested, using RM0008's endings for 1, 2 and ≥ 3
/// bytes (NACK and STOP programmed before the last byte arrives).
fn read(i2c: &pac::i2c1::RegisterBlock, address: u8, buf: &mut [u8]) -> Result<(), BusError> {
    let addr_byte = (address << 1) | 1;
    match buf {
        [] => {
            start(i2c, addr_byte)?;
            clear_addr(i2c);
            cr1_set(i2c, CR1_STOP);
            Ok(())
        }
        [only] => {
            cr1_clear(i2c, CR1_ACK | CR1_POS);
            start(i2c, addr_byte)?;
            critical_section::with(|_| {
                clear_addr(i2c);
                cr1_set(i2c, CR1_STOP);
            });
            wait(i2c, RXNE)?;
            *only = read_dr(i2c);
            Ok(())
        }
        [first, second] => {
            cr1_set(i2c, CR1_ACK | CR1_POS);
            start(i2c, addr_byte)?;
            critical_section::with(|_| {
                clear_addr(i2c);
                cr1_clear(i2c, CR1_ACK);
            });
            wait(i2c, BTF)?;
            critical_section::with(|_| {
                cr1_set(i2c, CR1_STOP);
                *first = read_dr(i2c);
            });
            // POS stays set: clearing it now would write CR1 with STOP
            // pending; every read clears it before its START.
            *second = read_dr(i2c);
            Ok(())
        }
        [head @ .., n2, n1, n0] => {
            cr1_clear(i2c, CR1_POS);
            cr1_set(i2c, CR1_ACK);
            start(i2c, addr_byte)?;
            clear_addr(i2c);
            for b in head {
                wait(i2c, RXNE)?;
                *b = read_dr(i2c);
            }
            // Data N−2 in DR, N−1 in the shift register.
            wait(i2c, BTF)?;
            cr1_clear(i2c, CR1_ACK);
            *n2 = read_dr(i2c);
            wait(i2c, BTF)?;
            critical_section::with(|_| {
                cr1_set(i2c, CR1_STOP);
                *n1 = read_dr(i2c);
            });
            wait(i2c, RXNE)?;
            *n0 = read_dr(i2c);
            Ok(())
        }
    }
}

/// Ends an aborted transfer: NACK first, then one STOP (unless one is
/// already pending, when CR1 is left alone), then the bounded wait for it; if the STOP never goes
/// out, SWRST + reprogram leaves the cell clean for the next transfer (the
/// service task recovers the bus itself).
fn abort(i2c: &pac::i2c1::RegisterBlock) {
    // With a STOP already pending (the read ending had set it), CR1 must
    // not be written at all until it has gone out.
    if i2c.cr1().read().bits() & CR1_STOP == 0 {
        cr1_clear(i2c, CR1_ACK | CR1_POS);
        cr1_set(i2c, CR1_STOP);
    }
    if wait_stop_sent(i2c).is_err() {
        configure(i2c);
    }
}

/// A handle onto the shared bus (zero-sized; one per driver). All handles
/// must live in the one RTIC resource that serialises the bus.
#[derive(Clone, Copy, Debug, Default)]
pub struct BusHandle;

impl ErrorType for BusHandle {
    type Error = BusError;
}

impl I2c for BusHandle {
    fn transaction(
        &mut self,
        address: u8,
        operations: &mut [Operation<'_>],
    ) -> Result<(), BusError> {
        let i2c = i2c1();
        // Every transfer of ours ends with its STOP sent (or the cell
        // reset), so BUSY here is someone else holding the bus.
        if busy(i2c) {
            BUSY_SEEN.fetch_add(1, Ordering::Relaxed);
            return Err(BusError::Busy);
        }
        let r = match operations {
            [Operation::Write(w)] => write(i2c, address, w, true),
            [Operation::Read(r)] => read(i2c, address, r),
            [Operation::Write(w), Operation::Read(r)] => {
                write(i2c, address, w, false).and_then(|()| read(i2c, address, r))
            }
            _ => return Err(BusError::Unsupported),
        };
        match r {
            Ok(()) => wait_stop_sent(i2c).inspect_err(|_| configure(i2c)),
            Err(e) => {
                abort(i2c);
                Err(e)
            }
        }
    }
}

/// PB6 (SCL) / PB7 (SDA) driven by hand through the GPIOB registers.
struct Pb67<'a> {
    gpiob: &'a pac::gpiob::RegisterBlock,
}

impl RecoveryPins for Pb67<'_> {
    fn set_scl(&mut self, high: bool) {
        let bit = if high { 1 << 6 } else { 1 << (6 + 16) };
        // SAFETY: BSRR is a write-only set/reset register; writing only
        // the PB6 bit is atomic and touches no other pin.
        #[allow(unsafe_code)]
        self.gpiob.bsrr().write(|w| unsafe { w.bits(bit) });
    }
    fn set_sda(&mut self, high: bool) {
        let bit = if high { 1 << 7 } else { 1 << (7 + 16) };
        // SAFETY: as above, PB7 only.
        #[allow(unsafe_code)]
        self.gpiob.bsrr().write(|w| unsafe { w.bits(bit) });
    }
    fn scl_is_high(&mut self) -> bool {
        self.gpiob.idr().read().bits() & (1 << 6) != 0
    }
    fn sda_is_high(&mut self) -> bool {
        self.gpiob.idr().read().bits() & (1 << 7) != 0
    }
}

/// Frees a stuck bus and unlocks the BUSY flag: PE off, PB6/PB7 as
/// open-drain GPIO, SCL clocked until the slave releases SDA and a STOP
/// generated ([`flight::health::recover_bus`]), then the ES096 2.13.7
/// sequence that forces a transition through each analog filter
/// ([`flight::health::unlock_busy_flag`]), pins back to alternate
/// function, SWRST and reprogramming. Call with the `sensors` resource
/// locked. Takes ≈ 0.25 ms with 9 clocks (10 µs per clock); interrupts
/// stay enabled.
pub fn recover() -> Result<RecoveryReport, RecoveryError> {
    let (gpiob, i2c) = (gpiob(), i2c1());
    cr1_clear(i2c, CR1_PE);
    let mut pins = Pb67 { gpiob };
    pins.set_scl(true);
    pins.set_sda(true);
    set_pb67_mode(gpiob, CRL_GPIO_OD);
    let result = recover_bus(&mut pins, &mut AsmDelay)
        .and_then(|rep| unlock_busy_flag(&mut pins, &mut AsmDelay).map(|()| rep));
    set_pb67_mode(gpiob, CRL_AF_OD);
    AsmDelay.delay_us(2);
    configure(i2c);
    let _ = take_busy_seen();
    result
}

/// `true` if I2C1 reports BUSY while no transfer of ours is under way
/// (call with the `sensors` resource locked): the bus needs [`recover`].
pub fn busy_while_idle() -> bool {
    busy(i2c1())
}
