//! The emulated Blue Pill: memory map, MMIO dispatch to the peripheral
//! models, the run loop (instruction-count slices with interrupts delivered
//! between them), resets, RTT and the test/CLI API.
//!
//! Time: `Hw::cycles` counts core (HCLK) cycles and is the one clock:
//! simulated time is those cycles at the HCLK the firmware programs in RCC
//! ([`crate::rcc::CoreClock`]: 8 MHz HSI from reset, 72 MHz from the
//! crystal's PLL, 64 MHz from the HSI's), SysTick and DWT CYCCNT count
//! them, and every peripheral's event times are in ns on their own bus
//! clocks (TIM3/TIM4 on the APB1 timer clock, USART1 on PCLK2, I2C1 on
//! PCLK1, RM0008 §7.2). Each translated block costs the cycles the model in
//! [`crate::cycles`] gives its instructions (computed once per block), a
//! block reached by a taken branch its pipeline refill and flash wait
//! states, an exception its entry, tail-chain or return, an APB register
//! access its bridge cycles ([`BoardConfig::cycle_model`] picks typical or
//! pessimistic figures).

use crate::adc::{Adc, AdcError};
use crate::cycles::{self, CycleModel, ExceptionStep};
use crate::dma::{self, Dma};
use crate::elf::{Firmware, FLASH_BASE};
use crate::exceptions;
use crate::exti::{irq_of_line, Exti};
use crate::flash::{Flash, FlashEffect};
use crate::gpio::{Afio, PinConfig, Port};
use crate::i2c1::{I2c1, PinMode};
use crate::iwdg::{Iwdg, LSI_NOMINAL_HZ};
use crate::rcc::{CoreClock, Rcc, ResetCause, HSI_HZ};
use crate::rtt::{LogLine, RttError, RttHost, RttMode, TargetMemory};
use crate::scs::{Dwt, Nvic, SysTick, IRQ0, SYSTICK};
use crate::tim::GpTimer;
use crate::usart::{TxByte, Usart};
use std::path::Path;
use unicorn_engine::unicorn_const::{uc_error, Arch, Mode, Prot};
use unicorn_engine::{ArmCpuModel, RegisterARM, Unicorn};

/// SRAM base and size of the STM32F103C8 (20 KiB).
pub const RAM_BASE: u32 = 0x2000_0000;
/// SRAM size.
pub const RAM_SIZE: u32 = 20 * 1024;
/// The flash page the firmware keeps its calibration in: the last 1 KiB
/// (a medium-density STM32F103 page, RM0008 §3.3.3).
const CALIBRATION_PAGE_BYTES: u32 = 1024;
const PERIPH_BASE: u32 = 0x4000_0000;
const PERIPH_SIZE: u32 = 0x3_0000;
const PERIPH_BB: u32 = 0x4200_0000;
const RAM_BB: u32 = 0x2200_0000;
const PPB_BASE: u32 = 0xE000_0000;
const PPB_SIZE: u32 = 0x10_0000;
/// Longest slice between two looks at interrupts (≈ 0.28 ms).
const MAX_SLICE: u64 = 20_000;
/// Slice length while an interrupt is pending but masked, so that a
/// BASEPRI/PRIMASK release is seen within ~7 µs (unicorn has no hook on
/// MSR/CPSIE; a per-instruction hook would cost more than this latency).
const MASKED_SLICE: u64 = 500;
/// How often the host polls RTT (simulated), like a probe's poll loop.
const RTT_POLL_NS: u64 = 1_000_000;
/// EXTI9_5's exception number (the MPU-9250 INT on PB5).
pub const EXTI9_5: usize = IRQ0 + 23;
/// TIM3's exception number (RM0008 §10.1.2 table 63: IRQ 29).
pub const TIM3_IRQ: usize = IRQ0 + 29;
/// TIM4's exception number (IRQ 30).
pub const TIM4_IRQ: usize = IRQ0 + 30;
/// TIM4 channel inputs in channel order: PB6, PB7, PB8, PB9 (RM0008 §9.3.7
/// table 44, no remap). PB6/PB7 are I2C1's on this board; PB8 (TIM4_CH3)
/// and PB9 (TIM4_CH4) are free and 5 V tolerant.
pub const TIM4_PINS: [(usize, u32); 4] = [(1, 6), (1, 7), (1, 8), (1, 9)];
/// Pins the board already drives (button, MPU INT, I2C1, TIM3's outputs,
/// USART1 TX and RX, the LED): a test waveform may not fight them.
const BOARD_DRIVEN_PINS: [(usize, u32); 11] = [
    (0, 9),
    (0, 0),
    (1, 5),
    (1, 6),
    (1, 7),
    (0, 6),
    (0, 7),
    (1, 0),
    (1, 1),
    (0, 10),
    (2, 13),
];
/// USART1's exception number (IRQ 37).
pub const USART1_IRQ: usize = IRQ0 + 37;
/// DMA1 channel 4's exception number (IRQ 14): USART1_TX's channel.
pub const DMA1_CHANNEL4_IRQ: usize = IRQ0 + dma::CHANNEL1_IRQ + 3;
/// DMA1 channel 5's exception number (IRQ 15; channel `n` is IRQ `10 + n`).
pub const DMA1_CHANNEL5_IRQ: usize = IRQ0 + dma::CHANNEL1_IRQ + 4;
/// DMA1's registers (RM0008 §3.3, table 3).
const DMA1_BASE: u32 = 0x4002_0000;
const DMA1_END: u32 = 0x4002_03FF;
/// ADC1's exception number (ADC1_2, IRQ 18).
pub const ADC1_2_IRQ: usize = IRQ0 + 18;
/// ADC1's registers (RM0008 §3.3, table 3).
const ADC1_BASE: u32 = 0x4001_2400;
const ADC1_END: u32 = 0x4001_27FF;
/// ADC1 input pins of the 48-pin package, channel `n` at index `n`
/// (ADC12_IN0..9: PA0..PA7, PB0, PB1; datasheet DS5319 table 5).
pub const ADC1_PINS: [(usize, u32); 10] = [
    (0, 0),
    (0, 1),
    (0, 2),
    (0, 3),
    (0, 4),
    (0, 5),
    (0, 6),
    (0, 7),
    (1, 0),
    (1, 1),
];
const USART1_BASE: u32 = 0x4001_3800;
const USART1_END: u32 = 0x4001_3BFF;
/// TIM3 channel outputs in channel order: PA6, PA7, PB0, PB1 (RM0008
/// §9.3.7 table 43, no remap).
pub const TIM3_PINS: [(usize, u32); 4] = [(0, 6), (0, 7), (1, 0), (1, 1)];

/// What stops the emulated board.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum BoardError {
    /// A register the board does not model was accessed.
    Unmodelled {
        /// Address.
        addr: u32,
        /// Value written (`None`: a read).
        write: Option<u32>,
        /// Access size in bytes.
        size: usize,
        /// PC of the block doing it.
        pc: u32,
    },
    /// A peripheral was accessed with its RCC clock disabled (reads 0 and
    /// ignores writes on silicon: always a firmware bug).
    ClockDisabled {
        /// Which peripheral.
        peripheral: &'static str,
        /// Address.
        addr: u32,
        /// PC.
        pc: u32,
    },
    /// The CPU stopped on an emulation error (unmapped or protected access).
    Cpu(String),
    /// A core feature the board does not model.
    Unsupported(String),
    /// A flash access the controller answers with a bus error.
    FlashBusError(&'static str),
    /// An exception frame outside RAM (stack overflow).
    StackOutsideRam {
        /// Address.
        sp: u32,
    },
    /// The firmware configured a clock tree outside the manual's limits
    /// (RM0008 §7.2 maxima, §3.3.3 flash wait states for SYSCLK).
    Clock(String),
    /// The firmware used a peripheral against the manual's sequence
    /// (on silicon an undefined or wrong result, e.g. an ADC conversion
    /// before t_STAB or of a pin not in analog mode).
    Misuse(String),
    /// The firmware ELF could not be used.
    Elf(String),
}

impl std::fmt::Display for BoardError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Unmodelled {
                addr,
                write,
                size,
                pc,
            } => match write {
                Some(v) => write!(
                    f,
                    "write of {v:#x} ({size} B) to unmodelled register {addr:#010x} (pc {pc:#010x})"
                ),
                None => write!(
                    f,
                    "read ({size} B) of unmodelled register {addr:#010x} (pc {pc:#010x})"
                ),
            },
            Self::ClockDisabled {
                peripheral,
                addr,
                pc,
            } => write!(
                f,
                "{peripheral} accessed at {addr:#010x} with its RCC clock disabled (pc {pc:#010x})"
            ),
            Self::Cpu(e) => write!(f, "CPU stopped: {e}"),
            Self::Unsupported(e) => write!(f, "not modelled: {e}"),
            Self::FlashBusError(e) => write!(f, "flash bus error: {e}"),
            Self::StackOutsideRam { sp } => write!(f, "exception frame at {sp:#010x} outside RAM"),
            Self::Clock(e) => write!(f, "clock configuration: {e}"),
            Self::Misuse(e) => write!(f, "used against the manual: {e}"),
            Self::Elf(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for BoardError {}

/// Something that happened to the board (not printed by the firmware).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BoardEvent {
    /// Simulated time (ns).
    pub time_ns: u64,
    /// What.
    pub what: String,
}

/// Faults outside the simulator's chip models.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum BoardFault {
    /// The MPU-9250 INT line stops toggling (PB5 held low).
    ImuIntStops,
    /// The MPU-9250 INT line works again.
    ImuIntRestored,
    /// The host stops reading RTT (a closed `cargo embed`).
    RttReaderStops,
    /// The host reads RTT again.
    RttReaderResumes,
    /// Bytes put on USART1's RX line (PA10) back to back at the given
    /// baud rate, from now (or when the bytes before them are through).
    UsartRx {
        /// The bytes (8N1 frames).
        bytes: Vec<u8>,
        /// Line baud rate.
        baud: u32,
    },
    /// The button on PA0 is pressed (`true`) or released.
    Button(bool),
    /// A fault of the I2C1 peripheral itself (errata BUSY lock-up of the
    /// analog filter, spurious BERR).
    I2c(crate::i2c1::PeripheralFault),
    /// SysTick (hardware priority 0, above every configurable priority) is
    /// pended by the next write that sets I2C1 CR1.STOP while the receiver
    /// holds SCL low on BTF: an interrupt arriving inside ES096's
    /// "set STOP … read byte N−1" window, which must not be interrupted.
    /// Its handler then takes `handler_ns` longer than the firmware's own
    /// (a monotonic's timer queue waking tasks, a flash wait).
    SysTickInStopWindow {
        /// Extra time the CPU spends in that SysTick handler.
        handler_ns: u64,
    },
    /// The next I2C1 event interrupt taken while a received byte waits in
    /// DR finds that byte `ns` old at the earliest: the CPU was inside a
    /// section that masks interrupts (a log frame's critical section, a
    /// flash erase) or a longer SysTick from the byte's arrival on. A
    /// handler due earlier enters `ns` after the byte arrived; one due
    /// later is not delayed. One shot. It makes the EV7 late that errata
    /// ES096 §2.13.2 asks to serve before the next byte is transferred.
    I2cEventHeldOff {
        /// How long after the byte's arrival the handler can enter.
        ns: u64,
    },
}

/// A waveform driven onto a GPIO pin from outside the board (a receiver's
/// PPM output, a signal generator).
#[derive(Clone, Debug)]
struct DrivenPin {
    port: usize,
    pin: u32,
    /// The level now.
    high: bool,
    /// Edges still to come: (time in ns since power-on, new level).
    edges: std::collections::VecDeque<(u64, bool)>,
}

/// A translated block's size in bytes, instruction count, cycles (taken
/// branch refill excluded), and whether it is an idle loop.
#[derive(Clone, Copy, Debug, Default)]
struct BlockInfo {
    size: u32,
    insns: u32,
    cycles: u32,
    idle: bool,
}

/// What the CPU executed: instructions and the cycles they, the exception
/// entries and returns and the register accesses took (sleep and flash
/// programming stalls excluded), for the cycles per instruction.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Executed {
    /// Instructions retired.
    pub instructions: u64,
    /// Core cycles they took, all of the parts below included.
    pub cycles: u64,
    /// Of which taken-branch refills and their flash wait states.
    pub refill_cycles: u64,
    /// Of which exception entries, tail-chains and returns.
    pub exception_cycles: u64,
    /// Of which APB bridge cycles.
    pub bus_cycles: u64,
}

/// The state behind the CPU: every peripheral model and the board's wiring.
pub struct Hw {
    /// Core cycles since power-on (the time base).
    pub cycles: u64,
    /// Those cycles in ns, at the HCLK of the moment.
    core: CoreClock,
    /// Instructions and the cycles they took since power-on.
    pub executed: Executed,
    cycle_model: CycleModel,
    /// Where the last executed block falls through to (`None` after an
    /// exception entry or return, which pay their own refill).
    fall_through: Option<u32>,
    slice_end: u64,
    first_block: bool,
    exc_return: Option<u32>,
    cpu_fault: Option<(u32, u32)>,
    error: Option<BoardError>,
    /// NVIC and SCB.
    pub nvic: Nvic,
    systick: SysTick,
    dwt: Dwt,
    rcc: Rcc,
    /// Flash memory and controller.
    pub flash: Flash,
    ports: [Port; 3],
    afio: Afio,
    exti: Exti,
    iwdg: Iwdg,
    i2c: I2c1,
    tim3: GpTimer,
    tim4: GpTimer,
    usart1: Usart,
    dma1: Dma,
    adc1: Adc,
    driven: Vec<DrivenPin>,
    clock: sim::SimClock,
    tail_base: u32,
    blocks: Vec<BlockInfo>,
    /// Exception entries per exception number since power-on.
    pub entries: Vec<u64>,
    dbgmcu_cr: u32,
    button_pressed: bool,
    imu_int_cut: bool,
    stall_ns: u64,
    code_changed: bool,
    last_poll: Option<(u32, u16, u64)>,
    /// A register access in this slice may have moved the next event.
    resched: bool,
    /// [`BoardFault::SysTickInStopWindow`] armed: its handler's extra ns.
    systick_in_stop_window: Option<u64>,
    /// SysTick pended by that fault: the extra ns charged at its entry.
    systick_entry_stall_ns: Option<u64>,
    /// Times that SysTick preempted the STOP window (see
    /// [`Board::i2c1_stop_window_preemptions`]).
    i2c_stop_window_preemptions: u64,
    /// [`BoardFault::I2cEventHeldOff`] armed: its `ns`.
    i2c_event_held_off: Option<u64>,
    /// Times that fault fired (see [`Board::i2c1_events_held_off`]).
    i2c_events_held_off: u64,
}

impl Hw {
    fn now_ns(&self) -> u64 {
        self.core.ns_at(self.cycles)
    }

    fn fail(&mut self, e: BoardError) {
        if self.error.is_none() {
            self.error = Some(e);
        }
    }

    /// Charges `n` cycles of CPU work (not sleep).
    fn charge(&mut self, n: u32) {
        self.cycles += u64::from(n);
        self.executed.cycles += u64::from(n);
    }

    /// Charges an exception entry, late arrival, tail-chain or return;
    /// the next block starts a new fetch stream (its refill is included).
    pub(crate) fn charge_exception(&mut self, step: ExceptionStep) {
        let ws = self.flash.wait_states();
        let n = cycles::exception_cycles(self.cycle_model, step, ws);
        self.charge(n);
        self.executed.exception_cycles += u64::from(n);
        self.fall_through = None;
    }

    /// Refill cycles when the block at `addr` was reached by a taken
    /// branch (it does not start where the last block fell through).
    fn refill_into(&self, addr: u32) -> u32 {
        match self.fall_through {
            Some(ft) if ft != addr => {
                let in_flash = addr.wrapping_sub(FLASH_BASE) < self.flash.size();
                let ws = if in_flash {
                    self.flash.wait_states()
                } else {
                    0
                };
                cycles::refill_cycles(self.cycle_model, ft, addr, ws)
            }
            _ => 0,
        }
    }

    /// Bridge cycles of a CPU access to the register at `a` (APB1:
    /// 0x4000_0000–0x4000_7FFF, APB2: 0x4001_0000–0x4001_7FFF; RM0008
    /// §3.3 table 3); AHB registers and the PPB cost none.
    fn charge_bus_access(&mut self, a: u32) {
        let hclk = self.rcc.hclk_hz().max(1);
        let pclk = match a {
            0x4000_0000..=0x4000_7FFF => self.rcc.pclk1_hz(),
            0x4001_0000..=0x4001_7FFF => self.rcc.pclk2_hz(),
            _ => return,
        };
        let divider = (hclk / pclk.max(1)).max(1);
        let n = cycles::apb_access_cycles(self.cycle_model, divider);
        self.charge(n);
        self.executed.bus_cycles += u64::from(n);
    }

    fn sync_clock(&self) {
        self.clock.advance_to_ns(self.now_ns());
    }

    /// Applies the driven pins' edges up to `t_ns` in time order: the pin
    /// levels, TIM4's inputs (a timer input sees the pin whatever its GPIO
    /// mode, except analog) and the EXTI line of a selected pin.
    fn drive_pins_to(&mut self, t_ns: u64) {
        loop {
            let next = self
                .driven
                .iter()
                .enumerate()
                .filter_map(|(i, d)| d.edges.front().map(|&(t, _)| (t, i)))
                .filter(|&(t, _)| t <= t_ns)
                .min();
            let Some((t, i)) = next else { return };
            let d = &mut self.driven[i];
            let Some((_, high)) = d.edges.pop_front() else {
                return;
            };
            d.high = high;
            let (port, pin) = (d.port, d.pin);
            let level = self.ports[port].level(pin, Some(high));
            let tim4_mapped = self.afio.mapr & (1 << 12) == 0;
            if let Some(ch) = TIM4_PINS.iter().position(|&p| p == (port, pin)) {
                if tim4_mapped && !matches!(self.ports[port].config(pin), PinConfig::Analog) {
                    self.tim4.input(ch, level, t);
                }
            }
            if self.afio.exti_port(pin) as usize == port {
                self.exti.input(pin, level);
            }
        }
    }

    /// Time of the next edge of a driven pin.
    fn next_pin_edge_ns(&self) -> Option<u64> {
        self.driven
            .iter()
            .filter_map(|d| d.edges.front().map(|&(t, _)| t))
            .min()
    }

    /// Level of a GPIO pin including what the board drives onto it.
    fn pin_level(&mut self, port: usize, pin: u32) -> bool {
        let now = self.now_ns();
        if let Some(d) = self.driven.iter().find(|d| (d.port, d.pin) == (port, pin)) {
            let high = d.high;
            return self.ports[port].level(pin, Some(high));
        }
        let external = match (port, pin) {
            (0, 0) => self.button_pressed.then_some(false),
            (1, 5) => {
                self.sync_clock();
                let high = !self.imu_int_cut && {
                    let s = self.i2c.bus().state();
                    s.mpu.int_pin_high(now)
                };
                Some(high)
            }
            (0, 6) | (0, 7) | (1, 0) | (1, 1)
                if matches!(self.ports[port].config(pin), PinConfig::Alternate { .. })
                    && self.afio.mapr & (3 << 10) == 0 =>
            {
                let ch = TIM3_PINS
                    .iter()
                    .position(|&p| p == (port, pin))
                    .unwrap_or(0);
                return self.tim3.output_high(ch, now);
            }
            (0, 9) if self.usart1_tx_wired() => {
                self.usart1.advance(now);
                return self.usart1.tx_line_high(now);
            }
            (1, 6) if self.afio.mapr & 2 == 0 => {
                self.sync_clock();
                return self.i2c.scl_high(now);
            }
            (1, 7) if self.afio.mapr & 2 == 0 => {
                self.sync_clock();
                return self.i2c.sda_high(now);
            }
            _ => None,
        };
        self.ports[port].level(pin, external)
    }

    /// USART1's TX output reaches PA9: an alternate-function output, and
    /// USART1 not remapped to PB6 (AFIO_MAPR.USART1_REMAP, RM0008 §9.3.8).
    fn usart1_tx_wired(&self) -> bool {
        matches!(self.ports[0].config(9), PinConfig::Alternate { .. }) && self.afio.mapr & 4 == 0
    }

    /// Tells USART1 whether its TX line reaches the pin (after a GPIOA or
    /// AFIO write, or a reset).
    fn update_usart1_tx_pin(&mut self) {
        let wired = self.usart1_tx_wired();
        self.usart1.set_tx_pin_connected(wired);
    }

    fn idr(&mut self, port: usize) -> u32 {
        self.drive_pins_to(self.now_ns());
        (0..16).fold(0, |v, pin| {
            v | (u32::from(self.pin_level(port, pin)) << pin)
        })
    }

    fn pin_mode(&self, pin: u32) -> PinMode {
        let p = &self.ports[1];
        let high = p.odr & (1 << pin) != 0;
        match p.config(pin) {
            PinConfig::Alternate { .. } => PinMode::AlternateOpenDrain,
            PinConfig::Output { open_drain: true } => PinMode::GpioOutputOpenDrain { high },
            PinConfig::Output { open_drain: false } => PinMode::GpioOutputPushPull { high },
            _ => PinMode::Input,
        }
    }

    fn update_i2c_pins(&mut self) {
        let (scl, sda) = (self.pin_mode(6), self.pin_mode(7));
        let now = self.now_ns();
        self.sync_clock();
        self.i2c.set_pins(scl, sda, now);
    }

    /// Samples the EXTI-selected pins (edges latch pending bits).
    fn sample_exti(&mut self) {
        for line in 0..16 {
            let port = self.afio.exti_port(line) as usize;
            if port < 3 {
                let level = self.pin_level(port, line);
                self.exti.input(line, level);
            }
        }
    }

    /// The peripheral at `addr` if its RCC clock is off (an access to it is
    /// the firmware's bug: on silicon it reads 0 and writes are lost).
    fn unclocked(&self, addr: u32) -> Option<&'static str> {
        let (name, on) = match addr {
            0x4001_0000..=0x4001_03FF => ("AFIO", self.rcc.apb2enr & 1 != 0),
            0x4001_0800..=0x4001_0BFF => ("GPIOA", self.rcc.apb2enr & (1 << 2) != 0),
            0x4001_0C00..=0x4001_0FFF => ("GPIOB", self.rcc.apb2enr & (1 << 3) != 0),
            0x4001_1000..=0x4001_13FF => ("GPIOC", self.rcc.apb2enr & (1 << 4) != 0),
            0x4000_5400..=0x4000_57FF => ("I2C1", self.rcc.apb1enr & (1 << 21) != 0),
            0x4000_0400..=0x4000_07FF => ("TIM3", self.rcc.apb1enr & (1 << 1) != 0),
            0x4000_0800..=0x4000_0BFF => ("TIM4", self.rcc.apb1enr & (1 << 2) != 0),
            USART1_BASE..=USART1_END => ("USART1", self.rcc.apb2enr & (1 << 14) != 0),
            ADC1_BASE..=ADC1_END => ("ADC1", self.rcc.apb2enr & (1 << 9) != 0),
            DMA1_BASE..=DMA1_END => ("DMA1", self.rcc.ahbenr() & 1 != 0),
            _ => return None,
        };
        (!on).then_some(name)
    }

    /// Fails the run with [`BoardError::ClockDisabled`] if the peripheral at
    /// `addr` is unclocked (`pc` 0 for an access by the DMA). Whether it did.
    fn failed_on_unclocked(&mut self, addr: u32, pc: u32) -> bool {
        let Some(peripheral) = self.unclocked(addr) else {
            return false;
        };
        self.fail(BoardError::ClockDisabled {
            peripheral,
            addr,
            pc,
        });
        true
    }

    /// Word-register read (`None`: not modelled).
    fn periph_read(&mut self, a: u32) -> Option<u32> {
        self.periph_read_at(a, self.now_ns())
    }

    /// Word-register read by a bus master at `now` (the CPU now, the DMA
    /// when the peripheral requested it).
    fn periph_read_at(&mut self, a: u32, now: u64) -> Option<u32> {
        match a {
            0x4000_3000..=0x4000_33FF => self.iwdg.read(a - 0x4000_3000, now),
            0x4000_0400..=0x4000_07FF => {
                self.resched = true;
                self.tim3.read(a - 0x4000_0400, now)
            }
            0x4000_0800..=0x4000_0BFF => {
                self.resched = true;
                self.drive_pins_to(now);
                self.tim4.read(a - 0x4000_0800, now)
            }
            USART1_BASE..=USART1_END => {
                self.resched = true;
                self.usart1.read(a - USART1_BASE, now)
            }
            DMA1_BASE..=DMA1_END => self.dma1.read(a - DMA1_BASE),
            ADC1_BASE..=ADC1_END => {
                self.resched = true;
                self.adc1.read(a - ADC1_BASE, now)
            }
            0x4000_5400..=0x4000_5420 => {
                self.sync_clock();
                let off = a - 0x4000_5400;
                self.resched = true;
                let v = self.i2c.read(off, now);
                self.skip_idle_poll(off, v);
                Some(u32::from(v))
            }
            0x4001_0000..=0x4001_03FF => self.afio.read(a - 0x4001_0000),
            0x4001_0400..=0x4001_07FF => self.exti.read(a - 0x4001_0400),
            0x4001_0800..=0x4001_13FF => {
                let port = ((a - 0x4001_0800) / 0x400) as usize;
                let off = (a - 0x4001_0800) % 0x400;
                let idr = if off == 8 { self.idr(port) } else { 0 };
                self.ports[port].read(off, || idr)
            }
            0x4002_1000..=0x4002_13FF => self.rcc.read(a - 0x4002_1000, now),
            0x4002_2000..=0x4002_23FF => self.flash.read(a - 0x4002_2000),
            0xE000_1000..=0xE000_1FFF => self.dwt.read(a - 0xE000_1000, self.cycles),
            0xE000_E010..=0xE000_E01F => self.systick.read(a - 0xE000_E010, self.cycles),
            0xE000_EDF0 => Some(0), // DHCSR: no debugger halting
            0xE000_EDFC => Some(self.dwt.demcr()),
            0xE000_E000..=0xE000_EFFF => self.nvic.read(a - 0xE000_E000),
            0xE004_2000 => Some(0x2003_6410), // DBGMCU_IDCODE: medium density
            0xE004_2004 => Some(self.dbgmcu_cr),
            _ => None,
        }
    }

    /// Word-register write with byte-lane `mask`; false if not modelled.
    fn periph_write(&mut self, a: u32, v: u32, mask: u32) -> bool {
        self.periph_write_at(a, v, mask, self.now_ns())
    }

    /// Word-register write by a bus master at `now`.
    fn periph_write_at(&mut self, a: u32, v: u32, mask: u32, now: u64) -> bool {
        let merged = |old: u32| (old & !mask) | (v & mask);
        match a {
            0x4000_3000..=0x4000_33FF => match self.iwdg.write(a - 0x4000_3000, v & mask, now) {
                Some(started) => {
                    if started {
                        self.rcc.force_lsi(now);
                    }
                    true
                }
                None => false,
            },
            0x4000_0400..=0x4000_07FF => {
                let r = self.tim3.write(a - 0x4000_0400, merged(0), now);
                self.peripheral_result(r)
            }
            0x4000_0800..=0x4000_0BFF => {
                self.resched = true;
                self.drive_pins_to(now);
                let r = self.tim4.write(a - 0x4000_0800, merged(0), now);
                self.peripheral_result(r)
            }
            USART1_BASE..=USART1_END => {
                let r = self.usart1.write(a - USART1_BASE, merged(0), now);
                self.peripheral_result(r)
            }
            ADC1_BASE..=ADC1_END => {
                let r = self.adc1.write(a - ADC1_BASE, merged(0), now);
                self.adc_result(r)
            }
            DMA1_BASE..=DMA1_END => {
                let off = a - DMA1_BASE;
                let current = self.dma1.read(off).unwrap_or(0);
                let r = self.dma1.write(off, merged(current));
                self.peripheral_result(r)
            }
            0x4000_5400..=0x4000_5420 => {
                self.sync_clock();
                let value = if mask & 0xFFFF == 0 {
                    0
                } else {
                    (v & mask) as u16
                };
                // I2C1's DMA requests (DMA1 channels 6 and 7) are not wired
                // to the DMA model: a firmware using them would wait for
                // transfers that never come.
                if a - 0x4000_5400 == crate::i2c1::reg::CR2 && value & (1 << 11) != 0 {
                    self.fail(BoardError::Unsupported(
                        "I2C1 DMA requests (CR2.DMAEN) not modelled".into(),
                    ));
                }
                self.pend_in_stop_window(a - 0x4000_5400, value);
                self.i2c.write(a - 0x4000_5400, value, now);
                true
            }
            0x4001_0000..=0x4001_03FF => {
                self.drive_pins_to(now);
                let ok = self.afio.write(a - 0x4001_0000, v, mask);
                self.update_usart1_tx_pin();
                if self.afio.mapr & 2 != 0 {
                    self.fail(BoardError::Unsupported(
                        "I2C1 remapped to PB8/PB9 (AFIO_MAPR.I2C1_REMAP)".into(),
                    ));
                }
                ok
            }
            0x4001_0400..=0x4001_07FF => self.exti.write(a - 0x4001_0400, v, mask),
            0x4001_0800..=0x4001_13FF => {
                self.drive_pins_to(now);
                let port = ((a - 0x4001_0800) / 0x400) as usize;
                let ok = self.ports[port].write((a - 0x4001_0800) % 0x400, v, mask);
                if port == 1 {
                    self.update_i2c_pins();
                }
                self.update_usart1_tx_pin();
                self.adc1.advance(now);
                self.update_adc1_pins();
                ok
            }
            0x4002_1000..=0x4002_13FF => {
                let old_rst = self.rcc.apb1rstr;
                let old2 = self.rcc.apb2rstr;
                let off = a - 0x4002_1000;
                let current = self.rcc.read(off, now).unwrap_or(0);
                match self.rcc.write(off, merged(current), now) {
                    None => return false,
                    Some(Err(e)) => self.fail(BoardError::Clock(e)),
                    Some(Ok(())) => {}
                }
                if self.rcc.apb1rstr & (1 << 21) != 0 && old_rst & (1 << 21) == 0 {
                    self.i2c.peripheral_reset();
                }
                if self.rcc.apb1rstr & (1 << 1) != 0 {
                    self.tim3.reset();
                }
                self.drive_pins_to(now);
                if self.rcc.apb1rstr & (1 << 2) != 0 {
                    self.tim4.reset();
                }
                if self.rcc.apb2rstr & (1 << 14) != 0 {
                    self.usart1.reset();
                }
                if self.rcc.apb2rstr & (1 << 9) != 0 {
                    self.adc1.reset();
                }
                self.follow_clock_tree(now);
                for (bit, port) in [(2, 0), (3, 1), (4, 2)] {
                    if self.rcc.apb2rstr & (1 << bit) != 0 && old2 & (1 << bit) == 0 {
                        self.ports[port] = Port::default();
                    }
                }
                if self.rcc.apb2rstr & 1 != 0 {
                    self.afio = Afio::default();
                }
                self.update_usart1_tx_pin();
                self.update_adc1_pins();
                true
            }
            0x4002_2000..=0x4002_23FF => match self.flash.write(a - 0x4002_2000, v & mask) {
                Some(effect) => {
                    self.flash_effect(effect);
                    self.check_flash_latency();
                    true
                }
                None => false,
            },
            0xE000_1000..=0xE000_1FFF => self.dwt.write(a - 0xE000_1000, merged(0), self.cycles),
            0xE000_E010..=0xE000_E01F => self.systick.write(a - 0xE000_E010, v & mask, self.cycles),
            0xE000_EDF0..=0xE000_EDF8 => true, // DHCSR/DCRSR/DCRDR: debugger side
            0xE000_EDFC => {
                let d = merged(self.dwt.demcr());
                self.dwt.set_demcr(d, self.cycles);
                true
            }
            0xE000_E000..=0xE000_EFFF => self.nvic.write(a - 0xE000_E000, v, mask),
            0xE004_2004 => {
                self.dbgmcu_cr = merged(self.dbgmcu_cr);
                true
            }
            _ => false,
        }
    }

    /// The bus clocks and the core's time base follow RCC's clock tree from
    /// `now` on (RM0008 §7.2, figure 8): TIM3/TIM4 on the APB1 timer clock
    /// (PCLK1, ×2 when the APB1 prescaler is not 1), USART1 on PCLK2, I2C1
    /// on PCLK1, the CPU, SysTick and DWT on HCLK.
    fn follow_clock_tree(&mut self, now: u64) {
        self.tim3.set_clock_hz(self.rcc.apb1_timer_hz(), now);
        self.tim4.set_clock_hz(self.rcc.apb1_timer_hz(), now);
        self.usart1.set_pclk_hz(self.rcc.pclk2_hz());
        self.adc1.set_clock_hz(self.rcc.adc_hz(), now);
        self.sync_clock();
        self.i2c.set_pclk1_hz(self.rcc.pclk1_hz(), now);
        self.core.retune(self.rcc.hclk_hz(), self.cycles);
        self.check_flash_latency();
    }

    /// FLASH_ACR.LATENCY against SYSCLK (RM0008 §3.3.3: zero wait states
    /// up to 24 MHz, one up to 48 MHz, two up to 72 MHz): fewer than the
    /// manual asks for stops the board (the flash would return wrong data).
    fn check_flash_latency(&mut self) {
        let sysclk = self.rcc.sysclk_hz();
        let needed = match sysclk {
            0..=24_000_000 => 0,
            24_000_001..=48_000_000 => 1,
            _ => 2,
        };
        let ws = self.flash.wait_states();
        if ws < needed {
            self.fail(BoardError::Clock(format!(
                "FLASH_ACR.LATENCY {ws} at SYSCLK {sysclk} Hz: RM0008 §3.3.3 asks for {needed} wait states"
            )));
        }
    }

    /// A tight loop polling an unchanged I2C1 status or control register
    /// (the same value read again within a few instructions) would only
    /// spin until the peripheral's next bus event: skip to that event. Time
    /// (and so DWT timeouts) stays exact; only the loop's iteration count
    /// shrinks.
    fn skip_idle_poll(&mut self, off: u32, v: u16) {
        const POLL_WINDOW: u64 = 40;
        let same = self.last_poll.is_some_and(|(o, pv, c)| {
            o == off && pv == v && self.cycles.saturating_sub(c) <= POLL_WINDOW
        });
        self.last_poll = Some((off, v, self.cycles));
        if !same || !matches!(off, 0x00 | 0x14 | 0x18) {
            return;
        }
        if let Some(t) = self.i2c.next_event_ns() {
            let target = self.core.cycle_at(t).min(self.slice_end);
            if target > self.cycles {
                self.cycles = target;
            }
        }
    }

    /// Acts on a timer/USART write: not modelled (`false`), or a feature
    /// the model lacks (the board stops with the reason).
    fn peripheral_result(&mut self, r: Option<Result<(), String>>) -> bool {
        match r {
            None => false,
            Some(Err(e)) => {
                self.fail(BoardError::Unsupported(e));
                true
            }
            Some(Ok(())) => true,
        }
    }

    /// Acts on an ADC1 write: not a register (`false`), or an error that
    /// stops the board.
    fn adc_result(&mut self, r: Option<Result<(), AdcError>>) -> bool {
        match r {
            None => false,
            Some(Err(e)) => {
                self.fail(adc_board_error(e));
                true
            }
            Some(Ok(())) => true,
        }
    }

    /// Tells ADC1 which inputs have their pin in analog mode.
    fn update_adc1_pins(&mut self) {
        for (ch, &(port, pin)) in ADC1_PINS.iter().enumerate() {
            let analog = matches!(self.ports[port].config(pin), PinConfig::Analog);
            self.adc1.set_pin_analog(ch, analog);
        }
    }

    fn flash_effect(&mut self, effect: FlashEffect) {
        match effect {
            FlashEffect::None => {}
            FlashEffect::Stall { ns, changed } => {
                self.stall_ns += ns;
                if (changed.start as u32) < self.tail_base - FLASH_BASE {
                    self.code_changed = true;
                }
            }
            FlashEffect::BusError(e) => self.fail(BoardError::FlashBusError(e)),
        }
    }
}

impl Hw {
    /// [`BoardFault::SysTickInStopWindow`]: a CR1 write that sets STOP
    /// with the receiver on BTF pends SysTick (once).
    fn pend_in_stop_window(&mut self, off: u32, value: u16) {
        use crate::i2c1::{cr1, reg};
        if off == reg::CR1 && value & cr1::STOP != 0 && self.i2c.receiver_on_btf() {
            if let Some(ns) = self.systick_in_stop_window.take() {
                self.systick_entry_stall_ns = Some(ns);
                self.nvic.pending[SYSTICK] = true;
            }
        }
    }

    /// Exception `n` entered: SysTick pended by
    /// [`BoardFault::SysTickInStopWindow`] spends its extra time now.
    pub(crate) fn on_exception_entry(&mut self, n: usize) {
        if n == IRQ0 + 31 {
            self.hold_off_i2c_event();
        }
        if n == SYSTICK {
            if let Some(ns) = self.systick_entry_stall_ns.take() {
                let n = self.core.cycles_for(ns);
                self.charge(u32::try_from(n).unwrap_or(u32::MAX));
            }
        }
    }
}

impl Hw {
    /// [`BoardFault::I2cEventHeldOff`] at an I2C1_EV entry: with a
    /// received byte in DR, the entry waits until that byte is `ns` old
    /// (the CPU's time goes to the masking section).
    fn hold_off_i2c_event(&mut self) {
        let Some(ns) = self.i2c_event_held_off else {
            return;
        };
        let now = self.now_ns();
        self.sync_clock();
        self.i2c.advance(now);
        let Some(since) = self.i2c.rx_byte_waiting_since() else {
            return;
        };
        self.i2c_event_held_off = None;
        self.i2c_events_held_off += 1;
        let late = (since + ns).saturating_sub(now);
        self.charge(u32::try_from(self.core.cycles_for(late)).unwrap_or(u32::MAX));
    }
}

/// [`BoardFault::SysTickInStopWindow`] fired by this write: when the
/// execution priority lets SysTick in (PRIMASK clear, priority above the
/// running handler's), the core takes it between the STOP store and the
/// next instruction. The emulator takes exceptions between blocks only, and
/// the window's store and DR load are one block, so the preemption's time
/// (entry, the handler's extra time, return) is spent here, before the
/// load; the handler's own code runs at the block's end. Masked, SysTick
/// stays pending and spends that time when it is entered.
fn preempt_in_stop_window(uc: &mut Unicorn<'_, Hw>) {
    let Some(ns) = uc.get_data().systick_entry_stall_ns else {
        return;
    };
    let prio = exceptions::execution_priority(uc);
    let hw = uc.get_data_mut();
    if hw.nvic.deliverable(prio) != Some(SYSTICK) {
        return;
    }
    hw.systick_entry_stall_ns = None;
    hw.charge_exception(ExceptionStep::Entry);
    let n = hw.core.cycles_for(ns);
    hw.charge(u32::try_from(n).unwrap_or(u32::MAX));
    hw.charge_exception(ExceptionStep::Return);
    hw.i2c_stop_window_preemptions += 1;
}

/// Re-pends IRQs whose peripheral line is asserted (EXTI pending bits):
/// an NVIC input that is still high after its handler returns pends again.
pub fn refresh_irq_lines(hw: &mut Hw) {
    // I2C1_EV (31) and I2C1_ER (32), RM0008 §26.4 table 122.
    for (irq, on) in [(31, hw.i2c.event_irq()), (32, hw.i2c.error_irq())] {
        if on && !hw.nvic.active.contains(&(IRQ0 + irq)) {
            hw.nvic.pending[IRQ0 + irq] = true;
        }
    }
    for (n, on) in [
        (TIM3_IRQ, hw.tim3.irq()),
        (TIM4_IRQ, hw.tim4.irq()),
        (USART1_IRQ, hw.usart1.irq()),
        (ADC1_2_IRQ, hw.adc1.irq()),
    ] {
        if on && !hw.nvic.active.contains(&n) {
            hw.nvic.pending[n] = true;
        }
    }
    for ch in 0..dma::CHANNELS {
        let n = IRQ0 + dma::CHANNEL1_IRQ + ch;
        if hw.dma1.irq(ch) && !hw.nvic.active.contains(&n) {
            hw.nvic.pending[n] = true;
        }
    }
    for line in 0..19 {
        if let Some(irq) = irq_of_line(line) {
            let n = IRQ0 + irq;
            if hw.exti.irq_asserted(irq) && !hw.nvic.active.contains(&n) {
                hw.nvic.pending[n] = true;
            }
        }
    }
}

/// The board's error for an ADC1 error.
fn adc_board_error(e: AdcError) -> BoardError {
    match e {
        AdcError::Unmodelled(s) => BoardError::Unsupported(s),
        AdcError::Clock(s) => BoardError::Clock(s),
        AdcError::Misuse(s) => BoardError::Misuse(s),
    }
}

fn pc_of(uc: &Unicorn<'_, Hw>) -> u32 {
    uc.reg_read(RegisterARM::PC).unwrap_or(0) as u32
}

fn lanes(addr: u64, size: usize) -> (u32, u32, u32) {
    let shift = (addr as u32 & 3) * 8;
    let m = match size {
        1 => 0xFF,
        2 => 0xFFFF,
        _ => 0xFFFF_FFFF,
    };
    (addr as u32 & !3, shift, m << shift)
}

/// An access at `addr` to a peripheral whose clock is off: the run fails
/// with [`BoardError::ClockDisabled`] and stops. Whether it did.
fn stopped_on_unclocked(uc: &mut Unicorn<'_, Hw>, addr: u32, pc: u32) -> bool {
    if !uc.get_data_mut().failed_on_unclocked(addr, pc) {
        return false;
    }
    let _ = uc.emu_stop();
    true
}

fn mmio_read(uc: &mut Unicorn<'_, Hw>, addr: u32, size: usize) -> u64 {
    let (a, shift, mask) = lanes(u64::from(addr), size);
    let pc = pc_of(uc);
    if stopped_on_unclocked(uc, addr, pc) {
        return 0;
    }
    if dma_side(a) {
        let now = uc.get_data().now_ns();
        catch_up_usart1(uc, now);
    }
    let hw = uc.get_data_mut();
    hw.charge_bus_access(a);
    match hw.periph_read(a) {
        Some(v) => u64::from((v & mask) >> shift),
        None => {
            hw.fail(BoardError::Unmodelled {
                addr,
                write: None,
                size,
                pc,
            });
            let _ = uc.emu_stop();
            0
        }
    }
}

fn mmio_write(uc: &mut Unicorn<'_, Hw>, addr: u32, size: usize, value: u64) {
    let (a, shift, mask) = lanes(u64::from(addr), size);
    let pc = pc_of(uc);
    if stopped_on_unclocked(uc, addr, pc) {
        return;
    }
    if dma_side(a) {
        let now = uc.get_data().now_ns();
        catch_up_usart1(uc, now);
    }
    let hw = uc.get_data_mut();
    hw.charge_bus_access(a);
    let pend_before = hw.nvic.pending;
    let hclk_before = hw.core.hz();
    hw.resched = true;
    if !hw.periph_write(a, (value as u32) << shift, mask) {
        hw.fail(BoardError::Unmodelled {
            addr,
            write: Some(value as u32),
            size,
            pc,
        });
    }
    preempt_in_stop_window(uc);
    if dma_side(a) {
        // A channel enabled, or a request line raised, by this write.
        let now = uc.get_data().now_ns();
        serve_dma(uc, now);
        refresh_irq_lines(uc.get_data_mut());
    }
    let hw = uc.get_data_mut();
    // A write that pends an exception, stalls the CPU, resets or changes
    // HCLK (the slice's end is in cycles of the old clock) ends the slice
    // at the next block so the run loop acts on it at once. (Not
    // `emu_stop` here: unicorn would re-execute the store on restart.)
    if hw.error.is_some() {
        let _ = uc.emu_stop();
    } else if hw.stall_ns > 0
        || hw.nvic.reset_requested
        || hw.nvic.pending != pend_before
        || hw.code_changed
        || hw.core.hz() != hclk_before
        || (0x4001_0400..0x4001_0800).contains(&a)
    {
        hw.slice_end = hw.cycles;
    }
}

/// A peripheral or system-control register (not memory).
fn is_register(addr: u32) -> bool {
    (PERIPH_BASE..PERIPH_BASE + PERIPH_SIZE).contains(&addr)
        || (PPB_BASE..PPB_BASE + PPB_SIZE).contains(&addr)
}

/// A register of DMA1 or of a DMA requester: its state depends on the
/// transfers up to now.
fn dma_side(a: u32) -> bool {
    matches!(a, DMA1_BASE..=DMA1_END | USART1_BASE..=USART1_END)
}

/// DMA1's request lines (RM0008 §13.3.7 table 78), bit `n` = channel
/// `n + 1`. A new requester is one more line here (I2C1_RX: bit 6, channel
/// 7, from CR2.DMAEN and RxNE), the side effects of the DMA's access to its
/// data register in its own model (the same as the CPU's), and a
/// [`serve_dma`] wherever its model advances to an event that raises the
/// request, as [`catch_up_usart1`] does for USART1.
fn dma1_requests(hw: &Hw) -> u8 {
    u8::from(hw.usart1.rx_dma_request()) << 4 | u8::from(hw.usart1.tx_dma_request()) << 3
}

/// What a DMA access reaches (RM0008 §3.3, table 3 and figure 1: the DMA
/// masters SRAM, flash and the AHB/APB peripherals through the bus
/// matrix).
enum DmaTarget {
    Ram,
    Flash(u32),
    Periph,
    BusError,
}

fn dma_target(addr: u32, bytes: u32, flash_size: u32) -> DmaTarget {
    let end = u64::from(addr) + u64::from(bytes);
    let within = |base: u32, size: u32| addr >= base && end <= u64::from(base) + u64::from(size);
    if within(RAM_BASE, RAM_SIZE) {
        DmaTarget::Ram
    } else if within(FLASH_BASE, flash_size) {
        DmaTarget::Flash(addr - FLASH_BASE)
    } else if within(PERIPH_BASE, PERIPH_SIZE) {
        DmaTarget::Periph
    } else {
        DmaTarget::BusError
    }
}

/// The DMA reads `bytes` at `addr` at time `at_ns`; `None`: bus error.
fn dma_read(uc: &mut Unicorn<'_, Hw>, addr: u32, bytes: u32, at_ns: u64) -> Option<u32> {
    let mut b = [0u8; 4];
    let n = bytes as usize;
    match dma_target(addr, bytes, uc.get_data().flash.size()) {
        DmaTarget::Ram => {
            uc.mem_read(u64::from(addr), &mut b[..n]).ok()?;
            Some(u32::from_le_bytes(b))
        }
        DmaTarget::Flash(off) => {
            let hw = uc.get_data();
            let src = hw.flash.image.get(off as usize..off as usize + n)?;
            b[..n].copy_from_slice(src);
            Some(u32::from_le_bytes(b))
        }
        DmaTarget::Periph => {
            let (a, shift, mask) = lanes(u64::from(addr), n);
            let hw = uc.get_data_mut();
            if hw.failed_on_unclocked(addr, 0) {
                return Some(0);
            }
            match hw.periph_read_at(a, at_ns) {
                Some(v) => Some((v & mask) >> shift),
                None => {
                    hw.fail(BoardError::Unmodelled {
                        addr,
                        write: None,
                        size: n,
                        pc: 0,
                    });
                    Some(0)
                }
            }
        }
        DmaTarget::BusError => None,
    }
}

/// The DMA writes `v` (`bytes` wide) at `addr`; `None`: bus error (also a
/// write to flash, which is programmed only through its controller).
fn dma_write(uc: &mut Unicorn<'_, Hw>, addr: u32, bytes: u32, v: u32, at_ns: u64) -> Option<()> {
    let n = bytes as usize;
    match dma_target(addr, bytes, uc.get_data().flash.size()) {
        DmaTarget::Ram => uc.mem_write(u64::from(addr), &v.to_le_bytes()[..n]).ok(),
        DmaTarget::Periph => {
            let (a, shift, mask) = lanes(u64::from(addr), n);
            let hw = uc.get_data_mut();
            if !hw.failed_on_unclocked(addr, 0) && !hw.periph_write_at(a, v << shift, mask, at_ns) {
                hw.fail(BoardError::Unmodelled {
                    addr,
                    write: Some(v),
                    size: n,
                    pc: 0,
                });
            }
            Some(())
        }
        DmaTarget::Flash(_) | DmaTarget::BusError => None,
    }
}

/// Serves DMA1's pending requests at `at_ns`, one item per request, in the
/// arbiter's order.
fn serve_dma(uc: &mut Unicorn<'_, Hw>, at_ns: u64) {
    // Each item lowers its request (the DMA read or wrote the requester's
    // data register); the bound only stops a requester that never does.
    for _ in 0..1024 {
        let hw = uc.get_data();
        if hw.error.is_some() {
            return;
        }
        let Some(t) = hw.dma1.next_transfer(dma1_requests(hw)) else {
            return;
        };
        let moved = dma_read(uc, t.from, t.from_bytes, at_ns)
            .and_then(|v| dma_write(uc, t.to, t.to_bytes, t.value_written(v), at_ns));
        let hw = uc.get_data_mut();
        match moved {
            Some(()) => hw.dma1.complete(t.channel),
            None => hw.dma1.bus_error(t.channel),
        }
    }
}

/// Brings USART1 to `now_ns` one received byte and one transmitted frame
/// at a time, serving its DMA requests as each byte lands in DR and as
/// each frame leaves the shift register (the CPU may have been stalled,
/// or its registers not read, for many byte times).
fn catch_up_usart1(uc: &mut Unicorn<'_, Hw>, now_ns: u64) {
    loop {
        let hw = uc.get_data_mut();
        let next = [hw.usart1.next_byte_ns(), hw.usart1.next_tx_ns()]
            .into_iter()
            .flatten()
            .min();
        let Some(t) = next.filter(|&t| t <= now_ns) else {
            break;
        };
        hw.usart1.advance(t);
        serve_dma(uc, t);
    }
    uc.get_data_mut().usart1.advance(now_ns);
    serve_dma(uc, now_ns);
}

fn bitband_target(alias_base: u32, target_base: u32, off: u32) -> (u32, u32) {
    let _ = alias_base;
    (target_base + ((off >> 5) & !3), (off >> 2) & 31)
}

fn ram_bitband_read(uc: &mut Unicorn<'_, Hw>, off: u32) -> u64 {
    let (addr, bit) = bitband_target(RAM_BB, RAM_BASE, off);
    let mut b = [0u8; 4];
    let _ = uc.mem_read(u64::from(addr), &mut b);
    u64::from((u32::from_le_bytes(b) >> bit) & 1)
}

fn ram_bitband_write(uc: &mut Unicorn<'_, Hw>, off: u32, value: u64) {
    let (addr, bit) = bitband_target(RAM_BB, RAM_BASE, off);
    let mut b = [0u8; 4];
    let _ = uc.mem_read(u64::from(addr), &mut b);
    let mut w = u32::from_le_bytes(b);
    if value & 1 != 0 {
        w |= 1 << bit;
    } else {
        w &= !(1 << bit);
    }
    let _ = uc.mem_write(u64::from(addr), &w.to_le_bytes());
}

/// Instruction count of a Thumb-2 block and whether it is an idle loop
/// (a branch to itself, optionally after NOPs/WFIs): first halfwords
/// 0b11101, 0b11110 and 0b11111 start 32-bit instructions.
fn scan_block(code: &[u8], addr: u32) -> (u32, bool) {
    let hws: Vec<u16> = code
        .chunks_exact(2)
        .map(|c| u16::from_le_bytes([c[0], c[1]]))
        .collect();
    let mut n = 0;
    let mut i = 0;
    let mut last = (0usize, 1usize);
    while i < hws.len() {
        let wide = matches!(hws[i] >> 11, 0b11101..=0b11111);
        last = (i, if wide { 2 } else { 1 });
        i += last.1;
        n += 1;
    }
    let (li, lw) = last;
    let branch_to_start = match (lw, hws.get(li), hws.get(li + 1)) {
        (1, Some(&h), _) if h >> 11 == 0b11100 => {
            let imm = (i32::from(h & 0x7FF) << 21) >> 20;
            (addr as i32 + 2 * li as i32 + 4 + imm) as u32 == addr
        }
        (2, Some(&0xF7FF), Some(&0xBFFE)) => li == 0,
        _ => false,
    };
    let only_waits = hws[..li].iter().all(|&h| h == 0xBF00 || h == 0xBF30);
    (n.max(1), branch_to_start && only_waits)
}

/// Target memory as the debug probe sees it (no CPU cycles).
struct ProbeView<'a, 'b>(&'a mut Unicorn<'b, Hw>);

impl TargetMemory for ProbeView<'_, '_> {
    fn read_u32(&mut self, addr: u32) -> Option<u32> {
        let mut b = [0u8; 4];
        self.0.mem_read(u64::from(addr), &mut b).ok()?;
        Some(u32::from_le_bytes(b))
    }
    fn write_u32(&mut self, addr: u32, v: u32) -> Option<()> {
        self.0.mem_write(u64::from(addr), &v.to_le_bytes()).ok()
    }
    fn read_bytes(&mut self, addr: u32, buf: &mut [u8]) -> Option<()> {
        self.0.mem_read(u64::from(addr), buf).ok()
    }
    fn write_bytes(&mut self, addr: u32, bytes: &[u8]) -> Option<()> {
        self.0.mem_write(u64::from(addr), bytes).ok()
    }
}

/// Builds the configuration of a board.
#[derive(Clone, Debug)]
pub struct BoardConfig {
    /// The simulated world (its `bus_hz` is ignored: I2C1 times the bus).
    pub sim: sim::SimConfig,
    /// LSI frequency (the IWDG's clock; 30–60 kHz on real parts).
    pub lsi_hz: u32,
    /// RTT mode set on channel 0 at attach (`None`: leave the firmware's).
    pub rtt_mode: Option<RttMode>,
    /// Flash contents to start with instead of the ELF alone (e.g. with a
    /// calibration page from an earlier run).
    pub flash: Option<Vec<u8>>,
    /// The HSE crystal oscillates.
    pub hse_works: bool,
    /// Typical or pessimistic instruction, exception and bus timing.
    pub cycle_model: CycleModel,
}

impl Default for BoardConfig {
    fn default() -> Self {
        let embed = std::fs::read_to_string(crate::elf::workspace_root().join("Embed.toml"))
            .ok()
            .and_then(|t| RttMode::from_embed_toml(&t));
        Self {
            sim: sim::SimConfig::default(),
            lsi_hz: LSI_NOMINAL_HZ,
            rtt_mode: embed,
            flash: None,
            hse_works: true,
            cycle_model: CycleModel::Typical,
        }
    }
}

/// The emulated board running a firmware image.
pub struct Board {
    uc: Unicorn<'static, Hw>,
    bus: sim::SimBus,
    rtt: RttHost,
    lines: Vec<LogLine>,
    events: Vec<BoardEvent>,
    next_rtt_poll_ns: u64,
    locked_up: bool,
    resets: Vec<(u64, ResetCause)>,
    csr: u32,
}

/// Maps `size` bytes at `base` to the peripheral register models
/// ([`mmio_read`], [`mmio_write`]).
fn map_registers(uc: &mut Unicorn<'static, Hw>, base: u32, size: u32) -> Result<(), BoardError> {
    uc.mmio_map(
        u64::from(base),
        u64::from(size),
        Some(move |uc: &mut Unicorn<'_, Hw>, off: u64, size: usize| {
            mmio_read(uc, base + off as u32, size)
        }),
        Some(
            move |uc: &mut Unicorn<'_, Hw>, off: u64, size: usize, v: u64| {
                mmio_write(uc, base + off as u32, size, v)
            },
        ),
    )
    .map_err(uc_err)
}

fn uc_err(e: uc_error) -> BoardError {
    BoardError::Cpu(format!("{e:?}"))
}

impl Board {
    /// Boots the release ELF at `path` (power-on reset).
    pub fn from_elf(path: &Path, config: BoardConfig) -> Result<Self, BoardError> {
        let fw = Firmware::load(path).map_err(|e| BoardError::Elf(e.to_string()))?;
        Self::new(&fw, config)
    }

    /// Boots `fw` on a new board.
    pub fn new(fw: &Firmware, config: BoardConfig) -> Result<Self, BoardError> {
        let mut sim_cfg = config.sim.clone();
        sim_cfg.bus_hz = None;
        let clock = sim::SimClock::new();
        let bus = sim::SimBus::new(&clock, sim_cfg);
        let image = config.flash.clone().unwrap_or_else(|| fw.flash.clone());
        let flash_size = fw.flash.len() as u32;
        if image.len() != fw.flash.len() {
            return Err(BoardError::Elf(format!(
                "flash image is {} bytes, not the chip's {flash_size}",
                image.len()
            )));
        }
        // The image is plain read-only memory; the rest of the flash, from
        // the next 4 KiB boundary, goes through the flash model (erase and
        // programming). That rest always includes the last 1 KiB page, the
        // firmware's calibration page, even when the image reaches into
        // its 4 KiB block.
        let tail_base = fw
            .image_end
            .next_multiple_of(0x1000)
            .min(FLASH_BASE + flash_size - CALIBRATION_PAGE_BYTES);
        let mut rcc = Rcc::new(ResetCause::PowerOn, 0);
        rcc.hse_works = config.hse_works;
        let hw = Hw {
            cycles: 0,
            core: CoreClock::new(HSI_HZ),
            executed: Executed::default(),
            cycle_model: config.cycle_model,
            fall_through: None,
            slice_end: 0,
            first_block: true,
            exc_return: None,
            cpu_fault: None,
            error: None,
            nvic: Nvic::default(),
            systick: SysTick::default(),
            dwt: Dwt::default(),
            rcc,
            flash: Flash::new(image),
            ports: Default::default(),
            afio: Afio::default(),
            exti: Exti::default(),
            iwdg: Iwdg::new(config.lsi_hz),
            i2c: I2c1::new(bus.clone()),
            tim3: GpTimer::new("TIM3", HSI_HZ),
            tim4: GpTimer::new("TIM4", HSI_HZ),
            usart1: Usart::new("USART1", HSI_HZ),
            dma1: Dma::new(),
            adc1: Adc::new(HSI_HZ / 2),
            driven: Vec::new(),
            clock,
            tail_base,
            blocks: vec![BlockInfo::default(); flash_size as usize / 2],
            entries: vec![0; crate::scs::EXCEPTIONS],
            dbgmcu_cr: 0,
            button_pressed: false,
            imu_int_cut: false,
            stall_ns: 0,
            code_changed: false,
            last_poll: None,
            resched: false,
            systick_in_stop_window: None,
            systick_entry_stall_ns: None,
            i2c_stop_window_preemptions: 0,
            i2c_event_held_off: None,
            i2c_events_held_off: 0,
        };
        let mut uc =
            Unicorn::new_with_data(Arch::ARM, Mode::THUMB | Mode::MCLASS, hw).map_err(uc_err)?;
        uc.ctl_set_cpu_model(ArmCpuModel::CORTEX_M3 as i32)
            .map_err(uc_err)?;
        Self::map(&mut uc, tail_base, flash_size)?;
        let mut board = Self {
            uc,
            rtt: RttHost::new(fw.rtt_address, fw.table, config.rtt_mode),
            bus,
            lines: Vec::new(),
            events: Vec::new(),
            next_rtt_poll_ns: 0,
            locked_up: false,
            resets: Vec::new(),
            csr: 0,
        };
        board.reset(ResetCause::PowerOn)?;
        Ok(board)
    }

    fn map(
        uc: &mut Unicorn<'static, Hw>,
        tail_base: u32,
        flash_size: u32,
    ) -> Result<(), BoardError> {
        let code_len = u64::from(tail_base - FLASH_BASE);
        uc.mem_map(u64::from(FLASH_BASE), code_len, Prot::READ | Prot::EXEC)
            .map_err(uc_err)?;
        let tail_len = u64::from(FLASH_BASE + flash_size - tail_base);
        if tail_len > 0 {
            let base = tail_base;
            uc.mmio_map(
                u64::from(base),
                tail_len,
                Some(move |uc: &mut Unicorn<'_, Hw>, off: u64, size: usize| {
                    u64::from(
                        uc.get_data()
                            .flash
                            .read_memory(base - FLASH_BASE + off as u32, size),
                    )
                }),
                Some(
                    move |uc: &mut Unicorn<'_, Hw>, off: u64, size: usize, v: u64| {
                        let hw = uc.get_data_mut();
                        let e =
                            hw.flash
                                .write_memory(base - FLASH_BASE + off as u32, size, v as u32);
                        hw.flash_effect(e);
                        if hw.error.is_some() {
                            let _ = uc.emu_stop();
                        } else {
                            hw.slice_end = hw.cycles;
                        }
                    },
                ),
            )
            .map_err(uc_err)?;
        }
        uc.mem_map(u64::from(RAM_BASE), u64::from(RAM_SIZE), Prot::ALL)
            .map_err(uc_err)?;
        map_registers(uc, PERIPH_BASE, PERIPH_SIZE)?;
        uc.mmio_map(
            u64::from(PERIPH_BB),
            u64::from(PERIPH_SIZE) * 32,
            Some(|uc: &mut Unicorn<'_, Hw>, off: u64, _size: usize| {
                let (addr, bit) = bitband_target(PERIPH_BB, PERIPH_BASE, off as u32);
                (mmio_read(uc, addr, 4) >> bit) & 1
            }),
            Some(|uc: &mut Unicorn<'_, Hw>, off: u64, _size: usize, v: u64| {
                // A bit-band write is a locked read-modify-write of the word.
                let (addr, bit) = bitband_target(PERIPH_BB, PERIPH_BASE, off as u32);
                let w = mmio_read(uc, addr, 4) as u32;
                let w = if v & 1 != 0 {
                    w | (1 << bit)
                } else {
                    w & !(1 << bit)
                };
                mmio_write(uc, addr, 4, u64::from(w));
            }),
        )
        .map_err(uc_err)?;
        uc.mmio_map(
            u64::from(RAM_BB),
            u64::from(RAM_SIZE) * 32,
            Some(|uc: &mut Unicorn<'_, Hw>, off: u64, _size: usize| {
                ram_bitband_read(uc, off as u32)
            }),
            Some(|uc: &mut Unicorn<'_, Hw>, off: u64, _size: usize, v: u64| {
                ram_bitband_write(uc, off as u32, v)
            }),
        )
        .map_err(uc_err)?;
        map_registers(uc, PPB_BASE, PPB_SIZE)?;
        uc.add_block_hook(1, 0, |uc: &mut Unicorn<'_, Hw>, addr: u64, size: u32| {
            // Per-halfword cache of flash blocks (a hash map here cost more
            // than the emulation itself).
            let slot = (addr as u32).wrapping_sub(FLASH_BASE) as usize / 2;
            let known = uc
                .get_data()
                .blocks
                .get(slot)
                .copied()
                .filter(|b| b.size == size && b.insns > 0);
            let b = match known {
                Some(b) => b,
                None => {
                    let code = uc.mem_read_as_vec(addr, size as usize).unwrap_or_default();
                    let (insns, idle) = scan_block(&code, addr as u32);
                    let model = uc.get_data().cycle_model;
                    let cycles = cycles::block_cycles(&code, model);
                    let b = BlockInfo {
                        size,
                        insns,
                        cycles,
                        idle,
                    };
                    if let Some(cached) = uc.get_data_mut().blocks.get_mut(slot) {
                        *cached = b;
                    }
                    b
                }
            };
            // A stop requested here takes effect before this block runs, so
            // a block is counted only when it will execute; the first block
            // of a slice always runs (progress).
            let hw = uc.get_data_mut();
            if b.idle {
                // Nothing observable happens until the next event: sleep,
                // unless a register access since the slice started may have
                // scheduled an earlier one (then end the slice to recompute).
                if !std::mem::take(&mut hw.resched) {
                    hw.cycles = hw.cycles.max(hw.slice_end);
                }
                let _ = uc.emu_stop();
                return;
            }
            let refill = hw.refill_into(addr as u32);
            let cost = b.cycles + refill;
            if !hw.first_block && hw.cycles + u64::from(cost) > hw.slice_end {
                let _ = uc.emu_stop();
                return;
            }
            hw.first_block = false;
            hw.charge(cost);
            hw.executed.refill_cycles += u64::from(refill);
            hw.executed.instructions += u64::from(b.insns);
            hw.fall_through = Some(addr as u32 + size);
        })
        .map_err(uc_err)?;
        uc.add_intr_hook(|uc: &mut Unicorn<'_, Hw>, intno: u32| {
            let pc = pc_of(uc);
            let hw = uc.get_data_mut();
            match intno {
                8 => hw.exc_return = Some(pc | 1),
                // UDF (1), BKPT without a debugger (7), invalid state (18):
                // escalate to HardFault (HFSR.FORCED).
                1 | 7 | 18 => hw.cpu_fault = Some((pc, 1 << 30)),
                other => hw.fail(BoardError::Unsupported(format!(
                    "CPU exception {other} at pc {pc:#010x}"
                ))),
            }
            let _ = uc.emu_stop();
        })
        .map_err(uc_err)?;
        Ok(())
    }

    /// Resets the MCU: peripherals to reset values, RAM cleared, flash and
    /// the world outside the chip (sensors, bus lines, time) kept.
    pub fn reset(&mut self, cause: ResetCause) -> Result<(), BoardError> {
        let now = self.now_ns();
        let csr = self.csr;
        {
            let hw = self.uc.get_data_mut();
            let hse_works = hw.rcc.hse_works;
            hw.rcc = Rcc::new(cause, csr);
            hw.rcc.hse_works = hse_works;
            hw.nvic = Nvic::default();
            hw.systick = SysTick::default();
            hw.dwt = Dwt::default();
            let image = std::mem::take(&mut hw.flash.image);
            hw.flash = Flash::new(image);
            hw.ports = Default::default();
            hw.afio = Afio::default();
            hw.exti = Exti::default();
            hw.iwdg = Iwdg::new(hw.iwdg.lsi_hz);
            hw.i2c.peripheral_reset();
            hw.update_i2c_pins();
            hw.tim3.reset();
            hw.drive_pins_to(now);
            hw.tim4.reset();
            hw.usart1.reset();
            hw.update_usart1_tx_pin();
            hw.adc1.reset();
            hw.update_adc1_pins();
            // Back on the HSI (RM0008 §7.3.2: CFGR resets to 0).
            hw.follow_clock_tree(now);
            hw.dma1 = Dma::new();
            hw.exc_return = None;
            hw.cpu_fault = None;
            hw.fall_through = None;
            hw.stall_ns = 0;
            hw.code_changed = false;
            hw.dbgmcu_cr = 0;
        }
        let (code, tail_base) = {
            let hw = self.uc.get_data();
            (hw.flash.image.clone(), hw.tail_base)
        };
        let code_len = (tail_base - FLASH_BASE) as usize;
        self.uc
            .mem_write(u64::from(FLASH_BASE), &code[..code_len])
            .map_err(uc_err)?;
        self.uc
            .mem_write(u64::from(RAM_BASE), &vec![0; RAM_SIZE as usize])
            .map_err(uc_err)?;
        let sp = u32::from_le_bytes([code[0], code[1], code[2], code[3]]);
        let pc = u32::from_le_bytes([code[4], code[5], code[6], code[7]]);
        let regs = [
            (RegisterARM::PRIMASK, 0),
            (RegisterARM::BASEPRI, 0),
            (RegisterARM::FAULTMASK, 0),
            (RegisterARM::CONTROL, 0),
            (RegisterARM::XPSR, 1 << 24),
            (RegisterARM::SP, sp),
            (RegisterARM::LR, 0xFFFF_FFFF),
            (RegisterARM::PC, pc | 1),
        ];
        for (r, v) in regs {
            self.uc.reg_write(r, u64::from(v)).map_err(uc_err)?;
        }
        self.locked_up = false;
        self.rtt.target_reset();
        self.resets.push((now, cause));
        self.csr = self.uc.get_data().rcc.csr();
        if cause != ResetCause::PowerOn {
            self.event(format!("MCU reset ({cause:?}): RAM cleared, flash kept"));
        }
        Ok(())
    }

    fn event(&mut self, what: String) {
        self.events.push(BoardEvent {
            time_ns: self.now_ns(),
            what,
        });
    }

    /// Simulated time since power-on (ns).
    pub fn now_ns(&self) -> u64 {
        self.uc.get_data().now_ns()
    }

    /// Instructions executed since power-on and the cycles they took
    /// (their ratio is the cycle model's cycles per instruction).
    pub fn executed(&self) -> Executed {
        self.uc.get_data().executed
    }

    /// A word of the emulated memory (RAM or flash), as a debugger reads
    /// it; `None` outside mapped memory.
    pub fn read_word(&self, addr: u32) -> Option<u32> {
        let mut b = [0u8; 4];
        self.uc.mem_read(u64::from(addr), &mut b).ok()?;
        Some(u32::from_le_bytes(b))
    }

    /// Reads the word at `addr` as a debug probe does through its access
    /// port (no CPU cycles): memory, or a peripheral register through its
    /// model now (with its read side effects, e.g. SR then DR clears).
    pub fn debug_read(&mut self, addr: u32) -> Result<u32, BoardError> {
        if !is_register(addr) {
            return self
                .read_word(addr)
                .ok_or_else(|| BoardError::Cpu(format!("debug read of unmapped {addr:#010x}")));
        }
        let now = self.now_ns();
        catch_up_usart1(&mut self.uc, now);
        let hw = self.uc.get_data_mut();
        let v = if hw.failed_on_unclocked(addr, 0) {
            None
        } else {
            hw.periph_read(addr & !3)
        };
        match (hw.error.take(), v) {
            (Some(e), _) => Err(e),
            (None, Some(v)) => Ok(v),
            (None, None) => Err(BoardError::Unmodelled {
                addr,
                write: None,
                size: 4,
                pc: 0,
            }),
        }
    }

    /// Writes the word at `addr` as a debug probe does (no CPU cycles):
    /// memory, or a peripheral register through its model now; a register
    /// write the board refuses (unmodelled, unclocked, a clock tree out of
    /// the manual's limits) is the error.
    pub fn debug_write(&mut self, addr: u32, v: u32) -> Result<(), BoardError> {
        if !is_register(addr) {
            return self
                .uc
                .mem_write(u64::from(addr), &v.to_le_bytes())
                .map_err(uc_err);
        }
        let now = self.now_ns();
        catch_up_usart1(&mut self.uc, now);
        let hw = self.uc.get_data_mut();
        if !hw.failed_on_unclocked(addr, 0) && !hw.periph_write(addr & !3, v, u32::MAX) {
            hw.fail(BoardError::Unmodelled {
                addr,
                write: Some(v),
                size: 4,
                pc: 0,
            });
        }
        serve_dma(&mut self.uc, now);
        let hw = self.uc.get_data_mut();
        refresh_irq_lines(hw);
        hw.error.take().map_or(Ok(()), Err)
    }

    /// The simulator's bus (chips, world, truth, fault injection).
    pub fn sim(&self) -> &sim::SimBus {
        &self.bus
    }

    /// I2C1 receiver bytes handed to the firmware wrong because it read
    /// byte N−1 after the STOP reached the bus (errata ES096 "Wrong data
    /// read into data register"), since power-on.
    pub fn i2c1_late_last_byte_reads(&self) -> u64 {
        self.uc.get_data().i2c.late_last_byte_reads()
    }

    /// DR reads since power-on that raced the end of the byte on the wire
    /// (errata ES096 §2.13.2's late EV7): each read a byte twice or lost
    /// one.
    pub fn i2c1_late_ev7_reads(&self) -> u64 {
        self.uc.get_data().i2c.late_ev7_reads()
    }

    /// How many [`BoardFault::I2cEventHeldOff`] faults have fired.
    pub fn i2c1_events_held_off(&self) -> u64 {
        self.uc.get_data().i2c_events_held_off
    }

    /// How many [`BoardFault::SysTickInStopWindow`] SysTicks preempted the
    /// firmware inside the window (the rest waited for it to close).
    pub fn i2c1_stop_window_preemptions(&self) -> u64 {
        self.uc.get_data().i2c_stop_window_preemptions
    }

    /// Every log line decoded so far.
    pub fn log_lines(&self) -> &[LogLine] {
        &self.lines
    }

    /// Board events (resets, faults taken) so far.
    pub fn events(&self) -> &[BoardEvent] {
        &self.events
    }

    /// MCU resets so far: (time, cause), the power-on first.
    pub fn resets(&self) -> &[(u64, ResetCause)] {
        &self.resets
    }

    /// How many times exception `n` was entered since power-on.
    pub fn exception_entries(&self, n: usize) -> u64 {
        self.uc.get_data().entries.get(n).copied().unwrap_or(0)
    }

    /// Current flash contents (64 KiB from 0x0800_0000).
    pub fn flash_image(&self) -> &[u8] {
        &self.uc.get_data().flash.image
    }

    /// The LED on PC13 (active low) is lit.
    pub fn led_on(&self) -> bool {
        let p = &self.uc.get_data().ports[2];
        matches!(p.config(13), PinConfig::Output { .. }) && p.odr & (1 << 13) == 0
    }

    /// TIM3 channel `ch` (0..4) as seen on its pin (PA6, PA7, PB0, PB1):
    /// (period, high time) in ns of the waveform the timer's active
    /// registers produce now. `None` while the pin is not an
    /// alternate-function output (no pulses reach the ESC) or the counter
    /// is stopped.
    pub fn esc_pwm_ns(&mut self, ch: usize) -> Option<(u64, u64)> {
        let now = self.now_ns();
        let hw = self.uc.get_data_mut();
        let &(port, pin) = TIM3_PINS.get(ch)?;
        let af = matches!(
            hw.ports[port].config(pin),
            PinConfig::Alternate { open_drain: false }
        );
        if !af || hw.afio.mapr & (3 << 10) != 0 {
            return None;
        }
        hw.tim3.advance(now);
        hw.tim3.pwm_ns(ch)
    }

    /// Level of a GPIO pin now (`port` 0 = A, 1 = B, 2 = C), including
    /// what the board and the peripherals drive onto it.
    pub fn pin_high(&mut self, port: usize, pin: u32) -> bool {
        self.uc.get_data_mut().pin_level(port, pin)
    }

    /// Drives `(time_ns, high)` edges onto a GPIO pin (`port` 0 = A, 1 = B,
    /// 2 = C) from outside the board, after the edges already queued: the
    /// pin reads that level from each edge's time on, and TIM4's channel
    /// input on PB6..PB9 sees each edge at its time (not when the firmware
    /// next looks). Times are ns since power-on, not in the past and not
    /// decreasing. A pin the board itself drives (button, MPU INT, I2C1,
    /// TIM3's outputs, USART1 RX, LED) is refused, as is a pin outside the
    /// ports.
    pub fn drive_pin(
        &mut self,
        port: usize,
        pin: u32,
        edges: &[(u64, bool)],
    ) -> Result<(), BoardError> {
        let now = self.now_ns();
        let hw = self.uc.get_data_mut();
        if port > 2 || pin > 15 || BOARD_DRIVEN_PINS.contains(&(port, pin)) {
            return Err(BoardError::Unsupported(format!(
                "driving pin P{}{pin}: not a free pin of this board",
                char::from(b'A' + port.min(25) as u8)
            )));
        }
        let i = match hw
            .driven
            .iter()
            .position(|d| (d.port, d.pin) == (port, pin))
        {
            Some(i) => i,
            None => {
                let high = hw.ports[port].level(pin, None);
                hw.driven.push(DrivenPin {
                    port,
                    pin,
                    high,
                    edges: Default::default(),
                });
                hw.driven.len() - 1
            }
        };
        let d = &mut hw.driven[i];
        let mut last = d.edges.back().map_or(now, |&(t, _)| t.max(now));
        for &(t, _) in edges {
            if t < last {
                return Err(BoardError::Unsupported(format!(
                    "pin waveform: edge at {t} ns is before {last} ns (the past or an earlier edge)"
                )));
            }
            last = t;
        }
        d.edges.extend(edges.iter().copied());
        Ok(())
    }

    /// Edges queued by [`Board::drive_pin`] and not reached yet.
    pub fn pending_pin_edges(&self) -> usize {
        self.uc
            .get_data()
            .driven
            .iter()
            .map(|d| d.edges.len())
            .sum()
    }

    /// USART1: bytes received into DR and bytes lost to overrun since the
    /// last reset.
    pub fn usart1_counts(&self) -> (u64, u64) {
        self.uc.get_data().usart1.counts()
    }

    /// Sets the voltage on ADC1 input `channel` (0..16; 0..9 are PA0..PA7,
    /// PB0, PB1) from now on: a conversion whose sample phase ends later
    /// converts it (VREF+ = 3.3 V, 12 bits, clamped).
    pub fn adc1_set_input_v(&mut self, channel: usize, volts: f64) {
        let now = self.now_ns();
        self.uc.get_data_mut().adc1.set_input_v(channel, volts, now);
    }

    /// Sets the offset (LSB) ADC1 adds to every code until it is
    /// calibrated (the chip's; 0 unless set).
    pub fn adc1_set_uncalibrated_offset_lsb(&mut self, lsb: i32) {
        self.uc.get_data_mut().adc1.set_uncalibrated_offset_lsb(lsb);
    }

    /// ADC1: regular and injected conversions completed and calibrations
    /// run since the last reset.
    pub fn adc1_counts(&self) -> (u64, u64, u64) {
        self.uc.get_data().adc1.counts()
    }

    /// Whether ADC1 completed a calibration since its last power-up.
    pub fn adc1_calibrated(&self) -> bool {
        self.uc.get_data().adc1.calibrated()
    }

    /// USART1's TX line: the data frames that reached PA9 so far (kept
    /// across MCU resets), in order, up to now.
    pub fn usart1_tx_log(&mut self) -> &[TxByte] {
        let now = self.now_ns();
        catch_up_usart1(&mut self.uc, now);
        self.uc.get_data().usart1.tx_log()
    }

    /// Takes USART1's TX line log up to now (the log starts empty again):
    /// for a long scenario that decodes the line as it goes.
    pub fn usart1_take_tx(&mut self) -> Vec<TxByte> {
        let now = self.now_ns();
        catch_up_usart1(&mut self.uc, now);
        self.uc.get_data_mut().usart1.take_tx_log()
    }

    /// USART1 data frames shifted out while PA9 was not wired to the
    /// transmitter (not an alternate-function output, or remapped).
    pub fn usart1_tx_unseen(&self) -> u64 {
        self.uc.get_data().usart1.tx_unseen()
    }

    /// DMA1: items each channel moved since the last reset.
    pub fn dma1_served(&self) -> [u64; dma::CHANNELS] {
        self.uc.get_data().dma1.served()
    }

    /// When USART1's RX line has sent everything injected so far (ns).
    pub fn usart1_line_free_ns(&self) -> Option<u64> {
        self.uc.get_data().usart1.line_free_ns()
    }

    /// Puts `bytes` on USART1's RX line back to back at `baud`, the first
    /// start bit at `at_ns` (or now, or when the bytes queued before them
    /// are through, whichever is latest): a sender on its own schedule,
    /// whatever the board does meanwhile (a flash erase stalls the CPU, not
    /// the line).
    pub fn usart1_send_at(&mut self, bytes: &[u8], baud: u32, at_ns: u64) {
        let now = self.now_ns();
        catch_up_usart1(&mut self.uc, now);
        self.uc
            .get_data_mut()
            .usart1
            .inject(bytes, baud, at_ns.max(now));
    }

    /// Applies a board-level fault or stimulus now.
    pub fn apply(&mut self, fault: BoardFault) {
        if let BoardFault::UsartRx { bytes, baud } = &fault {
            let now = self.now_ns();
            catch_up_usart1(&mut self.uc, now);
            self.uc.get_data_mut().usart1.inject(bytes, *baud, now);
            // Byte-level stimuli would flood the event list.
            return;
        }
        let hw = self.uc.get_data_mut();
        match &fault {
            BoardFault::UsartRx { .. } => {}
            BoardFault::ImuIntStops => hw.imu_int_cut = true,
            BoardFault::ImuIntRestored => hw.imu_int_cut = false,
            BoardFault::Button(p) => hw.button_pressed = *p,
            BoardFault::RttReaderStops => self.rtt.reading = false,
            BoardFault::RttReaderResumes => self.rtt.reading = true,
            BoardFault::SysTickInStopWindow { handler_ns } => {
                hw.systick_in_stop_window = Some(*handler_ns);
            }
            BoardFault::I2cEventHeldOff { ns } => hw.i2c_event_held_off = Some(*ns),
            BoardFault::I2c(f) => {
                let now = hw.now_ns();
                hw.sync_clock();
                hw.i2c.inject(*f, now);
            }
        }
        self.event(format!("{fault:?}"));
    }

    /// Whether the host reads RTT.
    pub fn rtt_reading(&self) -> bool {
        self.rtt.reading
    }

    /// Runs for `ns` of simulated time.
    pub fn run_for_ns(&mut self, ns: u64) -> Result<(), BoardError> {
        let t = self.now_ns() + ns;
        self.run_until_ns(t)
    }

    /// Runs until `t_ns` (simulated); stops early with the error that
    /// stopped the board.
    pub fn run_until_ns(&mut self, t_ns: u64) -> Result<(), BoardError> {
        // `t_ns` in cycles of the clock of the moment: a slice ends where
        // HCLK changes, and the next one converts again.
        loop {
            let hw = self.uc.get_data();
            let end = hw.core.cycle_at(t_ns);
            if hw.cycles >= end {
                break;
            }
            self.step(end)?;
        }
        self.poll_rtt();
        Ok(())
    }

    /// Runs until a new log line containing `pattern` appears, for at most
    /// `timeout_ns` of simulated time; returns the line.
    pub fn wait_for_line(
        &mut self,
        pattern: &str,
        timeout_ns: u64,
    ) -> Result<Option<LogLine>, BoardError> {
        let deadline = self.now_ns() + timeout_ns;
        let mut seen = self.lines.len();
        while self.now_ns() < deadline {
            let t = (self.now_ns() + RTT_POLL_NS).min(deadline);
            self.run_until_ns(t)?;
            if let Some(l) = self.lines[seen..].iter().find(|l| l.text.contains(pattern)) {
                return Ok(Some(l.clone()));
            }
            seen = self.lines.len();
        }
        Ok(None)
    }

    fn poll_rtt(&mut self) {
        let now = self.now_ns();
        let new = self.rtt.poll(&mut ProbeView(&mut self.uc), now);
        self.lines.extend(new);
    }

    /// Writes `bytes` into RTT down channel `channel` as a probe does when
    /// the user types into `cargo embed`'s terminal: what fits in the ring
    /// without passing the target's read offset, now. Returns how many
    /// bytes went in; an error when the control block has no such down
    /// channel (see [`RttError`]).
    pub fn rtt_write_down(&mut self, channel: u32, bytes: &[u8]) -> Result<usize, RttError> {
        self.rtt
            .write_down(&mut ProbeView(&mut self.uc), channel, bytes)
    }

    /// Brings the peripherals to the current time and acts on what they
    /// did: SysTick, EXTI edges, watchdog and software resets, RTT.
    fn service(&mut self) -> Result<(), BoardError> {
        let now = self.now_ns();
        if now >= self.next_rtt_poll_ns {
            self.poll_rtt();
            self.next_rtt_poll_ns = now + RTT_POLL_NS;
        }
        catch_up_usart1(&mut self.uc, now);
        let hw = self.uc.get_data_mut();
        if let Some(e) = hw.error.take() {
            return Err(e);
        }
        if hw.systick.advance(hw.cycles) {
            hw.nvic.pending[SYSTICK] = true;
        }
        hw.sync_clock();
        hw.i2c.advance(now);
        hw.tim3.advance(now);
        hw.drive_pins_to(now);
        hw.tim4.advance(now);
        hw.adc1.advance(now);
        if let Some(e) = hw.adc1.take_fault() {
            return Err(adc_board_error(e));
        }
        hw.sample_exti();
        refresh_irq_lines(hw);
        if hw.nvic.reset_requested {
            self.reset(ResetCause::Software)?;
        } else if hw.iwdg.timeout_ns().is_some_and(|t| now >= t) {
            self.event("IWDG timeout".into());
            self.reset(ResetCause::Watchdog)?;
        }
        Ok(())
    }

    /// Cycle of the next thing that happens without the CPU.
    fn next_event_cycle(&self, end: u64) -> u64 {
        let hw = self.uc.get_data();
        let now = hw.cycles;
        let mut next = end.min(now + MAX_SLICE);
        let mut at_ns = |t: Option<u64>| {
            if let Some(t) = t {
                next = next.min(hw.core.cycle_at(t).max(now + 1));
            }
        };
        at_ns(Some(self.next_rtt_poll_ns));
        at_ns(hw.i2c.next_event_ns());
        at_ns(hw.rcc.next_event_ns());
        at_ns(hw.iwdg.timeout_ns());
        at_ns(hw.tim3.next_update_ns());
        at_ns(hw.tim4.next_update_ns());
        at_ns(hw.tim4.next_input_ns());
        at_ns(hw.next_pin_edge_ns());
        at_ns(hw.usart1.next_event_ns());
        at_ns(hw.adc1.next_event_ns());
        let s = self.bus.state();
        at_ns(Some(s.mpu.next_sample_ns()));
        if let Some(last) = s.mpu.last_sample_ns() {
            let fall = last + 50_001;
            if fall > hw.now_ns() {
                at_ns(Some(fall));
            }
        }
        drop(s);
        if let Some(t) = hw.systick.next_event() {
            next = next.min(t.max(now + 1));
        }
        next
    }

    fn step(&mut self, end: u64) -> Result<(), BoardError> {
        self.service()?;
        if self.locked_up {
            let next = self.next_event_cycle(end);
            self.uc.get_data_mut().cycles = next;
            return Ok(());
        }
        exceptions::deliver(&mut self.uc)?;
        let mut slice_end = self.next_event_cycle(end);
        {
            let hw = self.uc.get_data();
            if hw.nvic.highest_pending().is_some() {
                slice_end = slice_end.min(hw.cycles + MASKED_SLICE);
            }
        }
        let hw = self.uc.get_data_mut();
        hw.slice_end = slice_end;
        hw.first_block = true;
        hw.resched = false;
        let pc = pc_of(&self.uc);
        let r = self.uc.emu_start(u64::from(pc | 1), 0, 0, 0);
        let hw = self.uc.get_data_mut();
        if hw.stall_ns > 0 {
            hw.cycles += hw.core.cycles_for(hw.stall_ns);
            hw.stall_ns = 0;
        }
        if hw.code_changed {
            hw.code_changed = false;
            let tail = hw.tail_base;
            let code: Vec<u8> = hw.flash.image[..(tail - FLASH_BASE) as usize].to_vec();
            hw.blocks.fill(BlockInfo::default());
            self.uc
                .mem_write(u64::from(FLASH_BASE), &code)
                .map_err(uc_err)?;
            let _ = self
                .uc
                .ctl_remove_cache(u64::from(FLASH_BASE), u64::from(tail));
        }
        if let Some(e) = self.uc.get_data_mut().error.take() {
            return Err(e);
        }
        if let Err(e) = r {
            return Err(BoardError::Cpu(format!(
                "{e:?} at pc {:#010x}",
                pc_of(&self.uc)
            )));
        }
        if let Some(ret) = self.uc.get_data_mut().exc_return.take() {
            exceptions::exception_return(&mut self.uc, ret)?;
        }
        if let Some((pc, hfsr)) = self.uc.get_data_mut().cpu_fault.take() {
            self.event(format!("HardFault (fault at pc {pc:#010x})"));
            if !exceptions::fault(&mut self.uc, pc, hfsr)? {
                self.event("lockup: fault inside HardFault".into());
                self.locked_up = true;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
#[allow(clippy::panic)]
mod tests {
    use super::*;
    use crate::elf::FLASH_SIZE;

    #[test]
    fn block_scan_counts_wide_and_narrow_instructions() {
        // movs r0,#1 ; ldr.w r1,[r2] ; b .-6
        let code = [0x01, 0x20, 0xD2, 0xF8, 0x00, 0x10, 0xFB, 0xE7];
        assert_eq!(scan_block(&code, 0x100), (3, false));
        // b . (0xE7FE)
        assert_eq!(scan_block(&[0xFE, 0xE7], 0x100), (1, true));
        // nop ; b .-2 back to the nop
        assert_eq!(scan_block(&[0x00, 0xBF, 0xFD, 0xE7], 0x100), (2, true));
    }

    /// A bare image: vector table (SP, reset, SysTick → 0x120), `code` at
    /// 0x100, a SysTick handler `adds r4, #1; bx lr` at 0x120.
    fn bare(code: &[u16], literal: u32) -> Firmware {
        let mut flash = vec![0xFF; FLASH_SIZE as usize];
        let mut put = |at: usize, w: u32| flash[at..at + 4].copy_from_slice(&w.to_le_bytes());
        put(0, 0x2000_5000);
        put(4, 0x0800_0101);
        put(15 * 4, 0x0800_0121);
        for (i, h) in code.iter().enumerate() {
            flash[0x100 + 2 * i..0x102 + 2 * i].copy_from_slice(&h.to_le_bytes());
        }
        flash[0x10C..0x110].copy_from_slice(&literal.to_le_bytes());
        flash[0x120..0x124].copy_from_slice(&[0x01, 0x34, 0x70, 0x47]);
        Firmware {
            flash,
            rtt_address: RAM_BASE,
            image_end: FLASH_BASE + 0x200,
            table: None,
            symbols: Default::default(),
        }
    }

    fn reg(b: &Board, r: RegisterARM) -> u32 {
        b.uc.reg_read(r).unwrap_or(0) as u32
    }

    #[test]
    fn systick_exceptions_stack_run_the_handler_and_unstack() {
        // ldr r0,=SYST; movs r1,#100; str r1,[r0,#4]; movs r1,#7; str r1,[r0]; b .
        let fw = bare(
            &[0x4802, 0x2164, 0x6041, 0x2107, 0x6001, 0xE7FE],
            0xE000_E010,
        );
        let mut b = Board::new(&fw, BoardConfig::default()).unwrap_or_else(|e| panic!("{e}"));
        // The core runs on the 8 MHz HSI from reset: 125 ns a cycle.
        b.run_until_ns(10_100 * 125)
            .unwrap_or_else(|e| panic!("{e}"));
        let ticks = reg(&b, RegisterARM::R4);
        // One tick every LOAD + 1 = 101 cycles from the enable.
        assert!((97..=100).contains(&ticks), "{ticks} ticks");
        assert_eq!(u64::from(ticks), b.exception_entries(SYSTICK));
        assert_eq!(reg(&b, RegisterARM::SP), 0x2000_5000, "frame unstacked");
        assert_eq!(reg(&b, RegisterARM::IPSR), 0, "back in thread mode");
        assert_eq!(reg(&b, RegisterARM::PC), 0x0800_010A);
    }

    #[test]
    fn a_driven_pin_follows_its_waveform_in_emulated_time() {
        // b . (an idle loop): the board only advances time.
        let fw = bare(&[0xE7FE], 0);
        let mut b = Board::new(&fw, BoardConfig::default()).unwrap_or_else(|e| panic!("{e}"));
        assert!(b.drive_pin(1, 6, &[(10, true)]).is_err(), "PB6 is I2C1's");
        assert!(
            b.drive_pin(0, 0, &[(10, true)]).is_err(),
            "PA0 is the button"
        );
        assert!(b.drive_pin(3, 0, &[(10, true)]).is_err(), "no port D");
        let edges = [(100_000, true), (400_000, false), (1_100_000, true)];
        assert!(b.drive_pin(1, 8, &edges).is_ok());
        assert!(
            b.drive_pin(1, 8, &[(1_000_000, false)]).is_err(),
            "before an edge already queued"
        );
        // PB8 at reset is a floating input: it reads what is driven.
        let mut seen = Vec::new();
        for t in [50_000, 150_000, 450_000, 1_200_000] {
            b.run_until_ns(t).unwrap_or_else(|e| panic!("{e}"));
            seen.push(b.pin_high(1, 8));
        }
        assert_eq!(seen, [false, true, false, true]);
        assert_eq!(b.pending_pin_edges(), 0);
        assert!(
            b.drive_pin(1, 8, &[(1_000_000, false)]).is_err(),
            "the past"
        );
    }

    #[test]
    fn unmodelled_register_stops_the_board() {
        // ldr r0,=TIM2; ldr r1,[r0]; b .
        let fw = bare(&[0x4802, 0x6801, 0xE7FE], 0x4000_0000);
        let mut b = Board::new(&fw, BoardConfig::default()).unwrap_or_else(|e| panic!("{e}"));
        let e = b.run_until_ns(1_000).err();
        assert!(
            matches!(
                e,
                Some(BoardError::Unmodelled {
                    addr: 0x4000_0000,
                    write: None,
                    ..
                })
            ),
            "{e:?}"
        );
    }

    #[test]
    fn unclocked_peripheral_stops_the_board_on_read_and_write() {
        // ldr r0,=addr; ldr r1,[r0]; b .   and   ldr r0,=addr; str r1,[r0]; b .
        // I2C1 on APB1; DMA1 (its CNDTR5) on AHB, whose enable is off at reset.
        for (addr, name) in [(0x4000_5400, "I2C1"), (0x4002_005C, "DMA1")] {
            for code in [[0x4802, 0x6801, 0xE7FE], [0x4802, 0x6001, 0xE7FE]] {
                let fw = bare(&code, addr);
                let mut b =
                    Board::new(&fw, BoardConfig::default()).unwrap_or_else(|e| panic!("{e}"));
                let e = b.run_until_ns(1_000).err();
                assert!(
                    matches!(
                        &e,
                        Some(BoardError::ClockDisabled {
                            peripheral,
                            addr: a,
                            ..
                        }) if *peripheral == name && *a == addr
                    ),
                    "{code:x?}: {e:?}"
                );
            }
        }
    }

    #[test]
    fn the_probe_writes_a_down_channel_in_target_ram() {
        let fw = bare(&[0xE7FE], 0);
        let mut b = Board::new(&fw, BoardConfig::default()).unwrap_or_else(|e| panic!("{e}"));
        let e = b.rtt_write_down(0, b"x").err();
        assert_eq!(e, Some(RttError::NoControlBlock { address: RAM_BASE }));
        // "SEGGER RTT", one up and one down channel, the down channel's
        // 32-byte buffer at 0x2000_0100.
        let id = *b"SEGGER RTT\0\0\0\0\0\0";
        for (i, w) in id.chunks_exact(4).enumerate() {
            let w = u32::from_le_bytes([w[0], w[1], w[2], w[3]]);
            b.debug_write(RAM_BASE + 4 * i as u32, w)
                .unwrap_or_else(|e| panic!("{e}"));
        }
        let down = RAM_BASE + 24 + 24;
        for (a, v) in [
            (RAM_BASE + 16, 1),
            (RAM_BASE + 20, 1),
            (down + 4, RAM_BASE + 0x100),
            (down + 8, 32),
        ] {
            b.debug_write(a, v).unwrap_or_else(|e| panic!("{e}"));
        }
        assert_eq!(b.rtt_write_down(0, b"save\n"), Ok(5));
        assert_eq!(b.read_word(down + 12), Some(5));
        assert_eq!(
            b.read_word(RAM_BASE + 0x100),
            Some(u32::from_le_bytes(*b"save"))
        );
        assert!(matches!(
            b.rtt_write_down(1, b"x"),
            Err(RttError::NoDownChannel {
                channel: 1,
                available: 1
            })
        ));
    }

    /// Writes `(address, value)` pairs as a debugger does.
    fn poke(b: &mut Board, writes: &[(u32, u32)]) {
        for &(a, v) in writes {
            b.debug_write(a, v)
                .unwrap_or_else(|e| panic!("{a:#x} <- {v:#x}: {e}"));
        }
    }

    #[test]
    fn adc1_converts_the_host_voltage_on_its_pin_and_pends_adc1_2() {
        let fw = bare(&[0xE7FE], 0);
        let mut b = Board::new(&fw, BoardConfig::default()).unwrap_or_else(|e| panic!("{e}"));
        let e = b.debug_write(ADC1_BASE + 8, 1).err();
        assert!(
            matches!(
                e,
                Some(BoardError::ClockDisabled {
                    peripheral: "ADC1",
                    ..
                })
            ),
            "{e:?}"
        );
        // GPIOA and ADC1 clocked; PA1 analog, PA2 floating input. ADCCLK
        // from reset: 8 MHz HSI / 2 = 4 MHz.
        poke(
            &mut b,
            &[
                (0x4002_1018, (1 << 2) | (1 << 9)),
                (0x4001_0800, 0x4444_4404),
            ],
        );
        poke(&mut b, &[(ADC1_BASE + 8, 1)]);
        b.run_for_ns(2_000).unwrap_or_else(|e| panic!("{e}"));
        poke(&mut b, &[(ADC1_BASE + 8, 1 | (1 << 2))]);
        // t_CAL: 83 cycles at 4 MHz, 20.75 µs.
        b.run_for_ns(20_000).unwrap_or_else(|e| panic!("{e}"));
        assert_ne!(b.debug_read(ADC1_BASE + 8).unwrap_or(0) & (1 << 2), 0);
        b.run_for_ns(1_000).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(b.debug_read(ADC1_BASE + 8).unwrap_or(0) & (1 << 2), 0);
        assert!(b.adc1_calibrated());
        b.adc1_set_input_v(1, 1.0);
        // SQ1 = channel 1, EOCIE, ADON written again: 14 cycles, 3.5 µs.
        poke(
            &mut b,
            &[
                (ADC1_BASE + 0x34, 1),
                (ADC1_BASE + 4, 1 << 5),
                (ADC1_BASE + 8, 1),
            ],
        );
        b.run_for_ns(3_000).unwrap_or_else(|e| panic!("{e}"));
        assert!(!b.uc.get_data().nvic.pending[ADC1_2_IRQ]);
        b.run_for_ns(1_000).unwrap_or_else(|e| panic!("{e}"));
        assert!(b.uc.get_data().nvic.pending[ADC1_2_IRQ], "EOC with EOCIE");
        assert_eq!(b.debug_read(ADC1_BASE + 0x4C).ok(), Some(1241));
        assert_eq!(b.adc1_counts(), (1, 0, 1));
        // PA2 is not an analog input: the sample stops the board.
        poke(&mut b, &[(ADC1_BASE + 0x34, 2), (ADC1_BASE + 8, 1)]);
        let e = b.run_for_ns(5_000).err();
        assert!(matches!(e, Some(BoardError::Misuse(_))), "{e:?}");
    }

    #[test]
    fn usart1_sends_a_dma_buffer_on_pa9() {
        let fw = bare(&[0xE7FE], 0);
        let mut b = Board::new(&fw, BoardConfig::default()).unwrap_or_else(|e| panic!("{e}"));
        b.debug_write(
            RAM_BASE + 0x100,
            u32::from_le_bytes([0xC8, 0x04, 0x21, 0x7E]),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        // GPIOA, USART1, DMA1 clocked; PA9 alternate push-pull; 115200
        // baud at 8 MHz (BRR 69: 115,942 baud); TE, DMAT.
        poke(
            &mut b,
            &[
                (0x4002_1018, (1 << 2) | (1 << 14)),
                (0x4002_1014, 0x15),
                (0x4001_0804, 0x4444_44B4),
                (USART1_BASE + 8, 69),
                (USART1_BASE + 0x0C, (1 << 13) | (1 << 3)),
                (USART1_BASE + 0x14, 1 << 7),
                (USART1_BASE, !(1 << 6)),
                (DMA1_BASE + dma::reg::cpar(4), USART1_BASE + 4),
                (DMA1_BASE + dma::reg::cmar(4), RAM_BASE + 0x100),
                (DMA1_BASE + dma::reg::cndtr(4), 4),
                (
                    DMA1_BASE + dma::reg::ccr(4),
                    dma::ccr::DIR | dma::ccr::MINC | dma::ccr::EN,
                ),
            ],
        );
        let t0 = b.now_ns();
        b.run_for_ns(1_000_000).unwrap_or_else(|e| panic!("{e}"));
        let log = b.usart1_tx_log().to_vec();
        let bytes: Vec<u8> = log.iter().map(|f| f.byte).collect();
        assert_eq!(bytes, [0xC8, 0x04, 0x21, 0x7E]);
        // After the idle frame, back to back, ten bits of 69 / 8 MHz each.
        let frame_ns = 10.0 * 69.0 / 8.0e6 * 1e9;
        assert!((log[0].start_ns - t0) as f64 >= frame_ns - 1.0);
        for w in log.windows(2) {
            assert_eq!(w[0].end_ns, w[1].start_ns);
            assert!(((w[1].end_ns - w[1].start_ns) as f64 - frame_ns).abs() <= 1.0);
        }
        assert_eq!(b.dma1_served()[3], 4);
        assert_ne!(b.debug_read(USART1_BASE).unwrap_or(0) & (1 << 6), 0, "TC");
        assert!(b.pin_high(0, 9), "the line idles high");
    }

    #[test]
    fn the_time_base_is_the_hsi_from_reset() {
        let fw = bare(&[0xE7FE], 0);
        let mut b = Board::new(&fw, BoardConfig::default()).unwrap_or_else(|e| panic!("{e}"));
        b.run_until_ns(1_000_000).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(b.uc.get_data().cycles, 8_000);
    }
}
