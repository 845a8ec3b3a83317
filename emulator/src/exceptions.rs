//! Cortex-M exception entry and return, done by the harness because
//! unicorn's Cortex-M core has no NVIC (ARMv7-M ARM B1.5.6 "Exception
//! entry behavior", B1.5.8 "Exception return behavior", B1.5.7 stack
//! alignment; tail-chaining, B1.5.12).
//!
//! Entry pushes r0–r3, r12, lr, the return address and xPSR on the main
//! stack (8-byte aligned when CCR.STKALIGN is set, recorded in the stacked
//! xPSR bit 9), writes EXC_RETURN to LR, the exception number to IPSR and
//! the vector to PC. A jump to EXC_RETURN surfaces in unicorn as interrupt
//! number 8 with nothing unstacked; [`exception_return`] then either
//! tail-chains into the next pending exception or unstacks the frame.
//!
//! Each step charges its cycles (`crate::cycles::exception_cycles`): an
//! entry 12, a tail-chain 6, a return 10, plus flash wait states; an entry
//! taken in the same delivery as an earlier one is a late arrival that
//! shares its stacking.

use crate::board::{BoardError, Hw};
use crate::cycles::ExceptionStep;
use crate::scs::HARDFAULT;
use unicorn_engine::{RegisterARM, Unicorn};

/// EXC_RETURN: return to handler mode, main stack.
const RETURN_HANDLER: u32 = 0xFFFF_FFF1;
/// EXC_RETURN: return to thread mode, main stack.
const RETURN_THREAD_MSP: u32 = 0xFFFF_FFF9;

fn reg(uc: &Unicorn<'_, Hw>, r: RegisterARM) -> u32 {
    uc.reg_read(r).unwrap_or(0) as u32
}

fn set(uc: &mut Unicorn<'_, Hw>, r: RegisterARM, v: u32) -> Result<(), BoardError> {
    uc.reg_write(r, u64::from(v))
        .map_err(|e| BoardError::Cpu(format!("register write {r:?}: {e:?}")))
}

fn write_word(uc: &mut Unicorn<'_, Hw>, addr: u32, v: u32) -> Result<(), BoardError> {
    uc.mem_write(u64::from(addr), &v.to_le_bytes())
        .map_err(|_| BoardError::StackOutsideRam { sp: addr })
}

fn read_word(uc: &Unicorn<'_, Hw>, addr: u32) -> Result<u32, BoardError> {
    let mut b = [0u8; 4];
    uc.mem_read(u64::from(addr), &mut b)
        .map_err(|_| BoardError::StackOutsideRam { sp: addr })?;
    Ok(u32::from_le_bytes(b))
}

/// The current execution priority from the NVIC's active list and the
/// core's BASEPRI/PRIMASK/FAULTMASK.
pub fn execution_priority(uc: &Unicorn<'_, Hw>) -> i16 {
    let basepri = reg(uc, RegisterARM::BASEPRI) as u8;
    let primask = reg(uc, RegisterARM::PRIMASK) & 1 != 0;
    let faultmask = reg(uc, RegisterARM::FAULTMASK) & 1 != 0;
    uc.get_data()
        .nvic
        .execution_priority(basepri, primask, faultmask)
}

/// Vector `n` of the table at VTOR (address 0 aliases flash, BOOT0 = 0).
fn vector(uc: &Unicorn<'_, Hw>, n: usize) -> Result<u32, BoardError> {
    let hw = uc.get_data();
    let mut addr = hw.nvic.vtor + 4 * n as u32;
    if addr < crate::elf::FLASH_BASE {
        addr += crate::elf::FLASH_BASE;
    }
    let off = addr.wrapping_sub(crate::elf::FLASH_BASE);
    if off < hw.flash.size() {
        return Ok(hw.flash.read_memory(off, 4));
    }
    read_word(uc, addr)
}

fn jump_to_handler(uc: &mut Unicorn<'_, Hw>, n: usize) -> Result<(), BoardError> {
    let handler = vector(uc, n)?;
    if handler & 1 == 0 {
        return Err(BoardError::Unsupported(format!(
            "vector {n} = {handler:#010x} has the Thumb bit clear (INVSTATE)"
        )));
    }
    let xpsr = reg(uc, RegisterARM::XPSR);
    // IPSR = n, EPSR: T set, IT cleared; the flags are kept.
    set(
        uc,
        RegisterARM::XPSR,
        (xpsr & 0xF800_0000) | (1 << 24) | n as u32,
    )?;
    set(uc, RegisterARM::PC, handler | 1)?;
    let hw = uc.get_data_mut();
    hw.nvic.pending[n] = false;
    hw.nvic.active.push(n);
    if let Some(c) = hw.entries.get_mut(n) {
        *c += 1;
    }
    Ok(())
}

/// Takes exception `n` now, from the current PC (the next instruction).
pub fn enter(uc: &mut Unicorn<'_, Hw>, n: usize) -> Result<(), BoardError> {
    enter_from(uc, n, reg(uc, RegisterARM::PC))
}

/// Takes exception `n` with `return_address` stacked (for a fault, the
/// faulting instruction).
pub fn enter_from(
    uc: &mut Unicorn<'_, Hw>,
    n: usize,
    return_address: u32,
) -> Result<(), BoardError> {
    let sp = reg(uc, RegisterARM::SP);
    let xpsr = reg(uc, RegisterARM::XPSR);
    let stkalign = uc.get_data().nvic.ccr & (1 << 9) != 0;
    let realign = stkalign && sp & 4 != 0;
    let frame = sp.wrapping_sub(0x20) & if stkalign { !4 } else { !0 };
    let stacked_xpsr = (xpsr & !(1 << 9)) | (u32::from(realign) << 9);
    let words = [
        reg(uc, RegisterARM::R0),
        reg(uc, RegisterARM::R1),
        reg(uc, RegisterARM::R2),
        reg(uc, RegisterARM::R3),
        reg(uc, RegisterARM::R12),
        reg(uc, RegisterARM::LR),
        return_address & !1,
        stacked_xpsr,
    ];
    for (i, w) in words.iter().enumerate() {
        write_word(uc, frame + 4 * i as u32, *w)?;
    }
    let handler_mode = xpsr & 0x1FF != 0;
    set(uc, RegisterARM::SP, frame)?;
    set(
        uc,
        RegisterARM::LR,
        if handler_mode {
            RETURN_HANDLER
        } else {
            RETURN_THREAD_MSP
        },
    )?;
    jump_to_handler(uc, n)
}

/// Completes a jump to `exc_return`: tail-chains into a pending exception
/// that may now run, or unstacks the frame.
pub fn exception_return(uc: &mut Unicorn<'_, Hw>, exc_return: u32) -> Result<(), BoardError> {
    if exc_return != RETURN_HANDLER && exc_return != RETURN_THREAD_MSP {
        return Err(BoardError::Unsupported(format!(
            "EXC_RETURN {exc_return:#010x} (process stack or reserved value)"
        )));
    }
    let ipsr = reg(uc, RegisterARM::IPSR) as usize & 0x1FF;
    let hw = uc.get_data_mut();
    if hw.nvic.active.last() != Some(&ipsr) {
        return Err(BoardError::Unsupported(format!(
            "exception return from {ipsr} which is not the active exception ({:?})",
            hw.nvic.active
        )));
    }
    hw.nvic.active.pop();
    let to_thread = exc_return == RETURN_THREAD_MSP;
    if to_thread != hw.nvic.active.is_empty() {
        return Err(BoardError::Unsupported(
            "EXC_RETURN mode does not match the nesting (INVPC UsageFault)".into(),
        ));
    }
    crate::board::refresh_irq_lines(hw);
    let prio = execution_priority(uc);
    if let Some(n) = uc.get_data().nvic.deliverable(prio) {
        // Tail-chain: the frame stays, LR keeps this EXC_RETURN.
        set(uc, RegisterARM::LR, exc_return)?;
        uc.get_data_mut().charge_exception(ExceptionStep::TailChain);
        uc.get_data_mut().on_exception_entry(n);
        return jump_to_handler(uc, n);
    }
    uc.get_data_mut().charge_exception(ExceptionStep::Return);
    let sp = reg(uc, RegisterARM::SP);
    let mut f = [0u32; 8];
    for (i, w) in f.iter_mut().enumerate() {
        *w = read_word(uc, sp + 4 * i as u32)?;
    }
    let [r0, r1, r2, r3, r12, lr, pc, xpsr] = f;
    for (r, v) in [
        (RegisterARM::R0, r0),
        (RegisterARM::R1, r1),
        (RegisterARM::R2, r2),
        (RegisterARM::R3, r3),
        (RegisterARM::R12, r12),
        (RegisterARM::LR, lr),
    ] {
        set(uc, r, v)?;
    }
    let realigned = xpsr & (1 << 9) != 0;
    set(
        uc,
        RegisterARM::SP,
        sp + 0x20 + if realigned { 4 } else { 0 },
    )?;
    set(uc, RegisterARM::XPSR, xpsr & !(1 << 9))?;
    set(uc, RegisterARM::PC, pc | 1)
}

/// Takes every exception that may run now (a later, higher-priority one
/// pre-empts the entry of an earlier one, as a late arrival does).
pub fn deliver(uc: &mut Unicorn<'_, Hw>) -> Result<(), BoardError> {
    for i in 0..crate::scs::EXCEPTIONS {
        crate::board::refresh_irq_lines(uc.get_data_mut());
        let prio = execution_priority(uc);
        let Some(n) = uc.get_data().nvic.deliverable(prio) else {
            return Ok(());
        };
        enter(uc, n)?;
        uc.get_data_mut().on_exception_entry(n);
        uc.get_data_mut().charge_exception(if i == 0 {
            ExceptionStep::Entry
        } else {
            ExceptionStep::LateArrival
        });
    }
    Ok(())
}

/// A fault (UDF, BKPT without a debugger, ...) escalated to HardFault; a
/// fault while HardFault is active locks the core up (ARMv7-M B1.5.15).
pub fn fault(uc: &mut Unicorn<'_, Hw>, pc: u32, hfsr: u32) -> Result<bool, BoardError> {
    if uc.get_data().nvic.active.contains(&HARDFAULT) {
        return Ok(false);
    }
    uc.get_data_mut().nvic.hfsr |= hfsr;
    enter_from(uc, HARDFAULT, pc)?;
    uc.get_data_mut().charge_exception(ExceptionStep::Entry);
    Ok(true)
}
