//! The Cortex-M3 cycle model: what each instruction, exception and
//! peripheral access costs in 72 MHz core cycles.
//!
//! Sources. Per-instruction costs are the Cortex-M3 Technical Reference
//! Manual's (ARM DDI 0337H/I, r2p0/r2p1, table 3.1 "Cortex-M3 instruction
//! set summary", and §3.3.2 "Load/store timings"); exception costs are the
//! TRM's §5.5 figures with ARM's knowledge article 103489845 ("the
//! Cortex-M3 has a latency on exit of ten cycles": the TRM's 12 is a
//! typographical error). The TRM's figures assume zero wait states.
//!
//! Rules, for the [`CycleModel::Typical`] model:
//! - data processing, MUL, shifts, bit fields, extends, saturation,
//!   hints: 1; MLA/MLS 2; SMULL/UMULL 4 and SMLAL/UMLAL 6 (the middle of
//!   the TRM's 3–5 and 4–7: early termination on the operands' size);
//!   SDIV/UDIV 7 (middle of 2–12);
//! - LDR (any size, literal, LDREX/STREX) 2; STR with an immediate offset
//!   1 (§3.3.2: "always one cycle", the write buffer), with a register
//!   offset 2; a load or store right after a load costs one cycle less
//!   when the earlier load's destination is not the later one's base
//!   (§3.3.2: neighbouring loads pipeline). LDRD/STRD 1 + N = 3;
//!   LDM/STM/PUSH/POP 1 + N;
//! - branches (B, `B<cond>`, BL, BX, BLX, CBZ/CBNZ; MOV/ADD/LDR/POP/LDM to
//!   PC) 1 in their block, and the refill when taken at the next block
//!   (see below); TBB/TBH 3 (load 2 + add 1, §3.3.2) plus the refill;
//! - IT 0 when it folds onto a preceding 16-bit instruction of its block,
//!   else 1; MSR, MRS, CPSID/CPSIE 1 (TRM: 1 or 2); DMB/DSB 1 (1 + B,
//!   B ≥ 0); ISB 3 (1 + B, B ≥ a refill).
//!
//! Taken branches. Unicorn's block hook cannot see whether the branch that
//! ends a block was taken; the next block can: a block that does not start
//! at the previous block's fall-through address was reached by a taken
//! branch (or a load to PC), and it pays the refill, P = 2 cycles (the
//! TRM r1p1's table 18.1: "if branch taken, pipeline reloads (two cycles
//! are added)"; r2p1 gives the range 1–3), plus the flash wait states.
//!
//! Flash wait states (an assumption: no ARM or ST document gives a cycle
//! figure). At 72 MHz FLASH_ACR.LATENCY is 2 (RM0008 §3.3.3). Sequential
//! fetches are hidden by the prefetch buffer (two 64-bit lines, one
//! 64-bit flash read feeding four 16-bit fetches while the next line is
//! read). A taken branch to a line not in the buffer waits LATENCY cycles
//! more: the model charges them unless the target is in the branch's own
//! 64-bit line or the next (a short loop runs from the buffer). LATENCY is
//! read from the flash model, so 0 wait states below 24 MHz cost nothing.
//!
//! Exceptions: entry 12 cycles, tail-chaining 6, return 10, each plus the
//! wait states of the fetch at the new address; an exception taken in the
//! same delivery as a higher-priority one that arrived later (late
//! arrival) shares its stacking and costs nothing more.
//!
//! APB access (an assumption: RM0008 gives no figure). An APB transfer
//! takes two PCLK cycles (setup and access phases, AMBA APB), so an access
//! through the AHB-APB bridge costs 2 × (HCLK/PCLK) − 1 cycles more than a
//! zero-wait AHB access: +1 on APB2 at 72 MHz (GPIO, AFIO, EXTI, USART1),
//! +3 on APB1 at 36 MHz (I2C1, TIM3, TIM4, IWDG). Reads and writes alike.
//!
//! [`CycleModel::Pessimistic`] is the corner the flight scenarios must also
//! pass: every data-dependent cost at the top of its range (SMULL/UMULL 5,
//! SMLAL/UMLAL 7, SDIV/UDIV 12, MSR/MRS/CPS 2), no load pipelining, STR
//! always 2, a literal load +1 (fetch contention, §3.3.2), a load or store
//! after a data-processing instruction +1 (address dependency, §3.3.2),
//! every refill P = 3 plus the wait states even inside the prefetch
//! buffer, an exception entry paying the wait states twice (vector read
//! and handler fetch), a return 12 (the TRM's figure), and one more PCLK
//! cycle of bridge resynchronisation per APB access.

/// Which end of the manuals' ranges the model takes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CycleModel {
    /// Mid-range costs, the TRM's pipelining, the prefetch buffer's hits.
    #[default]
    Typical,
    /// Every cost at the top of its range (see the module documentation).
    Pessimistic,
}

/// Timing class of one Thumb-2 instruction (rows of the TRM's table 3.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Class {
    /// Data processing, shifts, bit fields, extends, saturation, MUL.
    Alu,
    /// MLA, MLS.
    MulAcc,
    /// SMULL, UMULL.
    LongMul,
    /// SMLAL, UMLAL.
    LongMulAcc,
    /// SDIV, UDIV.
    Div,
    /// A single load (also LDREX and STREX, which pipeline as loads).
    Load {
        /// Destination register.
        rt: u8,
        /// Base register (15: a literal load).
        rn: u8,
    },
    /// A single store.
    Store {
        /// Base register.
        rn: u8,
        /// Register offset (the TRM's 2 cycles) rather than immediate (1).
        reg_offset: bool,
    },
    /// LDRD, STRD.
    Dual,
    /// LDM, STM, PUSH, POP with `n` registers.
    Multiple {
        /// Registers in the list, PC and LR included.
        n: u8,
    },
    /// B, `B<cond>`, BL, BX, BLX, CBZ, CBNZ, SVC, UDF, and data processing
    /// that writes PC.
    Branch,
    /// TBB, TBH.
    TableBranch,
    /// IT.
    It,
    /// MSR, MRS, CPSID, CPSIE.
    System,
    /// DMB, DSB, CLREX.
    Barrier,
    /// ISB.
    Isb,
    /// NOP, YIELD, WFE, WFI, SEV, BKPT.
    Hint,
}

/// The first halfword of a 32-bit Thumb-2 instruction (0b11101, 0b11110,
/// 0b11111 in bits 15:11).
pub fn is_wide(hw1: u16) -> bool {
    matches!(hw1 >> 11, 0b11101..=0b11111)
}

/// Class of the 16-bit instruction `hw`.
pub fn classify16(hw: u16) -> Class {
    let lo3 = |s: u16| ((hw >> s) & 7) as u8;
    match hw >> 12 {
        0x4 if hw & 0xF800 == 0x4800 => Class::Load { rt: lo3(8), rn: 15 },
        0x4 if hw & 0xFF00 == 0x4700 => Class::Branch,
        // ADD/MOV with a high register: Rd = PC is a branch.
        0x4 if hw & 0xFC00 == 0x4400 && hw & 0x87 == 0x87 && hw & 0x0300 != 0x0100 => Class::Branch,
        0x5 if (hw >> 9) & 7 < 3 => Class::Store {
            rn: lo3(3),
            reg_offset: true,
        },
        0x5 => Class::Load {
            rt: lo3(0),
            rn: lo3(3),
        },
        0x6..=0x8 if hw & 0x0800 != 0 => Class::Load {
            rt: lo3(0),
            rn: lo3(3),
        },
        0x6..=0x8 => Class::Store {
            rn: lo3(3),
            reg_offset: false,
        },
        0x9 if hw & 0x0800 != 0 => Class::Load { rt: lo3(8), rn: 13 },
        0x9 => Class::Store {
            rn: 13,
            reg_offset: false,
        },
        0xB => classify16_misc(hw),
        0xC => Class::Multiple {
            n: (hw & 0xFF).count_ones() as u8,
        },
        0xD | 0xE => Class::Branch,
        _ => Class::Alu,
    }
}

/// The 16-bit miscellaneous group (0xBxxx).
fn classify16_misc(hw: u16) -> Class {
    let list = (hw & 0x1FF).count_ones() as u8;
    match hw >> 8 {
        _ if hw & 0xF500 == 0xB100 => Class::Branch,
        0xB4 | 0xB5 | 0xBC | 0xBD => Class::Multiple { n: list },
        0xB6 if hw & 0xFFE8 == 0xB660 => Class::System,
        0xBE => Class::Hint,
        0xBF if hw & 0xF != 0 => Class::It,
        0xBF => Class::Hint,
        _ => Class::Alu,
    }
}

/// Class of the 32-bit instruction `hw1`, `hw2`.
pub fn classify32(hw1: u16, hw2: u16) -> Class {
    match hw1 >> 8 {
        0xE8 | 0xE9 if hw1 & 0x0040 == 0 => Class::Multiple {
            n: hw2.count_ones() as u8,
        },
        0xE8 | 0xE9 => classify32_dual(hw1, hw2),
        0xF0..=0xF7 if hw2 & 0x8000 != 0 => classify32_control(hw1, hw2),
        0xF8 | 0xF9 => classify32_single(hw1, hw2),
        0xFB => classify32_multiply(hw1, hw2),
        _ => Class::Alu,
    }
}

/// LDRD/STRD, the exclusives and the table branches.
fn classify32_dual(hw1: u16, hw2: u16) -> Class {
    if hw1 & 0x0120 != 0 {
        return Class::Dual;
    }
    if hw1 & 0xFFF0 == 0xE8D0 && hw2 & 0xFFE0 == 0xF000 {
        return Class::TableBranch;
    }
    Class::Load {
        rt: (hw2 >> 12) as u8,
        rn: (hw1 & 0xF) as u8,
    }
}

/// Branches and miscellaneous control (hw2 bit 15 set).
fn classify32_control(hw1: u16, hw2: u16) -> Class {
    if hw2 & 0x5000 != 0 || (hw1 >> 7) & 7 != 7 {
        return Class::Branch;
    }
    match hw1 & 0xFFF0 {
        0xF380 | 0xF390 | 0xF3E0 | 0xF3F0 => Class::System,
        0xF3A0 => Class::Hint,
        0xF3B0 if hw2 & 0xF0 == 0x60 => Class::Isb,
        0xF3B0 => Class::Barrier,
        _ => Class::Branch,
    }
}

/// Single loads and stores (0xF8xx, 0xF9xx).
fn classify32_single(hw1: u16, hw2: u16) -> Class {
    let rn = (hw1 & 0xF) as u8;
    if hw1 & 0x0010 != 0 {
        return Class::Load {
            rt: (hw2 >> 12) as u8,
            rn,
        };
    }
    Class::Store {
        rn,
        reg_offset: hw1 & 0x0080 == 0 && hw2 & 0x0FC0 == 0,
    }
}

/// Multiplies and divides (0xFBxx).
fn classify32_multiply(hw1: u16, hw2: u16) -> Class {
    let op1 = (hw1 >> 4) & 7;
    let op2 = (hw2 >> 4) & 0xF;
    if hw1 & 0x0080 == 0 {
        return match (op1, op2) {
            (0, 0) if hw2 >> 12 == 0xF => Class::Alu,
            (0, 0 | 1) => Class::MulAcc,
            _ => Class::Alu,
        };
    }
    match op1 {
        0 | 2 => Class::LongMul,
        1 | 3 => Class::Div,
        4 | 6 => Class::LongMulAcc,
        _ => Class::Alu,
    }
}

/// Decodes a block's code into (class, 16-bit?) per instruction.
pub fn decode_block(code: &[u8]) -> Vec<(Class, bool)> {
    let hws: Vec<u16> = code
        .chunks_exact(2)
        .map(|c| u16::from_le_bytes([c[0], c[1]]))
        .collect();
    let mut out = Vec::with_capacity(hws.len());
    let mut i = 0;
    while i < hws.len() {
        if is_wide(hws[i]) {
            let hw2 = hws.get(i + 1).copied().unwrap_or(0);
            out.push((classify32(hws[i], hw2), false));
            i += 2;
        } else {
            out.push((classify16(hws[i]), true));
            i += 1;
        }
    }
    out
}

/// Cycles of `class` after `prev` (the instruction before it in the block,
/// `prev_narrow` if that was 16-bit), refills of taken branches excluded.
pub fn instruction_cycles(
    model: CycleModel,
    class: Class,
    prev: Option<Class>,
    prev_narrow: bool,
) -> u32 {
    let top = model == CycleModel::Pessimistic;
    let after_load = match prev {
        Some(Class::Load { rt, .. }) if !top => Some(rt),
        _ => None,
    };
    let pipelined = |rn: u8| after_load.is_some_and(|rt| rt != rn);
    let dependent = top && matches!(prev, Some(Class::Alu));
    let memory = u32::from(dependent);
    match class {
        Class::Alu | Class::Branch | Class::Barrier | Class::Hint => 1,
        Class::MulAcc => 2,
        Class::LongMul => pick(top, 4, 5),
        Class::LongMulAcc => pick(top, 6, 7),
        Class::Div => pick(top, 7, 12),
        Class::Load { rn, .. } => {
            2 - u32::from(pipelined(rn)) + u32::from(top && rn == 15) + memory
        }
        Class::Store { rn, reg_offset } => match (top, reg_offset) {
            (true, _) => 2 + memory,
            (false, false) => 1,
            (false, true) => 2 - u32::from(pipelined(rn)),
        },
        Class::Dual => 3 + memory,
        Class::Multiple { n } => 1 + u32::from(n) + memory,
        Class::TableBranch => 3,
        Class::It => u32::from(top || !prev_narrow || matches!(prev, None | Some(Class::It))),
        Class::System => pick(top, 1, 2),
        Class::Isb => pick(top, 3, 4),
    }
}

fn pick(top: bool, typical: u32, pessimistic: u32) -> u32 {
    if top {
        pessimistic
    } else {
        typical
    }
}

/// Cycles of a block's instructions, taken-branch refills excluded.
pub fn block_cycles(code: &[u8], model: CycleModel) -> u32 {
    let mut prev: Option<Class> = None;
    let mut prev_narrow = false;
    let mut total = 0;
    for (class, narrow) in decode_block(code) {
        total += instruction_cycles(model, class, prev, prev_narrow);
        prev = Some(class);
        prev_narrow = narrow;
    }
    total
}

/// The 64-bit flash line holding `addr`.
fn line(addr: u32) -> u32 {
    addr & !7
}

/// Refill cycles of a taken branch from the block that falls through to
/// `fall_through` into `target`, with `wait_states` on a fetch from
/// `target`'s memory (0 outside flash).
pub fn refill_cycles(model: CycleModel, fall_through: u32, target: u32, wait_states: u32) -> u32 {
    if model == CycleModel::Pessimistic {
        return 3 + wait_states;
    }
    let branch_line = line(fall_through.wrapping_sub(2));
    let buffered = line(target) == branch_line || line(target) == branch_line + 8;
    2 + if buffered { 0 } else { wait_states }
}

/// What the core does at an exception boundary.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExceptionStep {
    /// Stacking, vector read, handler fetch.
    Entry,
    /// An entry during the stacking of a higher-priority one (shared).
    LateArrival,
    /// A return straight into the next pending handler.
    TailChain,
    /// A return that unstacks the frame.
    Return,
}

/// Cycles of `step` with `wait_states` on flash fetches.
pub fn exception_cycles(model: CycleModel, step: ExceptionStep, wait_states: u32) -> u32 {
    let top = model == CycleModel::Pessimistic;
    match step {
        ExceptionStep::Entry => 12 + wait_states * pick(top, 1, 2),
        ExceptionStep::LateArrival => 0,
        ExceptionStep::TailChain => 6 + wait_states * pick(top, 1, 2),
        ExceptionStep::Return => pick(top, 10, 12) + wait_states,
    }
}

/// Extra cycles of one CPU access to a register on an APB bus whose PCLK
/// is HCLK / `divider`.
pub fn apb_access_cycles(model: CycleModel, divider: u32) -> u32 {
    (2 + u32::from(model == CycleModel::Pessimistic)) * divider - 1
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bytes(hws: &[u16]) -> Vec<u8> {
        hws.iter().flat_map(|h| h.to_le_bytes()).collect()
    }

    #[test]
    fn classifies_the_common_encodings() {
        // ldr r0, [r1, #4]
        assert_eq!(classify16(0x6848), Class::Load { rt: 0, rn: 1 });
        // str r0, [r1, r2]
        assert_eq!(
            classify16(0x5088),
            Class::Store {
                rn: 1,
                reg_offset: true
            }
        );
        // push {r4-r7, lr}: N = 5
        assert_eq!(classify16(0xB5F0), Class::Multiple { n: 5 });
        // pop {r4, pc}: N = 2
        assert_eq!(classify16(0xBD10), Class::Multiple { n: 2 });
        // cbz r0, +0; bx lr; mov pc, r1
        assert_eq!(classify16(0xB100), Class::Branch);
        assert_eq!(classify16(0x4770), Class::Branch);
        assert_eq!(classify16(0x468F), Class::Branch);
        // mov r8, r1 (a high register, not PC); cmp r8, pc is not a branch
        assert_eq!(classify16(0x4688), Class::Alu);
        assert_eq!(classify16(0x45F8), Class::Alu);
        // it eq; nop; wfi; cpsid i
        assert_eq!(classify16(0xBF08), Class::It);
        assert_eq!(classify16(0xBF00), Class::Hint);
        assert_eq!(classify16(0xBF30), Class::Hint);
        assert_eq!(classify16(0xB672), Class::System);
        // mul r0, r1, r0 (16-bit MULS)
        assert_eq!(classify16(0x4348), Class::Alu);
    }

    #[test]
    fn classifies_wide_multiplies_divides_and_control() {
        // mul r0, r1, r2 = FB01 F002; mla r0, r1, r2, r3 = FB01 3002
        assert_eq!(classify32(0xFB01, 0xF002), Class::Alu);
        assert_eq!(classify32(0xFB01, 0x3002), Class::MulAcc);
        // mls r0, r1, r2, r3 = FB01 3012
        assert_eq!(classify32(0xFB01, 0x3012), Class::MulAcc);
        // umull r0, r1, r2, r3 = FBA2 0103; smull = FB82 0103
        assert_eq!(classify32(0xFBA2, 0x0103), Class::LongMul);
        assert_eq!(classify32(0xFB82, 0x0103), Class::LongMul);
        // umlal = FBE2 0103; smlal = FBC2 0103
        assert_eq!(classify32(0xFBE2, 0x0103), Class::LongMulAcc);
        assert_eq!(classify32(0xFBC2, 0x0103), Class::LongMulAcc);
        // udiv r0, r1, r2 = FBB1 F0F2; sdiv = FB91 F0F2
        assert_eq!(classify32(0xFBB1, 0xF0F2), Class::Div);
        assert_eq!(classify32(0xFB91, 0xF0F2), Class::Div);
        // bl; b.w; beq.w
        assert_eq!(classify32(0xF000, 0xF800), Class::Branch);
        assert_eq!(classify32(0xF000, 0xB800), Class::Branch);
        assert_eq!(classify32(0xF000, 0x8000), Class::Branch);
        // msr basepri, r0 = F380 8811; mrs r0, primask = F3EF 8010
        assert_eq!(classify32(0xF380, 0x8811), Class::System);
        assert_eq!(classify32(0xF3EF, 0x8010), Class::System);
        // dsb sy = F3BF 8F4F; dmb = F3BF 8F5F; isb = F3BF 8F6F
        assert_eq!(classify32(0xF3BF, 0x8F4F), Class::Barrier);
        assert_eq!(classify32(0xF3BF, 0x8F5F), Class::Barrier);
        assert_eq!(classify32(0xF3BF, 0x8F6F), Class::Isb);
        // tbb [r0, r1] = E8D0 F001; ldrd r0, r1, [r2] = E9D2 0100
        assert_eq!(classify32(0xE8D0, 0xF001), Class::TableBranch);
        assert_eq!(classify32(0xE9D2, 0x0100), Class::Dual);
        // ldrex r0, [r1] = E851 0F00
        assert_eq!(classify32(0xE851, 0x0F00), Class::Load { rt: 0, rn: 1 });
        // ldr.w r0, [r1, #4] = F8D1 0004; str.w r0, [r1, r2] = F841 0002
        assert_eq!(classify32(0xF8D1, 0x0004), Class::Load { rt: 0, rn: 1 });
        assert_eq!(
            classify32(0xF841, 0x0002),
            Class::Store {
                rn: 1,
                reg_offset: true
            }
        );
        // stmdb sp!, {r4-r11, lr} (push.w) = E92D 4FF0: N = 9
        assert_eq!(classify32(0xE92D, 0x4FF0), Class::Multiple { n: 9 });
        // movw r0, #0 = F240 0000 (data processing, plain immediate)
        assert_eq!(classify32(0xF240, 0x0000), Class::Alu);
    }

    #[test]
    fn typical_costs_follow_the_trm_table() {
        let t = CycleModel::Typical;
        // Three neighbouring LDRs: 2 + 1 + 1 (TRM §3.3.2's example: four).
        let ldr3 = bytes(&[0x6808, 0x6851, 0x689A]);
        assert_eq!(block_cycles(&ldr3, t), 4);
        // ldr r1, [r0]; ldr r2, [r1]: the base is the load's result, 2 + 2.
        assert_eq!(block_cycles(&bytes(&[0x6801, 0x680A]), t), 4);
        // ldr r0, [r1]; str r0, [r2, #0]: 2 + 1.
        assert_eq!(block_cycles(&bytes(&[0x6808, 0x6010]), t), 3);
        // push {r4-r7, lr}: 1 + 5.
        assert_eq!(block_cycles(&bytes(&[0xB5F0]), t), 6);
        // adds r0, #1; it eq; moveq r0, r1: the IT folds, 1 + 0 + 1.
        assert_eq!(block_cycles(&bytes(&[0x3001, 0xBF08, 0x4608]), t), 2);
        // umull 4, umlal 6, udiv 7, mla 2.
        assert_eq!(block_cycles(&bytes(&[0xFBA2, 0x0103]), t), 4);
        assert_eq!(block_cycles(&bytes(&[0xFBE2, 0x0103]), t), 6);
        assert_eq!(block_cycles(&bytes(&[0xFBB1, 0xF0F2]), t), 7);
        assert_eq!(block_cycles(&bytes(&[0xFB01, 0x3002]), t), 2);
    }

    #[test]
    fn pessimistic_costs_are_the_tops_of_the_ranges() {
        let p = CycleModel::Pessimistic;
        assert_eq!(block_cycles(&bytes(&[0x6808, 0x6851, 0x689A]), p), 6);
        assert_eq!(block_cycles(&bytes(&[0xFBA2, 0x0103]), p), 5);
        assert_eq!(block_cycles(&bytes(&[0xFBE2, 0x0103]), p), 7);
        assert_eq!(block_cycles(&bytes(&[0xFBB1, 0xF0F2]), p), 12);
        // adds r0, #1; ldr r1, [r0]: the address waits for the ALU, 1 + 3.
        assert_eq!(block_cycles(&bytes(&[0x3001, 0x6801]), p), 4);
        assert_eq!(refill_cycles(p, 0x0800_0104, 0x0800_0100, 2), 5);
    }

    #[test]
    fn refills_pay_wait_states_outside_the_prefetch_buffer() {
        let t = CycleModel::Typical;
        // A backward branch within its own 64-bit line: P = 2 only.
        assert_eq!(refill_cycles(t, 0x0800_0104, 0x0800_0100, 2), 2);
        // A branch far away: P + 2 wait states.
        assert_eq!(refill_cycles(t, 0x0800_0104, 0x0800_2000, 2), 4);
        // No wait states (below 24 MHz, or SRAM): P.
        assert_eq!(refill_cycles(t, 0x0800_0104, 0x0800_2000, 0), 2);
    }

    #[test]
    fn exceptions_and_apb_accesses() {
        let t = CycleModel::Typical;
        assert_eq!(exception_cycles(t, ExceptionStep::Entry, 0), 12);
        assert_eq!(exception_cycles(t, ExceptionStep::Return, 0), 10);
        assert_eq!(exception_cycles(t, ExceptionStep::TailChain, 0), 6);
        assert_eq!(apb_access_cycles(t, 2), 3);
        assert_eq!(apb_access_cycles(t, 1), 1);
        assert_eq!(apb_access_cycles(CycleModel::Pessimistic, 2), 5);
    }
}
