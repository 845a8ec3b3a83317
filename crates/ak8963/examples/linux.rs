//! Linux host (`/dev/i2c-N`): enable the MPU-9250's I2C bypass, then read ten
//! AK8963 measurements in µT (MPU frame).
//!
//! ```text
//! cargo run -p ak8963 --example linux -- /dev/i2c-1
//! ```

// The I2C set-up repeats the other drivers' examples on purpose: each example stands alone.

#[cfg(target_os = "linux")]
fn main() -> Result<(), Box<dyn std::error::Error>> {
    use ak8963::{Ak8963, Config};
    use embedded_hal::i2c::I2c;
    use linux_embedded_hal::{Delay, I2cdev};

    let path = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "/dev/i2c-1".into());
    let mut bus = I2cdev::new(&path).map_err(|e| format!("{path}: {e}"))?;
    // MPU-9250 at 0x68: USER_CTRL I2C_MST_EN off, INT_PIN_CFG BYPASS_EN on
    // (the mpu9250 crate's `set_bypass` does the same).
    bus.write(0x68u8, &[0x6A, 0x00])?;
    bus.write(0x68u8, &[0x37, 0x02])?;
    let mut mag = Ak8963::new(bus);
    mag.init(&mut Delay, &Config::default())?;
    println!("fuse ROM {:?}", mag.asa());
    let mut read = 0;
    while read < 10 {
        match mag.read() {
            Ok(s) => {
                println!("field_mpu_ut {:?}", s.field_mpu_ut());
                read += 1;
            }
            Err(ak8963::Error::NotReady) => {}
            Err(e) => return Err(e.into()),
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    Ok(())
}

#[cfg(not(target_os = "linux"))]
fn main() {}
