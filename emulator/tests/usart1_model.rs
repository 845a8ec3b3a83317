//! The USART receiver model against RM0008 §27.3.3 and §27.6.1: when RXNE
//! sets for a byte on the line, the overrun and framing errors, IDLE, the
//! SR-then-DR clear sequences and the interrupt line, at CRSF's 420 kbaud.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use emulator::usart::{cr1, cr3, reg, sr, Usart};

const PCLK2_HZ: u32 = 72_000_000;
const CRSF_BAUD: u32 = 420_000;
/// BRR for 420 kbaud at 72 MHz: USARTDIV = 72e6 / (16 · 420e3) = 10.71 →
/// mantissa 10, fraction 11/16 (§27.3.4): 0xAB, 421,053 baud (+0.25 %).
const BRR_420K: u32 = (10 << 4) | 11;
/// One bit at 420 kbaud (ns).
const BIT_NS: u64 = 2_381;

struct Rig {
    u: Usart,
    now: u64,
}

impl Rig {
    fn new(brr: u32, cr: u32) -> Self {
        let mut r = Self {
            u: Usart::new("USART1", PCLK2_HZ),
            now: 0,
        };
        r.wr(reg::BRR, brr);
        r.wr(reg::CR1, cr);
        r
    }
    fn wr(&mut self, off: u32, v: u32) {
        self.u.write(off, v, self.now).unwrap().unwrap();
    }
    fn rd(&mut self, off: u32) -> u32 {
        self.u.read(off, self.now).unwrap()
    }
    fn at(&mut self, t: u64) {
        self.now = t;
        self.u.advance(t);
    }
}

const RX_ON: u32 = cr1::UE | cr1::RE;

#[test]
fn brr_gives_the_baud_rate_of_section_27_3_4() {
    let r = Rig::new(BRR_420K, RX_ON);
    let baud = r.u.baud().unwrap();
    assert!((baud - 421_052.6).abs() < 1.0, "{baud}");
}

#[test]
fn rxne_sets_in_the_middle_of_the_stop_bit_and_a_dr_read_clears_it() {
    let mut r = Rig::new(BRR_420K, RX_ON);
    r.u.inject(&[0xC8], CRSF_BAUD, 1_000);
    r.at(1_000 + 9 * BIT_NS);
    assert_eq!(r.rd(reg::SR) & sr::RXNE, 0, "stop bit not yet sampled");
    r.at(1_000 + 10 * BIT_NS);
    assert_eq!(r.rd(reg::SR) & sr::RXNE, sr::RXNE);
    assert_eq!(r.rd(reg::DR), 0xC8);
    assert_eq!(r.rd(reg::SR) & sr::RXNE, 0);
    assert_eq!(r.u.counts(), (1, 0));
}

#[test]
fn back_to_back_bytes_arrive_one_frame_apart() {
    let mut r = Rig::new(BRR_420K, RX_ON);
    let frame: Vec<u8> = (0..26).collect();
    r.u.inject(&frame, CRSF_BAUD, 0);
    let mut got = Vec::new();
    let mut t = 0;
    while got.len() < frame.len() && t < 1_000_000 {
        t += 1_000;
        r.at(t);
        if r.rd(reg::SR) & sr::RXNE != 0 {
            got.push(r.rd(reg::DR) as u8);
        }
    }
    assert_eq!(got, frame);
    // 26 frames of 10 bits at 420 kbaud: the last byte at 25 · 10 + 9.5 bits.
    assert!((259 * BIT_NS..259 * BIT_NS + 2_000).contains(&t), "{t}");
    assert_eq!(r.u.counts(), (26, 0));
}

#[test]
fn overrun_keeps_the_unread_byte_and_clears_by_sr_then_dr() {
    let mut r = Rig::new(BRR_420K, RX_ON);
    r.u.inject(&[0x11, 0x22, 0x33], CRSF_BAUD, 0);
    r.at(40 * BIT_NS);
    let s = r.rd(reg::SR);
    assert_eq!(s & (sr::RXNE | sr::ORE), sr::RXNE | sr::ORE);
    assert_eq!(r.rd(reg::DR), 0x11, "DR keeps the byte not read");
    assert_eq!(r.rd(reg::SR) & (sr::ORE | sr::RXNE), 0, "SR read + DR read");
    assert_eq!(r.u.counts(), (1, 2));
}

#[test]
fn a_dr_read_without_an_sr_read_before_it_leaves_ore() {
    let mut r = Rig::new(BRR_420K, RX_ON);
    r.u.inject(&[0x11, 0x22], CRSF_BAUD, 0);
    r.at(30 * BIT_NS);
    assert_eq!(r.rd(reg::DR), 0x11);
    // The DR read was not preceded by an SR read: ORE stays.
    assert_eq!(r.rd(reg::SR) & sr::ORE, sr::ORE);
    r.rd(reg::DR);
    assert_eq!(r.rd(reg::SR) & sr::ORE, 0);
}

#[test]
fn idle_sets_one_frame_after_the_last_stop_bit_once_per_burst() {
    let mut r = Rig::new(BRR_420K, RX_ON);
    r.u.inject(&[1, 2, 3], CRSF_BAUD, 0);
    r.at(30 * BIT_NS);
    for _ in 0..3 {
        r.rd(reg::SR);
        r.rd(reg::DR);
    }
    r.at(30 * BIT_NS + 9 * BIT_NS);
    assert_eq!(r.rd(reg::SR) & sr::IDLE, 0, "not a whole idle frame yet");
    r.at(30 * BIT_NS + 11 * BIT_NS);
    assert_eq!(r.rd(reg::SR) & sr::IDLE, sr::IDLE);
    r.rd(reg::DR);
    assert_eq!(r.rd(reg::SR) & sr::IDLE, 0, "cleared by SR then DR");
    r.at(200 * BIT_NS);
    assert_eq!(r.rd(reg::SR) & sr::IDLE, 0, "not again without a new RXNE");
}

/// A receiver off the line's rate samples the wrong bits (§27.3.3: it
/// samples in the middle of its own bit times): wrong bytes, and framing
/// errors where its stop-bit sample falls on a low bit.
#[test]
fn a_receiver_off_the_line_rate_reads_wrong_bytes_and_framing_errors() {
    // BRR for 115200 baud listening to a 420 kbaud line.
    let mut r = Rig::new(625, RX_ON);
    let sent: Vec<u8> = (0..8u8).map(|i| 0xC8 ^ i.wrapping_mul(37)).collect();
    r.u.inject(&sent, CRSF_BAUD, 0);
    let mut got = Vec::new();
    let mut fe = 0;
    for t in (0..400).map(|i| i * BIT_NS) {
        r.at(t);
        let s = r.rd(reg::SR);
        if s & sr::RXNE != 0 {
            fe += usize::from(s & sr::FE != 0);
            got.push(r.rd(reg::DR) as u8);
        }
    }
    assert!(!got.is_empty() && got.len() < sent.len(), "{got:x?}");
    assert_ne!(got[..], sent[..got.len()]);
    assert!(fe > 0, "a stop-bit sample on a low bit: FE");
    // Within the 3.75 % tolerance (§27.3.5): every byte right, no error.
    let mut r = Rig::new(BRR_420K + 5, RX_ON);
    r.u.inject(&sent, CRSF_BAUD, 0);
    let mut got = Vec::new();
    for t in (0..400).map(|i| i * BIT_NS) {
        r.at(t);
        let s = r.rd(reg::SR);
        assert_eq!(s & sr::FE, 0);
        if s & sr::RXNE != 0 {
            got.push(r.rd(reg::DR) as u8);
        }
    }
    assert_eq!(got, sent);
}

#[test]
fn nothing_is_received_with_the_receiver_off() {
    let mut r = Rig::new(BRR_420K, cr1::UE);
    r.u.inject(&[1, 2], CRSF_BAUD, 0);
    r.at(100 * BIT_NS);
    assert_eq!(r.rd(reg::SR) & (sr::RXNE | sr::IDLE), 0);
    assert_eq!(r.u.counts(), (0, 0));
}

#[test]
fn interrupt_line_follows_rxneie_and_ore() {
    let mut r = Rig::new(BRR_420K, RX_ON | cr1::RXNEIE);
    assert!(!r.u.irq());
    r.u.inject(&[1, 2], CRSF_BAUD, 0);
    r.at(10 * BIT_NS);
    assert!(r.u.irq(), "RXNE with RXNEIE");
    r.rd(reg::DR);
    assert!(!r.u.irq());
    // ORE alone also requests the interrupt with RXNEIE (§27.4).
    let mut r = Rig::new(BRR_420K, RX_ON | cr1::RXNEIE);
    r.u.inject(&[1, 2], CRSF_BAUD, 0);
    r.at(30 * BIT_NS);
    r.wr(reg::SR, !sr::RXNE);
    assert_eq!(r.rd(reg::SR) & (sr::RXNE | sr::ORE), sr::ORE);
    assert!(r.u.irq());
}

#[test]
fn features_outside_the_model_are_refused() {
    let mut u = Usart::new("USART1", PCLK2_HZ);
    assert!(
        matches!(u.write(reg::CR1, cr1::UE | cr1::RE, 0), Some(Err(_))),
        "BRR 0"
    );
    u.write(reg::BRR, BRR_420K, 0);
    assert!(
        matches!(u.write(reg::CR1, cr1::UE | cr1::TE | 1, 0), Some(Err(_))),
        "send break"
    );
    assert!(
        matches!(u.write(reg::CR1, cr1::UE | (1 << 10), 0), Some(Err(_))),
        "parity"
    );
    assert!(
        matches!(u.write(reg::CR1, cr1::UE | (1 << 12), 0), Some(Err(_))),
        "9 bits"
    );
    assert!(
        matches!(u.write(reg::CR3, 1 << 8, 0), Some(Err(_))),
        "RTS flow control"
    );
    assert!(
        matches!(u.write(reg::CR3, 1 << 3, 0), Some(Err(_))),
        "half-duplex"
    );
    assert_eq!(u.read(0x1C, 0), None);
}

/// With the receiver's DMA (CR3.DMAR) the DMA reads DR. IDLE's clear
/// sequence is "a read to the USART_SR register followed by a read to the
/// USART_DR register" (RM0008 §27.6.1): the USART sees the bus access, not
/// the master, so the DMA's DR read after the handler's SR read clears
/// IDLE, and a DMA read with no SR read before it does not. (The firmware
/// relies on this when it leaves DR to the DMA while RXNE is set.)
#[test]
fn the_dmas_dr_read_after_an_sr_read_clears_idle() {
    let mut r = Rig::new(BRR_420K, RX_ON | cr1::IDLEIE);
    r.wr(reg::CR3, cr3::DMAR);
    r.u.inject(&[1], CRSF_BAUD, 0);
    r.at(10 * BIT_NS);
    assert!(r.u.rx_dma_request());
    assert_eq!(r.u.dma_read_dr(r.now), 1);
    r.at(25 * BIT_NS);
    assert!(r.u.irq(), "IDLE one idle character after the stop bit");
    // A byte the DMA takes with no SR read before it: IDLE stays.
    r.u.inject(&[2], CRSF_BAUD, 25 * BIT_NS);
    r.at(35 * BIT_NS);
    assert!(r.u.rx_dma_request());
    assert_eq!(r.u.dma_read_dr(r.now), 2);
    assert!(r.u.irq(), "a DR read alone does not clear IDLE");
    // The handler reads SR (IDLE set, no byte waiting), then a byte lands
    // and the DMA, not the handler, reads DR: IDLE is cleared.
    r.at(36 * BIT_NS);
    assert_eq!(r.rd(reg::SR) & (sr::IDLE | sr::RXNE), sr::IDLE);
    r.u.inject(&[3], CRSF_BAUD, 36 * BIT_NS);
    r.at(46 * BIT_NS);
    assert!(r.u.rx_dma_request());
    assert_eq!(r.u.dma_read_dr(r.now), 3);
    assert!(!r.u.irq(), "SR then the DMA's DR read cleared IDLE");
    assert_eq!(r.u.counts(), (3, 0));
    // And IDLE comes back one idle character after that byte.
    r.at(57 * BIT_NS);
    assert!(r.u.irq());
}
