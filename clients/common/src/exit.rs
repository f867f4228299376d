//! Exit codes and the interrupt signal.

/// Success.
pub const OK: u8 = 0;
/// Any error: the message on stderr says what.
pub const ERROR: u8 = 1;
/// The command line or the environment cannot be used (as for clap's
/// usage errors): the message on stderr says what.
pub const USAGE: u8 = 2;
/// A semaphore unit was not taken (try-wait, or wait with --timeout).
pub const NOT_ACQUIRED: u8 = 3;
/// Stopped by Ctrl-C or SIGTERM.
pub const INTERRUPTED: u8 = 130;

/// Resolves on Ctrl-C (SIGINT) or SIGTERM.
pub async fn interrupted() {
    #[cfg(unix)]
    {
        use tokio::signal::unix::{signal, SignalKind};
        match signal(SignalKind::terminate()) {
            Ok(mut term) => {
                tokio::select! {
                    _ = tokio::signal::ctrl_c() => {}
                    _ = term.recv() => {}
                }
            }
            Err(_) => {
                let _ = tokio::signal::ctrl_c().await;
            }
        }
    }
    #[cfg(not(unix))]
    {
        let _ = tokio::signal::ctrl_c().await;
    }
}

/// Writes one line to standard output; when whoever reads it is gone (`|
/// head`), the program ends quietly with [`OK`], as Unix tools do, instead
/// of panicking in `println!`.
pub fn line(text: std::fmt::Arguments<'_>) {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    if let Err(e) = out.write_fmt(text).and_then(|()| out.write_all(b"\n")) {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            std::process::exit(i32::from(OK));
        }
    }
}

/// `println!` for output that may go to a pipe closed early: see [`line()`](crate::exit::line).
#[macro_export]
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::exit::line(format_args!($($arg)*))
    };
}
