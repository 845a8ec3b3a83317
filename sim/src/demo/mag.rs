//! Access to the AK8963 for the demo through the `ak8963` driver.

use ak8963::{Ak8963, Config, Error};
use embedded_hal::delay::DelayNs;
use sim::SimBus;

/// The magnetometer as the demo uses it: µT in the MPU sensor frame, 100 Hz.
pub struct Mag {
    dev: Ak8963<SimBus>,
}

impl Mag {
    /// WIA, soft reset, fuse ROM, continuous mode 2 (100 Hz), 16-bit.
    pub fn init(bus: SimBus, delay: &mut impl DelayNs) -> Result<Self, String> {
        let mut dev = Ak8963::new(bus);
        dev.init(delay, &Config::default())
            .map_err(|e| format!("AK8963 init: {e}"))?;
        Ok(Self { dev })
    }

    /// A new sample if one is ready: µT, MPU sensor frame (factory
    /// adjustment applied, no hard/soft-iron correction).
    pub fn read(&mut self) -> Result<Option<[f32; 3]>, String> {
        match self.dev.read() {
            Ok(s) => Ok(Some(s.field_mpu_ut())),
            Err(Error::NotReady) => Ok(None),
            Err(e) => Err(format!("AK8963 read: {e}")),
        }
    }
}
