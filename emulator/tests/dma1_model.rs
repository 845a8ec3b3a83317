//! The DMA1 model against RM0008 §13.3 and §13.4, with USART1 as its
//! requester (§27.3.13, channel 5): circular reception into a ring, the
//! HT/TC flags and their IFCR clears, CNDTR counting down and reloading, a
//! transfer error on an address nothing answers, a disabled channel
//! leaving the request (and so an overrun) to the USART, the arbiter's
//! order, data-width packing, and the IDLE flag's own clear sequence.
//!
//! The rig below is the bus between the two models: what the board does
//! with a `Transfer` (read the source, write the destination, report
//! completion or a bus error), over a small SRAM.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use emulator::dma::{ccr, isr, reg, Dma, Transfer};
use emulator::usart::{self, cr1, cr3, sr, Usart};

const PCLK2_HZ: u32 = 72_000_000;
const CRSF_BAUD: u32 = 420_000;
/// 420 kbaud at 72 MHz (see usart1_model.rs).
const BRR_420K: u32 = (10 << 4) | 11;
/// One byte (10 bits) at 420 kbaud, ns.
const BYTE_NS: u64 = 23_810;
const USART1_DR: u32 = 0x4001_3800 + usart::reg::DR;
const RAM: u32 = 0x2000_0000;
const RING: u32 = RAM + 0x100;
/// Channel 5 (USART1_RX), 1-based as in the manual.
const CH: u32 = 5;

struct Rig {
    dma: Dma,
    usart: Usart,
    ram: Vec<u8>,
    now: u64,
}

impl Rig {
    /// USART1 receiving at 420 kbaud with `cr3`, DMA1 reset.
    fn new(cr3: u32) -> Self {
        let mut usart = Usart::new("USART1", PCLK2_HZ);
        usart.write(usart::reg::BRR, BRR_420K, 0).unwrap().unwrap();
        usart
            .write(usart::reg::CR1, cr1::UE | cr1::RE, 0)
            .unwrap()
            .unwrap();
        usart.write(usart::reg::CR3, cr3, 0).unwrap().unwrap();
        Self {
            dma: Dma::new(),
            usart,
            ram: vec![0; 1024],
            now: 0,
        }
    }

    fn wr(&mut self, off: u32, v: u32) {
        self.dma.write(off, v).unwrap().unwrap();
    }

    fn rd(&self, off: u32) -> u32 {
        self.dma.read(off).unwrap()
    }

    /// Channel 5 from USART1's DR into `RING` (`n` items, byte to byte,
    /// memory increment) with the extra CCR bits `bits`.
    fn setup(&mut self, n: u32, bits: u32) {
        self.wr(reg::cpar(CH), USART1_DR);
        self.wr(reg::cmar(CH), RING);
        self.wr(reg::cndtr(CH), n);
        self.wr(reg::ccr(CH), ccr::MINC | bits);
    }

    fn bus_read(&mut self, addr: u32, bytes: u32, at: u64) -> Option<u32> {
        if addr == USART1_DR {
            return Some(self.usart.dma_read_dr(at));
        }
        let off = addr.checked_sub(RAM)? as usize;
        let b = self.ram.get(off..off + bytes as usize)?;
        let mut w = [0u8; 4];
        w[..b.len()].copy_from_slice(b);
        Some(u32::from_le_bytes(w))
    }

    fn bus_write(&mut self, addr: u32, bytes: u32, v: u32) -> Option<()> {
        let off = addr.checked_sub(RAM)? as usize;
        let dst = self.ram.get_mut(off..off + bytes as usize)?;
        dst.copy_from_slice(&v.to_le_bytes()[..bytes as usize]);
        Some(())
    }

    /// What the board does on a request: serve until no request is left.
    fn serve(&mut self, at: u64) {
        for _ in 0..16 {
            let req = u8::from(self.usart.rx_dma_request()) << 4;
            let Some(t) = self.dma.next_transfer(req) else {
                return;
            };
            let moved = self
                .bus_read(t.from, t.from_bytes, at)
                .and_then(|v| self.bus_write(t.to, t.to_bytes, t.value_written(v)));
            match moved {
                Some(()) => self.dma.complete(t.channel),
                None => self.dma.bus_error(t.channel),
            }
        }
    }

    /// Sends `bytes` back to back and runs until the line is quiet, the
    /// DMA serving each byte as it lands.
    fn receive(&mut self, bytes: &[u8]) {
        self.usart.inject(bytes, CRSF_BAUD, self.now);
        while let Some(t) = self.usart.next_byte_ns() {
            self.usart.advance(t);
            self.serve(t);
            self.now = t;
        }
    }

    fn ring(&self, n: usize) -> &[u8] {
        &self.ram[0x100..0x100 + n]
    }

    fn flags(&self) -> u32 {
        (self.rd(reg::ISR) >> (4 * (CH - 1))) & 0xF
    }
}

#[test]
fn circular_reception_fills_the_ring_and_wraps() {
    let mut r = Rig::new(cr3::DMAR);
    r.setup(8, ccr::CIRC | ccr::EN);
    r.receive(&[1, 2, 3, 4, 5]);
    assert_eq!(r.ring(8), &[1, 2, 3, 4, 5, 0, 0, 0]);
    assert_eq!(r.rd(reg::cndtr(CH)), 3, "CNDTR counts the items left");
    r.receive(&[6, 7, 8, 9, 10, 11]);
    // Item 9 went back to the start: CMAR and CNDTR reloaded at 0.
    assert_eq!(r.ring(8), &[9, 10, 11, 4, 5, 6, 7, 8]);
    assert_eq!(r.rd(reg::cndtr(CH)), 5);
    // CMAR reads back as programmed, not as the current address.
    assert_eq!(r.rd(reg::cmar(CH)), RING);
    assert_eq!(r.usart.counts(), (11, 0), "no overrun: every byte taken");
    assert_eq!(r.usart.read(usart::reg::SR, r.now).unwrap() & sr::RXNE, 0);
    assert_eq!(r.dma.served()[4], 11);
}

#[test]
fn half_and_complete_flags_set_at_their_counts_and_clear_by_ifcr() {
    let mut r = Rig::new(cr3::DMAR);
    r.setup(8, ccr::CIRC | ccr::EN);
    r.receive(&[0; 3]);
    assert_eq!(r.flags(), 0);
    r.receive(&[0]);
    assert_eq!(r.flags(), isr::HTIF | isr::GIF, "after half of 8 items");
    r.receive(&[0; 4]);
    assert_eq!(r.flags(), isr::TCIF | isr::HTIF | isr::GIF);
    assert_eq!(r.rd(reg::cndtr(CH)), 8, "reloaded");
    // CHTIF and CTCIF clear their own flag; GIF only by CGIF (§13.4.1).
    r.wr(reg::IFCR, isr::of(CH, isr::HTIF));
    assert_eq!(r.flags(), isr::TCIF | isr::GIF);
    r.wr(reg::IFCR, isr::of(CH, isr::TCIF));
    assert_eq!(r.flags(), isr::GIF, "GIF latched");
    r.wr(reg::IFCR, isr::of(CH, isr::GIF));
    assert_eq!(r.flags(), 0);
    r.receive(&[0; 4]);
    assert_eq!(r.flags(), isr::HTIF | isr::GIF, "again on the next lap");
    // CGIF clears every flag of its channel, and only of its channel.
    r.wr(reg::IFCR, isr::of(4, isr::GIF) | isr::of(6, isr::GIF));
    assert_eq!(r.flags(), isr::HTIF | isr::GIF);
    r.wr(reg::IFCR, isr::of(CH, isr::GIF));
    assert_eq!(r.flags(), 0);
    // ISR is read-only.
    r.wr(reg::ISR, 0xFFFF_FFFF);
    assert_eq!(r.rd(reg::ISR), 0);
}

#[test]
fn a_normal_mode_channel_stops_at_zero_and_the_usart_then_overruns() {
    let mut r = Rig::new(cr3::DMAR);
    r.setup(4, ccr::EN);
    r.receive(&[1, 2, 3, 4, 5, 6]);
    assert_eq!(r.ring(6), &[1, 2, 3, 4, 0, 0]);
    assert_eq!(r.rd(reg::cndtr(CH)), 0, "no reload without CIRC");
    assert_eq!(r.flags(), isr::TCIF | isr::HTIF | isr::GIF);
    assert_eq!(r.rd(reg::ccr(CH)) & ccr::EN, ccr::EN, "EN stays set");
    // Byte 5 waits in DR (RXNE: the request stays up), byte 6 overruns.
    assert_eq!(r.usart.counts(), (5, 1));
    let s = r.usart.read(usart::reg::SR, r.now).unwrap();
    assert_eq!(s & (sr::RXNE | sr::ORE), sr::RXNE | sr::ORE);
}

#[test]
fn a_disabled_channel_ignores_requests_until_enabled() {
    let mut r = Rig::new(cr3::DMAR);
    r.setup(8, ccr::CIRC);
    r.receive(&[0x42]);
    assert_eq!(r.ring(1), &[0]);
    assert!(r.usart.rx_dma_request(), "the request waits");
    assert_eq!(r.rd(reg::cndtr(CH)), 8);
    // Enabling the channel serves the waiting request.
    r.wr(reg::ccr(CH), ccr::MINC | ccr::CIRC | ccr::EN);
    r.serve(r.now);
    assert_eq!(r.ring(1), &[0x42]);
    assert!(!r.usart.rx_dma_request());
    // Without DMAR the USART raises no request at all.
    let mut r = Rig::new(0);
    r.setup(8, ccr::CIRC | ccr::EN);
    r.receive(&[0x42]);
    assert_eq!(r.ring(1), &[0]);
    assert_eq!(r.rd(reg::cndtr(CH)), 8);
}

#[test]
fn counter_and_addresses_are_written_only_while_disabled() {
    let mut r = Rig::new(cr3::DMAR);
    r.setup(8, ccr::CIRC | ccr::EN);
    r.wr(reg::cndtr(CH), 3);
    r.wr(reg::cmar(CH), RAM);
    r.wr(reg::cpar(CH), 0);
    assert_eq!(r.rd(reg::cndtr(CH)), 8);
    assert_eq!(r.rd(reg::cmar(CH)), RING);
    assert_eq!(r.rd(reg::cpar(CH)), USART1_DR);
    r.receive(&[1, 2]);
    // Disabled: CNDTR keeps what is left; a re-enable restarts the
    // addresses at CMAR (the current address is internal).
    r.wr(reg::ccr(CH), ccr::MINC | ccr::CIRC);
    assert_eq!(r.rd(reg::cndtr(CH)), 6);
    r.wr(reg::ccr(CH), ccr::MINC | ccr::CIRC | ccr::EN);
    r.receive(&[3]);
    assert_eq!(r.ring(3), &[3, 2, 0]);
    assert_eq!(r.rd(reg::cndtr(CH)), 5);
}

#[test]
fn a_bus_error_sets_te_and_disables_the_channel() {
    let mut r = Rig::new(cr3::DMAR);
    // 0x2000_5000: past the 20 KiB of SRAM, nothing answers.
    r.wr(reg::cpar(CH), USART1_DR);
    r.wr(reg::cmar(CH), 0x2000_5000);
    r.wr(reg::cndtr(CH), 8);
    r.wr(reg::ccr(CH), ccr::MINC | ccr::CIRC | ccr::TEIE | ccr::EN);
    assert!(!r.dma.irq(4));
    r.receive(&[0x11, 0x22]);
    assert_eq!(r.flags(), isr::TEIF | isr::GIF);
    assert_eq!(r.rd(reg::ccr(CH)) & ccr::EN, 0, "EN cleared by hardware");
    assert_eq!(r.rd(reg::cndtr(CH)), 8, "the failed item is not counted");
    assert!(r.dma.irq(4), "TE with TEIE");
    // The first byte was read out of DR before the write failed; the
    // second waits for a channel that is now off.
    assert!(r.usart.rx_dma_request());
    r.wr(reg::IFCR, isr::of(CH, isr::TEIF));
    assert_eq!(r.flags(), isr::GIF);
    assert!(!r.dma.irq(4), "GIF alone raises no interrupt");
}

#[test]
fn interrupt_lines_follow_their_enables() {
    let mut r = Rig::new(cr3::DMAR);
    r.setup(4, ccr::CIRC | ccr::EN);
    r.receive(&[0; 4]);
    assert_eq!(r.flags(), isr::TCIF | isr::HTIF | isr::GIF);
    assert!(!r.dma.irq(4), "flags without enables raise nothing");
    r.wr(reg::ccr(CH), ccr::MINC | ccr::CIRC | ccr::HTIE | ccr::EN);
    assert!(r.dma.irq(4), "HT with HTIE (an enable may change while EN)");
    r.wr(reg::IFCR, isr::of(CH, isr::HTIF));
    assert!(!r.dma.irq(4), "TC is set but TCIE is not");
    r.wr(reg::ccr(CH), ccr::MINC | ccr::CIRC | ccr::TCIE | ccr::EN);
    assert!(r.dma.irq(4));
    assert!(!r.dma.irq(3) && !r.dma.irq(6), "only channel 5's line");
}

#[test]
fn the_arbiter_takes_priority_level_then_the_lower_channel() {
    let mut d = Dma::new();
    for (ch, pl) in [(2, 1), (5, 1), (7, 2)] {
        d.write(reg::cpar(ch), 0x4000_0000 + ch).unwrap().unwrap();
        d.write(reg::cmar(ch), RAM).unwrap().unwrap();
        d.write(reg::cndtr(ch), 1).unwrap().unwrap();
        d.write(reg::ccr(ch), ccr::pl(pl) | ccr::EN)
            .unwrap()
            .unwrap();
    }
    let all = (1 << 1) | (1 << 4) | (1 << 6);
    let next = |d: &Dma, req| d.next_transfer(req).map(|t: Transfer| t.channel + 1);
    assert_eq!(next(&d, all), Some(7), "highest PL first");
    assert_eq!(next(&d, all & !(1 << 6)), Some(2), "same PL: lower number");
    assert_eq!(next(&d, 1 << 4), Some(5));
    assert_eq!(next(&d, 1 << 2), None, "channel 3 is not enabled");
    d.complete(6);
    assert_eq!(next(&d, all), Some(2), "channel 7 has nothing left");
}

#[test]
fn data_width_packing_and_increments_follow_table_76() {
    // Byte reads from the USART into 16-bit memory items: zero-extended,
    // the memory address steps by 2.
    let mut r = Rig::new(cr3::DMAR);
    r.setup(4, ccr::MSIZE_16 | ccr::EN);
    r.receive(&[0xAB, 0xCD]);
    assert_eq!(r.ring(4), &[0xAB, 0, 0xCD, 0]);
    // A 32-bit memory source into a 16-bit peripheral keeps the low half;
    // addresses are aligned down to their size.
    let mut d = Dma::new();
    d.write(reg::cpar(1), 0x4001_3805).unwrap().unwrap();
    d.write(reg::cmar(1), RAM + 3).unwrap().unwrap();
    d.write(reg::cndtr(1), 2).unwrap().unwrap();
    let bits = ccr::DIR | ccr::PSIZE_16 | ccr::MSIZE_32 | ccr::MINC | ccr::EN;
    d.write(reg::ccr(1), bits).unwrap().unwrap();
    let t = d.next_transfer(1).unwrap();
    assert_eq!(
        (t.from, t.from_bytes, t.to, t.to_bytes),
        (RAM, 4, 0x4001_3804, 2)
    );
    assert_eq!(t.value_written(0x1234_5678), 0x5678);
    d.complete(0);
    assert_eq!(d.next_transfer(1).unwrap().from, RAM + 4);
}

#[test]
fn dma_reads_clear_rxne_but_idle_needs_sr_then_dr() {
    let mut r = Rig::new(cr3::DMAR);
    r.usart
        .write(usart::reg::CR1, cr1::UE | cr1::RE | cr1::IDLEIE, 0)
        .unwrap()
        .unwrap();
    r.setup(16, ccr::CIRC | ccr::EN);
    r.receive(&[1, 2, 3]);
    // One idle frame after the last stop bit (RXNE sets mid stop bit).
    let t = r.now + BYTE_NS + BYTE_NS / 10;
    r.usart.advance(t);
    r.now = t;
    assert!(r.usart.irq(), "IDLE with IDLEIE");
    assert_eq!(r.ring(3), &[1, 2, 3]);
    let s = r.usart.read(usart::reg::SR, t).unwrap();
    assert_eq!(s & (sr::IDLE | sr::RXNE), sr::IDLE, "DMA took every byte");
    // The DMA's DR reads came before this SR read: IDLE is still set until
    // the CPU's DR read completes the sequence.
    assert!(r.usart.irq());
    r.usart.read(usart::reg::DR, t).unwrap();
    assert!(!r.usart.irq());
    assert_eq!(r.usart.read(usart::reg::SR, t).unwrap() & sr::IDLE, 0);
}

#[test]
fn error_interrupt_with_dmar_and_eie() {
    // A receiver at 800 kbaud on a 420 kbaud line sending 0x00: its
    // stop-bit sample (9.5 of its bits, 5 of the line's) falls on a low
    // data bit: FE.
    let mut u = Usart::new("USART1", PCLK2_HZ);
    u.write(usart::reg::BRR, 90, 0).unwrap().unwrap();
    u.write(usart::reg::CR1, cr1::UE | cr1::RE, 0)
        .unwrap()
        .unwrap();
    u.write(usart::reg::CR3, cr3::DMAR | cr3::EIE, 0)
        .unwrap()
        .unwrap();
    u.inject(&[0x00], CRSF_BAUD, 0);
    u.advance(2 * BYTE_NS);
    assert!(u.rx_dma_request(), "the byte still goes to the DMA");
    assert!(u.irq(), "FE with EIE and DMAR");
    u.write(usart::reg::CR3, cr3::DMAR, 0).unwrap().unwrap();
    assert!(!u.irq(), "not without EIE");
}

#[test]
fn configurations_outside_the_model_are_refused() {
    let mut d = Dma::new();
    assert!(matches!(d.write(reg::ccr(1), ccr::MEM2MEM), Some(Err(_))));
    assert!(matches!(d.write(reg::ccr(1), 3 << 8), Some(Err(_))));
    assert!(matches!(d.write(reg::ccr(1), 3 << 10), Some(Err(_))));
    d.write(reg::ccr(1), ccr::EN).unwrap().unwrap();
    assert!(
        matches!(d.write(reg::ccr(1), ccr::EN | ccr::CIRC), Some(Err(_))),
        "reconfigured while enabled"
    );
    assert!(d.write(reg::ccr(1), ccr::EN | ccr::TCIE).unwrap().is_ok());
    assert_eq!(d.read(0x18), None, "the reserved word after CMAR1");
    assert_eq!(d.read(0x94), None, "past channel 7");
    assert!(d.write(0x94, 0).is_none());
}
