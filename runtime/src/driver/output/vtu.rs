//! The finite-element meshes as a ParaView time series: one VTK XML UnstructuredGrid file
//! per frame (`mesh/mesh_NNNNNN.vtu`) and a collection `mesh.pvd` indexing them by time,
//! and `mesh_energy.csv`, the meshes' energy balance per frame.
//!
//! Each frame holds every mesh's nodes at their reference positions, with point data
//! `displacement` (m; ParaView's "Warp By Vector" shows the deformed shape) and `velocity`
//! (m/s), and every element as a cell (VTK line, triangle, quad, tetra, hexahedron) with
//! cell data `stress` and `strain` (6 components, Voigt xx yy zz yz xz xy; Pa and tensor
//! strain), `von_mises` (Pa) and `mesh` (the mesh's index); when a mesh is plastic, also
//! `plastic_strain` (6 components, tensor; bars: the axial one in xx) and
//! `equivalent_plastic_strain` (0 in the elements of elastic meshes). ASCII, like the
//! beams' series; the results-at-scale issue replaces it by a binary one-file series.

use std::fmt::Write as _;
use std::path::Path;

use super::vtk::{push_row, PvdSeries};
use super::{Frame, OutputError};
use crate::contract::scene::ElementKind;
use crate::contract::system::Layout;

/// Columns of `mesh_energy.csv` after `t`.
pub const MESH_ENERGY_COLUMNS: [&str; 10] = [
    "kinetic",
    "strain",
    "hourglass",
    "foundation",
    "external_work",
    "dissipated",
    "plastic",
    "tie_work",
    "half_step",
    "balance",
];

/// The VTK cell type of an element kind (the `types` array of a `.vtu` file).
pub const fn cell_type(kind: ElementKind) -> u8 {
    match kind {
        ElementKind::Bar2 => 3,
        ElementKind::Tri3PlaneStress | ElementKind::Tri3PlaneStrain => 5,
        ElementKind::Quad4PlaneStress | ElementKind::Quad4PlaneStrain => 9,
        ElementKind::Tet4 => 10,
        ElementKind::Hex8 => 12,
    }
}

/// The von Mises stress of a Voigt stress.
pub fn von_mises(s: &[f64; 6]) -> f64 {
    let (xx, yy, zz, yz, xz, xy) = (s[0], s[1], s[2], s[3], s[4], s[5]);
    (0.5 * ((xx - yy).powi(2) + (yy - zz).powi(2) + (zz - xx).powi(2))
        + 3.0 * (yz * yz + xz * xz + xy * xy))
        .sqrt()
}

/// The meshes' `.vtu` files of a run and their `.pvd` index.
pub(crate) struct MeshSeries {
    /// The files and their index.
    series: PvdSeries,
    /// The constant part of every file: points, cells, types, mesh index.
    geometry: String,
    /// Scratch for one file.
    buf: String,
}

impl MeshSeries {
    /// Create `OUTDIR/mesh/` and an empty `mesh.pvd`.
    pub(crate) fn create(outdir: &Path, layout: &Layout) -> Result<MeshSeries, OutputError> {
        Self::with_series(PvdSeries::create(outdir, "mesh")?, layout)
    }

    /// Continue `OUTDIR/mesh/` after `frames` frames (a restart).
    pub(crate) fn resume(
        outdir: &Path,
        layout: &Layout,
        frames: u64,
    ) -> Result<MeshSeries, OutputError> {
        Self::with_series(PvdSeries::resume(outdir, "mesh", frames)?, layout)
    }

    /// Frames written.
    pub(crate) fn frames(&self) -> u64 {
        self.series.frames()
    }

    fn with_series(series: PvdSeries, layout: &Layout) -> Result<MeshSeries, OutputError> {
        let ml = &layout.meshes;
        let mut g = String::new();
        g.push_str(
            "<Points>\n<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n",
        );
        for x in &ml.x0 {
            push_row(&mut g, x);
        }
        g.push_str("</DataArray>\n</Points>\n<Cells>\n<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n");
        for b in &ml.blocks {
            for e in 0..b.elements() {
                let nodes = b.element_nodes(e);
                for (i, n) in nodes.iter().enumerate() {
                    let _ = write!(g, "{}{n}", if i == 0 { "" } else { " " });
                }
                g.push('\n');
            }
        }
        g.push_str("</DataArray>\n<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n");
        let mut off = 0;
        for b in &ml.blocks {
            for _ in 0..b.elements() {
                off += b.kind.nodes();
                let _ = writeln!(g, "{off}");
            }
        }
        g.push_str("</DataArray>\n<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">\n");
        for b in &ml.blocks {
            let t = cell_type(b.kind);
            for _ in 0..b.elements() {
                let _ = writeln!(g, "{t}");
            }
        }
        g.push_str("</DataArray>\n</Cells>\n");
        Ok(MeshSeries {
            series,
            geometry: g,
            buf: String::new(),
        })
    }

    /// Write the frame's `.vtu` file and add it to the index (the index itself is written
    /// by [`MeshSeries::write_index`]).
    pub(crate) fn write_frame(&mut self, layout: &Layout, f: &Frame) -> Result<(), OutputError> {
        let ml = &layout.meshes;
        let b = &mut self.buf;
        b.clear();
        b.push_str("<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" byte_order=\"LittleEndian\">\n<UnstructuredGrid>\n");
        let _ = writeln!(
            b,
            "<Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">",
            ml.nodes(),
            ml.elements()
        );
        b.push_str(&self.geometry);
        b.push_str("<PointData Vectors=\"displacement\">\n");
        for (what, data) in [("displacement", &f.mesh_u), ("velocity", &f.mesh_v)] {
            let _ = writeln!(
                b,
                "<DataArray type=\"Float64\" Name=\"{what}\" NumberOfComponents=\"3\" format=\"ascii\">"
            );
            for x in data.iter() {
                push_row(b, x);
            }
            b.push_str("</DataArray>\n");
        }
        b.push_str("</PointData>\n<CellData Scalars=\"von_mises\">\n");
        for (what, data) in [("stress", &f.mesh_stress), ("strain", &f.mesh_strain)] {
            let _ = writeln!(
                b,
                "<DataArray type=\"Float64\" Name=\"{what}\" NumberOfComponents=\"6\" format=\"ascii\">"
            );
            for s in data.iter() {
                push_row(b, s);
            }
            b.push_str("</DataArray>\n");
        }
        if !f.mesh_plastic_strain.is_empty() {
            b.push_str("<DataArray type=\"Float64\" Name=\"plastic_strain\" NumberOfComponents=\"6\" format=\"ascii\">\n");
            for s in &f.mesh_plastic_strain {
                push_row(b, s);
            }
            b.push_str("</DataArray>\n<DataArray type=\"Float64\" Name=\"equivalent_plastic_strain\" format=\"ascii\">\n");
            for a in &f.mesh_equivalent_plastic_strain {
                push_row(b, &[*a]);
            }
            b.push_str("</DataArray>\n");
        }
        b.push_str("<DataArray type=\"Float64\" Name=\"von_mises\" format=\"ascii\">\n");
        for s in &f.mesh_stress {
            push_row(b, &[von_mises(s)]);
        }
        b.push_str("</DataArray>\n<DataArray type=\"Int32\" Name=\"mesh\" format=\"ascii\">\n");
        for (i, bl) in ml.blocks.iter().enumerate() {
            for _ in 0..bl.elements() {
                let _ = writeln!(b, "{i}");
            }
        }
        b.push_str("</DataArray>\n</CellData>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n");
        self.series.add(f.t, "vtu", b.as_bytes())
    }

    /// Rewrite `mesh.pvd` with the frames written so far.
    pub(crate) fn write_index(&self) -> Result<(), OutputError> {
        self.series.write_index()
    }
}
