//! Lowering: syntax trees → [`Scene`].
//!
//! Two phases:
//! 1. **Expansion** ([`expand`]): imports' top-level items, parameters (with command-line
//!    overrides), constants, `for` loops, `if`s and component instances are expanded into
//!    a flat list of declarations per kind (bodies, joints, forces, ...), each with the
//!    environment visible at its position and its fully prefixed name. All names are
//!    registered here, so that any declaration may refer to any other.
//! 2. **Lowering** (the other modules): every declaration becomes Scene data, bodies first
//!    (joints need their poses), then joints, forces, contacts, beams, meshes, settings.
//!
//! Expressions are evaluated by [`eval`] (an `impl Lowerer` like the others, used by
//! every phase).
//!
//! Errors are collected, never thrown: a failing declaration is skipped and the others are
//! still checked. The scene is returned only if there was no error.

mod beam;
mod body;
mod contact;
mod eval;
mod expand;
mod force;
mod joint;
mod mesh;
pub mod msh;
#[cfg(test)]
mod msh_props;
mod props;
mod simulate;

use std::collections::HashMap;

use mbdc_dsl::ast::{Block, ComponentParam, Expr, Item, Span};
use mbdc_runtime::scene::{self, BodyRef, ParamValue, Scene};

use crate::diag::{codes, Diagnostic, Severity};
use crate::env::Env;
use crate::load::ParsedFile;
use crate::source::{FileId, Sources};
use crate::suggest;
use crate::value::{NameRef, Value};

/// Marker: the problem was reported as a diagnostic.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Reported;

/// Result of a lowering step whose errors were already reported.
pub(crate) type R<T> = Result<T, Reported>;

/// Where an expression is evaluated.
#[derive(Clone, Debug)]
pub(crate) struct Scope {
    /// The file the expression is in.
    pub file: FileId,
    /// The names visible.
    pub env: Env,
    /// The instance prefix (`arm.` inside instance `arm`), empty at model level.
    pub prefix: String,
    /// Tolerance of comparisons (node predicates), 0 elsewhere.
    pub eq_tol: f64,
}

impl Scope {
    pub fn new(file: FileId, env: Env) -> Scope {
        Scope {
            file,
            env,
            prefix: String::new(),
            eq_tol: 0.0,
        }
    }
}

/// Kinds of named items.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum EntKind {
    Body,
    Joint,
    Force,
    Contact,
    Material,
    Beam,
    Mesh,
    Instance,
}

impl EntKind {
    pub fn noun(self) -> &'static str {
        match self {
            EntKind::Body => "body",
            EntKind::Joint => "joint",
            EntKind::Force => "force",
            EntKind::Contact => "contact",
            EntKind::Material => "material",
            EntKind::Beam => "beam",
            EntKind::Mesh => "mesh",
            EntKind::Instance => "component instance",
        }
    }

    /// The plural of [`EntKind::noun`].
    pub fn nouns(self) -> &'static str {
        match self {
            EntKind::Body => "bodies",
            EntKind::Joint => "joints",
            EntKind::Force => "forces",
            EntKind::Contact => "contacts",
            EntKind::Material => "materials",
            EntKind::Beam => "beams",
            EntKind::Mesh => "meshes",
            EntKind::Instance => "component instances",
        }
    }
}

/// A registered name.
#[derive(Clone, Debug)]
pub(crate) struct Entity {
    pub kind: EntKind,
    /// Index among the items of its kind (declaration order).
    pub index: usize,
    pub file: FileId,
    pub span: Span,
}

/// A declaration waiting to be lowered.
#[derive(Clone, Debug)]
pub(crate) struct PDecl<'a> {
    /// Full name (prefixed, indices evaluated).
    pub name: String,
    /// Span of the declared name.
    pub name_span: Span,
    /// Span of the whole item.
    pub span: Span,
    /// `= value`.
    pub value: Option<&'a Expr>,
    /// `{ block }`.
    pub block: Option<&'a Block>,
    /// Where it is evaluated.
    pub sc: Scope,
}

/// A component definition.
#[derive(Clone, Debug)]
pub(crate) struct CompDef<'a> {
    pub params: &'a [ComponentParam],
    pub body: &'a Block,
    /// Index of the defining file in the loaded files.
    pub file_idx: usize,
    pub file: FileId,
    pub name_span: Span,
}

/// A `--set NAME=VALUE` override, parsed.
#[derive(Clone, Debug)]
pub(crate) struct OverrideState {
    pub name: String,
    pub expr: Option<Expr>,
    pub file: FileId,
    pub span: Span,
    pub used: bool,
}

/// A model-level singleton (gravity, simulate, reference).
#[derive(Clone, Debug)]
pub(crate) struct Single<'a> {
    pub item: &'a Item,
    pub sc: Scope,
}

/// All state of one lowering.
pub(crate) struct Lowerer<'a> {
    pub sources: Sources,
    pub diags: Vec<Diagnostic>,
    /// Current expression nesting depth.
    pub depth: u32,
    pub entities: HashMap<String, Entity>,
    pub entity_order: Vec<String>,
    pub counts: HashMap<EntKind, usize>,
    pub bodies: Vec<PDecl<'a>>,
    pub joints: Vec<PDecl<'a>>,
    pub forces: Vec<PDecl<'a>>,
    pub contacts: Vec<PDecl<'a>>,
    pub materials: Vec<PDecl<'a>>,
    pub beams: Vec<PDecl<'a>>,
    pub meshes: Vec<PDecl<'a>>,
    pub components: HashMap<String, CompDef<'a>>,
    pub comp_stack: Vec<String>,
    pub overrides: Vec<OverrideState>,
    pub params: Vec<ParamValue>,
    pub param_decls: HashMap<String, (FileId, Span)>,
    /// Constants of file and model top levels, first declaration: for the `--set` of a
    /// constant.
    pub const_decls: HashMap<String, (FileId, Span)>,
    pub generated: usize,
    pub limit_hit: bool,
    pub file_envs: Vec<Option<Env>>,
    pub file_in_progress: Vec<bool>,
    pub model: Option<(&'a Item, String, FileId)>,
    pub gravity: Option<Single<'a>>,
    pub simulate: Option<Single<'a>>,
    pub reference: Option<Single<'a>>,
    /// Lowered data, filled in phase 2.
    pub scene_bodies: Vec<Option<scene::Body>>,
    pub scene_joints: Vec<Option<scene::Joint>>,
    pub scene_materials: Vec<Option<scene::Material>>,
    /// Directory of each file, for relative paths (meshes).
    pub file_dirs: HashMap<FileId, Option<std::path::PathBuf>>,
    /// The glues of the meshes lowered so far, completed by `resolve_glues` once every
    /// mesh is lowered, then checked against the analysis by `check_glues`.
    pub glues: Vec<mesh::GlueSite>,
    /// The file and the span of each condition of each lowered mesh, by mesh index.
    pub mesh_condition_spans: HashMap<usize, (FileId, Vec<Span>)>,
}

/// Most items (declarations and properties) a file may generate with loops and components.
pub const MAX_ITEMS: usize = 1_000_000;

impl<'a> Lowerer<'a> {
    pub fn new(sources: Sources, overrides: Vec<OverrideState>) -> Self {
        Lowerer {
            sources,
            diags: Vec::new(),
            depth: 0,
            entities: HashMap::new(),
            entity_order: Vec::new(),
            counts: HashMap::new(),
            bodies: Vec::new(),
            joints: Vec::new(),
            forces: Vec::new(),
            contacts: Vec::new(),
            materials: Vec::new(),
            beams: Vec::new(),
            meshes: Vec::new(),
            components: HashMap::new(),
            comp_stack: Vec::new(),
            overrides,
            params: Vec::new(),
            param_decls: HashMap::new(),
            const_decls: HashMap::new(),
            generated: 0,
            limit_hit: false,
            file_envs: Vec::new(),
            file_in_progress: Vec::new(),
            model: None,
            gravity: None,
            simulate: None,
            reference: None,
            scene_bodies: Vec::new(),
            scene_joints: Vec::new(),
            scene_materials: Vec::new(),
            file_dirs: HashMap::new(),
            glues: Vec::new(),
            mesh_condition_spans: HashMap::new(),
        }
    }

    /// Records a diagnostic.
    pub fn report(&mut self, d: Diagnostic) -> Reported {
        self.diags.push(d);
        Reported
    }

    /// Whether an error was reported.
    pub fn has_errors(&self) -> bool {
        self.diags.iter().any(|d| d.severity == Severity::Error)
    }

    /// Registers a name; reports duplicates with both locations.
    pub fn register(&mut self, kind: EntKind, name: &str, file: FileId, span: Span) -> R<usize> {
        if name == "ground" || name.ends_with(".ground") {
            return Err(self.report(
                Diagnostic::error(
                    codes::DUPLICATE_NAME,
                    "`ground` is the name of the fixed frame",
                )
                .primary(file, span, "reserved name")
                .help("choose another name"),
            ));
        }
        if let Some(prev) = self.entities.get(name) {
            let (pf, ps, pk) = (prev.file, prev.span, prev.kind);
            return Err(self.report(
                Diagnostic::error(codes::DUPLICATE_NAME, format!("`{name}` is declared twice"))
                    .primary(file, span, format!("this {} has the same name", kind.noun()))
                    .secondary(pf, ps, format!("first declared here as a {}", pk.noun()))
                    .help("names of bodies, joints, forces, contacts, materials, beams, meshes and instances must be unique"),
            ));
        }
        let c = self.counts.entry(kind).or_insert(0);
        let index = *c;
        *c += 1;
        self.entities.insert(
            name.to_string(),
            Entity {
                kind,
                index,
                file,
                span,
            },
        );
        self.entity_order.push(name.to_string());
        Ok(index)
    }

    /// All registered names (for suggestions).
    pub fn entity_names(&self) -> Vec<String> {
        self.entity_order.clone()
    }

    /// The entity a name refers to, if any.
    pub fn resolve_any(&self, n: &NameRef) -> Option<&Entity> {
        n.candidates().iter().find_map(|c| self.entities.get(c))
    }

    /// Resolves a name to an item of the given kind; returns its index.
    pub fn resolve(&mut self, n: &NameRef, kind: EntKind) -> R<usize> {
        for c in n.candidates() {
            if let Some(e) = self.entities.get(&c) {
                if e.kind == kind {
                    return Ok(e.index);
                }
                let (ek, ef, es) = (e.kind, e.file, e.span);
                return Err(self.report(
                    Diagnostic::error(
                        codes::WRONG_KIND,
                        format!("`{}` is a {}, not a {}", n.path, ek.noun(), kind.noun()),
                    )
                    .primary(n.file, n.span, format!("expected a {}", kind.noun()))
                    .secondary(ef, es, "declared here"),
                ));
            }
        }
        let mut names: Vec<&str> = self
            .entity_order
            .iter()
            .filter(|s| self.entities.get(*s).is_some_and(|e| e.kind == kind))
            .map(|s| s.as_str())
            .collect();
        if kind == EntKind::Body {
            names.push("ground");
        }
        // Suggest against the prefixed names and the bare ones.
        let help = suggest::did_you_mean(&n.path, names.iter().copied()).or_else(|| {
            let full = format!("{}{}", n.prefix, n.path);
            suggest::did_you_mean(&full, names.iter().copied())
        });
        let mut d = Diagnostic::error(
            codes::UNKNOWN_NAME,
            format!("unknown {} `{}`", kind.noun(), n.path),
        )
        .primary(n.file, n.span, "not declared");
        d = match help {
            Some(h) => d.help(h),
            None if !names.is_empty() && names.len() <= 12 => d.help(format!(
                "declared {}: {}",
                kind.nouns(),
                names
                    .iter()
                    .map(|s| format!("`{s}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            )),
            None => d,
        };
        Err(self.report(d))
    }

    /// A body or ground from a value.
    pub fn body_ref(&mut self, v: &Value, span: Span, sc: &Scope) -> R<BodyRef> {
        match v {
            Value::Name(n) if n.path == "ground" => Ok(BodyRef::Ground),
            Value::Name(n) => self.resolve(n, EntKind::Body).map(BodyRef::Body),
            other => Err(self.report(
                Diagnostic::error(
                    codes::WRONG_KIND,
                    format!("expected a body, found {}", other.kind()),
                )
                .primary(sc.file, span, "not a body name"),
            )),
        }
    }

    /// The lowered body (pose needed for world points and axes); `None` for ground or a
    /// body that failed to lower.
    pub fn body_data(&self, b: BodyRef) -> Option<&scene::Body> {
        match b {
            BodyRef::Ground => None,
            BodyRef::Body(i) => self.scene_bodies.get(i).and_then(|b| b.as_ref()),
        }
    }
}

/// Lowers loaded files; `main` is the index of the file with the model.
pub(crate) fn lower(
    sources: Sources,
    files: &[ParsedFile],
    main: usize,
    overrides: Vec<OverrideState>,
) -> (Sources, Option<Scene>, Vec<Diagnostic>) {
    let mut lw = Lowerer::new(sources, overrides);
    for f in files {
        lw.file_dirs.insert(f.id, f.dir.clone());
    }
    lw.expand_program(files, main);
    let scene = if lw.model.is_some() && !lw.limit_hit {
        lw.build_scene()
    } else {
        None
    };
    let scene = if lw.has_errors() { None } else { scene };
    (lw.sources, scene, lw.diags)
}

impl<'a> Lowerer<'a> {
    /// Phase 2: lowers every declaration; returns the scene if nothing failed.
    pub fn build_scene(&mut self) -> Option<Scene> {
        let mut failed = false;
        let materials = std::mem::take(&mut self.materials);
        for d in &materials {
            let m = self.lower_material(d).ok();
            failed |= m.is_none();
            self.scene_materials.push(m);
        }
        self.materials = materials;
        let bodies = std::mem::take(&mut self.bodies);
        for d in &bodies {
            let b = self.lower_body(d).ok();
            failed |= b.is_none();
            self.scene_bodies.push(b);
        }
        self.bodies = bodies;
        let joints = std::mem::take(&mut self.joints);
        self.scene_joints = vec![None; joints.len()];
        for (i, d) in joints.iter().enumerate() {
            if joint::is_driver(d) {
                continue;
            }
            let j = self.lower_joint(d).ok();
            failed |= j.is_none();
            self.scene_joints[i] = j;
        }
        for (i, d) in joints.iter().enumerate() {
            if !joint::is_driver(d) {
                continue;
            }
            let j = self.lower_driver(d).ok();
            failed |= j.is_none();
            self.scene_joints[i] = j;
        }
        self.joints = joints;
        let mut forces = Vec::new();
        for d in std::mem::take(&mut self.forces) {
            match self.lower_force(&d) {
                Ok(Some(f)) => forces.push(f),
                Ok(None) => {}
                Err(_) => failed = true,
            }
        }
        let mut contacts = Vec::new();
        for d in std::mem::take(&mut self.contacts) {
            match self.lower_contact(&d) {
                Ok(c) => contacts.push(c),
                Err(_) => failed = true,
            }
        }
        let mut beams = Vec::new();
        for d in std::mem::take(&mut self.beams) {
            match self.lower_beam(&d) {
                Ok(b) => beams.push(b),
                Err(_) => failed = true,
            }
        }
        let mut meshes = Vec::new();
        for d in std::mem::take(&mut self.meshes) {
            let m = self.lower_mesh(&d).ok();
            failed |= m.is_none();
            meshes.push(m);
        }
        // A mesh may glue to a mesh declared after it.
        self.resolve_glues(&mut meshes);
        let meshes: Vec<scene::Mesh> = meshes.into_iter().flatten().collect();
        let gravity = match self.gravity.clone() {
            Some(g) => match self.lower_gravity(&g) {
                Ok(v) => Some(v),
                Err(_) => {
                    failed = true;
                    None
                }
            },
            None => None,
        };
        let simulate = match self.simulate.clone() {
            Some(s) => match self.lower_simulate(&s) {
                Ok(v) => v,
                Err(_) => {
                    failed = true;
                    scene::Simulate::default()
                }
            },
            None => {
                if let Some((item, name, file)) = &self.model {
                    let (span, file) = (item.span, *file);
                    let _ = name;
                    self.report(
                        Diagnostic::warning(
                            codes::MISSING_PROPERTY,
                            "the model has no `simulate` block: using duration 1 s and step 1 ms",
                        )
                        .primary(file, Span::new(span.start, span.start), "")
                        .help("add `simulate { duration 1 s; step 1 ms }`"),
                    );
                }
                scene::Simulate::default()
            }
        };
        let reference = match self.reference.clone() {
            Some(r) => match self.lower_reference(&r) {
                Ok(v) => Some(v),
                Err(_) => {
                    failed = true;
                    None
                }
            },
            None => None,
        };
        if failed || self.has_errors() {
            return None;
        }
        let name = self.model.as_ref().map(|m| m.1.clone()).unwrap_or_default();
        let scene = Scene {
            name,
            gravity,
            bodies: self.scene_bodies.iter().flatten().cloned().collect(),
            joints: self.scene_joints.iter().flatten().cloned().collect(),
            forces,
            beams,
            meshes,
            contacts,
            simulate,
            reference,
            params: std::mem::take(&mut self.params),
        };
        if let Some(s) = self.simulate.clone() {
            self.check_mesh_method(&s, &scene);
            self.check_mesh_solver(&s, &scene);
        }
        self.check_glues(self.simulate.clone().as_ref(), &scene);
        if self.has_errors() {
            return None;
        }
        Some(scene)
    }

    /// The directory relative paths in a file are resolved in.
    pub fn file_dir(&self, file: FileId) -> Option<std::path::PathBuf> {
        self.file_dirs.get(&file).cloned().flatten()
    }
}
