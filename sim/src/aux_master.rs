//! The MPU-9250's internal I2C master driving the AK8963 model (register map
//! §§ I2C_MST_CTRL, I2C_SLV0_*, I2C_SLV4_*, I2C_MST_STATUS, EXT_SENS_DATA):
//! once per MPU sample, with USER_CTRL I2C_MST_EN set, slave 4 performs its
//! one pending single-byte transfer and slave 0 repeats its read into
//! EXT_SENS_DATA_00... Only the AK8963 (0x0C) sits on the auxiliary bus; any
//! other address is not acknowledged. The AK8963 model is reached through
//! its byte interface, exactly as over the bypass.

use crate::ak8963::Ak8963Model;
use crate::bus::AK8963_ADDRESS;
use crate::device::Device;
use crate::mpu9250::Mpu9250Model;
use crate::world::World;

const USER_CTRL: u8 = 0x6A;
const I2C_MST_EN: u8 = 0x20;
const I2C_SLV0_ADDR: u8 = 0x25;
const I2C_SLV0_REG: u8 = 0x26;
const I2C_SLV0_CTRL: u8 = 0x27;
const I2C_SLV4_ADDR: u8 = 0x31;
const I2C_SLV4_REG: u8 = 0x32;
const I2C_SLV4_DO: u8 = 0x33;
const I2C_SLV4_CTRL: u8 = 0x34;
const I2C_SLV4_DI: u8 = 0x35;
const I2C_MST_STATUS: u8 = 0x36;
const EXT_SENS_DATA_00: u8 = 0x49;
const SLV_EN: u8 = 0x80;
const SLV4_DONE: u8 = 0x40;
const SLV4_NACK: u8 = 0x10;
const SLV0_NACK: u8 = 0x01;

/// Run the master for every MPU sample produced since the last call.
pub fn step(mpu: &mut Mpu9250Model, ak: &mut Ak8963Model, now_ns: u64, world: &mut World) {
    let samples = mpu.sample_count();
    let due = samples != mpu.master_samples_seen;
    mpu.master_samples_seen = samples;
    if !due || mpu.register(USER_CTRL) & I2C_MST_EN == 0 {
        return;
    }
    ak.update(now_ns, world);
    if mpu.register(I2C_SLV4_CTRL) & SLV_EN != 0 {
        slave4(mpu, ak, now_ns, world);
    }
    let ctrl = mpu.register(I2C_SLV0_CTRL);
    if ctrl & SLV_EN != 0 {
        slave0(mpu, ak, ctrl & 0x0F, now_ns, world);
    }
}

fn slave4(mpu: &mut Mpu9250Model, ak: &mut Ak8963Model, now_ns: u64, world: &mut World) {
    let addr = mpu.register(I2C_SLV4_ADDR);
    let register = mpu.register(I2C_SLV4_REG);
    mpu.set_register(I2C_SLV4_CTRL, mpu.register(I2C_SLV4_CTRL) & !SLV_EN);
    let status = mpu.register(I2C_MST_STATUS);
    if addr & 0x7F != AK8963_ADDRESS {
        mpu.set_register(I2C_MST_STATUS, status | SLV4_NACK);
        return;
    }
    ak.start(false);
    let _ = ak.write_byte(register, now_ns, world);
    if addr & 0x80 != 0 {
        ak.start(true);
        let v = ak.read_byte(now_ns, world);
        mpu.set_register(I2C_SLV4_DI, v);
    } else {
        let _ = ak.write_byte(mpu.register(I2C_SLV4_DO), now_ns, world);
    }
    ak.stop(now_ns, world);
    mpu.set_register(I2C_MST_STATUS, status | SLV4_DONE);
}

fn slave0(mpu: &mut Mpu9250Model, ak: &mut Ak8963Model, len: u8, now_ns: u64, world: &mut World) {
    let addr = mpu.register(I2C_SLV0_ADDR);
    if addr & 0x7F != AK8963_ADDRESS || addr & 0x80 == 0 {
        let status = mpu.register(I2C_MST_STATUS);
        mpu.set_register(I2C_MST_STATUS, status | SLV0_NACK);
        return;
    }
    ak.start(false);
    let _ = ak.write_byte(mpu.register(I2C_SLV0_REG), now_ns, world);
    ak.start(true);
    for i in 0..len {
        let v = ak.read_byte(now_ns, world);
        mpu.set_register(EXT_SENS_DATA_00 + i, v);
    }
    ak.stop(now_ns, world);
}
