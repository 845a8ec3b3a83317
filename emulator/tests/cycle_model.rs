//! The cycle model on hand-assembled Thumb-2 sequences, each count worked
//! from the Cortex-M3 TRM (DDI 0337H, table 3.1 and §3.3.2) and the
//! model's stated assumptions (`emulator::cycles`).
//!
//! Each image has its vector table at 0, code at 0x100, literals from
//! 0x1C0 and an optional second piece of code at 0x200. A program ends in
//! `b .`, an idle loop the board sleeps in: the loop's first pass is
//! charged with the block before it (1 cycle, 1 instruction) and the
//! sleep is not CPU work, so `Board::executed` counts exactly the program.
//! Flash wait states are 0 (FLASH_ACR at reset) unless a program sets them.
#![allow(clippy::panic, clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::{field, lines_after, run_until, S};
use emulator::{Board, BoardConfig, CycleModel, Executed, Firmware};

const FLASH: u32 = 0x0800_0000;
/// `b .`
const IDLE: u16 = 0xE7FE;
/// `adds r0, #1`
const ADDS: u16 = 0x3001;
/// `adds r5, #1`
const ADDS_R5: u16 = 0x3501;
const FLASH_ACR: u32 = 0x4002_2000;
/// FLASH_ACR: LATENCY = 2 wait states, prefetch buffer on.
const ACR_2WS: u16 = 0x32;
const ICSR: u32 = 0xE000_ED04;

/// `ldr rt, [pc, #..]` at code index `i` (address 0x100 + 2i) loading
/// literal `k` (at 0x1C0 + 4k).
fn ldr_lit(rt: u16, i: u32, k: u32) -> u16 {
    let pc = (0x100 + 2 * i + 4) & !3;
    let imm8 = (0x1C0 + 4 * k - pc) / 4;
    0x4800 | (rt << 8) | imm8 as u16
}

/// The image: SP at the top of RAM, reset to 0x100, PendSV and SysTick to
/// a handler `adds r4, #1; bx lr` at 0x1A0.
fn image(code: &[u16], literals: &[u32], far: &[u16]) -> Firmware {
    let mut flash = vec![0xFF; 64 * 1024];
    let mut put = |at: usize, w: u32| flash[at..at + 4].copy_from_slice(&w.to_le_bytes());
    put(0, 0x2000_5000);
    put(4, FLASH + 0x101);
    put(14 * 4, FLASH + 0x1A1);
    put(15 * 4, FLASH + 0x1A1);
    for (k, &w) in literals.iter().enumerate() {
        put(0x1C0 + 4 * k, w);
    }
    let mut halfwords = |at: usize, hws: &[u16]| {
        for (i, h) in hws.iter().enumerate() {
            flash[at + 2 * i..at + 2 * i + 2].copy_from_slice(&h.to_le_bytes());
        }
    };
    assert!(code.len() <= 0x50, "code runs into the handler");
    halfwords(0x100, code);
    halfwords(0x1A0, &[0x3401, 0x4770]);
    halfwords(0x200, far);
    Firmware {
        flash,
        rtt_address: 0x2000_0000,
        image_end: FLASH + 0x400,
        table: None,
        symbols: Default::default(),
    }
}

/// Runs the image for 20 µs; what the CPU executed, the trailing `b .`'s
/// one pass taken off.
fn run_image(fw: &Firmware, model: CycleModel) -> Executed {
    let config = BoardConfig {
        cycle_model: model,
        ..BoardConfig::default()
    };
    let mut b = Board::new(fw, config).unwrap_or_else(|e| panic!("{e}"));
    b.run_until_ns(20_000).unwrap_or_else(|e| panic!("{e}"));
    let e = b.executed();
    Executed {
        instructions: e.instructions - 1,
        cycles: e.cycles - 1,
        ..e
    }
}

fn cycles(code: &[u16], literals: &[u32], model: CycleModel) -> u64 {
    let mut c = code.to_vec();
    c.push(IDLE);
    run_image(&image(&c, literals, &[]), model).cycles
}

/// Ten ADDS: one cycle each (data processing, 1).
#[test]
fn ten_adds_take_ten_cycles() {
    let fw = image(&[[ADDS; 10].as_slice(), &[IDLE]].concat(), &[], &[]);
    let e = run_image(&fw, CycleModel::Typical);
    assert_eq!((e.instructions, e.cycles), (10, 10));
}

/// `sub sp, #16` 1; `ldr r0,[sp]; ldr r1,[sp,#4]; ldr r2,[sp,#8]`:
/// 2 + 1 + 1 (TRM §3.3.2: neighbouring loads pipeline, "normally four
/// cycles total" for three); pessimistic: no pipelining, 2 + 2 + 2, and
/// the first load's address waits for `sub sp` (+1).
#[test]
fn neighbouring_loads_pipeline() {
    let code = [0xB084, 0x9800, 0x9901, 0x9A02];
    assert_eq!(cycles(&code, &[], CycleModel::Typical), 1 + 4);
    assert_eq!(cycles(&code, &[], CycleModel::Pessimistic), 1 + 1 + 6);
}

/// `push {r4-r7, lr}` 1 + N = 6; `pop {r4-r7}` after `push {r4-r7}`:
/// 5 + 5.
#[test]
fn push_and_pop_cost_one_plus_n() {
    assert_eq!(cycles(&[0xB5F0], &[], CycleModel::Typical), 6);
    assert_eq!(cycles(&[0xB4F0, 0xBCF0], &[], CycleModel::Typical), 10);
}

/// `muls r0, r1, r0` 1; `mla r0, r1, r2, r3` 2; `umull r0, r1, r2, r3`
/// 3–5 (typical 4, top 5); `udiv r0, r1, r2` 2–12 (typical 7, top 12).
#[test]
fn multiplies_and_divides() {
    let t = CycleModel::Typical;
    let p = CycleModel::Pessimistic;
    assert_eq!(cycles(&[0x4348], &[], t), 1);
    assert_eq!(cycles(&[0xFB01, 0x3002], &[], t), 2);
    assert_eq!(cycles(&[0xFBA2, 0x0103], &[], t), 4);
    assert_eq!(cycles(&[0xFBA2, 0x0103], &[], p), 5);
    assert_eq!(cycles(&[0xFBB1, 0xF0F2], &[], t), 7);
    assert_eq!(cycles(&[0xFBB1, 0xF0F2], &[], p), 12);
}

/// FLASH_ACR = 2 wait states (`ldr r1, =FLASH_ACR` 2, `movs r2, #0x32` 1,
/// `str r2, [r1]` 1), then `b.w` to 0x200 (1) and `adds` there (1): the
/// target is not in the prefetch buffer, so the refill is P = 2 plus
/// 2 wait states. Pessimistic: literal load 3, STR after an ALU
/// instruction 3, refill 3 + 2.
#[test]
fn a_taken_far_branch_pays_the_refill_and_the_wait_states() {
    let code = [ldr_lit(1, 0, 0), 0x2200 | ACR_2WS, 0x600A, 0xF000, 0xB87B];
    let fw = image(&code, &[FLASH_ACR], &[ADDS, IDLE]);
    assert_eq!(run_image(&fw, CycleModel::Typical).cycles, 4 + 1 + 4 + 1);
    assert_eq!(
        run_image(&fw, CycleModel::Pessimistic).cycles,
        3 + 1 + 3 + 1 + 5 + 1
    );
    // The same program at 0 wait states (`movs r2, #0x10`: prefetch only).
    let code0 = [ldr_lit(1, 0, 0), 0x2210, 0x600A, 0xF000, 0xB87B];
    let fw0 = image(&code0, &[FLASH_ACR], &[ADDS, IDLE]);
    assert_eq!(run_image(&fw0, CycleModel::Typical).cycles, 4 + 1 + 2 + 1);
}

/// A conditional branch not taken costs 1 and no refill: `cmp r0, r0`
/// 1, `bne.w` to 0x200 1 (Z set: falls through), `adds r5, #1` 1; taken
/// (`cmp r0, #1` with r0 = 0), the same program pays the refill P = 2 at
/// 0 wait states and runs `adds` at 0x200 instead.
#[test]
fn a_conditional_branch_not_taken_pays_no_refill() {
    // bne.w 0x200 at 0x102: T3, offset 0x200 - 0x106 = 0xFA (imm11 0x7D).
    let bne_w = [0xF040, 0x807D];
    let not_taken = [&[0x4280][..], &bne_w, &[ADDS_R5, IDLE]].concat();
    let fw = image(&not_taken, &[], &[ADDS, IDLE]);
    assert_eq!(run_image(&fw, CycleModel::Typical).cycles, 3);
    let taken = [&[0x2801][..], &bne_w, &[ADDS_R5, IDLE]].concat();
    let fw = image(&taken, &[], &[ADDS, IDLE]);
    assert_eq!(run_image(&fw, CycleModel::Typical).cycles, 1 + 1 + 2 + 1);
}

/// `cortex_m::asm::delay`'s loop, `1: subs r0, #1; bne 1b`, ten passes
/// from `movs r0, #10`, at 2 wait states: the first pass runs in the
/// block after `movs` (1 + 1 + 1), the other nine each cost
/// subs 1 + bne 1 + refill 2, the loop's target being in the prefetch
/// buffer: 4 cycles a pass, as the TRM's 1 + P branch with P = 2 gives.
/// An `adds r5, #1` after the loop keeps the final `b .` in its block.
#[test]
fn the_busy_wait_loop_costs_four_cycles_a_pass() {
    let setup = [ldr_lit(1, 0, 0), 0x2200 | ACR_2WS, 0x600A];
    let code = [setup.as_slice(), &[0x200A, 0x3801, 0xD1FD, ADDS_R5]].concat();
    let c = cycles(&code, &[FLASH_ACR], CycleModel::Typical);
    assert_eq!(c, 4 + 3 + 9 * 4 + 1);
    // Pessimistic: every refill 3 + 2 wait states: 7 a pass.
    let c = cycles(&code, &[FLASH_ACR], CycleModel::Pessimistic);
    assert_eq!(c, 3 + 1 + 3 + 3 + 9 * 7 + 1);
}

/// SysTick (LOAD 100, enabled with its interrupt) fires once: the
/// set-up (`ldr r0, =SYST` 2, `movs` 1, `str` 1, `movs` 1, `str` 1),
/// then entry 12, the handler `adds r4, #1; bx lr` 2, return 10
/// (PM0056/TRM entry 12; ARM's knowledge article: return 10).
#[test]
fn an_exception_round_trip_costs_entry_and_return() {
    let code = [ldr_lit(0, 0, 0), 0x2164, 0x6041, 0x2107, 0x6001, IDLE];
    let fw = image(&code, &[0xE000_E010], &[]);
    let config = BoardConfig::default();
    let mut b = Board::new(&fw, config).unwrap_or_else(|e| panic!("{e}"));
    // The tick comes LOAD + 1 = 101 cycles after the enable; stop before
    // the second (150 cycles of the 8 MHz HSI the core runs on from reset).
    b.run_until_ns(150 * 125).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(b.exception_entries(15), 1);
    let e = b.executed();
    assert_eq!(e.cycles - 1, 6 + 12 + 2 + 10);
    assert_eq!(e.instructions - 1, 5 + 2);
}

/// PendSV and SysTick pended at once by one ICSR write (`ldr` 2, `ldr`
/// pipelined 1, `str` 1): PendSV (14) runs first, SysTick tail-chains.
/// Entry 12, handler 2, tail-chain 6, handler 2, return 10.
#[test]
fn a_tail_chain_costs_six() {
    let code = [ldr_lit(0, 0, 0), ldr_lit(1, 1, 1), 0x6001, IDLE];
    let fw = image(&code, &[ICSR, (1 << 28) | (1 << 26)], &[]);
    let e = run_image(&fw, CycleModel::Typical);
    assert_eq!(e.cycles, 4 + 12 + 2 + 6 + 2 + 10);
    assert_eq!(e.instructions, 3 + 2 + 2);
}

/// DWT CYCCNT follows the model. Block 1 enables the counter and reads
/// it into r3 (cycles are charged as a block starts, so a read sees its
/// whole block); `b` to block 2, which reads it again into r4 and stores
/// r4 - r3 below SP: block 2's refill P = 2 plus its cost, `adds r5` ×4 4,
/// `ldr` 2, `subs` 1, `sub sp` 1, `str` 1, `b .` 1.
#[test]
fn dwt_cyccnt_counts_the_model_cycles() {
    let code = [
        ldr_lit(0, 0, 0), // r0 = DEMCR
        ldr_lit(1, 1, 1), // r1 = 1 << 24 (TRCENA)
        0x6001,           // str r1, [r0]
        ldr_lit(0, 3, 2), // r0 = DWT_CTRL
        0x2101,           // movs r1, #1
        0x6001,           // str r1, [r0] (CYCCNTENA)
        0x6843,           // ldr r3, [r0, #4]
        0xE000,           // b +0 → 0x112 (skips one halfword)
        0xBF00,           // nop (skipped)
        ADDS_R5,
        ADDS_R5,
        ADDS_R5,
        ADDS_R5,
        0x6844, // ldr r4, [r0, #4]
        0x1AE4, // subs r4, r4, r3
        0xB084, // sub sp, #16
        0x9400, // str r4, [sp]
        IDLE,
    ];
    let fw = image(&code, &[0xE000_EDFC, 1 << 24, 0xE000_1000], &[]);
    let mut b = Board::new(&fw, BoardConfig::default()).unwrap_or_else(|e| panic!("{e}"));
    b.run_until_ns(20_000).unwrap_or_else(|e| panic!("{e}"));
    let delta = b.read_word(0x2000_5000 - 16).expect("RAM");
    assert_eq!(delta, 2 + 4 + 2 + 1 + 1 + 1 + 1);
}

/// An APB1 register read (TIM3_CNT) with PCLK1 = HCLK / 2 costs the load's
/// 2 and 2 × 2 − 1 = 3 bridge cycles; the RCC (AHB) accesses that set it
/// up cost none.
#[test]
fn an_apb1_read_pays_the_bridge() {
    // r0 = RCC; r1 = 0x400 (PPRE1 = /2) → CFGR; r1 = 2 (TIM3EN) → APB1ENR;
    // r2 = TIM3.
    let setup = [
        ldr_lit(0, 0, 0),
        0x2101,
        0x0289, // lsls r1, r1, #10
        0x6041, // str r1, [r0, #4] (CFGR)
        0x2102,
        0x61C1, // str r1, [r0, #28] (APB1ENR)
        ldr_lit(2, 6, 1),
    ];
    let lits = [0x4002_1000, 0x4000_0400];
    let base = cycles(&setup, &lits, CycleModel::Typical);
    let read = [setup.as_slice(), &[0x6A53]].concat(); // ldr r3, [r2, #36] (CNT)
    assert_eq!(cycles(&read, &lits, CycleModel::Typical) - base, 2 + 3);
    assert_eq!(
        cycles(&read, &lits, CycleModel::Pessimistic)
            - cycles(&setup, &lits, CycleModel::Pessimistic),
        2 + 5
    );
}

/// The firmware's per-sample work over seconds 2–4 of a hover under
/// `model`: the last `loop:` line's mean and worst cycles, its CPU
/// share in 0.1 %, and the CPI of everything the CPU executed meanwhile.
fn sample_work(model: CycleModel) -> Option<(u64, u64, u64, f64)> {
    let mut b = common::board_with(|c| {
        c.cycle_model = model;
        c.sim.trajectory = sim::Trajectory::Hover;
    })?;
    run_until(&mut b, 2 * S);
    let e0 = b.executed();
    run_until(&mut b, 4 * S + S / 10);
    let e1 = b.executed();
    let line = lines_after(&b, 3 * S, "loop:").pop().expect("a loop: line");
    let cpu = line
        .split("cpu ")
        .nth(1)
        .expect("cpu")
        .trim_end_matches('%');
    let (whole, tenth) = cpu.split_once('.').expect("cpu share");
    let permille = whole.parse::<u64>().unwrap() * 10 + tenth.parse::<u64>().unwrap();
    let insns = (e1.instructions - e0.instructions) as f64;
    let cpi = (e1.cycles - e0.cycles) as f64 / insns;
    let per = |a: u64, b: u64| (a - b) as f64 / insns;
    println!(
        "{model:?}: {line} (CPI {cpi:.3}: refills {:.3}, exceptions {:.3}, APB {:.3})",
        per(e1.refill_cycles, e0.refill_cycles),
        per(e1.exception_cycles, e0.exception_cycles),
        per(e1.bus_cycles, e0.bus_cycles),
    );
    Some((field(&line, "mean"), field(&line, "worst"), permille, cpi))
}

/// The firmware keeps its 1 kHz sample at both corners: the sample's
/// worst case fits its 1 ms period (72,000 cycles) with the CPU share
/// under half, and the pessimistic corner costs more than the typical
/// model, which costs more than one cycle per instruction.
#[test]
fn the_firmware_keeps_its_sample_rate_at_both_corners() {
    let Some(typical) = sample_work(CycleModel::Typical) else {
        return;
    };
    let pessimistic = sample_work(CycleModel::Pessimistic).expect("ELF");
    for (mean, worst, permille, cpi) in [typical, pessimistic] {
        assert!(worst < 72_000, "worst {worst} cycles");
        assert!(mean > 0 && permille < 500, "mean {mean}, cpu {permille} ‰");
        assert!(cpi > 1.0, "CPI {cpi}");
    }
    assert!(pessimistic.0 > typical.0, "{pessimistic:?} vs {typical:?}");
    assert!(pessimistic.3 > typical.3, "{pessimistic:?} vs {typical:?}");
}
