//! `mbdc view`: a 3-D replay of a run in the browser, one self-contained page
//! `OUTDIR/view.html` built from the run's output folder.
//!
//! # Flow
//!
//! ```text
//! OUTDIR/scene.json ──► scene_info   bodies' shapes (from their inertia), joints, springs,
//!                                    contact planes, beams
//! OUTDIR/bodies.csv ──► frames       every k-th frame (k from the size budget), and the last
//! OUTDIR/mesh.pvd, mesh/*.vtu ──► mesh_surface   boundary surface, nodal displacement and
//!                                    von Mises per shown frame
//! OUTDIR/beams.csv ──► beam_sections   per shown frame and beam element: N1, |M|, M1
//! OUTDIR/energy.csv, constraints.csv ──► curves
//! OUTDIR/summary.json ──► status, failure report, the body or joint it names
//!                     ──► page   viewer.html template + JSON + base64 Float32 frames +
//!                                the viewer bundle (three.js inlined) ──► OUTDIR/view.html
//! ```
//!
//! The page needs no network access. Its scripts are built from `cli/viewer/src` into
//! `cli/assets/viewer.js` (see `cli/viewer/README.md`, which also gives the data contract);
//! this module only fills the template.
//!
//! A run that stopped is shown up to its last frame, with its report and the body or joint
//! its failure names highlighted. A folder without `scene.json` (a run of an older mbdc)
//! is still shown: bodies as spheres, beams recognized by their nodes' names, no joints.

mod beam_sections;
mod curves;
mod frames;
mod mesh_surface;
mod open;
mod page;
mod scene_info;

use std::path::{Path, PathBuf};

use serde::Serialize;

use mbdc_runtime::output::{RunStatus, Summary};

pub use open::open_in_browser;

/// Options of [`write_view`].
#[derive(Clone, Copy, Debug)]
pub struct ViewOptions {
    /// Budget for the frames' binary block, bytes: frames are decimated (every k-th shown,
    /// and the last) to fit it.
    pub max_frame_bytes: usize,
}

impl Default for ViewOptions {
    fn default() -> Self {
        ViewOptions {
            max_frame_bytes: 48 << 20,
        }
    }
}

/// What [`write_view`] wrote.
#[derive(Clone, Debug)]
pub struct ViewWritten {
    /// `OUTDIR/view.html`.
    pub path: PathBuf,
    /// Frames in the page.
    pub frames: usize,
    /// Frames the run wrote.
    pub run_frames: usize,
    /// Every k-th frame of the run is shown.
    pub shown_every: usize,
    /// Size of the page, bytes.
    pub bytes: usize,
    /// Things the page cannot show, said once each (no scene.json, ...).
    pub notes: Vec<String>,
}

/// An error of `mbdc view`, with the file it concerns in its text.
#[derive(Clone, Debug, PartialEq)]
pub struct ViewError(pub String);

impl std::fmt::Display for ViewError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for ViewError {}

/// The page's data (the JSON block; the contract is in `cli/viewer/README.md`).
#[derive(Clone, Debug, Serialize)]
pub(crate) struct ViewData {
    format: u32,
    model: String,
    method: String,
    step: f64,
    duration: f64,
    status: &'static str,
    report: Option<String>,
    highlight: Option<Highlight>,
    up: [f64; 3],
    center: [f64; 3],
    extent: f64,
    bodies: Vec<scene_info::BodyView>,
    beams: Vec<scene_info::BeamView>,
    joints: Vec<scene_info::JointView>,
    springs: Vec<scene_info::SpringView>,
    planes: Vec<scene_info::PlaneView>,
    meshes: Vec<mesh_surface::MeshView>,
    frames: FramesInfo,
    curves: Vec<curves::Curve>,
}

/// What the failure names, to be drawn in red.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub(crate) enum Highlight {
    /// A body slot.
    Body {
        /// The slot.
        body: usize,
    },
    /// A joint, by index into `joints`.
    Joint {
        /// The index.
        joint: usize,
    },
}

/// The frames' block: `count` frames of `floats` Float32 values each.
#[derive(Clone, Copy, Debug, Serialize)]
pub(crate) struct FramesInfo {
    count: usize,
    floats: usize,
    shown_every: usize,
    run_frames: usize,
}

/// Build `DIR/view.html` from the output folder `dir`.
///
/// # Errors
/// If the folder is not a run's output folder, a file of it cannot be read or is malformed,
/// or the page cannot be written; the message names the file.
pub fn write_view(dir: &Path, opts: ViewOptions) -> Result<ViewWritten, ViewError> {
    if !dir.is_dir() {
        return Err(ViewError(format!(
            "{}: no such folder (give the output folder of a run: `mbdc run FILE -o DIR`)",
            dir.display()
        )));
    }
    let summary_path = dir.join("summary.json");
    let summary = Summary::read(&summary_path).map_err(|e| {
        ViewError(format!(
            "{e}\n  help: is {} the output folder of a run? It has no readable summary.json",
            dir.display()
        ))
    })?;
    let mut notes = Vec::new();
    let scene = match mbdc_runtime::output::read_scene(&dir.join(mbdc_runtime::output::SCENE_FILE))
    {
        Ok(s) => Some(s),
        Err(e) => {
            if dir.join(mbdc_runtime::output::SCENE_FILE).exists() {
                return Err(ViewError(e.to_string()));
            }
            notes.push(format!(
                "{} has no scene.json (written by runs of this mbdc): bodies are drawn as spheres and joints are not shown",
                dir.display()
            ));
            None
        }
    };
    let mesh_files = mesh_surface::series_files(dir)?;
    let body_names = frames::body_names(dir)?;
    let mut info = scene_info::SceneInfo::build(scene.as_ref(), &body_names);
    let meshes = match mesh_files.first() {
        Some((_, first)) => Some(mesh_surface::MeshGeometry::read(first, scene.as_ref())?),
        None => None,
    };
    let mesh_floats = meshes.as_ref().map_or(0, |m| m.floats_per_frame());
    let sections = beam_sections::layout(dir, &info.beams)?;
    if sections.is_none() && !info.beams.is_empty() {
        notes.push(format!(
            "{}: no beams.csv, or no rows in it (its output was turned off?): the beams are not coloured by their section forces",
            dir.display()
        ));
    }
    let layout = frames::FrameLayout {
        slots: body_names.len(),
        mesh_floats,
        beam_floats: sections
            .as_ref()
            .map_or(0, beam_sections::BeamSections::floats_per_frame),
    };
    let run_frames = frames::count_frames(dir, mesh_files.len())?;
    let max_frames = (opts.max_frame_bytes / (4 * layout.floats())).max(2);
    // reading a mesh frame parses a whole .vtu file: bounded separately
    let max_frames = if meshes.is_some() {
        max_frames.min(600)
    } else {
        max_frames.min(20_000)
    };
    let shown_every = run_frames.div_ceil(max_frames).max(1);
    let kept = frames::kept_frames(run_frames, shown_every);
    let mut block = frames::read_bodies(dir, &layout, &kept)?;
    if let Some(m) = &meshes {
        let files: Vec<&Path> = kept
            .iter()
            .filter_map(|&i| mesh_files.get(i).map(|(_, p)| p.as_path()))
            .collect();
        m.fill_frames(&files, &mut block, &layout)?;
        if block.times_missing() {
            block.set_times(
                kept.iter()
                    .filter_map(|&i| mesh_files.get(i).map(|(t, _)| *t)),
            );
        }
    }
    if let Some(sec) = &sections {
        beam_sections::fill(sec, &kept, &mut block, &layout, &mut info.beams)?;
    }
    let (center, extent) = info.bounds(&block, &layout, meshes.as_ref());
    info.finish_shapes(extent);
    let (status, report, highlight) = status_report(&summary, &info);
    let up = match scene.as_ref().and_then(|s| s.gravity) {
        Some(g) if norm(g) > 0.0 => {
            let n = norm(g);
            [-g[0] / n, -g[1] / n, -g[2] / n]
        }
        _ => [0.0, 0.0, 1.0],
    };
    let curves = curves::read(dir)?;
    let mesh_views = meshes.map(|m| m.views(&block, &layout)).unwrap_or_default();
    let data = ViewData {
        format: 1,
        model: summary.model.clone(),
        method: summary.method.clone(),
        step: summary.step,
        duration: summary.duration,
        status,
        report,
        highlight,
        up,
        center,
        extent,
        bodies: info.bodies,
        beams: info.beams,
        joints: info.joints,
        springs: info.springs,
        planes: info.planes,
        meshes: mesh_views,
        frames: FramesInfo {
            count: block.frames(),
            floats: layout.floats(),
            shown_every,
            run_frames,
        },
        curves,
    };
    let html = page::render(&data, &block.values)?;
    let path = dir.join("view.html");
    mbdc_runtime::output::replace_file(&path, html.as_bytes())
        .map_err(|e| ViewError(e.to_string()))?;
    notes.extend(info.notes);
    Ok(ViewWritten {
        path,
        frames: data.frames.count,
        run_frames,
        shown_every,
        bytes: html.len(),
        notes,
    })
}

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// The status word, the report text and what the report names.
fn status_report(
    s: &Summary,
    info: &scene_info::SceneInfo,
) -> (&'static str, Option<String>, Option<Highlight>) {
    match s.status() {
        RunStatus::Finished => ("finished", None, None),
        RunStatus::Started => (
            "unfinished",
            Some(
                "The run did not finish: its summary.json is still the one written when it started (its process was killed without a word — SIGKILL, a crash, a power cut — or it is still running). Shown up to its last complete frame.".into(),
            ),
            None,
        ),
        RunStatus::Interrupted => {
            let text = s.interrupted.as_ref().map_or_else(
                || "interrupted".to_string(),
                |i| format!("{i}. Shown up to its last frame."),
            );
            ("interrupted", Some(text), None)
        }
        RunStatus::Failed => {
            let Some(f) = &s.failure else {
                return ("failed", Some("the run stopped".into()), None);
            };
            let mut text = format!(
                "STOPPED at t = {} s (step {}): {} = {} at {}\ncause: {}",
                f.time, f.step, f.quantity, f.value, f.location, f.cause
            );
            if let Some(h) = &f.hint {
                text.push_str("\nhelp: ");
                text.push_str(h);
            }
            ("failed", Some(text), info.find(&f.location))
        }
    }
}
