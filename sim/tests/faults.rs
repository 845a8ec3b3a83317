//! `--fault TIME:KIND[:ARG]`, the one syntax of `cargo sim` and `cargo fil`:
//! every kind parses with its ARG and prints back to the same spec, each
//! rig takes exactly its own kinds, and every bad spec is an error that
//! says what is wrong, never a panic.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use proptest::prelude::*;
use sim::faults::{
    help, kinds, parse, ArgKind, BoardAction, FaultAction, FaultSchedule, Rig, KINDS,
};
use sim::{Chip, Fault, SimBus, SimClock, SimConfig};

/// A valid ARG for `arg`.
fn example_arg(arg: ArgKind) -> &'static str {
    match arg {
        ArgKind::None => "",
        ArgKind::Chip => ":baro",
        ArgKind::Count => ":7",
        ArgKind::ChipCount => ":mag:200",
        ArgKind::ChipId => ":mpu:0x70",
        ArgKind::Dipole => ":45:6800",
    }
}

#[test]
fn every_kind_parses_on_its_rigs_and_prints_back() {
    for k in KINDS {
        let spec = format!("1.5:{}{}", k.name, example_arg(k.arg));
        let f = parse(&spec, Rig::Board).unwrap();
        assert_eq!(f.at_s, 1.5);
        assert_eq!(f.kind.name, k.name);
        assert_eq!(parse(&f.to_string(), Rig::Board).unwrap(), f, "{spec}");
        let on_sim = parse(&spec, Rig::Sim);
        assert_eq!(on_sim.is_ok(), !k.board_only, "{spec}: {on_sim:?}");
        if k.board_only {
            assert!(matches!(f.action(), FaultAction::Board(_)), "{spec}");
            assert!(on_sim.unwrap_err().contains("emulated board only"));
        } else {
            assert!(!matches!(f.action(), FaultAction::Board(_)), "{spec}");
        }
    }
}

#[test]
fn each_help_lists_exactly_its_rigs_kinds() {
    for rig in [Rig::Sim, Rig::Board] {
        let text = help(rig);
        assert!(text.contains("TIME:KIND[:ARG]"));
        for k in KINDS {
            let line = format!("  {}{} ", k.name, k.arg.usage());
            assert_eq!(
                text.contains(&line),
                rig == Rig::Board || !k.board_only,
                "{rig:?}: `{line}` in\n{text}"
            );
        }
    }
    assert_eq!(kinds(Rig::Board).count(), KINDS.len());
}

#[test]
fn the_kinds_do_what_their_names_say() {
    let act = |s: &str| parse(s, Rig::Board).unwrap().action();
    assert_eq!(
        act("8:missing:mpu"),
        FaultAction::Inject(Fault::Nack {
            address: 0x68,
            transactions: None
        })
    );
    assert_eq!(
        act("0:nack:baro:200"),
        FaultAction::Inject(Fault::Nack {
            address: 0x77,
            transactions: Some(200)
        })
    );
    assert_eq!(
        act("2:wrong-id:mag:0"),
        FaultAction::Inject(Fault::WrongChipId {
            chip: Chip::Ak8963,
            id: 0
        })
    );
    assert_eq!(
        act("2:wrong-id:mpu:ff"),
        FaultAction::Inject(Fault::WrongChipId {
            chip: Chip::Mpu9250,
            id: 0xff
        })
    );
    assert_eq!(
        act("1:bus-error:2"),
        FaultAction::Inject(Fault::BusErrorMidTransfer { after_bytes: 2 })
    );
    assert_eq!(act("4:clear"), FaultAction::Clear);
    assert_eq!(
        act("4:button-up"),
        FaultAction::Board(BoardAction::Button(false))
    );
    // The magnet peaks 2 s after TIME.
    match act("10:magnet") {
        FaultAction::Inject(Fault::Magnet(m)) => assert_eq!(m.peak_time_s, 12.0),
        other => panic!("{other:?}"),
    }
    // `imu` is accepted for the MPU-9250 and printed as `mpu`.
    assert_eq!(
        parse("3:frozen:imu", Rig::Sim).unwrap().to_string(),
        "3:frozen:mpu"
    );
}

/// `spec` is refused on `rig` with an error containing every `want`.
fn refused(spec: &str, rig: Rig, want: &[&str]) {
    let e = parse(spec, rig).expect_err(spec);
    for w in want {
        assert!(e.contains(w), "{spec}: wanted `{w}` in `{e}`");
    }
    assert!(e.contains(&format!("`{spec}`")), "{spec}: {e}");
}

#[test]
fn a_riding_dipole_adds_its_equatorial_field_fixed_in_the_body() {
    let act = |s: &str| parse(s, Rig::Sim).unwrap().action();
    // A dipole riding in its equatorial plane: 0.1·m/r³ µT against its moment,
    // here a 3 × 1 mm NdFeB disc (6.8·10⁻³ A·m²) 60 mm away: 3.15 µT; body-fixed.
    match act("20:dipole-ride:60:6800") {
        FaultAction::Inject(Fault::Magnet(m)) => {
            let want = 0.1 * 6.8e-3 / (0.06f64 * 0.06 * 0.06);
            let b = m.peak_body_ut;
            let n = (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt();
            assert!(
                (n - want).abs() < 1e-9 && b[1] == 0.0 && b[0] < 0.0,
                "{b:?}"
            );
            assert!((b[0] - b[2]).abs() < 1e-12 && m.stays && m.peak_time_s == 21.0);
        }
        other => panic!("{other:?}"),
    }
    for bad in [
        "1:dipole-ride:4:100",
        "1:dipole-ride:1001:100",
        "1:dipole-ride:60",
    ] {
        assert!(parse(bad, Rig::Sim).is_err(), "{bad}");
    }
}

#[test]
fn bad_specs_say_what_is_wrong() {
    let sim = Rig::Sim;
    refused("magnet@20", sim, &["KIND@T form is gone", "`20:magnet`"]);
    refused("nack-imu@30", sim, &["TIME:KIND[:ARG]", "`30:nack:mpu:50`"]);
    refused(
        "stuck-bus",
        sim,
        &["expected TIME:KIND[:ARG]", "`0:stuck-bus`"],
    );
    refused("reset-imu", sim, &["`0:chip-reset:mpu`"]);
    refused("magnet", sim, &["expected TIME:KIND[:ARG]", "`0:magnet`"]);
    refused("", sim, &["expected TIME:KIND[:ARG]"]);
    refused("x:magnet", sim, &["TIME `x`"]);
    refused("-1:magnet", sim, &["TIME `-1`", ">= 0"]);
    refused("nan:magnet", sim, &["TIME `nan`"]);
    refused("inf:magnet", sim, &["TIME `inf`"]);
    refused(":magnet", sim, &["TIME ``"]);
    refused(
        "3:laser",
        sim,
        &["unknown fault kind `laser`", "magnet", "clear"],
    );
    refused("3:", sim, &["unknown fault kind ``"]);
    refused("3:busy-lockup", sim, &["emulated board only", "cargo fil"]);
    refused("3:nack", sim, &["needs its ARG", "nack:CHIP:N"]);
    refused("3:nack:mpu", sim, &["needs its ARG", "nack:CHIP:N"]);
    refused("3:missing", sim, &["needs its ARG", "missing:CHIP"]);
    refused("3:bus-error", sim, &["needs its ARG", "bus-error:N"]);
    refused(
        "3:wrong-id:mag",
        sim,
        &["needs its ARG", "wrong-id:CHIP:ID"],
    );
    refused("3:stuck-bus:mpu", sim, &["stuck-bus takes no ARG"]);
    refused("3:missing:mpu:5", sim, &["takes missing:CHIP"]);
    refused(
        "3:missing:gps",
        sim,
        &["unknown chip `gps`", "mpu, mag, baro"],
    );
    refused("3:nack:mpu:-1", sim, &["N `-1`"]);
    refused("3:nack:mpu:5000000000", sim, &["N `5000000000`"]);
    refused("3:wrong-id:mag:100", sim, &["ID `100`", "hex byte"]);
    refused("3:wrong-id:mag:0x", sim, &["ID `0x`"]);
    refused("3:wrong-id:mag:+1", sim, &["ID `+1`"]);
}

#[test]
fn a_schedule_gives_the_faults_in_time_order_and_applies_them() {
    let specs: Vec<_> = ["5:clear", "1:stuck-bus", "1:magnet", "3:nack:mpu:1"]
        .iter()
        .map(|s| parse(s, Rig::Sim).unwrap())
        .collect();
    let mut s = FaultSchedule::new(&specs);
    assert_eq!(s.next_at_s(), Some(1.0));
    assert!(s.next_due(0.5).is_none());
    let mut seen = Vec::new();
    let clock = SimClock::new();
    let bus = SimBus::new(&clock, SimConfig::default());
    s.apply_due(3.0, &bus, |f| seen.push(f.to_string()))
        .unwrap();
    assert_eq!(seen, ["1:stuck-bus", "1:magnet", "3:nack:mpu:1"]);
    assert_eq!(s.next_at_s(), Some(5.0));
    // A board fault cannot reach the simulator's bus.
    let board = parse("1:imu-int-stops", Rig::Board).unwrap();
    assert!(board
        .apply_to_bus(&bus)
        .unwrap_err()
        .contains("emulated board only"));
}

fn any_spec() -> impl Strategy<Value = String> {
    let kind = proptest::sample::select(KINDS.iter().map(|k| k.name).collect::<Vec<_>>());
    let word = "[a-z0-9x.+-]{0,6}";
    (
        "-?[0-9]{0,4}(\\.[0-9]{0,3})?(e-?[0-9])?",
        kind,
        proptest::collection::vec(word, 0..3),
    )
        .prop_map(|(t, k, args)| {
            std::iter::once(t)
                .chain(std::iter::once(k.to_string()))
                .chain(args)
                .collect::<Vec<_>>()
                .join(":")
        })
}

proptest! {
    /// Any spec parses or errs (never panics); what parses prints back to
    /// a spec that parses to the same fault, at a finite time >= 0.
    #[test]
    fn parse_round_trips(spec in prop_oneof![any_spec(), "[^\\x00]{0,24}"]) {
        for rig in [Rig::Sim, Rig::Board] {
            if let Ok(f) = parse(&spec, rig) {
                prop_assert!(f.at_s.is_finite() && f.at_s >= 0.0);
                prop_assert_eq!(parse(&f.to_string(), rig), Ok(f));
            }
        }
    }

    /// Every time and count a user can write survives the round trip exactly.
    #[test]
    fn times_and_counts_round_trip(t in 0.0..1e6f64, n: u32, id: u8) {
        for spec in [format!("{t}:nack:baro:{n}"), format!("{t}:wrong-id:mag:{id:x}")] {
            let f = parse(&spec, Rig::Sim).unwrap();
            prop_assert_eq!(f.at_s, t);
            prop_assert_eq!(parse(&f.to_string(), Rig::Sim), Ok(f));
        }
    }
}
