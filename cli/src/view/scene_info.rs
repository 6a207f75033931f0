//! What the page draws besides the moving frames: each body's shape, the joints, springs,
//! contact planes and beams of the scene (`scene.json`).
//!
//! A body's shape is the uniform solid with its mass and inertia: a sphere where the three
//! principal moments are equal (`I = 2/5 m r²`), otherwise the box whose sides `a, b, c`
//! give them (`I_x = m (b² + c²)/12`, …, so `a² = 6 (I_y + I_z − I_x)/m`). A rod's box is
//! its length by `√3 r`; no side is drawn thinner than 2 % of the longest, so that a rod of
//! nearly zero radius stays visible. The inertia's off-diagonal terms are not drawn: a body
//! with a full inertia matrix gets the box of its diagonal.

use serde::Serialize;

use mbdc_runtime::math;
use mbdc_runtime::scene::{BodyRef, ForceKind, JointKind, Scene, Shape};

use super::frames::{FrameBlock, FrameLayout};
use super::mesh_surface::MeshGeometry;
use super::Highlight;

/// Colours of the bodies, in turn (Tableau 10 without its red, which marks failures).
const PALETTE: [&str; 9] = [
    "#4e79a7", "#f28e2b", "#76b7b2", "#59a14f", "#edc948", "#b07aa1", "#ff9da7", "#9c755f",
    "#bab0ac",
];

/// A body's drawn shape, in its body frame, centred at its mass centre.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
pub(crate) enum ShapeView {
    /// A box of these side lengths along the body axes, m.
    Box {
        /// Side lengths, m.
        size: [f64; 3],
    },
    /// A sphere, m.
    Sphere {
        /// Radius, m.
        radius: f64,
    },
    /// Not drawn as a body (a beam node: its beam draws it).
    None,
}

/// A body slot of the frames.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub(crate) struct BodyView {
    name: String,
    shape: ShapeView,
    color: &'static str,
}

/// A beam: a tube through its nodes' slots, its elements coloured by a section quantity.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub(crate) struct BeamView {
    /// The beam's name (as in `beams.csv`).
    pub name: String,
    /// The nodes' slots, in node order.
    pub nodes: Vec<usize>,
    radius: f64,
    /// Elements whose section quantities are in the frames (`nodes − 1`, or 0 when the run
    /// wrote no `beams.csv`).
    pub elements: usize,
    /// Largest |N1| (axial force, N) over the shown frames.
    pub n_max: f64,
    /// Largest |M| = √(M2² + M3²) (bending moment, N·m) over the shown frames.
    pub m_max: f64,
    /// Largest |M1| (torsion, N·m) over the shown frames.
    pub t_max: f64,
}

impl BeamView {
    /// A beam through the slots `nodes` drawn with tubes of `radius` (m), not coloured yet
    /// (no elements: `beam_sections` sets them).
    pub fn new(name: String, nodes: Vec<usize>, radius: f64) -> BeamView {
        BeamView {
            name,
            nodes,
            radius,
            elements: 0,
            n_max: 0.0,
            m_max: 0.0,
            t_max: 0.0,
        }
    }
}

/// A joint: a marker at its point on each side.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub(crate) struct JointView {
    name: String,
    kind: String,
    a: Option<usize>,
    pa: [f64; 3],
    b: Option<usize>,
    pb: [f64; 3],
    /// The joint axis in b's frame (world for ground), for joints with an axis.
    axis: Option<[f64; 3]>,
}

/// A spring between two points.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub(crate) struct SpringView {
    name: String,
    a: Option<usize>,
    pa: [f64; 3],
    b: Option<usize>,
    pb: [f64; 3],
}

/// A contact plane.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub(crate) struct PlaneView {
    name: String,
    body: Option<usize>,
    point: [f64; 3],
    normal: [f64; 3],
}

/// The scene's drawn parts.
#[derive(Clone, Debug, Default)]
pub(crate) struct SceneInfo {
    pub bodies: Vec<BodyView>,
    pub beams: Vec<BeamView>,
    pub joints: Vec<JointView>,
    pub springs: Vec<SpringView>,
    pub planes: Vec<PlaneView>,
    /// Bodies whose size is not known (no scene.json): spheres sized from the scene's extent.
    size_unknown: Vec<usize>,
    /// What cannot be shown.
    pub notes: Vec<String>,
}

/// Rotate `v` by the unit quaternion `q = [w, x, y, z]` (the runtime's rotation).
fn rotate(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
    math::rotate(&math::quat(q), &math::vec3(&v)).into()
}

/// The uniform solid with mass `m` and inertia diagonal `d` (see the module doc).
pub(crate) fn equivalent_shape(m: f64, d: [f64; 3]) -> ShapeView {
    let (lo, hi) = d.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &x| {
        (lo.min(x), hi.max(x))
    });
    if m.is_nan() || m <= 0.0 || hi.is_nan() || hi <= 0.0 {
        return ShapeView::Sphere { radius: 0.0 };
    }
    if hi - lo <= 1e-3 * hi {
        return ShapeView::Sphere {
            radius: (d.iter().sum::<f64>() / 3.0 / (0.4 * m)).sqrt(),
        };
    }
    let side = |i: usize| {
        let (j, k) = ((i + 1) % 3, (i + 2) % 3);
        (6.0 * (d[j] + d[k] - d[i]) / m).max(0.0).sqrt()
    };
    let mut size = [side(0), side(1), side(2)];
    let longest = size.iter().cloned().fold(0.0, f64::max);
    for s in &mut size {
        *s = s.max(0.02 * longest);
    }
    ShapeView::Box { size }
}

/// Whether a joint kind has an axis worth drawing (its attachment frames' z).
fn has_axis(kind: &JointKind) -> bool {
    matches!(
        kind,
        JointKind::Revolute
            | JointKind::Prismatic
            | JointKind::Cylindrical
            | JointKind::DriveAngle { .. }
            | JointKind::DriveDisplacement { .. }
    )
}

impl SceneInfo {
    /// The drawn parts of `scene` (or, without one, spheres for the body slots and beams
    /// recognized by their nodes' names `BEAM.node[k]`).
    pub fn build(scene: Option<&Scene>, slots: &[String]) -> SceneInfo {
        let mut info = SceneInfo::default();
        let slot = |r: BodyRef| r.index();
        let mut beam_of = vec![None::<usize>; slots.len()];
        // beams: the nodes' slots by name
        // per beam: name, (node number, slot) pairs, tube radius
        type Found = (String, Vec<(usize, usize)>, f64);
        let mut beams: Vec<Found> = Vec::new();
        for (i, name) in slots.iter().enumerate() {
            let Some((beam, rest)) = name.rsplit_once(".node[") else {
                continue;
            };
            let Some(k) = rest.strip_suffix(']').and_then(|k| k.parse::<usize>().ok()) else {
                continue;
            };
            let known = scene.is_none_or(|s| s.beams.iter().any(|b| b.name == beam));
            if !known {
                continue;
            }
            let at = match beams.iter().position(|b| b.0 == beam) {
                Some(p) => p,
                None => {
                    let radius = scene
                        .and_then(|s| s.beams.iter().find(|b| b.name == beam))
                        .map_or(0.0, |b| {
                            let s = &b.section;
                            if s.rho_a > 0.0 {
                                (2.0 * s.rho_i / s.rho_a).sqrt()
                            } else {
                                0.0
                            }
                        });
                    beams.push((beam.to_string(), Vec::new(), radius));
                    beams.len() - 1
                }
            };
            beams[at].1.push((k, i));
            beam_of[i] = Some(at);
        }
        for (name, mut nodes, radius) in beams {
            nodes.sort_unstable();
            info.beams.push(BeamView::new(
                name,
                nodes.into_iter().map(|(_, s)| s).collect(),
                radius,
            ));
        }
        let mut colour = 0usize;
        for (i, name) in slots.iter().enumerate() {
            let shape = if beam_of[i].is_some() {
                ShapeView::None
            } else if let Some(b) = scene.and_then(|s| s.bodies.get(i)) {
                equivalent_shape(b.mass, [b.inertia[0][0], b.inertia[1][1], b.inertia[2][2]])
            } else {
                info.size_unknown.push(i);
                ShapeView::Sphere { radius: 0.0 }
            };
            let color = PALETTE[colour % PALETTE.len()];
            if shape != ShapeView::None {
                colour += 1;
            }
            info.bodies.push(BodyView {
                name: name.clone(),
                shape,
                color,
            });
        }
        let Some(scene) = scene else {
            return info;
        };
        let in_slots = |r: BodyRef| r.index().is_none_or(|i| i < slots.len());
        for j in &scene.joints {
            if !in_slots(j.a.body) || !in_slots(j.b.body) {
                continue;
            }
            info.joints.push(JointView {
                name: j.name.clone(),
                kind: j.kind.keyword().into(),
                a: slot(j.a.body),
                pa: j.a.point,
                b: slot(j.b.body),
                pb: j.b.point,
                axis: has_axis(&j.kind).then(|| rotate(j.b.frame, [0.0, 0.0, 1.0])),
            });
        }
        // the beams' clamps and pins, named as the run names them
        for (bi, beam) in scene.beams.iter().enumerate() {
            let Some(view) = info.beams.iter().find(|b| b.name == beam.name) else {
                continue;
            };
            let _ = bi;
            let nodes = view.nodes.clone();
            for (k, at) in beam.attachments.iter().enumerate() {
                let Some(&node) = nodes.get(at.node) else {
                    continue;
                };
                if !in_slots(at.to.body) {
                    continue;
                }
                let word = if at.clamped { "clamp" } else { "pin" };
                info.joints.push(JointView {
                    name: format!("{}.{word}[{k}]", beam.name),
                    kind: if at.clamped { "fixed" } else { "spherical" }.into(),
                    a: slot(at.to.body),
                    pa: at.to.point,
                    b: Some(node),
                    pb: [0.0; 3],
                    axis: None,
                });
            }
        }
        for f in &scene.forces {
            if let ForceKind::Spring { a, b, .. } = &f.kind {
                if in_slots(a.body) && in_slots(b.body) {
                    info.springs.push(SpringView {
                        name: f.name.clone(),
                        a: slot(a.body),
                        pa: a.point,
                        b: slot(b.body),
                        pb: b.point,
                    });
                }
            }
        }
        for c in &scene.contacts {
            for (at, shape) in [&c.a, &c.b] {
                if matches!(shape, Shape::Plane) && in_slots(at.body) {
                    info.planes.push(PlaneView {
                        name: c.name.clone(),
                        body: slot(at.body),
                        point: at.point,
                        normal: rotate(at.frame, [0.0, 0.0, 1.0]),
                    });
                }
            }
        }
        info
    }

    /// What a failure's `where` names (`body 'NAME'`, `joint 'NAME'`, or a bare name): a
    /// body slot or a joint.
    pub fn find(&self, location: &str) -> Option<Highlight> {
        let quoted = |kind: &str| {
            location
                .strip_prefix(kind)
                .and_then(|r| r.strip_prefix(" '"))
                .and_then(|r| r.strip_suffix('\''))
        };
        let body = |name: &str| {
            self.bodies
                .iter()
                .position(|b| b.name == name)
                .map(|i| Highlight::Body { body: i })
        };
        let joint = |name: &str| {
            self.joints
                .iter()
                .position(|j| j.name == name)
                .map(|i| Highlight::Joint { joint: i })
        };
        if let Some(n) = quoted("body") {
            return body(n);
        }
        if let Some(n) = quoted("joint") {
            return joint(n);
        }
        body(location).or_else(|| joint(location))
    }

    /// Centre and size of everything drawn over the shown frames.
    pub fn bounds(
        &self,
        block: &FrameBlock,
        layout: &FrameLayout,
        meshes: Option<&MeshGeometry>,
    ) -> ([f64; 3], f64) {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        let mut add = |p: [f64; 3]| {
            if p.iter().all(|x| x.is_finite()) {
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
        };
        for i in 0..block.frames() {
            let f = block.frame(i);
            for s in 0..layout.slots {
                let o = 1 + 7 * s;
                add([f[o] as f64, f[o + 1] as f64, f[o + 2] as f64]);
            }
        }
        for j in &self.joints {
            if j.a.is_none() {
                add(j.pa);
            }
        }
        for p in &self.planes {
            if p.body.is_none() {
                add(p.point);
            }
        }
        if let Some(m) = meshes {
            m.for_each_point(block, layout, &mut add);
        }
        let mut size = 0.0f64;
        for b in &self.bodies {
            size = size.max(match b.shape {
                ShapeView::Box { size } => size.iter().cloned().fold(0.0, f64::max),
                ShapeView::Sphere { radius } => 2.0 * radius,
                ShapeView::None => 0.0,
            });
        }
        if !lo[0].is_finite() {
            return ([0.0; 3], size.max(1.0));
        }
        let center = [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]));
        let diag = (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f64>().sqrt();
        let extent = diag.max(size);
        (center, if extent > 0.0 { extent } else { 1.0 })
    }

    /// Size the bodies whose size is not known, now that the extent is.
    pub fn finish_shapes(&mut self, extent: f64) {
        for &i in &self.size_unknown {
            self.bodies[i].shape = ShapeView::Sphere {
                radius: 0.02 * extent,
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rod_is_a_box_its_length_long() {
        // rod of length 1 m, radius 5 cm, mass 2 kg along z: I_z = m r²/2, I_x = I_y = m(3r² + L²)/12
        let (m, r, l) = (2.0, 0.05, 1.0);
        let it = m * (3.0 * r * r + l * l) / 12.0;
        let ShapeView::Box { size } = equivalent_shape(m, [it, it, m * r * r / 2.0]) else {
            panic!("not a box");
        };
        assert!((size[2] - l).abs() < 1e-12, "{size:?}");
        assert!((size[0] - 3f64.sqrt() * r).abs() < 1e-12, "{size:?}");
        assert!((size[1] - 3f64.sqrt() * r).abs() < 1e-12, "{size:?}");
    }

    #[test]
    fn a_thin_rod_is_drawn_two_percent_of_its_length_thick() {
        let (m, r, l) = (1.0, 1e-4, 1.0);
        let it = m * (3.0 * r * r + l * l) / 12.0;
        let ShapeView::Box { size } = equivalent_shape(m, [it, it, m * r * r / 2.0]) else {
            panic!("not a box");
        };
        assert_eq!(size[0], 0.02 * size[2]);
    }

    #[test]
    fn a_sphere_is_a_sphere_of_its_radius() {
        let (m, r) = (3.0, 0.2);
        let i = 0.4 * m * r * r;
        assert_eq!(
            equivalent_shape(m, [i, i, i]),
            ShapeView::Sphere {
                radius: (i / (0.4 * m)).sqrt()
            }
        );
    }

    #[test]
    fn a_box_gives_back_its_sides() {
        let (m, s) = (5.0, [0.3, 0.2, 0.1]);
        let d = [
            m * (s[1] * s[1] + s[2] * s[2]) / 12.0,
            m * (s[0] * s[0] + s[2] * s[2]) / 12.0,
            m * (s[0] * s[0] + s[1] * s[1]) / 12.0,
        ];
        let ShapeView::Box { size } = equivalent_shape(m, d) else {
            panic!("not a box");
        };
        for k in 0..3 {
            assert!((size[k] - s[k]).abs() < 1e-12, "{size:?}");
        }
    }

    #[test]
    fn the_quaternion_rotates_z_onto_the_axis() {
        // 90° about x: z → −y
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let v = rotate([h, h, 0.0, 0.0], [0.0, 0.0, 1.0]);
        assert!((v[0]).abs() < 1e-15 && (v[1] + 1.0).abs() < 1e-15 && v[2].abs() < 1e-15);
    }
}
