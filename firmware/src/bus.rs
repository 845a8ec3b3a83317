//! The I2C1 bus shared by the three chips, and its stuck-bus recovery.
//!
//! The `BlockingI2c` lives in a `critical_section::Mutex`; each driver owns
//! a zero-sized [`BusHandle`] that borrows it for one transfer. All drivers
//! sit in the single RTIC `sensors` resource, so RTIC's priority ceiling
//! already serialises them; the critical section only makes the static
//! sound (and masks interrupts for one transfer, ≤ 0.5 ms at 400 kHz).

use core::cell::RefCell;

use critical_section::Mutex;
use embedded_hal::delay::DelayNs;
use embedded_hal::i2c::{ErrorKind, ErrorType, I2c, NoAcknowledgeSource, Operation};
use flight::health::{recover_bus, RecoveryError, RecoveryPins, RecoveryReport};
use stm32f1xx_hal::i2c::{BlockingI2c, Error as HalError};
use stm32f1xx_hal::pac::{self, I2C1};

use crate::delay::AsmDelay;

/// The concrete bus type.
pub type Bus = BlockingI2c<I2C1>;

static BUS: Mutex<RefCell<Option<Bus>>> = Mutex::new(RefCell::new(None));

/// Puts the configured bus into the shared slot.
pub fn install(bus: Bus) {
    critical_section::with(|cs| {
        if let Ok(mut slot) = BUS.borrow(cs).try_borrow_mut() {
            *slot = Some(bus);
        }
    });
}

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
    /// Other peripheral error (CRC).
    Other,
    /// The bus is not installed or is being recovered.
    Unavailable,
    /// An operation sequence the STM32F1 HAL cannot do (only write, read and
    /// write-then-read are supported; its `transaction` is unimplemented).
    Unsupported,
}

impl From<HalError> for BusError {
    fn from(e: HalError) -> Self {
        match e {
            HalError::NoAcknowledge(_) => Self::Nack,
            HalError::Timeout => Self::Timeout,
            HalError::Bus => Self::Bus,
            HalError::ArbitrationLoss => Self::Arbitration,
            HalError::Overrun => Self::Overrun,
            _ => Self::Other,
        }
    }
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
        critical_section::with(|cs| {
            let mut slot = BUS
                .borrow(cs)
                .try_borrow_mut()
                .map_err(|_| BusError::Unavailable)?;
            let bus = slot.as_mut().ok_or(BusError::Unavailable)?;
            let r = match operations {
                [Operation::Write(w)] => bus.write(address, w),
                [Operation::Read(r)] => bus.read(address, r),
                [Operation::Write(w), Operation::Read(r)] => bus.write_read(address, w, r),
                _ => return Err(BusError::Unsupported),
            };
            r.map_err(BusError::from)
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

/// CRL nibble for PB6/PB7: general-purpose output, open drain, 2 MHz.
const CRL_GPIO_OD: u32 = 0b0110;
/// CRL nibble for PB6/PB7: alternate function, open drain, 50 MHz (as the HAL sets it).
const CRL_AF_OD: u32 = 0b1111;
const CRL_PB67_MASK: u32 = 0xFF00_0000;

/// Frees a stuck bus (STM32F10xx errata 2.13.7 workaround): with I2C1
/// disabled, PB6/PB7 become open-drain GPIO, SCL is clocked until SDA is
/// released and a STOP is generated ([`flight::health::recover_bus`]);
/// then the pins go back to alternate function and I2C1 is reset with
/// SWRST and re-programmed with the register values the HAL had set.
/// Runs in a critical section (~0.2 ms).
pub fn recover() -> Result<RecoveryReport, RecoveryError> {
    critical_section::with(|_| {
        // SAFETY: the only owner of I2C1 and of PB6/PB7 is the `BlockingI2c`
        // in `BUS`, which cannot run while we hold the critical section
        // (single core, interrupts masked). We touch only I2C1's registers
        // and GPIOB's PB6/PB7 configuration bits, restoring both before
        // returning, so the HAL's view of them stays valid.
        #[allow(unsafe_code)]
        let (gpiob, i2c) = unsafe { (&*pac::GPIOB::ptr(), &*pac::I2C1::ptr()) };
        let cr1 = i2c.cr1().read().bits();
        let cr2 = i2c.cr2().read().bits();
        let ccr = i2c.ccr().read().bits();
        let trise = i2c.trise().read().bits();
        let oar1 = i2c.oar1().read().bits();
        i2c.cr1().modify(|_, w| w.pe().clear_bit());

        let mut pins = Pb67 { gpiob };
        pins.set_scl(true);
        pins.set_sda(true);
        // SAFETY: read-modify-write of CRL inside the critical section;
        // only the PB6/PB7 nibbles change.
        #[allow(unsafe_code)]
        gpiob.crl().modify(|r, w| unsafe {
            w.bits((r.bits() & !CRL_PB67_MASK) | (CRL_GPIO_OD << 24) | (CRL_GPIO_OD << 28))
        });
        let result = recover_bus(&mut pins, &mut AsmDelay);
        #[allow(unsafe_code)]
        gpiob.crl().modify(|r, w| unsafe {
            w.bits((r.bits() & !CRL_PB67_MASK) | (CRL_AF_OD << 24) | (CRL_AF_OD << 28))
        });

        i2c.cr1().write(|w| w.swrst().set_bit());
        AsmDelay.delay_us(2);
        i2c.cr1().write(|w| w.swrst().clear_bit());
        // SAFETY: restoring the exact values the HAL's init wrote.
        #[allow(unsafe_code)]
        unsafe {
            i2c.cr2().write(|w| w.bits(cr2));
            i2c.ccr().write(|w| w.bits(ccr));
            i2c.trise().write(|w| w.bits(trise));
            i2c.oar1().write(|w| w.bits(oar1));
            i2c.cr1()
                .write(|w| w.bits(cr1 & !(1 << 15) & !(1 << 9) & !(1 << 8)));
        }
        result
    })
}
