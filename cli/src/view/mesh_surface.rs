//! The meshes in the page: their boundary surface (faces of one element only; every
//! element of a 2-D mesh; bars as lines), and per shown frame the displacement of the
//! surface's nodes and the von Mises stress averaged to them from the elements around
//! each node, read from the run's `.vtu` series (`mesh.pvd` lists this run's files). The
//! faces of tetrahedra and hexahedra are the scene's own ([`ElementKind::faces`]: VTK's node
//! order is mbdc's).

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use serde::Serialize;

use mbdc_runtime::output::vtk_cell_type;
use mbdc_runtime::scene::{ElementKind, Scene};

use super::frames::{FrameBlock, FrameLayout};
use super::ViewError;

/// The VTK cell types the `.vtu` writer gives each element kind.
const VTK_LINE: u8 = vtk_cell_type(ElementKind::Bar2);
const VTK_TRIANGLE: u8 = vtk_cell_type(ElementKind::Tri3PlaneStress);
const VTK_QUAD: u8 = vtk_cell_type(ElementKind::Quad4PlaneStress);
const VTK_TETRA: u8 = vtk_cell_type(ElementKind::Tet4);
const VTK_HEXAHEDRON: u8 = vtk_cell_type(ElementKind::Hex8);

/// One mesh of the page (the JSON `meshes` entry).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub(crate) struct MeshView {
    name: String,
    /// Reference coordinates of the view nodes, `x y z` after each other.
    points: Vec<f64>,
    /// Surface triangles, indices into `points`.
    triangles: Vec<u32>,
    /// Bars, index pairs into `points`.
    lines: Vec<u32>,
    /// Largest nodal von Mises stress over the shown frames, Pa.
    vm_max: f64,
}

/// One mesh's surface and where its values sit in a frame.
#[derive(Clone, Debug, PartialEq)]
struct Surface {
    name: String,
    /// Global (vtu) node of each view node.
    nodes: Vec<u32>,
    reference: Vec<[f64; 3]>,
    triangles: Vec<u32>,
    lines: Vec<u32>,
    /// Cells around each view node (CSR over `cells`).
    first: Vec<u32>,
    cells: Vec<u32>,
}

/// The meshes' surfaces of a run.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct MeshGeometry {
    surfaces: Vec<Surface>,
    /// Nodes in the vtu files (all meshes).
    all_nodes: usize,
    /// Cells in the vtu files.
    all_cells: usize,
}

/// The files of the run's mesh series with their times, from `mesh.pvd` (none without one).
pub(crate) fn series_files(dir: &Path) -> Result<Vec<(f64, PathBuf)>, ViewError> {
    let pvd = dir.join("mesh.pvd");
    if !pvd.exists() {
        return Ok(Vec::new());
    }
    let text = read(&pvd)?;
    let doc = roxmltree::Document::parse(&text)
        .map_err(|e| ViewError(format!("{}: not a ParaView collection: {e}", pvd.display())))?;
    let mut out = Vec::new();
    for n in doc.descendants().filter(|n| n.has_tag_name("DataSet")) {
        let t = n.attribute("timestep").and_then(|t| t.parse::<f64>().ok());
        let f = n.attribute("file");
        match (t, f) {
            (Some(t), Some(f)) => out.push((t, dir.join(f))),
            _ => {
                return Err(ViewError(format!(
                    "{}: a DataSet without a timestep or file",
                    pvd.display()
                )))
            }
        }
    }
    // the index is rewritten as the run goes: a file it lists may be the last one, cut short
    // by a kill; such a file is refused when read
    Ok(out)
}

fn read(path: &Path) -> Result<String, ViewError> {
    std::fs::read_to_string(path)
        .map_err(|e| ViewError(format!("{}: cannot read: {e}", path.display())))
}

/// A parsed `.vtu` file of the run.
struct Vtu<'a> {
    path: &'a Path,
    doc: roxmltree::Document<'a>,
}

impl<'a> Vtu<'a> {
    fn parse(path: &'a Path, text: &'a str) -> Result<Vtu<'a>, ViewError> {
        let doc = roxmltree::Document::parse(text).map_err(|e| {
            ViewError(format!(
                "{}: not a whole VTK file (a run killed while writing it?): {e}",
                path.display()
            ))
        })?;
        Ok(Vtu { path, doc })
    }

    /// The values of the `DataArray` named `name` (`None`: the points' array).
    fn array(&self, name: Option<&str>) -> Result<Vec<f64>, ViewError> {
        let node = self
            .doc
            .descendants()
            .find(|n| {
                n.has_tag_name("DataArray")
                    && match name {
                        Some(name) => n.attribute("Name") == Some(name),
                        None => n.parent().is_some_and(|p| p.has_tag_name("Points")),
                    }
            })
            .ok_or_else(|| {
                ViewError(format!(
                    "{}: no `{}` array",
                    self.path.display(),
                    name.unwrap_or("Points")
                ))
            })?;
        node.text()
            .unwrap_or("")
            .split_ascii_whitespace()
            .map(|v| {
                v.parse::<f64>().map_err(|_| {
                    ViewError(format!(
                        "{}: `{v}` in the `{}` array is not a number",
                        self.path.display(),
                        name.unwrap_or("Points")
                    ))
                })
            })
            .collect()
    }
}

impl MeshGeometry {
    /// The surfaces of the meshes in the run's first `.vtu` file; names from the scene.
    pub fn read(path: &Path, scene: Option<&Scene>) -> Result<MeshGeometry, ViewError> {
        let text = read(path)?;
        let vtu = Vtu::parse(path, &text)?;
        let bad = |what: &str| ViewError(format!("{}: {what}", path.display()));
        let points = vtu.array(None)?;
        let conn = vtu.array(Some("connectivity"))?;
        let offsets = vtu.array(Some("offsets"))?;
        let types = vtu.array(Some("types"))?;
        let mesh_of = vtu.array(Some("mesh"))?;
        let all_nodes = points.len() / 3;
        let all_cells = types.len();
        if offsets.len() != all_cells || mesh_of.len() != all_cells {
            return Err(bad("the cell arrays differ in length"));
        }
        let meshes = mesh_of.iter().fold(0usize, |m, &i| m.max(i as usize + 1));
        let mut surfaces = Vec::with_capacity(meshes);
        for m in 0..meshes {
            let name = scene
                .and_then(|s| s.meshes.get(m))
                .map_or_else(|| format!("mesh {m}"), |s| s.name.clone());
            // faces of one element: key = sorted nodes, value = (count, face as written)
            let mut faces: HashMap<[u32; 4], (u32, [u32; 4], u8)> = HashMap::new();
            let mut tris: Vec<[u32; 3]> = Vec::new();
            let mut lines: Vec<[u32; 2]> = Vec::new();
            let mut start = 0usize;
            let mut cell_nodes: Vec<(u32, u32)> = Vec::new(); // (node, cell)
            for c in 0..all_cells {
                let end = offsets[c] as usize;
                if end < start || end > conn.len() {
                    return Err(bad("the cell offsets are out of order"));
                }
                let nodes: Vec<u32> = conn[start..end].iter().map(|&n| n as u32).collect();
                start = end;
                if mesh_of[c] as usize != m {
                    continue;
                }
                if nodes.iter().any(|&n| n as usize >= all_nodes) {
                    return Err(bad("a cell names a point that does not exist"));
                }
                cell_nodes.extend(nodes.iter().map(|&n| (n, c as u32)));
                let mut add_face = |f: &[usize]| {
                    let mut key = [u32::MAX; 4];
                    let mut face = [u32::MAX; 4];
                    for (k, &i) in f.iter().enumerate() {
                        key[k] = nodes[i];
                        face[k] = nodes[i];
                    }
                    key.sort_unstable();
                    faces
                        .entry(key)
                        .and_modify(|e| e.0 += 1)
                        .or_insert((1, face, f.len() as u8));
                };
                match (types[c] as u8, nodes.len()) {
                    (VTK_LINE, 2) => lines.push([nodes[0], nodes[1]]),
                    (VTK_TRIANGLE, 3) => tris.push([nodes[0], nodes[1], nodes[2]]),
                    (VTK_QUAD, 4) => {
                        tris.push([nodes[0], nodes[1], nodes[2]]);
                        tris.push([nodes[0], nodes[2], nodes[3]]);
                    }
                    (VTK_TETRA, 4) => ElementKind::Tet4.faces().iter().for_each(|f| add_face(f)),
                    (VTK_HEXAHEDRON, 8) => {
                        ElementKind::Hex8.faces().iter().for_each(|f| add_face(f))
                    }
                    (t, n) => {
                        return Err(bad(&format!(
                            "cell {c} has type {t} with {n} points, which mbdc does not write"
                        )))
                    }
                }
            }
            let mut once: Vec<([u32; 4], u8)> = faces
                .into_values()
                .filter(|(count, _, _)| *count == 1)
                .map(|(_, f, n)| (f, n))
                .collect();
            once.sort_unstable();
            for (f, n) in once {
                tris.push([f[0], f[1], f[2]]);
                if n == 4 {
                    tris.push([f[0], f[2], f[3]]);
                }
            }
            // view nodes: those on the surface and the bars, in first-use order
            let mut local: HashMap<u32, u32> = HashMap::new();
            let mut nodes = Vec::new();
            let mut index = |n: u32| {
                *local.entry(n).or_insert_with(|| {
                    nodes.push(n);
                    (nodes.len() - 1) as u32
                })
            };
            let triangles: Vec<u32> = tris.iter().flatten().map(|&n| index(n)).collect();
            let lines: Vec<u32> = lines.iter().flatten().map(|&n| index(n)).collect();
            let reference = nodes
                .iter()
                .map(|&n| {
                    let i = 3 * n as usize;
                    [points[i], points[i + 1], points[i + 2]]
                })
                .collect();
            // cells around each view node
            cell_nodes.retain(|(n, _)| local.contains_key(n));
            cell_nodes.sort_unstable_by_key(|&(n, _)| local[&n]);
            let mut first = vec![0u32; nodes.len() + 1];
            for (n, _) in &cell_nodes {
                first[local[n] as usize + 1] += 1;
            }
            for i in 0..nodes.len() {
                first[i + 1] += first[i];
            }
            surfaces.push(Surface {
                name,
                nodes,
                reference,
                triangles,
                lines,
                first,
                cells: cell_nodes.into_iter().map(|(_, c)| c).collect(),
            });
        }
        Ok(MeshGeometry {
            surfaces,
            all_nodes,
            all_cells,
        })
    }

    /// Floats per frame: per view node 3 displacements and 1 stress.
    pub fn floats_per_frame(&self) -> usize {
        self.surfaces.iter().map(|s| 4 * s.nodes.len()).sum()
    }

    fn view_nodes(&self) -> usize {
        self.surfaces.iter().map(|s| s.nodes.len()).sum()
    }

    /// Fill the meshes' values of the block's frames from their `.vtu` files (one per
    /// frame, in order).
    pub fn fill_frames(
        &self,
        files: &[&Path],
        block: &mut FrameBlock,
        layout: &FrameLayout,
    ) -> Result<(), ViewError> {
        let base = layout.mesh_offset();
        let vm_base = base + 3 * self.view_nodes();
        for (i, path) in files.iter().enumerate().take(block.frames()) {
            let text = read(path)?;
            let vtu = Vtu::parse(path, &text)?;
            let u = vtu.array(Some("displacement"))?;
            let vm = vtu.array(Some("von_mises"))?;
            if u.len() != 3 * self.all_nodes || vm.len() != self.all_cells {
                return Err(ViewError(format!(
                    "{}: not of the same mesh as the series' first file",
                    path.display()
                )));
            }
            let f = block.frame_mut(i);
            let mut at = 0usize;
            for s in &self.surfaces {
                for (k, &n) in s.nodes.iter().enumerate() {
                    let g = 3 * n as usize;
                    for c in 0..3 {
                        f[base + 3 * (at + k) + c] = u[g + c] as f32;
                    }
                    let cells = &s.cells[s.first[k] as usize..s.first[k + 1] as usize];
                    let mean = if cells.is_empty() {
                        0.0
                    } else {
                        cells.iter().map(|&c| vm[c as usize]).sum::<f64>() / cells.len() as f64
                    };
                    f[vm_base + at + k] = mean as f32;
                }
                at += s.nodes.len();
            }
        }
        Ok(())
    }

    /// Call `add` with every view node's position in every frame.
    pub fn for_each_point(
        &self,
        block: &FrameBlock,
        layout: &FrameLayout,
        add: &mut impl FnMut([f64; 3]),
    ) {
        let base = layout.mesh_offset();
        for i in 0..block.frames() {
            let f = block.frame(i);
            let mut at = 0usize;
            for s in &self.surfaces {
                for (k, r) in s.reference.iter().enumerate() {
                    let o = base + 3 * (at + k);
                    add([
                        r[0] + f[o] as f64,
                        r[1] + f[o + 1] as f64,
                        r[2] + f[o + 2] as f64,
                    ]);
                }
                at += s.nodes.len();
            }
        }
    }

    /// The meshes' JSON entries, with their largest stress over the block.
    pub fn views(&self, block: &FrameBlock, layout: &FrameLayout) -> Vec<MeshView> {
        let vm_base = layout.mesh_offset() + 3 * self.view_nodes();
        let mut at = 0usize;
        let mut out = Vec::with_capacity(self.surfaces.len());
        for s in &self.surfaces {
            let mut vm_max = 0.0f64;
            for i in 0..block.frames() {
                let f = block.frame(i);
                for k in 0..s.nodes.len() {
                    let v = f[vm_base + at + k] as f64;
                    if v.is_finite() {
                        vm_max = vm_max.max(v);
                    }
                }
            }
            at += s.nodes.len();
            out.push(MeshView {
                name: s.name.clone(),
                points: s.reference.iter().flatten().copied().collect(),
                triangles: s.triangles.clone(),
                lines: s.lines.clone(),
                vm_max,
            });
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `.vtu` of our writer's form with these cells (all in mesh 0 unless `mesh` says).
    fn vtu(points: usize, cells: &[(u8, Vec<u32>)], mesh: &[u32]) -> String {
        let mut s = String::from("<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\"><UnstructuredGrid><Piece>\n<Points><DataArray NumberOfComponents=\"3\">");
        for p in 0..points {
            s.push_str(&format!("{p} 0 0\n"));
        }
        s.push_str("</DataArray></Points><Cells><DataArray Name=\"connectivity\">");
        let mut off = 0;
        let mut offs = String::new();
        let mut types = String::new();
        for (t, n) in cells {
            for x in n {
                s.push_str(&format!("{x} "));
            }
            off += n.len();
            offs.push_str(&format!("{off} "));
            types.push_str(&format!("{t} "));
        }
        s.push_str(&format!("</DataArray><DataArray Name=\"offsets\">{offs}</DataArray><DataArray Name=\"types\">{types}</DataArray></Cells><CellData><DataArray Name=\"mesh\">"));
        for c in 0..cells.len() {
            s.push_str(&format!("{} ", mesh.get(c).copied().unwrap_or(0)));
        }
        s.push_str("</DataArray></CellData></Piece></UnstructuredGrid></VTKFile>\n");
        s
    }

    fn geometry(text: &str) -> MeshGeometry {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("m.vtu");
        std::fs::write(&p, text).unwrap();
        MeshGeometry::read(&p, None).unwrap()
    }

    #[test]
    fn two_hexes_have_ten_outer_faces() {
        // 2×1×1 hexes sharing the face 1-2-6-5 (nodes 0..11)
        let a = vec![0, 1, 2, 3, 4, 5, 6, 7];
        let b = vec![1, 8, 9, 2, 5, 10, 11, 6];
        let g = geometry(&vtu(12, &[(12, a), (12, b)], &[]));
        let s = &g.surfaces[0];
        assert_eq!(s.triangles.len(), 3 * 2 * 10);
        assert_eq!(s.nodes.len(), 12);
        // the shared face's nodes touch both cells, the others one
        let shared = s.nodes.iter().position(|&n| n == 1).unwrap();
        assert_eq!(s.first[shared + 1] - s.first[shared], 2);
        let alone = s.nodes.iter().position(|&n| n == 0).unwrap();
        assert_eq!(s.first[alone + 1] - s.first[alone], 1);
    }

    #[test]
    fn a_tetrahedron_is_its_four_faces_and_meshes_stay_apart() {
        let g = geometry(&vtu(
            7,
            &[(10, vec![0, 1, 2, 3]), (3, vec![4, 5]), (5, vec![4, 5, 6])],
            &[0, 1, 1],
        ));
        assert_eq!(g.surfaces.len(), 2);
        assert_eq!(g.surfaces[0].triangles.len(), 12);
        assert!(g.surfaces[0].lines.is_empty());
        assert_eq!(g.surfaces[1].triangles.len(), 3);
        assert_eq!(g.surfaces[1].lines.len(), 2);
        assert_eq!(g.surfaces[1].nodes.len(), 3);
        assert_eq!(g.floats_per_frame(), 4 * 4 + 4 * 3);
    }

    #[test]
    fn a_cut_file_is_refused_with_its_name() {
        let text = vtu(4, &[(10, vec![0, 1, 2, 3])], &[]);
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("cut.vtu");
        std::fs::write(&p, &text[..text.len() / 2]).unwrap();
        let e = MeshGeometry::read(&p, None).unwrap_err();
        assert!(
            e.0.contains("cut.vtu") && e.0.contains("not a whole VTK file"),
            "{e}"
        );
    }
}
