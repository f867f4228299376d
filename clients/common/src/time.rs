//! Flags of seconds and minutes turned into durations. A time flag is
//! checked here once: positive, and no longer than some 31 years, since
//! `Duration::from_secs_f64` panics past what a `Duration` holds, and a
//! time added to a clock overflows long before that.

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
pub const LONGEST_S: f64 = 1.0e9;

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

/// A clap value parser for a flag of seconds checked as [`seconds`]
/// checks it, so that a bad value is refused with the flag's usage before
/// the command runs (`--connect-timeout`, global to every command).
pub fn parse_seconds(text: &str) -> Result<f64, String> {
    let value: f64 =
        (text.trim().parse()).map_err(|_| format!("expected a number of seconds, got '{text}'"))?;
    seconds("it", value).map_err(|e| e.to_string())?;
    Ok(value)
}

#[cfg(test)]
mod tests {
    use super::{minutes, parse_seconds, seconds};
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

    #[test]
    fn a_flag_of_seconds_is_parsed_or_refused_with_the_reason() {
        assert_eq!(parse_seconds("2.5"), Ok(2.5));
        for (bad, why) in [
            ("soon", "expected a number of seconds, got 'soon'"),
            ("0", "it must be a positive number of seconds, got 0"),
            (
                "1e30",
                "it must be at most 1000000000 seconds, got 1000000000000000000000000000000",
            ),
        ] {
            assert_eq!(parse_seconds(bad), Err(why.to_string()));
        }
    }
}
