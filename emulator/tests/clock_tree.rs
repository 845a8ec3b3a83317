//! The board's clock tree follows what RCC is programmed to (RM0008 §7.2,
//! figure 8): the core, SysTick and DWT on HCLK, TIM3 on the APB1 timer
//! clock (PCLK1 ×2 when the APB1 prescaler is not 1), USART1 on PCLK2,
//! I2C1 on PCLK1. The registers are written as a debug probe writes them
//! (`Board::debug_write`) on an image that only idles, so each tree is
//! exactly the one set here: the HSI at reset (8 MHz), the crystal's PLL
//! (8 MHz × 9 = 72 MHz) and the HSI fallback (HSI/2 × 16 = 64 MHz), both
//! with APB1 = HCLK / 2. A firmware that keeps the 72 MHz register values
//! on the 64 MHz tree shows it on the pins and the lines.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use emulator::{Board, BoardConfig, BoardError, Firmware};

const FLASH: u32 = 0x0800_0000;
const RCC_CR: u32 = 0x4002_1000;
const RCC_CFGR: u32 = 0x4002_1004;
const RCC_APB2ENR: u32 = 0x4002_1018;
const RCC_APB1ENR: u32 = 0x4002_101C;
const FLASH_ACR: u32 = 0x4002_2000;
const DWT_CTRL: u32 = 0xE000_1000;
const DWT_CYCCNT: u32 = 0xE000_1004;
const DEMCR: u32 = 0xE000_EDFC;
const SYST_CSR: u32 = 0xE000_E010;
const SYST_RVR: u32 = 0xE000_E014;
const GPIOA_CRL: u32 = 0x4001_0800;
const GPIOB_CRL: u32 = 0x4001_0C00;
const TIM3: u32 = 0x4000_0400;
const USART1: u32 = 0x4001_3800;
const I2C1: u32 = 0x4000_5400;
const MS: u64 = 1_000_000;
/// CFGR.PPRE1 = HCLK / 2 (0b100) and / 4 (0b101).
const PPRE1_DIV2: u32 = 4 << 8;
const PPRE1_DIV4: u32 = 5 << 8;

/// The clock trees under test.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Tree {
    /// Reset: SYSCLK = HSI = 8 MHz, every prescaler 1.
    Hsi8,
    /// HSE 8 MHz × 9 = 72 MHz, APB1 36 MHz (the firmware's normal tree).
    Hse72,
    /// HSI / 2 × 16 = 64 MHz, APB1 32 MHz (the firmware's fallback).
    Hsi64,
}

impl Tree {
    fn hclk_hz(self) -> u64 {
        match self {
            Tree::Hsi8 => 8_000_000,
            Tree::Hse72 => 72_000_000,
            Tree::Hsi64 => 64_000_000,
        }
    }
}

/// An image that idles (`b .`) with a SysTick handler `adds r4, #1; bx lr`.
fn idle_image() -> Firmware {
    let mut flash = vec![0xFF; 64 * 1024];
    let mut put = |at: usize, w: u32| flash[at..at + 4].copy_from_slice(&w.to_le_bytes());
    put(0, 0x2000_5000);
    put(4, FLASH + 0x101);
    put(15 * 4, FLASH + 0x1A1);
    flash[0x100..0x102].copy_from_slice(&0xE7FE_u16.to_le_bytes());
    flash[0x1A0..0x1A4].copy_from_slice(&[0x01, 0x34, 0x70, 0x47]);
    Firmware {
        flash,
        rtt_address: 0x2000_0000,
        image_end: FLASH + 0x400,
        table: None,
        symbols: Default::default(),
    }
}

fn wr(b: &mut Board, addr: u32, v: u32) {
    b.debug_write(addr, v)
        .unwrap_or_else(|e| panic!("{addr:#x} = {v:#x}: {e}"));
}

fn rd(b: &mut Board, addr: u32) -> u32 {
    b.debug_read(addr)
        .unwrap_or_else(|e| panic!("{addr:#x}: {e}"))
}

fn run_for(b: &mut Board, ns: u64) {
    let t = b.now_ns() + ns;
    b.run_until_ns(t).unwrap_or_else(|e| panic!("{e}"));
}

/// A board on `tree`, set up as the manual's sequence does it (RM0008
/// §7.3.1–7.3.2: oscillator on, PLL configured and locked, flash wait
/// states for the new SYSCLK first (§3.3.3), then the switch).
fn board(tree: Tree) -> Board {
    let mut b = Board::new(&idle_image(), BoardConfig::default()).expect("board");
    let cfgr = match tree {
        Tree::Hsi8 => return b,
        // PLLMUL ×9 (field 7), PLLSRC = HSE.
        Tree::Hse72 => (7 << 18) | (1 << 16) | PPRE1_DIV2,
        // PLLMUL ×16 (field 14), PLLSRC = HSI / 2.
        Tree::Hsi64 => (14 << 18) | PPRE1_DIV2,
    };
    if tree == Tree::Hse72 {
        let cr = rd(&mut b, RCC_CR);
        wr(&mut b, RCC_CR, cr | (1 << 16));
        run_for(&mut b, 3 * MS);
    }
    wr(&mut b, RCC_CFGR, cfgr);
    let cr = rd(&mut b, RCC_CR);
    wr(&mut b, RCC_CR, cr | (1 << 24));
    run_for(&mut b, MS);
    assert_ne!(rd(&mut b, RCC_CR) & (1 << 25), 0, "PLL locked");
    wr(&mut b, FLASH_ACR, 0x32);
    wr(&mut b, RCC_CFGR, cfgr | 2);
    assert_eq!((rd(&mut b, RCC_CFGR) >> 2) & 3, 2, "SYSCLK from the PLL");
    b
}

const TREES: [Tree; 3] = [Tree::Hsi8, Tree::Hse72, Tree::Hsi64];

/// DWT CYCCNT counts HCLK cycles (ARMv7-M ARM C1.8.8): a millisecond is
/// 8 000, 72 000 or 64 000 of them.
#[test]
fn the_cycle_counter_counts_hclk() {
    for tree in TREES {
        let mut b = board(tree);
        wr(&mut b, DEMCR, 1 << 24);
        wr(&mut b, DWT_CTRL, 1);
        let c0 = rd(&mut b, DWT_CYCCNT);
        run_for(&mut b, MS);
        let n = u64::from(rd(&mut b, DWT_CYCCNT).wrapping_sub(c0));
        let want = tree.hclk_hz() / 1_000;
        assert!(n.abs_diff(want) <= 1, "{tree:?}: {n} cycles in 1 ms");
    }
}

/// SysTick counts HCLK (CLKSOURCE = 1) or HCLK / 8 (CLKSOURCE = 0, the
/// STM32F1's external reference, RM0008 §7.2): the same reload gives
/// 72/64 times the ticks on the crystal's tree as on the fallback.
#[test]
fn systick_counts_hclk_or_hclk_over_8() {
    for tree in TREES {
        for (clksource, div) in [(1 << 2, 1), (0, 8)] {
            let mut b = board(tree);
            // 1 ms at 64 MHz.
            wr(&mut b, SYST_RVR, 64_000 / div - 1);
            wr(&mut b, SYST_CSR, clksource | 3);
            let n0 = b.exception_entries(15);
            run_for(&mut b, 9 * MS + MS / 2);
            let ticks = b.exception_entries(15) - n0;
            let want = 95 * tree.hclk_hz() / 640_000_000;
            assert_eq!(ticks, want, "{tree:?}, divider {div}");
        }
    }
}

/// TIM3 on `tree` with channel 1 in PWM mode 1 on PA6: PSC 71, ARR 2499,
/// CCR1 1000 (the firmware's 400 Hz ESC set-up at 72 MHz); the pin's
/// (period, high) in ns.
fn tim3_waveform(b: &mut Board) -> (u64, u64) {
    let apb1 = rd(b, RCC_APB1ENR);
    wr(b, RCC_APB1ENR, apb1 | (1 << 1));
    let apb2 = rd(b, RCC_APB2ENR);
    wr(b, RCC_APB2ENR, apb2 | (1 << 2));
    // PA6: alternate function push-pull, 2 MHz (0b1010).
    wr(b, GPIOA_CRL, 0x4A44_4444);
    for (off, v) in [
        (0x28, 71),                // PSC
        (0x2C, 2499),              // ARR
        (0x18, (6 << 4) | 1 << 3), // CCMR1: OC1M = PWM 1, OC1PE
        (0x34, 1000),              // CCR1
        (0x20, 1),                 // CCER: CC1E
        (0x14, 1),                 // EGR: UG
        (0x00, (1 << 7) | 1),      // CR1: ARPE, CEN
    ] {
        wr(b, TIM3 + off, v);
    }
    run_for(b, 30 * MS);
    b.esc_pwm_ns(0).expect("pulses on PA6")
}

/// RM0008 §7.2: the APB1 timers run at PCLK1 ×2 when the APB1 prescaler
/// is not 1, at PCLK1 when it is. The 72 MHz register values give a
/// 1000 µs pulse every 2.5 ms on the crystal's tree and 72/64 of that on
/// the fallback's: a firmware that kept them would command 12.5 % more
/// throttle than it meant.
#[test]
fn tim3_pulses_follow_the_apb1_timer_clock() {
    assert_eq!(
        tim3_waveform(&mut board(Tree::Hse72)),
        (2_500_000, 1_000_000)
    );
    assert_eq!(
        tim3_waveform(&mut board(Tree::Hsi64)),
        (2_812_500, 1_125_000)
    );
    // Reset tree: PCLK1 = HCLK = 8 MHz, prescaler 1, no doubling.
    assert_eq!(
        tim3_waveform(&mut board(Tree::Hsi8)),
        (22_500_000, 9_000_000)
    );
    // APB1 ÷ 4 on the fallback: PCLK1 16 MHz, the timers at 32 MHz.
    let mut b = board(Tree::Hsi64);
    let cfgr = rd(&mut b, RCC_CFGR);
    wr(&mut b, RCC_CFGR, (cfgr & !(7 << 8)) | PPRE1_DIV4);
    assert_eq!(tim3_waveform(&mut b), (5_625_000, 2_250_000));
}

/// Sends a CRSF-like burst at 420 kbaud into USART1 set to `brr` and
/// returns what the receiver read and how many bytes had FE.
fn usart1_receives(b: &mut Board, brr: u32) -> (Vec<u8>, usize) {
    let apb2 = rd(b, RCC_APB2ENR);
    wr(b, RCC_APB2ENR, apb2 | (1 << 14) | (1 << 2));
    wr(b, USART1 + 0x08, brr);
    wr(b, USART1 + 0x0C, (1 << 13) | (1 << 2)); // UE, RE
    let sent = crsf_burst();
    let t0 = b.now_ns() + 10_000;
    b.usart1_send_at(&sent, 420_000, t0);
    let (mut got, mut fe) = (Vec::new(), 0);
    while b.now_ns() < t0 + 26 * 23_810 + 100_000 {
        run_for(b, 5_000);
        let sr = rd(b, USART1);
        if sr & (1 << 5) != 0 {
            fe += usize::from(sr & 2 != 0);
            got.push(rd(b, USART1 + 0x04) as u8);
        }
    }
    (got, fe)
}

fn crsf_burst() -> Vec<u8> {
    (0..26u8).map(|i| 0xC8 ^ i.wrapping_mul(37)).collect()
}

/// USART1 runs on PCLK2 (RM0008 §27.3.4: baud = f_PCLK / (16 · USARTDIV)).
/// BRR 0xAB is 421 kbaud at 72 MHz, every byte right; at 64 MHz it is
/// 374 kbaud, 11 % slow, beyond the 3.75 % tolerance (§27.3.5): wrong
/// bytes and framing errors. BRR 0x98, computed for 64 MHz, is right again.
#[test]
fn a_brr_for_72_mhz_receives_garbage_at_64_mhz() {
    let (got, fe) = usart1_receives(&mut board(Tree::Hse72), 0xAB);
    assert_eq!((got, fe), (crsf_burst(), 0));
    let (got, fe) = usart1_receives(&mut board(Tree::Hsi64), 0xAB);
    println!(
        "BRR 0xAB at 64 MHz: {} bytes, {fe} with FE: {got:02x?}",
        got.len()
    );
    assert_ne!(got, crsf_burst());
    assert!(fe > 0);
    let (got, fe) = usart1_receives(&mut board(Tree::Hsi64), 0x98);
    assert_eq!((got, fe), (crsf_burst(), 0));
}

/// I2C1 starts a START on `tree` with FREQ = 36 and CCR = 0x801E (the
/// 400 kHz set-up for a 36 MHz PCLK1); whether SB is set `after_ns` later.
fn i2c1_sb_after(tree: Tree, after_ns: u64) -> bool {
    let mut b = board(tree);
    let apb1 = rd(&mut b, RCC_APB1ENR);
    wr(&mut b, RCC_APB1ENR, apb1 | (1 << 21));
    let apb2 = rd(&mut b, RCC_APB2ENR);
    wr(&mut b, RCC_APB2ENR, apb2 | (1 << 3));
    // PB6, PB7: alternate function open drain, 2 MHz (0b1110).
    wr(&mut b, GPIOB_CRL, 0xEE44_4444);
    for (off, v) in [(0x04, 36), (0x1C, 0x801E), (0x20, 11), (0x00, 1)] {
        wr(&mut b, I2C1 + off, v);
    }
    wr(&mut b, I2C1, 1 | (1 << 8)); // PE, START
    run_for(&mut b, after_ns);
    rd(&mut b, I2C1 + 0x14) & 1 != 0
}

/// I2C1's SCL comes from PCLK1 (RM0008 §26.6.8: T_high + T_low = 3 · CCR
/// · T_PCLK1 in fast mode, duty 2:1): CCR 30 is 2.5 µs (400 kHz) at
/// 36 MHz and 2.8125 µs (356 kHz) at 32 MHz, whatever CR2.FREQ says.
#[test]
fn i2c1_scl_follows_pclk1() {
    assert!(!i2c1_sb_after(Tree::Hse72, 2_400));
    assert!(i2c1_sb_after(Tree::Hse72, 2_600));
    assert!(!i2c1_sb_after(Tree::Hsi64, 2_700));
    assert!(i2c1_sb_after(Tree::Hsi64, 2_900));
}

/// Trees outside the manual's limits stop the board: APB1 above 36 MHz
/// (RM0008 §7.2), and SYSCLK above 48 MHz with fewer than two flash wait
/// states (§3.3.3).
#[test]
fn clock_trees_outside_the_manual_stop_the_board() {
    let mut b = board(Tree::Hsi64);
    let cfgr = rd(&mut b, RCC_CFGR);
    let e = b.debug_write(RCC_CFGR, cfgr & !(7 << 8));
    assert!(
        matches!(e, Err(BoardError::Clock(_))),
        "APB1 at 64 MHz: {e:?}"
    );
    let mut b = board(Tree::Hsi8);
    wr(&mut b, RCC_CFGR, 14 << 18 | PPRE1_DIV2);
    let cr = rd(&mut b, RCC_CR);
    wr(&mut b, RCC_CR, cr | (1 << 24));
    run_for(&mut b, MS);
    let e = b.debug_write(RCC_CFGR, 14 << 18 | PPRE1_DIV2 | 2);
    assert!(
        matches!(e, Err(BoardError::Clock(_))),
        "0 wait states at 64 MHz: {e:?}"
    );
}
