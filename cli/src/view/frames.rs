//! The shown frames: which of the run's frames, and the bodies' poses in them, read from
//! `bodies.csv` into the Float32 block of the page.
//!
//! A frame of the block is `t`, then per body slot `x y z qw qx qy qz`, then the meshes'
//! values (`mesh_surface`), then the beams' section quantities (`beam_sections`). Slots are
//! the columns of `bodies.csv`: the scene's bodies, then the beams' nodes.

use std::io::Read as _;
use std::path::Path;

use super::ViewError;
use crate::plot::data;

/// The shape of one frame in the block.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct FrameLayout {
    /// Body slots.
    pub slots: usize,
    /// Floats of the meshes' values.
    pub mesh_floats: usize,
    /// Floats of the beams' section quantities (3 per element: `N1`, `|M|`, `M1`).
    pub beam_floats: usize,
}

impl FrameLayout {
    /// Floats per frame.
    pub fn floats(&self) -> usize {
        1 + 7 * self.slots + self.mesh_floats + self.beam_floats
    }

    /// Where the meshes' values start in a frame.
    pub fn mesh_offset(&self) -> usize {
        1 + 7 * self.slots
    }

    /// Where the beams' section quantities start in a frame (after the meshes' values).
    pub fn beam_offset(&self) -> usize {
        self.mesh_offset() + self.mesh_floats
    }
}

/// The shown frames, frame after frame.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct FrameBlock {
    /// `frames × floats` values.
    pub values: Vec<f32>,
    floats: usize,
    /// The times are not known yet (no bodies.csv): the mesh series gives them.
    times_missing: bool,
}

impl FrameBlock {
    /// Number of frames.
    pub fn frames(&self) -> usize {
        self.values.len() / self.floats
    }

    /// Frame `i`.
    pub fn frame(&self, i: usize) -> &[f32] {
        &self.values[i * self.floats..(i + 1) * self.floats]
    }

    /// Frame `i`, to fill.
    pub fn frame_mut(&mut self, i: usize) -> &mut [f32] {
        &mut self.values[i * self.floats..(i + 1) * self.floats]
    }

    /// Whether the frames' times still have to be set.
    pub fn times_missing(&self) -> bool {
        self.times_missing
    }

    /// Set the frames' times, in order.
    pub fn set_times(&mut self, times: impl Iterator<Item = f64>) {
        for (i, t) in times.enumerate().take(self.frames()) {
            self.frame_mut(i)[0] = t as f32;
        }
        self.times_missing = false;
    }
}

/// The body slots: the names of the bodies in `bodies.csv` (none if the run wrote no
/// bodies.csv).
pub(crate) fn body_names(dir: &Path) -> Result<Vec<String>, ViewError> {
    let path = dir.join("bodies.csv");
    if !path.exists() {
        return Ok(Vec::new());
    }
    let head = data::header(&path).map_err(|e| ViewError(e.to_string()))?;
    let cols = mbdc_runtime::output::BODY_COLUMNS.len();
    if head.first().map(String::as_str) != Some("t") || (head.len() - 1) % cols != 0 {
        return Err(ViewError(format!(
            "{}: not a bodies.csv of mbdc (`t` and {cols} columns per body)",
            path.display()
        )));
    }
    Ok((0..(head.len() - 1) / cols)
        .map(|b| {
            let h = &head[1 + b * cols];
            h.strip_suffix(".x").unwrap_or(h).to_string()
        })
        .collect())
}

/// The frames the run wrote: complete data lines of bodies.csv, else the mesh series'
/// files.
pub(crate) fn count_frames(dir: &Path, mesh_frames: usize) -> Result<usize, ViewError> {
    let path = dir.join("bodies.csv");
    let n = if path.exists() {
        let mut f = std::fs::File::open(&path)
            .map_err(|e| ViewError(format!("{}: cannot read: {e}", path.display())))?;
        let mut buf = vec![0u8; 1 << 20];
        let mut lines = 0usize;
        loop {
            let k = f
                .read(&mut buf)
                .map_err(|e| ViewError(format!("{}: cannot read: {e}", path.display())))?;
            if k == 0 {
                break;
            }
            lines += buf[..k].iter().filter(|&&b| b == b'\n').count();
        }
        lines.saturating_sub(1)
    } else {
        mesh_frames
    };
    if n == 0 {
        return Err(ViewError(format!(
            "{}: the run wrote no frame to replay (no bodies.csv rows and no mesh series)",
            dir.display()
        )));
    }
    Ok(n)
}

/// Every `every`-th of `n` frames, and the last one (where a failed run stopped).
pub(crate) fn kept_frames(n: usize, every: usize) -> Vec<usize> {
    let mut k: Vec<usize> = (0..n).step_by(every.max(1)).collect();
    if n > 0 && k.last() != Some(&(n - 1)) {
        k.push(n - 1);
    }
    k
}

/// The block of the kept frames with their times and the bodies' poses (meshes' and beams'
/// values zero, to be filled).
pub(crate) fn read_bodies(
    dir: &Path,
    layout: &FrameLayout,
    kept: &[usize],
) -> Result<FrameBlock, ViewError> {
    let floats = layout.floats();
    let mut block = FrameBlock {
        values: vec![0.0; kept.len() * floats],
        floats,
        times_missing: true,
    };
    let path = dir.join("bodies.csv");
    if !path.exists() {
        return Ok(block);
    }
    let cols = mbdc_runtime::output::BODY_COLUMNS.len();
    let mut idx = vec![0usize];
    for b in 0..layout.slots {
        idx.extend((0..7).map(|c| 1 + b * cols + c));
    }
    let mut row = 0usize;
    let mut next = 0usize;
    let read = data::for_each_row(&path, &idx, |vals| {
        if next < kept.len() && kept[next] == row {
            let f = &mut block.values[next * floats..next * floats + idx.len()];
            for (d, v) in f.iter_mut().zip(vals) {
                *d = *v as f32;
            }
            next += 1;
        }
        row += 1;
    })
    .map_err(|e| ViewError(e.to_string()))?;
    // a last line cut short by a kill is not a frame: keep what was read
    block.values.truncate(next * floats);
    block.times_missing = false;
    let _ = read;
    Ok(block)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_last_frame_is_always_kept() {
        assert_eq!(kept_frames(10, 3), vec![0, 3, 6, 9]);
        assert_eq!(kept_frames(11, 3), vec![0, 3, 6, 9, 10]);
        assert_eq!(kept_frames(1, 5), vec![0]);
        assert_eq!(kept_frames(4, 1), vec![0, 1, 2, 3]);
    }
}
