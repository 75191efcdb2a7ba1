//! Ctrl-C as a request to stop: the first one sets a flag that long loops look at between
//! steps ([`check`]), so that a command ends cleanly, keeping what it finished (a partial run's
//! trajectory) and leaving earlier outputs as they were; a second one ends the process at once.
//! A file-size limit is likewise turned into an error the command can clean up after; a closed
//! pipe on the output ends the process quietly.

use std::sync::atomic::{AtomicBool, Ordering};

static REQUESTED: AtomicBool = AtomicBool::new(false);

/// Takes Ctrl-C (and SIGTERM) from here on. Once per process; later calls do nothing.
pub fn install() {
    let _ = ctrlc::set_handler(|| {
        if REQUESTED.swap(true, Ordering::SeqCst) {
            eprintln!("\ninterrupted again: quitting now");
            std::process::exit(130);
        }
        eprintln!("\ninterrupted: stopping after this step (Ctrl-C again to quit at once)");
    });
}

/// An error if a stop was requested.
pub fn check() -> anyhow::Result<()> {
    if REQUESTED.load(Ordering::SeqCst) {
        anyhow::bail!("interrupted (Ctrl-C)");
    }
    Ok(())
}

/// A file-size limit (`ulimit -f`) reached as a write error rather than the end of the process
/// (SIGXFSZ's default), so that the command reports it and removes its temporary files. Call
/// once at start-up.
pub fn file_size_limit_as_error() {
    let ignored = std::sync::Arc::new(AtomicBool::new(false));
    let _ = signal_hook::flag::register(signal_hook::consts::SIGXFSZ, ignored);
}

/// A reader that stops early (`roadvo eval ... | head`) ends the process quietly, as it does
/// `cat` (SIGPIPE's default action), rather than in a panic of a print to the closed pipe. Call
/// once at start-up.
pub fn broken_pipe_ends_quietly() {
    let always = std::sync::Arc::new(AtomicBool::new(true));
    let _ = signal_hook::flag::register_conditional_default(signal_hook::consts::SIGPIPE, always);
}
