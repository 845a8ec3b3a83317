//! Decodes a raw CRSF byte capture (e.g. from a USB-serial adapter at
//! 420 000 baud on the receiver's TX pin: `stty -F /dev/ttyUSB0 420000 raw;
//! cat /dev/ttyUSB0 > capture.bin`) and prints every frame and the counters.
//!
//! `cargo run -p rc-input --example crsf_dump -- capture.bin` (`-` = stdin).
//! A raw capture carries no byte times: bytes are stamped as if back to back
//! (every frame of at most 64 bytes then lasts less than the frame time; the
//! CRC resynchronises), and the end of the capture counts as a long pause,
//! releasing any frame still held behind a false start. Exit status: 0 done, 1 the input could not be
//! read, 2 bad arguments.

use std::io::{ErrorKind, Read, Write};
use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;
use rc_input::crsf::DEFAULT_MAX_FRAME_TIME_US;
use rc_input::{CrsfParser, Event};

/// One byte time at 420 kbaud 8N1, rounded up, µs.
const BYTE_US: u32 = 24;

/// Command-line options.
#[derive(Parser, Debug)]
#[command(about = "Print the frames and counters of a raw CRSF byte capture")]
struct Cli {
    /// Capture file (`-` = stdin).
    capture: PathBuf,
    /// Print only the counters.
    #[arg(long)]
    summary: bool,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let mut bytes = Vec::new();
    let read = if cli.capture.as_os_str() == "-" {
        std::io::stdin().read_to_end(&mut bytes)
    } else {
        std::fs::File::open(&cli.capture).and_then(|mut f| f.read_to_end(&mut bytes))
    };
    if let Err(e) = read {
        eprintln!("crsf_dump: {}: {e}", cli.capture.display());
        return ExitCode::from(1);
    }
    let mut parser = CrsfParser::new();
    let mut out = std::io::stdout().lock();
    let mut t_us = 0u32;
    for (offset, &b) in bytes.iter().enumerate() {
        t_us = t_us.wrapping_add(BYTE_US);
        if let Some(event) = parser.push(b, t_us) {
            if let Err(code) = print(&mut out, &cli, offset, &event) {
                return code;
            }
        }
    }
    let idle_us = t_us.wrapping_add(2 * DEFAULT_MAX_FRAME_TIME_US);
    while let Some(event) = parser.poll(idle_us) {
        if let Err(code) = print(&mut out, &cli, bytes.len(), &event) {
            return code;
        }
    }
    eprintln!("crsf_dump: {} bytes, {:?}", bytes.len(), parser.stats());
    ExitCode::SUCCESS
}

/// Prints one event (unless `--summary`); `Err` carries the exit code.
fn print(out: &mut impl Write, cli: &Cli, offset: usize, event: &Event) -> Result<(), ExitCode> {
    if cli.summary {
        return Ok(());
    }
    let line = match event {
        Event::Channels(f) => format!("{offset:8} channels_us {:?}", f.channels()),
        Event::LinkStatistics(s) => format!("{offset:8} link {s:?}"),
    };
    match writeln!(out, "{line}") {
        Ok(()) => Ok(()),
        // A closed pipe (e.g. `| head`) ends the listing quietly.
        Err(e) if e.kind() == ErrorKind::BrokenPipe => Err(ExitCode::SUCCESS),
        Err(e) => {
            eprintln!("crsf_dump: stdout: {e}");
            Err(ExitCode::from(1))
        }
    }
}
