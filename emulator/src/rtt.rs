//! The host side of SEGGER RTT, as a debug probe does it: find the control
//! block, copy up-channel 0 out of target RAM and advance its read offset,
//! then decode the bytes with `defmt-decoder` into log lines; and write
//! what a user types into a down channel ([`RttHost::write_down`]), as
//! `cargo embed`'s terminal does.
//!
//! The control block (SEGGER RTT's layout): the 16-byte id "SEGGER RTT",
//! MaxNumUpBuffers, MaxNumDownBuffers, then MaxNumUpBuffers up-buffer
//! descriptors followed by MaxNumDownBuffers down-buffer descriptors, each
//! six words: name pointer, buffer pointer, size, WrOff, RdOff, flags. On
//! a down channel the host owns WrOff and the target RdOff; the ring
//! holds at most size − 1 bytes (WrOff == RdOff is empty).

use defmt_decoder::{DecodeError, StreamDecoder, Table};

/// RTT up-channel operating mode (the `flags` word, low two bits).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RttMode {
    /// Drop the whole message when it does not fit.
    NoBlockSkip,
    /// Write what fits, drop the rest.
    NoBlockTrim,
    /// The target waits until the host makes room.
    BlockIfFull,
}

impl RttMode {
    fn flags(self) -> u32 {
        match self {
            Self::NoBlockSkip => 0,
            Self::NoBlockTrim => 1,
            Self::BlockIfFull => 2,
        }
    }

    /// Parses probe-rs's names (`Embed.toml` `mode = "..."`).
    pub fn from_name(s: &str) -> Option<Self> {
        Some(match s {
            "NoBlockSkip" => Self::NoBlockSkip,
            "NoBlockTrim" => Self::NoBlockTrim,
            "BlockIfFull" => Self::BlockIfFull,
            _ => return None,
        })
    }

    /// The mode `Embed.toml` at the workspace root asks for on channel 0
    /// (what `cargo embed` sets when it attaches); `None` if it sets none.
    pub fn from_embed_toml(text: &str) -> Option<Self> {
        let line = text
            .lines()
            .find(|l| l.contains("channel = 0") && l.contains("mode"))?;
        let rest = &line[line.find("mode")?..];
        let start = rest.find('"')? + 1;
        let end = start + rest[start..].find('"')?;
        Self::from_name(&rest[start..end])
    }
}

/// One decoded log line.
#[derive(Clone, Debug, PartialEq)]
pub struct LogLine {
    /// Simulated time at which the host read it (ns since power-on).
    pub host_time_ns: u64,
    /// Level (`None` for `println!`).
    pub level: Option<String>,
    /// The firmware's own timestamp, if its table has one.
    pub timestamp: Option<String>,
    /// The message.
    pub text: String,
}

impl std::fmt::Display for LogLine {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if let Some(t) = &self.timestamp {
            write!(f, "{t} ")?;
        }
        match &self.level {
            Some(l) => write!(f, "{:<5} {}", l.to_uppercase(), self.text),
            None => f.write_str(&self.text),
        }
    }
}

/// Offsets in the control block (SEGGER RTT: id[16], max up, max down,
/// then up-buffer descriptors of six words each).
const UP0: u32 = 24;
const MAX_UP: u32 = 16;
const MAX_DOWN: u32 = 20;
/// Bytes of one buffer descriptor.
const DESCRIPTOR: u32 = 24;
const BUFFER: u32 = 4;
const SIZE: u32 = 8;
const WR_OFF: u32 = 12;
const RD_OFF: u32 = 16;
const FLAGS: u32 = 20;

/// Why a write into a down channel did not happen.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum RttError {
    /// No "SEGGER RTT" id at the control block's address (the target has
    /// not initialised RTT yet, or the address is wrong).
    NoControlBlock {
        /// Where the host looked.
        address: u32,
    },
    /// The control block has fewer down channels than the one asked for
    /// (defmt-rtt alone creates none).
    NoDownChannel {
        /// The channel asked for.
        channel: u32,
        /// MaxNumDownBuffers of the control block.
        available: u32,
    },
    /// The descriptor is inconsistent (no buffer, size below 2, an offset
    /// outside the buffer) or target memory could not be accessed.
    BadDescriptor {
        /// The channel.
        channel: u32,
        /// What is wrong.
        what: String,
    },
}

impl std::fmt::Display for RttError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::NoControlBlock { address } => {
                write!(f, "no RTT control block at {address:#010x}")
            }
            Self::NoDownChannel { channel, available } => write!(
                f,
                "RTT down channel {channel} absent: the control block has {available} down channel(s)"
            ),
            Self::BadDescriptor { channel, what } => {
                write!(f, "RTT down channel {channel}: {what}")
            }
        }
    }
}

impl std::error::Error for RttError {}

/// The host reader for one board.
pub struct RttHost {
    address: u32,
    table: Option<&'static Table>,
    decoder: Option<Box<dyn StreamDecoder + Send + Sync>>,
    /// Set the channel mode at attach (as `cargo embed` does).
    pub mode: Option<RttMode>,
    attached: bool,
    /// Whether the host reads at all (false: the buffer fills up).
    pub reading: bool,
    /// Bytes that did not decode (malformed frames).
    pub malformed: u64,
}

/// Target memory as seen through the probe.
pub trait TargetMemory {
    /// Reads a word.
    fn read_u32(&mut self, addr: u32) -> Option<u32>;
    /// Writes a word.
    fn write_u32(&mut self, addr: u32, v: u32) -> Option<()>;
    /// Reads bytes.
    fn read_bytes(&mut self, addr: u32, buf: &mut [u8]) -> Option<()>;
    /// Writes bytes.
    fn write_bytes(&mut self, addr: u32, bytes: &[u8]) -> Option<()>;
}

impl RttHost {
    /// A reader for the control block at `address`.
    pub fn new(address: u32, table: Option<&'static Table>, mode: Option<RttMode>) -> Self {
        Self {
            address,
            table,
            decoder: table.map(|t| t.new_stream_decoder()),
            mode,
            attached: false,
            reading: true,
            malformed: 0,
        }
    }

    /// The target restarted: forget partial frames, attach again.
    pub fn target_reset(&mut self) {
        self.decoder = self.table.map(|t| t.new_stream_decoder());
        self.attached = false;
    }

    /// Reads what the target wrote since the last poll and returns the
    /// complete lines.
    pub fn poll(&mut self, mem: &mut impl TargetMemory, now_ns: u64) -> Vec<LogLine> {
        if !self.reading {
            return Vec::new();
        }
        let mut id = [0u8; 16];
        if mem.read_bytes(self.address, &mut id).is_none() || !id.starts_with(b"SEGGER RTT") {
            return Vec::new();
        }
        let ch = self.address + UP0;
        if !self.attached {
            self.attached = true;
            if let (Some(mode), Some(flags)) = (self.mode, mem.read_u32(ch + FLAGS)) {
                mem.write_u32(ch + FLAGS, (flags & !3) | mode.flags());
            }
        }
        let (Some(buf), Some(size), Some(wr), Some(rd)) = (
            mem.read_u32(ch + 4),
            mem.read_u32(ch + 8),
            mem.read_u32(ch + WR_OFF),
            mem.read_u32(ch + RD_OFF),
        ) else {
            return Vec::new();
        };
        if size == 0 || wr >= size || rd >= size || wr == rd {
            return Vec::new();
        }
        let mut bytes = Vec::new();
        let mut take = |from: u32, to: u32| {
            let mut chunk = vec![0u8; (to - from) as usize];
            if mem.read_bytes(buf + from, &mut chunk).is_some() {
                bytes.extend_from_slice(&chunk);
            }
        };
        if wr > rd {
            take(rd, wr);
        } else {
            take(rd, size);
            take(0, wr);
        }
        mem.write_u32(ch + RD_OFF, wr);
        let (Some(decoder), Some(table)) = (self.decoder.as_mut(), self.table) else {
            return Vec::new();
        };
        decoder.received(&bytes);
        let mut lines = Vec::new();
        loop {
            match decoder.decode() {
                Ok(frame) => lines.push(LogLine {
                    host_time_ns: now_ns,
                    level: frame.level().map(|l| l.as_str().to_owned()),
                    timestamp: frame.display_timestamp().map(|t| t.to_string()),
                    text: frame.display_message().to_string(),
                }),
                Err(DecodeError::UnexpectedEof) => break,
                Err(DecodeError::Malformed) => {
                    self.malformed += 1;
                    // The rzcobs decoder resynchronises on the next frame
                    // separator; a raw stream cannot.
                    if !table.encoding().can_recover() {
                        break;
                    }
                }
            }
        }
        lines
    }
}

impl RttHost {
    /// Writes `bytes` into down channel `channel` as a probe does: copies
    /// what fits into the ring after WrOff without passing RdOff (the
    /// target's unread bytes are never overwritten), then advances WrOff.
    /// Returns how many bytes went in (fewer than `bytes.len()`, down to 0,
    /// when the target has not read enough yet).
    pub fn write_down(
        &self,
        mem: &mut impl TargetMemory,
        channel: u32,
        bytes: &[u8],
    ) -> Result<usize, RttError> {
        let d = self.down_descriptor(mem, channel)?;
        let bad = |what: String| RttError::BadDescriptor { channel, what };
        let mut word = |off: u32| {
            mem.read_u32(d + off)
                .ok_or_else(|| bad(format!("descriptor word at +{off} unreadable")))
        };
        let (buf, size, wr, rd) = (word(BUFFER)?, word(SIZE)?, word(WR_OFF)?, word(RD_OFF)?);
        if buf == 0 || size < 2 || wr >= size || rd >= size {
            return Err(bad(format!(
                "buffer {buf:#010x}, size {size}, WrOff {wr}, RdOff {rd}"
            )));
        }
        // One slot stays empty so that WrOff == RdOff means empty.
        let free = (rd + size - wr - 1) % size;
        let n = bytes.len().min(free as usize);
        // Up to the end of the buffer, then the rest from its start.
        let first = n.min((size - wr) as usize);
        for (at, chunk) in [(wr, &bytes[..first]), (0, &bytes[first..n])] {
            if !chunk.is_empty() {
                mem.write_bytes(buf + at, chunk)
                    .ok_or_else(|| bad(format!("buffer at {:#010x} unwritable", buf + at)))?;
            }
        }
        if n > 0 {
            let new_wr = (wr + n as u32) % size;
            mem.write_u32(d + WR_OFF, new_wr)
                .ok_or_else(|| bad("WrOff unwritable".into()))?;
        }
        Ok(n)
    }

    /// Address of down channel `channel`'s descriptor.
    fn down_descriptor(&self, mem: &mut impl TargetMemory, channel: u32) -> Result<u32, RttError> {
        let mut id = [0u8; 16];
        if mem.read_bytes(self.address, &mut id).is_none() || !id.starts_with(b"SEGGER RTT") {
            return Err(RttError::NoControlBlock {
                address: self.address,
            });
        }
        let counts = (
            mem.read_u32(self.address + MAX_UP),
            mem.read_u32(self.address + MAX_DOWN),
        );
        let (Some(up), Some(down)) = counts else {
            return Err(RttError::NoControlBlock {
                address: self.address,
            });
        };
        if channel >= down {
            return Err(RttError::NoDownChannel {
                channel,
                available: down,
            });
        }
        Ok(self.address + UP0 + DESCRIPTOR * (up + channel))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn embed_toml_mode_is_read_from_channel_zero() {
        let t =
            "up_channels = [\n    { channel = 0, mode = \"BlockIfFull\", format = \"Defmt\" },\n]";
        assert_eq!(RttMode::from_embed_toml(t), Some(RttMode::BlockIfFull));
        assert_eq!(
            RttMode::from_embed_toml("[default.rtt]\nenabled = true"),
            None
        );
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::panic)]
mod down_channel_tests {
    use super::*;

    const CB: u32 = 0x2000_0000;
    const RAM: usize = 1024;

    /// Target RAM at `CB`.
    struct Ram(Vec<u8>);

    impl TargetMemory for Ram {
        fn read_u32(&mut self, addr: u32) -> Option<u32> {
            let mut b = [0u8; 4];
            self.read_bytes(addr, &mut b)?;
            Some(u32::from_le_bytes(b))
        }
        fn write_u32(&mut self, addr: u32, v: u32) -> Option<()> {
            self.write_bytes(addr, &v.to_le_bytes())
        }
        fn read_bytes(&mut self, addr: u32, buf: &mut [u8]) -> Option<()> {
            let o = addr.checked_sub(CB)? as usize;
            buf.copy_from_slice(self.0.get(o..o + buf.len())?);
            Some(())
        }
        fn write_bytes(&mut self, addr: u32, bytes: &[u8]) -> Option<()> {
            let o = addr.checked_sub(CB)? as usize;
            self.0.get_mut(o..o + bytes.len())?.copy_from_slice(bytes);
            Some(())
        }
    }

    /// A control block by hand in SEGGER's layout: `up` up channels, then
    /// `down` down channels of `size` bytes each, buffers from 0x200.
    fn control_block(up: u32, down: u32, size: u32) -> Ram {
        let mut m = Ram(vec![0; RAM]);
        m.write_bytes(CB, b"SEGGER RTT\0\0\0\0\0\0").unwrap();
        m.write_u32(CB + 16, up).unwrap();
        m.write_u32(CB + 20, down).unwrap();
        for i in 0..up + down {
            let d = CB + 24 + 24 * i;
            m.write_u32(d + 4, CB + 0x200 + i * size).unwrap();
            m.write_u32(d + 8, size).unwrap();
        }
        m
    }

    /// Down channel `ch`'s descriptor word at `off` (after one up channel).
    fn down_word(m: &mut Ram, ch: u32, off: u32) -> u32 {
        m.read_u32(CB + 24 + 24 * (1 + ch) + off).unwrap()
    }

    fn host() -> RttHost {
        RttHost::new(CB, None, None)
    }

    #[test]
    fn bytes_go_after_wroff_of_the_down_channel_asked_for() {
        let mut m = control_block(1, 2, 16);
        assert_eq!(host().write_down(&mut m, 1, b"get x\n"), Ok(6));
        assert_eq!(down_word(&mut m, 1, 12), 6, "WrOff advanced");
        assert_eq!(down_word(&mut m, 1, 16), 0, "RdOff is the target's");
        assert_eq!(down_word(&mut m, 0, 12), 0, "channel 0 untouched");
        let buf = down_word(&mut m, 1, 4);
        let mut got = [0u8; 6];
        m.read_bytes(buf, &mut got).unwrap();
        assert_eq!(&got, b"get x\n");
    }

    #[test]
    fn the_ring_wraps_and_never_passes_the_read_offset() {
        let mut m = control_block(1, 1, 8);
        let d = CB + 24 + 24;
        // The target has read up to 5; the host's last write ended at 6.
        m.write_u32(d + 12, 6).unwrap();
        m.write_u32(d + 16, 5).unwrap();
        // Free: 8 − 1 − (6 − 5) = 6 bytes: 6, 7, then 0..=3.
        assert_eq!(host().write_down(&mut m, 0, b"abcdefgh"), Ok(6));
        assert_eq!(down_word(&mut m, 0, 12), 4);
        let buf = down_word(&mut m, 0, 4);
        let mut ring = [0u8; 8];
        m.read_bytes(buf, &mut ring).unwrap();
        assert_eq!(&ring, b"cdef\0\0ab");
        // Full now (WrOff one behind RdOff): nothing goes in, WrOff stays.
        assert_eq!(host().write_down(&mut m, 0, b"z"), Ok(0));
        assert_eq!(down_word(&mut m, 0, 12), 4);
        // The target reads two more bytes: two slots free up.
        m.write_u32(d + 16, 7).unwrap();
        assert_eq!(host().write_down(&mut m, 0, b"xyz"), Ok(2));
        assert_eq!(down_word(&mut m, 0, 12), 6);
    }

    #[test]
    fn a_control_block_without_down_channels_is_a_clear_error() {
        // defmt-rtt's block: one up channel, no down channel.
        let mut m = control_block(1, 0, 16);
        let e = host().write_down(&mut m, 0, b"x").unwrap_err();
        assert_eq!(
            e,
            RttError::NoDownChannel {
                channel: 0,
                available: 0
            }
        );
        assert!(e.to_string().contains("absent"), "{e}");
        let mut blank = Ram(vec![0; RAM]);
        assert_eq!(
            host().write_down(&mut blank, 0, b"x"),
            Err(RttError::NoControlBlock { address: CB })
        );
    }

    #[test]
    fn an_inconsistent_descriptor_is_refused_without_writing() {
        let mut m = control_block(1, 1, 8);
        m.write_u32(CB + 48 + 16, 9).unwrap();
        assert!(matches!(
            host().write_down(&mut m, 0, b"x"),
            Err(RttError::BadDescriptor { channel: 0, .. })
        ));
        assert_eq!(down_word(&mut m, 0, 12), 0);
    }
}
