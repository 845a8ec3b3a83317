//! The text console's command processor: one line in, lines out, no heap
//! and no `core::fmt`.
//!
//! | command | does | while armed |
//! |---|---|---|
//! | `get NAME` | prints `set NAME VALUE # unit min..max, default D` | yes |
//! | `set NAME VALUE` | sets the value in RAM, echoes `set NAME VALUE` | refused |
//! | `save` | asks the caller to write the flash ([`Outcome::Save`]) | refused |
//! | `defaults` | every value back to its default in RAM | refused |
//! | `dump` | `set NAME VALUE` for every parameter | yes |
//! | `diff` | `set NAME VALUE` for those not at their default | yes |
//! | `help` | the commands, then every parameter's unit, range and help | yes |
//!
//! `dump`'s and `diff`'s lines can be pasted back: `#` starts a comment
//! and empty lines do nothing. Values are exact decimal text
//! ([`crate::fixed`]). Long outputs come one line at a time from a
//! [`Listing`], so a small RTT up buffer never has to hold more than one
//! line ([`MAX_LINE`] bytes).

use crate::fixed::{self, NumError};
use crate::store::{Page, SaveError, Saved};
use crate::table::{same, ParamError, ParamSet};
use crate::{ParamId, COUNT};

/// Longest line any command writes, newline included.
pub const MAX_LINE: usize = 96;

/// Where the processor writes its text (for example an RTT up channel or
/// a [`LineBuf`]).
pub trait Sink {
    /// Writes `bytes` (ASCII).
    fn put(&mut self, bytes: &[u8]);
}

/// A one-line [`Sink`] of [`MAX_LINE`] bytes; what does not fit is dropped
/// and [`LineBuf::truncated`] says so.
#[derive(Debug, Clone)]
pub struct LineBuf {
    buf: [u8; MAX_LINE],
    len: usize,
    truncated: bool,
}

impl Default for LineBuf {
    fn default() -> Self {
        Self {
            buf: [0; MAX_LINE],
            len: 0,
            truncated: false,
        }
    }
}

impl LineBuf {
    /// The bytes written since the last [`clear`](Self::clear).
    pub fn as_bytes(&self) -> &[u8] {
        self.buf.get(..self.len).unwrap_or(&[])
    }
    /// `true` if something did not fit.
    pub fn truncated(&self) -> bool {
        self.truncated
    }
    /// Empties the buffer.
    pub fn clear(&mut self) {
        self.len = 0;
        self.truncated = false;
    }
}

impl Sink for LineBuf {
    fn put(&mut self, bytes: &[u8]) {
        for &b in bytes {
            match self.buf.get_mut(self.len) {
                Some(slot) => {
                    *slot = b;
                    self.len += 1;
                }
                None => self.truncated = true,
            }
        }
    }
}

/// What the caller does after [`execute`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Nothing (the reply, if any, is written).
    Done,
    /// A value changed in RAM: apply it to what uses it.
    Changed(ParamId),
    /// Every value is back at its default in RAM: apply them.
    DefaultsLoaded,
    /// Write the values to flash (`store::save`), then [`report_save`].
    Save,
    /// More lines to write: one per [`Listing::next_line`].
    Listing(Listing),
}

/// Which listing a [`Listing`] writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ListKind {
    Dump,
    Diff,
    Help,
}

/// A resumable listing (`dump`, `diff`, `help`): each
/// [`next_line`](Self::next_line) writes one line, so the caller can emit
/// one per poll of a small output buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Listing {
    kind: ListKind,
    next: usize,
}

/// The commands, as `help` lists them before the parameters.
const COMMANDS: [&[u8]; 7] = [
    b"get NAME: value, unit, range, default\n",
    b"set NAME VALUE: change it (disarmed; save keeps it)\n",
    b"save: write to flash (disarmed)\n",
    b"defaults: all to defaults (disarmed)\n",
    b"dump: all as set lines\n",
    b"diff: those not at their default\n",
    b"help: this, then NAME unit MIN..MAX: help\n",
];

impl Listing {
    /// Writes the next line into `out`; `false` when the listing is done
    /// (nothing written).
    pub fn next_line(&mut self, params: &ParamSet, out: &mut impl Sink) -> bool {
        let line = match self.kind {
            ListKind::Help if self.next < COMMANDS.len() => {
                out.put(COMMANDS.get(self.next).copied().unwrap_or(b""));
                self.next += 1;
                return true;
            }
            ListKind::Help => self.next - COMMANDS.len(),
            ListKind::Dump | ListKind::Diff => self.next,
        };
        let skip_defaults = self.kind == ListKind::Diff;
        let found = (line..COUNT)
            .filter_map(ParamId::from_index)
            .find(|&id| !(skip_defaults && params.is_default(id)));
        let Some(id) = found else {
            return false;
        };
        self.next += id.index() - line + 1;
        match self.kind {
            ListKind::Help => write_help(id, out),
            ListKind::Dump | ListKind::Diff => write_set(id, params.get(id), out),
        }
        out.put(b"\n");
        true
    }
}

/// Runs one command line (without or with its `\n`/`\r\n`) on `params`;
/// `armed` refuses the commands that change or write them.
pub fn execute(line: &[u8], params: &mut ParamSet, armed: bool, out: &mut impl Sink) -> Outcome {
    let code = line.split(|&b| b == b'#').next().unwrap_or(&[]);
    let mut words = code
        .split(|b| b.is_ascii_whitespace())
        .filter(|w| !w.is_empty());
    let (Some(command), a, b, extra) = (words.next(), words.next(), words.next(), words.next())
    else {
        return Outcome::Done;
    };
    let Some(index) = COMMAND_NAMES.iter().position(|n| same(n, command)) else {
        return error(out, &[b"unknown command: ", command, b" (try help)"]);
    };
    let words = usize::from(a.is_some()) + usize::from(b.is_some()) + usize::from(extra.is_some());
    if COMMAND_WORDS.get(index) != Some(&words) {
        return error(out, &[b"usage: see help"]);
    }
    // set, save, defaults: nothing changes the values or the flash in flight.
    if (1..=3).contains(&index) && armed {
        return error(out, &[b"armed: disarm first"]);
    }
    let (name, text) = (a.unwrap_or(&[]), b.unwrap_or(&[]));
    match index {
        0 => get(name, params, out),
        1 => set(name, text, params, out),
        2 => Outcome::Save,
        3 => {
            *params = ParamSet::defaults();
            out.put(b"defaults loaded: save to keep them\n");
            Outcome::DefaultsLoaded
        }
        4 => listing(ListKind::Dump),
        5 => listing(ListKind::Diff),
        _ => listing(ListKind::Help),
    }
}

/// The commands [`execute`] knows, and the words each takes after it.
const COMMAND_NAMES: [&[u8]; 7] = [
    b"get",
    b"set",
    b"save",
    b"defaults",
    b"dump",
    b"diff",
    b"help",
];
const COMMAND_WORDS: [usize; 7] = [1, 2, 0, 0, 0, 0, 0];

fn listing(kind: ListKind) -> Outcome {
    Outcome::Listing(Listing { kind, next: 0 })
}

/// Writes `error: ` and the parts, a newline; [`Outcome::Done`].
fn error(out: &mut impl Sink, parts: &[&[u8]]) -> Outcome {
    out.put(b"error: ");
    for p in parts {
        out.put(p);
    }
    out.put(b"\n");
    Outcome::Done
}

fn lookup(name: &[u8], out: &mut impl Sink) -> Option<ParamId> {
    let id = ParamId::from_name(name);
    if id.is_none() {
        error(out, &[b"unknown name: ", name, b" (try help)"]);
    }
    id
}

fn get(name: &[u8], params: &ParamSet, out: &mut impl Sink) -> Outcome {
    if let Some(id) = lookup(name, out) {
        let p = id.param();
        write_set(id, params.get(id), out);
        out.put(b" # ");
        write_unit_range(id, out);
        out.put(b", default ");
        out.put(fixed::format(p.default, p.decimals).as_bytes());
        out.put(b"\n");
    }
    Outcome::Done
}

fn set(name: &[u8], text: &[u8], params: &mut ParamSet, out: &mut impl Sink) -> Outcome {
    let Some(id) = lookup(name, out) else {
        return Outcome::Done;
    };
    let p = id.param();
    let result = fixed::parse(text, p.decimals).map_err(Some).and_then(|v| {
        params
            .set(id, v)
            .map_err(|ParamError::OutOfRange { .. }| None)
    });
    let reason: &[u8] = match result {
        Ok(()) => {
            write_set(id, params.get(id), out);
            out.put(b"\n");
            return Outcome::Changed(id);
        }
        Err(Some(NumError::Empty | NumError::NotANumber)) => b": not a number: ",
        Err(Some(NumError::TooManyDecimals { .. })) => b": too many decimals: ",
        Err(_) if id == ParamId::ImuMount && p.in_range(parse_or_min(text, p.decimals)) => {
            b": not a rotation code: "
        }
        Err(_) => b": out of range: ",
    };
    out.put(b"error: ");
    out.put(p.name.as_bytes());
    out.put(reason);
    out.put(text);
    out.put(b" (");
    write_unit_range(id, out);
    out.put(b")\n");
    Outcome::Done
}

/// The value of `text`, or `i32::MIN` (out of every range) if it is none.
fn parse_or_min(text: &[u8], decimals: u8) -> i32 {
    fixed::parse(text, decimals).unwrap_or(i32::MIN)
}

/// `set NAME VALUE`, no newline.
fn write_set(id: ParamId, value: i32, out: &mut impl Sink) {
    out.put(b"set ");
    out.put(id.param().name.as_bytes());
    out.put(b" ");
    out.put(fixed::format(value, id.param().decimals).as_bytes());
}

/// `[unit ]MIN..MAX`, no newline.
fn write_unit_range(id: ParamId, out: &mut impl Sink) {
    let p = id.param();
    let unit = p.unit.as_str();
    if !unit.is_empty() {
        out.put(unit.as_bytes());
        out.put(b" ");
    }
    out.put(fixed::format(p.min, p.decimals).as_bytes());
    out.put(b"..");
    out.put(fixed::format(p.max, p.decimals).as_bytes());
}

/// `NAME [unit ]MIN..MAX: help`, no newline.
fn write_help(id: ParamId, out: &mut impl Sink) {
    out.put(id.param().name.as_bytes());
    out.put(b" ");
    write_unit_range(id, out);
    out.put(b": ");
    out.put(id.param().help.as_bytes());
}

/// The reply to `save` once the caller ran `store::save`.
pub fn report_save<E>(result: &Result<Saved, SaveError<E>>, out: &mut impl Sink) {
    match result {
        Ok(Saved { page: Page::A, .. }) => out.put(b"saved (PARAMS_A)\n"),
        Ok(Saved { page: Page::B, .. }) => out.put(b"saved (PARAMS_B)\n"),
        Err(SaveError::Flash(_)) => {
            out.put(b"error: save failed: flash error (values kept in RAM)\n")
        }
        Err(SaveError::VerifyFailed) => {
            out.put(b"error: save failed: read-back differs (values kept in RAM)\n")
        }
    }
}

/// Assembles command lines from the bytes a console receives: a line ends
/// at `\n` or `\r`; a line longer than `N` bytes is reported once and
/// dropped.
#[derive(Debug, Clone)]
pub struct LineReader<const N: usize> {
    buf: [u8; N],
    len: usize,
    overflow: bool,
    done: bool,
}

impl<const N: usize> Default for LineReader<N> {
    fn default() -> Self {
        Self {
            buf: [0; N],
            len: 0,
            overflow: false,
            done: false,
        }
    }
}

/// A line from [`LineReader::push`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Line<'a> {
    /// A complete line, without its end.
    Complete(&'a [u8]),
    /// A line longer than the reader holds: dropped.
    TooLong,
}

impl<const N: usize> LineReader<N> {
    /// Takes one received byte; a line when it ends one.
    pub fn push(&mut self, byte: u8) -> Option<Line<'_>> {
        if self.done {
            self.len = 0;
            self.overflow = false;
            self.done = false;
        }
        if byte == b'\n' || byte == b'\r' {
            self.done = true;
            return Some(if self.overflow {
                Line::TooLong
            } else {
                Line::Complete(self.buf.get(..self.len).unwrap_or(&[]))
            });
        }
        match self.buf.get_mut(self.len) {
            Some(slot) => {
                *slot = byte;
                self.len += 1;
            }
            None => self.overflow = true,
        }
        None
    }
}
