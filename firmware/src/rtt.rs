//! RTT for the STM32F103CB build: defmt's up channel and a down channel
//! the debug probe writes what the user types into (`cargo embed`'s
//! terminal, Embed.toml's `cb` profile), both in one control block from
//! `rtt-target`, which is also defmt's logger here: one logger, one
//! control block (`_SEGGER_RTT`), as defmt-rtt gives the C8 build, plus
//! the down channel defmt-rtt does not make.
//!
//! Up channel 0 ("defmt", 1 KiB, defmt-rtt's size) starts in NoBlockSkip:
//! a frame that does not fit is dropped, the firmware never waits for the
//! host (Embed.toml says why). Down channel 0 ("console", 64 B) is read
//! by the settings console (`console.rs`).

use rtt_target::{ChannelMode, DownChannel};

/// Sets up the control block and makes its up channel defmt's; returns
/// the console's down channel. Call once, first thing in `init`: log
/// lines written before it are dropped.
pub fn init() -> DownChannel {
    let channels = rtt_target::rtt_init! {
        up: {
            0: { size: 1024, mode: ChannelMode::NoBlockSkip, name: "defmt" }
        }
        down: {
            0: { size: 64, name: "console" }
        }
    };
    rtt_target::set_defmt_channel(channels.up.0);
    channels.down.0
}
