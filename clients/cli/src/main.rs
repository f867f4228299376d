//! The `rome` program: parses flags and hands over to [`rome_cli::run`].

use std::process::ExitCode;

fn main() -> ExitCode {
    // Set before any thread starts (Zenoh reads it when it first starts a
    // runtime); a `ZENOH_RUNTIME` of the user's own is left alone, once
    // Zenoh is known to be able to read it.
    if std::env::var_os(rome_cli::ZENOH_RUNTIME_ENV).is_none() {
        std::env::set_var(rome_cli::ZENOH_RUNTIME_ENV, rome_cli::ZENOH_RUNTIME);
    } else if let Err(e) = rome_cli::check_zenoh_runtime() {
        eprintln!("error: {e}");
        return ExitCode::from(rome_cli::exit::USAGE);
    }
    rome_cli::main(rome_cli::parse())
}
