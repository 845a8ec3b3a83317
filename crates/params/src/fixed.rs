//! Exact decimal text for scaled integers, without floating point or
//! `core::fmt` (both cost flash on a Cortex-M3 without an FPU).
//!
//! A value with `decimals` digits after the point is the integer
//! `value × 10^decimals`: with 4 decimals, `"0.0045"` is 45 and 45 prints
//! as `"0.0045"`. [`format`] always prints every decimal; [`parse`] takes
//! fewer (`"0.25"` is 2500 with 4 decimals) and more only when the extra
//! digits are zeros (`"0.25000"`), so every printed value parses back to
//! itself and nothing is silently rounded.

/// Most decimals [`format`] and [`parse`] handle: 10⁹ is the largest power
/// of ten an `i32` holds.
pub const MAX_DECIMALS: u8 = 9;

/// Longest text [`format`] produces: a sign, ten digits and the point.
pub const MAX_TEXT: usize = 12;

/// Why a text is not a value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NumError {
    /// Nothing to parse.
    Empty,
    /// Not an optional sign, digits and at most one decimal point with at
    /// least one digit (no exponent, no spaces inside).
    NotANumber,
    /// A non-zero digit beyond the value's decimals.
    TooManyDecimals {
        /// The decimals the value has.
        max: u8,
    },
    /// Beyond what an `i32` holds at this scale (certainly out of range).
    TooLarge,
}

/// A formatted value: up to [`MAX_TEXT`] ASCII bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Text {
    buf: [u8; MAX_TEXT],
    len: u8,
}

impl Text {
    /// The text's bytes (ASCII).
    pub fn as_bytes(&self) -> &[u8] {
        self.buf.get(..usize::from(self.len)).unwrap_or(&[])
    }
}

/// `value / 10^decimals` as decimal text, every decimal printed
/// (`format(-125, 1)` is `"-12.5"`, `format(5, 3)` is `"0.005"`).
/// `decimals` above [`MAX_DECIMALS`] print as [`MAX_DECIMALS`].
pub fn format(value: i32, decimals: u8) -> Text {
    let decimals = usize::from(decimals.min(MAX_DECIMALS));
    // Digits least significant first; at least one before the point.
    let mut digits = [b'0'; 10];
    let mut n = value.unsigned_abs();
    let mut count = 0;
    for d in digits.iter_mut() {
        *d = b'0' + (n % 10) as u8;
        n /= 10;
        count += 1;
        if n == 0 {
            break;
        }
    }
    let count = count.max(decimals + 1);
    let mut out = Text {
        buf: [0; MAX_TEXT],
        len: 0,
    };
    if value < 0 {
        out.push(b'-');
    }
    for i in (0..count).rev() {
        if i + 1 == decimals {
            out.push(b'.');
        }
        out.push(digits.get(i).copied().unwrap_or(b'0'));
    }
    out
}

impl Text {
    fn push(&mut self, b: u8) {
        if let Some(slot) = self.buf.get_mut(usize::from(self.len)) {
            *slot = b;
            self.len += 1;
        }
    }
}

/// The scaled integer of a decimal text: `parse(b"-12.5", 1)` is −125,
/// `parse(b"0.045", 4)` is 450. An optional `+` or `-`, digits, and an
/// optional point with more digits; at least one digit.
///
/// # Errors
/// [`NumError`]: empty, not a number, a non-zero digit past `decimals`, or
/// beyond an `i32`.
pub fn parse(text: &[u8], decimals: u8) -> Result<i32, NumError> {
    let decimals = decimals.min(MAX_DECIMALS);
    let (negative, body) = match text.split_first() {
        None => return Err(NumError::Empty),
        Some((b'-', rest)) => (true, rest),
        Some((b'+', rest)) => (false, rest),
        Some(_) => (false, text),
    };
    let mut magnitude: u32 = 0;
    let mut seen_digit = false;
    let mut seen_point = false;
    let mut fraction: u8 = 0;
    for &c in body {
        match c {
            b'.' if !seen_point => seen_point = true,
            b'0'..=b'9' => {
                seen_digit = true;
                if seen_point && fraction == decimals {
                    // Past the value's decimals only zeros are exact.
                    if c != b'0' {
                        return Err(NumError::TooManyDecimals { max: decimals });
                    }
                    continue;
                }
                magnitude = push_digit(magnitude, c - b'0')?;
                fraction += u8::from(seen_point);
            }
            _ => return Err(NumError::NotANumber),
        }
    }
    if !seen_digit {
        return Err(NumError::NotANumber);
    }
    for _ in fraction..decimals {
        magnitude = push_digit(magnitude, 0)?;
    }
    signed(magnitude, negative)
}

/// `magnitude · 10 + digit`, at most 2³¹ (the magnitude of `i32::MIN`).
fn push_digit(magnitude: u32, digit: u8) -> Result<u32, NumError> {
    magnitude
        .checked_mul(10)
        .and_then(|m| m.checked_add(u32::from(digit)))
        .filter(|&m| m <= 1 << 31)
        .ok_or(NumError::TooLarge)
}

fn signed(magnitude: u32, negative: bool) -> Result<i32, NumError> {
    if negative {
        // 2³¹ is i32::MIN's magnitude: wrapping_neg of it as i32 is itself.
        Ok((magnitude as i32).wrapping_neg())
    } else {
        i32::try_from(magnitude).map_err(|_| NumError::TooLarge)
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use proptest::prelude::*;
    use std::string::String;

    fn text(value: i32, decimals: u8) -> String {
        String::from_utf8(format(value, decimals).as_bytes().to_vec()).unwrap_or_default()
    }

    #[test]
    fn formats_like_written_decimals() {
        assert_eq!(text(45, 4), "0.0045");
        assert_eq!(text(-125, 1), "-12.5");
        assert_eq!(text(350, 0), "350");
        assert_eq!(text(0, 0), "0");
        assert_eq!(text(0, 3), "0.000");
        assert_eq!(text(-5, 3), "-0.005");
        assert_eq!(text(11000, 3), "11.000");
        assert_eq!(text(i32::MIN, 0), "-2147483648");
        assert_eq!(text(i32::MIN, 9), "-2.147483648");
        assert_eq!(text(i32::MAX, 4), "214748.3647");
        assert_eq!(text(-1, 9), "-0.000000001");
        assert_eq!(text(-1, 9).len(), MAX_TEXT);
    }

    #[test]
    fn parses_written_decimals_exactly() {
        assert_eq!(parse(b"0.045", 4), Ok(450));
        assert_eq!(parse(b"0.0045", 4), Ok(45));
        assert_eq!(parse(b"-12.5", 1), Ok(-125));
        assert_eq!(parse(b"-12.5", 3), Ok(-12_500));
        assert_eq!(parse(b"350", 0), Ok(350));
        assert_eq!(parse(b"+3", 2), Ok(300));
        assert_eq!(parse(b".5", 1), Ok(5));
        assert_eq!(parse(b"5.", 1), Ok(50));
        assert_eq!(parse(b"0.25000", 4), Ok(2500));
        assert_eq!(parse(b"-0", 2), Ok(0));
        assert_eq!(parse(b"-2147483648", 0), Ok(i32::MIN));
        assert_eq!(parse(b"2147483647", 0), Ok(i32::MAX));
    }

    #[test]
    fn refuses_what_is_not_an_exact_value() {
        assert_eq!(parse(b"", 2), Err(NumError::Empty));
        for bad in [
            &b"-"[..],
            b".",
            b"+.",
            b"1.2.3",
            b"1e3",
            b"0x10",
            b"1 2",
            b"--1",
            b"abc",
            b"1,5",
        ] {
            assert_eq!(parse(bad, 2), Err(NumError::NotANumber), "{bad:?}");
        }
        assert_eq!(
            parse(b"0.00451", 4),
            Err(NumError::TooManyDecimals { max: 4 })
        );
        assert_eq!(parse(b"1.5", 0), Err(NumError::TooManyDecimals { max: 0 }));
        assert_eq!(parse(b"2147483648", 0), Err(NumError::TooLarge));
        assert_eq!(parse(b"-2147483649", 0), Err(NumError::TooLarge));
        assert_eq!(parse(b"214749", 4), Err(NumError::TooLarge));
        assert_eq!(parse(b"99999999999999999999", 0), Err(NumError::TooLarge));
    }

    proptest! {
        #[test]
        fn format_then_parse_is_the_identity(value in any::<i32>(), decimals in 0u8..=MAX_DECIMALS) {
            let t = format(value, decimals);
            prop_assert!(t.as_bytes().len() <= MAX_TEXT);
            prop_assert_eq!(parse(t.as_bytes(), decimals), Ok(value));
        }

        #[test]
        fn parse_agrees_with_exact_rational_arithmetic(
            int in -99_999i64..=99_999, frac in 0u32..10_000, decimals in 0u8..=4,
        ) {
            // "int.frac" with frac written on 4 digits: its value times
            // 10^decimals is an integer iff the dropped digits are zeros
            // (every magnitude here is below 10⁹, inside an i32).
            let s = std::format!("{}{}.{:04}", if int < 0 { "-" } else { "" }, int.abs(), frac);
            let scaled_e4 = (int.abs() * 10_000 + i64::from(frac)) * if int < 0 { -1 } else { 1 };
            let div = 10i64.pow(u32::from(4 - decimals));
            let expect = if scaled_e4 % div == 0 {
                Ok((scaled_e4 / div) as i32)
            } else {
                Err(NumError::TooManyDecimals { max: decimals })
            };
            prop_assert_eq!(parse(s.as_bytes(), decimals), expect);
        }
    }
}
