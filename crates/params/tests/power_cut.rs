//! The A/B record against power cuts: a save cut at every erase and every
//! half-word program, with the interrupted cell left undefined in several
//! ways, must leave a flash whose load gives the values before the save or
//! the values of the save, and nothing else.

// Tests may unwrap and panic (workspace rules).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use params::ram::{EraseCut, PowerCut, ProgramCut, RamFlash, RamFlashError};
use params::store::{
    self, decode, encode, is_newer, load, save, LoadOutcome, Page, PageError, ParamFlash,
    SaveError, HEADER_LEN, MAGIC, PAGE_SIZE, RECORD_LEN, TABLE_FINGERPRINT, VERSION,
};
use params::{ParamId, ParamSet, COUNT};

/// A set with every value moved off its default by `k` steps (within range).
fn values(k: i32) -> ParamSet {
    let mut set = ParamSet::defaults();
    for id in ParamId::ALL {
        let p = id.param();
        let v = p.min + (p.default - p.min + k).rem_euclid(p.max - p.min + 1);
        // The mounting takes rotation codes only: keep its default.
        let _ = set.set(id, v);
    }
    set
}

/// Erases and programs of one save: the erase and every half-word.
const OPS_PER_SAVE: u32 = 1 + (RECORD_LEN / 2) as u32;

const PROGRAM_CUTS: [ProgramCut; 6] = [
    ProgramCut::Erased,
    ProgramCut::Intended,
    ProgramCut::Partial(1),
    ProgramCut::Partial(0xDEAD_BEEF),
    ProgramCut::Random(7),
    ProgramCut::Random(0x1234_5678),
];

const ERASE_CUTS: [EraseCut; 6] = [
    EraseCut::Untouched,
    EraseCut::Complete,
    EraseCut::FirstHalf,
    EraseCut::Partial(3),
    EraseCut::Random(11),
    EraseCut::Random(0xCAFE_F00D),
];

/// The flashes a save may start from, with the values a load gives there.
fn starting_flashes() -> Vec<(&'static str, RamFlash)> {
    let blank = RamFlash::default();
    let mut a_only = RamFlash::default();
    save(&mut a_only, &values(1)).unwrap();
    let mut both = a_only.clone();
    save(&mut both, &values(2)).unwrap(); // B newer
    let mut both_a_newer = both.clone();
    save(&mut both_a_newer, &values(3)).unwrap(); // A newer
                                                  // Sequence numbers about to wrap: A at u32::MAX, B older.
    let mut wrap = RamFlash::default();
    write_record(&mut wrap, Page::B, &values(4), u32::MAX - 1);
    write_record(&mut wrap, Page::A, &values(5), u32::MAX);
    // B holds garbage, A a record.
    let mut garbage_b = a_only.clone();
    garbage_b.pages[1] = [0x5A; PAGE_SIZE];
    vec![
        ("blank", blank),
        ("A only", a_only),
        ("A and B, B newer", both),
        ("A and B, A newer", both_a_newer),
        ("sequence wrapping", wrap),
        ("A and garbage in B", garbage_b),
    ]
}

/// Erases `page` and programs a record with `sequence` into it.
fn write_record(flash: &mut RamFlash, page: Page, set: &ParamSet, sequence: u32) {
    let image = encode(set, sequence);
    flash.erase_page(page).unwrap();
    for (i, pair) in image.chunks_exact(2).enumerate() {
        flash
            .program_halfword(page, 2 * i, u16::from_le_bytes([pair[0], pair[1]]))
            .unwrap();
    }
}

#[test]
fn a_save_cut_at_any_point_leaves_the_old_or_the_new_values() {
    let new = values(9);
    let mut cases = 0u32;
    let (mut old_seen, mut new_seen) = (0u32, 0u32);
    for (name, start) in starting_flashes() {
        let old = load(&mut start.clone()).set();
        assert_ne!(old, new);
        for at_op in 0..OPS_PER_SAVE {
            for (program, erase) in PROGRAM_CUTS.iter().zip(ERASE_CUTS.iter()) {
                let mut flash = start.clone();
                flash.arm(PowerCut {
                    at_op,
                    program: *program,
                    erase: *erase,
                });
                let result = save(&mut flash, &new);
                assert_eq!(
                    result,
                    Err(SaveError::Flash(RamFlashError::PowerCut)),
                    "{name}: cut at op {at_op}"
                );
                flash.power_on();
                let got = load(&mut flash).set();
                let what = format!("{name}: cut at op {at_op}, {program:?}, {erase:?}");
                assert!(got == old || got == new, "{what}: neither old nor new");
                if got == new {
                    new_seen += 1;
                    // Only a completely programmed record is the new one:
                    // the cut was at its last half-word, the CRC's.
                    assert_eq!(at_op, OPS_PER_SAVE - 1, "{what}");
                } else {
                    old_seen += 1;
                }
                // Saving again after the power comes back works, and keeps
                // what the load found as the other copy.
                let again = values(10);
                save(&mut flash, &again).unwrap_or_else(|e| panic!("{what}: {e:?}"));
                assert_eq!(load(&mut flash).set(), again, "{what}");
                cases += 1;
            }
        }
    }
    // Every cut point of every start, six patterns each.
    assert_eq!(cases, 6 * OPS_PER_SAVE * 6);
    assert!(old_seen > 0 && new_seen > 0);
    println!("{cases} cuts: {old_seen} kept the old values, {new_seen} the new ones");
}

#[test]
fn every_erase_and_program_pattern_at_every_cut_point() {
    // The full cross product of patterns, from a start with both pages
    // valid (the save erases a page that held a valid older record).
    let new = values(20);
    let start = &starting_flashes()[2].1;
    let old = load(&mut start.clone()).set();
    for at_op in 0..OPS_PER_SAVE {
        for program in PROGRAM_CUTS {
            for erase in ERASE_CUTS {
                let mut flash = start.clone();
                flash.arm(PowerCut {
                    at_op,
                    program,
                    erase,
                });
                assert!(save(&mut flash, &new).is_err());
                flash.power_on();
                let got = load(&mut flash).set();
                assert!(
                    got == old || got == new,
                    "cut at op {at_op}, {program:?}, {erase:?}"
                );
            }
        }
    }
}

#[test]
fn a_cut_never_touches_the_newest_record() {
    for (name, start) in starting_flashes() {
        let before = load(&mut start.clone());
        let LoadOutcome::Stored { page, .. } = before else {
            continue;
        };
        for at_op in 0..OPS_PER_SAVE {
            let mut flash = start.clone();
            flash.arm(PowerCut {
                at_op,
                program: ProgramCut::Random(at_op),
                erase: EraseCut::Random(at_op),
            });
            let _ = save(&mut flash, &values(30));
            let index = usize::from(page == Page::B);
            assert_eq!(flash.pages[index], start.pages[index], "{name}, op {at_op}");
        }
    }
}

#[test]
fn saves_alternate_pages_with_rising_sequence_numbers() {
    let mut flash = RamFlash::default();
    assert!(matches!(
        load(&mut flash),
        LoadOutcome::Defaults {
            a: PageError::Blank,
            b: PageError::Blank
        }
    ));
    assert_eq!(load(&mut flash).set(), ParamSet::defaults());
    let mut pages = Vec::new();
    for k in 0..5 {
        let saved = save(&mut flash, &values(k)).unwrap();
        assert_eq!(saved.sequence, k as u32 + 1);
        pages.push(saved.page);
        match load(&mut flash) {
            LoadOutcome::Stored { page, record } => {
                assert_eq!((page, record.sequence), (saved.page, saved.sequence));
                assert_eq!(record.set, values(k));
            }
            other => panic!("{other:?}"),
        }
    }
    assert_eq!(pages, [Page::A, Page::B, Page::A, Page::B, Page::A]);
    assert_eq!(flash.erases, [3, 2], "wear spread over both pages");
}

#[test]
fn the_newer_sequence_wins_across_the_wrap() {
    assert!(is_newer(1, 0));
    assert!(is_newer(0, u32::MAX));
    assert!(is_newer(5, u32::MAX - 5));
    assert!(!is_newer(u32::MAX, 0));
    assert!(!is_newer(7, 7));
    let mut flash = RamFlash::default();
    write_record(&mut flash, Page::A, &values(1), u32::MAX);
    write_record(&mut flash, Page::B, &values(2), 0);
    assert_eq!(load(&mut flash).set(), values(2));
    let saved = save(&mut flash, &values(3)).unwrap();
    assert_eq!((saved.page, saved.sequence), (Page::A, 1));
    assert_eq!(load(&mut flash).set(), values(3));
}

#[test]
fn the_layout_is_as_documented() {
    assert_eq!(RECORD_LEN, 16 + 4 * COUNT + 4);
    assert_eq!(RECORD_LEN % 2, 0);
    let img = encode(&values(1), 0x0102_0304);
    assert_eq!(&img[0..4], b"FPRM");
    assert_eq!(u32::from_le_bytes(img[0..4].try_into().unwrap()), MAGIC);
    assert_eq!(u16::from_le_bytes([img[4], img[5]]), VERSION);
    assert_eq!(usize::from(u16::from_le_bytes([img[6], img[7]])), 4 * COUNT);
    assert_eq!(&img[8..12], &[4, 3, 2, 1]);
    assert_eq!(
        u32::from_le_bytes(img[12..16].try_into().unwrap()),
        TABLE_FINGERPRINT
    );
    for (i, id) in ParamId::ALL.iter().enumerate() {
        let at = HEADER_LEN + 4 * i;
        let v = i32::from_le_bytes(img[at..at + 4].try_into().unwrap());
        assert_eq!(v, values(1).get(*id));
    }
    let crc = u32::from_le_bytes(img[RECORD_LEN - 4..].try_into().unwrap());
    assert_eq!(crc, sensor_crc(&img[..RECORD_LEN - 4]));
    assert_eq!(Page::A.address(), 0x0800_F000);
    assert_eq!(Page::B.address(), 0x0800_F400);
}

/// CRC-32/IEEE bit by bit (the record's check, written independently).
fn sensor_crc(data: &[u8]) -> u32 {
    let mut crc = 0xFFFF_FFFFu32;
    for &b in data {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

#[test]
fn the_table_fingerprint_is_the_crc_of_the_names_and_decimals() {
    let mut bytes = Vec::new();
    for p in params::TABLE.iter() {
        bytes.extend_from_slice(p.name.as_bytes());
        bytes.push(0);
        bytes.push(p.decimals);
    }
    assert_eq!(TABLE_FINGERPRINT, sensor_crc(&bytes));
}

fn decode_err(img: &[u8]) -> PageError<()> {
    decode::<()>(img).unwrap_err()
}

#[test]
fn every_single_bit_flip_is_detected() {
    let img = encode(&values(1), 42);
    assert_eq!(
        decode::<()>(&img).map(|r| (r.sequence, r.set)),
        Ok((42, values(1)))
    );
    for byte in 0..RECORD_LEN {
        for bit in 0..8 {
            let mut bad = img;
            bad[byte] ^= 1 << bit;
            assert!(decode::<()>(&bad).is_err(), "flip at {byte}.{bit}");
        }
    }
}

#[test]
fn each_reason_a_page_is_refused() {
    assert_eq!(decode_err(&[0xFF; RECORD_LEN]), PageError::Blank);
    assert_eq!(decode_err(&[0xFF; RECORD_LEN - 1]), PageError::TooShort);
    let img = encode(&values(1), 1);
    let mut bad = img;
    bad[0] = b'X';
    assert_eq!(decode_err(&bad), PageError::BadMagic);
    let mut bad = img;
    bad[4] = 2;
    assert_eq!(decode_err(&bad), PageError::UnsupportedVersion { found: 2 });
    let mut bad = img;
    bad[6] = 0;
    assert!(matches!(decode_err(&bad), PageError::BadLength { .. }));
    let mut bad = img;
    bad[12] ^= 1;
    assert_eq!(decode_err(&bad), PageError::OtherTable);
    let mut bad = img;
    bad[HEADER_LEN] ^= 1;
    assert_eq!(decode_err(&bad), PageError::CrcMismatch);
    // A right CRC over a value out of its range (rate.roll.p = −1).
    let mut bad = img;
    bad[HEADER_LEN..HEADER_LEN + 4].copy_from_slice(&(-1i32).to_le_bytes());
    let crc = sensor_crc(&bad[..RECORD_LEN - 4]);
    bad[RECORD_LEN - 4..].copy_from_slice(&crc.to_le_bytes());
    assert_eq!(decode_err(&bad), PageError::OutOfRange(ParamId::RateRollP));
}

#[test]
fn another_version_gives_the_defaults_and_the_reasons() {
    let mut flash = RamFlash::default();
    save(&mut flash, &values(1)).unwrap();
    flash.pages[0][4] = 7; // PARAMS_A from a future format
    assert_eq!(
        load(&mut flash),
        LoadOutcome::Defaults {
            a: PageError::UnsupportedVersion { found: 7 },
            b: PageError::Blank
        }
    );
    // The next save writes the current format beside it, into A (no
    // valid record anywhere) and is read from then on.
    let saved = save(&mut flash, &values(2)).unwrap();
    assert_eq!((saved.page, saved.sequence), (Page::A, 1));
    assert_eq!(load(&mut flash).set(), values(2));
}

/// A flash whose page A reads one bit flipped at `bad` (a worn cell).
struct WornCell {
    inner: RamFlash,
    bad: usize,
}

impl ParamFlash for WornCell {
    type Error = RamFlashError;
    fn erase_page(&mut self, page: Page) -> Result<(), RamFlashError> {
        self.inner.erase_page(page)
    }
    fn program_halfword(
        &mut self,
        page: Page,
        offset: usize,
        value: u16,
    ) -> Result<(), RamFlashError> {
        self.inner.program_halfword(page, offset, value)
    }
    fn read(&mut self, page: Page, offset: usize, buf: &mut [u8]) -> Result<(), RamFlashError> {
        self.inner.read(page, offset, buf)?;
        if page == Page::A {
            if let Some(b) = self.bad.checked_sub(offset).and_then(|i| buf.get_mut(i)) {
                *b ^= 0x10;
            }
        }
        Ok(())
    }
}

#[test]
fn a_failed_read_back_is_reported_and_the_other_copy_kept() {
    let mut flash = RamFlash::default();
    save(&mut flash, &values(1)).unwrap(); // A
    save(&mut flash, &values(2)).unwrap(); // B, newest
    let mut worn = WornCell {
        inner: flash,
        bad: 30,
    };
    assert_eq!(save(&mut worn, &values(3)), Err(SaveError::VerifyFailed));
    assert_eq!(load(&mut worn).set(), values(2));
}

#[test]
fn the_flash_model_refuses_what_the_f1_refuses() {
    let mut flash = RamFlash::default();
    assert_eq!(
        flash.program_halfword(Page::A, 1, 0),
        Err(RamFlashError::Unaligned)
    );
    assert_eq!(
        flash.program_halfword(Page::A, PAGE_SIZE, 0),
        Err(RamFlashError::OutOfBounds)
    );
    flash.program_halfword(Page::A, 0, 0x1234).unwrap();
    assert_eq!(
        flash.program_halfword(Page::A, 0, 0x1234),
        Err(RamFlashError::NotErased)
    );
    let mut buf = [0u8; 2];
    flash.read(Page::A, 0, &mut buf).unwrap();
    assert_eq!(buf, [0x34, 0x12], "little-endian half-words");
    // 0x0000 may be written over anything (PM0075 §2.3.3).
    flash.program_halfword(Page::A, 0, 0).unwrap();
    flash.read(Page::A, 0, &mut buf).unwrap();
    assert_eq!(buf, [0, 0]);
    flash.erase_page(Page::A).unwrap();
    flash.read(Page::A, 0, &mut buf).unwrap();
    assert_eq!(buf, [0xFF, 0xFF]);
    // After a cut nothing works until the power is back.
    flash.arm(PowerCut {
        at_op: 0,
        program: ProgramCut::Erased,
        erase: EraseCut::Untouched,
    });
    assert!(flash.erase_page(Page::B).is_err());
    assert!(flash.is_off());
    assert_eq!(
        flash.read(Page::A, 0, &mut buf),
        Err(RamFlashError::PowerCut)
    );
    flash.power_on();
    assert!(flash.read(Page::A, 0, &mut buf).is_ok());
    let _ = store::read_page(&mut flash, Page::A);
}

mod histories {
    use super::*;
    use proptest::prelude::*;

    fn program_cut() -> impl Strategy<Value = ProgramCut> {
        prop_oneof![
            Just(ProgramCut::Erased),
            Just(ProgramCut::Intended),
            any::<u32>().prop_map(ProgramCut::Partial),
            any::<u32>().prop_map(ProgramCut::Random),
        ]
    }

    fn erase_cut() -> impl Strategy<Value = EraseCut> {
        prop_oneof![
            Just(EraseCut::Untouched),
            Just(EraseCut::Complete),
            Just(EraseCut::FirstHalf),
            any::<u32>().prop_map(EraseCut::Partial),
            any::<u32>().prop_map(EraseCut::Random),
        ]
    }

    proptest! {
        /// Saves, some cut, in any order: after each, the load gives the
        /// last completed save's values or the cut one's, never older ones.
        #[test]
        fn a_history_of_cut_saves_never_goes_back(
            steps in proptest::collection::vec(
                (0i32..1000, proptest::option::of((0..OPS_PER_SAVE, program_cut(), erase_cut()))),
                1..12,
            )
        ) {
            let mut flash = RamFlash::default();
            let mut last = ParamSet::defaults();
            for (k, cut) in steps {
                let new = values(k);
                if let Some((at_op, program, erase)) = cut {
                    flash.arm(PowerCut { at_op, program, erase });
                }
                let done = save(&mut flash, &new).is_ok();
                flash.power_on();
                let got = load(&mut flash).set();
                prop_assert!(got == last || got == new);
                prop_assert!(!done || got == new);
                last = got;
            }
        }
    }
}
