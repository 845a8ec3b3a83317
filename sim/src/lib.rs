//! Host-side simulator of the flight controller's sensor bus.
//!
//! Register-level models of the MPU-9250, its AK8963 magnetometer and the
//! MS5611 barometer sit behind one virtual [`SimBus`] implementing
//! `embedded_hal::i2c::I2c` (and, for the MPU-9250 and MS5611, behind
//! `SpiDevice`s in [`spi`]), so the real no_std drivers run against them
//! unchanged. The models are written from the datasheets, not from the
//! drivers: their register maps and the MS5611 compensation repeat the
//! drivers' on purpose, as independent transcriptions that check them. The chips sample a rigid-body [`Trajectory`] (truth) through
//! seeded datasheet-size sensor errors, on a simulated [`SimClock`] that the
//! drivers' [`SimDelay`] advances — a 10-minute flight runs in seconds.
//! Faults (NACKs, bus errors, arbitration loss, stuck SDA/SCL, a chip left
//! holding SDA mid-byte, wrong ids, corrupted PROM, overflow, frozen data,
//! magnets, vibration, spontaneous resets) are injected with
//! [`SimBus::inject`]. A [`Quadcopter`] model (motors, battery, drag,
//! ground) can be the truth instead, through a [`QuadLink`], for closed-loop
//! flight. Shared by both flight rigs (`cargo sim`, `cargo fil`): the
//! scripted pilots ([`scenario`]), the `--fault TIME:KIND[:ARG]` syntax
//! ([`faults`]), the flight plots ([`plot`]) and the rate loop's
//! measurement from a flight's signals ([`rate_loop`]).
//!
//! The same bus is open at the wire level ([`wire`]): START + address,
//! bytes with the master's ACK/NACK, STOP, and the SCL/SDA levels with what
//! the chips do on each SCL edge, for a register-level master model (the
//! emulator's I2C1) and GPIO bus recovery. `SimBus`'s transactions run over
//! those same steps.
//!
//! What it is not: an electrical I2C model (no clock stretching by the
//! chips, no bit timing inside the chips: time per transfer is an optional
//! estimate or the master model's), nor a model of the MPU-9250's DMP.
//!
//! ```
//! use embedded_hal::i2c::I2c;
//! use sim::{SimBus, SimClock, SimConfig};
//!
//! let clock = SimClock::new();
//! let mut bus = SimBus::new(&clock, SimConfig::default());
//! let mut id = [0u8];
//! bus.write_read(0x68, &[0x75], &mut id).unwrap();
//! assert_eq!(id[0], 0x71);
//! ```

pub mod ak8963;
pub mod aux_master;
pub mod bus;
pub mod clock;
pub mod device;
pub mod dlpf;
pub mod errors;
pub mod faults;
pub mod math;
pub mod mpu9250;
pub mod ms5611;
pub mod physics;
pub mod plot;
pub mod quad;
pub mod rate_loop;
pub mod rng;
pub mod scenario;
pub mod spectrum;
pub mod spi;
pub mod wire;
pub mod world;

pub use bus::{
    magnet_pass, magnet_ride, Chip, Fault, SimBus, SimBusError, SimConfig, AK8963_ADDRESS,
};
pub use clock::{SimClock, SimDelay};
pub use errors::SensorErrors;
pub use math::{Quat, Vec3};
pub use physics::{Environment, MagneticField, Trajectory, TruthSample};
pub use quad::{QuadLink, QuadParams, Quadcopter};
pub use spi::{SimSpi, SimSpiError, SpiChip};
pub use world::{MagnetPass, Vibration};
