//! Meshes for the explicit method: the scene's meshes flattened into a
//! [`MeshLayout`] (nodes numbered once, one element block per mesh, lumped masses, the
//! boundary conditions and loads as node tables, the node → element-slot plan and the other
//! assembly strategies' plans, [`super::assembly_plan`]), and the critical step of the
//! central-difference method over all elements.
//!
//! - Lumped mass: each element's [`solid::lumped_masses`] summed at its nodes.
//! - `fix` and `displace`: per node component, the last condition written wins (`fix`
//!   after `displace` fixes; `displace` with a `free` component leaves that component as
//!   it was). 2-D meshes have their z components fixed.
//! - `traction` and `foundation`: on the set's faces, each face node gets its share
//!   `∫ N_a dA` of the face area (2-D: edge length × thickness; bars: the end's area);
//!   the foundation's normal is the area-weighted outward normal of the faces at the node.
//! - `body_force`: node `a` gets `b · ∫ N_a dV` (the lumped mass with ρ = 1).
//! - `tie`: left to [`crate::analysis::tie_model::apply`], which needs the bodies.
//! - Critical step: `h ≤ 2 / max_e ω_e` with `ω_e` the element bound of
//!   [`solid::max_frequency`] (Irons: the global highest frequency is below the largest
//!   element one). Congruent elements (a generated mesh's translates) are evaluated once.

use std::collections::HashMap;

use super::assembly_plan;
use crate::contract::mesh_layout::{
    ElementBlock, FoundationSpring, LoadGroup, MeshGlue, MeshLayout, Prescribed,
};
use crate::contract::mesh_plan::AssemblyOptions;
use crate::contract::scene::{
    ElementKind, Fn1, HourglassControl, Material, Mesh, MeshCondition, MeshFormulation,
    MeshIntegration, MeshKinematics,
};
use crate::kernels::solid::{self, Elastic, ElementOptions, MAX_NODES};

/// Why a mesh cannot be simulated.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("mesh '{mesh}': {reason}")]
pub struct MeshError {
    /// The mesh's name.
    pub mesh: String,
    /// What is wrong, with the element, its nodes and location where one is at fault.
    pub reason: String,
}

/// The elastic constants of a material, for the kernels.
pub fn elastic(m: &Material) -> Elastic {
    let lambda = m.e * m.nu / ((1.0 + m.nu) * (1.0 - 2.0 * m.nu));
    let mu = m.e / (2.0 * (1.0 + m.nu));
    Elastic {
        lambda,
        mu,
        e: m.e,
        rho: m.rho,
    }
}

/// The J2 plasticity constants of a material, for the kernels (`None`: elastic).
pub fn plastic(m: &Material) -> Option<solid::Plastic> {
    m.plastic.map(|p| solid::Plastic {
        yield_stress: p.yield_stress,
        hardening: p.hardening,
    })
}

/// How the elements of a block are evaluated: the block's thickness and plane mode, and
/// its [`MeshFormulation`] mapped to the kernels' [`solid::Integration`] and
/// [`solid::Kinematics`].
pub fn options(b: &ElementBlock) -> ElementOptions {
    let f = &b.formulation;
    ElementOptions {
        thickness: b.thickness,
        plane: match b.kind {
            ElementKind::Tri3PlaneStrain | ElementKind::Quad4PlaneStrain => solid::Plane::Strain,
            _ => solid::Plane::Stress,
        },
        kinematics: match f.kinematics {
            MeshKinematics::Small => solid::Kinematics::SmallStrain,
            MeshKinematics::Green => solid::Kinematics::TotalLagrangian,
        },
        integration: match f.integration {
            MeshIntegration::Full => solid::Integration::Full { bbar: false },
            MeshIntegration::Bbar => solid::Integration::Full { bbar: true },
            MeshIntegration::Reduced { hourglass } => {
                solid::Integration::Reduced(match hourglass {
                    HourglassControl::Viscous { coefficient } => {
                        solid::Hourglass::Viscous { coefficient }
                    }
                    HourglassControl::Stiffness { coefficient } => {
                        solid::Hourglass::Stiffness { coefficient }
                    }
                })
            }
        },
    }
}

/// Whether an element kind takes an `integration` choice (hex8 and quad4; the others have
/// one exact rule).
pub fn takes_integration(kind: ElementKind) -> bool {
    matches!(
        kind,
        ElementKind::Hex8 | ElementKind::Quad4PlaneStress | ElementKind::Quad4PlaneStrain
    )
}

/// Check a mesh's formulation against its element kind (the compiler reports the same
/// with spans; this guards scenes built by other means).
fn check_formulation(kind: ElementKind, f: &MeshFormulation) -> Result<(), String> {
    if f.integration != MeshIntegration::Full && !takes_integration(kind) {
        return Err(format!(
            "{:?} elements have one integration rule; only hex8 and quad4 take reduced or B-bar integration",
            kind
        ));
    }
    if let MeshIntegration::Reduced { hourglass } = f.integration {
        let c = match hourglass {
            HourglassControl::Viscous { coefficient }
            | HourglassControl::Stiffness { coefficient } => coefficient,
        };
        if !(c > 0.0 && c <= 1.0) {
            return Err(format!(
                "the hourglass coefficient must lie in (0, 1], got {c}"
            ));
        }
    }
    Ok(())
}

/// The reference coordinates of element `e` of block `b`.
pub fn element_x0(l: &MeshLayout, b: &ElementBlock, e: usize) -> [[f64; 3]; MAX_NODES] {
    let mut x = [[0.0; 3]; MAX_NODES];
    for (a, &n) in b.element_nodes(e).iter().enumerate() {
        x[a] = l.x0[n as usize];
    }
    x
}

/// A readable place of element `e` of block `b`: its index, nodes (mesh numbering) and
/// centroid.
pub fn element_place(l: &MeshLayout, b: &ElementBlock, e: usize) -> String {
    let nodes = b.element_nodes(e);
    let mut c = [0.0; 3];
    for &n in nodes {
        for (ck, xk) in c.iter_mut().zip(l.x0[n as usize]) {
            *ck += xk / nodes.len() as f64;
        }
    }
    // a rank's part names its elements and nodes by their numbers in the whole mesh
    let (id, node_id) = match &l.halo {
        Some(h) => (
            h.element_ids[b.first_element + e] as usize,
            nodes
                .iter()
                .map(|&n| h.node_ids[n as usize] as usize)
                .collect::<Vec<_>>(),
        ),
        None => (
            e,
            nodes.iter().map(|&n| n as usize - b.first_node).collect(),
        ),
    };
    let local: Vec<String> = node_id.iter().map(usize::to_string).collect();
    format!(
        "element {id} (nodes {}, centroid ({:.4}, {:.4}, {:.4}) m)",
        local.join(", "),
        c[0],
        c[1],
        c[2]
    )
}

/// Build the layout of `meshes` (empty input gives an empty layout), with the default
/// assembly strategy and plans ([`AssemblyOptions::default`]).
///
/// # Errors
/// A degenerate or inverted element (its index, nodes and centroid), a node index out of
/// range, a material or thickness that is not positive and finite.
pub fn build(meshes: &[Mesh]) -> Result<MeshLayout, MeshError> {
    build_with(meshes, AssemblyOptions::default())
}

/// [`build`] with the assembly strategy and the options of its plans chosen by the caller
/// (every strategy gives bitwise the same results; they differ in speed).
///
/// # Errors
/// As [`build`].
pub fn build_with(meshes: &[Mesh], assembly: AssemblyOptions) -> Result<MeshLayout, MeshError> {
    let mut l = MeshLayout::default();
    let mut first_slot = 0usize;
    let mut first_element = 0usize;
    for m in meshes {
        let err = |reason: String| MeshError {
            mesh: m.name.clone(),
            reason,
        };
        let mat = &m.material;
        if !(mat.e.is_finite() && mat.e > 0.0 && mat.rho.is_finite() && mat.rho > 0.0) {
            return Err(err(format!(
                "the material needs a positive, finite E and rho (E = {}, rho = {})",
                mat.e, mat.rho
            )));
        }
        if !(mat.nu > -1.0 && mat.nu < 0.5) {
            return Err(err(format!(
                "Poisson's ratio must lie in (-1, 0.5), got {}",
                mat.nu
            )));
        }
        if let Some(p) = &mat.plastic {
            if !(p.yield_stress.is_finite() && p.yield_stress > 0.0) {
                return Err(err(format!(
                    "the plastic yield stress must be positive and finite, got {}",
                    p.yield_stress
                )));
            }
            if !(p.hardening.is_finite() && p.hardening >= 0.0) {
                return Err(err(format!(
                    "the plastic hardening modulus must be zero or positive and finite, got {}",
                    p.hardening
                )));
            }
        }
        let thickness = if m.kind.dim() == 2 || m.kind == ElementKind::Bar2 {
            m.thickness
        } else {
            1.0
        };
        if !(thickness.is_finite() && thickness > 0.0) {
            return Err(err(format!(
                "the thickness (area for bars) must be positive and finite, got {thickness}"
            )));
        }
        check_formulation(m.kind, &m.formulation).map_err(err)?;
        let first_node = l.x0.len();
        let npe = m.kind.nodes();
        let mut conn = Vec::with_capacity(m.elements.len() * npe);
        for (e, el) in m.elements.iter().enumerate() {
            if el.len() != npe {
                return Err(err(format!(
                    "element {e} has {} nodes, a {:?} has {npe}",
                    el.len(),
                    m.kind
                )));
            }
            for &n in el {
                if n >= m.nodes.len() {
                    return Err(err(format!(
                        "element {e} refers to node {n}, but the mesh has {} nodes",
                        m.nodes.len()
                    )));
                }
                conn.push((first_node + n) as u32);
            }
        }
        l.x0.extend_from_slice(&m.nodes);
        l.mass.resize(l.x0.len(), 0.0);
        l.constrained.resize(l.x0.len(), [false; 3]);
        let block = ElementBlock {
            name: m.name.clone(),
            kind: m.kind,
            material: *mat,
            thickness,
            formulation: m.formulation,
            first_node,
            nodes: m.nodes.len(),
            conn,
            first_slot,
            first_element,
        };
        let opts = options(&block);
        // Shapes and masses.
        let mut volume_share = vec![0.0; m.nodes.len()];
        for e in 0..block.elements() {
            let x = element_x0(&l, &block, e);
            if let Err(d) = solid::shape_check(m.kind, &x[..npe]) {
                return Err(err(format!(
                    "{} is degenerate or inverted: its Jacobian determinant is {:.3e} at its node {} (check the node order: counter-clockwise in 2-D, hex8 bottom face counter-clockwise seen from above)",
                    element_place(&l, &block, e),
                    d.min_jacobian,
                    d.corner
                )));
            }
            let v = solid::lumped_masses(m.kind, &opts, 1.0, &x[..npe]);
            for (a, &n) in block.element_nodes(e).iter().enumerate() {
                volume_share[n as usize - first_node] += v[a];
            }
        }
        for (i, &v) in volume_share.iter().enumerate() {
            l.mass[first_node + i] = mat.rho * v;
        }
        let unused = volume_share.iter().filter(|&&v| v == 0.0).count();
        if unused > 0 {
            let i = volume_share.iter().position(|&v| v == 0.0).unwrap_or(0);
            return Err(err(format!(
                "{unused} node(s) belong to no element (the first is node {i} at ({:.4}, {:.4}, {:.4}) m): a node without mass cannot be integrated; remove it",
                m.nodes[i][0], m.nodes[i][1], m.nodes[i][2]
            )));
        }
        if m.kind.dim() == 2 {
            for c in &mut l.constrained[first_node..] {
                c[2] = true;
            }
        }
        check_sets(m).map_err(err)?;
        conditions(&mut l, m, &block, &volume_share).map_err(err)?;
        first_slot += block.elements() * npe;
        first_element += block.elements();
        l.blocks.push(block);
    }
    glues(&mut l, meshes)?;
    assembly_plan::build(&mut l, assembly);
    Ok(l)
}

/// The glues of every mesh into the layout's table, with global node numbers.
fn glues(l: &mut MeshLayout, meshes: &[Mesh]) -> Result<(), MeshError> {
    for (mi, m) in meshes.iter().enumerate() {
        for c in &m.conditions {
            let MeshCondition::Glue {
                set,
                mesh,
                other_set,
                traction,
            } = *c
            else {
                continue;
            };
            let err = |reason: String| MeshError {
                mesh: m.name.clone(),
                reason,
            };
            let Some(o) = meshes.get(mesh).filter(|_| mesh != mi) else {
                return Err(err(format!(
                    "a glue refers to mesh {mesh}, which is not another mesh of the scene"
                )));
            };
            let Some(os) = o.node_sets.get(other_set) else {
                return Err(err(format!(
                    "a glue refers to node set {other_set} of mesh '{}', which has {} sets",
                    o.name,
                    o.node_sets.len()
                )));
            };
            let s = &m.node_sets[set];
            if s.nodes.is_empty() || os.nodes.is_empty() {
                return Err(err(format!(
                    "glue of set '{}' to '{}.{}': a glued set needs nodes",
                    s.name, o.name, os.name
                )));
            }
            let global = |mesh: usize, nodes: &[usize]| -> Vec<u32> {
                let first = l.blocks[mesh].first_node;
                nodes.iter().map(|&n| (first + n) as u32).collect()
            };
            let glue = MeshGlue {
                mesh: m.name.clone(),
                set: s.name.clone(),
                other_mesh: o.name.clone(),
                other_set: os.name.clone(),
                nodes: global(mi, &s.nodes),
                other_nodes: global(mesh, &os.nodes),
                traction,
            };
            l.glues.push(glue);
        }
    }
    Ok(())
}

/// The node sets and conditions refer to what exists, and their values are finite (a scene
/// not made by the compiler, e.g. read from JSON, may not).
fn check_sets(m: &Mesh) -> Result<(), String> {
    let faces = m.kind.faces().len();
    for s in &m.node_sets {
        if let Some(&n) = s.nodes.iter().find(|&&n| n >= m.nodes.len()) {
            return Err(format!(
                "set '{}' refers to node {n}, but the mesh has {} nodes",
                s.name,
                m.nodes.len()
            ));
        }
        if let Some(&(e, f)) = s
            .faces
            .iter()
            .find(|&&(e, f)| e >= m.elements.len() || f >= faces)
        {
            return Err(format!(
                "set '{}' refers to face {f} of element {e}, but the mesh has {} elements of {faces} faces",
                s.name,
                m.elements.len()
            ));
        }
    }
    for c in &m.conditions {
        let set = match c {
            MeshCondition::Fixed { set }
            | MeshCondition::Displacement { set, .. }
            | MeshCondition::NodalLoad { set, .. }
            | MeshCondition::Traction { set, .. }
            | MeshCondition::Foundation { set, .. }
            | MeshCondition::Tie { set, .. }
            | MeshCondition::Glue { set, .. } => Some(*set),
            MeshCondition::BodyForce { .. } => None,
        };
        if let Some(set) = set {
            if set >= m.node_sets.len() {
                return Err(format!(
                    "a condition refers to node set {set}, but the mesh has {} sets",
                    m.node_sets.len()
                ));
            }
        }
        let finite = match c {
            MeshCondition::BodyForce { value } => value.iter().all(|v| v.is_finite()),
            MeshCondition::Foundation { modulus, .. } => modulus.is_finite() && *modulus >= 0.0,
            _ => true,
        };
        if !finite {
            return Err(
                "a body force or foundation modulus is not finite (or the modulus is negative)"
                    .into(),
            );
        }
        let fns: Vec<&Fn1> = match c {
            MeshCondition::Displacement { value, .. } => value.iter().flatten().collect(),
            MeshCondition::NodalLoad { value, .. } | MeshCondition::Traction { value, .. } => {
                value.iter().collect()
            }
            _ => Vec::new(),
        };
        for f in fns {
            crate::kernels::fn1::validate(f).map_err(|e| format!("a condition's function: {e}"))?;
        }
    }
    Ok(())
}

/// The boundary conditions and loads of one mesh into the layout's tables.
fn conditions(
    l: &mut MeshLayout,
    m: &Mesh,
    block: &ElementBlock,
    volume_share: &[f64],
) -> Result<(), String> {
    let first = block.first_node;
    // Per node component: None free, Some(None) fixed, Some(Some(f)) prescribed.
    let mut dof: HashMap<(usize, usize), Option<Fn1>> = HashMap::new();
    for c in &m.conditions {
        match c {
            MeshCondition::Fixed { set } => {
                for &n in &m.node_sets[*set].nodes {
                    for k in 0..3 {
                        dof.insert((n, k), None);
                    }
                }
            }
            MeshCondition::Displacement { set, value } => {
                for &n in &m.node_sets[*set].nodes {
                    for (k, f) in value.iter().enumerate() {
                        if let Some(f) = f {
                            dof.insert((n, k), Some(f.clone()));
                        }
                    }
                }
            }
            MeshCondition::NodalLoad { set, value } => {
                let nodes: Vec<u32> = m.node_sets[*set]
                    .nodes
                    .iter()
                    .map(|&n| (first + n) as u32)
                    .collect();
                l.loads.push(LoadGroup {
                    value: value.clone(),
                    weights: vec![1.0; nodes.len()],
                    nodes,
                });
            }
            MeshCondition::Traction { set, value } => {
                let shares = face_shares(l, m, block, *set)?;
                l.loads.push(LoadGroup {
                    value: value.clone(),
                    nodes: shares.iter().map(|s| s.0).collect(),
                    weights: shares.iter().map(|s| s.1).collect(),
                });
            }
            MeshCondition::BodyForce { value } => {
                if l.body_force.is_empty() {
                    l.body_force = vec![[0.0; 3]; l.x0.len()];
                }
                l.body_force.resize(l.x0.len(), [0.0; 3]);
                for (i, &v) in volume_share.iter().enumerate() {
                    for (f, b) in l.body_force[first + i].iter_mut().zip(value) {
                        *f += v * b;
                    }
                }
            }
            MeshCondition::Foundation { set, modulus } => {
                for (node, area, n) in face_shares(l, m, block, *set)? {
                    l.foundation.push(FoundationSpring {
                        node,
                        k: modulus * area,
                        n,
                    });
                }
            }
            // Ties need the bodies: `tie_model::apply` lays them out; glues need the other
            // mesh: `build_with` lays them out once every mesh has its nodes.
            MeshCondition::Tie { .. } | MeshCondition::Glue { .. } => {}
        }
    }
    let mut keys: Vec<_> = dof.into_iter().collect();
    keys.sort_by_key(|(k, _)| *k);
    for ((n, k), f) in keys {
        l.constrained[first + n][k] = true;
        if let Some(f) = f {
            l.prescribed.push(Prescribed {
                node: (first + n) as u32,
                dof: k as u8,
                value: f,
            });
        }
    }
    Ok(())
}

/// Per node of the set's faces: (global node, its share of the faces' area, the unit
/// area-weighted outward normal), in node order.
fn face_shares(
    l: &MeshLayout,
    m: &Mesh,
    block: &ElementBlock,
    set: usize,
) -> Result<Vec<(u32, f64, [f64; 3])>, String> {
    let s = &m.node_sets[set];
    if s.faces.is_empty() {
        return Err(format!(
            "set '{}' bounds no face (a traction or foundation acts on the boundary faces whose nodes all lie in the set)",
            s.name
        ));
    }
    let mut acc: HashMap<u32, (f64, [f64; 3])> = HashMap::new();
    for &(e, f) in &s.faces {
        let nodes = block.element_nodes(e);
        let face = m.kind.faces()[f];
        let x: Vec<[f64; 3]> = face.iter().map(|&a| l.x0[nodes[a] as usize]).collect();
        let (shares, normal) = face_integrals(block, face, &x, &element_x0(l, block, e));
        for (i, &a) in face.iter().enumerate() {
            let g = nodes[a];
            let entry = acc.entry(g).or_insert((0.0, [0.0; 3]));
            entry.0 += shares[i];
            for (s, nk) in entry.1.iter_mut().zip(normal) {
                *s += shares[i] * nk;
            }
        }
    }
    let mut out: Vec<_> = acc
        .into_iter()
        .map(|(g, (a, n))| {
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            let unit = if len > 0.0 {
                [n[0] / len, n[1] / len, n[2] / len]
            } else {
                [0.0; 3]
            };
            (g, a, unit)
        })
        .collect();
    out.sort_by_key(|s| s.0);
    Ok(out)
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn norm(a: [f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

/// A face's nodal area shares `∫ N_a dA` and its unit outward normal.
fn face_integrals(
    block: &ElementBlock,
    face: &[usize],
    x: &[[f64; 3]],
    ex: &[[f64; 3]; MAX_NODES],
) -> (Vec<f64>, [f64; 3]) {
    match x.len() {
        1 => {
            // A bar's end: the area, along the bar outward.
            let other = ex[1 - face[0]];
            let d = sub(x[0], other);
            let len = norm(d);
            (vec![block.thickness], [d[0] / len, d[1] / len, d[2] / len])
        }
        2 => {
            // An edge of a counter-clockwise 2-D element: outward normal (dy, -dx).
            let d = sub(x[1], x[0]);
            let len = norm(d);
            let a = len * block.thickness;
            (vec![a / 2.0; 2], [d[1] / len, -d[0] / len, 0.0])
        }
        3 => {
            let n = cross(sub(x[1], x[0]), sub(x[2], x[0]));
            let a = norm(n) / 2.0;
            (
                vec![a / 3.0; 3],
                [n[0] / (2.0 * a), n[1] / (2.0 * a), n[2] / (2.0 * a)],
            )
        }
        _ => {
            // A bilinear quadrilateral face, 2×2 Gauss points.
            let g = 1.0 / 3f64.sqrt();
            let mut shares = vec![0.0; 4];
            let mut total = [0.0; 3];
            for (xi, eta) in [(-g, -g), (g, -g), (g, g), (-g, g)] {
                let nn = [
                    (1.0 - xi) * (1.0 - eta) / 4.0,
                    (1.0 + xi) * (1.0 - eta) / 4.0,
                    (1.0 + xi) * (1.0 + eta) / 4.0,
                    (1.0 - xi) * (1.0 + eta) / 4.0,
                ];
                let dxi = [
                    -(1.0 - eta) / 4.0,
                    (1.0 - eta) / 4.0,
                    (1.0 + eta) / 4.0,
                    -(1.0 + eta) / 4.0,
                ];
                let deta = [
                    -(1.0 - xi) / 4.0,
                    -(1.0 + xi) / 4.0,
                    (1.0 + xi) / 4.0,
                    (1.0 - xi) / 4.0,
                ];
                let mut t1 = [0.0; 3];
                let mut t2 = [0.0; 3];
                for a in 0..4 {
                    for k in 0..3 {
                        t1[k] += dxi[a] * x[a][k];
                        t2[k] += deta[a] * x[a][k];
                    }
                }
                let n = cross(t1, t2);
                let da = norm(n);
                for a in 0..4 {
                    shares[a] += nn[a] * da;
                }
                for k in 0..3 {
                    total[k] += n[k];
                }
            }
            let len = norm(total);
            (shares, [total[0] / len, total[1] / len, total[2] / len])
        }
    }
}

/// The central-difference limit of a mesh system.
#[derive(Clone, Debug, PartialEq)]
pub struct CriticalStep {
    /// `2 / ω_max` (s).
    pub step: f64,
    /// The bound on the highest frequency (rad/s): the stiffest element's, raised by the
    /// stiffest node's foundation springs.
    pub omega: f64,
    /// The mesh whose element sets it.
    pub mesh: String,
    /// That element, its nodes and location (and the node whose foundation springs raise
    /// the bound, if any).
    pub place: String,
}

/// The critical step over all elements (`None` without elements).
pub fn critical_step(l: &MeshLayout) -> Option<CriticalStep> {
    let mut best: Option<(f64, usize, usize)> = None;
    for (bi, b) in l.blocks.iter().enumerate() {
        let opts = options(b);
        let mat = elastic(&b.material);
        let npe = b.kind.nodes();
        let mut cache: HashMap<Vec<i64>, f64> = HashMap::new();
        for e in 0..b.elements() {
            let x = element_x0(l, b, e);
            // Congruent translates share their frequency: key on the coordinates relative
            // to node 0, to 1e-9 of the element's size.
            let size = (1..npe)
                .map(|a| norm(sub(x[a], x[0])))
                .fold(0.0f64, f64::max)
                .max(f64::MIN_POSITIVE);
            let key: Vec<i64> = (1..npe)
                .flat_map(|a| (0..3).map(move |k| (a, k)))
                .map(|(a, k)| ((x[a][k] - x[0][k]) / size * 1e9).round() as i64)
                .chain(std::iter::once(size.to_bits() as i64 >> 20))
                .collect();
            let w = *cache
                .entry(key)
                .or_insert_with(|| solid::max_frequency(b.kind, &opts, &mat, &x[..npe]));
            if best.is_none_or(|(bw, _, _)| w > bw) {
                best = Some((w, bi, e));
            }
        }
    }
    let (w, bi, e) = best?;
    let b = &l.blocks[bi];
    let mut place = element_place(l, b, e);
    // Foundation springs add their `k/m` at a node to the lumped system's highest
    // eigenvalue at most: `ω_max² ≤ max_e ω_e² + max_n Σk_n/m_n` (the Rayleigh quotient
    // of `M^{-1/2}(K_elements + K_foundation)M^{-1/2}` splits, and the foundation's part
    // is diagonal up to its normals: each node's springs have norm at most Σk).
    let mut springs: Vec<(u32, f64)> = l.foundation.iter().map(|f| (f.node, f.k)).collect();
    springs.sort_unstable_by_key(|s| s.0);
    let mut stiffest: Option<(u32, f64)> = None;
    for run in springs.chunk_by(|a, b| a.0 == b.0) {
        let n = run[0].0;
        let k: f64 = run.iter().map(|s| s.1).sum();
        let w2 = k / l.mass[n as usize];
        if stiffest.is_none_or(|(_, best)| w2 > best) {
            stiffest = Some((n, w2));
        }
    }
    let mut omega = w;
    if let Some((n, wf2)) = stiffest {
        omega = (w * w + wf2).sqrt();
        let p = l.x0[n as usize];
        place = format!(
            "{place}, with the foundation springs of node {n} at ({:.4}, {:.4}, {:.4}) m (√(k/m) = {:.4e} rad/s)",
            p[0],
            p[1],
            p[2],
            wf2.sqrt()
        );
    }
    Some(CriticalStep {
        step: 2.0 / omega,
        omega,
        mesh: b.name.clone(),
        place,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contract::scene::Origin;

    fn cube(kind: ElementKind, formulation: MeshFormulation) -> Mesh {
        let (nodes, elements) = match kind {
            ElementKind::Hex8 => (
                vec![
                    [0.0, 0.0, 0.0],
                    [1.0, 0.0, 0.0],
                    [1.0, 1.0, 0.0],
                    [0.0, 1.0, 0.0],
                    [0.0, 0.0, 1.0],
                    [1.0, 0.0, 1.0],
                    [1.0, 1.0, 1.0],
                    [0.0, 1.0, 1.0],
                ],
                vec![(0..8).collect()],
            ),
            _ => (
                vec![
                    [0.0, 0.0, 0.0],
                    [1.0, 0.0, 0.0],
                    [0.0, 1.0, 0.0],
                    [0.0, 0.0, 1.0],
                ],
                vec![(0..4).collect()],
            ),
        };
        Mesh {
            name: "m".into(),
            kind,
            material: Material {
                e: 200e9,
                nu: 0.3,
                rho: 8000.0,
                plastic: None,
            },
            thickness: 1.0,
            nodes,
            elements,
            node_sets: Vec::new(),
            conditions: Vec::new(),
            formulation,
            origin: Origin::default(),
        }
    }

    /// The scene's formulation reaches the kernels' options; a formulation that does not
    /// fit the element kind, or a coefficient outside (0, 1], is refused.
    #[test]
    fn formulation_maps_to_kernel_options_and_is_checked() {
        let reduced = |hourglass| MeshFormulation {
            integration: MeshIntegration::Reduced { hourglass },
            kinematics: MeshKinematics::Green,
        };
        let stiff = reduced(HourglassControl::Stiffness { coefficient: 0.05 });
        let l = build(&[cube(ElementKind::Hex8, stiff)]).expect("valid");
        let o = options(&l.blocks[0]);
        assert_eq!(o.kinematics, solid::Kinematics::TotalLagrangian);
        assert_eq!(
            o.integration,
            solid::Integration::Reduced(solid::Hourglass::Stiffness { coefficient: 0.05 })
        );
        let bbar = MeshFormulation {
            integration: MeshIntegration::Bbar,
            kinematics: MeshKinematics::Small,
        };
        let o = options(
            &build(&[cube(ElementKind::Hex8, bbar)])
                .expect("valid")
                .blocks[0],
        );
        assert_eq!(o.integration, solid::Integration::Full { bbar: true });
        assert_eq!(o.kinematics, solid::Kinematics::SmallStrain);
        let o = options(
            &build(&[cube(ElementKind::Hex8, MeshFormulation::default())])
                .expect("valid")
                .blocks[0],
        );
        assert_eq!(o.integration, solid::Integration::Full { bbar: false });
        let err = build(&[cube(ElementKind::Tet4, bbar)]).expect_err("tet4 has one rule");
        assert!(err.reason.contains("hex8 and quad4"), "{err}");
        for c in [0.0, -0.1, 1.5, f64::NAN] {
            let f = reduced(HourglassControl::Viscous { coefficient: c });
            let err = build(&[cube(ElementKind::Hex8, f)]).expect_err("bad coefficient");
            assert!(err.reason.contains("(0, 1]"), "{err}");
        }
    }

    /// A plastic material reaches the kernels' constants and the layout; a yield stress
    /// that is not positive and finite, or a negative or non-finite hardening modulus, is
    /// refused (the compiler reports the same with spans; this guards other scenes).
    #[test]
    fn plastic_materials_are_checked() {
        use crate::contract::scene::Plasticity;
        let with = |yield_stress, hardening| {
            let mut m = cube(ElementKind::Hex8, MeshFormulation::default());
            m.material.plastic = Some(Plasticity {
                yield_stress,
                hardening,
            });
            m
        };
        let l = build(&[with(250e6, 1e9)]).expect("valid");
        assert!(l.is_plastic());
        assert_eq!(
            plastic(&l.blocks[0].material),
            Some(solid::Plastic {
                yield_stress: 250e6,
                hardening: 1e9
            })
        );
        assert!(
            !build(&[cube(ElementKind::Hex8, MeshFormulation::default())])
                .expect("valid")
                .is_plastic()
        );
        assert!(build(&[with(250e6, 0.0)]).is_ok(), "perfectly plastic");
        for y in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let err = build(&[with(y, 0.0)]).expect_err("bad yield stress");
            assert!(err.reason.contains("yield stress"), "{err}");
        }
        for h in [-1.0, f64::NAN, f64::INFINITY] {
            let err = build(&[with(250e6, h)]).expect_err("bad hardening");
            assert!(err.reason.contains("hardening"), "{err}");
        }
    }
}
