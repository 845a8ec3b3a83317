//! CRSF telemetry out of USART1 TX (PA9) by DMA1 channel 4 (USART1_TX,
//! RM0008 §13.3.7 table 78): a frame is handed to the DMA and leaves the
//! pin at 420 kbaud while the CPU does other work (a 12-byte frame takes
//! 286 µs on the wire; written byte by byte it would cost an interrupt
//! per byte). Which frame goes when is `rc_input::telemetry`'s.
//!
//! The transmitter shares USART1 with the receiver (`receiver.rs`), which
//! enables TE and DMAT in the same CR1/CR3 writes that start reception;
//! this module touches only DMA1 channel 4's registers, its IFCR bits and
//! its own buffer. Sequence (§27.3.13 "Transmission using DMA"): channel
//! disabled, CMAR/CNDTR set, channel enabled; the USART's TXE requests
//! move the bytes into DR. A frame is started only when the last one has
//! left DR (CNDTR = 0, or the channel never ran): frames are never cut or
//! interleaved.

use core::sync::atomic::{compiler_fence, Ordering};
use stm32f1xx_hal::pac;

/// The largest frame the buffer holds (CRSF's limit: 64 bytes; `init`'s
/// `tx_buf` local has this size).
pub const FRAME_BYTES: usize = 64;
/// DMA1 channel 4, index 3.
const CH4: usize = 3;
const CCR_EN: u32 = 1 << 0;
const CCR_DIR_FROM_MEMORY: u32 = 1 << 4;
const CCR_MINC: u32 = 1 << 7;
/// Priority medium: below the receiver's channel 5 (very high).
const CCR_PL_MEDIUM: u32 = 0b01 << 12;

/// The telemetry transmitter: DMA1 channel 4 and its frame buffer.
pub struct CrsfTx {
    buf: &'static mut [u8; FRAME_BYTES],
    ran: bool,
}

impl CrsfTx {
    /// Points DMA1 channel 4 from `buf` to USART1's DR (byte items,
    /// memory increment, no interrupt) and makes PA9 the USART's
    /// push-pull output (alternate function, 10 MHz: a 2.4 µs bit needs
    /// no faster edge). Call after the receiver's start, which clocks
    /// DMA1, GPIOA and USART1.
    pub fn start(buf: &'static mut [u8; FRAME_BYTES]) -> Self {
        // SAFETY: init-time writes to DMA1 channel 4's CPAR/CCR (disabled
        // at reset, so writable; no other code uses channel 4) and PA9's
        // CRH nibble (read-modify-write of that nibble only).
        #[allow(unsafe_code)]
        unsafe {
            let gpioa = &*pac::GPIOA::ptr();
            // CRH nibble 1 (PA9): MODE = 01 (10 MHz), CNF = 10 (AF push-pull).
            gpioa
                .crh()
                .modify(|r, w| w.bits((r.bits() & !(0xF << 4)) | (0b1001 << 4)));
            let usart = &*pac::USART1::ptr();
            let dma = &*pac::DMA1::ptr();
            let ch = dma.ch(CH4);
            ch.par().write(|w| w.bits(usart.dr().as_ptr() as u32));
            ch.cr()
                .write(|w| w.bits(CCR_DIR_FROM_MEMORY | CCR_MINC | CCR_PL_MEDIUM));
        }
        Self { buf, ran: false }
    }

    /// `true` while a frame is still being moved to the USART.
    pub fn busy(&self) -> bool {
        // SAFETY: a read of channel 4's CNDTR.
        #[allow(unsafe_code)]
        let left = unsafe { (*pac::DMA1::ptr()).ch(CH4).ndtr().read().bits() };
        self.ran && left != 0
    }

    /// Sends the first `len` bytes that `fill` writes into the buffer, if
    /// the last frame has gone; `fill` returns `len` (0: nothing to send).
    /// Returns whether a frame was started.
    pub fn send(&mut self, fill: impl FnOnce(&mut [u8; FRAME_BYTES]) -> usize) -> bool {
        if self.busy() {
            return false;
        }
        let len = fill(self.buf).min(FRAME_BYTES);
        if len == 0 {
            return false;
        }
        // The frame's bytes are in memory before the DMA may read them.
        compiler_fence(Ordering::SeqCst);
        // SAFETY: channel 4 is disabled before CMAR/CNDTR are written
        // (§13.4.4–13.4.6: writable only while disabled) and points into
        // `buf`, which this struct owns and does not touch again until the
        // channel is done (`busy`).
        #[allow(unsafe_code)]
        unsafe {
            let dma = &*pac::DMA1::ptr();
            let ch = dma.ch(CH4);
            let ccr = ch.cr().read().bits() & !CCR_EN;
            ch.cr().write(|w| w.bits(ccr));
            dma.ifcr().write(|w| w.cgif4().set_bit());
            ch.mar().write(|w| w.bits(self.buf.as_ptr() as u32));
            ch.ndtr().write(|w| w.bits(len as u32));
            ch.cr().write(|w| w.bits(ccr | CCR_EN));
        }
        self.ran = true;
        true
    }
}
