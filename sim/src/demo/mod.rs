//! The no-board demo: the whole sensor stack on the simulated bus.
//!
//! * [`stack`] runs the ground calibrations through the drivers and
//!   `calibration`, then the firmware's own per-sample path (`flight`'s
//!   sensors, start-up gyro bias, scheduler and pipeline).
//! * [`run`] drives the simulation (clock, INT line), compares with the truth
//!   and collects the records.
//! * [`output`] streams the CSV; [`plot`] keeps a bounded copy of the run
//!   and draws it (PNG or SVG).
//! * [`closed_loop`] flies the quadcopter model in a closed loop: its
//!   motion drives the chips, the same per-sample path estimates it, a
//!   [`closed_loop::FlightControl`] ([`flight_fc`]: the firmware's flight
//!   controller) flies it through the
//!   scripted pilot of a [`closed_loop::Scenario`]; [`figures`] scores it,
//!   [`timeline`] lists its events, [`plot_closed`] draws it,
//!   [`scenario_csv`] logs it sample by sample.
//! * [`spectrum`] draws the simulated gyro's spectrum at hover and full
//!   throttle (`--spectrum`).
//! * [`tuning`] applies `sim::rate_loop` (frequency response and
//!   margins, step response by deconvolution) to the rate loop of a
//!   flight or a log and draws it.
//!
//! Printing that survives a closed pipe is `host_console`, shared with `replay`.

pub mod analyse;
pub mod closed_loop;
pub mod figures;
pub mod flight_fc;
pub mod mag;
pub mod output;
pub mod plot;
pub mod plot_closed;
pub mod radio;
pub mod run;
pub mod scenario_csv;
pub mod settings_file;
pub mod spectrum;
pub mod stack;
pub mod sweep;
pub mod timeline;
pub mod tuning;
pub mod tuning_cli;

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]
mod tests {
    use super::output::CsvWriter;
    use super::plot::PlotSeries;
    use super::run::{run, RecordSink, RunOptions};
    use sim::Trajectory;

    fn short(trajectory: Trajectory, sinks: &mut [&mut dyn RecordSink]) -> super::run::RunResult {
        let opts = RunOptions {
            trajectory,
            seed: 1,
            board_seed: 1,
            duration_s: 15.0,
            print_every_s: 0.0,
            mag_dance_s: 30.0,
            faults: Vec::new(),
            progress: false,
            gyro_scale: None,
        };
        run(&opts, sinks).unwrap()
    }

    #[test]
    fn whole_stack_tracks_the_truth_and_writes_outputs() {
        let r = short(Trajectory::Hover, &mut []);
        let s = r.summary;
        assert!(s.samples > 13_000, "{s:?}");
        // All calibrations ran: the start-up gyro bias within a few counts.
        let g = r.gyro_bias.unwrap();
        for i in 0..3 {
            assert!(
                (f64::from(g.measured_rps[i]) - g.truth_rps[i]).abs() < 2e-3,
                "{g:?}"
            );
        }
        // The six-position calibration removed the ±60 mg offsets (which
        // alone tilt by up to 3.4°): what is left is cross-axis coupling
        // (±1 %, ≈0.6°) and the filter's own error.
        assert!(s.inclination_rms_deg < 2.0, "{s:?}");
        assert!(s.attitude_rms_deg < 4.0, "{s:?}");
        assert!(s.height_rms_m < 0.5, "{s:?}");
        assert!(s.vspeed_rms_mps < 0.5, "{s:?}");

        let dir = std::env::temp_dir();
        let csv_path = dir.join(format!("sim-demo-test-{}.csv", std::process::id()));
        let file = std::fs::File::create(&csv_path).unwrap();
        let mut csv = CsvWriter::new(Box::new(file), "test.csv").unwrap();
        let mut series = PlotSeries::default();
        let r = short(Trajectory::SlowRotations, &mut [&mut csv, &mut series]);
        csv.finish().unwrap();
        let text = std::fs::read_to_string(&csv_path).unwrap();
        let mut lines = text.lines();
        assert!(lines.next().unwrap().starts_with("t_s,gyr_x_rad_s"));
        assert_eq!(lines.next().unwrap().split(',').count(), 15);
        // One row per MPU sample (1 kHz) once the magnetometer has given one.
        let rows = text.lines().count() - 1;
        assert!((14_500..=15_001).contains(&rows), "{rows}");
        for ext in ["png", "svg"] {
            let path = dir.join(format!("sim-demo-test-{}.{ext}", std::process::id()));
            super::plot::write_plot(&path, "test", &series, &r.mag_cal).unwrap();
            assert!(std::fs::metadata(&path).unwrap().len() > 10_000);
            let _ = std::fs::remove_file(path);
        }
        let _ = std::fs::remove_file(csv_path);
    }
}
