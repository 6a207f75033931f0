//! A run across the ranks of a distributed engine (`mbdc run --mpi`): every rank builds the
//! same scene, takes its part of it ([`Ranked`]), runs the one run loop on that part, and
//! rank 0 gathers the parts at every output frame and writes the one output folder
//! ([`run_ranked_to_dir`]).
//!
//! What each rank runs:
//! - the explicit mesh method on its part of the meshes
//!   ([`crate::analysis::mesh_ranks`]: its elements, the nodes they touch, the interface
//!   exchange), bitwise the motion of the whole mesh in one process;
//! - the implicit analyses on the whole mesh with FETI's subdomains shared between the
//!   ranks (the layout stays whole; the solver takes the ranks from [`System::ranks`]).
//!
//! **Decisions alike on every rank.** Everything the run loop decides from the state is
//! taken on values that are the same bits on every rank (the energies summed in rank
//! order, failures agreed before any rank waits for another), and what only one rank can
//! know is broadcast from rank 0: whether a checkpoint is due (wall clocks differ) and
//! whether the run was asked to stop (signals reach the ranks at different steps). So
//! every rank takes the same steps, and no rank waits for a message that never comes.

use std::sync::Arc;

use crate::analysis::mesh_ranks::{self, RankMap, RankPart};
use crate::contract::mesh_layout::MeshLayout;
use crate::contract::persist::StateVisitor;
use crate::contract::ranks::Ranks;
use crate::contract::scene::MeshMethod;
use crate::contract::system::{
    ConstraintEval, JointGeom, JointKernel, Layout, Need, Pose, System, Twist, Wrench,
};
use crate::driver::run_loop::{Frame, Observer};
use crate::integrators::State;

/// One rank's part of a system: the system itself, but for its meshes, which are the
/// rank's part under the explicit method, and the ranks it runs with.
pub struct Ranked<'s, S: System> {
    whole: &'s S,
    layout: Layout,
    ranks: Arc<dyn Ranks>,
    /// The explicit method's split (`None` for the implicit analyses, whose layout stays
    /// whole).
    split: Option<(RankMap, RankPart)>,
}

impl<'s, S: System> Ranked<'s, S> {
    /// This rank's part of `whole`.
    ///
    /// # Errors
    /// A scene with bodies or joints (a distributed run simulates meshes alone for now), a
    /// scene without meshes, more ranks than elements, what the distributed explicit
    /// method refuses ([`mesh_ranks::refusal`]).
    pub fn new(whole: &'s S, ranks: Arc<dyn Ranks>) -> Result<Ranked<'s, S>, String> {
        let l = whole.layout();
        if l.bodies() > 0 || l.rows > 0 || !l.beams.beams.is_empty() {
            return Err("a run across ranks simulates meshes alone for now: this scene has bodies, beams or joints; run it without --mpi".into());
        }
        if l.meshes.is_empty() {
            return Err("a run across ranks splits meshes, and this scene has none".into());
        }
        let mut layout = l.clone();
        let split = if l.meshes.method == MeshMethod::CentralDifference {
            let map = mesh_ranks::rank_map(&l.meshes, ranks.size()).map_err(|e| e.to_string())?;
            let part =
                mesh_ranks::rank_part(&l.meshes, &map, ranks.rank()).map_err(|e| e.to_string())?;
            if ranks.size() > 1 {
                layout.meshes = Arc::new(part.layout.clone());
            }
            Some((map, part))
        } else {
            None
        };
        Ok(Ranked {
            whole,
            layout,
            ranks,
            split,
        })
    }

    /// The ranks.
    pub fn ranks(&self) -> &Arc<dyn Ranks> {
        &self.ranks
    }

    /// The whole system.
    pub fn whole(&self) -> &S {
        self.whole
    }

    /// Elements and nodes of this rank's part of the meshes, and the values exchanged per
    /// step with the other ranks (`None` for the implicit analyses).
    pub fn part_size(&self) -> Option<(usize, usize, usize)> {
        self.split.as_ref().map(|(_, p)| {
            let h = p.layout.halo.as_ref().map_or(0, |h| h.exchange.send_len());
            (p.elements.len(), p.nodes.len(), h)
        })
    }
}

impl<S: System> System for Ranked<'_, S> {
    fn layout(&self) -> &Layout {
        &self.layout
    }
    fn initial_state(&self, pose: &mut [Pose], twist: &mut [Twist]) {
        self.whole.initial_state(pose, twist)
    }
    fn applied(&self, t: f64, pose: &[Pose], twist: &[Twist], out: &mut [Wrench]) {
        self.whole.applied(t, pose, twist, out)
    }
    fn constraints(
        &self,
        t: f64,
        pose: &[Pose],
        twist: &[Twist],
        need: Need,
        out: &mut ConstraintEval,
    ) {
        self.whole.constraints(t, pose, twist, need, out)
    }
    fn potential_energy(&self, t: f64, pose: &[Pose]) -> f64 {
        self.whole.potential_energy(t, pose)
    }
    fn update_locks(&self, pose: &[Pose], twist: &[Twist], active: &mut [bool]) -> Option<usize> {
        self.whole.update_locks(pose, twist, active)
    }
    fn has_velocity_forces(&self) -> bool {
        self.whole.has_velocity_forces()
    }
    fn has_state_forces(&self) -> bool {
        self.whole.has_state_forces()
    }
    fn tree_joint(&self, joint: usize) -> Option<(JointKernel, &JointGeom)> {
        self.whole.tree_joint(joint)
    }
    fn mesh_kernels(&self) -> Option<&dyn std::any::Any> {
        self.whole.mesh_kernels()
    }
    fn beam_kernels(&self) -> Option<&dyn std::any::Any> {
        self.whole.beam_kernels()
    }
    fn ranks(&self) -> Option<Arc<dyn Ranks>> {
        Some(self.ranks.clone())
    }
}

/// Rank 0's view of the other ranks' parts at output frames: which global nodes and
/// elements each rank's piece carries, in its order.
struct Pieces {
    /// Per rank: its owned nodes (global numbers, ascending: the order it sends them).
    nodes: Vec<Vec<u32>>,
    /// Per rank: its elements (global numbers, ascending).
    elements: Vec<Vec<u32>>,
}

/// The observer of one rank: gathers the parts' frames to rank 0, which hands the whole
/// frame to `inner` (the writers); agrees stop requests; forwards notices from rank 0.
pub struct Gather<'a> {
    ranks: Arc<dyn Ranks>,
    /// The whole meshes (rank 0 writes them).
    whole: Arc<MeshLayout>,
    /// This rank's part: its owned nodes (part numbering) — `None` when every rank holds
    /// the whole state (the implicit analyses).
    owned: Option<Vec<usize>>,
    pieces: Option<Pieces>,
    plastic: bool,
    inner: Option<&'a mut dyn Observer>,
    piece: Vec<f64>,
    all: Vec<f64>,
    state: State,
}

/// Values per owned node (u, v) and per element (stress, strain; plastic strain and the
/// equivalent one when some mesh is plastic) in a frame's piece.
const PER_NODE: usize = 6;
fn per_element(plastic: bool) -> usize {
    if plastic {
        19
    } else {
        12
    }
}

impl<'a> Gather<'a> {
    /// The observer of `sys`'s rank; `inner` the writers on rank 0 (ignored elsewhere).
    pub fn new<S: System>(sys: &Ranked<'_, S>, inner: Option<&'a mut dyn Observer>) -> Gather<'a> {
        let whole = sys.whole.layout().meshes.clone();
        let rank = sys.ranks.rank();
        let distributed = sys.ranks.size() > 1;
        let (owned, pieces) = match (&sys.split, distributed) {
            (Some((map, part)), true) => {
                let h = part.layout.halo.as_ref().expect("a part has its exchange");
                let owned = (0..part.nodes.len()).filter(|&i| h.owned[i]).collect();
                let pieces = (rank == 0).then(|| {
                    let mut nodes = vec![Vec::new(); map.ranks];
                    for (n, &r) in map.node_owner.iter().enumerate() {
                        nodes[r as usize].push(n as u32);
                    }
                    let mut elements = vec![Vec::new(); map.ranks];
                    for (e, &r) in map.element_rank.iter().enumerate() {
                        elements[r as usize].push(e as u32);
                    }
                    Pieces { nodes, elements }
                });
                (Some(owned), pieces)
            }
            _ => (None, None),
        };
        let mut state = State::new(0, 0);
        let (n, ne) = (whole.nodes(), whole.elements());
        state.mesh.u = vec![[0.0; 3]; n];
        state.mesh.v = vec![[0.0; 3]; n];
        state.mesh.stress = vec![[0.0; 6]; ne];
        state.mesh.strain = vec![[0.0; 6]; ne];
        let plastic = whole.is_plastic();
        if plastic {
            state.mesh.plastic_strain = vec![[0.0; 6]; ne];
            state.mesh.equivalent_plastic_strain = vec![0.0; ne];
        }
        Gather {
            ranks: sys.ranks.clone(),
            whole,
            owned,
            pieces,
            plastic,
            inner: if rank == 0 { inner } else { None },
            piece: Vec::new(),
            all: Vec::new(),
            state,
        }
    }

    /// The whole meshes' state of `frame` on rank 0 (the parts gathered).
    fn gather(&mut self, frame: &Frame<'_>) {
        let Some(owned) = &self.owned else {
            return;
        };
        let m = &frame.state.mesh;
        self.piece.clear();
        for &i in owned {
            self.piece.extend_from_slice(&m.u[i]);
            self.piece.extend_from_slice(&m.v[i]);
        }
        for e in 0..m.stress.len() {
            self.piece.extend_from_slice(&m.stress[e]);
            self.piece.extend_from_slice(&m.strain[e]);
            if self.plastic {
                self.piece.extend_from_slice(&m.plastic_strain[e]);
                self.piece.push(m.equivalent_plastic_strain[e]);
            }
        }
        self.ranks.gather(&self.piece, &mut self.all);
        let Some(p) = &self.pieces else {
            return;
        };
        let pe = per_element(self.plastic);
        let g = &mut self.state.mesh;
        let mut at = 0;
        for (nodes, elements) in p.nodes.iter().zip(&p.elements) {
            for &n in nodes {
                let x = &self.all[at..at + PER_NODE];
                g.u[n as usize].copy_from_slice(&x[..3]);
                g.v[n as usize].copy_from_slice(&x[3..]);
                at += PER_NODE;
            }
            for &e in elements {
                let x = &self.all[at..at + pe];
                let e = e as usize;
                g.stress[e].copy_from_slice(&x[..6]);
                g.strain[e].copy_from_slice(&x[6..12]);
                if self.plastic {
                    g.plastic_strain[e].copy_from_slice(&x[12..18]);
                    g.equivalent_plastic_strain[e] = x[18];
                }
                at += pe;
            }
        }
    }
}

impl Observer for Gather<'_> {
    fn frame(&mut self, frame: &Frame<'_>) {
        self.gather(frame);
        let Some(inner) = self.inner.as_deref_mut() else {
            return;
        };
        if self.owned.is_none() {
            return inner.frame(frame);
        }
        self.state.t = frame.state.t;
        self.state.mesh.energy = frame.state.mesh.energy;
        let (p, l) = crate::driver::energy::mesh_momenta(&self.whole, &self.state.mesh);
        inner.frame(&Frame {
            step: frame.step,
            state: &self.state,
            kinetic: frame.kinetic,
            potential: frame.potential,
            work: frame.work,
            momentum: p.into(),
            angular_momentum: l.into(),
            violation: frame.violation,
            velocity_violation: frame.velocity_violation,
        });
    }

    fn progress(&mut self, t: f64) {
        if let Some(i) = self.inner.as_deref_mut() {
            i.progress(t);
        }
    }

    fn notice(&mut self, message: &str) {
        if let Some(i) = self.inner.as_deref_mut() {
            i.notice(message);
        }
    }

    fn stop_requested(&mut self) -> Option<&'static str> {
        const BY: [&str; 3] = ["SIGINT", "SIGTERM", "a stop request"];
        let mine = self.inner.as_deref_mut().and_then(|i| i.stop_requested());
        let mut x = [mine.map_or(0.0, |by| {
            1.0 + BY.iter().position(|&b| b == by).unwrap_or(2) as f64
        })];
        self.ranks.broadcast(&mut x);
        (x[0] > 0.0).then(|| BY[(x[0] as usize - 1).min(2)])
    }

    fn save_output(&mut self, v: &mut dyn StateVisitor) -> Result<(), String> {
        match self.inner.as_deref_mut() {
            Some(i) => i.save_output(v),
            None => Ok(()),
        }
    }
}

/// Run this rank's part of the system. On rank 0, write the output folder of the whole
/// system as [`crate::driver::run_loop::run_to_dir`] does (the parts gathered at every
/// frame) and return the summary too; on the other ranks, run with no writer.
///
/// # Errors
/// The output folder cannot be written: on rank 0 why, and on the other ranks, which then
/// stop before their first step, that rank 0 could not.
pub fn run_ranked_to_dir<S: System>(
    sys: &Ranked<'_, S>,
    cfg: &crate::driver::run_loop::RunConfig,
    meta: crate::driver::output::RunMeta,
    spec: &crate::contract::scene::OutputSpec,
    dir: &std::path::Path,
    progress: &mut dyn Observer,
) -> Result<
    (
        crate::driver::run_loop::RunReport,
        Option<crate::driver::output::Summary>,
    ),
    crate::driver::output::OutputError,
> {
    use crate::driver::run_loop::{run, write_run};
    if sys.ranks.rank() == 0 {
        let mut started = false;
        let r = write_run(
            sys.whole.layout(),
            cfg,
            meta,
            spec,
            dir,
            progress,
            &mut |obs| {
                // the writers are open: the other ranks may start
                started = true;
                sys.ranks.broadcast(&mut [1.0]);
                let mut g = Gather::new(sys, Some(obs));
                run(sys, cfg, &mut g)
            },
        );
        if !started {
            sys.ranks.broadcast(&mut [0.0]);
        }
        let (report, summary) = r?;
        Ok((report, Some(summary)))
    } else {
        let mut go = [0.0];
        sys.ranks.broadcast(&mut go);
        if go[0] == 0.0 {
            return Err(crate::driver::output::OutputError::Json {
                path: dir.to_path_buf(),
                message: "rank 0 could not open the output folder (its report says why)".into(),
            });
        }
        let mut g = Gather::new(sys, None);
        Ok((run(sys, cfg, &mut g), None))
    }
}
