//! Linux host (Raspberry Pi, BeagleBone, any `/dev/i2c-N`): read ten samples
//! from an MPU-9250 at 0x68.
//!
//! ```text
//! cargo run -p mpu9250 --example linux -- /dev/i2c-1
//! ```

// The I2C set-up repeats the other drivers' examples on purpose: each example stands alone.

#[cfg(target_os = "linux")]
fn main() -> Result<(), Box<dyn std::error::Error>> {
    use linux_embedded_hal::{Delay, I2cdev};
    use mpu9250::{Address, Config, Mpu9250};

    let path = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "/dev/i2c-1".into());
    let bus = I2cdev::new(&path).map_err(|e| format!("{path}: {e}"))?;
    let mut imu = Mpu9250::new(bus, Address::Ad0Low);
    let variant = imu.init(&mut Delay, &Config::default())?;
    println!("{variant:?} on {path}");
    for _ in 0..10 {
        let s = imu.read()?;
        println!(
            "accel_g {:?} gyro_dps {:?} temp_c {:.2}",
            s.accel_g, s.gyro_dps, s.temp_c
        );
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
    Ok(())
}

#[cfg(not(target_os = "linux"))]
fn main() {}
