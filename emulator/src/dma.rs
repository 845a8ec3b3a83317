//! DMA1 controller (RM0008 §13): seven channels, each a CCR/CNDTR/CPAR/CMAR
//! set, the shared ISR/IFCR flags, software priority then channel-number
//! arbitration, circular reload, and the per-channel interrupt lines
//! (DMA1_Channel1..7 = IRQ 11..17, §10.1.2 table 63).
//!
//! The model decides what a channel does with a request; the board carries
//! the transfer out on its memory map ([`Dma::next_transfer`], then
//! [`Dma::complete`] or [`Dma::bus_error`]), so a peripheral becomes a DMA
//! requester by driving one bit of the request mask the board passes in
//! (§13.3.7 table 78: USART1_RX on channel 5, I2C1_RX on channel 7, ...).
//!
//! Behaviour taken from the manual:
//! * CNDTR, CPAR and CMAR are written only while the channel is disabled
//!   (§13.4.4–13.4.6); writes while it is enabled are ignored. A CNDTR
//!   write also sets the value circular mode reloads.
//! * Enabling a channel restarts its current addresses at CPAR/CMAR; CNDTR
//!   keeps what is left. CPAR/CMAR read back as programmed (the current
//!   addresses are internal, §13.3.5).
//! * Each served request moves one item: read at the source's size, write
//!   at the destination's (§13.3.4 table 76: a wider destination gets the
//!   item zero-extended, a narrower one its low bytes); an address
//!   incremented (PINC/MINC) steps by its own size; an address is aligned
//!   down to its size (the manual: "automatically aligned").
//! * HTIF sets when half of the programmed items have moved (CNDTR reaches
//!   the programmed value / 2, rounded down: for an odd count the manual is
//!   silent, this is after the larger half), TCIF when CNDTR reaches 0.
//!   Circular mode then reloads CNDTR and both addresses; otherwise the
//!   channel stays enabled and serves nothing more (§13.3.6).
//! * A bus error on either access (an address outside SRAM, flash and the
//!   peripheral space, or a write to flash) sets TEIF and clears EN; the
//!   item is not counted (§13.3.6 "Error management").
//! * GIF sets with any of its channel's TC, HT and TE flags and, as
//!   §13.4.1 describes it, clears only by a write of 1 to CGIF, which also
//!   clears the other three; CTCIF, CHTIF and CTEIF clear their own flag.
//!
//! Timing: a request is served at the instant the peripheral raises it, and
//! the CPU loses no cycles to it. Left out: AHB bus-matrix arbitration with
//! the CPU (a few cycles stolen per item on silicon), the one-item-per-
//! request round-robin latency between two channels requesting at once
//! (here the higher priority channel's request is served first, then the
//! next), and the DMA's own access time to APB peripherals.
//!
//! Not modelled (the board stops with an error): memory-to-memory mode
//! (MEM2MEM), the reserved size encoding 0b11, and reconfiguring a channel
//! other than through EN and the interrupt enables while it is enabled.

/// Number of channels of DMA1.
pub const CHANNELS: usize = 7;
/// Exception number offset: DMA1_Channel1 is IRQ 11 (channel `n` is IRQ
/// `10 + n`).
pub const CHANNEL1_IRQ: usize = 11;

/// Register offsets (RM0008 §13.4.7, table 79).
pub mod reg {
    /// Interrupt status register.
    pub const ISR: u32 = 0x00;
    /// Interrupt flag clear register.
    pub const IFCR: u32 = 0x04;
    /// CCR of channel `ch` (1..=7).
    pub const fn ccr(ch: u32) -> u32 {
        0x08 + 20 * (ch - 1)
    }
    /// CNDTR of channel `ch` (1..=7).
    pub const fn cndtr(ch: u32) -> u32 {
        0x0C + 20 * (ch - 1)
    }
    /// CPAR of channel `ch` (1..=7).
    pub const fn cpar(ch: u32) -> u32 {
        0x10 + 20 * (ch - 1)
    }
    /// CMAR of channel `ch` (1..=7).
    pub const fn cmar(ch: u32) -> u32 {
        0x14 + 20 * (ch - 1)
    }
}

/// ISR/IFCR flags of channel `ch` (1..=7): shift the value by `4 * (ch - 1)`.
pub mod isr {
    /// Global interrupt flag (any of TC, HT, TE).
    pub const GIF: u32 = 1 << 0;
    /// Transfer complete.
    pub const TCIF: u32 = 1 << 1;
    /// Half transfer.
    pub const HTIF: u32 = 1 << 2;
    /// Transfer error.
    pub const TEIF: u32 = 1 << 3;
    /// The flags of channel `ch` (1..=7) in ISR/IFCR.
    pub const fn of(ch: u32, flags: u32) -> u32 {
        flags << (4 * (ch - 1))
    }
}

/// CCR bits.
pub mod ccr {
    /// Channel enable.
    pub const EN: u32 = 1 << 0;
    /// Transfer complete interrupt enable.
    pub const TCIE: u32 = 1 << 1;
    /// Half transfer interrupt enable.
    pub const HTIE: u32 = 1 << 2;
    /// Transfer error interrupt enable.
    pub const TEIE: u32 = 1 << 3;
    /// Direction: 0 peripheral → memory, 1 memory → peripheral.
    pub const DIR: u32 = 1 << 4;
    /// Circular mode.
    pub const CIRC: u32 = 1 << 5;
    /// Peripheral increment.
    pub const PINC: u32 = 1 << 6;
    /// Memory increment.
    pub const MINC: u32 = 1 << 7;
    /// Peripheral size: 8 bits.
    pub const PSIZE_8: u32 = 0 << 8;
    /// Peripheral size: 16 bits.
    pub const PSIZE_16: u32 = 1 << 8;
    /// Peripheral size: 32 bits.
    pub const PSIZE_32: u32 = 2 << 8;
    /// Memory size: 8 bits.
    pub const MSIZE_8: u32 = 0 << 10;
    /// Memory size: 16 bits.
    pub const MSIZE_16: u32 = 1 << 10;
    /// Memory size: 32 bits.
    pub const MSIZE_32: u32 = 2 << 10;
    /// Channel priority level (PL, 2 bits, 3 = very high).
    pub const fn pl(level: u32) -> u32 {
        (level & 3) << 12
    }
    /// Memory-to-memory mode.
    pub const MEM2MEM: u32 = 1 << 14;
}

/// One item a channel moves for a request: read `from_bytes` at `from`,
/// write `to_bytes` at `to`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Transfer {
    /// Channel index (0 = channel 1).
    pub channel: usize,
    /// Source address (aligned to its size).
    pub from: u32,
    /// Source access size in bytes (1, 2, 4).
    pub from_bytes: u32,
    /// Destination address (aligned to its size).
    pub to: u32,
    /// Destination access size in bytes.
    pub to_bytes: u32,
}

impl Transfer {
    /// The value written for `read` (the source item): zero-extended or
    /// truncated to the destination's size (RM0008 table 76).
    pub fn value_written(&self, read: u32) -> u32 {
        let src = mask(self.from_bytes) & read;
        src & mask(self.to_bytes)
    }
}

fn mask(bytes: u32) -> u32 {
    match bytes {
        1 => 0xFF,
        2 => 0xFFFF,
        _ => 0xFFFF_FFFF,
    }
}

#[derive(Clone, Copy, Debug, Default)]
struct Channel {
    ccr: u32,
    cndtr: u32,
    reload: u32,
    cpar: u32,
    cmar: u32,
    pa: u32,
    ma: u32,
}

impl Channel {
    fn psize(&self) -> u32 {
        1 << ((self.ccr >> 8) & 3)
    }
    fn msize(&self) -> u32 {
        1 << ((self.ccr >> 10) & 3)
    }
    fn enabled(&self) -> bool {
        self.ccr & ccr::EN != 0
    }
}

/// The DMA1 controller's state.
#[derive(Clone, Debug, Default)]
pub struct Dma {
    isr: u32,
    ch: [Channel; CHANNELS],
    served: [u64; CHANNELS],
}

impl Dma {
    /// Reset state: every register 0.
    pub fn new() -> Self {
        Self::default()
    }

    /// The channel (0-based) whose request is served next among the
    /// requesting channels in `requests` (bit `n` = channel `n + 1`):
    /// enabled, items left, highest PL, then the lowest channel number
    /// (§13.3.2). `None`: nothing to do.
    pub fn next_transfer(&self, requests: u8) -> Option<Transfer> {
        let (i, c) = self
            .ch
            .iter()
            .enumerate()
            .filter(|(i, c)| requests & (1 << i) != 0 && c.enabled() && c.cndtr > 0)
            .max_by_key(|(i, c)| ((c.ccr >> 12) & 3, CHANNELS - i))?;
        let (ps, ms) = (c.psize(), c.msize());
        let (pa, ma) = (c.pa & !(ps - 1), c.ma & !(ms - 1));
        Some(if c.ccr & ccr::DIR == 0 {
            Transfer {
                channel: i,
                from: pa,
                from_bytes: ps,
                to: ma,
                to_bytes: ms,
            }
        } else {
            Transfer {
                channel: i,
                from: ma,
                from_bytes: ms,
                to: pa,
                to_bytes: ps,
            }
        })
    }

    /// The item of `channel` (0-based) moved: addresses step, CNDTR counts
    /// down, HT/TC flags, circular reload.
    pub fn complete(&mut self, channel: usize) {
        let Some(c) = self.ch.get_mut(channel) else {
            return;
        };
        if c.ccr & ccr::PINC != 0 {
            c.pa = c.pa.wrapping_add(c.psize());
        }
        if c.ccr & ccr::MINC != 0 {
            c.ma = c.ma.wrapping_add(c.msize());
        }
        c.cndtr = c.cndtr.saturating_sub(1);
        let mut flags = 0;
        if c.cndtr == c.reload / 2 {
            flags |= isr::HTIF;
        }
        if c.cndtr == 0 {
            flags |= isr::TCIF;
            if c.ccr & ccr::CIRC != 0 {
                c.cndtr = c.reload;
                c.pa = c.cpar;
                c.ma = c.cmar;
            }
        }
        if let Some(s) = self.served.get_mut(channel) {
            *s += 1;
        }
        self.set_flags(channel, flags);
    }

    /// A bus error on the item of `channel`: TEIF, and the channel is
    /// disabled by hardware.
    pub fn bus_error(&mut self, channel: usize) {
        if let Some(c) = self.ch.get_mut(channel) {
            c.ccr &= !ccr::EN;
        }
        self.set_flags(channel, isr::TEIF);
    }

    fn set_flags(&mut self, channel: usize, flags: u32) {
        if flags != 0 {
            self.isr |= (flags | isr::GIF) << (4 * channel);
        }
    }

    /// Items each channel moved since reset.
    pub fn served(&self) -> [u64; CHANNELS] {
        self.served
    }

    /// The interrupt line of `channel` (0-based): a flag with its enable.
    pub fn irq(&self, channel: usize) -> bool {
        let Some(c) = self.ch.get(channel) else {
            return false;
        };
        let f = (self.isr >> (4 * channel)) & 0xF;
        (f & isr::TCIF != 0 && c.ccr & ccr::TCIE != 0)
            || (f & isr::HTIF != 0 && c.ccr & ccr::HTIE != 0)
            || (f & isr::TEIF != 0 && c.ccr & ccr::TEIE != 0)
    }

    /// Register read at `offset`; `None`: not a register.
    pub fn read(&self, offset: u32) -> Option<u32> {
        if offset == reg::ISR {
            return Some(self.isr);
        }
        if offset == reg::IFCR {
            return Some(0);
        }
        let (c, r) = Self::channel_reg(offset)?;
        let c = self.ch.get(c)?;
        Some(match r {
            0 => c.ccr,
            1 => c.cndtr,
            2 => c.cpar,
            3 => c.cmar,
            _ => return None,
        })
    }

    fn channel_reg(offset: u32) -> Option<(usize, u32)> {
        let o = offset.checked_sub(0x08)?;
        let (c, r) = ((o / 20) as usize, (o % 20) / 4);
        (c < CHANNELS && offset.is_multiple_of(4)).then_some((c, r))
    }

    /// Register write at `offset`. `None`: not a register; `Some(Err)`: a
    /// configuration the model does not have.
    pub fn write(&mut self, offset: u32, v: u32) -> Option<Result<(), String>> {
        if offset == reg::ISR {
            // Read-only.
            return Some(Ok(()));
        }
        if offset == reg::IFCR {
            for ch in 0..CHANNELS {
                let w = (v >> (4 * ch)) & 0xF;
                let clear = if w & isr::GIF != 0 { 0xF } else { w };
                self.isr &= !(clear << (4 * ch));
            }
            return Some(Ok(()));
        }
        let (i, r) = Self::channel_reg(offset)?;
        let c = self.ch.get_mut(i)?;
        let n = i + 1;
        match r {
            0 => {
                let v = v & 0x7FFF;
                if v & ccr::MEM2MEM != 0 {
                    return Some(Err(format!(
                        "DMA1 channel {n}: memory-to-memory mode not modelled"
                    )));
                }
                if (v >> 8) & 3 == 3 || (v >> 10) & 3 == 3 {
                    return Some(Err(format!(
                        "DMA1 channel {n}: reserved PSIZE/MSIZE 0b11 in CCR {v:#x}"
                    )));
                }
                let live = ccr::EN | ccr::TCIE | ccr::HTIE | ccr::TEIE;
                if c.enabled() && v & ccr::EN != 0 && (v ^ c.ccr) & !live != 0 {
                    return Some(Err(format!(
                        "DMA1 channel {n}: CCR changed from {:#x} to {v:#x} while enabled",
                        c.ccr
                    )));
                }
                if !c.enabled() && v & ccr::EN != 0 {
                    c.pa = c.cpar;
                    c.ma = c.cmar;
                }
                c.ccr = v;
            }
            // Written only while the channel is disabled (§13.4.4-6).
            1 if !c.enabled() => {
                c.cndtr = v & 0xFFFF;
                c.reload = c.cndtr;
            }
            2 if !c.enabled() => c.cpar = v,
            3 if !c.enabled() => c.cmar = v,
            1..=3 => {}
            _ => return None,
        }
        Some(Ok(()))
    }
}
