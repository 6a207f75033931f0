//! How much a run will write, estimated before it starts from the layout, the output
//! settings and the number of steps: a run that would fill a disk says so before its first
//! step, with the output interval that would keep it reasonable (issue: a 32-link chain
//! over 1000 s wrote 59 GB in ten minutes without a word).
//!
//! Every file writes its numbers as text (CSV; ASCII VTK XML), so its size is the count of
//! numbers per frame times the characters a number takes (plus the tags of a VTK file). A
//! written `f64` is ryu's shortest round-trip form: up to 17 significant digits, a sign, a point and an exponent, 18–24
//! characters with its separator for a value that is not round; [`BYTES_PER_NUMBER`] takes
//! 21. Round values (zeros, integers) are shorter, so the estimate is an upper figure: real
//! runs of bodies, joints, beams and meshes write 0.56–1.05 of it per file
//! (`tests/tests/output_estimate.rs`), a 10⁶-element mesh barely moving about 0.3 (its
//! numbers are mostly `0.0`).

use super::csv::{BEAM_COLUMNS, BODY_COLUMNS, ENERGY_COLUMNS};
use super::vtu::MESH_ENERGY_COLUMNS;
use crate::contract::scene::{OutputFormat, OutputSpec};
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
/// asks for (and those of beams and meshes, which every run with them writes, in the
/// spec's format) every `every` steps.
///
/// `results.exo` (format `exodus`) is binary: its size is exact, the header (the mesh, the
/// names) plus one record of 8-byte values per frame, taken from the file's own layout.
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
    let (series, exodus) = (
        spec.format == OutputFormat::Vtk,
        spec.format == OutputFormat::Exodus,
    );
    let bl = &layout.beams;
    if !bl.is_empty() {
        let elements = bl.elements.len() as u64;
        let points: u64 = bl.beams.iter().map(|b| b.elements as u64 + 1).sum();
        if !exodus {
            files.push(("beams.csv", elements * (4 + BEAM_COLUMNS.len() as u64) * n));
        }
        if series {
            // points, lines (two nodes, an offset, the beam), N M gamma kappa per element
            files.push((
                "beams/*.vtp",
                XML_TAGS + points * 3 * n + elements * (4 * i + 12 * n),
            ));
        }
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
        if series {
            // reference points, displacement and velocity per node
            files.push(("mesh/*.vtu", XML_TAGS + nodes * 9 * n + cells));
        }
    }
    for f in &mut files {
        f.1 = f.1.saturating_mul(frames);
    }
    if exodus {
        if let Some((header, record)) = super::exodus::file_layout(layout) {
            files.push((
                super::exodus::EXODUS_FILE,
                header.saturating_add(record.saturating_mul(frames)),
            ));
        }
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
    let after = estimate(layout, spec, steps, better);
    let help = if after.bytes() <= OUTPUT_SUGGEST_BYTES {
        format!(
            "write a frame every {better} steps — `output {{ every {better} }}` in the model's `simulate` block, or `--every {better}` — for up to about {}",
            human_bytes(after.bytes())
        )
    } else {
        // even the sparsest output is large: say what one frame costs
        format!(
            "one frame writes up to about {}: even the fewest frames ({} with `--every {better}`) write up to about {}",
            human_bytes(e.bytes() / e.frames.max(1)),
            after.frames,
            human_bytes(after.bytes())
        )
    };
    Some(format!(
        "this run will write up to about {} ({} frames, one every {} step(s): {})\n  help: {help}",
        human_bytes(e.bytes()),
        e.frames,
        every.max(1),
        list.join(", "),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contract::mesh_layout::{ElementBlock, MeshLayout};
    use crate::contract::scene::{ElementKind, Material, MeshFormulation};

    /// A layout of one hex8 block of `elements` elements over `elements` nodes (the
    /// estimate reads only the counts).
    fn hex_layout(elements: usize) -> Layout {
        let mut m = MeshLayout {
            x0: vec![[0.0; 3]; elements],
            ..MeshLayout::default()
        };
        m.blocks.push(ElementBlock {
            name: "m".into(),
            kind: ElementKind::Hex8,
            material: Material {
                e: 1.0,
                nu: 0.3,
                rho: 1.0,
                plastic: None,
            },
            thickness: 1.0,
            formulation: MeshFormulation::default(),
            first_node: 0,
            nodes: elements,
            conn: vec![0; 8 * elements],
            first_slot: 0,
            first_element: 0,
        });
        Layout {
            body_names: vec![],
            mass: vec![],
            joints: vec![],
            rows: 0,
            row_joint: vec![],
            row_kind: vec![],
            beams: Default::default(),
            meshes: std::sync::Arc::new(m),
        }
    }

    /// Frames: the first, every `every`-th step, the last.
    #[test]
    fn frames_count_the_first_and_the_last() {
        assert_eq!(frames(10, 1), 11);
        assert_eq!(frames(10, 5), 3);
        assert_eq!(frames(10, 3), 5);
        assert_eq!(frames(10, 100), 2);
        assert_eq!(frames(0, 7), 1);
    }

    /// 10⁴ hex8 over 10⁴ steps, every step: 10⁴ + 1 frames of 5.39 MB (9 numbers per node,
    /// 13 numbers and 11 indices per element, the tags) → 53.9 GB; the warning suggests the
    /// round interval that brings it under 100 MB (every 1000: 11 frames, 59 MB). 10⁶ hex8
    /// over 10 steps cannot get under it (539 MB a frame) and says what one frame costs.
    #[test]
    fn the_warning_suggests_a_round_interval_or_says_what_a_frame_costs() {
        let spec = OutputSpec::default();
        let small = hex_layout(10_000);
        let per_frame = 900 + 10_000 * 9 * 21 + 10_000 * (11 * 7 + 13 * 21);
        let e = estimate(&small, &spec, 10_000, 1);
        let csv = e.bytes() - e.files.iter().find(|f| f.0 == "mesh/*.vtu").unwrap().1;
        assert_eq!(e.bytes() - csv, 10_001 * per_frame);
        let w = warning(&small, &spec, 10_000, 1).expect("above 1 GB");
        assert!(w.contains("every 1000 steps"), "{w}");
        assert!(w.contains("53.9 GB") && w.contains("59.3 MB"), "{w}");
        assert!(w.contains("(10001 frames"), "{w}");
        assert!(warning(&small, &spec, 10, 1).is_none());
        let big = hex_layout(1_000_000);
        let w = warning(&big, &spec, 10, 1).expect("above 1 GB");
        assert!(w.contains("one frame writes up to about 539.0 MB"), "{w}");
        assert!(w.contains("(2 with `--every 10`)"), "{w}");
    }
}
