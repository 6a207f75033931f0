//! `app::StopSignals` in a process of its own (a test binary without other runs): while it is
//! installed, a stop signal is a request, seen by its handle and by the process-wide hook
//! that the accuracy study asks; other tests in the same process would see it too.
#![cfg(unix)]

use mbdc_runtime::app::{Signal, StopSignals};

/// A SIGTERM raised while the stop signals are installed is a request, not the end of
/// the process (this test process survives it), and is received as SIGTERM; a second
/// one is the same request. Only one `StopSignals` at a time. (SIGINT's second delivery
/// ends the process, so it is checked end to end, in `cli/tests/signals.rs`.)
#[test]
fn a_sigterm_is_a_request_while_installed() {
    let s = StopSignals::install().expect("handlers");
    assert_eq!(s.received(), None);
    assert_eq!(
        StopSignals::install().unwrap_err().kind(),
        std::io::ErrorKind::AlreadyExists
    );
    for _ in 0..2 {
        signal_hook::low_level::raise(signal_hook::consts::SIGTERM).expect("raise");
        assert_eq!(s.received(), Some(Signal::Terminate));
        assert_eq!(StopSignals::pending(), Some(Signal::Terminate));
    }
    drop(s);
    // the process-wide hook says nothing while none is installed
    assert_eq!(StopSignals::pending(), None);
    // installed again: a fresh start
    let s = StopSignals::install().expect("again");
    assert_eq!(s.received(), None);
}
