//! The calibration record kept in the reserved flash page (the last 1 KiB
//! page of the STM32F103C8, `0x0800_FC00`, see `memory.x`).
//!
//! Layout (little-endian, total [`RECORD_LEN`] bytes, even so it can be
//! programmed in half-words):
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 4 | magic [`MAGIC`] (`"FCAL"`) |
//! | 4 | 2 | format version [`VERSION`] |
//! | 6 | 2 | payload length in bytes ([`PAYLOAD_LEN`]) |
//! | 8 | 88 | payload: valid-parts flags u16, mounting code u16, 21 × f32 |
//! | 96 | 4 | CRC-32/IEEE of bytes 0..96 |
//!
//! Payload `f32` order: gyro bias (°/s, MPU frame) ×3, accelerometer offset
//! (g, MPU frame) ×3, accelerometer scale ×3, magnetometer hard-iron offset
//! (µT, MPU frame) ×3, magnetometer soft-iron matrix (row-major) ×9.
//!
//! [`load`] never fails: a blank or corrupt page gives the defaults plus the
//! reason ([`LoadOutcome::Defaults`]). [`save`] erases, programs and reads
//! back the page.

use crate::crc32::crc32;
use crate::mounting::{Mounting, MountingError};

/// Record magic: the ASCII bytes `"FCAL"` read as a little-endian `u32`.
pub const MAGIC: u32 = u32::from_le_bytes(*b"FCAL");
/// Current record format version.
pub const VERSION: u16 = 1;
/// Header: magic, version, payload length.
pub const HEADER_LEN: usize = 8;
/// Payload length of format version 1.
pub const PAYLOAD_LEN: usize = 4 + 21 * 4;
/// Whole record: header, payload, CRC-32.
pub const RECORD_LEN: usize = HEADER_LEN + PAYLOAD_LEN + 4;
/// Size of the flash page that holds the record.
pub const PAGE_SIZE: usize = 1024;
/// Absolute flash address of the calibration page on the STM32F103C8.
pub const PAGE_ADDRESS: u32 = 0x0800_FC00;

/// Which parts of a [`CalibrationRecord`] hold fitted (not default) values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ValidParts(pub u16);

impl ValidParts {
    /// Gyroscope bias was measured.
    pub const GYRO: u16 = 1;
    /// Accelerometer six-position fit was done.
    pub const ACCEL: u16 = 2;
    /// Magnetometer hard/soft iron fit was done.
    pub const MAG: u16 = 4;
    /// `true` if every bit of `part` is set.
    pub fn has(self, part: u16) -> bool {
        self.0 & part == part
    }
}

/// Persistent calibration values. All vectors are in the MPU sensor frame
/// (the magnetometer after `ak8963::to_mpu_frame`).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CalibrationRecord {
    /// Which parts were fitted.
    pub valid: ValidParts,
    /// MPU frame → body FRD.
    pub mounting: Mounting,
    /// Gyroscope bias, °/s (a fallback: the bias is re-measured at boot).
    pub gyro_bias_dps: [f32; 3],
    /// Accelerometer offset, g: `corrected = (raw − offset) · scale`.
    pub accel_offset_g: [f32; 3],
    /// Accelerometer per-axis scale factor (dimensionless, ≈ 1).
    pub accel_scale: [f32; 3],
    /// Magnetometer hard-iron offset, µT: `corrected = soft · (raw − offset)`.
    pub mag_offset_ut: [f32; 3],
    /// Magnetometer soft-iron matrix (row-major, dimensionless).
    pub mag_soft_iron: [[f32; 3]; 3],
}

impl Default for CalibrationRecord {
    fn default() -> Self {
        Self {
            valid: ValidParts(0),
            mounting: Mounting::default(),
            gyro_bias_dps: [0.0; 3],
            accel_offset_g: [0.0; 3],
            accel_scale: [1.0; 3],
            mag_offset_ut: [0.0; 3],
            mag_soft_iron: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        }
    }
}

/// A record field that holds an implausible value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Field {
    /// `gyro_bias_dps` (non-finite or |b| > 250 °/s).
    GyroBias,
    /// `accel_offset_g` (non-finite or |o| > 1 g).
    AccelOffset,
    /// `accel_scale` (non-finite or outside 0.5..2).
    AccelScale,
    /// `mag_offset_ut` (non-finite or |o| > 2000 µT).
    MagOffset,
    /// `mag_soft_iron` (non-finite or an element above 10 in magnitude).
    MagSoftIron,
    /// `mounting` (not a proper signed permutation).
    Mounting(MountingError),
}

/// Why a page did not decode to a record (the log writes it in words).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DecodeError {
    /// The page is erased (the header reads all 0xFF): never calibrated.
    Blank,
    /// Fewer bytes than a record.
    TooShort {
        /// Bytes available.
        len: usize,
    },
    /// The magic number is wrong: not a calibration record.
    BadMagic {
        /// The value found.
        found: u32,
    },
    /// Written by a firmware with another format.
    UnsupportedVersion {
        /// The version found.
        found: u16,
    },
    /// The payload length does not match this version.
    BadLength {
        /// The length found.
        found: u16,
    },
    /// The CRC does not match: the page is corrupt (torn write, bit rot).
    CrcMismatch {
        /// CRC stored in the page.
        stored: u32,
        /// CRC computed over header and payload.
        computed: u32,
    },
    /// The CRC is right but a value is implausible.
    InvalidValue(Field),
}

#[cfg(feature = "defmt")]
impl defmt::Format for DecodeError {
    fn format(&self, f: defmt::Formatter) {
        match *self {
            Self::Blank => defmt::write!(f, "the page is blank: never calibrated"),
            Self::TooShort { len } => defmt::write!(f, "the page is too short ({=usize} B)", len),
            Self::BadMagic { found } => defmt::write!(
                f,
                "the page holds no calibration record (magic {=u32:#x})",
                found
            ),
            Self::UnsupportedVersion { found } => defmt::write!(
                f,
                "the record is format version {=u16}, which this firmware does not read",
                found
            ),
            Self::BadLength { found } => defmt::write!(
                f,
                "the record's payload is {=u16} B, wrong for its version",
                found
            ),
            Self::CrcMismatch { stored, computed } => defmt::write!(
                f,
                "the record is corrupt (CRC stored {=u32:#x}, computed {=u32:#x})",
                stored,
                computed
            ),
            Self::InvalidValue(field) => {
                defmt::write!(f, "the record holds an implausible {}", field)
            }
        }
    }
}

/// Encodes a record into its [`RECORD_LEN`]-byte flash image.
///
/// ```
/// use sensor_stack::storage::{decode, encode, CalibrationRecord};
/// let rec = CalibrationRecord::default();
/// assert_eq!(decode(&encode(&rec)), Ok(rec));
/// ```
pub fn encode(rec: &CalibrationRecord) -> [u8; RECORD_LEN] {
    let mut out = [0u8; RECORD_LEN];
    let mut w = Writer {
        buf: &mut out,
        pos: 0,
    };
    w.put(&MAGIC.to_le_bytes());
    w.put(&VERSION.to_le_bytes());
    w.put(&(PAYLOAD_LEN as u16).to_le_bytes());
    w.put(&rec.valid.0.to_le_bytes());
    w.put(&rec.mounting.to_code().to_le_bytes());
    for v in floats(rec) {
        w.put(&v.to_le_bytes());
    }
    let crc = crc32(w.buf.get(..HEADER_LEN + PAYLOAD_LEN).unwrap_or(&[]));
    w.put(&crc.to_le_bytes());
    out
}

/// The 21 payload floats in storage order.
fn floats(rec: &CalibrationRecord) -> [f32; 21] {
    let mut f = [0.0f32; 21];
    let parts: [&[f32]; 7] = [
        &rec.gyro_bias_dps,
        &rec.accel_offset_g,
        &rec.accel_scale,
        &rec.mag_offset_ut,
        &rec.mag_soft_iron[0],
        &rec.mag_soft_iron[1],
        &rec.mag_soft_iron[2],
    ];
    for (dst, src) in f.iter_mut().zip(parts.iter().flat_map(|p| p.iter())) {
        *dst = *src;
    }
    f
}

struct Writer<'a> {
    buf: &'a mut [u8],
    pos: usize,
}

/// `dst.copy_from_slice(src)` for slices the caller already sized equal,
/// without its length-mismatch panic path (which links `core::fmt`, ~0.7 KiB
/// of flash on the firmware).
fn copy_bytes(dst: &mut [u8], src: &[u8]) {
    for (d, s) in dst.iter_mut().zip(src) {
        *d = *s;
    }
}

impl Writer<'_> {
    fn put(&mut self, bytes: &[u8]) {
        let end = self.pos.saturating_add(bytes.len());
        if let Some(dst) = self.buf.get_mut(self.pos..end) {
            copy_bytes(dst, bytes);
        }
        self.pos = end;
    }
}

struct Reader<'a> {
    buf: &'a [u8],
    pos: usize,
}

impl Reader<'_> {
    fn take<const N: usize>(&mut self) -> [u8; N] {
        let mut out = [0u8; N];
        let end = self.pos.saturating_add(N);
        if let Some(src) = self.buf.get(self.pos..end) {
            copy_bytes(&mut out, src);
        }
        self.pos = end;
        out
    }
    fn u16(&mut self) -> u16 {
        u16::from_le_bytes(self.take())
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }
    fn f32(&mut self) -> f32 {
        f32::from_le_bytes(self.take())
    }
    fn vec3(&mut self) -> [f32; 3] {
        [self.f32(), self.f32(), self.f32()]
    }
}

/// Decodes a flash image (at least [`RECORD_LEN`] bytes; a whole page is
/// fine) into a validated record.
pub fn decode(bytes: &[u8]) -> Result<CalibrationRecord, DecodeError> {
    let image = bytes
        .get(..RECORD_LEN)
        .ok_or(DecodeError::TooShort { len: bytes.len() })?;
    if image
        .get(..HEADER_LEN)
        .is_some_and(|h| h.iter().all(|&b| b == 0xFF))
    {
        return Err(DecodeError::Blank);
    }
    let mut r = Reader { buf: image, pos: 0 };
    let magic = r.u32();
    if magic != MAGIC {
        return Err(DecodeError::BadMagic { found: magic });
    }
    let version = r.u16();
    if version != VERSION {
        return Err(DecodeError::UnsupportedVersion { found: version });
    }
    let len = r.u16();
    if usize::from(len) != PAYLOAD_LEN {
        return Err(DecodeError::BadLength { found: len });
    }
    let computed = crc32(image.get(..HEADER_LEN + PAYLOAD_LEN).unwrap_or(&[]));
    let stored = u32::from_le_bytes(
        image
            .get(HEADER_LEN + PAYLOAD_LEN..RECORD_LEN)
            .and_then(|s| s.try_into().ok())
            .unwrap_or([0; 4]),
    );
    if stored != computed {
        return Err(DecodeError::CrcMismatch { stored, computed });
    }
    let valid = ValidParts(r.u16());
    let mounting =
        Mounting::from_code(r.u16()).map_err(|e| DecodeError::InvalidValue(Field::Mounting(e)))?;
    let rec = CalibrationRecord {
        valid,
        mounting,
        gyro_bias_dps: r.vec3(),
        accel_offset_g: r.vec3(),
        accel_scale: r.vec3(),
        mag_offset_ut: r.vec3(),
        mag_soft_iron: [r.vec3(), r.vec3(), r.vec3()],
    };
    validate(&rec).map_err(DecodeError::InvalidValue)?;
    Ok(rec)
}

fn within(v: &[f32], lo: f32, hi: f32) -> bool {
    v.iter().all(|x| x.is_finite() && *x >= lo && *x <= hi)
}

/// Checks that every value is finite and plausible.
pub fn validate(rec: &CalibrationRecord) -> Result<(), Field> {
    if !within(&rec.gyro_bias_dps, -250.0, 250.0) {
        return Err(Field::GyroBias);
    }
    if !within(&rec.accel_offset_g, -1.0, 1.0) {
        return Err(Field::AccelOffset);
    }
    if !within(&rec.accel_scale, 0.5, 2.0) {
        return Err(Field::AccelScale);
    }
    if !within(&rec.mag_offset_ut, -2000.0, 2000.0) {
        return Err(Field::MagOffset);
    }
    if !rec.mag_soft_iron.iter().all(|row| within(row, -10.0, 10.0)) {
        return Err(Field::MagSoftIron);
    }
    Ok(())
}

/// The flash page that holds the record. Offsets are relative to the page
/// start. Flash semantics: [`erase`](CalibrationStore::erase) sets every
/// byte to 0xFF; [`write`](CalibrationStore::write) programs half-words
/// (`offset` and `data.len()` even) into erased cells.
pub trait CalibrationStore {
    /// The storage's own error.
    type Error;
    /// Reads `buf.len()` bytes starting at `offset`.
    fn read(&mut self, offset: u32, buf: &mut [u8]) -> Result<(), Self::Error>;
    /// Erases the whole page.
    fn erase(&mut self) -> Result<(), Self::Error>;
    /// Programs `data` (even length) at the even `offset`.
    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), Self::Error>;
}

/// Why [`load`] fell back to the defaults.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LoadError<E> {
    /// The page could not be read.
    Storage(E),
    /// The page holds no valid record.
    Decode(DecodeError),
}

/// Result of [`load`]: always a usable record.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LoadOutcome<E> {
    /// The stored record decoded and validated.
    Loaded(CalibrationRecord),
    /// Defaults are in use; the reason says why.
    Defaults(CalibrationRecord, LoadError<E>),
}

impl<E> LoadOutcome<E> {
    /// The record to use (stored or defaults).
    pub fn record(&self) -> &CalibrationRecord {
        match self {
            Self::Loaded(r) | Self::Defaults(r, _) => r,
        }
    }
}

/// Reads and decodes the page; any failure falls back to the defaults and
/// reports why.
pub fn load<S: CalibrationStore>(store: &mut S) -> LoadOutcome<S::Error> {
    let mut image = [0u8; RECORD_LEN];
    match store.read(0, &mut image) {
        Err(e) => LoadOutcome::Defaults(CalibrationRecord::default(), LoadError::Storage(e)),
        Ok(()) => match decode(&image) {
            Ok(rec) => LoadOutcome::Loaded(rec),
            Err(e) => LoadOutcome::Defaults(CalibrationRecord::default(), LoadError::Decode(e)),
        },
    }
}

/// Why [`save`] failed. The previous record is lost once the erase ran, so
/// a failed save leaves a blank or corrupt page that [`load`] reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SaveError<E> {
    /// The record holds an implausible value; nothing was written.
    Invalid(Field),
    /// Erase, write or read-back failed in the storage.
    Storage(E),
    /// The read-back differs from what was written.
    VerifyFailed,
}

/// Validates, erases the page, programs the record and verifies it by
/// reading it back.
pub fn save<S: CalibrationStore>(
    store: &mut S,
    rec: &CalibrationRecord,
) -> Result<(), SaveError<S::Error>> {
    validate(rec).map_err(SaveError::Invalid)?;
    let image = encode(rec);
    store.erase().map_err(SaveError::Storage)?;
    store.write(0, &image).map_err(SaveError::Storage)?;
    let mut back = [0u8; RECORD_LEN];
    store.read(0, &mut back).map_err(SaveError::Storage)?;
    // A byte loop, not `back != image`: the array comparison links
    // `memcmp` (116 B) into firmware that compares nothing else in bulk.
    if back.iter().zip(&image).any(|(b, w)| b != w) {
        return Err(SaveError::VerifyFailed);
    }
    Ok(())
}

/// Errors of [`RamPage`], mirroring the STM32F1 flash controller's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RamPageError {
    /// Access beyond the page.
    OutOfBounds,
    /// Odd offset or length (flash programs half-words).
    Unaligned,
    /// Programming a half-word that is not erased (the F1's PGERR).
    NotErased,
    /// Injected failure.
    Injected,
}

/// A RAM model of a 1 KiB flash page with flash semantics, for host tests
/// and the simulator: erase → 0xFF, half-word programming only into erased
/// cells, optional injected failures and a torn write.
#[derive(Clone, Debug)]
pub struct RamPage {
    /// The page contents.
    pub bytes: [u8; PAGE_SIZE],
    /// When set, `write` programs only this many bytes and then fails
    /// (power loss mid-write).
    pub tear_after: Option<usize>,
    /// When set, every `read` fails.
    pub fail_reads: bool,
    /// Number of erases performed (wear accounting).
    pub erase_count: u32,
}

impl Default for RamPage {
    fn default() -> Self {
        Self {
            bytes: [0xFF; PAGE_SIZE],
            tear_after: None,
            fail_reads: false,
            erase_count: 0,
        }
    }
}

impl CalibrationStore for RamPage {
    type Error = RamPageError;

    fn read(&mut self, offset: u32, buf: &mut [u8]) -> Result<(), RamPageError> {
        if self.fail_reads {
            return Err(RamPageError::Injected);
        }
        let start = offset as usize;
        let src = self
            .bytes
            .get(start..start.saturating_add(buf.len()))
            .ok_or(RamPageError::OutOfBounds)?;
        buf.copy_from_slice(src);
        Ok(())
    }

    fn erase(&mut self) -> Result<(), RamPageError> {
        self.bytes = [0xFF; PAGE_SIZE];
        self.erase_count = self.erase_count.saturating_add(1);
        Ok(())
    }

    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), RamPageError> {
        let start = offset as usize;
        if !start.is_multiple_of(2) || !data.len().is_multiple_of(2) {
            return Err(RamPageError::Unaligned);
        }
        let dst = self
            .bytes
            .get_mut(start..start.saturating_add(data.len()))
            .ok_or(RamPageError::OutOfBounds)?;
        for (i, (d, s)) in dst
            .chunks_exact_mut(2)
            .zip(data.chunks_exact(2))
            .enumerate()
        {
            if self.tear_after.is_some_and(|t| i.saturating_mul(2) >= t) {
                return Err(RamPageError::Injected);
            }
            if d != [0xFF, 0xFF] {
                return Err(RamPageError::NotErased);
            }
            d.copy_from_slice(s);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> CalibrationRecord {
        CalibrationRecord {
            valid: ValidParts(ValidParts::GYRO | ValidParts::MAG),
            mounting: Mounting::default(),
            gyro_bias_dps: [0.5, -1.25, 2.0],
            accel_offset_g: [0.01, -0.02, 0.03],
            accel_scale: [1.01, 0.99, 1.002],
            mag_offset_ut: [12.5, -30.0, 4.0],
            mag_soft_iron: [[1.1, 0.02, 0.0], [0.02, 0.95, -0.01], [0.0, -0.01, 1.03]],
        }
    }

    #[test]
    fn layout_is_as_documented() {
        assert_eq!(RECORD_LEN, 100);
        assert_eq!(RECORD_LEN % 2, 0);
        let img = encode(&sample());
        assert_eq!(&img[0..4], b"FCAL");
        assert_eq!(u16::from_le_bytes([img[4], img[5]]), VERSION);
        assert_eq!(
            usize::from(u16::from_le_bytes([img[6], img[7]])),
            PAYLOAD_LEN
        );
        assert_eq!(f32::from_le_bytes(img[12..16].try_into().unwrap()), 0.5);
        let crc = u32::from_le_bytes(img[96..100].try_into().unwrap());
        assert_eq!(crc, crc32(&img[..96]));
    }

    #[test]
    fn roundtrip_and_every_single_bit_flip_is_detected() {
        let img = encode(&sample());
        assert_eq!(decode(&img), Ok(sample()));
        for byte in 0..RECORD_LEN {
            for bit in 0..8 {
                let mut bad = img;
                bad[byte] ^= 1 << bit;
                assert!(decode(&bad).is_err(), "flip at {byte}.{bit} undetected");
            }
        }
    }

    #[test]
    fn typed_errors() {
        assert_eq!(decode(&[0xFF; PAGE_SIZE]), Err(DecodeError::Blank));
        assert_eq!(decode(&[0u8; 10]), Err(DecodeError::TooShort { len: 10 }));
        let mut img = encode(&sample());
        img[0] = b'X';
        assert!(matches!(decode(&img), Err(DecodeError::BadMagic { .. })));
        let mut img = encode(&sample());
        img[4] = 9;
        assert_eq!(
            decode(&img),
            Err(DecodeError::UnsupportedVersion { found: 9 })
        );
        let mut img = encode(&sample());
        img[50] ^= 0x40;
        assert!(matches!(decode(&img), Err(DecodeError::CrcMismatch { .. })));
        // Valid CRC over an implausible value.
        let mut rec = sample();
        rec.accel_scale[1] = f32::NAN;
        assert_eq!(
            save(&mut RamPage::default(), &rec),
            Err(SaveError::Invalid(Field::AccelScale))
        );
        let mut img = encode(&rec);
        let crc = crc32(&img[..96]);
        img[96..].copy_from_slice(&crc.to_le_bytes());
        assert_eq!(
            decode(&img),
            Err(DecodeError::InvalidValue(Field::AccelScale))
        );
    }

    #[test]
    fn save_then_load() {
        let mut page = RamPage::default();
        assert!(matches!(
            load(&mut page),
            LoadOutcome::Defaults(_, LoadError::Decode(DecodeError::Blank))
        ));
        save(&mut page, &sample()).unwrap();
        assert_eq!(load(&mut page), LoadOutcome::Loaded(sample()));
        // Saving again erases first (flash cannot be re-programmed in place).
        let mut rec = sample();
        rec.gyro_bias_dps[0] = -3.0;
        save(&mut page, &rec).unwrap();
        assert_eq!(load(&mut page).record(), &rec);
        assert_eq!(page.erase_count, 2);
    }

    /// A page whose cell at `bad` reads back with one bit flipped (a worn
    /// flash cell).
    struct FlippedCell {
        page: RamPage,
        bad: usize,
    }

    impl CalibrationStore for FlippedCell {
        type Error = RamPageError;
        fn read(&mut self, offset: u32, buf: &mut [u8]) -> Result<(), RamPageError> {
            self.page.read(offset, buf)?;
            if let Some(b) = (self.bad.checked_sub(offset as usize)).and_then(|i| buf.get_mut(i)) {
                *b ^= 0x10;
            }
            Ok(())
        }
        fn erase(&mut self) -> Result<(), RamPageError> {
            self.page.erase()
        }
        fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), RamPageError> {
            self.page.write(offset, data)
        }
    }

    #[test]
    fn a_read_back_differing_in_any_byte_is_a_verify_failure() {
        for bad in [0, 1, RECORD_LEN / 2, RECORD_LEN - 1] {
            let mut store = FlippedCell {
                page: RamPage::default(),
                bad,
            };
            assert_eq!(
                save(&mut store, &sample()),
                Err(SaveError::VerifyFailed),
                "byte {bad}"
            );
        }
        // A flipped cell past the record is not part of it.
        let mut store = FlippedCell {
            page: RamPage::default(),
            bad: RECORD_LEN,
        };
        assert_eq!(save(&mut store, &sample()), Ok(()));
    }

    #[test]
    fn torn_write_and_read_failure_fall_back_with_reason() {
        let mut page = RamPage {
            tear_after: Some(40),
            ..RamPage::default()
        };
        assert_eq!(
            save(&mut page, &sample()),
            Err(SaveError::Storage(RamPageError::Injected))
        );
        page.tear_after = None;
        let out = load(&mut page);
        assert!(matches!(
            out,
            LoadOutcome::Defaults(_, LoadError::Decode(DecodeError::CrcMismatch { .. }))
        ));
        assert_eq!(out.record(), &CalibrationRecord::default());
        page.fail_reads = true;
        assert_eq!(
            load(&mut page),
            LoadOutcome::Defaults(
                CalibrationRecord::default(),
                LoadError::Storage(RamPageError::Injected)
            )
        );
    }

    #[test]
    fn ram_page_has_flash_semantics() {
        let mut page = RamPage::default();
        assert_eq!(page.write(1, &[0, 0]), Err(RamPageError::Unaligned));
        page.write(0, &[1, 2]).unwrap();
        assert_eq!(page.write(0, &[1, 2]), Err(RamPageError::NotErased));
        assert_eq!(
            page.write(1022, &[0, 0, 0, 0]),
            Err(RamPageError::OutOfBounds)
        );
    }
}
