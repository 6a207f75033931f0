//! Open MPI as the engine of a distributed run (`mbdc run --mpi`, cargo feature `mpi`): the
//! runtime's [`Ranks`] over `MPI_COMM_WORLD`, through the `mpi` crate.
//!
//! - [`Ranks::sum`]: an all-gather of every rank's vector, then the sum in rank order on
//!   every rank — the same bits everywhere and the same as the in-process engine's, whatever
//!   reduction tree `MPI_Allreduce` would pick.
//! - [`Ranks::exchange`]: non-blocking receives from every peer, then non-blocking sends,
//!   then one wait for all (no ordering between peers, so no deadlock however the peers
//!   pair up), into requests allocated once.
//! - [`Ranks::gather`], [`Ranks::broadcast`]: `MPI_Gatherv` and `MPI_Bcast` to and from
//!   rank 0.
//!
//! MPI is initialized with `MPI_THREAD_SERIALIZED`, and every call goes through one mutex:
//! any thread may call, never two at once, which is what that level allows. Nothing here
//! allocates once a call of a given size has run.

use std::os::raw::{c_int, c_void};
use std::sync::Mutex;

use mbdc_runtime::ranks::{Halo, Ranks};
use mpi::ffi;
use mpi::raw::AsRaw;
use mpi::traits::*;

/// What the mutex guards: the world and the scratch buffers.
struct Inner {
    world: mpi::topology::SimpleCommunicator,
    /// The all-gather of [`Ranks::sum`]: `size × len`.
    gathered: Vec<f64>,
    /// The exchange's requests: two per peer.
    requests: Vec<ffi::MPI_Request>,
    /// The gather's counts and displacements per rank.
    counts: Vec<c_int>,
    displs: Vec<c_int>,
}

// SAFETY: MPI runs at MPI_THREAD_SERIALIZED (checked in `MpiRanks::init`): its handles may
// be used from any thread as long as no two calls overlap, and every use of `Inner` is under
// `MpiRanks::inner`'s mutex.
unsafe impl Send for Inner {}

/// Open MPI's `MPI_COMM_WORLD` as [`Ranks`].
pub struct MpiRanks {
    inner: Mutex<Inner>,
    rank: usize,
    size: usize,
    library: String,
    /// Finalizes MPI when dropped (after `inner`, declared before it).
    _universe: Universe,
}

/// The `mpi` crate's universe, made `Send` and `Sync` for the reason [`Inner`] is: it is
/// only dropped, once.
struct Universe(#[allow(dead_code)] mpi::environment::Universe);
// SAFETY: as for `Inner`; the universe is never used after `init`, only dropped.
unsafe impl Send for Universe {}
// SAFETY: no method is called through a shared reference.
unsafe impl Sync for Universe {}

impl MpiRanks {
    /// Initialize MPI (once per process).
    ///
    /// # Errors
    /// MPI was initialized already, or the library gives less than
    /// `MPI_THREAD_SERIALIZED`.
    pub fn init() -> Result<MpiRanks, String> {
        let (universe, level) = mpi::initialize_with_threading(mpi::Threading::Serialized)
            .ok_or("MPI was initialized already in this process")?;
        if level < mpi::Threading::Serialized {
            return Err(format!(
                "the MPI library gives thread support {level:?}; mbdc needs MPI_THREAD_SERIALIZED"
            ));
        }
        let world = universe.world();
        let (rank, size) = (world.rank() as usize, world.size() as usize);
        let library = mpi::environment::library_version()
            .ok()
            .and_then(|v| v.split(',').next().map(|l| l.trim().to_string()))
            .unwrap_or_else(|| "MPI".into());
        Ok(MpiRanks {
            inner: Mutex::new(Inner {
                world,
                gathered: Vec::new(),
                requests: Vec::new(),
                counts: vec![0; size],
                displs: vec![0; size],
            }),
            rank,
            size,
            library,
            _universe: Universe(universe),
        })
    }

    fn inner(&self) -> std::sync::MutexGuard<'_, Inner> {
        self.inner.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Stop every rank of the run (`MPI_Abort`) with `code`.
    pub fn abort(&self, code: i32) -> ! {
        let inner = self.inner();
        inner.world.abort(code)
    }
}

impl Ranks for MpiRanks {
    fn rank(&self) -> usize {
        self.rank
    }

    fn size(&self) -> usize {
        self.size
    }

    fn sum(&self, x: &mut [f64]) {
        let mut g = self.inner();
        let Inner {
            world, gathered, ..
        } = &mut *g;
        let n = x.len();
        if gathered.len() < n * self.size {
            gathered.resize(n * self.size, 0.0);
        }
        let all = &mut gathered[..n * self.size];
        world.all_gather_into(&x[..], &mut all[..]);
        x.copy_from_slice(&all[..n]);
        for r in 1..self.size {
            for (x, y) in x.iter_mut().zip(&all[r * n..(r + 1) * n]) {
                *x += y;
            }
        }
    }

    fn exchange(&self, halo: &Halo, send: &[f64], recv: &mut [f64]) {
        let mut g = self.inner();
        let Inner {
            world, requests, ..
        } = &mut *g;
        let peers = halo.peers.len();
        // SAFETY: RSMPI_REQUEST_NULL is a constant of the MPI library.
        let null = unsafe { ffi::RSMPI_REQUEST_NULL };
        if requests.len() < 2 * peers {
            requests.resize(2 * peers, null);
        }
        let comm = world.as_raw();
        let double = f64::equivalent_datatype().as_raw();
        const TAG: c_int = 17;
        for (i, &p) in halo.peers.iter().enumerate() {
            let r = &mut recv[halo.recv_first[i] as usize..halo.recv_first[i + 1] as usize];
            // SAFETY: `r` outlives the request, which is waited for below before return;
            // the count is its length.
            unsafe {
                ffi::MPI_Irecv(
                    r.as_mut_ptr() as *mut c_void,
                    r.len() as c_int,
                    double,
                    p as c_int,
                    TAG,
                    comm,
                    &mut requests[i],
                );
            }
        }
        for (i, &p) in halo.peers.iter().enumerate() {
            let s = &send[halo.send_first[i] as usize..halo.send_first[i + 1] as usize];
            // SAFETY: as for the receives.
            unsafe {
                ffi::MPI_Isend(
                    s.as_ptr() as *const c_void,
                    s.len() as c_int,
                    double,
                    p as c_int,
                    TAG,
                    comm,
                    &mut requests[peers + i],
                );
            }
        }
        // SAFETY: the requests were started above on live buffers; statuses are ignored.
        unsafe {
            ffi::MPI_Waitall(
                2 * peers as c_int,
                requests.as_mut_ptr(),
                ffi::RSMPI_STATUSES_IGNORE,
            );
        }
    }

    fn gather(&self, piece: &[f64], all: &mut Vec<f64>) {
        let mut g = self.inner();
        let Inner {
            world,
            counts,
            displs,
            ..
        } = &mut *g;
        let root = world.process_at_rank(0);
        let n = piece.len() as c_int;
        if self.rank == 0 {
            root.gather_into_root(&n, &mut counts[..]);
            let mut at = 0;
            for (d, &c) in displs.iter_mut().zip(counts.iter()) {
                *d = at;
                at += c;
            }
            all.resize(at as usize, 0.0);
            let mut part = mpi::datatype::PartitionMut::new(&mut all[..], &counts[..], &displs[..]);
            root.gather_varcount_into_root(piece, &mut part);
        } else {
            root.gather_into(&n);
            root.gather_varcount_into(piece);
        }
    }

    fn broadcast(&self, x: &mut [f64]) {
        let g = self.inner();
        g.world.process_at_rank(0).broadcast_into(x);
    }

    fn engine(&self) -> String {
        format!("MPI ({})", self.library)
    }
}
