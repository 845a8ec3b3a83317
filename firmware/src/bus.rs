//! The I2C1 bus shared by the three chips: a small register-level master
//! (polling, every wait bounded by a DWT timeout) and the stuck-bus
//! recovery.
//!
//! The HAL's `BlockingI2c` is not used: its transfer code (~1.5 KiB) and a
//! bounds check that links `core::fmt` (~0.7 KiB) cost more flash than
//! these few register sequences (RM0008 §26.3.3, with the STM32F10xx
//! errata's 1-, 2- and N-byte read endings). Each driver owns a zero-sized
//! [`BusHandle`]; a transfer runs in a critical section. All drivers sit in
//! the single RTIC `sensors` resource, so RTIC's priority ceiling already
//! serialises them; the critical section only makes the register access
//! sound (and masks interrupts for one transfer, ≤ 0.5 ms at 400 kHz).

use cortex_m::peripheral::DWT;
use embedded_hal::delay::DelayNs;
use embedded_hal::i2c::{ErrorKind, ErrorType, I2c, NoAcknowledgeSource, Operation};
use flight::health::{recover_bus, RecoveryError, RecoveryPins, RecoveryReport};
use stm32f1xx_hal::pac;

use crate::delay::AsmDelay;

/// Longest wait for one bus event (a byte is 25 µs at 400 kHz; clock
/// stretching by the chips is far shorter): 1 ms in CPU cycles.
const TIMEOUT_CYCLES: u32 = crate::delay::CPU_HZ / 1_000;

/// APB1 clock (I2C1's kernel clock), MHz.
const PCLK1_MHZ: u16 = 36;
/// CCR for 400 kHz fast mode, duty 2:1 (t_low = 2 t_high): PCLK1 / (3 · 400 kHz).
const CCR_FAST_400K: u16 = (1 << 15) | (PCLK1_MHZ as u32 * 1_000_000 / (3 * 400_000)) as u16;
/// TRISE for fast mode: 300 ns · PCLK1 + 1.
const TRISE_FAST: u16 = PCLK1_MHZ * 300 / 1_000 + 1;

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
const SR1_ERRORS: u16 = BERR | ARLO | AF | OVR;
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
    /// A DWT timeout expired (stuck bus, missing pull-ups).
    Timeout,
    /// Bus error (misplaced START/STOP).
    Bus,
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
            Self::Bus => ErrorKind::Bus,
            Self::Arbitration => ErrorKind::ArbitrationLoss,
            Self::Overrun => ErrorKind::Overrun,
            _ => ErrorKind::Other,
        }
    }
}

fn i2c1() -> &'static pac::i2c1::RegisterBlock {
    // SAFETY: I2C1 is used only by this module, and only inside critical
    // sections (`BusHandle::transaction`, `recover`, and `init` before
    // interrupts are enabled), so accesses never interleave.
    #[allow(unsafe_code)]
    unsafe {
        &*pac::I2C1::ptr()
    }
}

/// Resets I2C1 and programs it for 400 kHz fast mode (PCLK1 = 36 MHz).
fn configure(i2c: &pac::i2c1::RegisterBlock) {
    // SAFETY (all raw writes below): documented register values for the
    // 36 MHz APB1 clock (RM0008 §26.6): FREQ = 36, CCR, TRISE, then PE.
    #[allow(unsafe_code)]
    unsafe {
        i2c.cr1().write(|w| w.bits(CR1_SWRST));
        i2c.cr1().write(|w| w.bits(0));
        i2c.cr2().write(|w| w.bits(PCLK1_MHZ));
        i2c.ccr().write(|w| w.bits(CCR_FAST_400K));
        i2c.trise().write(|w| w.bits(TRISE_FAST));
        i2c.cr1().write(|w| w.bits(CR1_PE));
    }
}

/// CRL nibble for PB6/PB7: general-purpose output, open drain, 2 MHz.
const CRL_GPIO_OD: u32 = 0b0110;
/// CRL nibble for PB6/PB7: alternate function, open drain, 50 MHz.
const CRL_AF_OD: u32 = 0b1111;
const CRL_PB67_MASK: u32 = 0xFF00_0000;

fn set_pb67_mode(gpiob: &pac::gpiob::RegisterBlock, nibble: u32) {
    // SAFETY: read-modify-write of CRL (callers hold a critical section or
    // run in `init`); only the PB6/PB7 nibbles change.
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
/// `init` after the clocks (APB1 = 36 MHz) and GPIOB are enabled, and
/// before any transfer.
pub fn init(rcc: &pac::RCC) {
    rcc.apb1enr().modify(|_, w| w.i2c1en().set_bit());
    rcc.apb1rstr().modify(|_, w| w.i2c1rst().set_bit());
    rcc.apb1rstr().modify(|_, w| w.i2c1rst().clear_bit());
    set_pb67_mode(gpiob(), CRL_AF_OD);
    configure(i2c1());
}

/// Waits until all of `flags` are set in SR1, failing on a bus error
/// (after generating STOP on a NACK) or after [`TIMEOUT_CYCLES`].
#[inline(never)]
fn wait(i2c: &pac::i2c1::RegisterBlock, flags: u16) -> Result<(), BusError> {
    let t0 = DWT::cycle_count();
    loop {
        let sr1 = i2c.sr1().read().bits();
        if sr1 & SR1_ERRORS != 0 {
            // SAFETY: writing 0 clears the rc_w0 error flags; the other
            // SR1 bits are read-only.
            #[allow(unsafe_code)]
            i2c.sr1().write(|w| unsafe { w.bits(!SR1_ERRORS) });
            return Err(if sr1 & AF != 0 {
                i2c.cr1().modify(|_, w| w.stop().set_bit());
                BusError::Nack
            } else if sr1 & ARLO != 0 {
                BusError::Arbitration
            } else if sr1 & BERR != 0 {
                BusError::Bus
            } else {
                BusError::Overrun
            });
        }
        if sr1 & flags == flags {
            return Ok(());
        }
        if DWT::cycle_count().wrapping_sub(t0) > TIMEOUT_CYCLES {
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

/// (Repeated) START, then the address byte; returns once ADDR is set
/// (not yet cleared: the read endings differ in when they clear it).
fn start(i2c: &pac::i2c1::RegisterBlock, addr_byte: u8) -> Result<(), BusError> {
    cr1_set(i2c, CR1_START);
    wait(i2c, SB)?;
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

/// STOP, then waits until the hardware has sent it (CR1.STOP clears).
fn stop(i2c: &pac::i2c1::RegisterBlock) -> Result<(), BusError> {
    cr1_set(i2c, CR1_STOP);
    let t0 = DWT::cycle_count();
    while i2c.cr1().read().bits() & CR1_STOP != 0 {
        if DWT::cycle_count().wrapping_sub(t0) > TIMEOUT_CYCLES {
            return Err(BusError::Timeout);
        }
    }
    Ok(())
}

/// Master write; ends with STOP if `stop_after`, else leaves the bus held
/// (BTF) for a repeated START.
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
        stop(i2c)?;
    }
    Ok(())
}

/// Master read with STOP, using RM0008's endings for 1, 2 and ≥ 3 bytes
/// (NACK and STOP programmed before the last byte arrives).
fn read(i2c: &pac::i2c1::RegisterBlock, address: u8, buf: &mut [u8]) -> Result<(), BusError> {
    let addr_byte = (address << 1) | 1;
    match buf {
        [] => {
            start(i2c, addr_byte)?;
            clear_addr(i2c);
            stop(i2c)
        }
        [only] => {
            cr1_clear(i2c, CR1_ACK | CR1_POS);
            start(i2c, addr_byte)?;
            clear_addr(i2c);
            cr1_set(i2c, CR1_STOP);
            wait(i2c, RXNE)?;
            *only = read_dr(i2c);
            Ok(())
        }
        [first, second] => {
            cr1_set(i2c, CR1_ACK | CR1_POS);
            let r = (|| {
                start(i2c, addr_byte)?;
                clear_addr(i2c);
                cr1_clear(i2c, CR1_ACK);
                wait(i2c, BTF)?;
                cr1_set(i2c, CR1_STOP);
                *first = read_dr(i2c);
                *second = read_dr(i2c);
                Ok(())
            })();
            cr1_clear(i2c, CR1_POS);
            r
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
            cr1_set(i2c, CR1_STOP);
            *n1 = read_dr(i2c);
            wait(i2c, RXNE)?;
            *n0 = read_dr(i2c);
            Ok(())
        }
    }
}

/// A handle onto the shared bus (zero-sized; one per driver).
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
        critical_section::with(|_| {
            let i2c = i2c1();
            let r = match operations {
                [Operation::Write(w)] => write(i2c, address, w, true),
                [Operation::Read(r)] => read(i2c, address, r),
                [Operation::Write(w), Operation::Read(r)] => {
                    write(i2c, address, w, false).and_then(|()| read(i2c, address, r))
                }
                _ => return Err(BusError::Unsupported),
            };
            if r.is_err() {
                // Leave the bus released and the next transfer a clean
                // start: STOP (best effort), ACK/POS back to reset.
                let _ = stop(i2c);
                cr1_clear(i2c, CR1_ACK | CR1_POS);
            }
            r
        })
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

/// Frees a stuck bus (STM32F10xx errata 2.13.7 workaround): with I2C1
/// disabled, PB6/PB7 become open-drain GPIO, SCL is clocked until SDA is
/// released and a STOP is generated ([`flight::health::recover_bus`]);
/// then the pins go back to alternate function and I2C1 is reset with
/// SWRST and re-programmed. Runs in a critical section (~0.2 ms).
pub fn recover() -> Result<RecoveryReport, RecoveryError> {
    critical_section::with(|_| {
        let (gpiob, i2c) = (gpiob(), i2c1());
        cr1_clear(i2c, CR1_PE);
        let mut pins = Pb67 { gpiob };
        pins.set_scl(true);
        pins.set_sda(true);
        set_pb67_mode(gpiob, CRL_GPIO_OD);
        let result = recover_bus(&mut pins, &mut AsmDelay);
        set_pb67_mode(gpiob, CRL_AF_OD);
        AsmDelay.delay_us(2);
        configure(i2c);
        result
    })
}
