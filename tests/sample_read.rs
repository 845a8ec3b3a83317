//! The sample read split for an interrupt-driven bus (`Sensors::plan_sample`,
//! the blocks read by a transfer engine, `Sensors::finish_sample`) against
//! the blocking `Sensors::read_sample` on two identical simulated boards:
//! the same bus transactions, the same samples, the same health books,
//! with and without faults.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use e2e::Rig;
use embedded_hal::i2c::I2c;
use sensor_stack::health::HealthCounters;
use sensor_stack::schedule::{SampleScheduler, MAG_DIVIDER};
use sensor_stack::sensors::{
    BlockResults, MagRead, SampleBytes, SamplePlan, Sensors, SAMPLE_BYTES,
};
use sim::{Fault, SimBus, SimBusError, SimConfig};

const MPU: u8 = 0x68;
const AK: u8 = 0x0C;

/// What the firmware's interrupt-driven engine does with a plan, written
/// with blocking transfers: each block once, in order, a block with a
/// condition only when the block it names completed and the byte matches.
/// `before` runs ahead of each block that is read (fault injection).
fn run_plan(
    bus: &mut SimBus,
    plan: &SamplePlan,
    bytes: &mut SampleBytes,
    mut before: impl FnMut(usize),
) -> BlockResults<SimBusError> {
    let mut results: BlockResults<SimBusError> = [None, None, None];
    for (i, block) in plan.blocks.iter().enumerate() {
        let Some(b) = block else { continue };
        if let Some(c) = b.only_if {
            let done = matches!(results[usize::from(c.block)], Some(Ok(())));
            if !done || bytes[usize::from(c.byte)] & c.mask == 0 {
                continue;
            }
        }
        before(i);
        let at = usize::from(b.offset);
        let buf = &mut bytes[at..at + usize::from(b.len)];
        results[i] = Some(bus.write_read(b.address, &[b.register], buf));
    }
    results
}

/// Two boards from the same seed, booted alike.
fn twin_boards() -> ((Rig, Sensors<SimBus>), (Rig, Sensors<SimBus>)) {
    let mut a = Rig::new(SimConfig::default());
    let mut b = Rig::new(SimConfig::default());
    let (sa, _) = e2e::boot_sensors(&mut a);
    let (sb, _) = e2e::boot_sensors(&mut b);
    ((a, sa), (b, sb))
}

fn books(s: &Sensors<SimBus>) -> [HealthCounters; 2] {
    [*s.mpu_health.counters(), *s.mag_health.counters()]
}

/// Runs `n` samples on both boards, the blocking read on `a`, the split
/// read on `b`, with `fault(k)` injected on both before sample `k`;
/// asserts equal results and books after every sample. Returns the
/// magnetometer samples seen.
fn compare(n: u32, fault: impl Fn(u32) -> Option<Fault>) -> u32 {
    let ((ra, mut sa), (mut rb, mut sb)) = twin_boards();
    let mut sched = SampleScheduler::new(MAG_DIVIDER);
    let mut mags = 0;
    for k in 0..n {
        if let Some(f) = fault(k) {
            ra.bus.inject(f);
            rb.bus.inject(f);
        }
        ra.bus.advance_to_next_mpu_sample();
        rb.bus.advance_to_next_mpu_sample();
        let tick = sched.on_imu_sample();
        let expected = sa.read_sample(tick.read_mag);
        let plan = sb.plan_sample(tick.read_mag);
        let mut bytes = [0u8; SAMPLE_BYTES];
        let results = run_plan(&mut rb.bus, &plan, &mut bytes, |_| {});
        let got = sb.finish_sample(tick.read_mag, &bytes, results);
        assert_eq!(got, expected, "sample {k}");
        assert_eq!(books(&sb), books(&sa), "health books after sample {k}");
        assert_eq!(
            rb.bus.transaction_counts(),
            ra.bus.transaction_counts(),
            "bus transactions after sample {k}"
        );
        if matches!(got.1, MagRead::Sample(_)) {
            mags += 1;
        }
        // The maintenance the service task would run, on both alike.
        if sa.service_due() {
            sa.service(&mut { ra.delay.clone() });
            sb.service(&mut { rb.delay.clone() });
        }
    }
    mags
}

#[test]
fn split_read_matches_the_blocking_read_at_rest() {
    let mags = compare(2_000, |_| None);
    // 100 Hz measurements read every 10th sample over 2 s.
    assert!(mags >= 150, "{mags} magnetometer samples");
}

#[test]
fn split_read_keeps_the_same_books_under_faults() {
    let mags = compare(3_000, |k| match k {
        100 => Some(Fault::BusErrorMidTransfer { after_bytes: 3 }),
        400 => Some(Fault::Nack {
            address: MPU,
            transactions: Some(7),
        }),
        800 => Some(Fault::Nack {
            address: AK,
            transactions: Some(4),
        }),
        // Stays on: every later measurement overflows.
        1_200 => Some(Fault::MagOverflow),
        _ => None,
    });
    assert!((100..=125).contains(&mags), "{mags} magnetometer samples");
}

/// A data block that dies after its first bytes leaves the AK8963's data
/// protection on (DRDY never rises again) unless ST2 is read: the finish
/// step reads it, and the next measurements arrive.
#[test]
fn failed_mag_data_block_releases_the_data_protection() {
    let mut rig = Rig::new(SimConfig::default());
    let (mut s, _) = e2e::boot_sensors(&mut rig);
    let mut sched = SampleScheduler::new(MAG_DIVIDER);
    let mut failed_at = None;
    let mut after = Vec::new();
    for k in 0..400u32 {
        rig.bus.advance_to_next_mpu_sample();
        let tick = sched.on_imu_sample();
        let plan = s.plan_sample(tick.read_mag);
        let mut bytes = [0u8; SAMPLE_BYTES];
        let bus = rig.bus.clone();
        let inject = failed_at.is_none() && k > 50;
        let results = run_plan(&mut rig.bus, &plan, &mut bytes, |i| {
            if inject && i == 2 {
                bus.inject(Fault::BusErrorMidTransfer { after_bytes: 4 });
            }
        });
        let hit = matches!(results[2], Some(Err(_)));
        let (_, mag) = s.finish_sample(tick.read_mag, &bytes, results);
        if hit {
            assert_eq!(mag, MagRead::Unavailable);
            failed_at = Some(k);
        } else if failed_at.is_some() && tick.read_mag {
            after.push(mag);
        }
    }
    assert!(failed_at.is_some(), "the data block was never hit");
    assert_eq!(s.mag_health.counters().errors, 1);
    let samples = after
        .iter()
        .filter(|m| matches!(m, MagRead::Sample(_)))
        .count();
    assert!(
        samples + 2 >= after.len() && samples > 20,
        "{samples} measurements in {} reads after the failure: {after:?}",
        after.len()
    );
}

/// The plan names the drivers' registers and nothing for a chip that is
/// not usable.
#[test]
fn plan_follows_the_tick_and_the_chips_in_use() {
    let mut rig = Rig::new(SimConfig::default());
    let (s, _) = e2e::boot_sensors(&mut rig);
    let p = s.plan_sample(false);
    let mpu = p.blocks[0].expect("MPU block");
    assert_eq!((mpu.address, mpu.register, mpu.len), (MPU, 0x3B, 14));
    assert_eq!(p.blocks[1], None);
    let p = s.plan_sample(true);
    let st1 = p.blocks[1].expect("ST1 block");
    let data = p.blocks[2].expect("data block");
    assert_eq!((st1.address, st1.register, st1.len), (AK, 0x02, 1));
    assert_eq!((data.register, data.len), (0x03, 7));
    assert_eq!(usize::from(data.offset), usize::from(st1.offset) + 1);
    assert_eq!(usize::from(data.offset + data.len), SAMPLE_BYTES);
    let c = data.only_if.expect("conditional on DRDY");
    assert_eq!((c.block, c.byte, c.mask), (1, st1.offset, 0x01));

    let mut rig = Rig::new(SimConfig::default());
    rig.bus.inject(Fault::Nack {
        address: AK,
        transactions: None,
    });
    let (s, _) = e2e::boot_sensors(&mut rig);
    let p = s.plan_sample(true);
    assert!(p.blocks[0].is_some());
    assert_eq!((p.blocks[1], p.blocks[2]), (None, None));
}
