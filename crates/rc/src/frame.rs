//! The protocol-independent result of decoding: channel pulse widths.

/// Most channels any supported protocol carries (CRSF: 16, PPM: up to 16).
pub const MAX_CHANNELS: usize = 16;

/// One decoded set of channels, as pulse widths in microseconds.
///
/// Whatever the protocol, channels are expressed in the servo-pulse scale
/// every radio and flight controller shares: about 1000 µs at one stick end,
/// 1500 µs centre, 2000 µs at the other end. Entries at index `count` and
/// above are 0 and carry no data.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RcFrame {
    /// Channel 1 at index 0; µs.
    pub channels_us: [u16; MAX_CHANNELS],
    /// Number of valid channels (CRSF: always 16; PPM: 4..=16).
    pub count: u8,
}

impl RcFrame {
    /// A frame of `count` channels (clamped to 16); entries past `count`
    /// are cleared so two frames with the same data compare equal.
    pub fn new(channels_us: [u16; MAX_CHANNELS], count: u8) -> Self {
        let count = count.min(MAX_CHANNELS as u8);
        let mut channels_us = channels_us;
        for slot in channels_us.iter_mut().skip(usize::from(count)) {
            *slot = 0;
        }
        Self { channels_us, count }
    }

    /// Pulse width of channel `index` (0-based) in µs, or `None` when the
    /// frame does not carry it.
    pub fn channel_us(&self, index: usize) -> Option<u16> {
        if index < usize::from(self.count) {
            self.channels_us.get(index).copied()
        } else {
            None
        }
    }

    /// The valid channels as a slice.
    pub fn channels(&self) -> &[u16] {
        let n = usize::from(self.count).min(MAX_CHANNELS);
        self.channels_us.get(..n).unwrap_or(&[])
    }
}
