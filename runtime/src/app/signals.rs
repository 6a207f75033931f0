//! SIGINT and SIGTERM end a run honestly: the program of a compiled scene and `mbdc run
//! --interp` install [`StopSignals`] for the time of a run, and answer the run loop's
//! [`stop_requested`](crate::driver::run_loop::Observer::stop_requested) from it. The run
//! then finishes its current step, writes that state as its last frame, flushes every
//! writer, writes `summary.json` with `"status": "interrupted"`, and the program exits with
//! [`Signal::exit_code`] (130 for SIGINT, 143 for SIGTERM).
//!
//! The handlers only store into process-wide atomics (through `signal-hook`, no hand-written
//! `unsafe`); the run loop loads one of them per step. The library's run loop installs
//! nothing: a program that embeds the runtime keeps the signal handling it has, and can
//! stop a run from anything through its observer.
//!
//! While a [`StopSignals`] is alive:
//! - the first SIGINT or SIGTERM is a stop request ([`StopSignals::received`]);
//! - a second SIGINT ends the process at once, as without handlers (for a user who presses
//!   Ctrl-C again because the last step or the flush takes too long): the frames written
//!   are whole, `summary.json` stays the one written at the start (`"status": "started"`);
//! - a second SIGTERM is the same request again, so that a SIGTERM sent both to the process
//!   group (a job scheduler) and forwarded by `mbdc run` stops the run once, honestly.
//!
//! When it is dropped, SIGINT and SIGTERM end the process at once again (their default).
//! Only Unix has these signals; elsewhere [`StopSignals::install`] installs nothing and
//! Ctrl-C ends the process as the operating system does.

#[cfg(unix)]
use std::sync::atomic::AtomicUsize;
use std::sync::atomic::{AtomicBool, Ordering};

/// A signal that stops a run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Signal {
    /// SIGINT (2): Ctrl-C on a terminal.
    Interrupt,
    /// SIGTERM (15): `kill`, a job scheduler, a service manager.
    Terminate,
}

impl Signal {
    /// Its name, `SIGINT` or `SIGTERM`: what `summary.json` says stopped the run.
    pub fn name(self) -> &'static str {
        match self {
            Signal::Interrupt => "SIGINT",
            Signal::Terminate => "SIGTERM",
        }
    }

    /// The signal of a name given by [`Signal::name`].
    pub fn from_name(name: &str) -> Option<Signal> {
        match name {
            "SIGINT" => Some(Signal::Interrupt),
            "SIGTERM" => Some(Signal::Terminate),
            _ => None,
        }
    }

    /// Its number (POSIX): 2 or 15.
    pub fn number(self) -> i32 {
        match self {
            Signal::Interrupt => 2,
            Signal::Terminate => 15,
        }
    }

    /// The exit code of a program it stopped, as shells report a process the signal ended:
    /// 128 + its number, 130 or 143.
    pub fn exit_code(self) -> u8 {
        128 + self.number() as u8
    }
}

/// The signal received, by number (0: none).
#[cfg(unix)]
static RECEIVED: AtomicUsize = AtomicUsize::new(0);
/// A SIGINT now ends the process at once: one was received already, or no run is going.
#[cfg(unix)]
static AGAIN: AtomicBool = AtomicBool::new(false);
/// A SIGTERM now ends the process at once: no run is going.
#[cfg(unix)]
static DONE: AtomicBool = AtomicBool::new(false);
/// Whether a [`StopSignals`] is alive.
static ACTIVE: AtomicBool = AtomicBool::new(false);

/// Register the process's handlers, once: they consult the flags above, so that installing
/// and dropping [`StopSignals`] only sets flags.
#[cfg(unix)]
fn register() -> std::io::Result<()> {
    use signal_hook::consts::{SIGINT, SIGTERM};
    use signal_hook::flag;
    static REGISTERED: std::sync::Mutex<bool> = std::sync::Mutex::new(false);
    let mut done = REGISTERED.lock().unwrap_or_else(|p| p.into_inner());
    if *done {
        return Ok(());
    }
    // The order matters: the default action is checked before the flag that arms it is set.
    flag::register_conditional_default(SIGINT, &AGAIN)?;
    flag::register(SIGINT, &AGAIN)?;
    flag::register_usize(SIGINT, &RECEIVED, SIGINT as usize)?;
    flag::register_conditional_default(SIGTERM, &DONE)?;
    flag::register_usize(SIGTERM, &RECEIVED, SIGTERM as usize)?;
    *done = true;
    Ok(())
}

/// SIGINT and SIGTERM as stop requests for the time of a run (see the module doc). One at
/// a time per process; dropping it restores the signals' default action.
#[derive(Debug)]
pub struct StopSignals {
    _private: (),
}

impl StopSignals {
    /// Make SIGINT and SIGTERM stop requests until the returned value is dropped.
    ///
    /// # Errors
    /// Another [`StopSignals`] is alive ([`std::io::ErrorKind::AlreadyExists`]), or the
    /// handlers cannot be installed.
    pub fn install() -> std::io::Result<StopSignals> {
        if ACTIVE.swap(true, Ordering::SeqCst) {
            return Err(std::io::Error::new(
                std::io::ErrorKind::AlreadyExists,
                "the stop signals are installed already",
            ));
        }
        #[cfg(unix)]
        {
            if let Err(e) = register() {
                ACTIVE.store(false, Ordering::SeqCst);
                return Err(e);
            }
            RECEIVED.store(0, Ordering::SeqCst);
            DONE.store(false, Ordering::SeqCst);
            AGAIN.store(false, Ordering::SeqCst);
        }
        Ok(StopSignals { _private: () })
    }

    /// The signal received since [`StopSignals::install`], if any (the last one when both
    /// arrived). One atomic load, no allocation: cheap enough to ask after every step.
    pub fn received(&self) -> Option<Signal> {
        received()
    }

    /// The process-wide hook: what [`StopSignals::received`] says while a [`StopSignals`]
    /// is installed in this process, by whoever installed it; `None` when none is. For
    /// library code that runs inside such a program without a handle to it: the accuracy
    /// study stops between its runs, and its interpreter runs within a step
    /// ([`crate::study`]). Two atomic loads, no allocation.
    pub fn pending() -> Option<Signal> {
        if ACTIVE.load(Ordering::Relaxed) {
            received()
        } else {
            None
        }
    }
}

/// The signal the handlers stored, if any.
fn received() -> Option<Signal> {
    #[cfg(unix)]
    {
        match RECEIVED.load(Ordering::Relaxed) {
            0 => None,
            n if n == signal_hook::consts::SIGINT as usize => Some(Signal::Interrupt),
            _ => Some(Signal::Terminate),
        }
    }
    #[cfg(not(unix))]
    {
        None
    }
}

impl Drop for StopSignals {
    /// SIGINT and SIGTERM end the process at once again.
    fn drop(&mut self) {
        #[cfg(unix)]
        {
            AGAIN.store(true, Ordering::SeqCst);
            DONE.store(true, Ordering::SeqCst);
        }
        ACTIVE.store(false, Ordering::SeqCst);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_numbers_and_exit_codes() {
        for s in [Signal::Interrupt, Signal::Terminate] {
            assert_eq!(Signal::from_name(s.name()), Some(s));
        }
        assert_eq!(Signal::from_name("a cancel button"), None);
        assert_eq!(Signal::Interrupt.exit_code(), 130);
        assert_eq!(Signal::Terminate.exit_code(), 143);
    }
}
