//! SIGINT and SIGTERM, handled from the start of the process.
//!
//! [`install`] runs first in `main`, so no signal finds the process without its handler. What a
//! signal does depends on the phase:
//!
//! - while reading, preparing or tracing rays/ST-maps (nothing to keep): the process ends at once
//!   with 128 + the signal (130 for SIGINT, 143 for SIGTERM);
//! - while `obscura render` renders and writes ([`Cancellable`]): the first signal sets
//!   [`job::CANCEL`]; the tiles in flight finish, the rendered part is written (marked partial) and
//!   the process ends with 130 or 143. A signal that arrives once every tile is rendered cuts nothing
//!   short: the outputs are complete and the exit status is 0. A second signal ends the process at once.

use std::sync::atomic::{AtomicBool, AtomicI32, Ordering};

use obscura_render::job;
use signal_hook::consts::{SIGINT, SIGTERM};
use signal_hook::iterator::Signals;

/// The first signal received (0: none).
static RECEIVED: AtomicI32 = AtomicI32::new(0);
/// True while a signal should cancel the render instead of ending the process.
static CANCELLABLE: AtomicBool = AtomicBool::new(false);

/// Starts the thread that receives SIGINT and SIGTERM. Call first thing in `main`.
///
/// If the handler cannot be installed (no threads, a refused registration), the signals keep their
/// default action, which also ends the process with 130 or 143.
pub fn install() {
    let Ok(mut signals) = Signals::new([SIGINT, SIGTERM]) else {
        return;
    };
    let spawned = std::thread::Builder::new().name("signals".into()).spawn(move || {
        for signal in signals.forever() {
            on_signal(signal);
        }
    });
    drop(spawned);
}

/// The exit status of a process ended by `signal`: 128 + its number, as a shell reports it.
#[must_use]
pub fn exit_status(signal: i32) -> u8 {
    u8::try_from(128 + signal).unwrap_or(255)
}

fn name(signal: i32) -> &'static str {
    if signal == SIGTERM { "SIGTERM" } else { "SIGINT" }
}

fn on_signal(signal: i32) {
    let first = RECEIVED
        .compare_exchange(0, signal, Ordering::SeqCst, Ordering::SeqCst)
        .is_ok();
    if !first || !CANCELLABLE.load(Ordering::SeqCst) {
        std::process::exit(i32::from(exit_status(signal)));
    }
    job::CANCEL.store(true, Ordering::SeqCst);
    eprintln!(
        "\ninterrupted ({}): finishing the tiles in flight, then writing what is rendered (again to quit at once)",
        name(signal)
    );
}

/// The first signal received so far, if any.
#[must_use]
pub fn received() -> Option<i32> {
    match RECEIVED.load(Ordering::SeqCst) {
        0 => None,
        s => Some(s),
    }
}

/// While alive, a first signal cancels the render (see the module documentation) instead of ending
/// the process.
pub struct Cancellable(());

impl Cancellable {
    /// Enters the phase where a signal cancels. A signal received before (while loading) has ended
    /// the process already.
    #[must_use]
    pub fn enter() -> Self {
        CANCELLABLE.store(true, Ordering::SeqCst);
        Cancellable(())
    }
}

impl Drop for Cancellable {
    fn drop(&mut self) {
        CANCELLABLE.store(false, Ordering::SeqCst);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exit_statuses_are_the_shells() {
        assert_eq!(exit_status(SIGINT), 130);
        assert_eq!(exit_status(SIGTERM), 143);
        assert_eq!(name(SIGTERM), "SIGTERM");
    }
}
