//! A RAM model of the two parameter pages with the STM32F1's flash
//! semantics (RM0008 §3.3.3, PM0075 §2.3.3: a page erase sets every bit;
//! programming writes a half-word that must read 0xFFFF first, else the
//! controller sets PGERR and writes nothing, unless the value is 0x0000),
//! and an injected power cut:
//! the flash operation in progress at the cut leaves its cells undefined
//! (one of the [`ProgramCut`] / [`EraseCut`] patterns), and nothing after
//! it happens until [`RamFlash::power_on`].

use crate::store::{Page, ParamFlash, PAGE_SIZE};

/// What a half-word being programmed holds after a cut.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProgramCut {
    /// Nothing was programmed: the cell as it was (0xFFFF after the
    /// erase).
    Erased,
    /// The programming completed, but was not reported.
    Intended,
    /// Some of the bits to clear were cleared: `old & (intended | noise)`.
    Partial(u32),
    /// Any value at all (pseudo-random from the seed).
    Random(u32),
}

/// What a page being erased holds after a cut.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EraseCut {
    /// The erase had not started: the page as it was.
    Untouched,
    /// The erase completed, but was not reported: all 0xFF.
    Complete,
    /// The first half of the page erased, the rest as it was.
    FirstHalf,
    /// Some bits set: `old | noise` (pseudo-random from the seed).
    Partial(u32),
    /// Any bytes at all (pseudo-random from the seed).
    Random(u32),
}

/// A power cut at the `at_op`-th erase or program (0-based) after it is
/// armed, with what the interrupted operation leaves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PowerCut {
    /// Erases and programs that complete before the cut.
    pub at_op: u32,
    /// A cut program's half-word.
    pub program: ProgramCut,
    /// A cut erase's page.
    pub erase: EraseCut,
}

/// Errors of [`RamFlash`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RamFlashError {
    /// Beyond the page.
    OutOfBounds,
    /// Odd offset (the flash programs half-words).
    Unaligned,
    /// Programming a value other than 0x0000 into a half-word that is not
    /// 0xFFFF (the F1's PGERR).
    NotErased,
    /// The power is off (cut at or before this operation).
    PowerCut,
}

/// The two pages in RAM.
#[derive(Debug, Clone)]
pub struct RamFlash {
    /// `PARAMS_A` and `PARAMS_B`'s bytes.
    pub pages: [[u8; PAGE_SIZE]; 2],
    /// Erases per page (wear accounting).
    pub erases: [u32; 2],
    cut: Option<PowerCut>,
    ops: u32,
    off: bool,
}

impl Default for RamFlash {
    fn default() -> Self {
        Self {
            pages: [[0xFF; PAGE_SIZE]; 2],
            erases: [0; 2],
            cut: None,
            ops: 0,
            off: false,
        }
    }
}

/// xorshift32: deterministic noise for the undefined cells.
fn noise(seed: u32, salt: u32) -> u32 {
    let mut x = seed ^ salt.wrapping_mul(0x9E37_79B9) ^ 0x2545_F491;
    for _ in 0..3 {
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
    }
    x
}

impl RamFlash {
    /// Arms a power cut; operations count from now.
    pub fn arm(&mut self, cut: PowerCut) {
        self.cut = Some(cut);
        self.ops = 0;
    }

    /// Power back: operations work again, no cut armed.
    pub fn power_on(&mut self) {
        self.cut = None;
        self.off = false;
    }

    /// `true` once a cut has happened (until [`power_on`](Self::power_on)).
    pub fn is_off(&self) -> bool {
        self.off
    }

    fn page_mut(&mut self, page: Page) -> &mut [u8; PAGE_SIZE] {
        match page {
            Page::A => &mut self.pages[0],
            Page::B => &mut self.pages[1],
        }
    }

    /// Counts one erase or program; the cut's patterns if this one is cut.
    fn step(&mut self) -> Result<Option<PowerCut>, RamFlashError> {
        if self.off {
            return Err(RamFlashError::PowerCut);
        }
        let cut = self.cut.filter(|c| c.at_op == self.ops);
        self.ops = self.ops.saturating_add(1);
        if cut.is_some() {
            self.off = true;
        }
        Ok(cut)
    }

    fn erase_cut(bytes: &mut [u8; PAGE_SIZE], how: EraseCut) {
        for (i, b) in (0u32..).zip(bytes.iter_mut()) {
            *b = match how {
                EraseCut::Untouched => *b,
                EraseCut::Complete => 0xFF,
                EraseCut::FirstHalf if (i as usize) < PAGE_SIZE / 2 => 0xFF,
                EraseCut::FirstHalf => *b,
                EraseCut::Partial(seed) => *b | noise(seed, i) as u8,
                EraseCut::Random(seed) => noise(seed, i) as u8,
            };
        }
    }
}

impl ParamFlash for RamFlash {
    type Error = RamFlashError;

    fn erase_page(&mut self, page: Page) -> Result<(), RamFlashError> {
        let cut = self.step()?;
        let index = usize::from(page == Page::B);
        self.erases[index] = self.erases[index].saturating_add(1);
        let bytes = self.page_mut(page);
        match cut {
            Some(c) => {
                Self::erase_cut(bytes, c.erase);
                Err(RamFlashError::PowerCut)
            }
            None => {
                *bytes = [0xFF; PAGE_SIZE];
                Ok(())
            }
        }
    }

    fn program_halfword(
        &mut self,
        page: Page,
        offset: usize,
        value: u16,
    ) -> Result<(), RamFlashError> {
        if !offset.is_multiple_of(2) {
            return Err(RamFlashError::Unaligned);
        }
        if offset + 2 > PAGE_SIZE {
            return Err(RamFlashError::OutOfBounds);
        }
        let cut = self.step()?;
        let bytes = self.page_mut(page);
        let old = u16::from_le_bytes([bytes[offset], bytes[offset + 1]]);
        let (new, result) = match cut {
            None if old != 0xFFFF && value != 0 => return Err(RamFlashError::NotErased),
            None => (old & value, Ok(())),
            Some(c) => (
                cut_value(c.program, old, value, offset),
                Err(RamFlashError::PowerCut),
            ),
        };
        bytes[offset..offset + 2].copy_from_slice(&new.to_le_bytes());
        result
    }

    fn read(&mut self, page: Page, offset: usize, buf: &mut [u8]) -> Result<(), RamFlashError> {
        if self.off {
            return Err(RamFlashError::PowerCut);
        }
        let src = self
            .page_mut(page)
            .get(offset..offset.saturating_add(buf.len()))
            .ok_or(RamFlashError::OutOfBounds)?;
        buf.copy_from_slice(src);
        Ok(())
    }
}

/// What a cut program leaves in a half-word that held `old`.
fn cut_value(how: ProgramCut, old: u16, value: u16, offset: usize) -> u16 {
    match how {
        ProgramCut::Erased => old,
        ProgramCut::Intended => old & value,
        ProgramCut::Partial(seed) => old & (value | noise(seed, offset as u32) as u16),
        ProgramCut::Random(seed) => noise(seed, offset as u32) as u16,
    }
}
