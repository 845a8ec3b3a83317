//! `--fault KIND[@T]`: the simulator's fault kinds (`sim::Fault`) by name,
//! with the magnitudes a user would see on a real board.

use super::run::ScheduledFault;
use sim::{Chip, Fault, Vibration, AK8963_ADDRESS};

/// A fault kind by name: (name, what it does).
pub const KINDS: [(&str, &str); 19] = [
    (
        "magnet",
        "a magnet passes the board: 60 µT peak on body x, 4 s wide, peaking 2 s after T",
    ),
    (
        "magnet-ride",
        "a magnet is attached ~5 cm from the board and rides along: 30 µT body-fixed \
         (20, -15, 15 on body x, y, z), reached 2 s after T",
    ),
    (
        "vibration",
        "unbalanced props from T on: 3 m/s² and 4 °/s at 85 Hz on every axis",
    ),
    (
        "frozen-imu",
        "MPU-9250 data stop updating (data-ready keeps firing)",
    ),
    ("frozen-mag", "AK8963 data stop updating"),
    ("frozen-baro", "MS5611 conversions stop updating"),
    (
        "mag-overflow",
        "every AK8963 sample reports magnetic overflow (HOFL)",
    ),
    (
        "nack-imu",
        "the MPU-9250 does not acknowledge its next 50 transactions",
    ),
    (
        "nack-mag",
        "the AK8963 does not acknowledge its next 50 transactions",
    ),
    (
        "nack-baro",
        "the MS5611 does not acknowledge its next 50 transactions",
    ),
    (
        "bus-error",
        "one transaction fails with a bus error after 2 data bytes",
    ),
    (
        "arbitration-loss",
        "the next 5 transactions lose arbitration",
    ),
    (
        "stuck-bus",
        "SDA held low: every transaction fails to the end of the run",
    ),
    (
        "scl-stuck",
        "SCL held low (a shorted line): no transaction to the end of the run",
    ),
    (
        "holds-sda-imu",
        "the MPU-9250 is left mid-byte holding SDA low until SCL is clocked",
    ),
    ("wrong-id-mag", "the AK8963 reports WIA 0x00 from T on"),
    (
        "reset-imu",
        "the MPU-9250 resets itself (registers back to power-on values)",
    ),
    ("reset-mag", "the AK8963 resets itself"),
    ("reset-baro", "the MS5611 resets itself"),
];

/// The MPU-9250's address on the demo board (AD0 low).
const MPU_ADDRESS: u8 = 0x68;
/// The MS5611's address on the demo board (CSB low).
const MS5611_ADDRESS: u8 = 0x77;

fn fault(kind: &str, at_s: f64) -> Option<Fault> {
    let nack = |address| Fault::Nack {
        address,
        transactions: Some(50),
    };
    Some(match kind {
        "magnet" => sim::magnet_pass([60.0, 0.0, 0.0], at_s + 2.0, 4.0),
        "magnet-ride" => sim::magnet_ride([20.0, -15.0, 15.0], at_s + 2.0, 4.0),
        "vibration" => Fault::Vibration(Vibration {
            accel_amplitude_mps2: 3.0,
            gyro_amplitude_dps: 4.0,
            frequency_hz: 85.0,
        }),
        "frozen-imu" => Fault::Frozen(Chip::Mpu9250),
        "frozen-mag" => Fault::Frozen(Chip::Ak8963),
        "frozen-baro" => Fault::Frozen(Chip::Ms5611),
        "mag-overflow" => Fault::MagOverflow,
        "nack-imu" => nack(MPU_ADDRESS),
        "nack-mag" => nack(AK8963_ADDRESS),
        "nack-baro" => nack(MS5611_ADDRESS),
        "bus-error" => Fault::BusErrorMidTransfer { after_bytes: 2 },
        "arbitration-loss" => Fault::ArbitrationLoss { transactions: 5 },
        "stuck-bus" => Fault::StuckBus,
        "scl-stuck" => Fault::SclStuckLow,
        "holds-sda-imu" => Fault::SlaveHoldsSda(Chip::Mpu9250),
        "wrong-id-mag" => Fault::WrongChipId {
            chip: Chip::Ak8963,
            id: 0x00,
        },
        "reset-imu" => Fault::ChipReset(Chip::Mpu9250),
        "reset-mag" => Fault::ChipReset(Chip::Ak8963),
        "reset-baro" => Fault::ChipReset(Chip::Ms5611),
        _ => return None,
    })
}

/// Parses `KIND` or `KIND@T` (T in seconds of flight time, default 0).
pub fn parse(spec: &str) -> Result<ScheduledFault, String> {
    let (kind, at) = match spec.split_once('@') {
        Some((k, t)) => (k, Some(t)),
        None => (spec, None),
    };
    let at_s = match at {
        None => 0.0,
        Some(t) => t
            .parse::<f64>()
            .ok()
            .filter(|t| t.is_finite() && *t >= 0.0)
            .ok_or_else(|| format!("`{t}` is not a time in seconds >= 0 (KIND@T)"))?,
    };
    let names: Vec<&str> = KINDS.iter().map(|(n, _)| *n).collect();
    let fault = fault(kind, at_s)
        .ok_or_else(|| format!("unknown fault kind `{kind}` (one of {})", names.join(", ")))?;
    Ok(ScheduledFault { at_s, fault })
}

/// The `--help` text listing the kinds.
pub fn help() -> String {
    let mut s = String::from("Fault kinds for --fault KIND[@T] (T: seconds of flight, default 0; persistent faults last to the end):\n");
    for (name, what) in KINDS {
        s.push_str(&format!("  {name:<17} {what}\n"));
    }
    s
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn every_listed_kind_parses_and_bad_specs_are_refused() {
        for (name, _) in KINDS {
            let f = parse(&format!("{name}@1.5")).unwrap();
            assert_eq!(f.at_s, 1.5);
        }
        assert_eq!(parse("stuck-bus").unwrap().at_s, 0.0);
        assert!(parse("magnet@-1").unwrap_err().contains("-1"));
        assert!(parse("magnet@nan").is_err());
        assert!(parse("magnet@").is_err());
        assert!(parse("laser@3")
            .unwrap_err()
            .contains("unknown fault kind `laser`"));
    }
}
