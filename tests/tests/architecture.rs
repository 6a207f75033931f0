//! The workspace's architecture, enforced on the source (parsed with `syn`, not matched with
//! regexes), in the spirit of rust-analyzer's layering: code is arranged so that each part
//! depends only on the parts below it, and no two parts depend on each other.
//!
//! **Rule 1: no import circle among sibling modules, in every crate.** For each library and
//! binary crate (dsl, compiler, runtime, macros, cli) every path a module writes (`use` trees,
//! and the paths in expressions, types, patterns, impls, bounds and macro arguments) that
//! resolves into the crate (`crate::`, `self::`, `super::`, or a child module declared in the
//! same file) is an edge from the module to the longest known module the path names. An edge
//! between an ancestor and a descendant (a child using `super::Item`, a parent re-exporting
//! a child) is fine; any other edge A → B is lifted to the two children of A's and B's lowest
//! common ancestor that contain them, and among the children of each module those lifted edges
//! must not form a circle. A circle means neither module can be understood, tested or moved
//! without the other: the cut between them is in the wrong place.
//!
//! **Rule 2: the runtime's floors.** `runtime/src` is a stack of top-level modules, the
//! [`FLOORS`], from bottom to top. A module may refer (by `crate::…` or a `super::` that climbs
//! out of its floor) only to its own floor and the floors below; `contract`, the bottom, only
//! to itself. Every top-level module of the runtime must be a floor, so a new one is placed
//! deliberately. The items of `lib.rs` itself (the façade and its re-exports) are exempt.
//!
//! Items under `#[cfg(test)]` are skipped by both rules: tests may use anything in their crate,
//! as integration tests do. Inline `mod x { … }` blocks count as part of their file's module.

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::path::{Path, PathBuf};

use syn::punctuated::Punctuated;
use syn::visit::{self, Visit};
use syn::{Attribute, Item, Meta, Token, UseTree};

/// The runtime's floors, from bottom to top: one top-level module of `runtime/src` each.
///
/// This list must match the floor list in the doc comment of `runtime/src/lib.rs`; change
/// both together. A floor may refer only to itself and the floors before it in this list.
///
/// - `contract`: scene data, the `System` trait, math
/// - `kernels`: joint, force, contact and time-function kernels (later beam and solid elements)
/// - `linalg`: dense and sparse solvers
/// - `analysis`: topology, step-limit estimates, input limits, effects
/// - `integrators`: the time-stepping methods
/// - `driver`: run loop, watchdog, output writers, assembly, energy
/// - `interp`: the interpreter `System`
/// - `compiled`: support for generated code
/// - `app`: the compiled program's entry
/// - `study`: the accuracy / work–precision study engine
const FLOORS: &[&str] = &[
    "contract",
    "kernels",
    "linalg",
    "analysis",
    "integrators",
    "driver",
    "interp",
    "compiled",
    "app",
    "study",
];

/// The crates rule 1 checks: directory (relative to the workspace root) and root file.
const CRATES: &[(&str, &str)] = &[
    ("dsl", "lib.rs"),
    ("compiler", "lib.rs"),
    ("runtime", "lib.rs"),
    ("macros", "lib.rs"),
    ("cli", "main.rs"),
];

/// A module's path inside its crate, `[]` for the crate root.
type ModPath = Vec<String>;

fn show(m: &[String]) -> String {
    if m.is_empty() {
        "crate".to_string()
    } else {
        m.join("::")
    }
}

/// One parsed source file, the module it is.
struct Module {
    /// Path shown in messages, e.g. `runtime/src/kernels/forces.rs`.
    file: String,
    ast: syn::File,
    /// Child modules the file declares with `mod x;` (not under `#[cfg(test)]`).
    children: BTreeSet<String>,
}

/// A crate's module tree: the files reachable from the root through `mod x;` declarations.
struct Crate {
    label: String,
    modules: BTreeMap<ModPath, Module>,
}

/// A reference from one module to another, with the path that makes it.
#[derive(Debug)]
struct Edge {
    from: ModPath,
    to: ModPath,
    written: String,
    file: String,
}

// ---------------------------------------------------------------------------------------------
// Module tree

/// The module a file is: `lib.rs`/`main.rs` (the given root) is the crate root, `a/b.rs` and
/// `a/b/mod.rs` are `a::b`.
fn file_module_path(rel: &str, root_file: &str) -> Option<ModPath> {
    if rel == root_file {
        return Some(Vec::new());
    }
    let stem = rel.strip_suffix(".rs")?;
    let stem = stem.strip_suffix("/mod").unwrap_or(stem);
    Some(stem.split('/').map(str::to_string).collect())
}

/// Whether a `cfg` predicate holds only under test: `test` or `all(…, test, …)`.
fn cfg_is_test(meta: &Meta) -> bool {
    match meta {
        Meta::Path(p) => p.is_ident("test"),
        Meta::List(l) if l.path.is_ident("all") => l
            .parse_args_with(Punctuated::<Meta, Token![,]>::parse_terminated)
            .is_ok_and(|ms| ms.iter().any(cfg_is_test)),
        _ => false,
    }
}

fn is_test(attrs: &[Attribute]) -> bool {
    attrs
        .iter()
        .any(|a| a.path().is_ident("cfg") && a.parse_args::<Meta>().is_ok_and(|m| cfg_is_test(&m)))
}

fn item_attrs(item: &Item) -> &[Attribute] {
    match item {
        Item::Const(i) => &i.attrs,
        Item::Enum(i) => &i.attrs,
        Item::ExternCrate(i) => &i.attrs,
        Item::Fn(i) => &i.attrs,
        Item::ForeignMod(i) => &i.attrs,
        Item::Impl(i) => &i.attrs,
        Item::Macro(i) => &i.attrs,
        Item::Mod(i) => &i.attrs,
        Item::Static(i) => &i.attrs,
        Item::Struct(i) => &i.attrs,
        Item::Trait(i) => &i.attrs,
        Item::TraitAlias(i) => &i.attrs,
        Item::Type(i) => &i.attrs,
        Item::Union(i) => &i.attrs,
        Item::Use(i) => &i.attrs,
        _ => &[],
    }
}

/// The modules a file's top level declares, `(name, has a file)`, skipping `#[cfg(test)]`.
fn declared_modules(ast: &syn::File) -> Vec<(String, bool)> {
    ast.items
        .iter()
        .filter_map(|item| match item {
            Item::Mod(m) if !is_test(&m.attrs) => Some((m.ident.to_string(), m.content.is_none())),
            _ => None,
        })
        .collect()
}

/// Builds a crate's module tree from its source files, given as (path relative to the source
/// directory, text). `src` is the directory shown in messages, e.g. `runtime/src`.
fn build_crate(
    label: &str,
    src: &str,
    root_file: &str,
    files: &[(String, String)],
) -> Result<Crate, String> {
    let by_module: BTreeMap<ModPath, &(String, String)> = files
        .iter()
        .filter_map(|f| file_module_path(&f.0, root_file).map(|m| (m, f)))
        .collect();
    let mut modules = BTreeMap::new();
    let mut queue = VecDeque::from([Vec::new()]);
    while let Some(path) = queue.pop_front() {
        let Some((rel, text)) = by_module.get(&path) else {
            return Err(format!(
                "{label}: module `{}` is declared but neither {src}/{0}.rs nor {src}/{0}/mod.rs exists",
                path.join("/")
            ));
        };
        let file = format!("{src}/{rel}");
        let ast = syn::parse_file(text).map_err(|e| format!("{file}: {e}"))?;
        let mut children = BTreeSet::new();
        for (name, has_file) in declared_modules(&ast) {
            if has_file {
                let mut child = path.clone();
                child.push(name.clone());
                queue.push_back(child);
                children.insert(name);
            }
        }
        modules.insert(
            path,
            Module {
                file,
                ast,
                children,
            },
        );
    }
    Ok(Crate {
        label: label.to_string(),
        modules,
    })
}

// ---------------------------------------------------------------------------------------------
// Edges

/// Resolves a written path to an absolute module path inside the crate (not yet cut to a known
/// module), or `None` if it does not point into the crate. `logical` is the module the path is
/// written in (an inline `mod` included), `file_mod` the file's module and `children` the
/// modules that file declares with `mod x;`. A bare one-segment path outside `use` (a local
/// variable named like a module) is not a module reference.
fn resolve(
    logical: &[String],
    file_mod: &[String],
    children: &BTreeSet<String>,
    segs: &[String],
    in_use: bool,
) -> Option<ModPath> {
    let first = segs.first()?;
    match first.as_str() {
        "crate" => Some(segs[1..].to_vec()),
        "self" => Some([logical, &segs[1..]].concat()),
        "super" => {
            let mut base = logical.to_vec();
            let mut i = 0;
            while segs.get(i).is_some_and(|s| s == "super") {
                base.pop()?;
                i += 1;
            }
            base.extend_from_slice(&segs[i..]);
            Some(base)
        }
        _ if logical == file_mod && children.contains(first) && (in_use || segs.len() > 1) => {
            Some([file_mod, segs].concat())
        }
        _ => None,
    }
}

/// Flattens a `use` tree into (segments, text as written): groups expand, a renamed name keeps
/// its original, `self` in a group names the prefix, a glob names its prefix.
fn flatten_use(tree: &UseTree, prefix: &mut Vec<String>, out: &mut Vec<(ModPath, String)>) {
    match tree {
        UseTree::Path(p) => {
            prefix.push(p.ident.to_string());
            flatten_use(&p.tree, prefix, out);
            prefix.pop();
        }
        UseTree::Name(n) => {
            let mut segs = prefix.clone();
            if n.ident != "self" || segs.is_empty() {
                segs.push(n.ident.to_string());
            }
            out.push((segs.clone(), segs.join("::")));
        }
        UseTree::Rename(r) => {
            let mut segs = prefix.clone();
            if r.ident != "self" || segs.is_empty() {
                segs.push(r.ident.to_string());
            }
            out.push((segs.clone(), segs.join("::")));
        }
        UseTree::Glob(_) => out.push((prefix.clone(), format!("{}::*", prefix.join("::")))),
        UseTree::Group(g) => {
            for t in &g.items {
                flatten_use(t, prefix, out);
            }
        }
    }
}

struct Collector<'a> {
    krate: &'a Crate,
    file_mod: &'a [String],
    module: &'a Module,
    /// The module being visited, inline `mod` blocks included.
    logical: ModPath,
    edges: Vec<Edge>,
}

impl Collector<'_> {
    fn record(&mut self, segs: &[String], written: String, in_use: bool) {
        let Some(mut to) = resolve(
            &self.logical,
            self.file_mod,
            &self.module.children,
            segs,
            in_use,
        ) else {
            return;
        };
        while !self.krate.modules.contains_key(&to) {
            to.pop();
        }
        if to != self.file_mod {
            self.edges.push(Edge {
                from: self.file_mod.to_vec(),
                to,
                written,
                file: self.module.file.clone(),
            });
        }
    }

    /// A path with an optional `<T>::` / `<T as Trait>::` qualifier: `<T>::x` names no module.
    fn visit_qualified(&mut self, qself: Option<&syn::QSelf>, path: &syn::Path) {
        if let Some(q) = qself {
            self.visit_type(&q.ty);
            if q.position == 0 {
                for seg in &path.segments {
                    self.visit_path_arguments(&seg.arguments);
                }
                return;
            }
        }
        self.visit_path(path);
    }
}

impl<'ast> Visit<'ast> for Collector<'_> {
    fn visit_item(&mut self, i: &'ast Item) {
        if !is_test(item_attrs(i)) {
            visit::visit_item(self, i);
        }
    }
    fn visit_item_mod(&mut self, i: &'ast syn::ItemMod) {
        if let Some((_, items)) = &i.content {
            self.logical.push(i.ident.to_string());
            for item in items {
                self.visit_item(item);
            }
            self.logical.pop();
        }
    }
    fn visit_item_use(&mut self, i: &'ast syn::ItemUse) {
        if i.leading_colon.is_some() {
            return;
        }
        let mut flat = Vec::new();
        flatten_use(&i.tree, &mut Vec::new(), &mut flat);
        for (segs, written) in flat {
            self.record(&segs, written, true);
        }
    }
    fn visit_path(&mut self, p: &'ast syn::Path) {
        if p.leading_colon.is_none() {
            let segs: Vec<String> = p.segments.iter().map(|s| s.ident.to_string()).collect();
            let written = segs.join("::");
            self.record(&segs, written, false);
        }
        visit::visit_path(self, p);
    }
    fn visit_expr_path(&mut self, e: &'ast syn::ExprPath) {
        self.visit_qualified(e.qself.as_ref(), &e.path);
    }
    fn visit_type_path(&mut self, t: &'ast syn::TypePath) {
        self.visit_qualified(t.qself.as_ref(), &t.path);
    }
    fn visit_macro(&mut self, m: &'ast syn::Macro) {
        self.visit_path(&m.path);
        // Most macros (`vec!`, `format!`, `assert!`…) take expressions: look inside those.
        if let Ok(args) = m.parse_body_with(Punctuated::<syn::Expr, Token![,]>::parse_terminated) {
            for e in &args {
                self.visit_expr(e);
            }
        }
    }
    // `pub(crate)`, `pub(super)` and attributes name no dependency.
    fn visit_visibility(&mut self, _: &'ast syn::Visibility) {}
    fn visit_attribute(&mut self, _: &'ast Attribute) {}
    // `#[cfg(test)]` on things other than items.
    fn visit_impl_item(&mut self, i: &'ast syn::ImplItem) {
        let attrs = match i {
            syn::ImplItem::Const(x) => &x.attrs,
            syn::ImplItem::Fn(x) => &x.attrs,
            syn::ImplItem::Type(x) => &x.attrs,
            syn::ImplItem::Macro(x) => &x.attrs,
            _ => return visit::visit_impl_item(self, i),
        };
        if !is_test(attrs) {
            visit::visit_impl_item(self, i);
        }
    }
    fn visit_trait_item(&mut self, i: &'ast syn::TraitItem) {
        let attrs = match i {
            syn::TraitItem::Const(x) => &x.attrs,
            syn::TraitItem::Fn(x) => &x.attrs,
            syn::TraitItem::Type(x) => &x.attrs,
            syn::TraitItem::Macro(x) => &x.attrs,
            _ => return visit::visit_trait_item(self, i),
        };
        if !is_test(attrs) {
            visit::visit_trait_item(self, i);
        }
    }
    fn visit_field(&mut self, f: &'ast syn::Field) {
        if !is_test(&f.attrs) {
            visit::visit_field(self, f);
        }
    }
    fn visit_field_value(&mut self, f: &'ast syn::FieldValue) {
        if !is_test(&f.attrs) {
            visit::visit_field_value(self, f);
        }
    }
    fn visit_variant(&mut self, v: &'ast syn::Variant) {
        if !is_test(&v.attrs) {
            visit::visit_variant(self, v);
        }
    }
    fn visit_local(&mut self, l: &'ast syn::Local) {
        if !is_test(&l.attrs) {
            visit::visit_local(self, l);
        }
    }
    fn visit_arm(&mut self, a: &'ast syn::Arm) {
        if !is_test(&a.attrs) {
            visit::visit_arm(self, a);
        }
    }
    fn visit_stmt_macro(&mut self, s: &'ast syn::StmtMacro) {
        if !is_test(&s.attrs) {
            visit::visit_stmt_macro(self, s);
        }
    }
}

/// Every reference from a module of the crate to another module of it.
fn extract_edges(krate: &Crate) -> Vec<Edge> {
    let mut edges = Vec::new();
    for (path, module) in &krate.modules {
        let mut c = Collector {
            krate,
            file_mod: path,
            module,
            logical: path.clone(),
            edges: Vec::new(),
        };
        c.visit_file(&module.ast);
        edges.append(&mut c.edges);
    }
    edges
}

// ---------------------------------------------------------------------------------------------
// Rule 1: circles among siblings

/// The module nodes reachable from `start` in `graph`.
fn reachable<V>(
    graph: &BTreeMap<ModPath, BTreeMap<ModPath, V>>,
    start: &ModPath,
) -> BTreeSet<ModPath> {
    let mut seen = BTreeSet::from([start.clone()]);
    let mut queue = VecDeque::from([start.clone()]);
    while let Some(n) = queue.pop_front() {
        for m in graph.get(&n).into_iter().flat_map(|s| s.keys()) {
            if seen.insert(m.clone()) {
                queue.push_back(m.clone());
            }
        }
    }
    seen
}

/// A shortest circle through `start` inside the strongly connected `component`.
fn shortest_circle<V>(
    graph: &BTreeMap<ModPath, BTreeMap<ModPath, V>>,
    component: &BTreeSet<ModPath>,
    start: &ModPath,
) -> Vec<ModPath> {
    let mut prev: BTreeMap<ModPath, ModPath> = BTreeMap::new();
    let mut queue = VecDeque::from([start.clone()]);
    while let Some(n) = queue.pop_front() {
        for m in graph.get(&n).into_iter().flat_map(|s| s.keys()) {
            if m == start {
                let mut circle = vec![n.clone()];
                while let Some(p) = prev.get(circle.last().unwrap()) {
                    circle.push(p.clone());
                }
                circle.reverse();
                return circle;
            }
            if component.contains(m) && !prev.contains_key(m) && m != start {
                prev.insert(m.clone(), n.clone());
                queue.push_back(m.clone());
            }
        }
    }
    unreachable!("a strongly connected component of two or more nodes has a circle")
}

/// Rule 1: one message per tangle of sibling modules that refer to each other in a circle.
fn sibling_circles(label: &str, edges: &[Edge]) -> Vec<String> {
    // parent -> sibling -> sibling it refers to -> first example
    let mut graphs: BTreeMap<ModPath, BTreeMap<ModPath, BTreeMap<ModPath, &Edge>>> =
        BTreeMap::new();
    for e in edges {
        let l = e.from.iter().zip(&e.to).take_while(|(a, b)| a == b).count();
        if l == e.from.len() || l == e.to.len() {
            continue; // ancestor <-> descendant
        }
        graphs
            .entry(e.from[..l].to_vec())
            .or_default()
            .entry(e.from[..=l].to_vec())
            .or_default()
            .entry(e.to[..=l].to_vec())
            .or_insert(e);
    }
    let mut out = Vec::new();
    for graph in graphs.values() {
        let nodes: BTreeSet<&ModPath> = graph.keys().collect();
        let reach: BTreeMap<&ModPath, BTreeSet<ModPath>> =
            nodes.iter().map(|n| (*n, reachable(graph, n))).collect();
        let mut done = BTreeSet::new();
        for n in &nodes {
            if done.contains(*n) {
                continue;
            }
            let component: BTreeSet<ModPath> = reach[n]
                .iter()
                .filter(|m| reach.get(m).is_some_and(|r| r.contains(*n)))
                .cloned()
                .collect();
            done.extend(component.iter().cloned());
            if component.len() < 2 {
                continue;
            }
            let circle = shortest_circle(graph, &component, n);
            let mut msg = format!("{label}: {}", show(&circle[0]));
            for (i, a) in circle.iter().enumerate() {
                let b = &circle[(i + 1) % circle.len()];
                let e = graph[a][b];
                msg += &format!(" -> {} ({} in {})", show(b), e.written, e.file);
            }
            if component.len() > circle.len() {
                // A bigger tangle: breaking one circle is not enough, so list all its edges.
                let all: Vec<String> = component.iter().map(|m| show(m)).collect();
                msg += &format!("\n    one tangle of {}; its edges:", all.join(", "));
                for a in &component {
                    for (b, e) in graph[a].iter().filter(|(b, _)| component.contains(*b)) {
                        msg += &format!(
                            "\n      {} -> {} ({} in {})",
                            show(a),
                            show(b),
                            e.written,
                            e.file
                        );
                    }
                }
            }
            out.push(msg);
        }
    }
    out
}

// ---------------------------------------------------------------------------------------------
// Rule 2: the runtime's floors

/// Rule 2: every violation of the floors in the runtime crate `krate` with edges `edges`.
fn floor_violations(krate: &Crate, edges: &[Edge], floors: &[&str]) -> Vec<String> {
    let floor = |name: &str| floors.iter().position(|f| *f == name);
    let root = &krate.modules[&Vec::new()];
    let mut out = Vec::new();
    for (name, _) in declared_modules(&root.ast) {
        if floor(&name).is_none() {
            out.push(format!(
                "{}: top-level module `{name}` is not a floor: move it into one, or add a new \
                 floor to FLOORS in tests/tests/architecture.rs and to runtime/src/lib.rs's doc",
                root.file
            ));
        }
    }
    for e in edges {
        let Some(from) = e.from.first() else {
            continue; // lib.rs, the façade
        };
        let Some(k) = floor(from) else {
            continue; // not a floor: reported above
        };
        let Some(to) = e.to.first() else {
            out.push(format!(
                "{}: `{}`: floor {from} reaches the crate root (lib.rs façade); name the module \
                 it is in instead",
                e.file, e.written
            ));
            continue;
        };
        let Some(j) = floor(to) else {
            continue;
        };
        if j > k {
            let why = if k == 0 {
                " (contract may refer to nothing outside contract)"
            } else {
                ""
            };
            out.push(format!(
                "{}: `{}`: floor {from} (#{k}) reaches up to floor {to} (#{j}){why}",
                e.file, e.written
            ));
        }
    }
    out
}

// ---------------------------------------------------------------------------------------------
// The workspace

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Every `.rs` file under `dir`, as (path relative to `dir` with `/`, text), sorted.
fn read_sources(dir: &Path) -> Vec<(String, String)> {
    fn walk(dir: &Path, rel: &str, out: &mut Vec<(String, String)>) {
        let entries = std::fs::read_dir(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
        for entry in entries {
            let path = entry.unwrap().path();
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            let rel = if rel.is_empty() {
                name.clone()
            } else {
                format!("{rel}/{name}")
            };
            if path.is_dir() {
                walk(&path, &rel, out);
            } else if name.ends_with(".rs") {
                let text = std::fs::read_to_string(&path)
                    .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
                out.push((rel, text));
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, "", &mut out);
    out.sort();
    out
}

fn load_crate(dir: &str, root_file: &str) -> Crate {
    let src = format!("{dir}/src");
    let files = read_sources(&workspace().join(&src));
    build_crate(dir, &src, root_file, &files).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn rule1_no_sibling_circles_in_any_crate() {
    let mut circles = Vec::new();
    for (dir, root) in CRATES {
        let krate = load_crate(dir, root);
        circles.extend(sibling_circles(&krate.label, &extract_edges(&krate)));
    }
    assert!(
        circles.is_empty(),
        "{} circle(s) among sibling modules; cut each one where a module should not know the \
         other (move the shared part down, or pass it in):\n{}",
        circles.len(),
        circles.join("\n")
    );
}

#[test]
fn rule2_runtime_floors() {
    let krate = load_crate("runtime", "lib.rs");
    let violations = floor_violations(&krate, &extract_edges(&krate), FLOORS);
    assert!(
        violations.is_empty(),
        "{} violation(s) of the runtime's floors (bottom to top: {}); a floor may refer only to \
         itself and the floors below:\n{}",
        violations.len(),
        FLOORS.join(" < "),
        violations.join("\n")
    );
}

// ---------------------------------------------------------------------------------------------
// The checker itself, on tiny crates

fn synthetic(files: &[(&str, &str)]) -> Crate {
    let files: Vec<(String, String)> = files
        .iter()
        .map(|(p, t)| (p.to_string(), t.to_string()))
        .collect();
    build_crate("t", "t/src", "lib.rs", &files).unwrap()
}

fn circles_of(files: &[(&str, &str)]) -> Vec<String> {
    let k = synthetic(files);
    sibling_circles("t", &extract_edges(&k))
}

fn floors_of(files: &[(&str, &str)]) -> Vec<String> {
    let k = synthetic(files);
    floor_violations(&k, &extract_edges(&k), FLOORS)
}

/// (from, to, written) of every edge.
fn edges_of(files: &[(&str, &str)]) -> Vec<(String, String, String)> {
    extract_edges(&synthetic(files))
        .into_iter()
        .map(|e| (show(&e.from), show(&e.to), e.written))
        .collect()
}

fn s(v: &[&str]) -> ModPath {
    v.iter().map(|x| x.to_string()).collect()
}

#[test]
fn module_paths_of_files() {
    assert_eq!(file_module_path("lib.rs", "lib.rs"), Some(s(&[])));
    assert_eq!(file_module_path("a/b.rs", "lib.rs"), Some(s(&["a", "b"])));
    assert_eq!(
        file_module_path("a/b/mod.rs", "lib.rs"),
        Some(s(&["a", "b"]))
    );
    assert_eq!(file_module_path("main.rs", "main.rs"), Some(s(&[])));
}

#[test]
fn a_clean_crate_passes() {
    let files = [
        ("lib.rs", "mod a; mod b; pub use a::X;"),
        ("a.rs", "use crate::b::Y; pub struct X(Y);"),
        ("b.rs", "pub struct Y;"),
    ];
    assert_eq!(circles_of(&files), Vec::<String>::new());
    assert_eq!(
        edges_of(&files),
        [
            ("crate".into(), "a".into(), "a::X".into()),
            ("a".into(), "b".into(), "crate::b::Y".into())
        ]
    );
}

#[test]
fn a_two_module_circle_is_reported() {
    let c = circles_of(&[
        ("lib.rs", "mod a; mod b;"),
        ("a.rs", "pub fn f() { crate::b::g() }"),
        ("b.rs", "use crate::a::f; pub fn g() {}"),
    ]);
    assert_eq!(
        c,
        ["t: a -> b (crate::b::g in t/src/a.rs) -> a (crate::a::f in t/src/b.rs)"]
    );
}

#[test]
fn a_circle_between_nested_siblings_is_lifted_to_them() {
    // kernels::forces::x -> kernels::contact and kernels::contact -> kernels::forces::x.
    let c = circles_of(&[
        ("lib.rs", "mod kernels;"),
        ("kernels/mod.rs", "pub mod contact; pub mod forces;"),
        ("kernels/forces/mod.rs", "pub mod x;"),
        (
            "kernels/forces/x.rs",
            "fn f(c: &crate::kernels::contact::C) {}",
        ),
        (
            "kernels/contact.rs",
            "pub struct C; fn g() { super::forces::x::add_wrench(); }",
        ),
    ]);
    assert_eq!(
        c,
        [
            "t: kernels::contact -> kernels::forces (super::forces::x::add_wrench in \
          t/src/kernels/contact.rs) -> kernels::contact (crate::kernels::contact::C in \
          t/src/kernels/forces/x.rs)"
        ]
    );
}

#[test]
fn a_three_module_circle_through_types_and_macros_is_reported() {
    let c = circles_of(&[
        ("lib.rs", "mod a; mod b; mod c; mod d;"),
        ("a.rs", "pub struct A; impl crate::b::Tr for A {}"),
        (
            "b.rs",
            "pub trait Tr {} fn f<T: Tr>() -> Vec<u8> { vec![crate::c::N] }",
        ),
        (
            "c.rs",
            "pub const N: u8 = 0; fn g(x: Option<crate::a::A>) { let crate::a::A = A; }",
        ),
        ("d.rs", "use crate::a::A;"),
    ]);
    assert_eq!(c.len(), 1, "{c:?}");
    assert!(c[0].starts_with("t: a -> b (crate::b::Tr in t/src/a.rs) -> c (crate::c::N in t/src/b.rs) -> a (crate::a::A in t/src/c.rs)"), "{c:?}");
}

#[test]
fn super_super_is_resolved() {
    let files = [
        ("lib.rs", "mod a; mod b;"),
        ("a/mod.rs", "mod inner;"),
        ("a/inner.rs", "use super::super::b::Thing;"),
        (
            "b.rs",
            "pub struct Thing; mod z { fn f() { super::super::a::g(); } }",
        ),
    ];
    assert_eq!(
        edges_of(&files),
        [
            (
                "a::inner".into(),
                "b".into(),
                "super::super::b::Thing".into()
            ),
            ("b".into(), "a".into(), "super::super::a::g".into()),
        ]
    );
    assert_eq!(circles_of(&files).len(), 1);
    let none = BTreeSet::new();
    let p = resolve(
        &s(&["x", "y", "z"]),
        &s(&["x", "y", "z"]),
        &none,
        &s(&["super", "super", "q", "r"]),
        false,
    );
    assert_eq!(p, Some(s(&["x", "q", "r"])));
    assert_eq!(
        resolve(
            &s(&["x"]),
            &s(&["x"]),
            &none,
            &s(&["super", "super", "q"]),
            true
        ),
        None
    );
}

#[test]
fn use_groups_globs_and_renames_are_seen() {
    let files = [
        ("lib.rs", "mod a; mod c; mod d; mod e;"),
        ("a/mod.rs", "pub mod b;"),
        ("a/b.rs", ""),
        ("c.rs", ""),
        ("d.rs", "use crate::{a::b, c};"),
        (
            "e.rs",
            "use crate::a::b::*; use crate::c as cc; use crate::a::{self};",
        ),
    ];
    assert_eq!(
        edges_of(&files),
        [
            ("d".into(), "a::b".into(), "crate::a::b".into()),
            ("d".into(), "c".into(), "crate::c".into()),
            ("e".into(), "a::b".into(), "crate::a::b::*".into()),
            ("e".into(), "c".into(), "crate::c".into()),
            ("e".into(), "a".into(), "crate::a".into()),
        ]
    );
}

#[test]
fn child_modules_and_foreign_paths() {
    // `x::g` names the declared child; `x` alone is a local; `std::…`, `Self::…` are not ours.
    let files = [
        ("lib.rs", "mod a;"),
        (
            "a/mod.rs",
            "mod x; fn f() { x::g(); let y = x; std::mem::drop(y); Self::h(); }",
        ),
        ("a/x.rs", "pub fn g() {}"),
    ];
    assert_eq!(
        edges_of(&files),
        [("a".into(), "a::x".into(), "x::g".into())]
    );
}

#[test]
fn cfg_test_items_are_ignored() {
    let c = circles_of(&[
        ("lib.rs", "mod a; mod b;"),
        (
            "a.rs",
            "use crate::b::Y;
             #[cfg(test)] mod tests { use crate::b::Z; }
             #[cfg(test)] mod more;
             struct S { #[cfg(test)] z: crate::b::Z }
             impl S { #[cfg(test)] fn t() { crate::b::z(); } }
             #[cfg(all(test, unix))] fn u() { crate::b::z(); }",
        ),
        ("a/more.rs", "use crate::b::Z;"),
        (
            "b.rs",
            "pub struct Y; pub struct Z; pub fn z() {}
             #[cfg(test)] fn t() { crate::a::S; }
             #[cfg(test)] use crate::a::S;
             fn f() { #[cfg(test)] let q = crate::a::S; }",
        ),
    ]);
    assert_eq!(c, Vec::<String>::new());
    // …but cfg(not(test)) and other cfgs are real code.
    let c = circles_of(&[
        ("lib.rs", "mod a; mod b;"),
        ("a.rs", "use crate::b::Y;"),
        ("b.rs", "pub struct Y; #[cfg(not(test))] use crate::a::S; #[cfg(unix)] fn f() { crate::a::g(); }"),
    ]);
    assert_eq!(c.len(), 1, "{c:?}");
}

#[test]
fn ancestor_descendant_edges_are_not_circles() {
    let c = circles_of(&[
        (
            "lib.rs",
            "mod a; pub use a::x::Thing; fn f() { a::helper(); }",
        ),
        (
            "a/mod.rs",
            "pub mod x; pub use x::Thing; pub fn helper() { crate::a::x::g(); }",
        ),
        (
            "a/x.rs",
            "use super::helper; use crate::a; pub struct Thing; pub fn g() { crate::f2() } ",
        ),
    ]);
    assert_eq!(c, Vec::<String>::new());
}

#[test]
fn a_floor_reaching_up_is_reported() {
    let v = floors_of(&[
        (
            "lib.rs",
            "pub mod contract; pub mod kernels; pub mod driver; pub use driver::run;",
        ),
        ("contract.rs", ""),
        ("kernels/mod.rs", "mod forces;"),
        (
            "kernels/forces.rs",
            "use crate::contract::Scene; fn f() { crate::driver::x(); }",
        ),
        ("driver.rs", "use crate::kernels::forces; pub fn run() {}"),
    ]);
    assert_eq!(
        v,
        [
            "t/src/kernels/forces.rs: `crate::driver::x`: floor kernels (#1) reaches up to floor \
          driver (#5)"
        ]
    );
}

#[test]
fn contract_referring_to_kernels_is_reported() {
    let v = floors_of(&[
        ("lib.rs", "pub mod contract; pub mod kernels;"),
        ("contract/mod.rs", "pub mod scene;"),
        (
            "contract/scene.rs",
            "use super::super::kernels::K; use super::Other;",
        ),
        ("kernels.rs", "pub struct K;"),
    ]);
    assert_eq!(v.len(), 1, "{v:?}");
    assert!(
        v[0].starts_with(
            "t/src/contract/scene.rs: `super::super::kernels::K`: floor contract (#0) reaches up \
             to floor kernels (#1) (contract may refer to nothing outside contract)"
        ),
        "{v:?}"
    );
}

#[test]
fn an_unknown_top_level_runtime_module_is_reported() {
    let v = floors_of(&[
        (
            "lib.rs",
            "pub mod contract; pub mod scene; mod misc { } #[cfg(test)] mod testutil;",
        ),
        ("contract.rs", ""),
        ("scene.rs", ""),
    ]);
    assert_eq!(v.len(), 2, "{v:?}");
    assert!(
        v[0].contains("top-level module `scene` is not a floor"),
        "{v:?}"
    );
    assert!(
        v[0].contains("floor to FLOORS in tests/tests/architecture.rs"),
        "{v:?}"
    );
    assert!(
        v[1].contains("top-level module `misc` is not a floor"),
        "{v:?}"
    );
}

#[test]
fn a_floor_reaching_the_facade_is_reported() {
    let v = floors_of(&[
        ("lib.rs", "pub mod contract; pub use contract::Scene;"),
        (
            "contract.rs",
            "pub struct Scene; fn f() -> crate::Scene { Scene }",
        ),
    ]);
    assert_eq!(v.len(), 1, "{v:?}");
    assert!(v[0].contains("reaches the crate root"), "{v:?}");
}
