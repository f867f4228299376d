//! The `rome` program: parses flags and hands over to [`rome_cli::run`].

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    rome_cli::main(rome_cli::Cli::parse())
}
