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

/// Keeps SIGINT from ending this process and forwards SIGTERM to the child, from
/// [`Forward::start`] (before the child is spawned, so that no signal finds this process
/// unprepared) to [`Forward::stop`].
pub struct Forward {
    #[cfg(unix)]
    handle: signal_hook::iterator::Handle,
    #[cfg(unix)]
    thread: std::thread::JoinHandle<()>,
    /// The child, once spawned, and whether a SIGTERM came before it was.
    #[cfg(unix)]
    child: std::sync::Arc<std::sync::Mutex<(Option<libc::pid_t>, bool)>>,
}

/// After [`Forward::stop`], SIGINT and SIGTERM end this process at once again.
#[cfg(unix)]
static DEFAULT_AGAIN: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Send SIGTERM to `pid`.
#[cfg(unix)]
fn terminate(pid: libc::pid_t) {
    // SAFETY: `kill` has no memory-safety preconditions. The child is not reaped before
    // `Forward::stop` has joined the forwarding thread, so `pid` is still the child's
    // (running or a zombie), never another process.
    unsafe {
        libc::kill(pid, libc::SIGTERM);
    }
}

impl Forward {
    /// Start, before the child is spawned ([`Forward::child`] names it).
    ///
    /// # Errors
    /// If the handlers cannot be installed (then the signals keep their default action).
    pub fn start() -> std::io::Result<Forward> {
        #[cfg(unix)]
        {
            use signal_hook::consts::{SIGINT, SIGTERM};
            use std::sync::atomic::Ordering;
            // Registered before the iterator's handlers, so that once they are gone (the
            // iterator dropped, which leaves a signal ignored) the default action is back.
            static REGISTERED: std::sync::Once = std::sync::Once::new();
            let mut registered: std::io::Result<()> = Ok(());
            REGISTERED.call_once(|| {
                registered =
                    signal_hook::flag::register_conditional_default(SIGINT, &DEFAULT_AGAIN)
                        .and_then(|_| {
                            signal_hook::flag::register_conditional_default(SIGTERM, &DEFAULT_AGAIN)
                        })
                        .map(|_| ());
            });
            registered?;
            DEFAULT_AGAIN.store(false, Ordering::SeqCst);
            let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM])?;
            let handle = signals.handle();
            let child = std::sync::Arc::new(std::sync::Mutex::new((None, false)));
            let seen = child.clone();
            let thread = std::thread::spawn(move || {
                for s in signals.forever() {
                    if s == SIGTERM {
                        let mut c = seen.lock().unwrap_or_else(|p| p.into_inner());
                        match c.0 {
                            Some(pid) => terminate(pid),
                            None => c.1 = true,
                        }
                    }
                }
            });
            Ok(Forward {
                handle,
                thread,
                child,
            })
        }
        #[cfg(not(unix))]
        {
            Ok(Forward {})
        }
    }

    /// The child is spawned, with process id `pid` (a SIGTERM that came before is forwarded
    /// now).
    pub fn child(&self, pid: u32) {
        #[cfg(unix)]
        {
            let Ok(pid) = libc::pid_t::try_from(pid) else {
                return;
            };
            let mut c = self.child.lock().unwrap_or_else(|p| p.into_inner());
            c.0 = Some(pid);
            if std::mem::take(&mut c.1) {
                terminate(pid);
            }
        }
        #[cfg(not(unix))]
        let _ = pid;
    }

    /// Stop forwarding — before the child is reaped: after its output ended, before `wait`
    /// — and let SIGINT and SIGTERM end this process at once again.
    pub fn stop(self) {
        #[cfg(unix)]
        {
            self.handle.close();
            let _ = self.thread.join();
            DEFAULT_AGAIN.store(true, std::sync::atomic::Ordering::SeqCst);
        }
    }
}
