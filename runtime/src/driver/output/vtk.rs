//! The beams as a ParaView time series: one VTK XML PolyData file per frame
//! (`beams/beams_NNNNNN.vtp`) and a collection `beams.pvd` that indexes them by time.
//!
//! Each frame holds every beam's nodes as points and each element as a line cell (two
//! points), with the element's section quantities as cell data: `N` (axial, shear 2, shear 3;
//! N), `M` (torsion, bending 2, bending 3; N·m), `gamma` and `kappa` (strains, curvatures),
//! in the element's convected frame, and `beam` (the beam's index). Open `beams.pvd` in
//! ParaView; the Tube filter gives the beams a thickness. ASCII, so that the files are
//! readable and diffable; the results-at-scale issue replaces this by the one-file series.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::{Frame, OutputError, OutputErrorKind};
use crate::contract::system::Layout;

/// A ParaView time series: one file per frame in `OUTDIR/STEM/` and the collection
/// `OUTDIR/STEM.pvd` indexing them by time (shared by the beams' and the meshes' series).
pub(crate) struct PvdSeries {
    /// `OUTDIR/STEM/`.
    dir: PathBuf,
    /// `STEM`: the folder and the files' prefix.
    stem: &'static str,
    /// `OUTDIR/STEM.pvd`.
    pvd: PathBuf,
    /// The `<DataSet>` lines written so far.
    entries: String,
    /// Frames written.
    frames: u64,
}

impl PvdSeries {
    /// Create `OUTDIR/STEM/` and an empty `STEM.pvd`.
    pub(crate) fn create(outdir: &Path, stem: &'static str) -> Result<PvdSeries, OutputError> {
        let dir = outdir.join(stem);
        std::fs::create_dir_all(&dir)
            .map_err(|e| OutputError::io(OutputErrorKind::CreateDir, &dir, e))?;
        let s = PvdSeries {
            dir,
            stem,
            pvd: outdir.join(format!("{stem}.pvd")),
            entries: String::new(),
            frames: 0,
        };
        s.write_index()?;
        Ok(s)
    }

    /// Continue the series in `OUTDIR/STEM/` after its first `frames` frames (a restart):
    /// the index keeps the entries of those frames; later files are overwritten as the run
    /// writes them again.
    pub(crate) fn resume(
        outdir: &Path,
        stem: &'static str,
        frames: u64,
    ) -> Result<PvdSeries, OutputError> {
        let dir = outdir.join(stem);
        std::fs::create_dir_all(&dir)
            .map_err(|e| OutputError::io(OutputErrorKind::CreateDir, &dir, e))?;
        let pvd = outdir.join(format!("{stem}.pvd"));
        let text = std::fs::read_to_string(&pvd)
            .map_err(|e| OutputError::io(OutputErrorKind::Read, &pvd, e))?;
        let mut entries = String::new();
        let mut kept = 0u64;
        for line in text
            .lines()
            .filter(|l| l.trim_start().starts_with("<DataSet "))
        {
            if kept == frames {
                break;
            }
            entries.push_str(line);
            entries.push('\n');
            kept += 1;
        }
        if kept < frames {
            return Err(OutputError::io(
                OutputErrorKind::Read,
                &pvd,
                std::io::Error::other(format!(
                    "it lists {kept} frames, the checkpoint was taken after {frames}"
                )),
            ));
        }
        let s = PvdSeries {
            dir,
            stem,
            pvd,
            entries,
            frames,
        };
        s.write_index()?;
        Ok(s)
    }

    /// Frames in the series.
    pub(crate) fn frames(&self) -> u64 {
        self.frames
    }

    /// Write the next frame's file (`STEM_NNNNNN.EXT`) at time `t` and add it to the index
    /// (the index itself is written by [`PvdSeries::write_index`]).
    pub(crate) fn add(&mut self, t: f64, ext: &str, bytes: &[u8]) -> Result<(), OutputError> {
        let name = format!("{}_{:06}.{ext}", self.stem, self.frames);
        let path = self.dir.join(&name);
        std::fs::write(&path, bytes)
            .map_err(|e| OutputError::io(OutputErrorKind::Write, &path, e))?;
        let _ = writeln!(
            self.entries,
            "    <DataSet timestep=\"{t}\" part=\"0\" file=\"{}/{name}\"/>",
            self.stem
        );
        self.frames += 1;
        Ok(())
    }

    /// Rewrite the `.pvd` with the frames written so far (atomically: a temporary file,
    /// then a rename, so a reader or a killed run never sees half an index).
    pub(crate) fn write_index(&self) -> Result<(), OutputError> {
        let text = format!(
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\">\n  <Collection>\n{}  </Collection>\n</VTKFile>\n",
            self.entries
        );
        super::replace_file::replace_file(&self.pvd, text.as_bytes())
    }
}

/// The beams' `.vtp` files of a run and their `.pvd` index.
pub(crate) struct BeamSeries {
    /// The files and their index.
    series: PvdSeries,
    /// Scratch for one file.
    buf: String,
}

impl BeamSeries {
    /// Create `OUTDIR/beams/` and an empty `beams.pvd`.
    pub(crate) fn create(outdir: &Path) -> Result<BeamSeries, OutputError> {
        Ok(BeamSeries {
            series: PvdSeries::create(outdir, "beams")?,
            buf: String::new(),
        })
    }

    /// Continue `OUTDIR/beams/` after `frames` frames (a restart).
    pub(crate) fn resume(outdir: &Path, frames: u64) -> Result<BeamSeries, OutputError> {
        Ok(BeamSeries {
            series: PvdSeries::resume(outdir, "beams", frames)?,
            buf: String::new(),
        })
    }

    /// Frames written.
    pub(crate) fn frames(&self) -> u64 {
        self.series.frames()
    }

    /// Write the frame's `.vtp` file and add it to the index (the index itself is written
    /// by [`BeamSeries::write_index`]).
    pub(crate) fn write_frame(&mut self, layout: &Layout, f: &Frame) -> Result<(), OutputError> {
        let bl = &layout.beams;
        let points: usize = bl.beams.iter().map(|b| b.elements + 1).sum();
        let cells = bl.elements.len();
        let b = &mut self.buf;
        b.clear();
        b.push_str("<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"0.1\" byte_order=\"LittleEndian\">\n<PolyData>\n");
        let _ = writeln!(
            b,
            "<Piece NumberOfPoints=\"{points}\" NumberOfVerts=\"0\" NumberOfLines=\"{cells}\" NumberOfStrips=\"0\" NumberOfPolys=\"0\">"
        );
        b.push_str(
            "<Points>\n<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n",
        );
        for beam in &bl.beams {
            for k in 0..=beam.elements {
                let r = f.poses[beam.first_body + k].r;
                push_row(b, &[r.x, r.y, r.z]);
            }
        }
        b.push_str("</DataArray>\n</Points>\n<Lines>\n<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n");
        let mut first_point = 0;
        for beam in &bl.beams {
            for e in 0..beam.elements {
                let _ = writeln!(b, "{} {}", first_point + e, first_point + e + 1);
            }
            first_point += beam.elements + 1;
        }
        b.push_str("</DataArray>\n<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n");
        for c in 0..cells {
            let _ = writeln!(b, "{}", 2 * (c + 1));
        }
        b.push_str("</DataArray>\n</Lines>\n<CellData Scalars=\"beam\">\n");
        b.push_str("<DataArray type=\"Int32\" Name=\"beam\" format=\"ascii\">\n");
        for el in &bl.elements {
            let _ = writeln!(b, "{}", el.beam);
        }
        b.push_str("</DataArray>\n");
        for (k, what) in ["N", "M", "gamma", "kappa"].iter().enumerate() {
            let _ = writeln!(
                b,
                "<DataArray type=\"Float64\" Name=\"{what}\" NumberOfComponents=\"3\" format=\"ascii\">"
            );
            for row in &f.sections {
                let c = 1 + 3 * k;
                push_row(b, &row[c..c + 3]);
            }
            b.push_str("</DataArray>\n");
        }
        b.push_str("</CellData>\n</Piece>\n</PolyData>\n</VTKFile>\n");
        self.series.add(f.t, "vtp", b.as_bytes())
    }

    /// Rewrite `beams.pvd` with the frames written so far.
    pub(crate) fn write_index(&self) -> Result<(), OutputError> {
        self.series.write_index()
    }
}

/// Append the values of one data row, space-separated, in ryu's shortest round-trip form
/// (as the CSV files: `1.5e-9`, where `{}` would print `0.0000000015`), and a line end.
pub(crate) fn push_row(b: &mut String, xs: &[f64]) {
    for (i, &x) in xs.iter().enumerate() {
        if i > 0 {
            b.push(' ');
        }
        super::csv::push_f64(b, x);
    }
    b.push('\n');
}
