//! The processes of one distributed run (MPI ranks, notes E §2 and D §5) as the numerics see
//! them: a rank number, a sum over ranks, a neighbour exchange and a gather. The methods
//! that run across ranks (the explicit mesh method with its interface forces, FETI with its
//! multiplier-space vectors) ask only this of the engine; the engine itself — Open MPI behind
//! the `mbdc` program's `mpi` feature, or [`super::thread_ranks::ThreadRanks`] for ranks as
//! threads of one process — is not known here.
//!
//! **Same bits everywhere.** [`Ranks::sum`] adds in rank order, `((x₀ + x₁) + x₂) + …`, and
//! hands every rank the same result, whatever reduction tree the engine would pick: ranks
//! that decide from a sum (the watchdog's energy balance, a convergence test, a failure
//! flag) decide alike, so none waits for a message that will never come.

/// A neighbour exchange's plan: with peer `peers[i]` this rank swaps
/// `send[send_first[i]..send_first[i + 1]]` for `recv[recv_first[i]..recv_first[i + 1]]`
/// (the peer's plan lists this rank with the matching counts). Built once before a run: the
/// communication pattern is fixed in time (notes D §5).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Halo {
    /// The peers, ascending.
    pub peers: Vec<u32>,
    /// Where each peer's values start in the send buffer (`peers.len() + 1` entries).
    pub send_first: Vec<u32>,
    /// Where each peer's values start in the receive buffer (`peers.len() + 1` entries).
    pub recv_first: Vec<u32>,
}

impl Halo {
    /// Values sent per exchange.
    pub fn send_len(&self) -> usize {
        self.send_first.last().map_or(0, |&s| s as usize)
    }
    /// Values received per exchange.
    pub fn recv_len(&self) -> usize {
        self.recv_first.last().map_or(0, |&s| s as usize)
    }
}

/// The ranks of a distributed run, seen from one of them. Every method is collective: all
/// ranks call it, in the same order (for [`Ranks::exchange`]: the rank and its peers).
/// After a first call of a given size, no method allocates.
pub trait Ranks: Send + Sync {
    /// This process's rank, `0..size()`.
    fn rank(&self) -> usize;
    /// Number of ranks.
    fn size(&self) -> usize;
    /// Element by element, the sum over the ranks of `x`, in place, taken in rank order and
    /// the same bits on every rank.
    fn sum(&self, x: &mut [f64]);
    /// The neighbour exchange of `halo`: `send` out, `recv` in.
    fn exchange(&self, halo: &Halo, send: &[f64], recv: &mut [f64]);
    /// Rank 0 receives every rank's `piece`, rank after rank, into `all` (resized); the
    /// others leave `all` as it is. Pieces may differ in length.
    fn gather(&self, piece: &[f64], all: &mut Vec<f64>);
    /// Every rank receives rank 0's `x` (the same length on every rank).
    fn broadcast(&self, x: &mut [f64]);
    /// What the engine is, for reports: `"MPI (Open MPI 4.1.4)"`, `"threads"`.
    fn engine(&self) -> String;
}

/// Whether any rank says `mine`: a flag agreed by all (one [`Ranks::sum`]).
pub fn any(ranks: &dyn Ranks, mine: bool) -> bool {
    let mut x = [if mine { 1.0 } else { 0.0 }];
    ranks.sum(&mut x);
    x[0] > 0.0
}
