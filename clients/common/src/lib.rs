//! What every `rome` command shares, whichever crate holds it.
//!
//! How this crate is laid out:
//! - [`args`]: [`CommonArgs`], the Zenoh and deployment
//!   flags of every command (`--connect`, `--listen`, `--mode`, `--config`,
//!   `--no-multicast`, `--root`, `--identity` …), turned into network
//!   options in one place.
//! - [`exit`]: the exit codes, documented in `rome --help`, the interrupt
//!   signal, and [`out!`] for output that may go to a closed pipe.
//! - [`progress`]: progress bars on a terminal, plain lines elsewhere.
//! - [`supervise`]: keeps a set of `rome` processes running, restarting
//!   each that ends with a back-off (`rome crew`).
//! - Here: reaching the data server from the flags, and the checks of
//!   flags several commands take.

pub mod args;
pub mod exit;
pub mod progress;
pub mod supervise;

use anyhow::Context;
use args::{CommonArgs, Side};
use rome_client::{DataClient, DataOptions};

/// Checks a `--cruise` speed: mm/s, above 0 and at most 1000.
pub fn check_cruise(mm_s: f64) -> anyhow::Result<()> {
    anyhow::ensure!(
        mm_s.is_finite() && mm_s > 0.0 && mm_s <= 1_000.0,
        "--cruise must be a speed in mm/s in 0..=1000, got {mm_s}"
    );
    Ok(())
}

/// Checks a flag that must be a positive number of `unit` (`--limit-min
/// must be a positive number of minutes, got -3`).
pub fn check_positive(flag: &str, value: f64, unit: &str) -> anyhow::Result<()> {
    anyhow::ensure!(
        value.is_finite() && value > 0.0,
        "{flag} must be a positive number of {unit}, got {value}"
    );
    Ok(())
}

/// The longest time a flag may give, s (some 31 years): a time added to
/// a clock or multiplied past this overflows a `Duration`, which panics.
const LONGEST_S: f64 = 1.0e9;

/// A flag's positive number of seconds as a `Duration`, with a clear error
/// for what is not one or is longer than some 31 years.
pub fn seconds(flag: &str, value: f64) -> anyhow::Result<std::time::Duration> {
    check_positive(flag, value, "seconds")?;
    anyhow::ensure!(
        value <= LONGEST_S,
        "{flag} must be at most {LONGEST_S} seconds, got {value}"
    );
    Ok(std::time::Duration::from_secs_f64(value))
}

/// A flag's positive number of minutes as a `Duration`, as [`seconds`].
pub fn minutes(flag: &str, value: f64) -> anyhow::Result<std::time::Duration> {
    check_positive(flag, value, "minutes")?;
    anyhow::ensure!(
        value * 60.0 <= LONGEST_S,
        "{flag} must be at most {} minutes, got {value}",
        LONGEST_S / 60.0
    );
    Ok(std::time::Duration::from_secs_f64(value * 60.0))
}

/// Opens a client session and connects to the data server.
pub async fn connect_data(common: &CommonArgs, role: &str) -> anyhow::Result<DataClient> {
    let session = common.open(Side::Client).await?;
    anyhow::ensure!(
        common.connect_timeout.is_finite() && common.connect_timeout > 0.0,
        "--connect-timeout must be a positive number of seconds, got {}",
        common.connect_timeout
    );
    let mut options = DataOptions::new(role);
    options.root = common.root()?;
    options.connect_timeout = std::time::Duration::from_secs_f64(common.connect_timeout);
    DataClient::connect(&session, options).await.context(
        "cannot reach the data server (start one with `rome data-server`, or pass --connect)",
    )
}

/// A Zenoh session that talks to nobody (no listening, no scouting), for
/// a command's tests in this process.
///
/// # Panics
///
/// When Zenoh cannot open a session at all: a test cannot go on then.
pub async fn isolated_session() -> zenoh::Session {
    let config = rome_client::net::NetOptions::isolated()
        .to_config()
        .expect("an isolated session's configuration");
    zenoh::open(config).await.expect("an isolated session")
}

#[cfg(test)]
mod tests {
    use super::{minutes, seconds};
    use std::time::Duration;

    #[test]
    fn a_time_flag_is_a_duration_or_an_error_naming_the_flag() {
        assert_eq!(seconds("--every", 15.0).unwrap(), Duration::from_secs(15));
        assert_eq!(
            minutes("--limit-min", 2.0).unwrap(),
            Duration::from_secs(120)
        );
        for bad in [0.0, -3.0, f64::NAN, f64::INFINITY] {
            let e = seconds("--every", bad).unwrap_err().to_string();
            assert!(
                e.starts_with("--every must be a positive number of seconds"),
                "{e}"
            );
        }
        // Converting these panicked before: more time than a Duration holds.
        let e = seconds("--every", 1e30).unwrap_err().to_string();
        assert_eq!(
            e,
            "--every must be at most 1000000000 seconds, got 1000000000000000000000000000000"
        );
        let e = minutes("--limit-min", 1e30).unwrap_err().to_string();
        assert!(e.starts_with("--limit-min must be at most"), "{e}");
    }
}
