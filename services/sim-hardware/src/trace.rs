//! The world's ground truth at every instant, as text that keeps every bit:
//! two runs are the same run exactly when their traces are the same bytes.
//!
//! One line a robot an instant, after the instant's step:
//!
//! ```text
//! <time ms> <robot> <x mm> <y mm> <heading °> <travelled mm> <24 sonar ranges, mm>
//! ```
//!
//! Each float is written as Rust's shortest text that reads back to the
//! same `f64` (`{:?}`), so a difference in the last bit shows; the ranges
//! are the proximity subsystem's last complete cycle, which carries the
//! sensor noise drawn from the robot's generator.

use rome_sim::Sim;
use std::io::{self, Write};

/// Writes the lines of the instant `sim` is at.
pub fn write_instant(sim: &Sim, out: &mut impl Write) -> io::Result<()> {
    let t = sim.time_ms();
    for r in sim.robots() {
        write!(
            out,
            "{t} {} {:?} {:?} {:?} {:?}",
            r.name,
            r.pose.at.x,
            r.pose.at.y,
            r.pose.heading.deg(),
            r.travelled_mm
        )?;
        for range in r.scan {
            write!(out, " {range}")?;
        }
        writeln!(out)?;
    }
    Ok(())
}

/// A trace being written: a file, flushed at every instant so that a
/// process killed mid-run leaves every instant it stepped.
pub struct Trace {
    out: Box<dyn Write + Send>,
    /// Set after the first failed write: the run goes on untraced.
    failed: bool,
    line: Vec<u8>,
}

impl Trace {
    /// A trace written to `out`.
    pub fn new(out: impl Write + Send + 'static) -> Trace {
        Trace {
            out: Box::new(out),
            failed: false,
            line: Vec::new(),
        }
    }

    /// Writes the instant `sim` is at. A trace that cannot be written says
    /// so once and stops; the run is not ended for it.
    pub fn instant(&mut self, sim: &Sim) {
        if self.failed {
            return;
        }
        self.line.clear();
        let written = write_instant(sim, &mut self.line)
            .and_then(|()| self.out.write_all(&self.line))
            .and_then(|()| self.out.flush());
        if let Err(e) = written {
            self.failed = true;
            tracing::warn!("the trace cannot be written ({e}): the run goes on without it");
        }
    }
}
