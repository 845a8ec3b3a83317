//! The no-board demo: the whole sensor stack on the simulated bus.
//!
//! * [`stack`] wires drivers → calibration → AHRS → altitude. It is the one
//!   place to switch to the `flight` crate's pipeline later.
//! * [`run`] drives the simulation (clock, INT line), compares with the truth
//!   and collects the records.
//! * [`output`] writes the CSV; [`plot`] draws the PNG.

pub mod mag;
pub mod output;
pub mod plot;
pub mod run;
pub mod stack;

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]
mod tests {
    use super::run::{run, RunOptions};
    use super::stack::Filter;
    use sim::Trajectory;

    fn short(trajectory: Trajectory, filter: Filter) -> super::run::RunResult {
        run(&RunOptions {
            trajectory,
            seed: 1,
            duration_s: 15.0,
            filter,
            print_every_s: 0.0,
            mag_dance_s: 30.0,
        })
        .unwrap()
    }

    #[test]
    fn whole_stack_tracks_the_truth_and_writes_outputs() {
        for filter in [Filter::F32, Filter::Fixed] {
            let r = short(Trajectory::Hover, filter);
            let s = r.summary;
            assert!(s.samples > 13_000, "{s:?}");
            // Datasheet-size accelerometer bias (±60 mg, not calibrated here) alone tilts by up to 3.4°.
            assert!(s.attitude_rms_deg < 8.0, "{filter:?}: {s:?}");
            assert!(s.height_rms_m < 0.5, "{filter:?}: {s:?}");
        }
        let r = short(Trajectory::SlowRotations, Filter::F32);
        let dir = std::env::temp_dir();
        let csv = dir.join(format!("sim-demo-test-{}.csv", std::process::id()));
        super::output::write_csv(csv.to_str().unwrap(), &r.records).unwrap();
        let text = std::fs::read_to_string(&csv).unwrap();
        let mut lines = text.lines();
        assert!(lines.next().unwrap().starts_with("t_s,gyr_x_rad_s"));
        assert_eq!(lines.next().unwrap().split(',').count(), 15);
        let png = dir.join(format!("sim-demo-test-{}.png", std::process::id()));
        super::plot::write_plot(png.to_str().unwrap(), "test", &r.records, &r.mag_cal).unwrap();
        assert!(std::fs::metadata(&png).unwrap().len() > 10_000);
        let _ = std::fs::remove_file(csv);
        let _ = std::fs::remove_file(png);
    }
}
