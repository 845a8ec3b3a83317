//! Register addresses and bit fields (MPU-9250 Register Map and Descriptions, rev 1.6).
//!
//! Only the registers this driver touches are listed. Bit-field constants are
//! masks already shifted into position unless their name ends in `_SHIFT`.

/// SMPLRT_DIV (25): sample rate divider. Effective only when FCHOICE = 0b11
/// (GYRO_CONFIG FCHOICE_B = 0b00) and 0 < DLPF_CFG < 7:
/// `SAMPLE_RATE = INTERNAL_SAMPLE_RATE / (1 + SMPLRT_DIV)` with 1 kHz internal rate.
pub const SMPLRT_DIV: u8 = 0x19;
/// CONFIG (26): FIFO_MODE, EXT_SYNC_SET, DLPF_CFG.
pub const CONFIG: u8 = 0x1A;
/// GYRO_CONFIG (27): self-test, GYRO_FS_SEL, FCHOICE_B.
pub const GYRO_CONFIG: u8 = 0x1B;
/// ACCEL_CONFIG (28): self-test, ACCEL_FS_SEL.
pub const ACCEL_CONFIG: u8 = 0x1C;
/// ACCEL_CONFIG 2 (29): ACCEL_FCHOICE_B, A_DLPF_CFG.
pub const ACCEL_CONFIG2: u8 = 0x1D;
/// SELF_TEST_X_GYRO (0): factory self-test code of the gyro x axis (y, z follow).
pub const SELF_TEST_X_GYRO: u8 = 0x00;
/// SELF_TEST_X_ACCEL (13): factory self-test code of the accel x axis (y, z follow).
pub const SELF_TEST_X_ACCEL: u8 = 0x0D;
/// FIFO_EN (35): which data the FIFO records.
pub const FIFO_EN: u8 = 0x23;
/// I2C_MST_CTRL (36): internal I2C master clock, stop between reads, wait for data.
pub const I2C_MST_CTRL: u8 = 0x24;
/// I2C_SLV0_ADDR (37): slave 0 address, bit 7 = read.
pub const I2C_SLV0_ADDR: u8 = 0x25;
/// I2C_SLV0_REG (38): slave 0 first register.
pub const I2C_SLV0_REG: u8 = 0x26;
/// I2C_SLV0_CTRL (39): slave 0 enable and length.
pub const I2C_SLV0_CTRL: u8 = 0x27;
/// I2C_SLV4_ADDR (49): slave 4 address, bit 7 = read.
pub const I2C_SLV4_ADDR: u8 = 0x31;
/// I2C_SLV4_REG (50): slave 4 register.
pub const I2C_SLV4_REG: u8 = 0x32;
/// I2C_SLV4_DO (51): byte slave 4 writes.
pub const I2C_SLV4_DO: u8 = 0x33;
/// I2C_SLV4_CTRL (52): slave 4 enable (one transfer), I2C_MST_DLY.
pub const I2C_SLV4_CTRL: u8 = 0x34;
/// I2C_SLV4_DI (53): byte slave 4 read.
pub const I2C_SLV4_DI: u8 = 0x35;
/// I2C_MST_STATUS (54): slave 4 done / NACK flags (cleared by reading).
pub const I2C_MST_STATUS: u8 = 0x36;
/// INT_PIN_CFG (55): INT pin / bypass enable configuration.
pub const INT_PIN_CFG: u8 = 0x37;
/// INT_ENABLE (56): interrupt enables.
pub const INT_ENABLE: u8 = 0x38;
/// INT_STATUS (58): interrupt status (reading it clears the flags).
pub const INT_STATUS: u8 = 0x3A;
/// ACCEL_XOUT_H (59): first byte of the 14-byte accel/temp/gyro block.
pub const ACCEL_XOUT_H: u8 = 0x3B;
/// TEMP_OUT_H (65).
pub const TEMP_OUT_H: u8 = 0x41;
/// GYRO_XOUT_H (67).
pub const GYRO_XOUT_H: u8 = 0x43;
/// GYRO_ZOUT_L (72): last byte of the 14-byte block.
pub const GYRO_ZOUT_L: u8 = 0x48;
/// EXT_SENS_DATA_00 (73): first of 24 bytes the internal master read.
pub const EXT_SENS_DATA_00: u8 = 0x49;
/// I2C_MST_DELAY_CTRL (103): DELAY_ES_SHADOW, per-slave reduced access rate.
pub const I2C_MST_DELAY_CTRL: u8 = 0x67;
/// USER_CTRL (106): FIFO_EN, I2C_MST_EN, I2C_IF_DIS, resets.
pub const USER_CTRL: u8 = 0x6A;
/// PWR_MGMT_1 (107): H_RESET, SLEEP, CYCLE, GYRO_STANDBY, PD_PTAT, CLKSEL.
pub const PWR_MGMT_1: u8 = 0x6B;
/// PWR_MGMT_2 (108): DIS_XA..DIS_ZG (1 = axis disabled).
pub const PWR_MGMT_2: u8 = 0x6C;
/// FIFO_COUNTH (114): bits 12:8 of the FIFO byte count (FIFO_COUNTL follows).
pub const FIFO_COUNTH: u8 = 0x72;
/// FIFO_R_W (116): reading pops FIFO bytes.
pub const FIFO_R_W: u8 = 0x74;
/// WHO_AM_I (117).
pub const WHO_AM_I: u8 = 0x75;

/// Length of the ACCEL_XOUT_H..GYRO_ZOUT_L burst.
pub const SAMPLE_LEN: usize = 14;

/// WHO_AM_I value of the MPU-9250.
pub const WHO_AM_I_MPU9250: u8 = 0x71;
/// WHO_AM_I value of the MPU-9255.
pub const WHO_AM_I_MPU9255: u8 = 0x73;
/// WHO_AM_I value of the MPU-6500 (same accel/gyro die, no AK8963).
pub const WHO_AM_I_MPU6500: u8 = 0x70;

/// PWR_MGMT_1 bit 7: H_RESET, reset the internal registers; self-clearing.
pub const PWR_MGMT_1_H_RESET: u8 = 1 << 7;
/// PWR_MGMT_1 bit 6: SLEEP.
pub const PWR_MGMT_1_SLEEP: u8 = 1 << 6;
/// PWR_MGMT_1 CLKSEL field mask (bits 2:0).
pub const PWR_MGMT_1_CLKSEL_MASK: u8 = 0b0000_0111;
/// CLKSEL = 1: auto-select the best clock (PLL when the gyro is ready).
pub const PWR_MGMT_1_CLKSEL_PLL: u8 = 0b0000_0001;

/// CONFIG DLPF_CFG field mask (bits 2:0).
pub const CONFIG_DLPF_CFG_MASK: u8 = 0b0000_0111;

/// GYRO_CONFIG GYRO_FS_SEL field shift (bits 4:3).
pub const GYRO_CONFIG_FS_SEL_SHIFT: u8 = 3;
/// GYRO_CONFIG GYRO_FS_SEL field mask.
pub const GYRO_CONFIG_FS_SEL_MASK: u8 = 0b0001_1000;
/// GYRO_CONFIG FCHOICE_B field mask (bits 1:0); 0b00 enables the DLPF table.
pub const GYRO_CONFIG_FCHOICE_B_MASK: u8 = 0b0000_0011;

/// ACCEL_CONFIG ACCEL_FS_SEL field shift (bits 4:3).
pub const ACCEL_CONFIG_FS_SEL_SHIFT: u8 = 3;
/// ACCEL_CONFIG ACCEL_FS_SEL field mask.
pub const ACCEL_CONFIG_FS_SEL_MASK: u8 = 0b0001_1000;

/// ACCEL_CONFIG2 bit 3: ACCEL_FCHOICE_B (1 = bypass the accel DLPF, 1.13 kHz / 4 kHz).
pub const ACCEL_CONFIG2_FCHOICE_B: u8 = 1 << 3;
/// ACCEL_CONFIG2 A_DLPF_CFG field mask (bits 2:0).
pub const ACCEL_CONFIG2_A_DLPF_CFG_MASK: u8 = 0b0000_0111;

/// INT_PIN_CFG bit 7: ACTL, 1 = INT pin active low.
pub const INT_PIN_CFG_ACTL: u8 = 1 << 7;
/// INT_PIN_CFG bit 6: OPEN, 1 = open drain, 0 = push-pull.
pub const INT_PIN_CFG_OPEN: u8 = 1 << 6;
/// INT_PIN_CFG bit 5: LATCH_INT_EN, 1 = held until cleared, 0 = 50 µs pulse.
pub const INT_PIN_CFG_LATCH_INT_EN: u8 = 1 << 5;
/// INT_PIN_CFG bit 4: INT_ANYRD_2CLEAR, 1 = cleared by any read, 0 = only by reading INT_STATUS.
pub const INT_PIN_CFG_INT_ANYRD_2CLEAR: u8 = 1 << 4;
/// INT_PIN_CFG bit 3: ACTL_FSYNC.
pub const INT_PIN_CFG_ACTL_FSYNC: u8 = 1 << 3;
/// INT_PIN_CFG bit 2: FSYNC_INT_MODE_EN.
pub const INT_PIN_CFG_FSYNC_INT_MODE_EN: u8 = 1 << 2;
/// INT_PIN_CFG bit 1: BYPASS_EN, connect the auxiliary I2C bus (AK8963) to the host bus
/// (requires USER_CTRL I2C_MST_EN = 0).
pub const INT_PIN_CFG_BYPASS_EN: u8 = 1 << 1;

/// INT_ENABLE bit 6: WOM_EN (wake on motion).
pub const INT_ENABLE_WOM_EN: u8 = 1 << 6;
/// INT_ENABLE bit 4: FIFO_OFLOW_EN.
pub const INT_ENABLE_FIFO_OFLOW_EN: u8 = 1 << 4;
/// INT_ENABLE bit 3: FSYNC_INT_EN.
pub const INT_ENABLE_FSYNC_INT_EN: u8 = 1 << 3;
/// INT_ENABLE bit 0: RAW_RDY_EN (raw sensor data ready).
pub const INT_ENABLE_RAW_RDY_EN: u8 = 1 << 0;

/// INT_STATUS bit 6: WOM_INT.
pub const INT_STATUS_WOM_INT: u8 = 1 << 6;
/// INT_STATUS bit 4: FIFO_OFLOW_INT.
pub const INT_STATUS_FIFO_OFLOW_INT: u8 = 1 << 4;
/// INT_STATUS bit 3: FSYNC_INT.
pub const INT_STATUS_FSYNC_INT: u8 = 1 << 3;
/// INT_STATUS bit 0: RAW_DATA_RDY_INT.
pub const INT_STATUS_RAW_DATA_RDY_INT: u8 = 1 << 0;

/// USER_CTRL bit 6: FIFO_EN.
pub const USER_CTRL_FIFO_EN: u8 = 1 << 6;
/// USER_CTRL bit 5: I2C_MST_EN (must be 0 for bypass).
pub const USER_CTRL_I2C_MST_EN: u8 = 1 << 5;
/// USER_CTRL bit 4: I2C_IF_DIS (SPI only).
pub const USER_CTRL_I2C_IF_DIS: u8 = 1 << 4;
/// USER_CTRL bit 2: FIFO_RST (self-clearing).
pub const USER_CTRL_FIFO_RST: u8 = 1 << 2;
/// USER_CTRL bit 1: I2C_MST_RST (self-clearing).
pub const USER_CTRL_I2C_MST_RST: u8 = 1 << 1;

/// CONFIG bit 6: FIFO_MODE, 1 = when full, further samples are not written
/// (instead of replacing the oldest).
pub const CONFIG_FIFO_MODE: u8 = 1 << 6;

/// FIFO_EN bits for TEMP_OUT, GYRO_X/Y/ZOUT and ACCEL: the whole 14-byte sample,
/// stored in register order (accel, temperature, gyro).
pub const FIFO_EN_SAMPLE: u8 = 0b1111_1000;
/// FIFO size in bytes.
pub const FIFO_SIZE: u16 = 512;
/// FIFO_COUNTH significant bits.
pub const FIFO_COUNTH_MASK: u8 = 0x1F;

/// I2C_SLVx_ADDR bit 7: the transfer is a read.
pub const I2C_SLV_READ: u8 = 1 << 7;
/// I2C_SLVx_CTRL bit 7: slave enable.
pub const I2C_SLV_EN: u8 = 1 << 7;
/// I2C_SLVx_CTRL length field mask (bits 3:0).
pub const I2C_SLV_LENG_MASK: u8 = 0x0F;
/// I2C_MST_CTRL bit 4: I2C_MST_P_NSR, a STOP (not a restart) between slave reads.
pub const I2C_MST_CTRL_P_NSR: u8 = 1 << 4;
/// I2C_MST_CTRL bit 6: WAIT_FOR_ES, hold the data-ready interrupt until the
/// external sensor data has been read.
pub const I2C_MST_CTRL_WAIT_FOR_ES: u8 = 1 << 6;
/// I2C_MST_CTRL clock code 13: 400 kHz (8 MHz / 20).
pub const I2C_MST_CLK_400KHZ: u8 = 13;
/// I2C_MST_DELAY_CTRL bit 7: DELAY_ES_SHADOW, shadow the external sensor data
/// until all slaves were read.
pub const I2C_MST_DELAY_ES_SHADOW: u8 = 1 << 7;
/// I2C_MST_DELAY_CTRL bit 0: I2C_SLV0_DLY_EN, slave 0 only every
/// (1 + I2C_MST_DLY) samples.
pub const I2C_MST_DELAY_SLV0_DLY_EN: u8 = 1 << 0;
/// I2C_SLV4_CTRL I2C_MST_DLY field mask (bits 4:0).
pub const I2C_SLV4_MST_DLY_MASK: u8 = 0x1F;
/// I2C_MST_STATUS bit 6: I2C_SLV4_DONE.
pub const I2C_MST_STATUS_SLV4_DONE: u8 = 1 << 6;
/// I2C_MST_STATUS bit 4: I2C_SLV4_NACK.
pub const I2C_MST_STATUS_SLV4_NACK: u8 = 1 << 4;
/// I2C_MST_STATUS bit 5: I2C_LOST_ARB.
pub const I2C_MST_STATUS_LOST_ARB: u8 = 1 << 5;
/// I2C_MST_STATUS bit 0: I2C_SLV0_NACK.
pub const I2C_MST_STATUS_SLV0_NACK: u8 = 1 << 0;

/// GYRO_CONFIG / ACCEL_CONFIG bits 7:5: self-test on all three axes.
pub const SELF_TEST_XYZ: u8 = 0b1110_0000;
