//! The I2C1 bus shared by the three chips: a small register-level master
//! (polling, every wait bounded by a DWT timeout), the interrupt-driven
//! read of the 1 kHz sample, and the stuck-bus recovery.
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
//! The 1 kHz sample read runs on the I2C1 interrupts instead:
//! * `imu` (EXTI9_5, priority 3) takes `sensors`, asks it for the sample's
//!   blocks (`Sensors::plan_sample`: MPU-9250 14 bytes; on a magnetometer
//!   tick AK8963 ST1, then HXL..ST2 only if ST1 shows DRDY), calls
//!   [`start_sample`] (START, interrupt enables) and returns.
//! * I2C1_EV and I2C1_ER run [`on_irq`] at priority 5, the highest: ES096
//!   §2.13.2 asks for the master's events to be handled before the current
//!   byte ends (its workaround for interrupt-driven transfers). The
//!   handler is one short step per event; every decision falls where SCL
//!   is held low (ADDR, BTF), the endings are RM0008's for N = 1 and N ≥ 3,
//!   and a block of N ≥ 3 takes every byte on BTF (not RXNE), so no DR read
//!   races the next byte's transfer (ES096 §2.13.2: "reading the same data
//!   twice or missing data"); SCL waits a handler's latency per byte.
//!   The two windows the errata wants uninterrupted (ADDR clear → STOP for
//!   N = 1; STOP → reading byte N−1 for N ≥ 3) run in a critical section:
//!   SysTick (hardware priority 0) is above the handlers, and stays there
//!   because the 1 kHz monotonic counts its ticks in that interrupt.
//! * The last block's end pends [`SAMPLE_DONE_IRQ`]: `sample_done`
//!   (priority 3) takes the bytes ([`take_sample`]) and `sensors` parses
//!   them with the drivers' pure functions (`Sensors::finish_sample`),
//!   then the pipeline, the flight controller and the ESC outputs run.
//! * Exclusion, by RTIC's ceilings plus one state ([`SAMPLE_STATE`]: idle,
//!   running, finished): blocking transfers (boot, `service`) run only
//!   with `sensors` locked or in `init`; `imu` and `sample_done` run at
//!   `sensors`' ceiling (3), so they never start a read inside a blocking
//!   transfer. A blocking transfer (and [`recover`]) first waits for a
//!   running read to end (≤ 0.75 ms: the longest plan is 288 bit times),
//!   so none starts while a read is on the bus. A data-ready that finds a
//!   read still running or unprocessed is started by `sample_done`.
//! * Faults end a block as the polling transfers end theirs: NACK,
//!   arbitration loss and overrun by the error interrupt ([`abort`], the
//!   same [`BusError`]s, the read goes on with the next block); BUSY
//!   before a START refuses the block and counts for [`take_busy_seen`];
//!   a lone BERR is cleared. A read with no progress for 250 µs (a stuck
//!   bus, a real BERR, a lost START) is ended with [`BusError::Timeout`]
//!   by whoever looks next: the handler itself when an event it does not
//!   act on keeps firing (BTF while a held SCL delays the repeated START),
//!   else the next data-ready (≤ 1 ms), a blocking transfer's wait, or the
//!   service round (≤ 10 ms, when data-ready stopped too). The results reach the same health counters, re-init
//!   triggers and bus recovery as the blocking reads'.
//!
//! Concurrency of the blocking transfers: all [`BusHandle`]s live in the
//! single RTIC `sensors` resource, and [`recover`] is only called with
//! that resource locked, so RTIC's priority ceiling serialises every
//! blocking I2C1 access and a transfer runs with interrupts enabled (it
//! keeps the 1 kHz path waiting at most one transfer: 0.1–0.3 ms for the
//! service task's, plus 0.1 ms on a timeout). Only the errata-critical
//! endings (ADDR clear followed by ACK/STOP programming; ES096, "some
//! software events must be managed before the current byte is being
//! transferred") run in a critical section of two or three register
//! accesses (< 1 µs at 72 MHz).

use core::cell::UnsafeCell;
use core::mem::MaybeUninit;
use core::sync::atomic::{AtomicU32, AtomicU8, Ordering};
use cortex_m::peripheral::{DWT, NVIC};
use embedded_hal::delay::DelayNs;
use embedded_hal::i2c::{ErrorKind, ErrorType, I2c, NoAcknowledgeSource, Operation};
use sensor_stack::health::{
    recover_bus, unlock_busy_flag, RecoveryError, RecoveryPins, RecoveryReport,
};
use sensor_stack::sensors::{BlockRead, BlockResults, SampleBytes, SamplePlan, SAMPLE_BYTES};
use stm32f1xx_hal::pac;

use crate::delay::AsmDelay;

/// Longest wait for one bus event, CPU cycles: 250 µs, ten byte times at
/// 400 kHz (the chips do not stretch the clock in the transfers used here).
/// It was 100 µs: on the emulator's cycle model the events of a healthy
/// sample read were held off longer than that by the other sections that
/// mask interrupts (defmt's critical section over a whole log frame, the
/// ES096 windows), and the read was ended mid-byte — a chip left holding
/// SDA, a bus recovery, an MPU re-initialisation (the flight-in-the-loop
/// rig with CRSF traffic found it). 250 µs still ends a stuck read well
/// inside the 1 ms sample period.
fn timeout_cycles() -> u32 {
    crate::delay::cpu_hz() / 4_000
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
// CR2 interrupt enables.
const CR2_ITERREN: u16 = 1 << 8;
const CR2_ITEVTEN: u16 = 1 << 9;
const CR2_ITBUFEN: u16 = 1 << 10;
const CR2_IRQS: u16 = CR2_ITERREN | CR2_ITEVTEN | CR2_ITBUFEN;
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
        // No driver reads nothing.
        [] => Err(BusError::Unsupported),
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
            // On BTF, as the sample read (ES096 §2.13.2: a DR read racing
            // the next byte's transfer reads a byte twice or misses one;
            // this task can be preempted between the flag and the read).
            for b in head {
                wait(i2c, BTF)?;
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
        wait_for_sample_read(i2c);
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
/// generated ([`sensor_stack::health::recover_bus`]), then the ES096 2.13.7
/// sequence that forces a transition through each analog filter
/// ([`sensor_stack::health::unlock_busy_flag`]), pins back to alternate
/// function, SWRST and reprogramming. Call with the `sensors` resource
/// locked. Takes ≈ 0.25 ms with 9 clocks (10 µs per clock); interrupts
/// stay enabled.
pub fn recover() -> Result<RecoveryReport, RecoveryError> {
    let (gpiob, i2c) = (gpiob(), i2c1());
    wait_for_sample_read(i2c);
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
/// A sample read that stopped making progress is ended first.
pub fn busy_while_idle() -> bool {
    let i2c = i2c1();
    end_stalled_read(i2c);
    SAMPLE_STATE.load(Ordering::Acquire) != RUNNING && busy(i2c)
}

// ------------------------------------------------- interrupt-driven read

/// The interrupt that runs the sample's processing when its read ended:
/// bound to the `sample_done` task. CAN is not used; its number (21) is
/// below EXTI9_5's (23), so when both are pending at the same priority the
/// finished sample is processed before the next read starts.
pub const SAMPLE_DONE_IRQ: pac::Interrupt = pac::Interrupt::CAN_RX1;

/// [`SAMPLE_STATE`]: no read, or its result taken.
const IDLE: u8 = 0;
/// A read is on the bus: [`SAMPLE`] belongs to the I2C1 handlers.
const RUNNING: u8 = 1;
/// The read ended (all blocks done, failed or skipped): [`SAMPLE`] waits
/// for [`take_sample`].
const FINISHED: u8 = 2;
static SAMPLE_STATE: AtomicU8 = AtomicU8::new(IDLE);
/// CYCCNT when the running read last made progress (a block's START, or
/// a handled event); read by whoever checks it for a stall.
static PROGRESS: AtomicU32 = AtomicU32::new(0);

/// Where the current block is.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Step {
    /// START requested: the address byte for writing the register goes out on SB.
    WriteAddress,
    /// Register byte in DR: the repeated START goes out on BTF.
    Register,
    /// Repeated START requested: the address byte for reading goes out on SB.
    ReadAddress,
    /// Receiving.
    Receive,
}

/// One sample's read as the handlers run it.
struct SampleRead {
    plan: SamplePlan,
    /// The block on the bus.
    cur: BlockRead,
    bytes: SampleBytes,
    results: BlockResults<BusError>,
    block: usize,
    step: Step,
    /// Next byte's index in `bytes`, and bytes left in this block.
    at: usize,
    left: usize,
    /// CPU cycles spent in the I2C1 handlers for this read.
    handler_cycles: u32,
}

struct SampleCell(UnsafeCell<MaybeUninit<SampleRead>>);
// SAFETY: ownership of the cell's contents follows SAMPLE_STATE: while
// RUNNING only the I2C1 handlers touch it (they run at the highest
// priority, so they never overlap each other and never run inside code
// that reads it); otherwise only code holding the `sensors` resource
// does (`start_sample`, `take_sample`, and `end_stalled_read` after it
// won the RUNNING → FINISHED exchange). The state is stored with Release
// after the last write and loaded with Acquire before the first read.
#[allow(unsafe_code)]
unsafe impl Sync for SampleCell {}

/// Uninitialised until the first [`start_sample`] writes all of it (an
/// initialised static would cost its image in flash); nothing reads it
/// before, as every reader first sees SAMPLE_STATE leave IDLE.
static SAMPLE: SampleCell = SampleCell(UnsafeCell::new(MaybeUninit::uninit()));

/// The read, for whoever owns it by [`SAMPLE_STATE`] (see [`SampleCell`]),
/// after the first [`start_sample`].
#[allow(clippy::mut_from_ref)]
fn sample() -> &'static mut SampleRead {
    // SAFETY: callers own the contents by SAMPLE_STATE (see SampleCell)
    // and keep the reference only while they do; SAMPLE_STATE leaves IDLE
    // only after `start_sample` initialised the contents.
    #[allow(unsafe_code)]
    unsafe {
        (*SAMPLE.0.get()).assume_init_mut()
    }
}

fn cr2_modify(i2c: &pac::i2c1::RegisterBlock, set: u16, clear: u16) {
    // SAFETY: only the interrupt enable bits change; FREQ is kept.
    #[allow(unsafe_code)]
    i2c.cr2()
        .modify(|r, w| unsafe { w.bits((r.bits() & !clear) | set) });
}

/// Starts `plan`'s reads on the I2C1 interrupts and returns at once; when
/// they end (each block done, failed or skipped), [`SAMPLE_DONE_IRQ`] is
/// pended and [`take_sample`] hands the bytes over. An empty plan ends at
/// once. `false` (nothing started, nothing pended) while the previous read
/// is still running or not yet taken; a read that stopped making progress
/// is ended with [`BusError::Timeout`] first. Call with the `sensors`
/// resource locked, so no blocking transfer is under way.
pub fn start_sample(plan: &SamplePlan) -> bool {
    let i2c = i2c1();
    end_stalled_read(i2c);
    if SAMPLE_STATE.load(Ordering::Acquire) != IDLE {
        return false;
    }
    // SAFETY: IDLE: the cell is ours (see SampleCell); this writes all of it.
    #[allow(unsafe_code)]
    let s = unsafe {
        (*SAMPLE.0.get()).write(SampleRead {
            plan: *plan,
            cur: BlockRead {
                address: 0,
                register: 0,
                offset: 0,
                len: 0,
                only_if: None,
            },
            bytes: [0; SAMPLE_BYTES],
            results: [None; 3],
            block: 0,
            step: Step::WriteAddress,
            at: 0,
            left: 0,
            handler_cycles: 0,
        })
    };
    // RUNNING before the first START: a higher-priority task between the
    // START and the store must not let the handler see an idle engine.
    SAMPLE_STATE.store(RUNNING, Ordering::Release);
    if !s.next_block(i2c) {
        finish();
    }
    true
}

/// Runs `f` on the finished read (its bytes where [`SamplePlan`]'s blocks
/// put them, each block's outcome, and the CPU cycles the I2C1 handlers
/// spent on it), then frees the engine for the next read. `None` if no
/// read has finished.
pub fn take_sample<R>(f: impl FnOnce(&SampleBytes, BlockResults<BusError>, u32) -> R) -> Option<R> {
    if SAMPLE_STATE.load(Ordering::Acquire) != FINISHED {
        return None;
    }
    let s = sample();
    let r = f(&s.bytes, s.results, s.handler_cycles);
    SAMPLE_STATE.store(IDLE, Ordering::Release);
    Some(r)
}

fn finish() {
    SAMPLE_STATE.store(FINISHED, Ordering::Release);
    NVIC::pend(SAMPLE_DONE_IRQ);
}

/// A blocking transfer waits for a running sample read (≤ 0.75 ms: the
/// longest plan is 288 bit times at 400 kHz) and ends one that stopped
/// making progress.
fn wait_for_sample_read(i2c: &pac::i2c1::RegisterBlock) {
    while SAMPLE_STATE.load(Ordering::Acquire) == RUNNING {
        end_stalled_read(i2c);
    }
}

/// Ends a running read with [`BusError::Timeout`] if no bus event came for
/// [`timeout_cycles`] (the polling transfers' bound per event).
fn end_stalled_read(i2c: &pac::i2c1::RegisterBlock) {
    if SAMPLE_STATE.load(Ordering::Acquire) != RUNNING {
        return;
    }
    let since = DWT::cycle_count().wrapping_sub(PROGRESS.load(Ordering::Relaxed));
    if since <= timeout_cycles() {
        return;
    }
    if SAMPLE_STATE
        .compare_exchange(RUNNING, FINISHED, Ordering::AcqRel, Ordering::Acquire)
        .is_err()
    {
        // The handlers finished it meanwhile.
        return;
    }
    cr2_modify(i2c, 0, CR2_IRQS);
    abort(i2c);
    let s = sample();
    if let Some(r) = s.results.get_mut(s.block) {
        *r = Some(Err(BusError::Timeout));
    }
    NVIC::pend(SAMPLE_DONE_IRQ);
}

impl SampleRead {
    /// Starts the next block whose condition holds; `false` when none is left.
    fn next_block(&mut self, i2c: &pac::i2c1::RegisterBlock) -> bool {
        while let Some(slot) = self.plan.blocks.get(self.block) {
            let Some(b) = *slot else {
                self.block += 1;
                continue;
            };
            if !self.wanted(&b) {
                self.block += 1;
                continue;
            }
            // Two bytes need the POS ending, which this engine leaves out.
            if b.len == 0 || b.len == 2 {
                self.fail(BusError::Unsupported);
                continue;
            }
            // As every transfer: BUSY before START is someone else's.
            if busy(i2c) {
                BUSY_SEEN.fetch_add(1, Ordering::Relaxed);
                self.fail(BusError::Busy);
                continue;
            }
            self.cur = b;
            self.at = usize::from(b.offset);
            self.left = usize::from(b.len);
            self.step = Step::WriteAddress;
            PROGRESS.store(DWT::cycle_count(), Ordering::Relaxed);
            // Every block enables the interrupts again: a SWRST after the
            // previous block's STOP timed out (`configure`) cleared them.
            cr2_modify(i2c, CR2_ITEVTEN | CR2_ITERREN, CR2_ITBUFEN);
            cr1_clear(i2c, CR1_POS);
            cr1_set(i2c, CR1_ACK | CR1_START);
            return true;
        }
        false
    }

    fn wanted(&self, b: &BlockRead) -> bool {
        let Some(c) = b.only_if else { return true };
        let done = matches!(self.results.get(usize::from(c.block)), Some(Some(Ok(()))));
        done && self
            .bytes
            .get(usize::from(c.byte))
            .is_some_and(|v| v & c.mask != 0)
    }

    fn fail(&mut self, e: BusError) {
        if let Some(r) = self.results.get_mut(self.block) {
            *r = Some(Err(e));
        }
        self.block += 1;
    }

    fn put(&mut self, v: u8) {
        if let Some(b) = self.bytes.get_mut(self.at) {
            *b = v;
        }
        self.at += 1;
        self.left = self.left.saturating_sub(1);
    }

    /// One event (RM0008 §26.3.3, master receiver with every byte of a
    /// block of three or more taken on BTF: SCL is held low at every
    /// decision and every DR read, so none depends on how soon the handler
    /// runs, except the single-byte ending's STOP, programmed in the same
    /// handler run as the ADDR clear). `Some(true)` when the block
    /// ended, `None` for an event this step does not act on.
    fn on_event(&mut self, i2c: &pac::i2c1::RegisterBlock, sr1: u16) -> Option<bool> {
        if sr1 & SB != 0 {
            // EV5: SR1 read, then the address byte in DR clears SB.
            let rw = u8::from(self.step == Step::ReadAddress);
            // SAFETY: DR takes the 8-bit address byte.
            #[allow(unsafe_code)]
            i2c.dr()
                .write(|w| unsafe { w.bits(u16::from((self.cur.address << 1) | rw)) });
            return Some(false);
        }
        if sr1 & ADDR != 0 {
            if self.step == Step::WriteAddress {
                clear_addr(i2c);
                // SAFETY: DR takes the register byte.
                #[allow(unsafe_code)]
                i2c.dr()
                    .write(|w| unsafe { w.bits(u16::from(self.cur.register)) });
                self.step = Step::Register;
            } else if self.left == 1 {
                // EV6_3: NACK before the ADDR clear, STOP right after it.
                // ES096 §2.13.2: from the ADDR clear the byte is on the
                // wire, and STOP must be set before it ends; this handler's
                // priority keeps every task out, the critical section also
                // SysTick (hardware priority 0, above this one).
                cr1_clear(i2c, CR1_ACK);
                critical_section::with(|_| {
                    clear_addr(i2c);
                    cr1_set(i2c, CR1_STOP);
                });
                self.step = Step::Receive;
                cr2_modify(i2c, CR2_ITBUFEN, 0);
            } else {
                clear_addr(i2c);
                self.step = Step::Receive;
            }
            return Some(false);
        }
        match self.step {
            Step::Register if sr1 & BTF != 0 => {
                cr1_set(i2c, CR1_START);
                self.step = Step::ReadAddress;
                Some(false)
            }
            Step::Receive if self.left == 1 && sr1 & RXNE != 0 => {
                self.put(read_dr(i2c));
                Some(true)
            }
            Step::Receive if self.left > 3 && sr1 & BTF != 0 => {
                // EV7 on BTF, not RXNE: DR is read only while SCL is held
                // low, never while the next byte is being transferred,
                // which ES096 §2.13.2 says can read a byte twice or miss
                // one (a handler held off about a byte time would).
                self.put(read_dr(i2c));
                Some(false)
            }
            Step::Receive if self.left == 3 && sr1 & BTF != 0 => {
                // EV7_1: N−2 in DR, N−1 in the shift register, SCL low.
                cr1_clear(i2c, CR1_ACK);
                self.put(read_dr(i2c));
                Some(false)
            }
            Step::Receive if self.left == 2 && sr1 & BTF != 0 => {
                // N−1 in DR, N (NACKed) in the shift register. ES096
                // ("Wrong data read into data register"): byte N−1 must be
                // read before the STOP reaches the bus, one SCL period
                // after it is set here, else byte N reads shifted one bit
                // left; the errata's workaround masks interrupts from
                // setting STOP to reading byte N−1. SysTick, the
                // monotonic's tick at hardware priority 0, is the one
                // exception above this handler; it stays there (the 1 kHz
                // tick counts time in its interrupt: one held off for over
                // 1 ms is time lost), so the window masks every interrupt
                // instead, as the polled read's endings do: two register
                // accesses, < 1 µs.
                let n1 = critical_section::with(|_| {
                    cr1_set(i2c, CR1_STOP);
                    read_dr(i2c)
                });
                self.put(n1);
                self.put(read_dr(i2c));
                Some(true)
            }
            _ => None,
        }
    }

    /// The block ended (read, or failed and aborted): its STOP out, then
    /// the next block or the end of the read. `true` when the read ended.
    fn after_block(&mut self, i2c: &pac::i2c1::RegisterBlock) -> bool {
        if wait_stop_sent(i2c).is_err() {
            configure(i2c);
        }
        if self.next_block(i2c) {
            return false;
        }
        cr2_modify(i2c, 0, CR2_IRQS);
        true
    }
}

/// I2C1 event and error interrupts (both vectors run this): one step of
/// the sample read. NACK, arbitration loss and overrun end the block as
/// the polling transfers end theirs ([`abort`]), and the read goes on
/// with the next block. A lone BERR is cleared and the block goes on
/// (ES096: spurious in master mode; a real one leaves the block without
/// events, and the timeout ends it).
#[inline(never)]
pub fn on_irq() {
    let t0 = DWT::cycle_count();
    let i2c = i2c1();
    if SAMPLE_STATE.load(Ordering::Acquire) != RUNNING {
        // Ended by a timeout: nothing of ours is on the bus any more.
        cr2_modify(i2c, 0, CR2_IRQS);
        return;
    }
    let s = sample();
    let sr1 = i2c.sr1().read().bits();
    let errors = sr1 & (SR1_ABORTS | BERR);
    let ended = if errors != 0 {
        // SAFETY: writing 0 clears the rc_w0 error flags; the other SR1
        // bits are read-only.
        #[allow(unsafe_code)]
        i2c.sr1().write(|w| unsafe { w.bits(!errors) });
        if errors & SR1_ABORTS != 0 {
            abort(i2c);
            s.fail(if sr1 & AF != 0 {
                BusError::Nack
            } else if sr1 & ARLO != 0 {
                BusError::Arbitration
            } else {
                BusError::Overrun
            });
            s.after_block(i2c)
        } else {
            false
        }
    } else {
        match s.on_event(i2c, sr1) {
            Some(done) => {
                PROGRESS.store(t0, Ordering::Relaxed);
                if done {
                    if let Some(r) = s.results.get_mut(s.block) {
                        *r = Some(Ok(()));
                    }
                    s.block += 1;
                    s.after_block(i2c)
                } else {
                    false
                }
            }
            // An event the step does not act on (a transmitter's BTF stays
            // set until the repeated START is on the wire, which a slave
            // holding SCL low delays without end) fires again at once, at
            // the highest priority, so no lower-priority stall check can
            // run: the handler ends the stalled read itself.
            None if t0.wrapping_sub(PROGRESS.load(Ordering::Relaxed)) > timeout_cycles() => {
                cr2_modify(i2c, 0, CR2_IRQS);
                abort(i2c);
                s.fail(BusError::Timeout);
                true
            }
            None => false,
        }
    };
    s.handler_cycles = s
        .handler_cycles
        .wrapping_add(DWT::cycle_count().wrapping_sub(t0));
    if ended {
        finish();
    }
}
