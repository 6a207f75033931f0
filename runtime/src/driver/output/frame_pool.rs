//! The pool of recycled [`Frame`] buffers between the simulation thread and the writer.
//!
//! A `Mutex<Vec<Frame>>` with a `Condvar`, not a channel: a blocking `recv` on a std
//! channel allocates the waiting thread's context and the channel's waiter list the first
//! time it has to wait, and when it first has to wait depends on how far the writer lags
//! (a warm-up wait cannot be made to happen reliably). A futex `Condvar` wait and a `Vec`
//! whose capacity is the pool size never allocate.

use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use super::Frame;

struct Shelf {
    frames: Vec<Frame>,
    /// The writer thread has ended (normally or by panic): nothing more will come back.
    closed: bool,
}

struct Shared {
    shelf: Mutex<Shelf>,
    returned: Condvar,
}

impl Shared {
    fn lock(&self) -> MutexGuard<'_, Shelf> {
        self.shelf.lock().unwrap_or_else(|p| p.into_inner())
    }
}

/// The simulation thread's end: takes frames, waiting while all are with the writer.
pub(super) struct FramePool {
    shared: Arc<Shared>,
}

/// The writer thread's end: gives frames back. Dropping it (also when the writer thread
/// unwinds) closes the pool, so a waiting [`FramePool::take`] returns `None`.
pub(super) struct FrameReturn {
    shared: Arc<Shared>,
}

impl FramePool {
    /// A pool holding `frames` (all of them: its capacity is their number).
    pub(super) fn new(frames: Vec<Frame>) -> (FramePool, FrameReturn) {
        let shared = Arc::new(Shared {
            shelf: Mutex::new(Shelf {
                frames,
                closed: false,
            }),
            returned: Condvar::new(),
        });
        (
            FramePool {
                shared: shared.clone(),
            },
            FrameReturn { shared },
        )
    }

    /// A frame, waiting while the pool is empty, with how long it waited (`None`: the
    /// pool had one); `None` once the writer has ended with the pool empty.
    /// Allocation-free (the clock is read only when it has to wait).
    pub(super) fn take(&self) -> Option<(Frame, Option<Duration>)> {
        let mut shelf = self.shared.lock();
        let mut since: Option<Instant> = None;
        loop {
            if let Some(f) = shelf.frames.pop() {
                return Some((f, since.map(|t| t.elapsed())));
            }
            if shelf.closed {
                return None;
            }
            since.get_or_insert_with(Instant::now);
            shelf = self
                .shared
                .returned
                .wait(shelf)
                .unwrap_or_else(|p| p.into_inner());
        }
    }
}

impl FrameReturn {
    /// Put a written frame back. Never grows the shelf past its capacity (a frame that
    /// did not come from this pool is dropped instead).
    pub(super) fn give(&self, frame: Frame) {
        let mut shelf = self.shared.lock();
        if shelf.frames.len() < shelf.frames.capacity() {
            shelf.frames.push(frame);
            drop(shelf);
            self.shared.returned.notify_one();
        }
    }
}

impl Drop for FrameReturn {
    fn drop(&mut self) {
        self.shared.lock().closed = true;
        self.shared.returned.notify_all();
    }
}
