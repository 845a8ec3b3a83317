//! The flight stack's integer units converted to the telemetry fields'
//! wire units: rounded to nearest, saturated at the field's range, no
//! floating point (the Cortex-M3 has no FPU).

/// π in Q16 radians (`π · 2¹⁶ = 205 887.4`), as `sensor_stack::angles`.
pub const PI_RAD_Q16: i32 = 205_887;
/// π in Q40 radians, rounded: the wrap into ±π works at 2⁻⁴⁰ rad so
/// that wrapping even 5 000 turns (the ends of an `i32` in Q16) moves an
/// angle by less than 3e-9 rad.
const PI_RAD_Q40: i64 = 3_454_217_652_358;
/// 2π in Q40 radians, rounded.
const TWO_PI_RAD_Q40: i64 = 6_908_435_304_715;
/// 2π in Q16 radians (411 774.9), rounded: only to count whole turns.
const TWO_PI_RAD_Q16: i32 = 411_775;

/// Largest attitude field, 1e-4 rad: π rounded down, so a sent angle is
/// never outside ±180° (the TBS specification's warning for 0x1E;
/// ArduPilot's CRSF telemetry clamps to the same ±31 415).
pub const ATTITUDE_LIMIT_E4_RAD: i16 = 31_415;

/// Largest used-capacity value sent, mAh (2²³ − 1). The field is 24 bits;
/// EdgeTX sign-extends it and ignores an all-ones value, so values from
/// 2²³ up would read negative there: all readers agree below.
pub const USED_MAH_LIMIT: u32 = 0x7F_FFFF;

/// Barometric altitude below which the packed field is 0, dm (−1000 m).
const ALT_MIN_DM: i64 = -10_000;
/// From this altitude the packed field is in metres with bit 15 set, dm
/// (`0x8000 − 10 000`: the dm form's largest value is 0x7FFF = 2276.7 m).
const ALT_METRE_FORM_DM: i64 = 0x8000 - 10_000;
/// Above this the packed field is 0xFFFE (32 766 m), dm: OpenTX and EdgeTX
/// take 0xFFFF as "no value" (the TBS specification's pack example).
const ALT_MAX_DM: i64 = 0x7FFE * 10 - 5;

/// `num / den` rounded to nearest, halves away from zero (`den > 0`).
const fn div_round(num: i64, den: i64) -> i64 {
    if num >= 0 {
        (num + den / 2) / den
    } else {
        (num - den / 2) / den
    }
}

/// Battery voltage, mV → the battery frame's 0.1 V (decivolt) field,
/// rounded to nearest and saturated at 32 767 dV (the field is read as a
/// signed 16-bit value by the crsf-wg description and by EdgeTX).
pub const fn voltage_dv(voltage_mv: u32) -> u16 {
    let dv = div_round(voltage_mv as i64, 100);
    if dv > i16::MAX as i64 {
        i16::MAX as u16
    } else {
        dv as u16
    }
}

/// Battery current, mA (positive discharging) → the battery frame's 0.1 A
/// (deciampere) field, rounded to nearest (halves away from zero) and
/// saturated at ±3276.7 A.
pub const fn current_da(current_ma: i32) -> i16 {
    let da = div_round(current_ma as i64, 100);
    if da > i16::MAX as i64 {
        i16::MAX
    } else if da < i16::MIN as i64 {
        i16::MIN
    } else {
        da as i16
    }
}

/// Capacity drawn from the pack, mAh, saturated at [`USED_MAH_LIMIT`].
pub const fn used_mah_u24(used_mah: u32) -> u32 {
    if used_mah > USED_MAH_LIMIT {
        USED_MAH_LIMIT
    } else {
        used_mah
    }
}

/// An angle in Q16 radians (`1.0 rad = 65 536`, the form of
/// `sensor_stack::angles::euler_q16`) → the attitude frame's field in
/// 1e-4 rad (100 µrad): wrapped into ±π, rounded to nearest (halves away
/// from zero) and clamped to ±[`ATTITUDE_LIMIT_E4_RAD`].
///
/// The result is within 0.5 field units (5e-5 rad) of the exact wrapped
/// angle (plus < 3e-9 rad from the wrap), except at the clamp.
///
/// ```
/// use rc_input::telemetry::{attitude_e4_rad, PI_RAD_Q16};
/// assert_eq!(attitude_e4_rad(0), 0);
/// assert_eq!(attitude_e4_rad(65_536), 10_000); // 1 rad
/// assert_eq!(attitude_e4_rad(PI_RAD_Q16 / 4), 7_854); // 45°: 0.785 398 rad
/// assert_eq!(attitude_e4_rad(-PI_RAD_Q16), -31_415);
/// ```
pub const fn attitude_e4_rad(angle_rad_q16: i32) -> i16 {
    // Whole turns by the 32-bit (hardware) division on Q16, then the rest
    // in Q40 (|a| < 2⁵⁵, no overflow) without a 64-bit division: it is
    // within 2π of zero, so one step brings it into [−π, π).
    let turns = (angle_rad_q16 / TWO_PI_RAD_Q16) as i64;
    let mut a = ((angle_rad_q16 as i64) << 24) - turns * TWO_PI_RAD_Q40;
    if a >= PI_RAD_Q40 {
        a -= TWO_PI_RAD_Q40;
    } else if a < -PI_RAD_Q40 {
        a += TWO_PI_RAD_Q40;
    }
    // |a| ≤ π · 2⁴⁰ < 2⁴² and 10 000 < 2¹⁴: the product stays below 2⁵⁶.
    let e4 = div_round(a * 10_000, 1 << 40);
    let limit = ATTITUDE_LIMIT_E4_RAD as i64;
    if e4 > limit {
        ATTITUDE_LIMIT_E4_RAD
    } else if e4 < -limit {
        -ATTITUDE_LIMIT_E4_RAD
    } else {
        e4 as i16
    }
}

/// Height above the take-off point, cm → the barometric-altitude frame's
/// packed 16-bit field, as the TBS specification's `get_altitude_packed`:
/// decimetres + 10 000 (bit 15 clear) from −1000.0 m up to 2276.7 m;
/// above, whole metres with bit 15 set, up to 32 766 m (0xFFFE); below
/// −1000 m, 0. Rounded to nearest, halves away from zero: to decimetres,
/// and in the metre form from the centimetres (rounding the decimetres
/// again, as the specification's example does, would be off by up to
/// 0.55 m).
///
/// ```
/// use rc_input::telemetry::altitude_packed;
/// // The crsf-wg description's examples: 10 m and −10 m.
/// assert_eq!(altitude_packed(1_000), 0x2774);
/// assert_eq!(altitude_packed(-1_000), 0x26AC);
/// ```
pub const fn altitude_packed(altitude_cm: i32) -> u16 {
    let dm = div_round(altitude_cm as i64, 10);
    if dm < ALT_MIN_DM {
        0
    } else if dm > ALT_MAX_DM {
        0xFFFE
    } else if dm < ALT_METRE_FORM_DM {
        (dm - ALT_MIN_DM) as u16
    } else {
        div_round(altitude_cm as i64, 100) as u16 | 0x8000
    }
}

/// The packed altitude field back in decimetres (the specification's
/// `get_altitude_dm`): bit 15 set, metres; clear, decimetres − 10 000.
pub const fn altitude_unpacked_dm(packed: u16) -> i32 {
    if packed & 0x8000 != 0 {
        (packed & 0x7FFF) as i32 * 10
    } else {
        packed as i32 - 10_000
    }
}

/// Vertical speed, cm/s (up positive), saturated to the 16-bit field.
pub const fn vertical_speed_cmps_i16(vertical_speed_cmps: i32) -> i16 {
    if vertical_speed_cmps > i16::MAX as i32 {
        i16::MAX
    } else if vertical_speed_cmps < i16::MIN as i32 {
        i16::MIN
    } else {
        vertical_speed_cmps as i16
    }
}
