//! Linux host (`/dev/i2c-N`): an MS5611 at 0x77 (CSB low), ten blocking
//! measurements at OSR 4096.
//!
//! ```text
//! cargo run -p ms5611 --example linux -- /dev/i2c-1
//! ```

// The I2C set-up repeats the other drivers' examples on purpose: each example stands alone.

#[cfg(target_os = "linux")]
fn main() -> Result<(), Box<dyn std::error::Error>> {
    use linux_embedded_hal::{Delay, I2cdev};
    use ms5611::{Address, Ms5611, Osr};

    let path = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "/dev/i2c-1".into());
    let bus = I2cdev::new(&path).map_err(|e| format!("{path}: {e}"))?;
    let mut baro = Ms5611::new(bus, Address::CsbLow);
    let prom = baro.init(&mut Delay)?;
    println!("PROM C1..C6 {:?}", prom.coefficients());
    for _ in 0..10 {
        let m = baro.measure(&mut Delay, Osr::Osr4096)?;
        println!(
            "{} Pa  {}.{:02} C",
            m.pressure_pa,
            m.temperature_centi_c / 100,
            (m.temperature_centi_c % 100).abs()
        );
    }
    Ok(())
}

#[cfg(not(target_os = "linux"))]
fn main() {}
