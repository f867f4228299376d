//! Progress for long commands: an indicatif bar or spinner on a terminal,
//! a plain line now and then otherwise (a log file, CI), on stderr so the
//! results on stdout stay clean.

use std::io::IsTerminal;
use std::time::{Duration, Instant};

/// How often a plain progress line is printed when stderr is no terminal.
const PLAIN_EVERY: Duration = Duration::from_secs(10);

/// One task's progress.
pub struct Progress {
    bar: Option<indicatif::ProgressBar>,
    label: String,
    unit: String,
    total: Option<u64>,
    last_line: Instant,
    pos: u64,
}

impl Progress {
    /// A count with no known end (messages recorded).
    pub fn counter(label: &str, unit: &str) -> Progress {
        Self::new(label, unit, None)
    }

    /// A count up to `total` (messages replayed, runs done).
    pub fn bar(label: &str, unit: &str, total: u64) -> Progress {
        Self::new(label, unit, Some(total))
    }

    fn new(label: &str, unit: &str, total: Option<u64>) -> Progress {
        let bar = std::io::stderr().is_terminal().then(|| {
            let (bar, template) = match total {
                Some(n) => (
                    indicatif::ProgressBar::new(n),
                    "{prefix} [{elapsed_precise}] {wide_bar} {pos}/{len} {msg}",
                ),
                None => (
                    indicatif::ProgressBar::new_spinner(),
                    "{spinner} {prefix} [{elapsed_precise}] {pos} {msg}",
                ),
            };
            if let Ok(style) = indicatif::ProgressStyle::with_template(template) {
                bar.set_style(style);
            }
            bar.set_prefix(label.to_string());
            bar.enable_steady_tick(Duration::from_millis(200));
            bar
        });
        Progress {
            bar,
            label: label.to_string(),
            unit: unit.to_string(),
            total,
            // The first note is printed at once.
            last_line: Instant::now()
                .checked_sub(PLAIN_EVERY)
                .unwrap_or_else(Instant::now),
            pos: 0,
        }
    }

    /// Moves to `pos`, with a short note (`3 channels, 12 kB`); without a
    /// bar, said at most every ten seconds.
    pub fn set(&mut self, pos: u64, note: &str) {
        let due = self.last_line.elapsed() >= PLAIN_EVERY;
        self.show(pos, note, due);
    }

    /// Moves to `pos` as a new step begins (a measurement, a run): said
    /// on a line of its own when there is no bar.
    pub fn step(&mut self, pos: u64, note: &str) {
        self.show(pos, note, true);
    }

    fn show(&mut self, pos: u64, note: &str, plain_line: bool) {
        self.pos = pos;
        match &self.bar {
            Some(bar) => {
                bar.set_position(pos);
                bar.set_message(format!("{} {note}", self.unit));
            }
            None if plain_line => {
                self.last_line = Instant::now();
                eprintln!("{}", self.plain(note));
            }
            None => {}
        }
    }

    /// A line above the bar (or just a line).
    pub fn println(&self, text: &str) {
        match &self.bar {
            Some(bar) => bar.println(text),
            None => eprintln!("{text}"),
        }
    }

    /// Takes the bar off the screen.
    pub fn finish(&mut self) {
        if let Some(bar) = self.bar.take() {
            bar.finish_and_clear();
        }
    }

    fn plain(&self, note: &str) -> String {
        let of = self.total.map(|t| format!("/{t}")).unwrap_or_default();
        format!("{}: {}{of} {} {note}", self.label, self.pos, self.unit)
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.finish();
    }
}

/// A byte count for people: `193 B`, `44.5 kB`, `12.3 MB`.
pub fn size(n: u64) -> String {
    if n < 10_000 {
        format!("{n} B")
    } else if n < 10_000_000 {
        format!("{:.1} kB", n as f64 / 1e3)
    } else {
        format!("{:.1} MB", n as f64 / 1e6)
    }
}
