//! The whole run as one Exodus II file, `results.exo` (netCDF-3 64-bit offset, see
//! `netcdf3.rs`), written by `p` partitions at computed offsets, with a manifest
//! `results.exo.manifest.json` saying which partition wrote which slice. ParaView and VisIt
//! open it natively; `docs/output.md` describes the layout.
//!
//! - **Nodes**: every mesh node (at its reference position), then every body (beam nodes
//!   and rigid bodies, at their first frame's position). Nodal variables `displacement_x/y/z`
//!   (mesh: the mesh's displacement; bodies: position − first position), `velocity_x/y/z`,
//!   and with bodies `quaternion_w/x/y/z` (body → world) and `angular_velocity_x/y/z` (body
//!   components), identity and zero at mesh nodes.
//! - **Element blocks**: one per mesh (BAR2, TRI3, QUAD4, TETRA4, HEX8) with `stress_*`,
//!   `strain_*` (Voigt order xx yy zz yz xz xy), `von_mises` and, when a mesh is plastic,
//!   `plastic_strain_*` and `equivalent_plastic_strain`; one BAR2 block per beam with `s`
//!   and the section quantities of `beams.csv`; one SPHERE block holding the rigid bodies
//!   (no element variables). The truth table `elem_var_tab` says which block has which.
//! - **Global variables**: `kinetic`, `potential`, `work`, `total`; the time is `time_whole`.
//!
//! Each record variable's values are split into `p` contiguous slices; partition `k` writes
//! slice `k` of every variable (partition 0 also the time and the globals) with positional
//! writes, on its own thread, into reused buffers. Once every partition has written its
//! slices, `numrecs` in the header is raised to cover the frame: a reader (or a process
//! killed at any moment) sees only complete frames.

use std::fs::File;
use std::path::{Path, PathBuf};

pub use super::exodus_manifest::{Manifest, ManifestSlice, MANIFEST_VERSION};
pub use super::exodus_read::{Block, ExodusFile};

use super::netcdf3::{read_at, write_at, Attr, AttrValue, NcType, Schema, NUMRECS_OFFSET};
use super::vtu::von_mises;
use super::{Frame, OutputError, OutputErrorKind, BEAM_COLUMNS};
use crate::contract::scene::ElementKind;
use crate::contract::system::Layout;

/// The file's name in the output folder.
pub const EXODUS_FILE: &str = "results.exo";
/// The manifest's name in the output folder.
pub const MANIFEST_FILE: &str = "results.exo.manifest.json";
/// Longest name stored (Exodus `maximum_name_length`).
const NAME_LEN: u64 = 32;

/// The nodal variables, in file order (the last seven only with bodies).
pub const NODAL_VARIABLES: [&str; 13] = [
    "displacement_x",
    "displacement_y",
    "displacement_z",
    "velocity_x",
    "velocity_y",
    "velocity_z",
    "quaternion_w",
    "quaternion_x",
    "quaternion_y",
    "quaternion_z",
    "angular_velocity_x",
    "angular_velocity_y",
    "angular_velocity_z",
];

/// The meshes' element variables, in file order (the last seven only with plasticity).
pub const MESH_VARIABLES: [&str; 20] = [
    "stress_xx",
    "stress_yy",
    "stress_zz",
    "stress_yz",
    "stress_xz",
    "stress_xy",
    "strain_xx",
    "strain_yy",
    "strain_zz",
    "strain_yz",
    "strain_xz",
    "strain_xy",
    "von_mises",
    "plastic_strain_xx",
    "plastic_strain_yy",
    "plastic_strain_zz",
    "plastic_strain_yz",
    "plastic_strain_xz",
    "plastic_strain_xy",
    "equivalent_plastic_strain",
];

/// The global variables, in file order.
pub const GLOBAL_VARIABLES: [&str; 4] = ["kinetic", "potential", "work", "total"];

/// The Exodus name of an element kind.
pub fn elem_type(kind: ElementKind) -> &'static str {
    match kind {
        ElementKind::Bar2 => "BAR2",
        ElementKind::Tri3PlaneStress | ElementKind::Tri3PlaneStrain => "TRI3",
        ElementKind::Quad4PlaneStress | ElementKind::Quad4PlaneStrain => "QUAD4",
        ElementKind::Tet4 => "TETRA4",
        ElementKind::Hex8 => "HEX8",
    }
}

/// Where a record variable's values come from.
#[derive(Clone, Copy, Debug)]
enum Source {
    Time,
    Globals,
    /// Nodal variable (index into [`NODAL_VARIABLES`]).
    Nodal(usize),
    /// Mesh element variable (index into [`MESH_VARIABLES`]) of the elements from `first`.
    Mesh(usize, usize),
    /// Beam column (0: `s`, then [`BEAM_COLUMNS`]) of the beam elements from `first`.
    Beam(usize, usize),
}

/// A record variable.
#[derive(Clone, Debug)]
struct Column {
    var: usize,
    len: u64,
    source: Source,
}

/// One slice a partition writes: values `start..start + count` of a column.
#[derive(Clone, Copy, Debug)]
struct Slice {
    column: usize,
    start: u64,
    count: u64,
}

/// Open an Exodus II file for reading (see [`ExodusFile`]).
///
/// # Errors
/// As [`ExodusFile::open`].
pub fn read(path: &Path) -> Result<ExodusFile, OutputError> {
    ExodusFile::open(path)
}

/// The size of the file a run of `layout` writes, as (bytes before the first frame, bytes
/// per frame); `None` when it writes none (no node). The model's name in the header is left
/// out (a few bytes).
pub(crate) fn file_layout(layout: &Layout) -> Option<(u64, u64)> {
    let plan = Plan::new(layout, "")?;
    Some((plan.schema.records_begin, plan.schema.record_size))
}

/// An element block being planned: name, Exodus type, nodes per element, 1-based
/// connectivity, where its element variables come from (`None`: it has none).
type BlockDef = (String, &'static str, usize, Vec<i64>, Option<Source>);

/// The file's structure for a layout: the header, the record variables and what fills them.
struct Plan {
    schema: Schema,
    columns: Vec<Column>,
    /// Fixed variables and their big-endian bytes (body coordinates filled at frame 0).
    fixed: Vec<(usize, Vec<u8>)>,
    coord: [usize; 3],
    mesh_nodes: usize,
    bodies: usize,
}

fn text_rows(names: &[String], width: u64) -> Vec<u8> {
    let mut b = Vec::with_capacity(names.len() * width as usize);
    for n in names {
        let bytes = n.as_bytes();
        let k = bytes.len().min(width as usize - 1);
        b.extend_from_slice(&bytes[..k]);
        b.resize(b.len() + width as usize - k, 0);
    }
    b
}

fn ints(v: impl IntoIterator<Item = i64>) -> Vec<u8> {
    v.into_iter()
        .flat_map(|x| (x.clamp(i32::MIN as i64, i32::MAX as i64) as i32).to_be_bytes())
        .collect()
}

fn doubles(v: impl IntoIterator<Item = f64>) -> Vec<u8> {
    v.into_iter().flat_map(f64::to_be_bytes).collect()
}

impl Plan {
    /// `None` when the layout has nothing to put in the file (no node).
    fn new(layout: &Layout, title: &str) -> Option<Plan> {
        let ml = &layout.meshes;
        let mesh_nodes = ml.nodes();
        let bodies = layout.bodies();
        let nodes = mesh_nodes + bodies;
        if nodes == 0 {
            return None;
        }
        let mut beam_node = vec![false; bodies];
        for e in &layout.beams.elements {
            beam_node[e.nodes[0]] = true;
            beam_node[e.nodes[1]] = true;
        }
        let rigid: Vec<usize> = (0..bodies).filter(|&b| !beam_node[b]).collect();
        // Blocks: (name, type, nodes per element, 1-based connectivity, element source).
        let mut blocks: Vec<BlockDef> = Vec::new();
        let mut first = 0;
        for b in &ml.blocks {
            let conn = b.conn.iter().map(|&n| i64::from(n) + 1).collect();
            blocks.push((
                b.name.clone(),
                elem_type(b.kind),
                b.kind.nodes(),
                conn,
                Some(Source::Mesh(0, first)),
            ));
            first += b.elements();
        }
        for beam in &layout.beams.beams {
            let els =
                &layout.beams.elements[beam.first_element..beam.first_element + beam.elements];
            let conn = els
                .iter()
                .flat_map(|e| e.nodes.map(|n| (mesh_nodes + n) as i64 + 1))
                .collect();
            blocks.push((
                beam.name.clone(),
                "BAR2",
                2,
                conn,
                Some(Source::Beam(0, beam.first_element)),
            ));
        }
        if !rigid.is_empty() {
            let conn = rigid.iter().map(|&b| (mesh_nodes + b) as i64 + 1).collect();
            blocks.push(("bodies".into(), "SPHERE", 1, conn, None));
        }
        let nodal = if bodies > 0 { 13 } else { 6 };
        let mesh_vars = if ml.is_empty() {
            0
        } else if ml.is_plastic() {
            20
        } else {
            13
        };
        let beam_vars = if layout.beams.is_empty() { 0 } else { 13 };
        let mut elem_names: Vec<String> = MESH_VARIABLES[..mesh_vars]
            .iter()
            .map(|s| s.to_string())
            .collect();
        if beam_vars > 0 {
            elem_names.push("s".into());
            elem_names.extend(BEAM_COLUMNS.iter().map(|s| s.to_string()));
        }

        let mut s = Schema::default();
        let _len_string = s.dim("len_string", 33);
        let _len_line = s.dim("len_line", 81);
        let _four = s.dim("four", 4);
        let len_name = s.dim("len_name", NAME_LEN + 1);
        let time = s.dim("time_step", 0);
        let num_dim = s.dim("num_dim", 3);
        let num_nodes = s.dim("num_nodes", nodes as u64);
        let total: usize = blocks.iter().map(|b| b.3.len() / b.2).sum();
        let nblk = blocks.len();
        let num_el_blk = (nblk > 0).then(|| {
            s.dim("num_elem", total as u64);
            s.dim("num_el_blk", nblk as u64)
        });
        let blk_dims: Vec<(usize, usize)> = blocks
            .iter()
            .enumerate()
            .map(|(k, b)| {
                (
                    s.dim(&format!("num_el_in_blk{}", k + 1), (b.3.len() / b.2) as u64),
                    s.dim(&format!("num_nod_per_el{}", k + 1), b.2 as u64),
                )
            })
            .collect();
        let num_glo_var = s.dim("num_glo_var", GLOBAL_VARIABLES.len() as u64);
        let num_nod_var = s.dim("num_nod_var", nodal as u64);
        let num_elem_var =
            (!elem_names.is_empty()).then(|| s.dim("num_elem_var", elem_names.len() as u64));

        s.attr("api_version", AttrValue::Float(vec![8.25]));
        s.attr("version", AttrValue::Float(vec![8.25]));
        s.attr("floating_point_word_size", AttrValue::Int(vec![8]));
        s.attr("file_size", AttrValue::Int(vec![1]));
        s.attr("maximum_name_length", AttrValue::Int(vec![NAME_LEN as i32]));
        s.attr("int64_status", AttrValue::Int(vec![0]));
        s.attr("title", AttrValue::Text(title.chars().take(80).collect()));

        let mut fixed = Vec::new();
        if let Some(nb) = num_el_blk {
            let v = s.var("eb_status", NcType::Int, &[nb]);
            fixed.push((v, ints((0..nblk).map(|_| 1))));
            let v = s.var("eb_prop1", NcType::Int, &[nb]);
            s.vars[v].attrs.push(Attr {
                name: "name".into(),
                value: AttrValue::Text("ID".into()),
            });
            fixed.push((v, ints((1..=nblk).map(|k| k as i64))));
            let v = s.var("eb_names", NcType::Char, &[nb, len_name]);
            let names: Vec<String> = blocks.iter().map(|b| b.0.clone()).collect();
            fixed.push((v, text_rows(&names, NAME_LEN + 1)));
        }
        let v = s.var("coor_names", NcType::Char, &[num_dim, len_name]);
        fixed.push((
            v,
            text_rows(&["X".into(), "Y".into(), "Z".into()], NAME_LEN + 1),
        ));
        let mut coord = [0; 3];
        for (c, name) in ["coordx", "coordy", "coordz"].iter().enumerate() {
            coord[c] = s.var(name, NcType::Double, &[num_nodes]);
            let x = ml
                .x0
                .iter()
                .map(|x| x[c])
                .chain(std::iter::repeat_n(0.0, bodies));
            fixed.push((coord[c], doubles(x)));
        }
        for (k, b) in blocks.iter().enumerate() {
            let v = s.var(
                &format!("connect{}", k + 1),
                NcType::Int,
                &[blk_dims[k].0, blk_dims[k].1],
            );
            s.vars[v].attrs.push(Attr {
                name: "elem_type".into(),
                value: AttrValue::Text(b.1.into()),
            });
            fixed.push((v, ints(b.3.iter().copied())));
        }
        let v = s.var("name_glo_var", NcType::Char, &[num_glo_var, len_name]);
        let g: Vec<String> = GLOBAL_VARIABLES.iter().map(|s| s.to_string()).collect();
        fixed.push((v, text_rows(&g, NAME_LEN + 1)));
        let v = s.var("name_nod_var", NcType::Char, &[num_nod_var, len_name]);
        let n: Vec<String> = NODAL_VARIABLES[..nodal]
            .iter()
            .map(|s| s.to_string())
            .collect();
        fixed.push((v, text_rows(&n, NAME_LEN + 1)));
        // Which element variable each block has (a mesh block the mesh's, a beam block the
        // beam's, the bodies' block none).
        let has = |k: usize, i: usize| match blocks[k].4 {
            Some(Source::Mesh(..)) => i < mesh_vars,
            Some(Source::Beam(..)) => i >= mesh_vars,
            _ => false,
        };
        if let (Some(nev), Some(nb)) = (num_elem_var, num_el_blk) {
            let v = s.var("name_elem_var", NcType::Char, &[nev, len_name]);
            fixed.push((v, text_rows(&elem_names, NAME_LEN + 1)));
            let v = s.var("elem_var_tab", NcType::Int, &[nb, nev]);
            let tab = (0..nblk).flat_map(|k| (0..elem_names.len()).map(move |i| (k, i)));
            fixed.push((v, ints(tab.map(|(k, i)| i64::from(has(k, i))))));
        }

        let mut columns = Vec::new();
        let v = s.var("time_whole", NcType::Double, &[time]);
        columns.push(Column {
            var: v,
            len: 1,
            source: Source::Time,
        });
        let v = s.var("vals_glo_var", NcType::Double, &[time, num_glo_var]);
        columns.push(Column {
            var: v,
            len: GLOBAL_VARIABLES.len() as u64,
            source: Source::Globals,
        });
        for i in 0..nodal {
            let v = s.var(
                &format!("vals_nod_var{}", i + 1),
                NcType::Double,
                &[time, num_nodes],
            );
            columns.push(Column {
                var: v,
                len: nodes as u64,
                source: Source::Nodal(i),
            });
        }
        for i in 0..elem_names.len() {
            for (k, b) in blocks.iter().enumerate() {
                if !has(k, i) {
                    continue;
                }
                let v = s.var(
                    &format!("vals_elem_var{}eb{}", i + 1, k + 1),
                    NcType::Double,
                    &[time, blk_dims[k].0],
                );
                let source = match b.4 {
                    Some(Source::Mesh(_, first)) => Source::Mesh(i, first),
                    Some(Source::Beam(_, first)) => Source::Beam(i - mesh_vars, first),
                    _ => continue,
                };
                columns.push(Column {
                    var: v,
                    len: (b.3.len() / b.2) as u64,
                    source,
                });
            }
        }
        s.finish();
        Some(Plan {
            schema: s,
            columns,
            fixed,
            coord,
            mesh_nodes,
            bodies,
        })
    }
}

/// The slices of partition `k` of `p`: slice `k` of every column (partition 0 also the
/// one-value time column, and the globals).
fn partition_slices(columns: &[Column], k: usize, p: usize) -> Vec<Slice> {
    let mut out = Vec::new();
    for (c, col) in columns.iter().enumerate() {
        if matches!(col.source, Source::Time | Source::Globals) {
            if k == 0 {
                out.push(Slice {
                    column: c,
                    start: 0,
                    count: col.len,
                });
            }
            continue;
        }
        let (a, b) = (
            col.len * k as u64 / p as u64,
            col.len * (k as u64 + 1) / p as u64,
        );
        if b > a {
            out.push(Slice {
                column: c,
                start: a,
                count: b - a,
            });
        }
    }
    out
}

/// Append the big-endian values `start..start + count` of a column for frame `f`.
fn encode(
    buf: &mut Vec<u8>,
    source: Source,
    start: usize,
    count: usize,
    f: &Frame,
    mesh_nodes: usize,
    x_ref: &[[f64; 3]],
) {
    let mut put = |x: f64| buf.extend_from_slice(&x.to_be_bytes());
    match source {
        Source::Time => put(f.t),
        Source::Globals => {
            put(f.kinetic);
            put(f.potential);
            put(f.work);
            put(f.kinetic + f.potential);
        }
        Source::Nodal(c) => {
            for i in start..start + count {
                let x = if i < mesh_nodes {
                    match c {
                        0..=2 => f.mesh_u[i][c],
                        3..=5 => f.mesh_v[i][c - 3],
                        6 => 1.0,
                        _ => 0.0,
                    }
                } else {
                    let b = i - mesh_nodes;
                    let (p, t) = (&f.poses[b], &f.twists[b]);
                    match c {
                        0..=2 => p.r[c] - x_ref[b][c],
                        3..=5 => t.v[c - 3],
                        6 => p.q.w,
                        7 => p.q.i,
                        8 => p.q.j,
                        9 => p.q.k,
                        _ => t.w[c - 10],
                    }
                };
                put(x);
            }
        }
        Source::Mesh(v, first) => {
            for e in first + start..first + start + count {
                put(match v {
                    0..=5 => f.mesh_stress[e][v],
                    6..=11 => f.mesh_strain[e][v - 6],
                    12 => von_mises(&f.mesh_stress[e]),
                    13..=18 => f.mesh_plastic_strain[e][v - 13],
                    _ => f.mesh_equivalent_plastic_strain[e],
                });
            }
        }
        Source::Beam(col, first) => {
            for e in first + start..first + start + count {
                put(f.sections[e][col]);
            }
        }
    }
}

/// `results.exo` being written, and its manifest.
pub(crate) struct ExodusSeries {
    path: PathBuf,
    manifest_path: PathBuf,
    file: File,
    plan: Plan,
    /// Per partition: its slices and its reused buffer.
    parts: Vec<(Vec<Slice>, Vec<u8>)>,
    /// The bodies' reference positions (their first frame's).
    x_ref: Vec<[f64; 3]>,
    frames: u64,
    manifest_frames: u64,
    /// Scratch for the header's `numrecs`.
    numrecs: [u8; 4],
}

fn io_err(kind: OutputErrorKind, path: &Path, e: std::io::Error) -> OutputError {
    OutputError::io(kind, path, e)
}

impl ExodusSeries {
    /// Create `OUTDIR/results.exo` for a layout, written by `partitions` partitions (0:
    /// chosen from the frame's size and the machine). `None` when the layout has no node.
    pub(crate) fn create(
        outdir: &Path,
        layout: &Layout,
        title: &str,
        partitions: u32,
    ) -> Result<Option<ExodusSeries>, OutputError> {
        Self::open(outdir, layout, title, partitions, None)
    }

    /// Continue `OUTDIR/results.exo` after its first `frames` frames (a restart): the header's
    /// record count is cut back to `frames`, and what a killed run wrote after them goes.
    pub(crate) fn resume(
        outdir: &Path,
        layout: &Layout,
        title: &str,
        partitions: u32,
        frames: u64,
    ) -> Result<Option<ExodusSeries>, OutputError> {
        Self::open(outdir, layout, title, partitions, Some(frames))
    }

    fn open(
        outdir: &Path,
        layout: &Layout,
        title: &str,
        partitions: u32,
        resume: Option<u64>,
    ) -> Result<Option<ExodusSeries>, OutputError> {
        let Some(plan) = Plan::new(layout, title) else {
            return Ok(None);
        };
        let path = outdir.join(EXODUS_FILE);
        let record_bytes = plan.schema.record_size;
        let p = if partitions > 0 {
            partitions as usize
        } else {
            // A partition per 4 MiB of frame, at most the machine's threads (and 8).
            let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
            ((record_bytes >> 22) as usize + 1).min(threads).min(8)
        };
        let parts = (0..p)
            .map(|k| {
                let sl = partition_slices(&plan.columns, k, p);
                let most = sl.iter().map(|s| s.count).max().unwrap_or(0) as usize;
                (sl, Vec::with_capacity(most * 8))
            })
            .collect();
        let header = plan.schema.encode(0);
        let (file, frames, x_ref) = match resume {
            None => {
                let file = std::fs::OpenOptions::new()
                    .read(true)
                    .write(true)
                    .create(true)
                    .truncate(true)
                    .open(&path)
                    .map_err(|e| io_err(OutputErrorKind::Create, &path, e))?;
                write_at(&file, &header, 0)
                    .map_err(|e| io_err(OutputErrorKind::Write, &path, e))?;
                for (v, bytes) in &plan.fixed {
                    write_at(&file, bytes, plan.schema.vars[*v].begin)
                        .map_err(|e| io_err(OutputErrorKind::Write, &path, e))?;
                }
                (file, 0, vec![[0.0; 3]; plan.bodies])
            }
            Some(frames) => {
                let file = std::fs::OpenOptions::new()
                    .read(true)
                    .write(true)
                    .open(&path)
                    .map_err(|e| io_err(OutputErrorKind::Create, &path, e))?;
                let mut on_disk = vec![0u8; header.len()];
                read_at(&file, &mut on_disk, 0)
                    .map_err(|e| io_err(OutputErrorKind::Read, &path, e))?;
                on_disk[4..8].copy_from_slice(&[0; 4]);
                if on_disk != header {
                    return Err(io_err(
                        OutputErrorKind::Read,
                        &path,
                        std::io::Error::other(
                            "its header is not the one this scene writes (another scene or mbdc version)",
                        ),
                    ));
                }
                let end = plan.schema.records_begin + frames * record_bytes;
                let len = file
                    .metadata()
                    .map_err(|e| io_err(OutputErrorKind::Read, &path, e))?
                    .len();
                if len < end {
                    return Err(io_err(
                        OutputErrorKind::Read,
                        &path,
                        std::io::Error::other(format!(
                            "it has {len} bytes, fewer than the {end} of the {frames} frames at the checkpoint"
                        )),
                    ));
                }
                write_at(&file, &(frames as u32).to_be_bytes(), NUMRECS_OFFSET)
                    .and_then(|()| file.set_len(end))
                    .map_err(|e| io_err(OutputErrorKind::Write, &path, e))?;
                // The bodies' reference positions: the coordinates written at frame 0.
                let mut x_ref = vec![[0.0; 3]; plan.bodies];
                if frames > 0 && plan.bodies > 0 {
                    let mut b = vec![0u8; plan.bodies * 8];
                    for (c, &var) in plan.coord.iter().enumerate() {
                        let off = plan.schema.offset(var, 0, plan.mesh_nodes as u64);
                        read_at(&file, &mut b, off)
                            .map_err(|e| io_err(OutputErrorKind::Read, &path, e))?;
                        for (r, x) in x_ref.iter_mut().zip(b.chunks_exact(8)) {
                            r[c] = f64::from_be_bytes(x.try_into().unwrap_or([0; 8]));
                        }
                    }
                }
                (file, frames, x_ref)
            }
        };
        let s = ExodusSeries {
            manifest_path: outdir.join(MANIFEST_FILE),
            path,
            file,
            plan,
            parts,
            x_ref,
            frames,
            manifest_frames: u64::MAX,
            numrecs: [0; 4],
        };
        s.write_manifest()?;
        Ok(Some(s))
    }

    /// Frames complete.
    pub(crate) fn frames(&self) -> u64 {
        self.frames
    }

    /// Write a frame: every partition its slices, then the header's record count.
    pub(crate) fn write_frame(&mut self, f: &Frame) -> Result<(), OutputError> {
        let plan = &self.plan;
        let path = &self.path;
        if self.frames == 0 && plan.bodies > 0 {
            // The bodies' reference positions: this first frame's.
            for (x, p) in self.x_ref.iter_mut().zip(&f.poses) {
                *x = [p.r.x, p.r.y, p.r.z];
            }
            let mut b = Vec::with_capacity(plan.bodies * 8);
            for c in 0..3 {
                b.clear();
                b.extend(self.x_ref.iter().flat_map(|x| x[c].to_be_bytes()));
                let off = plan.schema.offset(plan.coord[c], 0, plan.mesh_nodes as u64);
                write_at(&self.file, &b, off)
                    .map_err(|e| io_err(OutputErrorKind::Write, path, e))?;
            }
        }
        let rec = self.frames;
        let (file, x_ref) = (&self.file, &self.x_ref[..]);
        let write_part = |slices: &[Slice], buf: &mut Vec<u8>| -> std::io::Result<()> {
            for s in slices {
                let col = &plan.columns[s.column];
                buf.clear();
                encode(
                    buf,
                    col.source,
                    s.start as usize,
                    s.count as usize,
                    f,
                    plan.mesh_nodes,
                    x_ref,
                );
                write_at(file, buf, plan.schema.offset(col.var, rec, s.start))?;
            }
            Ok(())
        };
        let result = if self.parts.len() == 1 {
            let (sl, buf) = &mut self.parts[0];
            write_part(sl, buf)
        } else {
            std::thread::scope(|scope| {
                let handles: Vec<_> = self
                    .parts
                    .iter_mut()
                    .map(|(sl, buf)| scope.spawn(|| write_part(sl, buf)))
                    .collect();
                let mut r = Ok(());
                for h in handles {
                    let x = h
                        .join()
                        .unwrap_or_else(|_| Err(std::io::Error::other("a partition panicked")));
                    if r.is_ok() {
                        r = x;
                    }
                }
                r
            })
        };
        result.map_err(|e| io_err(OutputErrorKind::Write, path, e))?;
        // Every slice of the frame is written: only now does the header count it.
        self.numrecs = ((rec + 1).min(u64::from(u32::MAX)) as u32).to_be_bytes();
        write_at(&self.file, &self.numrecs, NUMRECS_OFFSET)
            .map_err(|e| io_err(OutputErrorKind::Write, path, e))?;
        self.frames += 1;
        Ok(())
    }

    /// The manifest as it stands.
    fn manifest(&self) -> Manifest {
        let schema = &self.plan.schema;
        let mut slices = Vec::new();
        for (k, (sl, _)) in self.parts.iter().enumerate() {
            for s in sl {
                let col = &self.plan.columns[s.column];
                slices.push(ManifestSlice {
                    partition: k as u32,
                    variable: schema.vars[col.var].name.clone(),
                    start: s.start,
                    count: s.count,
                    offset: schema.offset(col.var, 0, s.start),
                    length: s.count * 8,
                });
            }
        }
        Manifest {
            format_version: MANIFEST_VERSION,
            file: EXODUS_FILE.into(),
            partitions: self.parts.len() as u32,
            records_begin: schema.records_begin,
            record_size: schema.record_size,
            frames_complete: self.frames,
            slices,
        }
    }

    /// Rewrite the manifest (atomically: a temporary file, then a rename) if frames were
    /// completed since it was last written.
    pub(crate) fn write_index(&mut self) -> Result<(), OutputError> {
        if self.manifest_frames == self.frames {
            return Ok(());
        }
        self.write_manifest()?;
        self.manifest_frames = self.frames;
        Ok(())
    }

    fn write_manifest(&self) -> Result<(), OutputError> {
        let text =
            serde_json::to_string_pretty(&self.manifest()).map_err(|e| OutputError::Json {
                path: self.manifest_path.clone(),
                message: e.to_string(),
            })?;
        super::replace_file::replace_file(&self.manifest_path, (text + "\n").as_bytes())
    }
}
