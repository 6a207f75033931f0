//! How much a run will write, estimated before it starts from the layout, the output
//! settings and the number of steps: a run that would fill a disk says so before its first
//! step, with the output interval that would keep it reasonable (issue: a 32-link chain
//! over 1000 s wrote 59 GB in ten minutes without a word).
//!
//! Every file writes its numbers as text (CSV; ASCII VTK XML), so its size is the count of
//! numbers per frame times the characters a number takes (plus the tags of a VTK file). A
//! written `f64` is ryu's shortest round-trip form: up to 17 significant digits, a sign, a point and an exponent, 18–24
//! characters with its separator for a value that is not round; [`BYTES_PER_NUMBER`] takes
//! 21. Round values (zeros, integers) are shorter, so the estimate is an upper-side figure;
//! `tests/tests/output_estimate.rs` holds every file's estimate between 0.9× and 2× what
//! real runs of bodies, joints, beams and meshes write.

use super::csv::{BEAM_COLUMNS, BODY_COLUMNS, ENERGY_COLUMNS};
use super::vtu::MESH_ENERGY_COLUMNS;
use crate::contract::scene::OutputSpec;
use crate::contract::system::Layout;

/// Characters of one written `f64` with its separator (see the module doc).
pub const BYTES_PER_NUMBER: u64 = 21;
/// Characters of one written index (connectivity, offsets, cell types) with its separator.
const BYTES_PER_INDEX: u64 = 7;
/// Characters of a `.vtp`/`.vtu` frame's XML tags (header, array names, closing tags).
const XML_TAGS: u64 = 900;
/// Above this estimate (bytes) a run warns before it starts: 1 GB.
pub const OUTPUT_WARN_BYTES: u64 = 1_000_000_000;
/// What the suggested output interval aims at (bytes): 100 MB.
pub const OUTPUT_SUGGEST_BYTES: u64 = 100_000_000;

/// The output a run will write, estimated before it starts ([`estimate`]).
#[derive(Clone, Debug, PartialEq)]
pub struct OutputEstimate {
    /// Frames the run writes: every `every`-th step, the initial state and the last step.
    pub frames: u64,
    /// Per file (or per ParaView series), its estimated size over the whole run (bytes).
    pub files: Vec<(&'static str, u64)>,
}

impl OutputEstimate {
    /// The estimated total (bytes).
    pub fn bytes(&self) -> u64 {
        self.files.iter().map(|f| f.1).sum()
    }
}

/// Frames of a run of `steps` steps written every `every` steps: the initial frame, every
/// `every`-th step, and the last step when it is not one of those.
pub fn frames(steps: u64, every: u32) -> u64 {
    let every = u64::from(every.max(1));
    1 + steps / every + u64::from(!steps.is_multiple_of(every))
}

/// The output of a run of `steps` steps on a system of `layout`, writing the files `spec`
/// asks for (and those of beams and meshes, which every run with them writes) every
/// `every` steps.
pub fn estimate(layout: &Layout, spec: &OutputSpec, steps: u64, every: u32) -> OutputEstimate {
    let n = BYTES_PER_NUMBER;
    let i = BYTES_PER_INDEX;
    let frames = frames(steps, every);
    let mut files = Vec::new();
    if spec.bodies {
        let numbers = 1 + BODY_COLUMNS.len() as u64 * layout.body_names.len() as u64;
        files.push(("bodies.csv", numbers * n));
    }
    if spec.energy {
        files.push(("energy.csv", ENERGY_COLUMNS.len() as u64 * n));
    }
    if spec.constraints {
        let numbers: u64 = 1 + layout
            .joints
            .iter()
            .map(|j| 1 + u64::from(j.nonholonomic > 0) + j.rows as u64)
            .sum::<u64>();
        files.push(("constraints.csv", numbers * n));
    }
    let bl = &layout.beams;
    if !bl.is_empty() {
        let elements = bl.elements.len() as u64;
        let points: u64 = bl.beams.iter().map(|b| b.elements as u64 + 1).sum();
        files.push(("beams.csv", elements * (4 + BEAM_COLUMNS.len() as u64) * n));
        // points, lines (two nodes, an offset, the beam), N M gamma kappa per element
        files.push((
            "beams/*.vtp",
            XML_TAGS + points * 3 * n + elements * (4 * i + 12 * n),
        ));
    }
    let ml = &layout.meshes;
    if !ml.blocks.is_empty() {
        files.push((
            "mesh_energy.csv",
            (1 + MESH_ENERGY_COLUMNS.len() as u64) * n,
        ));
        let nodes = ml.nodes() as u64;
        let mut cells = 0u64;
        for b in &ml.blocks {
            let e = b.elements() as u64;
            // connectivity, offset, type, mesh index; stress, strain, von Mises (and the
            // plastic strain and its equivalent)
            let plastic = if b.material.plastic.is_some() { 7 } else { 0 };
            cells += e * ((b.kind.nodes() as u64 + 3) * i + (13 + plastic) * n);
        }
        // reference points, displacement and velocity per node
        files.push(("mesh/*.vtu", XML_TAGS + nodes * 9 * n + cells));
    }
    for f in &mut files {
        f.1 = f.1.saturating_mul(frames);
    }
    OutputEstimate { frames, files }
}

/// A size in bytes as people read it (decimal units: kB, MB, GB, TB).
pub fn human_bytes(b: u64) -> String {
    let units = ["B", "kB", "MB", "GB", "TB", "PB"];
    let mut x = b as f64;
    let mut u = 0;
    while x >= 1000.0 && u + 1 < units.len() {
        x /= 1000.0;
        u += 1;
    }
    if u == 0 {
        format!("{b} B")
    } else {
        format!("{x:.1} {}", units[u])
    }
}

/// The smallest round output interval (1, 2 or 5 times a power of ten) at or above `every`
/// for which the run writes at most `target` bytes (or one frame a run, if even that writes
/// more).
pub fn every_for(layout: &Layout, spec: &OutputSpec, steps: u64, every: u32, target: u64) -> u32 {
    let mut k: u64 = 1;
    loop {
        for m in [1u64, 2, 5] {
            let cand = m.saturating_mul(k);
            if cand < u64::from(every.max(1)) {
                continue;
            }
            let cand = cand.min(u64::from(u32::MAX)) as u32;
            if estimate(layout, spec, steps, cand).bytes() <= target || cand == u32::MAX {
                return cand;
            }
            // beyond one frame per run nothing shrinks further
            if u64::from(cand) >= steps.max(1) {
                return cand;
            }
        }
        k = k.saturating_mul(10);
    }
}

/// The warning a run gives before it starts when it would write more than
/// [`OUTPUT_WARN_BYTES`], naming the biggest files and the output interval that would
/// bring it to about [`OUTPUT_SUGGEST_BYTES`]; `None` below.
pub fn warning(layout: &Layout, spec: &OutputSpec, steps: u64, every: u32) -> Option<String> {
    let e = estimate(layout, spec, steps, every);
    if e.bytes() <= OUTPUT_WARN_BYTES {
        return None;
    }
    let mut files = e.files.clone();
    files.sort_by_key(|f| std::cmp::Reverse(f.1));
    let list: Vec<String> = files
        .iter()
        .take(3)
        .map(|(f, b)| format!("{f} {}", human_bytes(*b)))
        .collect();
    let better = every_for(layout, spec, steps, every, OUTPUT_SUGGEST_BYTES);
    let after = estimate(layout, spec, steps, better).bytes();
    Some(format!(
        "this run will write about {} ({} frames, one every {} step(s): {})\n  help: write a frame every {better} steps — `output {{ every {better} }}` in the model's `simulate` block, or `--every {better}` — for about {}",
        human_bytes(e.bytes()),
        e.frames,
        every.max(1),
        list.join(", "),
        human_bytes(after),
    ))
}
