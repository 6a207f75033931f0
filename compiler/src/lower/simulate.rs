//! Model-level settings: gravity, `simulate { ... }`, `reference { ... }`.

use mbdc_dsl::ast::{Expr, ItemKind};
use mbdc_runtime::scene::{
    BodyReference, Factorization, FetiOptions, FetiPreconditioner, Fn1, Gyroscopic, LintForm,
    MeshMethod, MeshSolver, MethodSpec, OutputFormat, OutputSpec, Reference, Relaxation, Simulate,
    StaggeredOptions,
};

use super::body::num;
use super::eval::ident_of;
use super::props::{one, Key};
use super::{EntKind, Lowerer, Reported, Scope, Single, R};
use crate::diag::{codes, Diagnostic};
use crate::units::Dim;
use crate::value::{Value, Var};

const SIM_KEYS: &[Key] = &[
    one("duration"),
    one("step"),
    one("method"),
    one("mesh_method"),
    one("solver"),
];
const OUTPUT_KEYS: &[Key] = &[
    one("every"),
    one("format"),
    one("partitions"),
    one("checkpoint_every"),
    one("checkpoint_seconds"),
    one("keep_checkpoints"),
    Key {
        name: "include",
        min: 1,
        max: 3,
        repeat: false,
    },
];

/// The options each method accepts.
pub(crate) fn method_options(name: &str) -> &'static [&'static str] {
    match name {
        "staggered" => &[
            "epsilon",
            "single_stage",
            "paper_literal",
            "lint",
            "gyroscopic",
            "factorization",
            "relaxation",
            "beam_substeps",
        ],
        "baumgarte" => &["alpha", "beta"],
        "penalty" => &["epsilon"],
        "implicit_trapezoid" => &["tolerance", "max_iterations"],
        "natural_partitioning" => &["epsilon", "tolerance", "max_iterations"],
        "dopri5" | "dop853" => &["tolerance"],
        "state_time" => &["steps_per_element", "window"],
        _ => &[],
    }
}

/// The names of the meshes' linear solvers (`simulate { solver NAME }`), in documentation
/// order.
pub(crate) const SOLVER_NAMES: &[&str] = &["direct", "feti"];

/// The options each mesh solver accepts.
pub(crate) fn solver_options(name: &str) -> &'static [&'static str] {
    match name {
        "feti" => &[
            "subdomains",
            "preconditioner",
            "tolerance",
            "max_iterations",
        ],
        _ => &[],
    }
}

/// The most subdomains `solver feti { subdomains P }` accepts.
pub(crate) const MAX_SUBDOMAINS: i64 = 100_000;

impl<'a> Lowerer<'a> {
    pub(crate) fn lower_gravity(&mut self, s: &Single<'a>) -> R<[f64; 3]> {
        let ItemKind::Prop { values, .. } = &s.item.kind else {
            return Err(Reported);
        };
        if values.len() != 1 {
            return Err(self.report(
                Diagnostic::error(
                    codes::WRONG_KIND,
                    format!("`gravity` takes one vector, found {} values", values.len()),
                )
                .primary(s.sc.file, s.item.span, "")
                .help("write `gravity (0, 0, -9.81) m/s^2`"),
            ));
        }
        self.vec3(&values[0], &s.sc, Dim::ACCELERATION, "gravity")
    }

    pub(crate) fn lower_simulate(&mut self, s: &Single<'a>) -> R<Simulate> {
        let sc = &s.sc;
        let ItemKind::Decl {
            body: Some(block),
            keyword,
            ..
        } = &s.item.kind
        else {
            return Err(Reported);
        };
        let props = self.props(
            block,
            sc,
            "`simulate`",
            SIM_KEYS,
            &["method", "solver", "output"],
        );
        let duration = match props.value("duration") {
            Some(e) => self.positive(e, sc, Dim::TIME, "the duration"),
            None => Err(self.missing(
                &props,
                "duration",
                "`simulate`",
                sc,
                keyword.span,
                "duration 1 s",
            )),
        };
        let step = match props.value("step") {
            Some(e) => self.positive(e, sc, Dim::TIME, "the time step"),
            None => Err(self.missing(&props, "step", "`simulate`", sc, keyword.span, "step 1 ms")),
        };
        let mut method: R<MethodSpec> = Ok(MethodSpec::default_for("staggered")
            .unwrap_or(MethodSpec::Staggered(StaggeredOptions::default())));
        let mut method_seen = props.get("method").map(|p| p.span);
        if let Some(p) = props.get("method") {
            method = self.method(&p.values[0], None, sc);
        }
        let mesh_method = match props.value("mesh_method") {
            Some(e) => self.keyword(
                e,
                sc,
                "mesh_method",
                &[
                    ("central_difference", MeshMethod::CentralDifference),
                    ("newmark", MeshMethod::Newmark),
                    ("static", MeshMethod::Static),
                ],
            ),
            None => Ok(MeshMethod::default()),
        };
        let mut mesh_solver: R<MeshSolver> = Ok(MeshSolver::default());
        let mut solver_seen = props.get("solver").map(|p| p.span);
        if let Some(p) = props.get("solver") {
            mesh_solver = self.solver(&p.values[0], None, sc);
        }
        let mut output: R<OutputSpec> = Ok(OutputSpec::default());
        let mut output_seen: Option<mbdc_dsl::ast::Span> = None;
        for item in &props.decls {
            let ItemKind::Decl {
                keyword,
                name,
                value,
                body,
            } = &item.kind
            else {
                continue;
            };
            match keyword.name.as_str() {
                "method" => {
                    if let Some(prev) = method_seen {
                        self.report(
                            Diagnostic::error(
                                codes::DUPLICATE_PROPERTY,
                                "`method` is given twice in `simulate`",
                            )
                            .primary(sc.file, item.span, "second")
                            .secondary(sc.file, prev, "first"),
                        );
                        method = Err(Reported);
                        continue;
                    }
                    method_seen = Some(item.span);
                    method = match (name, value) {
                        (Some(n), None) if n.indices.is_empty() => {
                            let e = Expr {
                                kind: mbdc_dsl::ast::ExprKind::Ident(n.base.clone()),
                                span: n.span,
                            };
                            self.method(&e, body.as_ref(), sc)
                        }
                        _ => Err(self.report(
                            Diagnostic::error(
                                codes::WRONG_KIND,
                                "write `method NAME` or `method NAME { OPTIONS }`",
                            )
                            .primary(sc.file, item.span, ""),
                        )),
                    };
                }
                "solver" => {
                    if let Some(prev) = solver_seen {
                        self.report(
                            Diagnostic::error(
                                codes::DUPLICATE_PROPERTY,
                                "`solver` is given twice in `simulate`",
                            )
                            .primary(sc.file, item.span, "second")
                            .secondary(sc.file, prev, "first"),
                        );
                        mesh_solver = Err(Reported);
                        continue;
                    }
                    solver_seen = Some(item.span);
                    mesh_solver = match (name, value) {
                        (Some(n), None) if n.indices.is_empty() => {
                            let e = Expr {
                                kind: mbdc_dsl::ast::ExprKind::Ident(n.base.clone()),
                                span: n.span,
                            };
                            self.solver(&e, body.as_ref(), sc)
                        }
                        _ => Err(self.report(
                            Diagnostic::error(
                                codes::WRONG_KIND,
                                "write `solver NAME` or `solver NAME { OPTIONS }`",
                            )
                            .primary(sc.file, item.span, ""),
                        )),
                    };
                }
                _ => {
                    if let Some(prev) = output_seen {
                        self.report(
                            Diagnostic::error(
                                codes::DUPLICATE_PROPERTY,
                                "`output` is given twice in `simulate`",
                            )
                            .primary(sc.file, item.span, "second")
                            .secondary(sc.file, prev, "first"),
                        );
                        output = Err(Reported);
                        continue;
                    }
                    output_seen = Some(item.span);
                    output = match (name, value, body) {
                        (None, None, Some(b)) => self.output(b, sc),
                        _ => Err(self.report(
                            Diagnostic::error(
                                codes::WRONG_KIND,
                                "write `output { every N; include bodies, energy, constraints }`",
                            )
                            .primary(sc.file, item.span, ""),
                        )),
                    };
                }
            }
        }
        let (duration, step, method, mesh_method, mesh_solver, output) = (
            duration?,
            step?,
            method?,
            mesh_method?,
            mesh_solver?,
            output?,
        );
        if step > duration {
            self.report(
                Diagnostic::warning(
                    codes::INVALID_VALUE,
                    format!(
                        "the step ({} s) is longer than the duration ({} s)",
                        num(step),
                        num(duration)
                    ),
                )
                .primary(
                    sc.file,
                    props.get("step").map(|p| p.span).unwrap_or(s.item.span),
                    "",
                )
                .help("the run will take a single step"),
            );
        }
        if duration / step > 1e12 {
            self.report(
                Diagnostic::warning(
                    codes::INVALID_VALUE,
                    format!("this run takes {:.3e} steps", duration / step),
                )
                .primary(
                    sc.file,
                    props.get("step").map(|p| p.span).unwrap_or(s.item.span),
                    "",
                ),
            );
        }
        Ok(Simulate {
            duration,
            step,
            method,
            mesh_method,
            mesh_solver,
            output,
        })
    }

    /// An implicit `mesh_method` (`newmark`, `static`) on a scene it cannot analyse: beside
    /// bodies, joints or beams (an error at `mesh_method`), or with a mesh whose stiffness is
    /// not linear (plastic, `strain green`, viscous hourglass control, ties; an error at
    /// `mesh_method` naming the mesh); without meshes, a warning.
    pub(crate) fn check_mesh_method(&mut self, s: &Single<'a>, scene: &mbdc_runtime::scene::Scene) {
        use mbdc_runtime::scene::{
            HourglassControl, MeshCondition, MeshIntegration, MeshKinematics,
        };
        let m = scene.simulate.mesh_method;
        if !m.is_implicit() {
            return;
        }
        let ItemKind::Decl {
            body: Some(block), ..
        } = &s.item.kind
        else {
            return;
        };
        let Some(span) = block.items.iter().find_map(|it| match &it.kind {
            ItemKind::Prop { key, .. } if key.name == "mesh_method" => Some(it.span),
            _ => None,
        }) else {
            return;
        };
        let name = m.name();
        let file = s.sc.file;
        if scene.meshes.is_empty() {
            self.report(
                Diagnostic::warning(
                    codes::INVALID_VALUE,
                    format!("`mesh_method {name}` has no effect: the model has no mesh"),
                )
                .primary(file, span, ""),
            );
            return;
        }
        let others = scene.bodies.len() + scene.joints.len() + scene.beams.len();
        if others > 0 {
            self.report(
                Diagnostic::error(
                    codes::INVALID_VALUE,
                    format!(
                        "`mesh_method {name}` analyses models of meshes alone, and this one has {} bodies, {} joints and {} beams",
                        scene.bodies.len(),
                        scene.joints.len(),
                        scene.beams.len()
                    ),
                )
                .primary(file, span, "")
                .help("use `mesh_method central_difference` (the default) to simulate meshes beside bodies, or analyse the mesh in a model of its own"),
            );
            return;
        }
        for mesh in &scene.meshes {
            let f = &mesh.formulation;
            let why = if mesh.material.plastic.is_some() {
                Some("its material is plastic: the stiffness changes as it yields")
            } else if f.kinematics == MeshKinematics::Green {
                Some("it has `strain green`: large rotations change the stiffness with the configuration")
            } else if matches!(
                f.integration,
                MeshIntegration::Reduced {
                    hourglass: HourglassControl::Viscous { .. }
                }
            ) {
                Some("its one-point elements have viscous hourglass control, which gives the hourglass modes no stiffness (use `hourglass stiffness(0.05)` or `integration full`)")
            } else if mesh
                .conditions
                .iter()
                .any(|c| matches!(c, MeshCondition::Tie { .. }))
            {
                Some("it is tied to a body")
            } else {
                None
            };
            if let Some(why) = why {
                self.report(
                    Diagnostic::error(
                        codes::INVALID_VALUE,
                        format!(
                            "`mesh_method {name}` solves with the linear elastic, small-strain stiffness, and mesh '{}' cannot use it: {why}",
                            mesh.name
                        ),
                    )
                    .primary(file, span, "")
                    .help("use `mesh_method central_difference` (the default), which simulates every mesh"),
                );
            }
        }
    }

    /// The glues against the analysis, each error at a `glue` item: glued meshes must be
    /// 2-D (the interface is a line; an error naming the mesh), and they are solved by
    /// `mesh_method static` with the direct solver for now (one error, at the first glue,
    /// pointing at `mesh_method` or `solver` when written).
    pub(crate) fn check_glues(
        &mut self,
        s: Option<&Single<'a>>,
        scene: &mbdc_runtime::scene::Scene,
    ) {
        let sites = self.glues.clone();
        let Some(first) = sites.first() else {
            return;
        };
        for site in &sites {
            let mut named: Vec<usize> = Vec::new();
            for mi in [site.mesh, site.other_mesh] {
                let Some(m) = scene.meshes.get(mi) else {
                    continue;
                };
                if m.kind.dim() == 2 || named.contains(&mi) {
                    continue;
                }
                named.push(mi);
                self.report(
                    Diagnostic::error(
                        codes::MESH,
                        format!(
                            "glues join 2-D meshes for now: the interface is a line, and mesh `{}` has {} elements",
                            m.name,
                            super::mesh::element_name(m.kind)
                        ),
                    )
                    .primary(site.file, site.span, "")
                    .help("glue meshes of tri3 or quad4 elements"),
                );
            }
        }
        // Where `mesh_method` and `solver` are written in `simulate`, if they are.
        let written = |key: &str| -> Option<(crate::source::FileId, mbdc_dsl::ast::Span)> {
            let s = s?;
            let ItemKind::Decl {
                body: Some(block), ..
            } = &s.item.kind
            else {
                return None;
            };
            block.items.iter().find_map(|it| match &it.kind {
                ItemKind::Prop { key: k, .. } if k.name == key => Some((s.sc.file, it.span)),
                ItemKind::Decl { keyword, .. } if keyword.name == key => Some((s.sc.file, it.span)),
                _ => None,
            })
        };
        let m = scene.simulate.mesh_method;
        if m != MeshMethod::Static {
            let mut d = Diagnostic::error(
                codes::INVALID_VALUE,
                "glued meshes are solved by `mesh_method static` for now; central_difference and newmark do not take glues yet",
            )
            .primary(first.file, first.span, "");
            let help = match written("mesh_method") {
                Some((f, sp)) => {
                    d = d.secondary(f, sp, format!("`mesh_method {}` here", m.name()));
                    "use `mesh_method static`"
                }
                None => {
                    "`central_difference` is the default: add `mesh_method static` to `simulate`"
                }
            };
            self.report(d.help(help));
        } else if let MeshSolver::Feti(_) = scene.simulate.mesh_solver {
            let mut d = Diagnostic::error(
                codes::INVALID_VALUE,
                "FETI does not take glues yet: glued meshes are solved by the direct solver",
            )
            .primary(first.file, first.span, "");
            if let Some((f, sp)) = written("solver") {
                d = d.secondary(f, sp, "FETI chosen here");
            }
            self.report(d.help("remove `solver feti` (the direct solver is the default)"));
        }
    }

    /// `solver feti` where it cannot act: with the explicit `mesh_method central_difference`
    /// (no linear solve) or on a model without meshes, a warning at `solver`; with more
    /// `subdomains` than the meshes have elements, an error at `subdomains`.
    pub(crate) fn check_mesh_solver(&mut self, s: &Single<'a>, scene: &mbdc_runtime::scene::Scene) {
        let MeshSolver::Feti(o) = scene.simulate.mesh_solver else {
            return;
        };
        let ItemKind::Decl {
            body: Some(block), ..
        } = &s.item.kind
        else {
            return;
        };
        let Some(item) = block.items.iter().find(|it| match &it.kind {
            ItemKind::Prop { key, .. } => key.name == "solver",
            ItemKind::Decl { keyword, .. } => keyword.name == "solver",
            _ => false,
        }) else {
            return;
        };
        let file = s.sc.file;
        if scene.meshes.is_empty() {
            self.report(
                Diagnostic::warning(
                    codes::NO_EFFECT,
                    "`solver feti` has no effect: the model has no mesh",
                )
                .primary(file, item.span, ""),
            );
            return;
        }
        let m = scene.simulate.mesh_method;
        if !m.is_implicit() {
            self.report(
                Diagnostic::warning(
                    codes::NO_EFFECT,
                    format!(
                        "`solver feti` has no effect with `mesh_method {}`, which solves no linear system: FETI serves `mesh_method static | newmark`",
                        m.name()
                    ),
                )
                .primary(file, item.span, "")
                .help("add `mesh_method static` or `mesh_method newmark`, or remove `solver feti`"),
            );
            return;
        }
        let elements: usize = scene.meshes.iter().map(|m| m.elements.len()).sum();
        if o.subdomains as usize > elements {
            // At `subdomains` when it is written, else at `solver` (the default).
            let written = match &item.kind {
                ItemKind::Decl {
                    body: Some(options),
                    ..
                } => options.items.iter().find_map(|it| match &it.kind {
                    ItemKind::Prop { key, .. } if key.name == "subdomains" => Some(it.span),
                    _ => None,
                }),
                _ => None,
            };
            let (n, p) = (scene.meshes.len(), o.subdomains);
            let meshes = if n == 1 {
                "mesh".to_string()
            } else {
                format!("{n} meshes")
            };
            let what = match written {
                Some(_) => format!("`subdomains {p}` is"),
                None => format!("`solver feti` tears the meshes into {p} subdomains by default,"),
            };
            self.report(
                Diagnostic::error(
                    codes::INVALID_VALUE,
                    format!(
                        "{what} more than the {elements} elements of the model's {meshes}: each subdomain needs at least one element"
                    ),
                )
                .primary(file, written.unwrap_or(item.span), "")
                .help(format!("use at most {elements} subdomains (`subdomains {elements}`)")),
            );
        }
    }

    fn method(
        &mut self,
        e: &Expr,
        block: Option<&'a mbdc_dsl::ast::Block>,
        sc: &Scope,
    ) -> R<MethodSpec> {
        let Some(name) = ident_of(e) else {
            return Err(self.report(
                Diagnostic::error(
                    codes::UNKNOWN_METHOD,
                    "a method is a name such as `staggered`",
                )
                .primary(sc.file, e.span, "")
                .help(format!("methods: {}", MethodSpec::NAMES.join(", "))),
            ));
        };
        let Some(mut spec) = MethodSpec::default_for(name) else {
            let help = match crate::suggest::closest(name, MethodSpec::NAMES.iter().copied()) {
                Some(s) => format!(
                    "did you mean `{s}`? Methods: {}",
                    MethodSpec::NAMES.join(", ")
                ),
                None => format!("methods: {}", MethodSpec::NAMES.join(", ")),
            };
            return Err(self.report(
                Diagnostic::error(codes::UNKNOWN_METHOD, format!("unknown method `{name}`"))
                    .primary(sc.file, e.span, "")
                    .help(help),
            ));
        };
        let Some(block) = block else { return Ok(spec) };
        let ok = self.options(
            block,
            sc,
            "method",
            name,
            method_options(name),
            |this, k, v, sc| this.set_option(&mut spec, k, v, sc),
        );
        if ok {
            Ok(spec)
        } else {
            Err(Reported)
        }
    }

    /// The mesh solver of `solver NAME` (`e` is NAME) with the options of its `block`
    /// (`solver feti { subdomains 8 }`), diagnosed as `method NAME { OPTIONS }` is.
    fn solver(
        &mut self,
        e: &Expr,
        block: Option<&'a mbdc_dsl::ast::Block>,
        sc: &Scope,
    ) -> R<MeshSolver> {
        let names = SOLVER_NAMES.join(", ");
        let Some(name) = ident_of(e) else {
            return Err(self.report(
                Diagnostic::error(codes::UNKNOWN_METHOD, "a solver is a name such as `feti`")
                    .primary(sc.file, e.span, "")
                    .help(format!("solvers: {names}")),
            ));
        };
        let mut solver = match name {
            "direct" => MeshSolver::Direct,
            "feti" => MeshSolver::Feti(FetiOptions::default()),
            _ => {
                let help = match crate::suggest::closest(name, SOLVER_NAMES.iter().copied()) {
                    Some(s) => format!("did you mean `{s}`? Solvers: {names}"),
                    None => format!("solvers: {names}"),
                };
                return Err(self.report(
                    Diagnostic::error(codes::UNKNOWN_METHOD, format!("unknown solver `{name}`"))
                        .primary(sc.file, e.span, "")
                        .help(help),
                ));
            }
        };
        let Some(block) = block else {
            return Ok(solver);
        };
        let ok = self.options(
            block,
            sc,
            "solver",
            name,
            solver_options(name),
            |this, k, v, sc| this.set_solver_option(&mut solver, k, v, sc),
        );
        if ok {
            Ok(solver)
        } else {
            Err(Reported)
        }
    }

    /// The options block of `what NAME { OPTIONS }` (`what` is `method` or `solver`): each
    /// item a `KEY VALUE` with a key among `valid`, given once, passed to `set`. Reports
    /// anything else (unknown options with the valid ones in a help line, duplicates, items
    /// that are not options, several values) and returns whether all were good.
    fn options(
        &mut self,
        block: &'a mbdc_dsl::ast::Block,
        sc: &Scope,
        what: &str,
        name: &str,
        valid: &[&str],
        mut set: impl FnMut(&mut Self, &str, &Expr, &Scope) -> R<()>,
    ) -> bool {
        let mut ok = true;
        let mut seen: Vec<(&str, mbdc_dsl::ast::Span)> = Vec::new();
        for it in &block.items {
            let ItemKind::Prop { key, values, .. } = &it.kind else {
                self.report(
                    Diagnostic::error(
                        codes::UNKNOWN_METHOD_OPTION,
                        format!("{what} options are written `NAME VALUE`"),
                    )
                    .primary(sc.file, it.span, ""),
                );
                ok = false;
                continue;
            };
            let k = key.name.as_str();
            if !valid.contains(&k) {
                let help = if valid.is_empty() {
                    format!("`{name}` takes no options")
                } else {
                    match crate::suggest::closest(k, valid.iter().copied()) {
                        Some(s) => {
                            format!("did you mean `{s}`? `{name}` takes: {}", valid.join(", "))
                        }
                        None => format!("`{name}` takes: {}", valid.join(", ")),
                    }
                };
                self.report(
                    Diagnostic::error(
                        codes::UNKNOWN_METHOD_OPTION,
                        format!("unknown option `{k}` of {what} `{name}`"),
                    )
                    .primary(sc.file, key.span, "unknown option")
                    .help(help),
                );
                ok = false;
                continue;
            }
            if let Some((_, prev)) = seen.iter().find(|(n, _)| *n == k) {
                let prev = *prev;
                self.report(
                    Diagnostic::error(
                        codes::DUPLICATE_PROPERTY,
                        format!("option `{k}` is given twice"),
                    )
                    .primary(sc.file, it.span, "second")
                    .secondary(sc.file, prev, "first"),
                );
                ok = false;
                continue;
            }
            seen.push((k, it.span));
            if values.len() != 1 {
                self.report(
                    Diagnostic::error(codes::WRONG_KIND, format!("option `{k}` takes one value"))
                        .primary(sc.file, it.span, ""),
                );
                ok = false;
                continue;
            }
            ok &= set(self, k, &values[0], sc).is_ok();
        }
        ok
    }

    fn set_solver_option(
        &mut self,
        solver: &mut MeshSolver,
        k: &str,
        v: &Expr,
        sc: &Scope,
    ) -> R<()> {
        let MeshSolver::Feti(o) = solver else {
            return Err(Reported);
        };
        match k {
            "subdomains" => {
                let n = self.int(v, sc, "subdomains")?;
                if !(1..=MAX_SUBDOMAINS).contains(&n) {
                    let msg = if n < 1 {
                        format!("subdomains must be a positive integer, found {n}")
                    } else {
                        format!("subdomains must be at most {MAX_SUBDOMAINS}, found {n}")
                    };
                    return Err(self.report(
                        Diagnostic::error(codes::INVALID_VALUE, msg).primary(sc.file, v.span, ""),
                    ));
                }
                o.subdomains = n as u32;
            }
            "preconditioner" => {
                o.preconditioner = self.keyword(
                    v,
                    sc,
                    "preconditioner",
                    &[
                        ("dirichlet", FetiPreconditioner::Dirichlet),
                        ("lumped", FetiPreconditioner::Lumped),
                        ("none", FetiPreconditioner::None),
                    ],
                )?
            }
            "tolerance" => {
                let t = self.positive(v, sc, Dim::NONE, "a tolerance")?;
                if t >= 1.0 {
                    return Err(self.report(
                        Diagnostic::error(
                            codes::INVALID_VALUE,
                            format!("a tolerance must be less than 1, found {}", num(t)),
                        )
                        .primary(sc.file, v.span, "")
                        .help("it is the factor by which the interface residual must fall, such as 1e-10"),
                    ));
                }
                o.tolerance = t;
            }
            "max_iterations" => o.max_iterations = self.count(v, sc, "max_iterations")?,
            _ => return Err(Reported),
        }
        Ok(())
    }

    /// A method option that is one of a few words: the value of the word `v` names, or an
    /// error at `v` listing the words ("`option` is `a`, `b` or `c`").
    fn keyword<T: Copy>(
        &mut self,
        v: &Expr,
        sc: &Scope,
        option: &str,
        words: &[(&str, T)],
    ) -> R<T> {
        if let Some(&(_, t)) = ident_of(v).and_then(|w| words.iter().find(|(k, _)| *k == w)) {
            return Ok(t);
        }
        let list: Vec<String> = words.iter().map(|(k, _)| format!("`{k}`")).collect();
        let (last, rest) = list.split_last().expect("at least one word");
        let msg = if rest.is_empty() {
            format!("`{option}` is {last}")
        } else {
            format!("`{option}` is {} or {last}", rest.join(", "))
        };
        Err(self.report(Diagnostic::error(codes::WRONG_KIND, msg).primary(sc.file, v.span, "")))
    }

    fn set_option(&mut self, spec: &mut MethodSpec, k: &str, v: &Expr, sc: &Scope) -> R<()> {
        match (spec, k) {
            (MethodSpec::Staggered(o), "epsilon") => o.epsilon = Some(self.epsilon(v, sc)?),
            (MethodSpec::Staggered(o), "single_stage") => o.single_stage = self.boolean(v, sc)?,
            (MethodSpec::Staggered(o), "paper_literal") => o.paper_literal = self.boolean(v, sc)?,
            (MethodSpec::Staggered(o), "lint") => {
                o.lint = self.keyword(
                    v,
                    sc,
                    "lint",
                    &[("exact", LintForm::Exact), ("midpoint", LintForm::Midpoint)],
                )?
            }
            (MethodSpec::Baumgarte { alpha, .. }, "alpha") => {
                *alpha = self.nonneg(v, sc, Dim::FREQUENCY, "alpha")?
            }
            (MethodSpec::Baumgarte { beta, .. }, "beta") => {
                *beta = self.nonneg(v, sc, Dim::FREQUENCY, "beta")?
            }
            (MethodSpec::Penalty { epsilon }, "epsilon") => *epsilon = Some(self.epsilon(v, sc)?),
            (MethodSpec::Staggered(o), "gyroscopic") => {
                o.gyroscopic = self.keyword(
                    v,
                    sc,
                    "gyroscopic",
                    &[
                        ("midpoint", Gyroscopic::Midpoint),
                        ("synchronous", Gyroscopic::Synchronous),
                        ("lagged", Gyroscopic::Lagged),
                    ],
                )?
            }
            (MethodSpec::Staggered(o), "relaxation") => {
                o.relaxation = self.keyword(
                    v,
                    sc,
                    "relaxation",
                    &[("none", Relaxation::None), ("kinetic", Relaxation::Kinetic)],
                )?
            }
            (MethodSpec::Staggered(o), "beam_substeps") => {
                o.beam_substeps = self.count(v, sc, "beam_substeps")?
            }
            (MethodSpec::Staggered(o), "factorization") => {
                o.factorization = self.keyword(
                    v,
                    sc,
                    "factorization",
                    &[
                        ("auto", Factorization::Auto),
                        ("dense", Factorization::Dense),
                        ("sparse", Factorization::Sparse),
                    ],
                )?
            }
            (MethodSpec::NaturalPartitioning { epsilon, .. }, "epsilon") => {
                *epsilon = Some(self.epsilon(v, sc)?)
            }
            (MethodSpec::ImplicitTrapezoid { tolerance, .. }, "tolerance")
            | (MethodSpec::NaturalPartitioning { tolerance, .. }, "tolerance")
            | (MethodSpec::DormandPrince { tolerance }, "tolerance")
            | (MethodSpec::DormandPrince853 { tolerance }, "tolerance") => {
                *tolerance = self.positive(v, sc, Dim::NONE, "a tolerance")?
            }
            (MethodSpec::ImplicitTrapezoid { max_iterations, .. }, "max_iterations") => {
                *max_iterations = self.count(v, sc, "max_iterations")?
            }
            (MethodSpec::NaturalPartitioning { max_iterations, .. }, "max_iterations") => {
                *max_iterations = Some(self.count(v, sc, "max_iterations")?)
            }
            (
                MethodSpec::StateTime {
                    steps_per_element, ..
                },
                "steps_per_element",
            ) => *steps_per_element = self.count(v, sc, "steps_per_element")?,
            (MethodSpec::StateTime { window, .. }, "window") => {
                *window = self.count(v, sc, "window")?
            }
            _ => return Err(Reported),
        }
        Ok(())
    }

    /// ε: a positive number, dimensionless or in m/N.
    fn epsilon(&mut self, e: &Expr, sc: &Scope) -> R<f64> {
        let q = self.num(e, sc)?;
        if !(q.fits(Dim::NONE) || q.fits(Dim::COMPLIANCE)) {
            self.expect_dim(&q, Dim::COMPLIANCE, e.span, sc, "epsilon")?;
        }
        let v = self.constant_of(&q, e.span, sc, "epsilon")?;
        if v <= 0.0 {
            return Err(self.report(
                Diagnostic::error(
                    codes::INVALID_VALUE,
                    format!("epsilon must be positive, found {}", num(v)),
                )
                .primary(sc.file, e.span, ""),
            ));
        }
        Ok(v)
    }

    /// An integer ≥ 1 that fits in u32.
    fn count(&mut self, e: &Expr, sc: &Scope, what: &str) -> R<u32> {
        let n = self.int(e, sc, what)?;
        if n < 1 || n > u32::MAX as i64 {
            return Err(self.report(
                Diagnostic::error(
                    codes::INVALID_VALUE,
                    format!("{what} must be a positive integer, found {n}"),
                )
                .primary(sc.file, e.span, ""),
            ));
        }
        Ok(n as u32)
    }

    fn output(&mut self, block: &'a mbdc_dsl::ast::Block, sc: &Scope) -> R<OutputSpec> {
        let props = self.props(block, sc, "`output`", OUTPUT_KEYS, &[]);
        let mut out = OutputSpec::default();
        let mut ok = true;
        if let Some(e) = props.value("every") {
            match self.count(e, sc, "`every`") {
                Ok(n) => out.every = n,
                Err(_) => ok = false,
            }
        }
        if let Some(e) = props.value("format") {
            match ident_of(e).and_then(OutputFormat::from_name) {
                Some(f) => out.format = f,
                None => {
                    let found = ident_of(e).unwrap_or("this");
                    let names = OutputFormat::NAMES.join(", ");
                    let help = match ident_of(e).and_then(|n| {
                        crate::suggest::closest(n, OutputFormat::NAMES.iter().copied())
                    }) {
                        Some(s) => format!("did you mean `{s}`? Formats: {names}"),
                        None => format!("formats: {names}"),
                    };
                    self.report(
                        Diagnostic::error(
                            codes::INVALID_VALUE,
                            format!("unknown output format `{found}`"),
                        )
                        .primary(sc.file, e.span, "")
                        .help(help),
                    );
                    ok = false;
                }
            }
        }
        if let Some(e) = props.value("partitions") {
            match self.count(e, sc, "`partitions`") {
                Ok(n) => out.partitions = n,
                Err(_) => ok = false,
            }
        }
        if let Some(e) = props.value("checkpoint_every") {
            match self.count(e, sc, "`checkpoint_every`") {
                Ok(n) => out.checkpoint.every_steps = Some(u64::from(n)),
                Err(_) => ok = false,
            }
        }
        if let Some(e) = props.value("checkpoint_seconds") {
            match self.positive(e, sc, Dim::TIME, "`checkpoint_seconds`") {
                Ok(t) => out.checkpoint.every_seconds = Some(t),
                Err(_) => ok = false,
            }
        }
        if let Some(e) = props.value("keep_checkpoints") {
            match self.count(e, sc, "`keep_checkpoints`") {
                Ok(n) => out.checkpoint.keep = Some(n),
                Err(_) => ok = false,
            }
        }
        if let Some(p) = props.get("include") {
            out.bodies = false;
            out.energy = false;
            out.constraints = false;
            for v in p.values {
                match ident_of(v) {
                    Some("bodies") => out.bodies = true,
                    Some("energy") => out.energy = true,
                    Some("constraints") => out.constraints = true,
                    _ => {
                        self.report(
                            Diagnostic::error(
                                codes::WRONG_KIND,
                                "`include` lists `bodies`, `energy` and `constraints`",
                            )
                            .primary(sc.file, v.span, ""),
                        );
                        ok = false;
                    }
                }
            }
        }
        if ok {
            Ok(out)
        } else {
            Err(Reported)
        }
    }

    pub(crate) fn lower_reference(&mut self, s: &Single<'a>) -> R<Reference> {
        let sc = &s.sc;
        let ItemKind::Decl {
            body: Some(block), ..
        } = &s.item.kind
        else {
            return Err(Reported);
        };
        let props = self.props(block, sc, "`reference`", &[one("table")], &["body"]);
        let table = match props.value("table") {
            Some(e) => Some(self.string(e, sc, "a table path")?),
            None => None,
        };
        let mut bodies = Vec::new();
        let mut ok = true;
        for item in &props.decls {
            let ItemKind::Decl {
                name: Some(name),
                body: Some(b),
                value: None,
                ..
            } = &item.kind
            else {
                self.report(
                    Diagnostic::error(
                        codes::WRONG_KIND,
                        "write `body NAME { position (...); orientation (...) }`",
                    )
                    .primary(sc.file, item.span, ""),
                );
                ok = false;
                continue;
            };
            let path = {
                let mut p = name.base.name.clone();
                let mut bad = false;
                for ix in &name.indices {
                    match self.int(ix, sc, "an index") {
                        Ok(i) => p.push_str(&format!("[{i}]")),
                        Err(_) => bad = true,
                    }
                }
                if bad {
                    ok = false;
                    continue;
                }
                p
            };
            let nref = crate::value::NameRef {
                path,
                prefix: sc.prefix.clone(),
                file: sc.file,
                span: name.span,
            };
            let Ok(bi) = self.resolve(&nref, EntKind::Body) else {
                ok = false;
                continue;
            };
            let bp = self.props(
                b,
                sc,
                "a reference body",
                &[one("position"), one("orientation")],
                &[],
            );
            let position = match bp.value("position") {
                Some(e) => match self.fvec3(e, sc, Dim::LENGTH, "a reference position") {
                    Ok(v) => Some(v),
                    Err(_) => {
                        ok = false;
                        None
                    }
                },
                None => None,
            };
            let orientation = match bp.value("orientation") {
                Some(e) => match self.eval(e, sc) {
                    Ok(Value::Tuple(items)) if items.len() == 4 => {
                        let mut out: Vec<Fn1> = Vec::new();
                        for it in items {
                            match self.scalar_of(it, e.span, sc) {
                                Ok(q) if q.fits(Dim::NONE) && q.var != Var::X => out.push(q.f),
                                Ok(_) => {
                                    self.report(
                                        Diagnostic::error(
                                            codes::UNITS,
                                            "quaternion components are dimensionless",
                                        )
                                        .primary(sc.file, e.span, ""),
                                    );
                                    ok = false;
                                }
                                Err(_) => ok = false,
                            }
                        }
                        <[Fn1; 4]>::try_from(out).ok()
                    }
                    Ok(other) => {
                        self.report(
                            Diagnostic::error(codes::WRONG_KIND, format!("a reference orientation is a quaternion (w, x, y, z), found {}", other.kind()))
                                .primary(sc.file, e.span, ""),
                        );
                        ok = false;
                        None
                    }
                    Err(_) => {
                        ok = false;
                        None
                    }
                },
                None => None,
            };
            if position.is_none() && orientation.is_none() && ok {
                self.report(
                    Diagnostic::error(
                        codes::MISSING_PROPERTY,
                        "a reference body needs `position` or `orientation`",
                    )
                    .primary(sc.file, item.span, ""),
                );
                ok = false;
            }
            bodies.push(BodyReference {
                body: bi,
                position,
                orientation,
            });
        }
        if ok {
            Ok(Reference { bodies, table })
        } else {
            Err(Reported)
        }
    }
}
