//! RTT for the STM32F103CB build: defmt's up channel and a down channel
//! the debug probe writes what the user types into (`cargo embed`'s
//! terminal, Embed.toml's `cb` profile), both in one control block from
//! `rtt-target`, which is also defmt's logger here: one logger, one
//! control block (`_SEGGER_RTT`), as defmt-rtt gives the C8 build, plus
//! the down channel defmt-rtt does not make.
//!
//! Up channel 0 ("defmt", 1 KiB, defmt-rtt's size) starts in NoBlockSkip:
//! a frame that does not fit is dropped, the firmware never waits for the
//! host (Embed.toml says why). Down channel 0 ("console", 64 B) is read
//! by [`LineReader`], one line at a time.

use rtt_target::{ChannelMode, DownChannel};

/// The longest console line (bytes, without its end): `set NAME VALUE`
/// with the longest name and value fits with room to spare.
pub const LINE_BYTES: usize = 64;

/// Sets up the control block and makes its up channel defmt's; returns
/// the console's down channel. Call once, first thing in `init`: log
/// lines written before it are dropped.
pub fn init() -> DownChannel {
    let channels = rtt_target::rtt_init! {
        up: {
            0: { size: 1024, mode: ChannelMode::NoBlockSkip, name: "defmt" }
        }
        down: {
            0: { size: 64, name: "console" }
        }
    };
    rtt_target::set_defmt_channel(channels.up.0);
    channels.down.0
}

/// A console line, or why there is none.
#[derive(Debug, PartialEq, Eq)]
pub enum Line<'a> {
    /// A complete line (without its `\n` or `\r\n`), ASCII-checked.
    Text(&'a str),
    /// A line longer than [`LINE_BYTES`] or not ASCII: dropped whole.
    Rejected,
}

/// Assembles the down channel's bytes into lines.
pub struct LineReader {
    buf: [u8; LINE_BYTES],
    len: usize,
    bad: bool,
    pending: [u8; 16],
    pending_len: usize,
    pending_at: usize,
}

impl LineReader {
    /// An empty reader.
    pub const fn new() -> Self {
        Self {
            buf: [0; LINE_BYTES],
            len: 0,
            bad: false,
            pending: [0; 16],
            pending_len: 0,
            pending_at: 0,
        }
    }

    /// The next complete line from `down`, if one has arrived. Reads at
    /// most 16 bytes from the channel per call that finds none buffered.
    pub fn poll(&mut self, down: &mut DownChannel) -> Option<Line<'_>> {
        loop {
            if self.pending_at == self.pending_len {
                self.pending_len = down.read(&mut self.pending);
                self.pending_at = 0;
                if self.pending_len == 0 {
                    return None;
                }
            }
            let b = self.pending[self.pending_at];
            self.pending_at += 1;
            if b == b'\n' {
                let (len, bad) = (self.len, self.bad);
                self.len = 0;
                self.bad = false;
                return Some(self.finish(len, bad));
            }
            self.push(b);
        }
    }

    fn push(&mut self, b: u8) {
        if b == b'\r' {
            return;
        }
        match self.buf.get_mut(self.len) {
            Some(slot) if b.is_ascii() && !b.is_ascii_control() => {
                *slot = b;
                self.len += 1;
            }
            _ => self.bad = true,
        }
    }

    fn finish(&self, len: usize, bad: bool) -> Line<'_> {
        match (bad, core::str::from_utf8(&self.buf[..len])) {
            (false, Ok(s)) => Line::Text(s),
            _ => Line::Rejected,
        }
    }
}
