//! A readable summary of a scene: what `mbdc check` prints after the diagnostics.

use std::fmt;

use mbdc_runtime::scene::{
    BodyRef, ElementKind, ForceKind, HourglassControl, MeshCondition, MeshFormulation,
    MeshIntegration, MeshKinematics, MeshSolver, MethodSpec, ParamValue, Scene, Vec3,
};
use serde::Serialize;

use crate::kinematics;

/// One joint in the summary.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct JointSummary {
    /// Name.
    pub name: String,
    /// Kind keyword (`revolute`, ...).
    pub kind: &'static str,
    /// Constraint rows.
    pub rows: usize,
    /// Of which nonholonomic.
    pub nonholonomic: usize,
    /// First body (or `ground`).
    pub a: String,
    /// Second body (or `ground`).
    pub b: String,
    /// Largest position-level residual at t = 0 (m or rad).
    pub position_violation: f64,
    /// Largest velocity-level residual at t = 0 (m/s or rad/s).
    pub velocity_violation: f64,
}

/// Size of a beam or mesh.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PartSummary {
    /// Name.
    pub name: String,
    /// Element kind (`beam`, `quad4`, ...; `, plastic` after a mesh's kind when its
    /// material is plastic).
    pub kind: String,
    /// Nodes.
    pub nodes: usize,
    /// Elements.
    pub elements: usize,
    /// Node sets (meshes) or attachments (beams).
    pub sets: usize,
    /// The element formulation (meshes: quadrature, hourglass control, strain measure).
    pub formulation: Option<String>,
    /// Meshes: the sets tied to bodies, as `SET → BODY`.
    pub tied: Vec<String>,
    /// Meshes: the sets glued to other meshes' sets, as `SET → MESH.SET`.
    pub glued: Vec<String>,
}

/// What `mbdc check` reports about a valid scene.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CheckSummary {
    /// Model name.
    pub name: String,
    /// Body names.
    pub bodies: Vec<String>,
    /// Bodies not connected to ground through joints or beams.
    pub free_bodies: Vec<String>,
    /// Joints.
    pub joints: Vec<JointSummary>,
    /// Holonomic constraint rows (drivers included).
    pub holonomic_rows: usize,
    /// Nonholonomic constraint rows.
    pub nonholonomic_rows: usize,
    /// Grübler count: 6 · bodies − holonomic rows.
    pub dof: i64,
    /// Rank of the constraint Jacobian at t = 0 and its row count (`None`: not computed).
    pub jacobian_rank: Option<(usize, usize)>,
    /// Effects the scene uses.
    pub effects: Vec<&'static str>,
    /// Forces: name and kind.
    pub forces: Vec<(String, &'static str)>,
    /// Contact pair names.
    pub contacts: Vec<String>,
    /// Beams.
    pub beams: Vec<PartSummary>,
    /// Meshes.
    pub meshes: Vec<PartSummary>,
    /// The meshes' central-difference limit (s) and the element (and foundation node) that
    /// sets it; `None` without meshes or when the meshes cannot be built.
    pub mesh_critical_step: Option<(f64, String)>,
    /// Gravity.
    pub gravity: Option<Vec3>,
    /// Method with its options, as text.
    pub method: String,
    /// Time step, s.
    pub step: f64,
    /// Duration, s.
    pub duration: f64,
    /// Number of steps.
    pub steps: u64,
    /// Parameters.
    pub params: Vec<ParamValue>,
}

/// Names of bodies not connected to ground through joints, beams or meshes (a mesh
/// connects the bodies tied to it, the meshes glued to it, and ground when it has fixed or
/// displaced nodes).
pub fn free_bodies(scene: &Scene) -> Vec<usize> {
    let n = scene.bodies.len();
    // Union-find over bodies + ground (index n) + meshes (n + 1 + i).
    let mut parent: Vec<usize> = (0..=n + scene.meshes.len()).collect();
    fn find(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    let idx = |b: BodyRef| b.index().filter(|i| *i < n).unwrap_or(n);
    let union = |a: usize, b: usize, p: &mut Vec<usize>| {
        let (ra, rb) = (find(p, a), find(p, b));
        if ra != rb {
            p[ra] = rb;
        }
    };
    for j in &scene.joints {
        union(idx(j.a.body), idx(j.b.body), &mut parent);
    }
    for beam in &scene.beams {
        let ends: Vec<usize> = beam.attachments.iter().map(|a| idx(a.to.body)).collect();
        for w in ends.windows(2) {
            union(w[0], w[1], &mut parent);
        }
    }
    for (i, m) in scene.meshes.iter().enumerate() {
        let me = n + 1 + i;
        for c in &m.conditions {
            match c {
                MeshCondition::Tie { body, .. } => {
                    union(me, idx(BodyRef::Body(*body)), &mut parent)
                }
                MeshCondition::Glue { mesh, .. } if *mesh < scene.meshes.len() => {
                    union(me, n + 1 + mesh, &mut parent)
                }
                MeshCondition::Fixed { .. } => union(me, n, &mut parent),
                MeshCondition::Displacement { value, .. } if value.iter().any(Option::is_some) => {
                    union(me, n, &mut parent)
                }
                _ => {}
            }
        }
    }
    let g = find(&mut parent, n);
    (0..n).filter(|&i| find(&mut parent, i) != g).collect()
}

/// The method and its options as text: `staggered (epsilon 1e-6)`.
pub fn method_text(m: &MethodSpec) -> String {
    let opts = match m {
        MethodSpec::Staggered(o) => {
            let mut v = Vec::new();
            match o.epsilon {
                Some(e) => v.push(format!("epsilon {}", short(e))),
                None => v.push("epsilon default".into()),
            }
            if o.single_stage {
                v.push("single_stage".into());
            }
            if o.paper_literal {
                v.push("paper_literal".into());
            }
            v.push(format!("lint {:?}", o.lint).to_lowercase());
            if o.factorization != mbdc_runtime::scene::Factorization::Auto {
                v.push(format!("factorization {:?}", o.factorization).to_lowercase());
            }
            if o.beam_substeps > 1 {
                v.push(format!("beam_substeps {}", o.beam_substeps));
            }
            v
        }
        MethodSpec::Baumgarte { alpha, beta } => {
            vec![
                format!("alpha {}/s", short(*alpha)),
                format!("beta {}/s", short(*beta)),
            ]
        }
        MethodSpec::Penalty { epsilon } | MethodSpec::NaturalPartitioning { epsilon, .. } => {
            let mut v = vec![match epsilon {
                Some(e) => format!("epsilon {}", short(*e)),
                None => "epsilon default".into(),
            }];
            if let MethodSpec::NaturalPartitioning {
                tolerance,
                max_iterations,
                ..
            } = m
            {
                v.push(format!("tolerance {}", short(*tolerance)));
                if let Some(n) = max_iterations {
                    v.push(format!("max_iterations {n}"));
                }
            }
            v
        }
        MethodSpec::CoordinatePartitioning | MethodSpec::RungeKutta4 => vec![],
        MethodSpec::DormandPrince { tolerance } | MethodSpec::DormandPrince853 { tolerance } => {
            vec![format!("tolerance {}", short(*tolerance))]
        }
        MethodSpec::ImplicitTrapezoid {
            tolerance,
            max_iterations,
        } => {
            vec![
                format!("tolerance {}", short(*tolerance)),
                format!("max_iterations {max_iterations}"),
            ]
        }
        MethodSpec::StateTime {
            steps_per_element,
            window,
        } => {
            vec![
                format!("steps_per_element {steps_per_element}"),
                format!("window {window}"),
            ]
        }
    };
    if opts.is_empty() {
        m.name().to_string()
    } else {
        format!("{} ({})", m.name(), opts.join(", "))
    }
}

/// The meshes' linear solver and its options as text: `feti (subdomains 8, preconditioner
/// dirichlet, tolerance 1e-10, max_iterations 1000)`, `direct`.
pub fn mesh_solver_text(s: &MeshSolver) -> String {
    match s {
        MeshSolver::Direct => s.name().to_string(),
        MeshSolver::Feti(o) => format!(
            "{} (subdomains {}, preconditioner {}, tolerance {}, max_iterations {})",
            s.name(),
            o.subdomains,
            o.preconditioner.name(),
            short(o.tolerance),
            o.max_iterations
        ),
    }
}

fn element_text(k: ElementKind) -> &'static str {
    match k {
        ElementKind::Bar2 => "bar2",
        ElementKind::Tri3PlaneStress => "tri3 plane stress",
        ElementKind::Tri3PlaneStrain => "tri3 plane strain",
        ElementKind::Quad4PlaneStress => "quad4 plane stress",
        ElementKind::Quad4PlaneStrain => "quad4 plane strain",
        ElementKind::Tet4 => "tet4",
        ElementKind::Hex8 => "hex8",
    }
}

/// The formulation of a mesh's elements, as the language writes it.
fn formulation_text(kind: ElementKind, f: &MeshFormulation) -> String {
    let mut parts = Vec::new();
    if mbdc_runtime::mesh_model::takes_integration(kind) {
        parts.push(match f.integration {
            MeshIntegration::Full => "full integration".to_string(),
            MeshIntegration::Bbar => "bbar integration".to_string(),
            MeshIntegration::Reduced { hourglass } => format!(
                "reduced integration, hourglass {}",
                match hourglass {
                    HourglassControl::Viscous { coefficient } =>
                        format!("viscous({})", short(coefficient)),
                    HourglassControl::Stiffness { coefficient } =>
                        format!("stiffness({})", short(coefficient)),
                }
            ),
        });
    }
    parts.push(
        match f.kinematics {
            MeshKinematics::Small => "small strain",
            MeshKinematics::Green => "green strain",
        }
        .to_string(),
    );
    parts.join(", ")
}

/// Summarises a scene (computes constraint residuals and the Jacobian rank at t = 0).
pub fn summary(scene: &Scene) -> CheckSummary {
    let body_name = |b: BodyRef| match b {
        BodyRef::Ground => "ground".to_string(),
        BodyRef::Body(i) => scene
            .bodies
            .get(i)
            .map(|b| b.name.clone())
            .unwrap_or_else(|| format!("#{i}")),
    };
    let check = kinematics::initial_check(scene);
    let violations = check.as_ref().map_or_else(
        || vec![(0.0, 0.0); scene.joints.len()],
        |c| c.violations.clone(),
    );
    let joints: Vec<JointSummary> = scene
        .joints
        .iter()
        .zip(violations)
        .map(|(j, (p, v))| JointSummary {
            name: j.name.clone(),
            kind: j.kind.keyword(),
            rows: j.kind.rows(),
            nonholonomic: j.kind.nonholonomic_rows(),
            a: body_name(j.a.body),
            b: body_name(j.b.body),
            position_violation: p,
            velocity_violation: v,
        })
        .collect();
    let nonholonomic_rows: usize = scene
        .joints
        .iter()
        .map(|j| j.kind.nonholonomic_rows())
        .sum();
    let holonomic_rows = scene.constraint_rows() - nonholonomic_rows;
    let forces = scene
        .forces
        .iter()
        .map(|f| {
            let k = match &f.kind {
                ForceKind::Point { .. } => "point",
                ForceKind::Torque { .. } => "torque",
                ForceKind::Spring { stiffness, .. } if *stiffness == 0.0 => "damper",
                ForceKind::Spring { .. } => "spring",
                ForceKind::RotationalSpring { stiffness, .. } if *stiffness == 0.0 => {
                    "rotational_damper"
                }
                ForceKind::RotationalSpring { .. } => "rotational_spring",
            };
            (f.name.clone(), k)
        })
        .collect();
    let steps = if scene.simulate.step > 0.0 {
        (scene.simulate.duration / scene.simulate.step * (1.0 - 1e-12))
            .ceil()
            .min(u64::MAX as f64) as u64
    } else {
        0
    };
    CheckSummary {
        name: scene.name.clone(),
        bodies: scene.bodies.iter().map(|b| b.name.clone()).collect(),
        free_bodies: free_bodies(scene)
            .into_iter()
            .map(|i| scene.bodies[i].name.clone())
            .collect(),
        joints,
        holonomic_rows,
        nonholonomic_rows,
        dof: 6 * scene.bodies.len() as i64 - holonomic_rows as i64,
        jacobian_rank: check.as_ref().map(|c| c.rank),
        effects: mbdc_runtime::effects::Effects::of(scene).names(),
        forces,
        contacts: scene.contacts.iter().map(|c| c.name.clone()).collect(),
        beams: scene
            .beams
            .iter()
            .map(|b| PartSummary {
                name: b.name.clone(),
                kind: "beam".into(),
                nodes: b.nodes.len(),
                elements: b.nodes.len().saturating_sub(1),
                sets: b.attachments.len(),
                formulation: None,
                tied: Vec::new(),
                glued: Vec::new(),
            })
            .collect(),
        meshes: scene
            .meshes
            .iter()
            .map(|m| PartSummary {
                name: m.name.clone(),
                kind: match m.material.plastic {
                    Some(_) => format!("{}, plastic", element_text(m.kind)),
                    None => element_text(m.kind).into(),
                },
                nodes: m.nodes.len(),
                elements: m.elements.len(),
                sets: m.node_sets.len(),
                formulation: Some(formulation_text(m.kind, &m.formulation)),
                tied: m
                    .conditions
                    .iter()
                    .filter_map(|c| match c {
                        MeshCondition::Tie { set, body } => Some(format!(
                            "{} → {}",
                            m.node_sets.get(*set).map_or("?", |s| s.name.as_str()),
                            scene.bodies.get(*body).map_or("?", |b| b.name.as_str())
                        )),
                        _ => None,
                    })
                    .collect(),
                glued: m
                    .conditions
                    .iter()
                    .filter_map(|c| match c {
                        MeshCondition::Glue {
                            set,
                            mesh,
                            other_set,
                            ..
                        } => {
                            let other = scene.meshes.get(*mesh);
                            Some(format!(
                                "{} → {}.{}",
                                m.node_sets.get(*set).map_or("?", |s| s.name.as_str()),
                                other.map_or("?", |o| o.name.as_str()),
                                other
                                    .and_then(|o| o.node_sets.get(*other_set))
                                    .map_or("?", |s| s.name.as_str())
                            ))
                        }
                        _ => None,
                    })
                    .collect(),
            })
            .collect(),
        // (the implicit analyses have no step limit)
        mesh_critical_step: if scene.meshes.is_empty() || scene.simulate.mesh_method.is_implicit() {
            None
        } else {
            mbdc_runtime::mesh_model::build(&scene.meshes)
                .ok()
                .and_then(|l| mbdc_runtime::mesh_model::critical_step(&l))
                .map(|c| (c.step, format!("mesh '{}', {}", c.mesh, c.place)))
        },
        gravity: scene.gravity,
        method: match scene.simulate.mesh_method {
            m if m.is_implicit() => match scene.simulate.mesh_solver {
                MeshSolver::Direct => format!("mesh_method {}", m.name()),
                s => format!("mesh_method {}, solver {}", m.name(), mesh_solver_text(&s)),
            },
            _ => method_text(&scene.simulate.method),
        },
        step: scene.simulate.step,
        duration: scene.simulate.duration,
        steps,
        params: scene.params.clone(),
    }
}

fn list(names: &[String], max: usize) -> String {
    if names.is_empty() {
        return "none".into();
    }
    let mut s = names
        .iter()
        .take(max)
        .cloned()
        .collect::<Vec<_>>()
        .join(", ");
    if names.len() > max {
        s.push_str(&format!(", … ({} more)", names.len() - max));
    }
    s
}

/// A number in a short form: `0.15`, `1e-6`, `2.5e6`.
pub fn short(x: f64) -> String {
    if x != 0.0 && (x.abs() < 1e-3 || x.abs() >= 1e6) {
        let s = format!("{x:e}");
        s
    } else {
        format!("{x}")
    }
}

fn sci(x: f64) -> String {
    if x == 0.0 {
        "0".into()
    } else {
        format!("{x:.1e}")
    }
}

/// Seconds in a readable unit.
fn secs(x: f64) -> String {
    if x >= 1.0 || x == 0.0 {
        format!("{x} s")
    } else if x >= 1e-3 {
        format!("{} ms", (x * 1e3 * 1e9).round() / 1e9)
    } else {
        format!("{} us", (x * 1e6 * 1e9).round() / 1e9)
    }
}

impl fmt::Display for CheckSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "model {}", self.name)?;
        writeln!(
            f,
            "  bodies       {}: {}",
            self.bodies.len(),
            list(&self.bodies, 12)
        )?;
        writeln!(
            f,
            "  joints       {} ({} holonomic rows, {} nonholonomic)",
            self.joints.len(),
            self.holonomic_rows,
            self.nonholonomic_rows
        )?;
        let w = self
            .joints
            .iter()
            .take(20)
            .map(|j| j.name.chars().count())
            .max()
            .unwrap_or(0);
        for j in self.joints.iter().take(20) {
            let viol = if j.position_violation > 1e-9 || j.velocity_violation > 1e-9 {
                format!(
                    "  violation at t = 0: {} (position), {} (velocity)",
                    sci(j.position_violation),
                    sci(j.velocity_violation)
                )
            } else {
                String::new()
            };
            writeln!(
                f,
                "    {:<w$}  {:<18} {} – {}, {} row{}{viol}",
                j.name,
                j.kind,
                j.a,
                j.b,
                j.rows,
                if j.rows == 1 { "" } else { "s" },
                w = w
            )?;
        }
        if self.joints.len() > 20 {
            writeln!(f, "    … ({} more)", self.joints.len() - 20)?;
        }
        if !self.bodies.is_empty() {
            write!(
                f,
                "  DOF          {} (Grübler: 6·{} − {})",
                self.dof,
                self.bodies.len(),
                self.holonomic_rows
            )?;
            match self.jacobian_rank {
                Some((r, m)) if m > 0 => writeln!(f, "; Jacobian rank {r} of {m} rows at t = 0")?,
                _ => writeln!(f)?,
            }
        }
        writeln!(f, "  free bodies  {}", list(&self.free_bodies, 12))?;
        let forces: Vec<String> = self
            .forces
            .iter()
            .map(|(n, k)| format!("{n} ({k})"))
            .collect();
        writeln!(f, "  forces       {}", list(&forces, 12))?;
        if !self.contacts.is_empty() {
            writeln!(f, "  contacts     {}", list(&self.contacts, 12))?;
        }
        for b in &self.beams {
            writeln!(
                f,
                "  beam         {}: {} nodes, {} elements, {} attachments",
                b.name, b.nodes, b.elements, b.sets
            )?;
        }
        for m in &self.meshes {
            write!(
                f,
                "  mesh         {}: {}, {} nodes, {} elements, {} sets{}",
                m.name,
                m.kind,
                m.nodes,
                m.elements,
                m.sets,
                m.formulation
                    .as_ref()
                    .map_or(String::new(), |t| format!("; {t}"))
            )?;
            if !m.tied.is_empty() {
                write!(f, "; tied: {}", m.tied.join(", "))?;
            }
            if !m.glued.is_empty() {
                write!(f, "; glued: {}", m.glued.join(", "))?;
            }
            writeln!(f)?;
        }
        if let Some((limit, place)) = &self.mesh_critical_step {
            writeln!(
                f,
                "  critical     step {:.4e} s (the step is {:.3} of it), set by {place}",
                limit,
                self.step / limit
            )?;
        }
        if let Some(g) = self.gravity {
            writeln!(
                f,
                "  gravity      ({}, {}, {}) m/s^2",
                short(g[0]),
                short(g[1]),
                short(g[2])
            )?;
        }
        writeln!(
            f,
            "  effects      {}",
            if self.effects.is_empty() {
                "none".to_string()
            } else {
                self.effects.join(", ")
            }
        )?;
        writeln!(f, "  method       {}", self.method)?;
        writeln!(
            f,
            "  time         duration {}, step {} ({} steps)",
            secs(self.duration),
            secs(self.step),
            self.steps
        )?;
        if !self.params.is_empty() {
            let ps: Vec<String> = self
                .params
                .iter()
                .map(|p| {
                    format!(
                        "{} = {}{}",
                        p.name,
                        short(p.value),
                        if p.overridden { " (set)" } else { "" }
                    )
                })
                .collect();
            writeln!(f, "  params       {}", list(&ps, 12))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    /// A mesh's line names its formulation; the critical step is that of the stiffest
    /// element: a 2 × 1 grid of 0.5 m quad4 squares in plane stress, whose bound is
    /// computed by the runtime (`mesh_model::critical_step`), here against the step.
    #[test]
    fn a_mesh_scene_reports_its_formulation_and_critical_step() {
        let src = "model m {\n  material alu { E 70 GPa; nu 0.33; rho 2700 kg/m^3 }\n  mesh p {\n    element quad4\n    thickness 1 cm\n    integration reduced\n    hourglass stiffness(0.05)\n    generate rect(origin: (0, 0) m, size: (1, 0.5) m, divisions: (2, 1))\n    material alu\n  }\n  simulate { duration 1 ms; step 1 us }\n}\n";
        let loaded = crate::load_str("m.mbd", src, &[]);
        let scene = loaded.scene.expect("a scene");
        let s = super::summary(&scene);
        let (limit, place) = s.mesh_critical_step.clone().expect("a limit");
        let layout = mbdc_runtime::mesh_model::build(&scene.meshes).expect("a layout");
        let c = mbdc_runtime::mesh_model::critical_step(&layout).expect("elements");
        assert_eq!(limit, c.step);
        assert!(place.starts_with("mesh 'p', element 0"), "{place}");
        let text = s.to_string();
        assert!(
            text.contains("; reduced integration, hourglass stiffness(0.05), small strain"),
            "{text}"
        );
        assert!(text.contains("  critical     step "), "{text}");
    }

    /// `mbdc check` shows a FETI mesh solver with its options beside the implicit
    /// `mesh_method`, and nothing more for the direct one.
    #[test]
    fn the_method_line_shows_a_feti_solver() {
        let plate = |simulate: &str| {
            format!("model m {{\n  material alu {{ E 70 GPa; nu 0.33; rho 2700 kg/m^3 }}\n  mesh p {{\n    element quad4\n    thickness 1 cm\n    generate rect(origin: (0, 0) m, size: (1, 0.5) m, divisions: (4, 2))\n    material alu\n    set left = nodes(x == 0)\n    fix left\n  }}\n  simulate {{ duration 1 s; step 1 s; {simulate} }}\n}}\n")
        };
        let method = |simulate: &str| {
            let loaded = crate::load_str("m.mbd", &plate(simulate), &[]);
            let scene = loaded.scene.expect("a scene");
            let s = super::summary(&scene);
            assert!(
                s.to_string()
                    .contains(&format!("  method       {}\n", s.method)),
                "{s}"
            );
            s.method
        };
        assert_eq!(
            method("mesh_method static; solver feti { subdomains 8; preconditioner lumped; max_iterations 500 }"),
            "mesh_method static, solver feti (subdomains 8, preconditioner lumped, tolerance 1e-10, max_iterations 500)"
        );
        assert_eq!(
            method("mesh_method newmark; solver feti"),
            "mesh_method newmark, solver feti (subdomains 4, preconditioner dirichlet, tolerance 1e-10, max_iterations 1000)"
        );
        assert_eq!(
            method("mesh_method static; solver direct"),
            "mesh_method static"
        );
    }
}
