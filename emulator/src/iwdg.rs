//! Independent watchdog (RM0008 §19): key register, prescaler and reload
//! with write access gated by 0x5555, a 12-bit down-counter on the LSI.

/// LSI nominal frequency (DS5319 table 28: 30–60 kHz, 40 kHz typical).
pub const LSI_NOMINAL_HZ: u32 = 40_000;

/// IWDG state.
#[derive(Clone, Debug)]
pub struct Iwdg {
    /// LSI frequency this board's RC oscillator runs at.
    pub lsi_hz: u32,
    pr: u32,
    rlr: u32,
    access: bool,
    running: bool,
    /// Time of the last reload (counter = RLR).
    reloaded_at_ns: u64,
    /// PVU/RVU busy until (5 LSI periods after a write, RM0008 §19.4.4).
    pvu_until: u64,
    rvu_until: u64,
}

impl Iwdg {
    /// Reset state (RM0008 §19.4: PR = 0, RLR = 0xFFF).
    pub fn new(lsi_hz: u32) -> Self {
        Self {
            lsi_hz,
            pr: 0,
            rlr: 0xFFF,
            access: false,
            running: false,
            reloaded_at_ns: 0,
            pvu_until: 0,
            rvu_until: 0,
        }
    }

    fn tick_ns(&self) -> u64 {
        let div = 4u64 << self.pr.min(6);
        div * 1_000_000_000 / u64::from(self.lsi_hz.max(1))
    }

    /// Whether the watchdog has been started.
    pub fn running(&self) -> bool {
        self.running
    }

    /// Time at which the counter reaches zero and resets the MCU.
    pub fn timeout_ns(&self) -> Option<u64> {
        self.running
            .then(|| self.reloaded_at_ns + (u64::from(self.rlr) + 1) * self.tick_ns())
    }

    /// Read at `offset` from 0x4000_3000.
    pub fn read(&self, offset: u32, now_ns: u64) -> Option<u32> {
        Some(match offset {
            0x00 => 0,
            0x04 => self.pr,
            0x08 => self.rlr,
            0x0C => u32::from(now_ns < self.pvu_until) | (u32::from(now_ns < self.rvu_until) << 1),
            _ => return None,
        })
    }

    /// Write at `offset`; `start` is true when the watchdog was just started
    /// (the LSI is forced on).
    pub fn write(&mut self, offset: u32, v: u32, now_ns: u64) -> Option<bool> {
        let five_lsi = 5 * 1_000_000_000 / u64::from(self.lsi_hz.max(1));
        match offset {
            0x00 => match v & 0xFFFF {
                0xCCCC => {
                    let started = !self.running;
                    self.running = true;
                    self.reloaded_at_ns = now_ns;
                    self.access = false;
                    return Some(started);
                }
                0xAAAA => {
                    self.reloaded_at_ns = now_ns;
                    self.access = false;
                }
                0x5555 => self.access = true,
                _ => self.access = false,
            },
            0x04 => {
                if self.access {
                    self.pr = v & 7;
                    self.pvu_until = now_ns + five_lsi;
                }
            }
            0x08 => {
                if self.access {
                    self.rlr = v & 0xFFF;
                    self.rvu_until = now_ns + five_lsi;
                }
            }
            0x0C => {}
            _ => return None,
        }
        Some(false)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timeouts_match_rm0008_table_96() {
        // RLR = 0xFFF at /4: 409.6 ms; at /256: 26.2 s (RM0008 §19.4, 40 kHz).
        let mut w = Iwdg::new(LSI_NOMINAL_HZ);
        w.write(0, 0xCCCC, 0);
        assert_eq!(w.timeout_ns(), Some(409_600_000));
        w.write(0, 0x5555, 0);
        w.write(4, 6, 0);
        w.write(0, 0xAAAA, 0);
        assert_eq!(w.timeout_ns(), Some(26_214_400_000));
    }

    #[test]
    fn prescaler_is_write_protected_without_the_access_key() {
        let mut w = Iwdg::new(LSI_NOMINAL_HZ);
        w.write(4, 3, 0);
        assert_eq!(w.read(4, 0), Some(0));
        w.write(0, 0x5555, 0);
        w.write(4, 3, 0);
        assert_eq!(w.read(4, 0), Some(3));
        assert_eq!(w.read(0xC, 0), Some(1));
        assert_eq!(w.read(0xC, 200_000), Some(0));
    }
}
