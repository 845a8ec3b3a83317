//! The settings console of the STM32F103CB build: lines typed into
//! `cargo embed`'s terminal arrive on the RTT down channel (`rtt.rs`), run
//! through `params::console` (get, set, save, defaults, dump, diff, help),
//! and the replies go out as log lines. `save` writes the A/B parameter
//! pages, then restarts the board: the values apply at boot, as
//! Betaflight's CLI `save` does (refused while armed, by the console; the
//! erase stalls the CPU 20–40 ms, which only a disarmed craft can spare).
//!
//! Besides the table's commands, `vbat VOLTS` sets `batt.scale` from one
//! multimeter reading of the pack (`battery::scale_from_reading` on the
//! filtered ADC reading), then `save` keeps it.

use battery::scale_from_reading;
use params::console::{self, LineBuf, LineReader, Listing, Outcome, Sink};
use params::{ParamId, ParamSet};
use rtt_target::DownChannel;
use stm32f1xx_hal::flash;

use crate::store::ParamPages;

/// Input bytes read from the channel per poll (its size: 64 B).
const READ_BYTES: usize = 64;
/// Listing lines per poll: 8 lines of ≤ 96 B in each 50 ms fit the 1 KiB
/// up channel with room for the log.
const LINES_PER_POLL: u8 = 8;

/// A reply line, as text (the console writes ASCII only).
fn emit(line: &LineBuf) {
    let b = line.as_bytes();
    let b = b.strip_suffix(b"\n").unwrap_or(b);
    defmt::println!("{=str}", core::str::from_utf8(b).unwrap_or("(not text)"));
}

/// Sends each finished line to the log as it comes.
struct LogSink(LineBuf);

impl Sink for LogSink {
    fn put(&mut self, bytes: &[u8]) {
        self.0.put(bytes);
        if bytes.ends_with(b"\n") {
            emit(&self.0);
            self.0.clear();
        }
    }
}

impl LogSink {
    /// Emits what is left without its newline.
    fn flush(&mut self) {
        if !self.0.as_bytes().is_empty() {
            emit(&self.0);
            self.0.clear();
        }
    }
}

/// The console's state: the down channel, the line being typed, the
/// values being edited (those the board booted with, until `save`), and a
/// listing being written.
pub struct Console {
    down: DownChannel,
    reader: LineReader<96>,
    params: ParamSet,
    listing: Option<Listing>,
}

/// What the caller does after a poll.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum After {
    /// Nothing.
    Continue,
    /// The values are saved: restart to apply them.
    Restart,
}

impl Console {
    /// The console over `down`, editing `params`.
    pub fn new(down: DownChannel, params: ParamSet) -> Self {
        Self {
            down,
            reader: LineReader::default(),
            params,
            listing: None,
        }
    }

    /// Runs the lines that arrived (and continues a listing). `armed`
    /// refuses the commands that change values; `filtered_counts` is the
    /// battery monitor's reading for `vbat`.
    pub fn poll(
        &mut self,
        flash: &mut flash::Parts,
        armed: bool,
        filtered_counts: Option<u16>,
    ) -> After {
        let mut out = LogSink(LineBuf::default());
        self.continue_listing(&mut out);
        let mut bytes = [0u8; READ_BYTES];
        let n = self.down.read(&mut bytes);
        let mut after = After::Continue;
        for &b in bytes.get(..n).unwrap_or(&[]) {
            let Some(line) = self.reader.push(b) else {
                continue;
            };
            let outcome = match line {
                console::Line::Complete(l) if l.starts_with(b"vbat ") => {
                    vbat(&mut self.params, l, armed, filtered_counts, &mut out);
                    Outcome::Done
                }
                console::Line::Complete(l) => {
                    console::execute(l, &mut self.params, armed, &mut out)
                }
                console::Line::TooLong => {
                    out.put(b"error: line too long\n");
                    Outcome::Done
                }
            };
            // A later line in the same read never cancels a restart.
            if self.on_outcome(outcome, flash, &mut out) == After::Restart {
                after = After::Restart;
            }
        }
        out.flush();
        after
    }

    fn on_outcome(&mut self, o: Outcome, flash: &mut flash::Parts, out: &mut LogSink) -> After {
        match o {
            Outcome::Listing(l) => {
                self.listing = Some(l);
                self.continue_listing(out);
            }
            Outcome::Save => {
                if let Err(why) = self.params.validate(settings::IMU_RATE_HZ) {
                    out.put(b"error: not saved: ");
                    out.put(why.as_bytes());
                    out.put(b"\n");
                    return After::Continue;
                }
                let r = params::store::save(&mut ParamPages::new(flash), &self.params);
                console::report_save(&r, out);
                if r.is_ok() {
                    out.put(b"restarting to apply\n");
                    return After::Restart;
                }
            }
            Outcome::Changed(_) | Outcome::DefaultsLoaded => {
                out.put(b"(save to keep and apply)\n");
            }
            Outcome::Done => {}
        }
        After::Continue
    }

    fn continue_listing(&mut self, out: &mut LogSink) {
        for _ in 0..LINES_PER_POLL {
            let Some(l) = self.listing.as_mut() else {
                return;
            };
            if !l.next_line(&self.params, out) {
                self.listing = None;
            }
        }
    }
}

/// `vbat VOLTS`: the divider ratio that makes the filtered reading read
/// VOLTS, into `batt.scale`.
fn vbat(params: &mut ParamSet, line: &[u8], armed: bool, counts: Option<u16>, out: &mut impl Sink) {
    if armed {
        return out.put(b"error: refused while armed\n");
    }
    let text = line.get(5..).unwrap_or(&[]);
    let Ok(mv) = params::fixed::parse(text.trim_ascii(), 3) else {
        return out.put(b"error: vbat VOLTS, e.g. vbat 12.34\n");
    };
    let Some(counts) = counts else {
        return out.put(b"error: no battery reading yet\n");
    };
    let Ok(scale) = scale_from_reading(counts, mv.max(0) as u32) else {
        return out.put(b"error: reading out of range for the divider\n");
    };
    // `batt.scale` is pack volts per pin volt, 3 decimals: the scale is
    // pack mV at full scale (3300 mV at the pin).
    let ratio_milli = (scale.full_scale_mv() as u64 * 1000 / 3300) as i32;
    match params.set(ParamId::BattScale, ratio_milli) {
        Ok(()) => {
            out.put(b"set batt.scale ");
            out.put(params::fixed::format(ratio_milli, 3).as_bytes());
            out.put(b" (save to keep and apply)\n");
        }
        Err(_) => out.put(b"error: the ratio is out of batt.scale's range\n"),
    }
}
