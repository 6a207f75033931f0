//! The beams' section quantities per shown frame, read from `beams.csv` into the Float32
//! block of the page, so that the page can colour each element of a beam.
//!
//! `beams.csv` has one row per element and frame (`t, beam, element, s, N1 … kappa3`):
//! frames in order, one to one with the rows of `bodies.csv`; within a frame the beams in
//! scene order and each beam's elements in order. `beam` is the beam's name (a string, so
//! the file is read with the csv crate, not with `plot::data`, which parses every column
//! it is asked for as a number).
//!
//! Per shown frame, per beam of the page (in `beams` order), per element, three floats go
//! after the meshes' values: `N1` (axial force, N), `|M| = √(M2² + M3²)` (bending moment,
//! N·m) and `M1` (torsion, N·m). A frame `beams.csv` does not have (a run killed between
//! writing its `bodies.csv` row and its `beams.csv` rows) gets NaN: drawn uncoloured.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use super::frames::{FrameBlock, FrameLayout};
use super::scene_info::BeamView;
use super::ViewError;

/// Floats per element in a frame: `N1`, `|M|`, `M1`.
pub(crate) const PER_ELEMENT: usize = 3;

/// The columns of `beams.csv` that are read, by name.
const COLUMNS: [&str; 6] = ["beam", "element", "N1", "M1", "M2", "M3"];

/// Where the rows of one frame of `beams.csv` go.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct BeamSections {
    path: PathBuf,
    /// Per row of a frame: the beam's name, the element number and the float offset of its
    /// values within the frame's beam part (`None`: a beam the page does not draw).
    rows: Vec<(String, usize, Option<usize>)>,
    /// Per beam of the page, its element count.
    pub elements: Vec<usize>,
}

impl BeamSections {
    /// Floats per frame of the beams' section quantities.
    pub fn floats_per_frame(&self) -> usize {
        PER_ELEMENT * self.elements.iter().sum::<usize>()
    }
}

fn csv_err(path: &Path, e: impl std::fmt::Display) -> ViewError {
    ViewError(format!("{}: {e}", path.display()))
}

/// A reader of `beams.csv` and the positions of [`COLUMNS`] in it.
fn open(path: &Path) -> Result<(csv::Reader<std::fs::File>, [usize; 6], usize), ViewError> {
    let mut r = csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(true)
        .from_path(path)
        .map_err(|e| csv_err(path, format!("cannot read: {e}")))?;
    let head = r.headers().map_err(|e| csv_err(path, e))?.clone();
    let mut idx = [0usize; 6];
    for (i, name) in COLUMNS.iter().enumerate() {
        idx[i] = head.iter().position(|h| h.trim() == *name).ok_or_else(|| {
            csv_err(
                path,
                format!("not a beams.csv of mbdc (it has no `{name}` column)"),
            )
        })?;
    }
    Ok((r, idx, head.len()))
}

/// The line number of a record, for messages.
fn line(rec: &csv::StringRecord) -> u64 {
    rec.position().map_or(0, |p| p.line())
}

/// The element number of a record.
fn element(path: &Path, rec: &csv::StringRecord, i: usize) -> Result<usize, ViewError> {
    let f = rec.get(i).unwrap_or("").trim();
    f.parse::<usize>().map_err(|_| {
        csv_err(
            path,
            format!("line {}: element `{f}` is not a whole number", line(rec)),
        )
    })
}

/// The layout of `DIR/beams.csv` (its first frame) matched to the page's beams; `None`
/// when the run wrote no `beams.csv` or it has no rows (the beams are then not coloured).
///
/// # Errors
/// If the file cannot be read, is not a `beams.csv`, or a beam of the page has not
/// `nodes − 1` elements in it; the message names the file.
pub(crate) fn layout(dir: &Path, beams: &[BeamView]) -> Result<Option<BeamSections>, ViewError> {
    let path = dir.join("beams.csv");
    if beams.is_empty() || !path.exists() {
        return Ok(None);
    }
    let (mut r, idx, width) = open(&path)?;
    // the rows of the first frame: up to the first row's (beam, element) again
    let mut rows: Vec<(String, usize, Option<usize>)> = Vec::new();
    let mut rec = csv::StringRecord::new();
    loop {
        match r.read_record(&mut rec) {
            Ok(false) => break,
            Ok(true) => {}
            Err(e) => return Err(csv_err(&path, e)),
        }
        if rec.len() != width {
            break; // an incomplete last line
        }
        let name = rec.get(idx[0]).unwrap_or("");
        let el = element(&path, &rec, idx[1])?;
        if rows.first().is_some_and(|(n, e, _)| *n == name && *e == el) {
            break;
        }
        // a beam's elements in order, from 0
        let expected = match rows.last() {
            Some((n, e, _)) if n == name => e + 1,
            _ => 0,
        };
        if el != expected || (expected == 0 && rows.iter().any(|(n, _, _)| n == name)) {
            return Err(csv_err(
                &path,
                format!(
                    "line {}: beam `{name}` element {el} where element {expected} of {} was expected (rows out of order)",
                    line(&rec),
                    if expected == 0 { "a new beam" } else { "it" }
                ),
            ));
        }
        rows.push((name.to_string(), el, None));
    }
    if rows.is_empty() {
        return Ok(None);
    }
    let mut count: HashMap<&str, usize> = HashMap::new();
    for (n, _, _) in &rows {
        *count.entry(n.as_str()).or_default() += 1;
    }
    let mut elements = Vec::with_capacity(beams.len());
    let mut start: HashMap<&str, usize> = HashMap::new();
    let mut at = 0usize;
    for b in beams {
        let n = count.get(b.name.as_str()).copied().unwrap_or(0);
        let want = b.nodes.len().saturating_sub(1);
        if n != want {
            return Err(csv_err(
                &path,
                format!(
                    "beam `{}` has {n} elements in a frame but {} nodes in bodies.csv ({want} elements expected)",
                    b.name,
                    b.nodes.len()
                ),
            ));
        }
        start.insert(b.name.as_str(), at);
        elements.push(n);
        at += PER_ELEMENT * n;
    }
    let offsets: Vec<Option<usize>> = rows
        .iter()
        .map(|(n, e, _)| start.get(n.as_str()).map(|s| s + PER_ELEMENT * e))
        .collect();
    for (row, o) in rows.iter_mut().zip(offsets) {
        row.2 = o;
    }
    Ok(Some(BeamSections {
        path,
        rows,
        elements,
    }))
}

/// Put the section quantities of the kept frames (`kept`: the run's frame numbers, in
/// order, one per frame of `block`) into `block`, and each beam's largest |value| of each
/// quantity over them into `beams`.
///
/// # Errors
/// If the file cannot be read or its rows do not repeat the first frame's order; the
/// message names the file.
pub(crate) fn fill(
    sections: &BeamSections,
    kept: &[usize],
    block: &mut FrameBlock,
    layout: &FrameLayout,
    beams: &mut [BeamView],
) -> Result<(), ViewError> {
    let path = &sections.path;
    let base = layout.beam_offset();
    let floats = sections.floats_per_frame();
    let frames = block.frames().min(kept.len());
    for i in 0..block.frames() {
        block.frame_mut(i)[base..base + floats].fill(f32::NAN);
    }
    let (mut r, idx, width) = open(path)?;
    let per_frame = sections.rows.len();
    let mut rec = csv::StringRecord::new();
    let mut row = 0usize;
    let mut next = 0usize;
    while next < frames {
        match r.read_record(&mut rec) {
            Ok(false) => break,
            Ok(true) => {}
            Err(e) => return Err(csv_err(path, e)),
        }
        if rec.len() != width {
            break; // an incomplete last line
        }
        let (frame, k) = (row / per_frame, row % per_frame);
        row += 1;
        let (name, el, dest) = &sections.rows[k];
        let here = rec.get(idx[0]).unwrap_or("");
        let e = element(path, &rec, idx[1])?;
        if here != name || e != *el {
            return Err(csv_err(
                path,
                format!(
                    "line {}: beam `{here}` element {e} where beam `{name}` element {el} was expected (every frame has the rows of the first, in its order)",
                    line(&rec)
                ),
            ));
        }
        if kept[next] != frame {
            continue;
        }
        if let Some(o) = dest {
            let num = |c: usize| -> Result<f64, ViewError> {
                let f = rec.get(idx[c]).unwrap_or("").trim();
                f.parse::<f64>().map_err(|_| {
                    csv_err(path, format!("line {}: `{f}` is not a number", line(&rec)))
                })
            };
            let (n1, m1, m2, m3) = (num(2)?, num(3)?, num(4)?, num(5)?);
            let f = &mut block.frame_mut(next)[base + o..base + o + PER_ELEMENT];
            f[0] = n1 as f32;
            f[1] = (m2 * m2 + m3 * m3).sqrt() as f32;
            f[2] = m1 as f32;
        }
        if k + 1 == per_frame {
            next += 1;
        }
    }
    // the largest |value| per beam and quantity, as shown
    let mut o = base;
    for (b, &n) in beams.iter_mut().zip(&sections.elements) {
        let mut max = [0.0f64; PER_ELEMENT];
        for i in 0..block.frames() {
            let f = block.frame(i);
            for e in 0..n {
                for (q, m) in max.iter_mut().enumerate() {
                    let v = f64::from(f[o + PER_ELEMENT * e + q]).abs();
                    if v > *m {
                        *m = v;
                    }
                }
            }
        }
        b.elements = n;
        [b.n_max, b.m_max, b.t_max] = max;
        o += PER_ELEMENT * n;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::view::frames::{kept_frames, read_bodies};

    /// A beam view of `nodes` node slots named `name`.
    fn beam(name: &str, nodes: usize) -> BeamView {
        BeamView::new(name.to_string(), (0..nodes).collect(), 0.01)
    }

    const HEAD: &str =
        "t,beam,element,s,N1,N2,N3,M1,M2,M3,gamma1,gamma2,gamma3,kappa1,kappa2,kappa3\n";

    /// A row of beams.csv.
    fn row(t: f64, beam: &str, e: usize, n1: f64, m: [f64; 3]) -> String {
        format!(
            "{t},{beam},{e},{},{n1},0,0,{},{},{},0,0,0,0,0,0\n",
            0.1 * e as f64 + 0.05,
            m[0],
            m[1],
            m[2]
        )
    }

    #[test]
    fn section_quantities_go_into_the_kept_frames() {
        let dir = tempfile::tempdir().unwrap();
        // two beams: `arm` (3 nodes, 2 elements), `blade-2` (2 nodes, 1 element); three frames
        let mut text = String::from(HEAD);
        for f in 0..3 {
            let t = 0.5 * f as f64;
            let x = f as f64;
            text += &row(t, "arm", 0, 10.0 + x, [1.0, 3.0, 4.0 + x]);
            text += &row(t, "arm", 1, -20.0 - x, [-2.0, 0.0, 1.0]);
            text += &row(t, "blade-2", 0, 5.0, [0.5, -6.0, 8.0]);
        }
        // a line cut short by a kill
        text += "1.5,arm,0,0.05,1";
        std::fs::write(dir.path().join("beams.csv"), text).unwrap();
        let mut beams = vec![beam("arm", 3), beam("blade-2", 2)];
        let s = layout(dir.path(), &beams)
            .unwrap()
            .expect("beams.csv is read");
        assert_eq!(s.elements, vec![2, 1]);
        assert_eq!(s.floats_per_frame(), 9);
        let lay = FrameLayout {
            slots: 0,
            mesh_floats: 0,
            beam_floats: s.floats_per_frame(),
        };
        // frames 0 and 2 of three
        let kept = kept_frames(3, 2);
        assert_eq!(kept, vec![0, 2]);
        let mut block = read_bodies(dir.path(), &lay, &kept).unwrap();
        fill(&s, &kept, &mut block, &lay, &mut beams).unwrap();
        let b = lay.beam_offset();
        assert_eq!(
            &block.frame(0)[b..b + 9],
            &[10.0, 5.0, 1.0, -20.0, 1.0, -2.0, 5.0, 10.0, 0.5]
        );
        let m = (9.0f64 + 36.0).sqrt() as f32;
        assert_eq!(
            &block.frame(1)[b..b + 9],
            &[12.0, m, 1.0, -22.0, 1.0, -2.0, 5.0, 10.0, 0.5]
        );
        assert_eq!(
            (
                beams[0].elements,
                beams[0].n_max,
                beams[0].m_max,
                beams[0].t_max
            ),
            (2, 22.0, f64::from(m), 2.0)
        );
        assert_eq!(
            (
                beams[1].elements,
                beams[1].n_max,
                beams[1].m_max,
                beams[1].t_max
            ),
            (1, 5.0, 10.0, 0.5)
        );
    }

    #[test]
    fn a_beam_with_the_wrong_element_count_is_an_error_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let text = format!(
            "{HEAD}{}{}",
            row(0.0, "arm", 0, 1.0, [0.0; 3]),
            row(0.0, "arm", 1, 1.0, [0.0; 3])
        );
        std::fs::write(dir.path().join("beams.csv"), text).unwrap();
        let e = layout(dir.path(), &[beam("arm", 4)]).unwrap_err();
        assert!(
            e.0.contains("beams.csv") && e.0.contains("`arm` has 2 elements"),
            "{e}"
        );
    }

    #[test]
    fn no_beams_csv_means_no_colouring() {
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(layout(dir.path(), &[beam("arm", 3)]).unwrap(), None);
        std::fs::write(dir.path().join("beams.csv"), HEAD).unwrap();
        assert_eq!(layout(dir.path(), &[beam("arm", 3)]).unwrap(), None);
    }
}
