//! The host side of SEGGER RTT, as a debug probe does it: find the control
//! block, copy up-channel 0 out of target RAM and advance its read offset,
//! then decode the bytes with `defmt-decoder` into log lines.

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
const WR_OFF: u32 = 12;
const RD_OFF: u32 = 16;
const FLAGS: u32 = 20;

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
