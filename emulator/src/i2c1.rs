//! I2C1 master model (RM0008 §26, errata ES096).
//!
//! Placeholder with the agreed interface only, so the rest of the board can
//! boot the firmware: every address byte is not acknowledged (AF), as on a
//! bus with no chip on it. The real model replaces this file.

/// How PB6 (SCL) or PB7 (SDA) is configured in GPIOB (RM0008 §9.2.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PinMode {
    /// Alternate function, open drain: the I2C1 peripheral drives the line.
    AlternateOpenDrain,
    /// General-purpose output, open drain: ODR low pulls the line down.
    GpioOutputOpenDrain {
        /// ODR bit.
        high: bool,
    },
    /// General-purpose output, push-pull: the pin drives both levels.
    GpioOutputPushPull {
        /// ODR bit.
        high: bool,
    },
    /// Input (floating or with pull-up/down): the pin does not drive.
    Input,
}

const SB: u16 = 1 << 0;
const AF: u16 = 1 << 10;
const CR1_PE: u16 = 1 << 0;
const CR1_START: u16 = 1 << 8;
const CR1_STOP: u16 = 1 << 9;
const CR1_SWRST: u16 = 1 << 15;

/// I2C1 with the simulator's chips behind it (placeholder: no chip answers).
pub struct I2c1 {
    bus: sim::SimBus,
    regs: [u16; 9],
    sr1: u16,
    sb_at_ns: Option<u64>,
}

impl I2c1 {
    /// I2C1 in its reset state on `bus`.
    pub fn new(bus: sim::SimBus) -> Self {
        Self {
            bus,
            regs: [0; 9],
            sr1: 0,
            sb_at_ns: None,
        }
    }

    /// Register read at `offset` (CR1 0x00 … TRISE 0x20).
    pub fn read(&mut self, offset: u32, now_ns: u64) -> u16 {
        self.advance(now_ns);
        match offset {
            0x14 => self.sr1,
            0x18 => 0,
            o if o <= 0x20 && o % 4 == 0 => self.regs[(o / 4) as usize],
            _ => 0,
        }
    }

    /// Register write at `offset`.
    pub fn write(&mut self, offset: u32, value: u16, now_ns: u64) {
        self.advance(now_ns);
        match offset {
            0x00 => {
                if value & CR1_SWRST != 0 {
                    self.peripheral_reset();
                    self.regs[0] = CR1_SWRST;
                    return;
                }
                let mut v = value;
                if v & CR1_START != 0 && v & CR1_PE != 0 {
                    self.sb_at_ns = Some(now_ns + 2_500);
                    v &= !CR1_START;
                }
                if v & CR1_STOP != 0 {
                    v &= !CR1_STOP;
                }
                self.regs[0] = v;
            }
            0x10 if self.sr1 & SB != 0 => {
                self.sr1 &= !SB;
                self.sr1 |= AF;
            }
            0x14 => self.sr1 &= value | !0x0F00,
            o if o <= 0x20 && o % 4 == 0 => self.regs[(o / 4) as usize] = value,
            _ => {}
        }
    }

    /// Bus progress up to `now_ns`.
    pub fn advance(&mut self, now_ns: u64) {
        if let Some(t) = self.sb_at_ns {
            if now_ns >= t {
                self.sb_at_ns = None;
                self.sr1 |= SB;
            }
        }
    }

    /// When the state next changes by itself.
    pub fn next_event_ns(&self) -> Option<u64> {
        self.sb_at_ns
    }

    /// Pin configuration of PB6/PB7.
    pub fn set_pins(&mut self, _scl: PinMode, _sda: PinMode, _now_ns: u64) {}

    /// SCL line level.
    pub fn scl_high(&mut self, _now_ns: u64) -> bool {
        true
    }

    /// SDA line level.
    pub fn sda_high(&mut self, _now_ns: u64) -> bool {
        true
    }

    /// RCC APB1RSTR.I2C1RST.
    pub fn peripheral_reset(&mut self) {
        self.regs = [0; 9];
        self.sr1 = 0;
        self.sb_at_ns = None;
    }

    /// The simulated bus behind the pins.
    pub fn bus(&self) -> &sim::SimBus {
        &self.bus
    }
}
