//! The parameters in flash: two 1 KiB pages (`PARAMS_A` at
//! [`Page::A`]`.address()`, `PARAMS_B` after it; `memory.x`'s flash plan),
//! each holding at most one record, so that a save cut by a power loss at
//! any point leaves the previous values readable.
//!
//! # Record layout
//!
//! Little-endian, [`RECORD_LEN`] bytes (even: the STM32F1 programs
//! half-words, RM0008 §3.3.3 / PM0075 §2.3.3):
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 4 | magic [`MAGIC`] (`"FPRM"`) |
//! | 4 | 2 | format version [`VERSION`] |
//! | 6 | 2 | payload length in bytes ([`PAYLOAD_LEN`]) |
//! | 8 | 4 | sequence number (the newer record has the larger one, modulo 2³²) |
//! | 12 | 4 | table fingerprint [`TABLE_FINGERPRINT`] (names, decimals, order) |
//! | 16 | 4·[`COUNT`] | the values, `i32`, in [`ParamId`] order |
//! | 16 + 4·`COUNT` | 4 | CRC-32/IEEE of every byte before it |
//!
//! # Save and load
//!
//! [`save`] reads both pages, erases the one that does not hold the newest
//! valid record (the older, or an invalid one), programs the new record
//! into it half-word by half-word with the sequence number one above the
//! newest, and reads it back. [`load`] reads both pages and takes the
//! valid record with the newer sequence number (wrap-safe: `a` is newer
//! than `b` when `a − b`, modulo 2³², is below 2³¹). A cut during a save
//! leaves the page being written without a valid record (its CRC covers
//! every byte, and the CRC itself is the last thing programmed) and the
//! other page as it was: the load finds the previous values. Only a
//! completed save makes the new record the newest.
//!
//! While the STM32F1's flash erases or programs, a fetch from it stalls
//! the core (PM0075 §2.3): a save (one page erase, 20–40 ms, and
//! [`RECORD_LEN`]/2 half-words at 40–70 µs each; DS5319 table 24) stops every task for about 25–50 ms, which is why the
//! console refuses it while armed and why the watchdog's period must
//! cover it.
//!
//! A record of another format version, or written for another table (a
//! firmware whose parameters differ), is not read: the load falls back to
//! the other page or to the defaults, and says why. There is no
//! migration; the next save writes the current format.

use crate::table::{ParamSet, TABLE};
use crate::{ParamId, COUNT};
use sensor_stack::crc32::crc32;

/// Record magic: the ASCII bytes `"FPRM"` read as a little-endian `u32`.
pub const MAGIC: u32 = u32::from_le_bytes(*b"FPRM");
/// Current record format version.
pub const VERSION: u16 = 1;
/// Header: magic, version, payload length, sequence, table fingerprint.
pub const HEADER_LEN: usize = 16;
/// Payload: one `i32` per parameter.
pub const PAYLOAD_LEN: usize = 4 * COUNT;
/// Whole record: header, payload, CRC-32.
pub const RECORD_LEN: usize = HEADER_LEN + PAYLOAD_LEN + 4;
/// Size of each of the two flash pages.
pub const PAGE_SIZE: usize = 1024;

const _: () = assert!(RECORD_LEN.is_multiple_of(2) && RECORD_LEN <= PAGE_SIZE);

/// CRC-32 of the table's shape: each name, a zero byte and its decimals,
/// in table order. A record written for a table with another shape (a
/// parameter added, removed, renamed, moved or rescaled) does not match.
pub const TABLE_FINGERPRINT: u32 = table_fingerprint();

const fn table_fingerprint() -> u32 {
    let mut crc = 0xFFFF_FFFFu32;
    let mut i = 0;
    while i < COUNT {
        let name = TABLE[i].name.as_bytes();
        let mut j = 0;
        while j < name.len() {
            crc = crc_byte(crc, name[j]);
            j += 1;
        }
        crc = crc_byte(crc, 0);
        crc = crc_byte(crc, TABLE[i].decimals);
        i += 1;
    }
    !crc
}

/// One byte into a CRC-32/IEEE register, bit by bit (compile time only).
const fn crc_byte(mut crc: u32, byte: u8) -> u32 {
    crc ^= byte as u32;
    let mut k = 0;
    while k < 8 {
        crc = if crc & 1 != 0 {
            (crc >> 1) ^ 0xEDB8_8320
        } else {
            crc >> 1
        };
        k += 1;
    }
    crc
}

/// One of the two parameter pages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Page {
    /// `PARAMS_A`.
    A,
    /// `PARAMS_B`.
    B,
}

impl Page {
    /// Absolute flash address of `PARAMS_A` on the STM32F103C8.
    pub const A_ADDRESS: u32 = 0x0800_F000;
    /// Absolute flash address of `PARAMS_B`.
    pub const B_ADDRESS: u32 = 0x0800_F400;

    /// The page's absolute flash address.
    pub fn address(self) -> u32 {
        match self {
            Self::A => Self::A_ADDRESS,
            Self::B => Self::B_ADDRESS,
        }
    }

    /// The other page.
    pub fn other(self) -> Self {
        match self {
            Self::A => Self::B,
            Self::B => Self::A,
        }
    }
}

/// The two parameter pages, with the STM32F1's flash semantics: an erase
/// sets a whole page to 0xFF; a half-word can be programmed once after it
/// (programming a half-word that is not 0xFFFF is an error, the F1's
/// PGERR, except for 0x0000; PM0075 §2.3.3). Offsets are bytes from the page's start.
pub trait ParamFlash {
    /// The flash's own error.
    type Error;
    /// Erases `page`.
    fn erase_page(&mut self, page: Page) -> Result<(), Self::Error>;
    /// Programs the half-word at the even `offset` of `page`
    /// (little-endian: the low byte at `offset`).
    fn program_halfword(
        &mut self,
        page: Page,
        offset: usize,
        value: u16,
    ) -> Result<(), Self::Error>;
    /// Reads `buf.len()` bytes of `page` from `offset`.
    fn read(&mut self, page: Page, offset: usize, buf: &mut [u8]) -> Result<(), Self::Error>;
}

/// A valid record.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Record {
    /// Its sequence number.
    pub sequence: u32,
    /// Its values.
    pub set: ParamSet,
}

/// Why a page holds no valid record.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PageError<E> {
    /// The page could not be read.
    Read(E),
    /// Fewer bytes than a record (only from [`decode`] of a short slice).
    TooShort,
    /// The header reads all 0xFF: never written (or erased).
    Blank,
    /// No parameter record (the magic is wrong).
    BadMagic,
    /// Another format version.
    UnsupportedVersion {
        /// The version found.
        found: u16,
    },
    /// The payload length is not this table's.
    BadLength {
        /// The length found.
        found: u16,
    },
    /// Written for another parameter table.
    OtherTable,
    /// The CRC does not match: a torn save or a corrupt page.
    CrcMismatch,
    /// The CRC is right but a value is out of its range.
    OutOfRange(ParamId),
}

/// Decodes a record image (at least [`RECORD_LEN`] bytes). Errors:
/// [`PageError`] other than `Read`.
pub fn decode<E>(image: &[u8]) -> Result<Record, PageError<E>> {
    let image = image.get(..RECORD_LEN).ok_or(PageError::TooShort)?;
    if image.iter().take(HEADER_LEN).all(|&b| b == 0xFF) {
        return Err(PageError::Blank);
    }
    if le_u32(image, 0) != MAGIC {
        return Err(PageError::BadMagic);
    }
    let version = le_u16(image, 4);
    if version != VERSION {
        return Err(PageError::UnsupportedVersion { found: version });
    }
    let len = le_u16(image, 6);
    if usize::from(len) != PAYLOAD_LEN {
        return Err(PageError::BadLength { found: len });
    }
    if le_u32(image, 12) != TABLE_FINGERPRINT {
        return Err(PageError::OtherTable);
    }
    let body = image.get(..RECORD_LEN - 4).unwrap_or(&[]);
    if crc32(body) != le_u32(image, RECORD_LEN - 4) {
        return Err(PageError::CrcMismatch);
    }
    let mut values = [0i32; COUNT];
    for (i, v) in values.iter_mut().enumerate() {
        *v = le_u32(image, HEADER_LEN + 4 * i) as i32;
    }
    let set = ParamSet::from_values(&values).map_err(|e| match e {
        crate::ParamError::OutOfRange { id, .. } => PageError::OutOfRange(id),
    })?;
    Ok(Record {
        sequence: le_u32(image, 8),
        set,
    })
}

/// The [`RECORD_LEN`]-byte image of `set` with `sequence`.
pub fn encode(set: &ParamSet, sequence: u32) -> [u8; RECORD_LEN] {
    let mut out = [0u8; RECORD_LEN];
    put(&mut out, 0, &MAGIC.to_le_bytes());
    put(&mut out, 4, &VERSION.to_le_bytes());
    put(&mut out, 6, &(PAYLOAD_LEN as u16).to_le_bytes());
    put(&mut out, 8, &sequence.to_le_bytes());
    put(&mut out, 12, &TABLE_FINGERPRINT.to_le_bytes());
    for (i, v) in set.values().iter().enumerate() {
        put(&mut out, HEADER_LEN + 4 * i, &v.to_le_bytes());
    }
    let crc = crc32(out.get(..RECORD_LEN - 4).unwrap_or(&[]));
    put(&mut out, RECORD_LEN - 4, &crc.to_le_bytes());
    out
}

/// Copies `bytes` to `buf[at..]` (element by element: `copy_from_slice`'s
/// length-mismatch panic links `core::fmt`).
fn put(buf: &mut [u8], at: usize, bytes: &[u8]) {
    for (d, s) in buf.iter_mut().skip(at).zip(bytes) {
        *d = *s;
    }
}

fn le_u16(buf: &[u8], at: usize) -> u16 {
    let b = |i: usize| buf.get(at + i).copied().unwrap_or(0);
    u16::from_le_bytes([b(0), b(1)])
}

fn le_u32(buf: &[u8], at: usize) -> u32 {
    u32::from(le_u16(buf, at)) | (u32::from(le_u16(buf, at + 2)) << 16)
}

/// Reads and decodes one page.
pub fn read_page<F: ParamFlash>(flash: &mut F, page: Page) -> Result<Record, PageError<F::Error>> {
    let mut image = [0u8; RECORD_LEN];
    flash.read(page, 0, &mut image).map_err(PageError::Read)?;
    decode(&image)
}

/// `true` if sequence `a` is newer than `b` (modulo 2³²).
pub fn is_newer(a: u32, b: u32) -> bool {
    (a.wrapping_sub(b) as i32) > 0
}

/// What [`load`] found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LoadOutcome<E> {
    /// A valid record: the newer of the two pages'.
    Stored {
        /// The page it was on.
        page: Page,
        /// Its record.
        record: Record,
    },
    /// No valid record: the defaults, and why each page was refused.
    Defaults {
        /// Why `PARAMS_A` was refused.
        a: PageError<E>,
        /// Why `PARAMS_B` was refused.
        b: PageError<E>,
    },
}

impl<E> LoadOutcome<E> {
    /// The values to use: the stored record's, or the defaults.
    pub fn set(&self) -> ParamSet {
        match self {
            Self::Stored { record, .. } => record.set,
            Self::Defaults { .. } => ParamSet::defaults(),
        }
    }

    /// The newest record's page and sequence number, if any.
    fn newest(&self) -> Option<(Page, u32)> {
        match self {
            Self::Stored { page, record } => Some((*page, record.sequence)),
            Self::Defaults { .. } => None,
        }
    }
}

/// Reads both pages and takes the newest valid record; never fails (no
/// valid record gives the defaults and both reasons).
pub fn load<F: ParamFlash>(flash: &mut F) -> LoadOutcome<F::Error> {
    match (read_page(flash, Page::A), read_page(flash, Page::B)) {
        (Ok(a), Ok(b)) if is_newer(b.sequence, a.sequence) => LoadOutcome::Stored {
            page: Page::B,
            record: b,
        },
        (Ok(a), _) => LoadOutcome::Stored {
            page: Page::A,
            record: a,
        },
        (Err(_), Ok(b)) => LoadOutcome::Stored {
            page: Page::B,
            record: b,
        },
        (Err(a), Err(b)) => LoadOutcome::Defaults { a, b },
    }
}

/// Why [`save`] failed. The page it wrote is then invalid and the other
/// page untouched, so [`load`] still finds the previous values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SaveError<E> {
    /// The flash failed (erase, program or read-back).
    Flash(E),
    /// The read-back differs from the record.
    VerifyFailed,
}

/// Where [`save`] wrote.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Saved {
    /// The page written.
    pub page: Page,
    /// The new record's sequence number.
    pub sequence: u32,
}

/// Writes `set` as the newest record into the page that does not hold the
/// current newest valid record; see the [module docs](self).
pub fn save<F: ParamFlash>(flash: &mut F, set: &ParamSet) -> Result<Saved, SaveError<F::Error>> {
    let (page, sequence) = match load(flash).newest() {
        Some((newest, seq)) => (newest.other(), seq.wrapping_add(1)),
        None => (Page::A, 1),
    };
    let image = encode(set, sequence);
    flash.erase_page(page).map_err(SaveError::Flash)?;
    for (i, pair) in image.chunks_exact(2).enumerate() {
        let value = u16::from_le_bytes([pair[0], pair[1]]);
        flash
            .program_halfword(page, 2 * i, value)
            .map_err(SaveError::Flash)?;
    }
    let mut back = [0u8; RECORD_LEN];
    flash.read(page, 0, &mut back).map_err(SaveError::Flash)?;
    // A byte loop, not `back != image`: the array comparison links `memcmp`.
    if back.iter().zip(&image).any(|(b, w)| b != w) {
        return Err(SaveError::VerifyFailed);
    }
    Ok(Saved { page, sequence })
}
