//! Streaming output: CSV time series and `summary.json`, written by a background thread
//! while the simulation runs, so that a run that is stopped or fails keeps every frame
//! written so far.
//!
//! # Flow
//!
//! ```text
//! simulation thread                         writer thread
//! frame = writer.frame()   ◄── pool ───     (recycled Frame buffers)
//! fill frame (no allocation)
//! writer.submit(frame)     ─── queue ──►    format rows into per-file Strings,
//!                                           return the Frame to the pool;
//!                                           when the queue is empty: write the
//!                                           Strings to the files
//! writer.finish(&summary)  ─── close ──►    flush, exit; summary.json written
//! ```
//!
//! - **Bounded memory.** All [`Frame`]s are allocated by [`OutputWriter::create`]: a pool
//!   of `clamp(64 MiB / frame size, 2, 32)` buffers. [`OutputWriter::frame`] blocks while
//!   every buffer is queued, so a slow disk slows the simulation instead of growing memory.
//! - **No allocation on the simulation thread.** `frame` takes buffers from a pool that
//!   waits on a futex (`frame_pool.rs`), `submit` sends them through a bounded channel
//!   that holds every buffer there is (so it never waits); all formatting happens on the writer thread, into
//!   `String`s reused across batches.
//! - **Lag and integrity.** The writer writes whenever its queue runs empty (and whenever
//!   a file's batch exceeds 1 MiB), so data on disk lags the simulation by at most one
//!   batch. Each write is a whole number of lines, issued with one `write_all` on the
//!   unbuffered file, so a process killed between writes leaves only complete lines. If a
//!   write fails (disk full, I/O error), the file is truncated back to its last complete
//!   batch, writing stops for every file (so the files stay mutually consistent), and the
//!   error — with the path — is returned by the next [`OutputWriter::submit`] and by
//!   [`OutputWriter::finish`].
//! - **Numbers** are written in the shortest decimal form that parses back to the same
//!   `f64` (ryu), so a CSV round trip is exact; non-finite values are `NaN`, `inf`, `-inf`.
//!   The VTK frames use the same form (`1.5e-9`, not `0.0000000015`).
//! - **Size**: [`size_estimate`] estimates before a run what it will write; `mbdc run`
//!   warns above 1 GB with the output interval that would not.
//! - **summary.json** is written at creation with `"status": "started"` and `finished:
//!   false` (so even a killed run leaves one, and `mbdc plot` can tell that it never
//!   finished) and rewritten atomically (temporary file + rename) by `finish`, also on
//!   failure or interruption ([`RunStatus`]).
//!
//! # Files
//!
//! | file | columns |
//! |---|---|
//! | `scene.json` | the scene the run simulated, its meshes without nodes and elements (see `scene_file.rs`; written by `mbdc run` and generated programs before the first step) |
//! | `bodies.csv` | `t`, then per body `<body>.x .y .z .qw .qx .qy .qz .vx .vy .vz .wx .wy .wz` (position and velocity world, quaternion body → world, angular velocity body components) |
//! | `energy.csv` | `t, kinetic, potential, total, work, drift, px, py, pz, Lx, Ly, Lz` (`work`: done since t = 0 by point forces and torques, dampers, contact damping and drivers, see `driver::work`; momenta world, angular about the world origin) |
//! | `constraints.csv` | `t`, then per joint `<joint>.violation`, `<joint>.velocity_violation` (joints with nonholonomic rows only), `<joint>.lambda0 …` (one per row) |
//! | `beams.pvd`, `beams/beams_NNNNNN.vtp` | scenes with beams: a ParaView time series, one VTK PolyData file per frame (nodes as points, elements as lines, the section quantities as cell data; see `vtk.rs`) |
//! | `mesh.pvd`, `mesh/mesh_NNNNNN.vtu` | scenes with meshes: a ParaView time series, one VTK UnstructuredGrid per frame (reference points with `displacement` and `velocity`, elements with `stress`, `strain`, `von_mises`, and with a plastic mesh `plastic_strain` and `equivalent_plastic_strain`; see `vtu.rs`) |
//! | `mesh_energy.csv` | scenes with meshes: `t, kinetic, strain, hourglass, foundation, external_work, dissipated, plastic, tie_work, half_step, balance` (J): `balance = kinetic + strain + hourglass + foundation − external_work − tie_work + dissipated + plastic + half_step`, constant up to the method's error (`half_step = −(h²/8) Σ m |a|²` makes the kinetic energy that of the half-step velocities, which the central difference conserves; `strain` is the elastic strain energy, `plastic` the plastic work, `tie_work` the work the bodies do on the meshes through ties; tied nodes' kinetic energy is their body's) |
//! | `beams.csv` | scenes with beams: one row per element and frame, `t, beam, element, s` (arc length of the element's midpoint, unstrained), section forces `N1 N2 N3` (axial, shear 2, shear 3; N), moments `M1 M2 M3` (torsion, bending 2, bending 3; N·m), strains `gamma1 gamma2 gamma3` and curvatures `kappa1 kappa2 kappa3` (1/m), all in the element's convected frame |
//!
//! | `results.exo`, `results.exo.manifest.json` | format `exodus`: every body, beam and mesh frame in one Exodus II file (netCDF-3 64-bit offset) written by partitions at computed offsets, and who wrote what where (see `exodus.rs`, `docs/output.md`); replaces `beams.csv` and the VTK series |
//!
//! Only the files the [`OutputSpec`] asks for are created; its `format` chooses between the
//! VTK series (`vtk`, the default), none (`csv`) and `results.exo` (`exodus`).
//!
//! `drift` is the error of the energy balance, `(E − W − E₀) / E_ref`, with `E = K + V` the
//! total energy, `W` the work column, `E₀` the total energy of the first frame (less its
//! work) and `E_ref = max(|E₀|, K_max + (V_max − V_min), |W|_max, 10⁻³⁰⁰)` over the frames
//! written so far: the energy in play, as in the run driver's report (which also counts
//! every step between frames). Unlike `|E₀|` alone it does not
//! divide by zero when the potential datum makes `E₀ = 0`, and unlike `K + |V|` it does
//! not depend on where the potential's zero is once anything has moved.

mod csv;
pub mod exodus;
mod exodus_manifest;
mod exodus_read;
mod frame_pool;
mod json;
mod netcdf3;
mod replace_file;
mod scene_file;
pub mod size_estimate;
mod vtk;
mod vtu;

pub use replace_file::replace_file;
pub use scene_file::{read_scene, write_scene, SCENE_FILE};
pub use size_estimate::{estimate, OutputEstimate};

pub use vtu::{cell_type as vtk_cell_type, von_mises, MESH_ENERGY_COLUMNS};

use std::collections::BTreeMap;
use std::fs::File;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender};

use frame_pool::{FramePool, FrameReturn};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;

use serde::{Deserialize, Serialize};

use crate::contract::persist::{self, StateVisitor};
use crate::contract::scene::{OutputFormat, OutputSpec};
use crate::contract::system::{Layout, Pose, RowKind, Twist};

pub use csv::{
    beams_header, bodies_header, constraints_header, energy_header, BEAM_COLUMNS, BODY_COLUMNS,
    ENERGY_COLUMNS,
};

/// One output frame: the state and the derived quantities at one time. Plain data,
/// allocated by [`OutputWriter::create`] and recycled.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// Step number.
    pub step: u64,
    /// Time, s.
    pub t: f64,
    /// Body poses.
    pub poses: Vec<Pose>,
    /// Body twists.
    pub twists: Vec<Twist>,
    /// Kinetic energy, J.
    pub kinetic: f64,
    /// Potential energy, J.
    pub potential: f64,
    /// Work done since t = 0 by what the potential energy does not hold (point forces and
    /// torques, dampers, contact damping, drivers), J.
    pub work: f64,
    /// Linear momentum, world components.
    pub momentum: [f64; 3],
    /// Angular momentum about the world origin, world components.
    pub angular_momentum: [f64; 3],
    /// Per joint: the largest `|Φ|` over its (active) holonomic rows, 0 if none.
    pub violation: Vec<f64>,
    /// Per joint: the largest velocity residual `|B u̇ + b|` over its (active)
    /// nonholonomic rows, 0 if none (written only for joints that have such rows).
    pub velocity_violation: Vec<f64>,
    /// Multipliers λ, one per constraint row.
    pub lambda: Vec<f64>,
    /// Per beam element: `s`, then the [`BEAM_COLUMNS`] (empty without beams).
    pub sections: Vec<[f64; 13]>,
    /// Per mesh node: displacement, m (empty without meshes).
    pub mesh_u: Vec<[f64; 3]>,
    /// Per mesh node: velocity, m/s.
    pub mesh_v: Vec<[f64; 3]>,
    /// Per mesh element: mean stress, Pa (Voigt xx yy zz yz xz xy).
    pub mesh_stress: Vec<[f64; 6]>,
    /// Per mesh element: mean strain (tensor shear).
    pub mesh_strain: Vec<[f64; 6]>,
    /// Per mesh element: mean plastic strain (tensor shear; empty when no mesh is plastic).
    pub mesh_plastic_strain: Vec<[f64; 6]>,
    /// Per mesh element: mean equivalent plastic strain (empty when no mesh is plastic).
    pub mesh_equivalent_plastic_strain: Vec<f64>,
    /// The meshes' energies, J, in the order of [`MESH_ENERGY_COLUMNS`].
    pub mesh_energy: [f64; 10],
}

impl Frame {
    /// A zeroed frame sized for a layout.
    pub fn new(layout: &Layout) -> Frame {
        Frame {
            step: 0,
            t: 0.0,
            poses: vec![Pose::default(); layout.bodies()],
            twists: vec![Twist::default(); layout.bodies()],
            kinetic: 0.0,
            potential: 0.0,
            work: 0.0,
            momentum: [0.0; 3],
            angular_momentum: [0.0; 3],
            violation: vec![0.0; layout.joints.len()],
            velocity_violation: vec![0.0; layout.joints.len()],
            lambda: vec![0.0; layout.rows],
            sections: vec![[0.0; 13]; layout.beams.elements.len()],
            mesh_u: vec![[0.0; 3]; layout.meshes.nodes()],
            mesh_v: vec![[0.0; 3]; layout.meshes.nodes()],
            mesh_stress: vec![[0.0; 6]; layout.meshes.elements()],
            mesh_strain: vec![[0.0; 6]; layout.meshes.elements()],
            mesh_plastic_strain: vec![[0.0; 6]; plastic_elements(layout)],
            mesh_equivalent_plastic_strain: vec![0.0; plastic_elements(layout)],
            mesh_energy: [0.0; 10],
        }
    }

    /// Fill the per-joint violations and the multipliers from per-row data: `phi` the
    /// constraint values, `velocity_residual` the velocity-level residuals `B u̇ + b`,
    /// `lambda` the multipliers, `active` the enforced rows (`None`: all). Inactive rows
    /// count neither as violation nor as multiplier. Allocation-free.
    ///
    /// # Panics
    /// If a slice does not have one entry per row.
    pub fn set_constraints(
        &mut self,
        layout: &Layout,
        phi: &[f64],
        velocity_residual: &[f64],
        lambda: &[f64],
        active: Option<&[bool]>,
    ) {
        assert_eq!(phi.len(), layout.rows);
        assert_eq!(velocity_residual.len(), layout.rows);
        assert_eq!(lambda.len(), layout.rows);
        for (j, jl) in layout.joints.iter().enumerate() {
            let (mut p, mut v) = (0.0f64, 0.0f64);
            for r in jl.first_row..jl.first_row + jl.rows {
                let on = active.is_none_or(|a| a[r]);
                self.lambda[r] = if on { lambda[r] } else { 0.0 };
                if !on {
                    continue;
                }
                match layout.row_kind[r] {
                    RowKind::Holonomic => p = p.max(phi[r].abs()),
                    RowKind::Nonholonomic => v = v.max(velocity_residual[r].abs()),
                }
            }
            self.violation[j] = p;
            self.velocity_violation[j] = v;
        }
    }

    fn bytes(layout: &Layout) -> usize {
        std::mem::size_of::<Frame>()
            + layout.bodies() * (std::mem::size_of::<Pose>() + std::mem::size_of::<Twist>())
            + (2 * layout.joints.len() + layout.rows) * 8
            + layout.beams.elements.len() * 13 * 8
            + layout.meshes.nodes() * 6 * 8
            + layout.meshes.elements() * 12 * 8
            + plastic_elements(layout) * 7 * 8
    }
}

/// The number of elements with plastic outputs: all of them when some mesh is plastic.
fn plastic_elements(layout: &Layout) -> usize {
    if layout.meshes.is_plastic() {
        layout.meshes.elements()
    } else {
        0
    }
}

/// What a run is, for `summary.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunMeta {
    /// Model name.
    pub model: String,
    /// Method name.
    pub method: String,
    /// Step size, s.
    #[serde(with = "json::f64_any")]
    pub step: f64,
    /// Requested duration, s.
    #[serde(with = "json::f64_any")]
    pub duration: f64,
}

/// Why a run stopped early (the `failure` object of `summary.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Failure {
    /// Simulated time of the last good state, s.
    #[serde(with = "json::f64_any")]
    pub time: f64,
    /// Step number at which it went wrong.
    pub step: u64,
    /// The body or joint where it started (or `system`).
    #[serde(rename = "where")]
    pub location: String,
    /// The quantity that went wrong.
    pub quantity: String,
    /// Its value (may be NaN or infinite; written as a string then).
    #[serde(with = "json::f64_any")]
    pub value: f64,
    /// The likely cause.
    pub cause: String,
    /// What to try.
    pub hint: Option<String>,
}

/// The energy balance of a run where it ended (the `energy_balance` object of
/// `summary.json`): `kinetic + potential − work_forces − work_drivers − start` is the
/// balance's error, zero for an exact solution.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct EnergyBalance {
    /// Kinetic energy at the end, J (bodies, beam nodes, mesh nodes).
    #[serde(with = "json::f64_any")]
    pub kinetic: f64,
    /// Potential energy at the end, J: gravity, springs, contact, the beams' strain energy and
    /// the meshes' stored energy less their own loads' work plus their dissipation.
    #[serde(with = "json::f64_any")]
    pub potential: f64,
    /// Work done since the start by point forces and torques, dampers and contact damping
    /// (positive: energy put in), J.
    #[serde(with = "json::f64_any")]
    pub work_forces: f64,
    /// Work done since the start by drivers and prescribed velocities, J.
    #[serde(with = "json::f64_any")]
    pub work_drivers: f64,
    /// The energy change over the steps with an impulse the states do not show — a lock
    /// engaging (usually a loss), a driver's rate jumping — J; counted like work.
    #[serde(default, with = "json::f64_any")]
    pub impulses: f64,
    /// Kinetic plus potential energy at the start, J.
    #[serde(with = "json::f64_any")]
    pub start: f64,
    /// The energy in play the error is measured against, J: the largest of |start|, the
    /// largest kinetic energy plus the potential energy's range, and the largest work.
    #[serde(with = "json::f64_any")]
    pub in_play: f64,
    /// Whether an energy loss stops the run too (false with locks, damped beams or dynamic
    /// relaxation, whose dissipation is not booked).
    pub loss_checked: bool,
}

impl EnergyBalance {
    /// The balance's error, J: `kinetic + potential − work − impulses − start`.
    pub fn error(&self) -> f64 {
        self.kinetic + self.potential
            - self.work_forces
            - self.work_drivers
            - self.impulses
            - self.start
    }
}

/// A run stopped from outside before its end: by a signal (`SIGINT`, `SIGTERM`) or another
/// request ([`crate::driver::run_loop::Observer::stop_requested`]). Not a failure: the state
/// was fine; the `interrupted` object of `summary.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Interruption {
    /// What asked the run to stop: the signal's name, or the requester's words.
    pub by: String,
    /// Simulated time reached (the time of the last step taken, which is also the time of
    /// the last frame written), s.
    #[serde(with = "json::f64_any")]
    pub time: f64,
    /// Steps taken.
    pub step: u64,
}

impl std::fmt::Display for Interruption {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "interrupted by {} at t = {:.6} s (step {})",
            self.by, self.time, self.step
        )
    }
}

/// Where a run is, as its `summary.json` says: the `status` field, derived from the other
/// fields ([`Summary::status`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RunStatus {
    /// The summary written when the run started and never replaced: the run is still going,
    /// or its process ended without a word (SIGKILL, a crash, a power cut). The frames on
    /// disk are whole up to the last one written.
    Started,
    /// The run reached its duration.
    Finished,
    /// The run stopped because it could not continue (the `failure` object says why).
    Failed,
    /// The run was stopped from outside (the `interrupted` object says by what, and when).
    Interrupted,
}

impl RunStatus {
    /// The word for it on a terminal.
    pub fn word(self) -> &'static str {
        match self {
            RunStatus::Started => "did not finish",
            RunStatus::Finished => "finished",
            RunStatus::Failed => "STOPPED",
            RunStatus::Interrupted => "interrupted",
        }
    }
}

/// The content of `summary.json`.
///
/// Non-finite numbers are written as the strings `"NaN"`, `"inf"`, `"-inf"` (JSON has
/// no such numbers) and read back. The file also has a `status` field
/// ([`Summary::status`]: `started`, `finished`, `failed`, `interrupted`), written first;
/// it is derived from the other fields, so it is not read back.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// Model name.
    pub model: String,
    /// Method name.
    pub method: String,
    /// Step size, s.
    #[serde(with = "json::f64_any")]
    pub step: f64,
    /// Requested duration, s.
    #[serde(with = "json::f64_any")]
    pub duration: f64,
    /// Steps taken.
    pub steps: u64,
    /// Simulated time reached, s.
    #[serde(with = "json::f64_any")]
    pub final_time: f64,
    /// Wall-clock time of the run, s.
    #[serde(with = "json::f64_any")]
    pub wall_time: f64,
    /// Whether the run reached its duration.
    pub finished: bool,
    /// Why it stopped early.
    pub failure: Option<Failure>,
    /// Whether, by what and when it was stopped from outside (a signal).
    #[serde(default)]
    pub interrupted: Option<Interruption>,
    /// Largest holonomic constraint violation. `None` in the summary given to
    /// [`OutputWriter::finish`]: the largest over the written frames is filled in.
    #[serde(with = "json::opt_f64_any")]
    pub max_constraint_violation: Option<f64>,
    /// The joint where it occurred (filled in like `max_constraint_violation`).
    pub max_violation_joint: Option<String>,
    /// Largest `|drift|` (see the module doc); filled in like `max_constraint_violation`.
    #[serde(with = "json::opt_f64_any")]
    pub max_energy_drift: Option<f64>,
    /// The energy balance where the run ended (absent in the summary written at the start).
    #[serde(default)]
    pub energy_balance: Option<EnergyBalance>,
    /// Frames written to the CSV files (set by [`OutputWriter::finish`]).
    pub frames: u64,
    /// Method statistics and anything else (iterations, retries, ...).
    pub extra: BTreeMap<String, serde_json::Value>,
}

impl Summary {
    /// A summary of a run that has not finished (yet): no steps, no failure.
    pub fn started(meta: &RunMeta) -> Summary {
        Summary {
            model: meta.model.clone(),
            method: meta.method.clone(),
            step: meta.step,
            duration: meta.duration,
            steps: 0,
            final_time: 0.0,
            wall_time: 0.0,
            finished: false,
            failure: None,
            interrupted: None,
            max_constraint_violation: None,
            max_violation_joint: None,
            max_energy_drift: None,
            energy_balance: None,
            frames: 0,
            extra: BTreeMap::new(),
        }
    }

    /// Where the run is: finished, failed (`failure`), interrupted (`interrupted`), or
    /// none of these — the summary written at the start, never replaced
    /// ([`RunStatus::Started`]).
    pub fn status(&self) -> RunStatus {
        if self.finished {
            RunStatus::Finished
        } else if self.interrupted.is_some() {
            RunStatus::Interrupted
        } else if self.failure.is_some() {
            RunStatus::Failed
        } else {
            RunStatus::Started
        }
    }

    /// Read a `summary.json`.
    ///
    /// # Errors
    /// On I/O or format errors, with the path.
    pub fn read(path: &Path) -> Result<Summary, OutputError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| OutputError::io(OutputErrorKind::Read, path, e))?;
        serde_json::from_str(&text).map_err(|e| OutputError::Json {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
    }
}

/// What was being done when an I/O error happened.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutputErrorKind {
    /// Creating the output folder.
    CreateDir,
    /// Creating a file.
    Create,
    /// Writing a file.
    Write,
    /// Reading a file.
    Read,
}

impl std::fmt::Display for OutputErrorKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            OutputErrorKind::CreateDir => "cannot create the output folder",
            OutputErrorKind::Create => "cannot create",
            OutputErrorKind::Write => "cannot write",
            OutputErrorKind::Read => "cannot read",
        })
    }
}

/// Errors of the output writers. Cheap to clone (the I/O error is shared).
#[derive(Clone, Debug, thiserror::Error)]
pub enum OutputError {
    /// An I/O error on a path.
    #[error("{kind} {}: {source}", path.display())]
    Io {
        /// What was being done.
        kind: OutputErrorKind,
        /// The file or folder.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: Arc<std::io::Error>,
    },
    /// `summary.json` could not be encoded or decoded.
    #[error("{}: {message}", path.display())]
    Json {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// The writer thread panicked.
    #[error("the output writer thread for {} stopped unexpectedly", dir.display())]
    Thread {
        /// The output folder.
        dir: PathBuf,
    },
    /// A write failed during a run, which then stopped: the error, and where the run was.
    #[error(
        "{source}\n  the run stopped at t = {t} s (step {step}); every file keeps the same frames, up to the last batch written before the error"
    )]
    RunStopped {
        /// The write error.
        #[source]
        source: Box<OutputError>,
        /// Time the run had reached, s.
        t: f64,
        /// Steps the run had taken.
        step: u64,
    },
}

impl OutputError {
    fn io(kind: OutputErrorKind, path: &Path, e: std::io::Error) -> OutputError {
        OutputError::Io {
            kind,
            path: path.to_path_buf(),
            source: Arc::new(e),
        }
    }

    /// The path the error is about.
    pub fn path(&self) -> &Path {
        match self {
            OutputError::Io { path, .. } | OutputError::Json { path, .. } => path,
            OutputError::Thread { dir } => dir,
            OutputError::RunStopped { source, .. } => source.path(),
        }
    }
}

/// One CSV file being written by the writer thread.
struct CsvFile {
    path: PathBuf,
    file: File,
    buf: String,
    /// Bytes known to be on disk (complete lines).
    written: u64,
    /// Tests: simulate a full disk once the file would exceed this size.
    #[cfg(test)]
    limit: Arc<std::sync::atomic::AtomicU64>,
}

impl CsvFile {
    /// Open `path` (written by an earlier part of this run) to continue after its first
    /// `len` bytes, cutting what a killed run wrote after them.
    fn reopen(path: PathBuf, len: u64) -> Result<CsvFile, OutputError> {
        let mut file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(&path)
            .map_err(|e| OutputError::io(OutputErrorKind::Create, &path, e))?;
        let on_disk = file
            .metadata()
            .map_err(|e| OutputError::io(OutputErrorKind::Read, &path, e))?
            .len();
        if on_disk < len {
            return Err(OutputError::io(
                OutputErrorKind::Read,
                &path,
                std::io::Error::other(format!(
                    "it has {on_disk} bytes, fewer than the {len} it had at the checkpoint"
                )),
            ));
        }
        file.set_len(len)
            .and_then(|()| std::io::Seek::seek(&mut file, std::io::SeekFrom::End(0)).map(drop))
            .map_err(|e| OutputError::io(OutputErrorKind::Write, &path, e))?;
        Ok(CsvFile {
            path,
            file,
            buf: String::with_capacity(1 << 16),
            written: len,
            #[cfg(test)]
            limit: Arc::new(std::sync::atomic::AtomicU64::new(u64::MAX)),
        })
    }

    fn create(path: PathBuf, header: &str) -> Result<CsvFile, OutputError> {
        let mut file =
            File::create(&path).map_err(|e| OutputError::io(OutputErrorKind::Create, &path, e))?;
        file.write_all(header.as_bytes())
            .map_err(|e| OutputError::io(OutputErrorKind::Write, &path, e))?;
        Ok(CsvFile {
            path,
            file,
            buf: String::with_capacity(1 << 16),
            written: header.len() as u64,
            #[cfg(test)]
            limit: Arc::new(std::sync::atomic::AtomicU64::new(u64::MAX)),
        })
    }

    #[cfg(not(test))]
    fn write_out(&mut self) -> std::io::Result<()> {
        self.file.write_all(self.buf.as_bytes())
    }

    /// Like the real one, but the "disk" is full at `limit` bytes: the write is cut there
    /// (mid-line, as a real partial write would be) and fails.
    #[cfg(test)]
    fn write_out(&mut self) -> std::io::Result<()> {
        let room = self
            .limit
            .load(Ordering::Relaxed)
            .saturating_sub(self.written) as usize;
        if self.buf.len() > room {
            self.file.write_all(&self.buf.as_bytes()[..room])?;
            return Err(std::io::Error::new(
                std::io::ErrorKind::StorageFull,
                "no space left on device (simulated)",
            ));
        }
        self.file.write_all(self.buf.as_bytes())
    }

    /// Cut the file back to its first `len` bytes (a batch of the other files failed).
    fn rollback(&mut self, len: u64) {
        let _ = self.file.set_len(len);
        self.written = len;
    }

    /// Write the pending lines. On error, truncate back to the last complete batch.
    fn flush(&mut self) -> Result<(), OutputError> {
        if self.buf.is_empty() {
            return Ok(());
        }
        match self.write_out() {
            Ok(()) => {
                self.written += self.buf.len() as u64;
                self.buf.clear();
                Ok(())
            }
            Err(e) => {
                let _ = self.file.set_len(self.written);
                self.buf.clear();
                Err(OutputError::io(OutputErrorKind::Write, &self.path, e))
            }
        }
    }
}

/// Flush a file's batch early once it exceeds this many bytes.
const BATCH_BYTES: usize = 1 << 20;
/// Memory budget of the frame pool.
const POOL_BYTES: usize = 64 << 20;
/// Most frames in the pool.
const POOL_MAX: usize = 32;

/// Statistics the writer thread gathers from the frames it writes.
#[derive(Clone, Debug, Default)]
struct Stats {
    frames: u64,
    e0: Option<f64>,
    k_max: f64,
    v_min: f64,
    v_max: f64,
    w_max: f64,
    max_drift: f64,
    max_violation: f64,
    max_violation_joint: Option<usize>,
}

impl Stats {
    fn persist(&mut self, v: &mut dyn StateVisitor) {
        persist::u64(v, "out.frames", &mut self.frames);
        let mut e0 = [
            f64::from(u8::from(self.e0.is_some())),
            self.e0.unwrap_or(0.0),
        ];
        v.f64s("out.e0", &mut e0);
        self.e0 = (e0[0] != 0.0).then_some(e0[1]);
        persist::f64_fields(
            v,
            "out.maxima",
            [
                &mut self.k_max,
                &mut self.v_min,
                &mut self.v_max,
                &mut self.w_max,
                &mut self.max_drift,
                &mut self.max_violation,
            ],
        );
        let mut j = self.max_violation_joint.map_or(u64::MAX, |j| j as u64);
        persist::u64(v, "out.max_violation_joint", &mut j);
        self.max_violation_joint = (j != u64::MAX).then_some(j as usize);
    }

    /// Update with a frame; returns its drift.
    fn add(&mut self, f: &Frame) -> f64 {
        let e = f.kinetic + f.potential - f.work;
        let e0 = *self.e0.get_or_insert(e);
        if self.frames == 0 {
            self.v_min = f.potential;
            self.v_max = f.potential;
        }
        self.frames += 1;
        self.k_max = self.k_max.max(f.kinetic);
        self.v_min = self.v_min.min(f.potential);
        self.v_max = self.v_max.max(f.potential);
        self.w_max = self.w_max.max(f.work.abs());
        let scale = e0
            .abs()
            .max(self.k_max + (self.v_max - self.v_min))
            .max(self.w_max)
            .max(1e-300);
        let drift = (e - e0) / scale;
        // Maxima keep the first NaN they see (f64::max would ignore it).
        if !self.max_drift.is_nan() && (drift.is_nan() || drift.abs() > self.max_drift) {
            self.max_drift = drift.abs();
        }
        for (j, &v) in f.violation.iter().enumerate() {
            if self.max_violation.is_nan() {
                break;
            }
            if self.max_violation_joint.is_none() || v.is_nan() || v > self.max_violation {
                self.max_violation = v;
                self.max_violation_joint = Some(j);
            }
        }
        drift
    }
}

/// Where the writers are after the frames written so far: what a checkpoint records so that
/// a restarted run continues the same files ([`OutputWriter::sync`], [`OutputWriter::resume`]).
#[derive(Clone, Debug, Default)]
pub struct OutputPosition {
    /// Bytes of `bodies.csv`, `energy.csv`, `constraints.csv`, `beams.csv`,
    /// `mesh_energy.csv` (0 where the file is not written).
    lens: [u64; 5],
    /// Frames of the beams' and the meshes' series.
    vtk_frames: u64,
    vtu_frames: u64,
    /// Frames of `results.exo`.
    exo_frames: u64,
    /// What the writer measured over the frames (the summary's maxima).
    stats: Stats,
}

impl OutputPosition {
    /// Save or load it.
    pub fn persist(&mut self, v: &mut dyn StateVisitor) {
        v.u64s("out.lens", &mut self.lens);
        persist::u64(v, "out.vtk_frames", &mut self.vtk_frames);
        persist::u64(v, "out.vtu_frames", &mut self.vtu_frames);
        persist::u64(v, "out.exo_frames", &mut self.exo_frames);
        self.stats.persist(v);
    }

    /// Frames written.
    pub fn frames(&self) -> u64 {
        self.stats.frames
    }
}

/// What the simulation thread sends the writer thread. (A frame is moved, not boxed: the
/// pool recycles its buffers, and a box would allocate per frame.)
#[allow(clippy::large_enum_variant)]
enum Msg {
    /// A frame to write.
    Frame(Frame),
    /// Write everything queued, then answer with the position.
    Sync,
}

/// The writer thread's state.
struct Worker {
    layout: Layout,
    bodies: Option<CsvFile>,
    energy: Option<CsvFile>,
    constraints: Option<CsvFile>,
    beams: Option<CsvFile>,
    vtk: Option<vtk::BeamSeries>,
    mesh_energy: Option<CsvFile>,
    vtu: Option<vtu::MeshSeries>,
    exo: Option<exodus::ExodusSeries>,
    stats: Stats,
    failed: Arc<AtomicBool>,
    error: Arc<Mutex<Option<OutputError>>>,
}

impl Worker {
    fn files(&mut self) -> impl Iterator<Item = &mut CsvFile> {
        [
            &mut self.bodies,
            &mut self.energy,
            &mut self.constraints,
            &mut self.beams,
            &mut self.mesh_energy,
        ]
        .into_iter()
        .flatten()
    }

    fn fail(&mut self, e: OutputError) {
        let mut slot = self.error.lock().unwrap_or_else(|p| p.into_inner());
        if slot.is_none() {
            *slot = Some(e);
        }
        self.failed.store(true, Ordering::Release);
    }

    fn write(&mut self, f: &Frame) {
        let drift = self.stats.add(f);
        if self.failed.load(Ordering::Acquire) {
            return;
        }
        if let Some(c) = &mut self.bodies {
            csv::bodies_row(&mut c.buf, f);
        }
        if let Some(c) = &mut self.energy {
            csv::energy_row(&mut c.buf, f, drift);
        }
        if let Some(c) = &mut self.constraints {
            csv::constraints_row(&mut c.buf, &self.layout, f);
        }
        if let Some(c) = &mut self.beams {
            csv::beams_rows(&mut c.buf, &self.layout, f);
        }
        if let Some(c) = &mut self.mesh_energy {
            csv::mesh_energy_row(&mut c.buf, f);
        }
        if let Some(v) = &mut self.vtk {
            if let Err(e) = v.write_frame(&self.layout, f) {
                self.fail(e);
                return;
            }
        }
        if let Some(v) = &mut self.vtu {
            if let Err(e) = v.write_frame(&self.layout, f) {
                self.fail(e);
                return;
            }
        }
        if let Some(x) = &mut self.exo {
            if let Err(e) = x.write_frame(f) {
                self.fail(e);
                return;
            }
        }
        let big = self.files().any(|c| c.buf.len() >= BATCH_BYTES);
        if big {
            self.flush();
        }
    }

    fn flush(&mut self) {
        if self.failed.load(Ordering::Acquire) {
            return;
        }
        let mut err = None;
        // Each file's length before this batch: when one file's write fails, the files
        // written before it in this batch are cut back too, so that every file ends at the
        // same frame.
        let mut before = [0u64; 5];
        for (b, c) in before.iter_mut().zip(self.files()) {
            *b = c.written;
        }
        let mut done = 0;
        for c in self.files() {
            if let Err(e) = c.flush() {
                err = Some(e);
                break;
            }
            done += 1;
        }
        if err.is_some() {
            for (b, c) in before.iter().zip(self.files()).take(done) {
                c.rollback(*b);
            }
        }
        if err.is_none() {
            if let Some(v) = &self.vtk {
                err = v.write_index().err();
            }
        }
        if err.is_none() {
            if let Some(v) = &self.vtu {
                err = v.write_index().err();
            }
        }
        if err.is_none() {
            if let Some(x) = &mut self.exo {
                err = x.write_index().err();
            }
        }
        if let Some(e) = err {
            self.fail(e);
        }
    }

    fn position(&self) -> OutputPosition {
        let len = |c: &Option<CsvFile>| c.as_ref().map_or(0, |c| c.written);
        OutputPosition {
            lens: [
                len(&self.bodies),
                len(&self.energy),
                len(&self.constraints),
                len(&self.beams),
                len(&self.mesh_energy),
            ],
            vtk_frames: self.vtk.as_ref().map_or(0, |v| v.frames()),
            vtu_frames: self.vtu.as_ref().map_or(0, |v| v.frames()),
            exo_frames: self.exo.as_ref().map_or(0, |x| x.frames()),
            stats: self.stats.clone(),
        }
    }

    fn run(
        mut self,
        rx: Receiver<Msg>,
        pool: FrameReturn,
        synced: SyncSender<OutputPosition>,
    ) -> Stats {
        let handle = |w: &mut Worker, m: Msg| match m {
            Msg::Frame(f) => {
                w.write(&f);
                pool.give(f);
            }
            Msg::Sync => {
                w.flush();
                let _ = synced.send(w.position());
            }
        };
        while let Ok(first) = rx.recv() {
            handle(&mut self, first);
            while let Ok(m) = rx.try_recv() {
                handle(&mut self, m);
            }
            self.flush();
        }
        self.flush();
        self.stats
    }
}

/// Streams frames to CSV files on a background thread and writes `summary.json`.
/// See the module doc.
pub struct OutputWriter {
    dir: PathBuf,
    meta: RunMeta,
    joint_names: Vec<String>,
    layout_for_fallback: Layout,
    tx: Option<SyncSender<Msg>>,
    /// The writer thread's answers to [`Msg::Sync`].
    synced: Receiver<OutputPosition>,
    pool: FramePool,
    failed: Arc<AtomicBool>,
    error: Arc<Mutex<Option<OutputError>>>,
    handle: Option<JoinHandle<Stats>>,
    pool_size: usize,
    /// How often and how long [`OutputWriter::frame`] waited for the writer.
    waits: WriterWaits,
    #[cfg(test)]
    limits: Vec<(String, Arc<std::sync::atomic::AtomicU64>)>,
}

/// How often the simulation thread waited for a frame buffer because the writer had fallen a
/// whole pool of frames behind, and for how long in all.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WriterWaits {
    /// Frames taken by [`OutputWriter::frame`].
    pub frames: u64,
    /// Frames for which [`OutputWriter::frame`] had to wait.
    pub count: u64,
    /// Wall time spent waiting, s.
    pub seconds: f64,
}

impl std::fmt::Debug for OutputWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("OutputWriter")
            .field("dir", &self.dir)
            .field("pool_size", &self.pool_size)
            .finish()
    }
}

impl OutputWriter {
    /// Create the folder (and parents), the CSV files the spec asks for with their
    /// headers, an initial `summary.json` (`finished: false`), the frame pool, and start
    /// the writer thread.
    ///
    /// # Errors
    /// [`OutputError::Io`] with the path when the folder or a file cannot be created or
    /// written.
    pub fn create(
        dir: &Path,
        layout: &Layout,
        spec: &OutputSpec,
        meta: RunMeta,
    ) -> Result<OutputWriter, OutputError> {
        Self::open(dir, layout, spec, meta, None)
    }

    /// Continue the files of a run from the position a checkpoint recorded
    /// ([`OutputWriter::sync`]): each file is cut back to its length then (what a killed
    /// run wrote after the checkpoint goes), the series' indexes to their frames then, and
    /// the writer's statistics are the checkpoint's. `summary.json` says `"started"` again
    /// until the run ends.
    ///
    /// # Errors
    /// [`OutputError::Io`] with the path when a file is missing, shorter than at the
    /// checkpoint, or cannot be written.
    pub fn resume(
        dir: &Path,
        layout: &Layout,
        spec: &OutputSpec,
        meta: RunMeta,
        at: &OutputPosition,
    ) -> Result<OutputWriter, OutputError> {
        Self::open(dir, layout, spec, meta, Some(at))
    }

    fn open(
        dir: &Path,
        layout: &Layout,
        spec: &OutputSpec,
        meta: RunMeta,
        at: Option<&OutputPosition>,
    ) -> Result<OutputWriter, OutputError> {
        std::fs::create_dir_all(dir)
            .map_err(|e| OutputError::io(OutputErrorKind::CreateDir, dir, e))?;
        let csv_file = |want: bool, name: &str, k: usize, header: &dyn Fn() -> String| {
            want.then(|| match at {
                Some(p) => CsvFile::reopen(dir.join(name), p.lens[k]),
                None => CsvFile::create(dir.join(name), &header()),
            })
            .transpose()
        };
        let bodies = csv_file(spec.bodies, "bodies.csv", 0, &|| bodies_header(layout))?;
        let energy = csv_file(spec.energy, "energy.csv", 1, &energy_header)?;
        let constraints = csv_file(spec.constraints, "constraints.csv", 2, &|| {
            constraints_header(layout)
        })?;
        let exodus = spec.format == OutputFormat::Exodus;
        let series = spec.format == OutputFormat::Vtk;
        let beams = csv_file(
            !layout.beams.is_empty() && !exodus,
            "beams.csv",
            3,
            &beams_header,
        )?;
        let vtk = (!layout.beams.is_empty() && series)
            .then(|| match at {
                Some(p) => vtk::BeamSeries::resume(dir, p.vtk_frames),
                None => vtk::BeamSeries::create(dir),
            })
            .transpose()?;
        let mesh_energy = csv_file(
            !layout.meshes.is_empty(),
            "mesh_energy.csv",
            4,
            &csv::mesh_energy_header,
        )?;
        let vtu = (!layout.meshes.is_empty() && series)
            .then(|| match at {
                Some(p) => vtu::MeshSeries::resume(dir, layout, p.vtu_frames),
                None => vtu::MeshSeries::create(dir, layout),
            })
            .transpose()?;
        let exo = if exodus {
            match at {
                Some(p) => exodus::ExodusSeries::resume(
                    dir,
                    layout,
                    &meta.model,
                    spec.partitions,
                    p.exo_frames,
                )?,
                None => exodus::ExodusSeries::create(dir, layout, &meta.model, spec.partitions)?,
            }
        } else {
            None
        };
        write_summary(dir, &Summary::started(&meta))?;

        let pool_size = (POOL_BYTES / Frame::bytes(layout)).clamp(2, POOL_MAX);
        // The queue holds every frame there is, so `submit` never waits (a waiting send
        // would allocate its wait context); `frame` waits on the pool's futex instead.
        // (one more for a sync request)
        let (tx, rx) = sync_channel::<Msg>(pool_size + 1);
        let (synced_tx, synced) = sync_channel::<OutputPosition>(1);
        let (pool, pool_return) =
            FramePool::new((0..pool_size).map(|_| Frame::new(layout)).collect());
        let failed = Arc::new(AtomicBool::new(false));
        let error = Arc::new(Mutex::new(None));
        #[cfg(test)]
        let limits = [&bodies, &energy, &constraints, &beams, &mesh_energy]
            .into_iter()
            .flatten()
            .map(|c| {
                let name = c
                    .path
                    .file_name()
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_default();
                (name, c.limit.clone())
            })
            .collect();
        let worker = Worker {
            layout: layout.clone(),
            bodies,
            energy,
            constraints,
            beams,
            vtk,
            mesh_energy,
            vtu,
            exo,
            stats: at.map_or_else(Stats::default, |p| p.stats.clone()),
            failed: failed.clone(),
            error: error.clone(),
        };
        let handle = std::thread::Builder::new()
            .name("mbdc-output".into())
            .spawn(move || worker.run(rx, pool_return, synced_tx))
            .map_err(|e| OutputError::io(OutputErrorKind::Create, dir, e))?;
        Ok(OutputWriter {
            dir: dir.to_path_buf(),
            meta,
            joint_names: layout.joints.iter().map(|j| j.name.clone()).collect(),
            layout_for_fallback: layout.clone(),
            tx: Some(tx),
            synced,
            pool,
            failed,
            error,
            handle: Some(handle),
            pool_size,
            waits: WriterWaits::default(),
            #[cfg(test)]
            limits,
        })
    }

    /// Tests: make the file `name` fail with "disk full" once it would exceed `bytes`.
    #[cfg(test)]
    fn limit_file_bytes_for_test(&self, name: &str, bytes: u64) {
        let (_, l) = self
            .limits
            .iter()
            .find(|(n, _)| n == name)
            .expect("file is written");
        l.store(bytes, Ordering::Relaxed);
    }

    /// The output folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Number of frame buffers in the pool.
    pub fn pool_size(&self) -> usize {
        self.pool_size
    }

    /// A frame buffer to fill (its previous content is stale: overwrite every field).
    /// Blocks while every buffer is queued for writing (holding more than
    /// [`OutputWriter::pool_size`] frames at once would therefore wait forever).
    /// Allocation-free, on any thread. If the writer thread has died, a fresh frame is
    /// allocated so the run can continue to its end and report (the next `submit`
    /// returns the error). A wait is counted in [`OutputWriter::waits`].
    pub fn frame(&mut self) -> Frame {
        match self.pool.take() {
            Some((f, waited)) => {
                self.waits.frames += 1;
                if let Some(d) = waited {
                    self.waits.count += 1;
                    self.waits.seconds += d.as_secs_f64();
                }
                f
            }
            None => Frame::new(&self.layout_for_fallback),
        }
    }

    /// How often and how long [`OutputWriter::frame`] has waited for the writer so far: the
    /// step goes on without waiting unless the writer falls a whole pool of frames behind.
    pub fn waits(&self) -> WriterWaits {
        self.waits
    }

    /// Queue a filled frame for writing. Allocation-free.
    ///
    /// # Errors
    /// The first write error of the writer thread (with the path). After an error
    /// nothing more is written; the frames already on disk stay valid.
    pub fn submit(&mut self, frame: Frame) -> Result<(), OutputError> {
        if self.failed.load(Ordering::Acquire) {
            return Err(self.current_error());
        }
        match &self.tx {
            Some(tx) => tx.send(Msg::Frame(frame)).map_err(|_| self.current_error()),
            None => Err(OutputError::Thread {
                dir: self.dir.clone(),
            }),
        }
    }

    /// Wait until every frame submitted so far is written and flushed, and return where
    /// the files are (for a checkpoint).
    ///
    /// # Errors
    /// The first write error of the writer thread.
    pub fn sync(&mut self) -> Result<OutputPosition, OutputError> {
        if self.failed.load(Ordering::Acquire) {
            return Err(self.current_error());
        }
        let sent = match &self.tx {
            Some(tx) => tx.send(Msg::Sync).is_ok(),
            None => false,
        };
        let pos = if sent { self.synced.recv().ok() } else { None };
        if self.failed.load(Ordering::Acquire) {
            return Err(self.current_error());
        }
        pos.ok_or_else(|| self.current_error())
    }

    fn current_error(&self) -> OutputError {
        let slot = self.error.lock().unwrap_or_else(|p| p.into_inner());
        slot.clone().unwrap_or_else(|| OutputError::Thread {
            dir: self.dir.clone(),
        })
    }

    /// Stop the writer thread after it has written every queued frame, then write
    /// `summary.json` from `summary`, filling in what the writer measured when the
    /// summary leaves it open (`max_constraint_violation`, `max_violation_joint`,
    /// `max_energy_drift`) and the number of frames written. Also called after a failed
    /// run, with the failure filled in. Returns the summary as written.
    ///
    /// # Errors
    /// The first write error of the writer thread (the summary is still written if
    /// possible), or an error writing `summary.json`.
    pub fn finish(mut self, summary: &Summary) -> Result<Summary, OutputError> {
        let stats = self.join();
        let mut s = summary.clone();
        if let Some(st) = &stats {
            s.frames = st.frames;
            if s.max_constraint_violation.is_none() && st.max_violation_joint.is_some() {
                s.max_constraint_violation = Some(st.max_violation);
                s.max_violation_joint = st.max_violation_joint.map(|j| self.joint_names[j].clone());
            }
            if s.max_energy_drift.is_none() && st.frames > 0 {
                s.max_energy_drift = Some(st.max_drift);
            }
        }
        let written = write_summary(&self.dir, &s);
        if stats.is_none() {
            return Err(OutputError::Thread {
                dir: self.dir.clone(),
            });
        }
        if self.failed.load(Ordering::Acquire) {
            return Err(self.current_error());
        }
        written.map(|()| s)
    }

    /// Whether a write has failed (the next [`OutputWriter::submit`] returns the error): a
    /// run stops then, since nothing more it computes can be kept.
    pub fn has_failed(&self) -> bool {
        self.failed.load(Ordering::Acquire)
    }

    /// The run description given at creation.
    pub fn meta(&self) -> &RunMeta {
        &self.meta
    }

    /// Close the queue and wait for the thread; `None` if it panicked.
    fn join(&mut self) -> Option<Stats> {
        self.tx = None;
        self.handle.take().and_then(|h| h.join().ok())
    }
}

impl Drop for OutputWriter {
    /// Dropping without [`OutputWriter::finish`] (a run that was stopped): every queued
    /// frame is still written and flushed; `summary.json` keeps `finished: false`.
    fn drop(&mut self) {
        let _ = self.join();
    }
}

/// `summary.json` as written: the derived status first, then the summary's fields.
#[derive(Serialize)]
struct Written<'a> {
    status: RunStatus,
    #[serde(flatten)]
    summary: &'a Summary,
}

/// Write `summary.json` atomically (temporary file, then rename).
fn write_summary(dir: &Path, s: &Summary) -> Result<(), OutputError> {
    let path = dir.join("summary.json");
    let written = Written {
        status: s.status(),
        summary: s,
    };
    let text = serde_json::to_string_pretty(&written).map_err(|e| OutputError::Json {
        path: path.clone(),
        message: e.to_string(),
    })?;
    replace_file::replace_file(&path, format!("{text}\n").as_bytes())
}

#[cfg(test)]
mod tests;
