//! Ranks as threads of one process: the [`Ranks`] engine that needs no MPI, so that the
//! distributed algorithms (the explicit mesh method's interface exchange, FETI's sums) run
//! and are tested in every build, and give the bits the MPI engine gives: its sums take the
//! same rank order.
//!
//! Each collective is two barrier crossings around shared boards (one per rank for sums and
//! gathers, one per ordered pair of ranks for the exchange). A rank that panics breaks the
//! barrier, and every other rank then panics too instead of waiting for ever.

use std::sync::{Arc, Condvar, Mutex, MutexGuard};

use super::ranks::{Halo, Ranks};

/// One rank of a [`ThreadRanks::run`].
pub struct ThreadRanks {
    rank: usize,
    shared: Arc<Shared>,
}

struct Shared {
    n: usize,
    gate: Gate,
    /// Per rank: what it hands to sums, gathers and broadcasts.
    board: Vec<Mutex<Vec<f64>>>,
    /// Per ordered pair `(from, to)`, at `from · n + to`: the exchange's message.
    mail: Vec<Mutex<Vec<f64>>>,
}

/// A reusable barrier that a panicking rank breaks.
struct Gate {
    n: usize,
    /// (arrived, generation, broken)
    state: Mutex<(usize, u64, bool)>,
    cv: Condvar,
}

impl Gate {
    fn wait(&self) {
        let mut g = lock(&self.state);
        if g.2 {
            drop(g);
            panic!("another rank failed");
        }
        g.0 += 1;
        if g.0 == self.n {
            g.0 = 0;
            g.1 += 1;
            self.cv.notify_all();
            return;
        }
        let generation = g.1;
        while g.1 == generation && !g.2 {
            g = self.cv.wait(g).unwrap_or_else(|e| e.into_inner());
        }
        if g.2 {
            drop(g);
            panic!("another rank failed");
        }
    }

    fn break_all(&self) {
        lock(&self.state).2 = true;
        self.cv.notify_all();
    }
}

/// Breaks the gate when its rank's thread unwinds.
struct BreakOnPanic<'a>(&'a Gate);

impl Drop for BreakOnPanic<'_> {
    fn drop(&mut self) {
        if std::thread::panicking() {
            self.0.break_all();
        }
    }
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

impl ThreadRanks {
    /// Run `f` on `n` ≥ 1 ranks, each a thread of this process, and return what each
    /// returned, in rank order.
    ///
    /// # Panics
    /// If a rank panics (then every rank does, and the first panic is re-raised).
    pub fn run<T: Send>(n: usize, f: impl Fn(Arc<dyn Ranks>) -> T + Sync) -> Vec<T> {
        assert!(n >= 1, "at least one rank");
        let shared = Arc::new(Shared {
            n,
            gate: Gate {
                n,
                state: Mutex::new((0, 0, false)),
                cv: Condvar::new(),
            },
            board: (0..n).map(|_| Mutex::new(Vec::new())).collect(),
            mail: (0..n * n).map(|_| Mutex::new(Vec::new())).collect(),
        });
        let f = &f;
        std::thread::scope(|s| {
            let handles: Vec<_> = (0..n)
                .map(|rank| {
                    let shared = shared.clone();
                    s.spawn(move || {
                        let _guard = BreakOnPanic(&shared.gate);
                        let me: Arc<dyn Ranks> = Arc::new(ThreadRanks {
                            rank,
                            shared: shared.clone(),
                        });
                        f(me)
                    })
                })
                .collect();
            let results: Vec<std::thread::Result<T>> =
                handles.into_iter().map(|h| h.join()).collect();
            // a rank's own panic, not a follower's "another rank failed"
            let mut out = Vec::with_capacity(n);
            let (mut own, mut follower) = (None, None);
            for r in results {
                match r {
                    Ok(t) => out.push(t),
                    Err(p) => {
                        if p.downcast_ref::<&str>() == Some(&"another rank failed") {
                            follower.get_or_insert(p);
                        } else {
                            own.get_or_insert(p);
                        }
                    }
                }
            }
            if let Some(p) = own.or(follower) {
                std::panic::resume_unwind(p);
            }
            out
        })
    }
}

impl Ranks for ThreadRanks {
    fn rank(&self) -> usize {
        self.rank
    }

    fn size(&self) -> usize {
        self.shared.n
    }

    fn sum(&self, x: &mut [f64]) {
        let sh = &*self.shared;
        {
            let mut b = lock(&sh.board[self.rank]);
            b.clear();
            b.extend_from_slice(x);
        }
        sh.gate.wait();
        for (r, board) in sh.board.iter().enumerate() {
            let b = lock(board);
            assert_eq!(
                b.len(),
                x.len(),
                "ranks summed vectors of different lengths"
            );
            if r == 0 {
                x.copy_from_slice(&b);
            } else {
                for (x, b) in x.iter_mut().zip(b.iter()) {
                    *x += b;
                }
            }
        }
        sh.gate.wait();
    }

    fn exchange(&self, halo: &Halo, send: &[f64], recv: &mut [f64]) {
        let sh = &*self.shared;
        let (me, n) = (self.rank, sh.n);
        for (i, &p) in halo.peers.iter().enumerate() {
            let mut m = lock(&sh.mail[me * n + p as usize]);
            m.clear();
            m.extend_from_slice(
                &send[halo.send_first[i] as usize..halo.send_first[i + 1] as usize],
            );
        }
        sh.gate.wait();
        for (i, &p) in halo.peers.iter().enumerate() {
            let m = lock(&sh.mail[p as usize * n + me]);
            let r = &mut recv[halo.recv_first[i] as usize..halo.recv_first[i + 1] as usize];
            assert_eq!(
                m.len(),
                r.len(),
                "rank {p} sent {} values where rank {me} expects {}",
                m.len(),
                r.len()
            );
            r.copy_from_slice(&m);
        }
        sh.gate.wait();
    }

    fn gather(&self, piece: &[f64], all: &mut Vec<f64>) {
        let sh = &*self.shared;
        {
            let mut b = lock(&sh.board[self.rank]);
            b.clear();
            b.extend_from_slice(piece);
        }
        sh.gate.wait();
        if self.rank == 0 {
            all.clear();
            for board in &sh.board {
                all.extend_from_slice(&lock(board));
            }
        }
        sh.gate.wait();
    }

    fn broadcast(&self, x: &mut [f64]) {
        let sh = &*self.shared;
        if self.rank == 0 {
            let mut b = lock(&sh.board[0]);
            b.clear();
            b.extend_from_slice(x);
        }
        sh.gate.wait();
        if self.rank != 0 {
            x.copy_from_slice(&lock(&sh.board[0]));
        }
        sh.gate.wait();
    }

    fn engine(&self) -> String {
        "threads of one process".into()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contract::ranks::any;

    #[test]
    fn sums_in_rank_order_and_alike_everywhere() {
        // 1 + 1e-16 + 1e-16 in order is 1 (each tiny addend is lost), which a tree that
        // added the tiny ones first would not give
        let out = ThreadRanks::run(3, |r| {
            let mut x = [[1.0, 1e-16, 1e-16][r.rank()], r.rank() as f64];
            r.sum(&mut x);
            x
        });
        for x in &out {
            assert_eq!(x[0].to_bits(), 1.0f64.to_bits());
            assert_eq!(x[1], 3.0);
        }
    }

    #[test]
    fn exchanges_gathers_and_broadcasts() {
        let out = ThreadRanks::run(3, |r| {
            let me = r.rank() as u32;
            // a ring: each rank sends its number (me + 1) times to each other rank
            let peers: Vec<u32> = (0..3).filter(|&p| p != me).collect();
            let mut halo = Halo {
                peers: peers.clone(),
                send_first: vec![0],
                recv_first: vec![0],
            };
            let mut send = Vec::new();
            for &p in &peers {
                send.extend(std::iter::repeat_n(me as f64, me as usize + 1));
                halo.send_first.push(send.len() as u32);
                let last = *halo.recv_first.last().unwrap();
                halo.recv_first.push(last + p + 1);
            }
            let mut recv = vec![0.0; halo.recv_len()];
            r.exchange(&halo, &send, &mut recv);
            let mut all = Vec::new();
            r.gather(&[me as f64; 2][..me as usize % 2 + 1], &mut all);
            let mut b = [me as f64 + 10.0];
            r.broadcast(&mut b);
            (recv, all, b[0], any(&*r, me == 2))
        });
        assert_eq!(out[0].0, vec![1.0, 1.0, 2.0, 2.0, 2.0]);
        assert_eq!(out[1].0, vec![0.0, 2.0, 2.0, 2.0]);
        assert_eq!(out[2].0, vec![0.0, 1.0, 1.0]);
        assert_eq!(out[0].1, vec![0.0, 1.0, 1.0, 2.0]);
        assert!(out[1].1.is_empty());
        assert!(out.iter().all(|o| o.2 == 10.0 && o.3));
    }

    #[test]
    fn a_panicking_rank_stops_the_others() {
        let r = std::panic::catch_unwind(|| {
            ThreadRanks::run(3, |r| {
                if r.rank() == 1 {
                    panic!("rank one broke");
                }
                let mut x = [1.0];
                r.sum(&mut x);
            })
        });
        let p = r.expect_err("the run panics");
        assert_eq!(p.downcast_ref::<&str>(), Some(&"rank one broke"));
    }
}
