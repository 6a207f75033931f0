//! `mbdc run`'s signals while the scene's compiled program runs as its child.
//!
//! The child handles SIGINT and SIGTERM itself ([`mbdc_runtime::app::StopSignals`]): it
//! finishes its step, flushes, writes `summary.json` and exits with 130 or 143. This process
//! must then not die first — it reports the child's summary and exits with the child's code:
//! - SIGINT: a terminal's Ctrl-C reaches the whole foreground process group, the child too,
//!   so it is only noted here (forwarding it would make it the child's second SIGINT, which
//!   ends the child at once);
//! - SIGTERM: a job scheduler may send it to this process only; it is forwarded to the
//!   child (a second SIGTERM, when the child had it from the process group too, is the same
//!   request for the child).
//!
//! While cargo builds the program, nothing is installed: a signal ends the build and this
//! process at once.

/// Forwards SIGTERM to a child and keeps SIGINT from ending this process, until
/// [`Forward::stop`].
pub struct Forward {
    #[cfg(unix)]
    handle: signal_hook::iterator::Handle,
    #[cfg(unix)]
    thread: std::thread::JoinHandle<()>,
}

/// After [`Forward::stop`], SIGINT and SIGTERM end this process at once again.
#[cfg(unix)]
static DEFAULT_AGAIN: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

impl Forward {
    /// Start for the child with process id `pid`.
    ///
    /// # Errors
    /// If the handlers cannot be installed (then the signals keep their default action).
    pub fn start(pid: u32) -> std::io::Result<Forward> {
        #[cfg(unix)]
        {
            use signal_hook::consts::{SIGINT, SIGTERM};
            use std::sync::atomic::Ordering;
            // Registered before the iterator's handlers, so that once they are gone (the
            // iterator dropped, which leaves a signal ignored) the default action is back.
            static REGISTERED: std::sync::Once = std::sync::Once::new();
            let mut registered: std::io::Result<()> = Ok(());
            REGISTERED.call_once(|| {
                registered = signal_hook::flag::register_conditional_default(SIGINT, &DEFAULT_AGAIN)
                    .and_then(|_| {
                        signal_hook::flag::register_conditional_default(SIGTERM, &DEFAULT_AGAIN)
                    })
                    .map(|_| ());
            });
            registered?;
            DEFAULT_AGAIN.store(false, Ordering::SeqCst);
            let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM])?;
            let handle = signals.handle();
            let pid = libc::pid_t::try_from(pid).map_err(std::io::Error::other)?;
            let thread = std::thread::spawn(move || {
                for s in signals.forever() {
                    if s == SIGTERM {
                        // SAFETY: `kill` has no memory-safety preconditions. The child is not
                        // reaped before `Forward::stop` has joined this thread, so `pid` is
                        // still the child's (running or a zombie), never another process.
                        unsafe {
                            libc::kill(pid, SIGTERM);
                        }
                    }
                }
            });
            Ok(Forward { handle, thread })
        }
        #[cfg(not(unix))]
        {
            let _ = pid;
            Ok(Forward {})
        }
    }

    /// Stop forwarding (call it before the child is reaped: after its output ended, before
    /// `wait`); SIGINT and SIGTERM end this process at once again.
    pub fn stop(self) {
        #[cfg(unix)]
        {
            self.handle.close();
            let _ = self.thread.join();
            DEFAULT_AGAIN.store(true, std::sync::atomic::Ordering::SeqCst);
        }
    }
}
