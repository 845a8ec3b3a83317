//! The USART transmitter model against RM0008 §27.3.2 (character
//! transmission, figure 282), §27.6.1 (TXE and TC and their clears) and
//! §27.3.13 (transmission using DMA, DMA1 channel 4): the idle frame that
//! TE sends, ten bit times per byte, TXE/TC timing and clear sequences,
//! the interrupt line, the line log and its level as a receiver samples
//! it, and a DMA-fed frame ending in TC.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use emulator::dma::{ccr, isr, reg as dreg, Dma};
use emulator::usart::{cr1, cr3, reg, sr, TxByte, Usart};

const PCLK2_HZ: u32 = 72_000_000;
/// 420 kbaud at 72 MHz (usart1_model.rs): 421,053 baud.
const BRR_420K: u32 = (10 << 4) | 11;
/// One bit at BRR 0xAB, ns: 16 · 171 / 72 MHz.
const BIT_NS: f64 = 171.0 / 72.0 * 1e3;
const TX_ON: u32 = cr1::UE | cr1::TE;

struct Rig {
    u: Usart,
    now: u64,
}

impl Rig {
    fn new(cr: u32) -> Self {
        let mut r = Self {
            u: Usart::new("USART1", PCLK2_HZ),
            now: 0,
        };
        r.wr(reg::BRR, BRR_420K);
        r.wr(reg::CR1, cr);
        r
    }
    fn try_wr(&mut self, off: u32, v: u32) -> Result<(), String> {
        self.u.write(off, v, self.now).unwrap()
    }
    fn wr(&mut self, off: u32, v: u32) {
        self.try_wr(off, v).unwrap();
    }
    fn rd(&mut self, off: u32) -> u32 {
        self.u.read(off, self.now).unwrap()
    }
    fn at(&mut self, t: f64) {
        self.now = t.round() as u64;
        self.u.advance(self.now);
    }
    fn sr(&mut self) -> u32 {
        self.rd(reg::SR)
    }
}

/// `n` bit times, ns.
fn bits(n: f64) -> f64 {
    n * BIT_NS
}

#[test]
fn te_sends_an_idle_frame_before_the_first_byte() {
    let mut r = Rig::new(TX_ON);
    assert_eq!(
        r.sr() & (sr::TXE | sr::TC),
        sr::TXE | sr::TC,
        "reset values"
    );
    r.wr(reg::DR, 0x55);
    assert_eq!(r.sr() & sr::TXE, 0, "the byte waits behind the idle frame");
    r.at(bits(9.9));
    assert_eq!(r.sr() & sr::TXE, 0);
    r.at(bits(10.0) + 1.0);
    assert_eq!(r.sr() & sr::TXE, sr::TXE, "in the shift register");
    r.at(bits(25.0));
    let log = r.u.tx_log().to_vec();
    assert_eq!(log.len(), 1);
    assert_eq!(log[0].byte, 0x55);
    assert!(
        (log[0].start_ns as f64 - bits(10.0)).abs() <= 1.0,
        "{log:?}"
    );
    assert!(((log[0].end_ns - log[0].start_ns) as f64 - bits(10.0)).abs() <= 1.0);
}

#[test]
fn back_to_back_bytes_take_ten_bit_times_each_and_tc_sets_after_the_last() {
    let mut r = Rig::new(TX_ON);
    r.at(bits(11.0));
    let t0 = r.now as f64;
    let sent = [0xC8u8, 0x0C, 0x14, 0x00, 0xFF];
    r.wr(reg::SR, !sr::TC);
    for &b in &sent {
        // Wait for TXE, then write the next byte.
        while r.sr() & sr::TXE == 0 {
            let t = r.now as f64 + 100.0;
            r.at(t);
        }
        r.wr(reg::DR, u32::from(b));
    }
    assert_eq!(r.sr() & sr::TC, 0);
    let end = t0 + bits(10.0 * sent.len() as f64);
    r.at(end - 5.0);
    assert_eq!(r.sr() & sr::TC, 0, "the last stop bit is still going");
    r.at(end + 5.0);
    assert_eq!(r.sr() & (sr::TC | sr::TXE), sr::TC | sr::TXE);
    let log = r.u.tx_log().to_vec();
    let bytes: Vec<u8> = log.iter().map(|f| f.byte).collect();
    assert_eq!(bytes, sent);
    for w in log.windows(2) {
        assert_eq!(w[0].end_ns, w[1].start_ns, "no gap: {log:?}");
    }
}

#[test]
fn tc_clears_by_an_sr_read_then_a_dr_write_or_by_writing_zero() {
    let mut r = Rig::new(TX_ON);
    r.at(bits(11.0));
    // A DR write without an SR read first leaves TC.
    r.wr(reg::DR, 1);
    assert_eq!(r.u.read(reg::CR1, r.now).unwrap() & cr1::TE, cr1::TE);
    let s = r.u.read(reg::SR, r.now).unwrap();
    assert_eq!(
        s & sr::TC,
        sr::TC,
        "TC set from reset, DR written without SR read"
    );
    // SR read (just above) then DR write: cleared.
    r.wr(reg::DR, 2);
    assert_eq!(r.sr() & sr::TC, 0);
    r.at(bits(40.0));
    assert_eq!(r.sr() & sr::TC, sr::TC);
    r.wr(reg::SR, !sr::TC);
    assert_eq!(r.sr() & sr::TC, 0, "written 0");
    r.wr(reg::SR, !0);
    assert_eq!(r.sr() & sr::TXE, sr::TXE, "TXE is read-only");
}

#[test]
fn txe_and_tc_raise_the_interrupt_line_with_their_enables() {
    let mut r = Rig::new(TX_ON | cr1::TXEIE);
    assert!(r.u.irq(), "TXE set from reset");
    r.wr(reg::DR, 0xAA);
    assert!(!r.u.irq(), "TDR full behind the idle frame");
    r.at(bits(10.5));
    assert!(r.u.irq(), "TXE again");
    r.wr(reg::CR1, TX_ON | cr1::TCIE);
    r.sr();
    r.wr(reg::DR, 0xBB);
    r.at(bits(25.0));
    assert!(!r.u.irq(), "0xBB still on the line");
    r.at(bits(40.0));
    assert!(r.u.irq(), "TC after 0xBB");
}

/// What a receiver at the same rate sees on the line: the model's own
/// receiver, fed the logged frames, decodes the bytes; the line level
/// follows the frame bit by bit.
#[test]
fn a_receiver_on_the_tx_line_reads_the_bytes() {
    // The line level, mid-bit, of 0xC8 after the idle frame: start bit
    // low, data LSB first, stop bit high.
    let mut r = Rig::new(TX_ON);
    r.wr(reg::DR, 0xC8);
    let mut levels = Vec::new();
    for k in 0..10 {
        r.at(bits(10.0 + k as f64 + 0.5));
        levels.push(r.u.tx_line_high(r.now));
    }
    let expect: Vec<bool> = (0..10)
        .map(|k| match k {
            0 => false,
            9 => true,
            _ => 0xC8 >> (k - 1) & 1 != 0,
        })
        .collect();
    assert_eq!(levels, expect);
    r.at(bits(25.0));
    assert!(r.u.tx_line_high(r.now), "idle high after the stop bit");

    let mut r = Rig::new(TX_ON);
    let sent = [0xC8u8, 0x18, 0x16, 0xA5];
    for &b in &sent {
        while r.sr() & sr::TXE == 0 {
            let t = r.now as f64 + 200.0;
            r.at(t);
        }
        r.wr(reg::DR, u32::from(b));
    }
    r.at(bits(60.0));
    let mut rx = Usart::new("receiver", PCLK2_HZ);
    rx.write(reg::BRR, BRR_420K, 0).unwrap().unwrap();
    rx.write(reg::CR1, cr1::UE | cr1::RE, 0).unwrap().unwrap();
    for f in r.u.tx_log() {
        let baud = (1e10 / (f.end_ns - f.start_ns) as f64).round() as u32;
        rx.inject(&[f.byte], baud, f.start_ns);
    }
    let mut got = Vec::new();
    while let Some(t) = rx.next_byte_ns() {
        rx.advance(t);
        got.push(rx.read(reg::DR, t).unwrap() as u8);
    }
    assert_eq!(got, sent);
}

#[test]
fn frames_while_the_pin_is_not_wired_are_not_on_the_line() {
    let mut r = Rig::new(TX_ON);
    r.u.set_tx_pin_connected(false);
    r.wr(reg::DR, 1);
    r.at(bits(30.0));
    assert!(r.u.tx_log().is_empty());
    assert_eq!(r.u.tx_unseen(), 1);
}

#[test]
fn clearing_te_while_a_byte_is_on_the_line_stops_the_board() {
    let mut r = Rig::new(TX_ON);
    r.at(bits(11.0));
    r.wr(reg::DR, 0x42);
    r.at(bits(15.0));
    let e = r.try_wr(reg::CR1, cr1::UE);
    assert!(e.is_err_and(|m| m.contains("TE or UE cleared")));
    // After the frame, TE may be cleared.
    let mut r = Rig::new(TX_ON);
    r.at(bits(11.0));
    r.wr(reg::DR, 0x42);
    r.at(bits(22.0));
    r.wr(reg::CR1, cr1::UE);
    assert_eq!(r.u.tx_log().len(), 1);
}

#[test]
fn a_byte_written_before_te_goes_after_the_idle_frame() {
    let mut r = Rig::new(cr1::UE);
    r.wr(reg::DR, 0x33);
    r.at(bits(50.0));
    assert!(r.u.tx_log().is_empty(), "TE clear: nothing sent");
    assert_eq!(r.sr() & sr::TXE, 0);
    r.wr(reg::CR1, TX_ON);
    let te_at = r.now;
    r.at(bits(80.0));
    let log = r.u.tx_log();
    assert_eq!(log.len(), 1);
    assert!(
        (log[0].start_ns - te_at) as f64 >= bits(10.0) - 1.0,
        "{log:?}"
    );
}

/// The manual's DMA transmission (§27.3.13): CPAR = DR, CMAR = the
/// buffer, CNDTR = n, channel 4 memory → peripheral; TC cleared by
/// writing 0; the DMA refills DR at each TXE; DMA TCIF when the last byte
/// is in DR, the USART's TC when it has left the line.
#[test]
fn dma_channel_4_feeds_the_transmitter_until_tc() {
    const DR_ADDR: u32 = 0x4001_3804;
    const BUF: u32 = 0x2000_0100;
    let frame: Vec<u8> = vec![0xC8, 0x06, 0x21, b'A', b'C', b'R', 0x00, 0x5B];
    let mut ram = vec![0u8; 0x200];
    ram[0x100..0x100 + frame.len()].copy_from_slice(&frame);
    let mut u = Usart::new("USART1", PCLK2_HZ);
    let mut dma = Dma::new();
    u.write(reg::BRR, BRR_420K, 0).unwrap().unwrap();
    u.write(reg::CR1, TX_ON, 0).unwrap().unwrap();
    u.write(reg::CR3, cr3::DMAT, 0).unwrap().unwrap();
    // After the idle frame TE sent (ten bits from 0).
    let t0 = 30_000u64;
    u.advance(t0);
    u.write(reg::SR, !sr::TC, t0).unwrap().unwrap();
    dma.write(dreg::cpar(4), DR_ADDR).unwrap().unwrap();
    dma.write(dreg::cmar(4), BUF).unwrap().unwrap();
    dma.write(dreg::cndtr(4), frame.len() as u32)
        .unwrap()
        .unwrap();
    let cfg = ccr::DIR | ccr::MINC | ccr::TCIE | ccr::EN;
    dma.write(dreg::ccr(4), cfg).unwrap().unwrap();
    // The board's loop: serve the request now and at each frame end.
    let serve = |u: &mut Usart, dma: &mut Dma, at: u64| {
        while let Some(t) = dma.next_transfer(u8::from(u.tx_dma_request()) << 3) {
            assert_eq!((t.channel, t.to, t.to_bytes), (3, DR_ADDR, 1));
            let v = ram[(t.from - 0x2000_0000) as usize];
            u.dma_write_dr(u32::from(v), at);
            dma.complete(t.channel);
        }
    };
    serve(&mut u, &mut dma, t0);
    let mut tcif_at = None;
    while let Some(t) = u.next_tx_ns() {
        u.advance(t);
        serve(&mut u, &mut dma, t);
        if tcif_at.is_none() && dma.read(dreg::ISR).unwrap() & isr::of(4, isr::TCIF) != 0 {
            tcif_at = Some(t);
        }
        assert_eq!(
            u.read(reg::SR, t).unwrap() & sr::TC != 0,
            u.next_tx_ns().is_none()
        );
    }
    let log: Vec<TxByte> = u.tx_log().to_vec();
    assert_eq!(log.iter().map(|f| f.byte).collect::<Vec<_>>(), frame);
    assert_eq!(log[0].start_ns, t0, "the first byte starts at the enable");
    let line = (log[log.len() - 1].end_ns - t0) as f64;
    assert!(
        (line - bits(10.0 * frame.len() as f64)).abs() <= 2.0,
        "{line}"
    );
    assert!(dma.irq(3), "DMA TC interrupt");
    // TCIF when the last byte went into DR: at the end of the third-last
    // frame, with two frames (shift register, TDR) still to go.
    let tcif_at = tcif_at.unwrap();
    assert_eq!(tcif_at, log[log.len() - 3].end_ns);
}
