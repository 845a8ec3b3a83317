//! The virtual I2C bus: address routing, transfer timing, fault injection.

use crate::ak8963::Ak8963Model;
use crate::clock::SimClock;
use crate::device::Device;
use crate::errors::SensorErrors;
use crate::math::Vec3;
use crate::mpu9250::Mpu9250Model;
use crate::ms5611::Ms5611Model;
use crate::physics::{Environment, Trajectory};
use crate::wire::{Target, WireState};
use crate::world::{MagnetPass, Vibration, World};
use embedded_hal::i2c::{ErrorKind, ErrorType, I2c, NoAcknowledgeSource, Operation};
use std::cell::{Ref, RefCell, RefMut};
use std::rc::Rc;

/// AK8963 address (reachable through the MPU-9250's bypass only).
pub const AK8963_ADDRESS: u8 = 0x0C;

/// Error of a simulated transaction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SimBusError {
    /// Address or data byte not acknowledged.
    Nack(NoAcknowledgeSource),
    /// Bus error (misplaced start/stop), e.g. a glitch mid-transfer or a stuck bus.
    Bus,
    /// Arbitration lost.
    ArbitrationLoss,
}

impl embedded_hal::i2c::Error for SimBusError {
    fn kind(&self) -> ErrorKind {
        match *self {
            SimBusError::Nack(s) => ErrorKind::NoAcknowledge(s),
            SimBusError::Bus => ErrorKind::Bus,
            SimBusError::ArbitrationLoss => ErrorKind::ArbitrationLoss,
        }
    }
}

impl std::fmt::Display for SimBusError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{self:?}")
    }
}

impl std::error::Error for SimBusError {}

/// Which chip a fault targets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Chip {
    /// MPU-9250 (accelerometer, gyroscope).
    Mpu9250,
    /// AK8963 magnetometer.
    Ak8963,
    /// MS5611 barometer.
    Ms5611,
}

/// A fault to inject with [`SimBus::inject`]. Persistent faults last until
/// [`SimBus::clear_faults`]; one-shot ones say so.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Fault {
    /// Transactions to `address` are not acknowledged, for the next
    /// `transactions` ones (`None`: until cleared).
    Nack {
        /// 7-bit address.
        address: u8,
        /// How many transactions; `None` = until cleared.
        transactions: Option<u32>,
    },
    /// One-shot: the next transaction (any address) fails with
    /// `ErrorKind::Bus` after `after_bytes` data bytes have been transferred.
    /// On the wire: a misplaced START/STOP during that byte; the chip drops
    /// out of the transaction (releases SDA, answers nothing until the next
    /// START).
    BusErrorMidTransfer {
        /// Data bytes that get through before the error.
        after_bytes: usize,
    },
    /// The next `transactions` transactions lose arbitration (during the
    /// address byte: another master wins the bus).
    ArbitrationLoss {
        /// How many.
        transactions: u32,
    },
    /// SDA held low until cleared: every transaction fails with
    /// `ErrorKind::Bus`, and a line-level master reads SDA low.
    StuckBus,
    /// SCL held low until cleared (a shorted line): no START is possible.
    SclStuckLow,
    /// The chip is left in the middle of a read byte of 0x00 and holds SDA
    /// low until the master clocks SCL (as after an MCU reset mid-read, or
    /// power-up noise); a STOP after 9 SCL pulses releases it. Not cleared
    /// by [`SimBus::clear_faults`]: only the wire releases it.
    SlaveHoldsSda(Chip),
    /// The chip reports a wrong id (WHO_AM_I / WIA); the MS5611 has none.
    WrongChipId {
        /// Which chip.
        chip: Chip,
        /// The id it reports.
        id: u8,
    },
    /// MS5611 PROM word `word` reads with `xor_mask` flipped.
    CorruptProm {
        /// Word 0..7.
        word: usize,
        /// Bits to flip.
        xor_mask: u16,
    },
    /// Every AK8963 measurement reports HOFL (magnetic sensor overflow).
    MagOverflow,
    /// The chip's data stops updating (data-ready keeps firing, values stay).
    Frozen(Chip),
    /// A magnet passes by (field disturbance, body frame).
    Magnet(MagnetPass),
    /// Vibration on the accelerometer and gyroscope.
    Vibration(Vibration),
    /// One-shot: the chip resets itself now (registers back to reset values).
    ChipReset(Chip),
}

/// Everything needed to build a simulated board.
#[derive(Clone, Debug)]
pub struct SimConfig {
    /// The motion.
    pub trajectory: Trajectory,
    /// Field and atmosphere.
    pub env: Environment,
    /// Sensor errors.
    pub errors: SensorErrors,
    /// Seed of all randomness.
    pub seed: u64,
    /// MPU-9250 address (0x68 with AD0 low, 0x69 high).
    pub mpu_address: u8,
    /// MS5611 address (0x77 with CSB low, 0x76 high).
    pub ms5611_address: u8,
    /// Bus clock (Hz) used to advance simulated time per transfer; `None` = transfers take no time.
    pub bus_hz: Option<u32>,
    /// AK8963 fuse-ROM values.
    pub ak8963_asa: [u8; 3],
}

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            trajectory: Trajectory::at_rest(),
            env: Environment::default(),
            errors: SensorErrors::noise_only(),
            seed: 1,
            mpu_address: 0x68,
            ms5611_address: 0x77,
            bus_hz: Some(400_000),
            ak8963_asa: crate::ak8963::DEFAULT_ASA,
        }
    }
}

/// The state behind a [`SimBus`]; borrow it with [`SimBus::state`].
#[derive(Debug)]
pub struct BusState {
    /// The world (truth, errors, disturbances).
    pub world: World,
    /// MPU-9250 model.
    pub mpu: Mpu9250Model,
    /// AK8963 model.
    pub ak: Ak8963Model,
    /// MS5611 model.
    pub ms: Ms5611Model,
    /// MPU-9250 address.
    pub mpu_address: u8,
    /// MS5611 address.
    pub ms5611_address: u8,
    /// Bus clock for transfer timing.
    pub bus_hz: Option<u32>,
    pub(crate) nacks: Vec<(u8, Option<u32>)>,
    pub(crate) bus_error_after: Option<usize>,
    pub(crate) arbitration_losses: u32,
    pub(crate) stuck: bool,
    pub(crate) transactions: u64,
    pub(crate) failed_transactions: u64,
    pub(crate) wire: WireState,
}

impl BusState {
    pub(crate) fn update_all(&mut self, now_ns: u64) {
        self.mpu.update(now_ns, &mut self.world);
        self.ak.update(now_ns, &mut self.world);
        self.ms.update(now_ns, &mut self.world);
        crate::aux_master::step(&mut self.mpu, &mut self.ak, now_ns, &mut self.world);
    }
}

/// The virtual I2C bus with the three chips on it. Cheap to clone: clones
/// share the same chips, so each driver can own one and the test keeps one
/// for fault injection and inspection.
#[derive(Clone, Debug)]
pub struct SimBus {
    clock: SimClock,
    state: Rc<RefCell<BusState>>,
}

impl SimBus {
    /// A bus on `clock` built from `config`.
    pub fn new(clock: &SimClock, config: SimConfig) -> Self {
        let world = World::new(config.trajectory, config.env, config.errors, config.seed);
        let state = BusState {
            world,
            mpu: Mpu9250Model::new(),
            ak: Ak8963Model::new(config.ak8963_asa),
            ms: Ms5611Model::default(),
            mpu_address: config.mpu_address,
            ms5611_address: config.ms5611_address,
            bus_hz: config.bus_hz,
            nacks: Vec::new(),
            bus_error_after: None,
            arbitration_losses: 0,
            stuck: false,
            transactions: 0,
            failed_transactions: 0,
            wire: WireState::default(),
        };
        Self {
            clock: clock.clone(),
            state: Rc::new(RefCell::new(state)),
        }
    }

    pub(crate) fn state_cell(&self) -> &RefCell<BusState> {
        &self.state
    }

    /// The shared clock.
    pub fn clock(&self) -> &SimClock {
        &self.clock
    }

    /// Read access to the models and the world (brought up to date first).
    pub fn state(&self) -> Ref<'_, BusState> {
        self.sync();
        self.state.borrow()
    }

    /// Write access to the models and the world.
    pub fn state_mut(&self) -> RefMut<'_, BusState> {
        self.sync();
        self.state.borrow_mut()
    }

    fn sync(&self) {
        let now = self.clock.now_ns();
        self.state.borrow_mut().update_all(now);
    }

    /// The MPU-9250 INT line is asserted now (data ready; see
    /// `Mpu9250Model::int_asserted` for the latched / 50 µs pulse modes).
    pub fn data_ready(&self) -> bool {
        let now = self.clock.now_ns();
        let mut s = self.state.borrow_mut();
        s.update_all(now);
        s.mpu.int_asserted(now)
    }

    /// Simulated time (ns) of the MPU-9250's next sample.
    pub fn next_mpu_sample_ns(&self) -> u64 {
        self.state().mpu.next_sample_ns()
    }

    /// Advances the clock to the next MPU-9250 sample (if it is running) and
    /// returns the new time.
    pub fn advance_to_next_mpu_sample(&self) -> u64 {
        let t = self.next_mpu_sample_ns();
        self.clock.advance_to_ns(t);
        self.sync();
        self.clock.now_ns()
    }

    /// Truth at the current simulated time.
    pub fn truth_now(&self) -> crate::physics::TruthSample {
        let t = self.clock.now_s();
        self.state.borrow().world.truth(t)
    }

    /// Truth at the time of the MPU's latest sample (what the sample registers hold).
    pub fn truth_at_last_mpu_sample(&self) -> Option<crate::physics::TruthSample> {
        let s = self.state();
        s.mpu
            .last_sample_ns()
            .map(|t| s.world.truth(t as f64 * 1e-9))
    }

    /// Transactions so far (all / failed).
    pub fn transaction_counts(&self) -> (u64, u64) {
        let s = self.state.borrow();
        (s.transactions, s.failed_transactions)
    }

    /// Injects a fault.
    pub fn inject(&self, fault: Fault) {
        let now = self.clock.now_ns();
        let mut s = self.state.borrow_mut();
        s.update_all(now);
        match fault {
            Fault::Nack {
                address,
                transactions,
            } => {
                s.nacks.retain(|(a, _)| *a != address);
                s.nacks.push((address, transactions));
            }
            Fault::BusErrorMidTransfer { after_bytes } => s.bus_error_after = Some(after_bytes),
            Fault::ArbitrationLoss { transactions } => s.arbitration_losses = transactions,
            Fault::StuckBus => s.stuck = true,
            Fault::SclStuckLow => s.wire.scl_stuck = true,
            Fault::SlaveHoldsSda(chip) => {
                drop(s);
                self.wire_hold_sda(match chip {
                    Chip::Mpu9250 => Target::Mpu,
                    Chip::Ak8963 => Target::Ak,
                    Chip::Ms5611 => Target::Ms,
                });
            }
            Fault::WrongChipId { chip, id } => match chip {
                Chip::Mpu9250 => s.mpu.who_am_i_override = Some(id),
                Chip::Ak8963 => s.ak.who_am_i_override = Some(id),
                Chip::Ms5611 => {}
            },
            Fault::CorruptProm { word, xor_mask } => {
                if let Some(w) = s.ms.prom_corruption.get_mut(word) {
                    *w ^= xor_mask;
                }
            }
            Fault::MagOverflow => s.ak.force_overflow = true,
            Fault::Frozen(chip) => match chip {
                Chip::Mpu9250 => s.mpu.frozen = true,
                Chip::Ak8963 => s.ak.frozen = true,
                Chip::Ms5611 => s.ms.frozen = true,
            },
            Fault::Magnet(m) => s.world.magnets.push(m),
            Fault::Vibration(v) => s.world.vibration = Some(v),
            Fault::ChipReset(chip) => match chip {
                Chip::Mpu9250 => s.mpu.power_on_reset(now),
                Chip::Ak8963 => s.ak.power_on_reset(now),
                Chip::Ms5611 => s.ms.power_on_reset(now),
            },
        }
    }

    /// Clears every persistent fault (NACKs, stuck bus, wrong ids, PROM
    /// corruption, overflow, frozen chips, magnets, vibration).
    pub fn clear_faults(&self) {
        let mut s = self.state.borrow_mut();
        s.nacks.clear();
        s.bus_error_after = None;
        s.arbitration_losses = 0;
        s.stuck = false;
        s.wire.scl_stuck = false;
        s.mpu.who_am_i_override = None;
        s.ak.who_am_i_override = None;
        s.ms.prom_corruption = [0; 8];
        s.ak.force_overflow = false;
        s.mpu.frozen = false;
        s.ak.frozen = false;
        s.ms.frozen = false;
        s.world.magnets.clear();
        s.world.vibration = None;
    }

    fn transfer_time_ns(bus_hz: Option<u32>, segments: usize, bytes: usize) -> u64 {
        match bus_hz {
            Some(hz) if hz > 0 => {
                // Start + 9 bits of address per segment, 9 bits per byte, stop.
                let bits = (segments * 10 + bytes * 9 + 1) as u64;
                bits * 1_000_000_000 / u64::from(hz)
            }
            _ => 0,
        }
    }

    fn run(&self, address: u8, operations: &mut [Operation<'_>]) -> Result<(), SimBusError> {
        let segments = operations.len().max(1);
        let bytes: usize = operations
            .iter()
            .map(|o| match o {
                Operation::Read(b) => b.len(),
                Operation::Write(b) => b.len(),
            })
            .sum();
        let result = self.run_ops(address, operations);
        self.wire_stop();
        let bus_hz = self.state.borrow().bus_hz;
        let dt = Self::transfer_time_ns(bus_hz, segments, if result.is_ok() { bytes } else { 0 });
        self.clock.advance_ns(dt);
        result
    }

    /// The operations as wire steps: a (repeated) START with the address
    /// whenever the direction changes (adjacent operations of one kind are
    /// merged, as `embedded_hal::i2c` specifies), the last byte read before
    /// a direction change or the end NACKed.
    fn run_ops(&self, address: u8, operations: &mut [Operation<'_>]) -> Result<(), SimBusError> {
        let mut prev_read: Option<bool> = None;
        let n = operations.len();
        for i in 0..n {
            let next_is_read = matches!(operations.get(i + 1), Some(Operation::Read(_)));
            let Some(op) = operations.get_mut(i) else {
                break;
            };
            let is_read = matches!(op, Operation::Read(_));
            if prev_read != Some(is_read) {
                self.wire_start((address << 1) | u8::from(is_read))?;
                prev_read = Some(is_read);
            }
            match op {
                Operation::Write(bytes) => {
                    for &b in bytes.iter() {
                        self.wire_write(b)?;
                    }
                }
                Operation::Read(buf) => {
                    let len = buf.len();
                    for (k, slot) in buf.iter_mut().enumerate() {
                        let last = k + 1 == len && !next_is_read;
                        *slot = self.wire_read(!last)?;
                    }
                }
            }
        }
        Ok(())
    }
}

impl ErrorType for SimBus {
    type Error = SimBusError;
}

impl I2c for SimBus {
    fn transaction(
        &mut self,
        address: u8,
        operations: &mut [Operation<'_>],
    ) -> Result<(), Self::Error> {
        self.run(address, operations)
    }
}

/// Convenience: a field disturbance of `peak_body_ut` peaking at `peak_time_s`.
pub fn magnet_pass(peak_body_ut: Vec3, peak_time_s: f64, width_s: f64) -> Fault {
    Fault::Magnet(MagnetPass {
        peak_body_ut,
        peak_time_s,
        width_s,
        stays: false,
    })
}

/// Convenience: a magnet that approaches (the rising half of [`magnet_pass`]'s profile)
/// and from `peak_time_s` on rides along: a body-fixed offset of `peak_body_ut`.
pub fn magnet_ride(peak_body_ut: Vec3, peak_time_s: f64, width_s: f64) -> Fault {
    Fault::Magnet(MagnetPass {
        peak_body_ut,
        peak_time_s,
        width_s,
        stays: true,
    })
}
