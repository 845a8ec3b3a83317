//! Register addresses and bit fields (AK8963 datasheet, MS1356-E-02, §8).
//!
//! Bit-field constants are masks already shifted into position.

/// Fixed 7-bit I2C address of the AK8963 inside the MPU-9250 (CAD0 = CAD1 = 0).
pub const ADDRESS: u8 = 0x0C;

/// WIA: device ID, reads 0x48.
pub const WIA: u8 = 0x00;
/// INFO: device information (AKM internal).
pub const INFO: u8 = 0x01;
/// ST1: status 1 (DRDY, DOR).
pub const ST1: u8 = 0x02;
/// HXL: first byte of the measurement data (little-endian X, Y, Z).
pub const HXL: u8 = 0x03;
/// HZH: last measurement byte.
pub const HZH: u8 = 0x08;
/// ST2: status 2 (HOFL, BITM). Reading it ends the data read and unlocks the
/// data registers for the next measurement.
pub const ST2: u8 = 0x09;
/// CNTL1: control 1 (BIT, MODE).
pub const CNTL1: u8 = 0x0A;
/// CNTL2: control 2 (SRST).
pub const CNTL2: u8 = 0x0B;
/// ASTC: self-test control (SELF).
pub const ASTC: u8 = 0x0C;
/// I2CDIS: I2C disable (write 0x1B to disable I2C; never used here).
pub const I2CDIS: u8 = 0x0F;
/// ASAX: X-axis sensitivity adjustment (fuse ROM; readable only in fuse-ROM access mode).
pub const ASAX: u8 = 0x10;
/// ASAY: Y-axis sensitivity adjustment.
pub const ASAY: u8 = 0x11;
/// ASAZ: Z-axis sensitivity adjustment.
pub const ASAZ: u8 = 0x12;

/// WIA value of the AK8963.
pub const WIA_VALUE: u8 = 0x48;

/// Length of the ST1..ST2 block (ST1, the measurement, ST2).
pub const STATUS_BLOCK_LEN: usize = 8;
/// Length of the HXL..ST2 burst.
pub const MEASUREMENT_LEN: usize = 7;

/// ST1 bit 0: DRDY, data ready.
pub const ST1_DRDY: u8 = 1 << 0;
/// ST1 bit 1: DOR, data overrun (a measurement was skipped because the data
/// was not read in time; the data now present is still valid).
pub const ST1_DOR: u8 = 1 << 1;

/// ST2 bit 3: HOFL, magnetic sensor overflow (|X|+|Y|+|Z| > 4912 µT).
pub const ST2_HOFL: u8 = 1 << 3;
/// ST2 bit 4: BITM, mirror of CNTL1 BIT (1 = 16-bit output).
pub const ST2_BITM: u8 = 1 << 4;

/// CNTL1 bit 4: BIT, output bit setting (0 = 14-bit, 1 = 16-bit).
pub const CNTL1_BIT: u8 = 1 << 4;
/// CNTL1 MODE field mask (bits 3:0).
pub const CNTL1_MODE_MASK: u8 = 0b0000_1111;

/// MODE 0000: power-down.
pub const MODE_POWER_DOWN: u8 = 0b0000;
/// MODE 0001: single measurement.
pub const MODE_SINGLE: u8 = 0b0001;
/// MODE 0010: continuous measurement 1 (8 Hz).
pub const MODE_CONTINUOUS_1: u8 = 0b0010;
/// MODE 0110: continuous measurement 2 (100 Hz).
pub const MODE_CONTINUOUS_2: u8 = 0b0110;
/// MODE 0100: external trigger measurement.
pub const MODE_EXTERNAL_TRIGGER: u8 = 0b0100;
/// MODE 1000: self-test.
pub const MODE_SELF_TEST: u8 = 0b1000;
/// MODE 1111: fuse ROM access.
pub const MODE_FUSE_ROM: u8 = 0b1111;

/// CNTL2 bit 0: SRST, soft reset (self-clearing).
pub const CNTL2_SRST: u8 = 1 << 0;

/// ASTC bit 6: SELF, generate the self-test magnetic field.
pub const ASTC_SELF: u8 = 1 << 6;
