//! The pilot's radio link as the firmware receives it: the scripted sticks
//! and switches are packed into CRSF RC_CHANNELS_PACKED frames at 250 Hz
//! (ExpressLRS' common rate), the frame bytes go through `rc_input`'s
//! parser, channel map (AETR, arm on channel 5) and link monitor, and
//! `flight` turns the result into its `PilotInput`. While the script says
//! the link is lost no frame is sent: the link monitor's timeout is what
//! the flight controller sees.
//!
//! Channel 6 selects the mode: low angle, middle altitude hold, high acro.

use super::closed_loop::Mode;
use flight::flightctl::PilotInput;
use rc_input::crsf::{encode_rc_channels, us_to_ticks, ADDRESS_FLIGHT_CONTROLLER, TICKS_MID};
use rc_input::{ChannelMap, CrsfParser, Event, LinkMonitor, SwitchPosition, MAX_CHANNELS};
use sim::scenario::Pilot;

pub use sim::scenario::FRAME_PERIOD_S;
/// Channel index (0-based) of the mode switch: channel 6.
const MODE_CHANNEL: u8 = 5;

/// Transmitter, receiver bytes and the firmware's receiver code.
pub struct Radio {
    parser: CrsfParser,
    link: LinkMonitor,
    map: ChannelMap,
    next_frame_s: f64,
    last: Option<(rc_input::Sticks, bool, Mode)>,
    frames: u32,
}

impl Default for Radio {
    fn default() -> Self {
        Self {
            parser: CrsfParser::new(),
            link: LinkMonitor::crsf(),
            map: ChannelMap::DEFAULT,
            next_frame_s: 0.0,
            last: None,
            frames: 0,
        }
    }
}

impl Radio {
    /// Frames the parser accepted so far.
    pub fn frames(&self) -> u32 {
        self.frames
    }

    /// Sends the frames due by `t_s` (none while `script` is `None`: link
    /// lost), feeds their bytes to the parser, and returns what the
    /// firmware's pilot input is at `now_us`.
    pub fn poll(&mut self, t_s: f64, now_us: u32, script: Option<Pilot>) -> PilotInput {
        while self.next_frame_s <= t_s {
            self.next_frame_s += FRAME_PERIOD_S;
            let Some(p) = script else { continue };
            let mut ticks = [TICKS_MID; MAX_CHANNELS];
            let channels = p.channels_us();
            for (t, c) in ticks.iter_mut().zip(channels) {
                *t = us_to_ticks(c);
            }
            for b in encode_rc_channels(ADDRESS_FLIGHT_CONTROLLER, &ticks) {
                if let Some(Event::Channels(frame)) = self.parser.push(b, now_us) {
                    self.frames = self.frames.wrapping_add(1);
                    self.link.on_frame(now_us);
                    let mode = match ChannelMap::switch(&frame, MODE_CHANNEL) {
                        Ok(SwitchPosition::Low) => Mode::Angle,
                        Ok(SwitchPosition::High) => Mode::Acro,
                        _ => Mode::AltitudeHold,
                    };
                    if let (Ok(sticks), Ok(arm)) =
                        (self.map.sticks(&frame), self.map.arm_switch(&frame))
                    {
                        self.last = Some((sticks, arm, mode));
                    }
                }
            }
        }
        let link_ok = !self.link.is_lost(now_us);
        match self.last {
            Some((sticks, arm, mode)) => PilotInput::from_rc(&sticks, arm, mode, link_ok),
            None => PilotInput::default(),
        }
    }
}
