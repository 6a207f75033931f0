//! Bad scenes never crash the runtime (issue 7, "Bad input, hardened").
//!
//! A [`Scene`] reaches the runtime as JSON (`mbdc check --json`, the scene file a compiled
//! program loads with `--scene`) or built in Rust. These property tests take the JSON of
//! every model in `models/` and mutate it, then check, for every input:
//! - `serde_json::from_str::<Scene>` (and [`compiled::scene_from_json`], the generated
//!   program's loader) returns a scene or an error, never panics;
//! - [`Interp::new`] returns an error that names an item of the scene (`body 'x'`,
//!   `joint 'j'`, …), or a system whose initial state, masses and inverse inertias are
//!   finite;
//! - on an accepted scene, the analyses that take a scene (effects, topology, stability
//!   estimate, the compiled plan in both layouts and its structure key, the run settings)
//!   do not panic, and a plan checked against the seed's key is accepted or refused with
//!   [`CompiledError::Structure`];
//! - on a subset of accepted scenes, a few steps of every method of [`integrators::make`]
//!   (and of the scene's own method with its options) finish or stop with a failure
//!   report, and the assembly (`--assemble`) returns.
//!
//! Mutations, one to four per case: JSON numbers replaced by 0, negative, huge (1e308,
//! u64::MAX), tiny (5e-324) or fractional values; body, joint, node and set indices moved
//! out of range; arrays emptied, truncated, shuffled or with elements duplicated; object
//! fields swapped, removed or replaced by values of another type; enum variants renamed;
//! subtrees grafted elsewhere; and, on the deserialized scene (JSON cannot carry them),
//! floats replaced by NaN, ±∞, 0, −x, huge and tiny values, and inertia tensors made
//! indefinite, singular or extreme. Plus truncated JSON, flipped and inserted bytes, and
//! random bytes.
//!
//! Bounds: every case runs under a watchdog thread that aborts the test binary (naming
//! the case) when one case takes more than [`CASE_SECONDS`]; a counting allocator makes
//! the test fail when a case's live memory grows by more than [`CASE_BYTES`], and
//! refuses any single allocation above [`MAX_ALLOCATION`] (the process aborts with the
//! size). The counts are chosen to keep this file to well under a minute at opt-level 2.

use std::alloc::{GlobalAlloc, Layout as AllocLayout, System as SystemAlloc};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::{Duration, Instant};

use mbdc_runtime::app::{self, Settings};
use mbdc_runtime::compiled::{self, CompiledError, Mode, Plan};
use mbdc_runtime::integrators::{self, State};
use mbdc_runtime::interp::{Interp, InterpError};
use mbdc_runtime::run_loop::{self, Frame, Observer, OnFailure, RunConfig, Watchdog};
use mbdc_runtime::scene::{
    Attachment, Body, BodyRef, Fn1, ForceKind, Joint, JointKind, MethodSpec, Scene, Shape,
};
use mbdc_runtime::system::System;
use mbdc_runtime::{assemble, step_limits, topology};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestCaseError, TestRunner};
use serde_json::Value;

// ---------------------------------------------------------------------------------------
// Memory and time bounds.

/// Largest single allocation the runtime may ask for while a case runs.
const MAX_ALLOCATION: usize = 1 << 30;
/// Largest growth of live heap memory during one case (all threads).
const CASE_BYTES: usize = 256 << 20;
/// Longest a case may take before the watchdog aborts the test binary.
const CASE_SECONDS: u64 = 60;

struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

fn note_alloc(size: usize) {
    let now = LIVE.fetch_add(size, Ordering::Relaxed) + size;
    PEAK.fetch_max(now, Ordering::Relaxed);
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: AllocLayout) -> *mut u8 {
        if layout.size() > MAX_ALLOCATION {
            return std::ptr::null_mut();
        }
        let p = SystemAlloc.alloc(layout);
        if !p.is_null() {
            note_alloc(layout.size());
        }
        p
    }
    unsafe fn alloc_zeroed(&self, layout: AllocLayout) -> *mut u8 {
        if layout.size() > MAX_ALLOCATION {
            return std::ptr::null_mut();
        }
        let p = SystemAlloc.alloc_zeroed(layout);
        if !p.is_null() {
            note_alloc(layout.size());
        }
        p
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: AllocLayout) {
        SystemAlloc.dealloc(ptr, layout);
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: AllocLayout, new_size: usize) -> *mut u8 {
        if new_size > MAX_ALLOCATION {
            return std::ptr::null_mut();
        }
        let p = SystemAlloc.realloc(ptr, layout, new_size);
        if !p.is_null() {
            LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
            note_alloc(new_size);
        }
        p
    }
}

#[global_allocator]
static ALLOC: Counting = Counting;

/// Aborts the process when a case takes longer than [`CASE_SECONDS`], printing the case:
/// a hang must fail the test with a reproducer, not time out the CI job.
struct Hang {
    started: Arc<AtomicU64>,
    case: Arc<Mutex<String>>,
    done: Arc<AtomicBool>,
    epoch: Instant,
}

impl Hang {
    fn watch(test: &'static str) -> Hang {
        let h = Hang {
            started: Arc::new(AtomicU64::new(u64::MAX)),
            case: Arc::new(Mutex::new(String::new())),
            done: Arc::new(AtomicBool::new(false)),
            epoch: Instant::now(),
        };
        let (started, case, done, epoch) =
            (h.started.clone(), h.case.clone(), h.done.clone(), h.epoch);
        std::thread::spawn(move || {
            while !done.load(Ordering::Relaxed) {
                std::thread::sleep(Duration::from_millis(200));
                let s = started.load(Ordering::Relaxed);
                let now = epoch.elapsed().as_millis() as u64;
                if s != u64::MAX && now.saturating_sub(s) > CASE_SECONDS * 1000 {
                    let c = case.lock().map(|c| c.clone()).unwrap_or_default();
                    eprintln!("{test}: a case ran for more than {CASE_SECONDS} s (a hang):\n{c}");
                    std::process::abort();
                }
            }
        });
        h
    }

    fn begin(&self, describe: impl FnOnce() -> String) {
        if let Ok(mut c) = self.case.lock() {
            *c = describe();
        }
        self.started
            .store(self.epoch.elapsed().as_millis() as u64, Ordering::Relaxed);
    }

    fn end(&self) {
        self.started.store(u64::MAX, Ordering::Relaxed);
    }
}

impl Drop for Hang {
    fn drop(&mut self) {
        self.done.store(true, Ordering::Relaxed);
    }
}

/// The thread's one-time allocations, made before its first case is measured: faer's first
/// dense factorization of 100 unknowns or more on a thread keeps about 520 MB on this machine
/// (buffers of its kernels, kept per thread; a later `DenseLu` of 873 unknowns peaks at 11
/// MB), which the first case to factor such a matrix counted as its own growth
/// (`implicit_trapezoid` on a mutated `tree8.mbd`: CI failed on it).
fn warm_up() {
    thread_local! {
        static WARM: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
    }
    if !WARM.get() {
        use mbdc_runtime::linalg::{DenseCholesky, DenseLu, PivotedCholesky, DEFAULT_PIVOT_TOL};
        drop(DenseLu::new(256));
        drop(DenseCholesky::new(256));
        drop(PivotedCholesky::new(256, DEFAULT_PIVOT_TOL));
        WARM.set(true);
    }
}

/// One bounded case at a time across the tests of this file: the live-heap count is the
/// process's, so a case of one test measured beside another test's case counted both (CI saw
/// "live memory grew by 520 MB" on a mutated scene while the large-scene test ran).
static ONE_CASE_AT_A_TIME: Mutex<()> = Mutex::new(());

thread_local! {
    /// Whether this thread holds [`ONE_CASE_AT_A_TIME`] (a test that builds a large scene
    /// holds it across the building and its bounded runs).
    static HOLDING: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// This thread's turn at the heap ([`ONE_CASE_AT_A_TIME`]); nothing when it has it already.
struct Alone(Option<std::sync::MutexGuard<'static, ()>>);

fn alone() -> Alone {
    if HOLDING.get() {
        return Alone(None);
    }
    let g = ONE_CASE_AT_A_TIME
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    HOLDING.set(true);
    Alone(Some(g))
}

impl Drop for Alone {
    fn drop(&mut self) {
        if self.0.is_some() {
            HOLDING.set(false);
        }
    }
}

/// Runs `f` and fails when the live heap grew by more than [`CASE_BYTES`] meanwhile (no
/// other test's case runs meanwhile: [`alone`]).
fn bounded<T>(what: &str, f: impl FnOnce() -> T) -> Result<T, TestCaseError> {
    let _alone = alone();
    warm_up();
    let base = LIVE.load(Ordering::Relaxed);
    PEAK.fetch_min(base, Ordering::Relaxed);
    PEAK.fetch_max(base, Ordering::Relaxed);
    let r = f();
    let grew = PEAK.load(Ordering::Relaxed).saturating_sub(base);
    if grew > CASE_BYTES {
        return Err(TestCaseError::fail(format!(
            "{what}: live memory grew by {} MB",
            grew >> 20
        )));
    }
    Ok(r)
}

// ---------------------------------------------------------------------------------------
// Seeds: the JSON of every model.

struct Seed {
    name: String,
    value: Value,
    /// Structure keys of the unrolled and table plans, when the runtime accepts the model.
    keys: Option<(u64, u64)>,
}

fn model_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return;
    };
    let mut paths: Vec<PathBuf> = rd.filter_map(|e| e.ok().map(|e| e.path())).collect();
    paths.sort();
    for p in paths {
        if p.is_dir() {
            model_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "mbd") {
            out.push(p);
        }
    }
}

/// Bench models are lowered at a small size so that a case stays cheap.
const SMALL: &[(&str, &str)] = &[("N", "6"), ("K", "4")];

fn seeds() -> &'static [Seed] {
    static SEEDS: OnceLock<Vec<Seed>> = OnceLock::new();
    SEEDS.get_or_init(|| {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../models");
        let mut files = Vec::new();
        model_files(&root, &mut files);
        let mut out = Vec::new();
        for f in files {
            let text = std::fs::read_to_string(&f).expect("model file");
            let overrides: Vec<mbdc_compiler::Override> = SMALL
                .iter()
                .filter(|(p, _)| text.contains(&format!("param {p} =")))
                .map(|(p, v)| mbdc_compiler::Override::new(*p, *v))
                .collect();
            let loaded = mbdc_compiler::load_file(&f, &overrides);
            let Some(scene) = loaded.scene.clone() else {
                panic!("{}: {}", f.display(), loaded.render_plain());
            };
            let keys = match (
                Plan::new(&scene, Mode::Unrolled),
                Plan::new(&scene, Mode::Tables),
            ) {
                (Ok(a), Ok(b)) => Some((a.key(), b.key())),
                _ => None,
            };
            let value = serde_json::to_value(&scene).expect("scene to JSON");
            out.push(Seed {
                name: f.file_name().unwrap().to_string_lossy().into_owned(),
                value,
                keys,
            });
        }
        assert!(out.len() >= 15, "only {} models", out.len());
        assert!(
            out.iter().filter(|s| s.keys.is_some()).count() >= 10,
            "too few models run on the rigid-body runtime"
        );
        out
    })
}

// ---------------------------------------------------------------------------------------
// Mutations.

/// Replacement JSON numbers.
fn numbers() -> Vec<Value> {
    use serde_json::json;
    vec![
        json!(0),
        json!(1),
        json!(2),
        json!(3),
        json!(-1),
        json!(-0.0),
        json!(0.5),
        json!(-2.5),
        json!(1e308),
        json!(-1e308),
        json!(1e-308),
        json!(5e-324),
        json!(-1e-300),
        json!(1e19),
        json!(u64::MAX),
        json!(i64::MIN),
        json!(4_294_967_296u64),
        json!(1_000_000),
        json!(123_456_789),
        json!(1e-12),
    ]
}

/// Variant names of the scene's enums (unit variants and externally tagged ones).
const VARIANTS: &[&str] = &[
    "Ground",
    "Body",
    "Spherical",
    "Revolute",
    "Prismatic",
    "Cylindrical",
    "Universal",
    "Fixed",
    "Planar",
    "Distance",
    "DriveAngle",
    "DriveDisplacement",
    "Rolling",
    "PointVelocity",
    "Curve",
    "World",
    "Point",
    "Torque",
    "Spring",
    "RotationalSpring",
    "Const",
    "Var",
    "Add",
    "Div",
    "Powf",
    "Unary",
    "Smoothstep",
    "Table",
    "JacobiSn",
    "Sin",
    "Sqrt",
    "Ln",
    "Sphere",
    "Box",
    "Plane",
    "Staggered",
    "Baumgarte",
    "Penalty",
    "CoordinatePartitioning",
    "ImplicitTrapezoid",
    "NaturalPartitioning",
    "RungeKutta4",
    "DormandPrince",
    "DormandPrince853",
    "StateTime",
    "Exact",
    "Midpoint",
    "Bar2",
    "Hex8",
    "Nope",
];

/// Keys whose values are indices into other arrays.
const INDEX_KEYS: &[&str] = &["Body", "joint", "body", "node", "set"];

/// Replacement values of another type.
fn others() -> Vec<Value> {
    use serde_json::json;
    vec![
        Value::Null,
        json!(true),
        json!("x"),
        json!({}),
        json!([]),
        json!([1, 2]),
        json!(0),
        json!({"Body": 0}),
        json!({"Const": 1.0}),
    ]
}

/// Special floats set on the deserialized scene.
const SPECIAL: &[f64] = &[
    f64::NAN,
    f64::INFINITY,
    f64::NEG_INFINITY,
    0.0,
    -0.0,
    -1.0,
    1e308,
    -1e308,
    5e-324,
    1e-300,
    1e300,
    f64::MAX,
    f64::MIN_POSITIVE,
];

#[derive(Clone, Debug)]
enum Mutation {
    /// The k-th JSON number becomes `numbers()[i]`.
    Number(usize, usize),
    /// The index under the k-th index key becomes its value plus `d`, or a huge one.
    Index(usize, i64),
    /// The k-th array becomes empty.
    Empty(usize),
    /// The k-th array keeps its first `n` elements.
    Truncate(usize, usize),
    /// Element `i` of the k-th array is repeated `n` more times.
    Duplicate(usize, usize, usize),
    /// Elements `i` and `j` of the k-th array are swapped.
    SwapElements(usize, usize, usize),
    /// Fields `i` and `j` of the k-th object swap their values.
    SwapFields(usize, usize, usize),
    /// Field `i` of the k-th object is removed.
    Remove(usize, usize),
    /// The k-th value becomes `others()[i]`.
    Other(usize, usize),
    /// The k-th enum tag (a string, or the key of a one-key object) becomes `VARIANTS[i]`.
    Variant(usize, usize),
    /// A copy of the `from`-th value replaces the `to`-th value.
    Graft(usize, usize),
    /// The JSON text is cut at a fraction `f` (per mille) of its length.
    Cut(u16),
    /// Bytes at fractions of the text are overwritten.
    Bytes(Vec<(u16, u8)>),
    /// Bytes are inserted at a fraction of the text.
    Insert(u16, Vec<u8>),
    /// On the deserialized scene: the k-th float becomes `SPECIAL[i]`, or `-x`
    /// (`i == SPECIAL.len()`), or `x · 1e200` (`i == SPECIAL.len() + 1`).
    Float(usize, usize),
    /// On the deserialized scene: body k's inertia becomes the i-th bad tensor.
    Inertia(usize, usize),
    /// On the deserialized scene: joint k's sides become bodies (or the ground) `a`, `b`
    /// modulo the number of bodies plus one.
    Rewire(usize, usize, usize),
    /// On the deserialized scene: joint k becomes the i-th kind of [`joint_kind`], its
    /// index (drivers) `j`.
    Kind(usize, usize, usize),
    /// On the deserialized scene: the k-th time function becomes the i-th of
    /// [`nasty_fn`].
    Function(usize, usize),
    /// On the deserialized scene: a force element of the i-th kind of [`add_force`] on
    /// bodies or joints `a`, `b`.
    AddForce(usize, usize, usize),
    /// On the deserialized scene: a contact of the i-th pair of shapes between `a` and `b`.
    AddContact(usize, usize, usize),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let n = numbers().len();
    let o = others().len();
    let special = SPECIAL.len() + 2;
    prop_oneof![
        6 => (any::<usize>(), 0..n).prop_map(|(k, i)| Mutation::Number(k, i)),
        4 => (any::<usize>(), prop_oneof![-3i64..4, Just(i64::MAX), Just(1 << 40)])
            .prop_map(|(k, d)| Mutation::Index(k, d)),
        1 => any::<usize>().prop_map(Mutation::Empty),
        1 => (any::<usize>(), 0usize..4).prop_map(|(k, n)| Mutation::Truncate(k, n)),
        1 => (any::<usize>(), any::<usize>(), 1usize..40)
            .prop_map(|(k, i, n)| Mutation::Duplicate(k, i, n)),
        1 => (any::<usize>(), any::<usize>(), any::<usize>())
            .prop_map(|(k, i, j)| Mutation::SwapElements(k, i, j)),
        2 => (any::<usize>(), any::<usize>(), any::<usize>())
            .prop_map(|(k, i, j)| Mutation::SwapFields(k, i, j)),
        1 => (any::<usize>(), any::<usize>()).prop_map(|(k, i)| Mutation::Remove(k, i)),
        1 => (any::<usize>(), 0..o).prop_map(|(k, i)| Mutation::Other(k, i)),
        2 => (any::<usize>(), 0..VARIANTS.len()).prop_map(|(k, i)| Mutation::Variant(k, i)),
        1 => (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Mutation::Graft(a, b)),
        1 => (0u16..1000).prop_map(Mutation::Cut),
        1 => proptest::collection::vec((0u16..1000, any::<u8>()), 1..4).prop_map(Mutation::Bytes),
        1 => (0u16..1000, proptest::collection::vec(any::<u8>(), 1..8))
            .prop_map(|(a, b)| Mutation::Insert(a, b)),
        8 => (any::<usize>(), 0..special).prop_map(|(k, i)| Mutation::Float(k, i)),
        2 => (any::<usize>(), 0usize..8).prop_map(|(k, i)| Mutation::Inertia(k, i)),
        2 => (any::<usize>(), any::<usize>(), any::<usize>())
            .prop_map(|(k, a, b)| Mutation::Rewire(k, a, b)),
        2 => (any::<usize>(), 0..JOINT_KINDS, any::<usize>())
            .prop_map(|(k, i, j)| Mutation::Kind(k, i, j)),
        3 => (any::<usize>(), 0..NASTY_FNS).prop_map(|(k, i)| Mutation::Function(k, i)),
        3 => (0..FORCE_KINDS, any::<usize>(), any::<usize>())
            .prop_map(|(i, a, b)| Mutation::AddForce(i, a, b)),
        2 => (0..CONTACT_KINDS, any::<usize>(), any::<usize>())
            .prop_map(|(i, a, b)| Mutation::AddContact(i, a, b)),
    ]
}

fn count(v: &Value, pred: &dyn Fn(&Value) -> bool) -> usize {
    let here = usize::from(pred(v));
    here + match v {
        Value::Array(a) => a.iter().map(|x| count(x, pred)).sum(),
        Value::Object(o) => o.values().map(|x| count(x, pred)).sum(),
        _ => 0,
    }
}

fn nth_mut<'a>(
    v: &'a mut Value,
    pred: &dyn Fn(&Value) -> bool,
    k: &mut usize,
) -> Option<&'a mut Value> {
    if pred(v) {
        if *k == 0 {
            return Some(v);
        }
        *k -= 1;
    }
    match v {
        Value::Array(a) => a.iter_mut().find_map(|x| nth_mut(x, pred, k)),
        Value::Object(o) => o.values_mut().find_map(|x| nth_mut(x, pred, k)),
        _ => None,
    }
}

/// The k-th (modulo their number) value matching `pred`.
fn pick<'a>(v: &'a mut Value, k: usize, pred: &dyn Fn(&Value) -> bool) -> Option<&'a mut Value> {
    let n = count(v, pred);
    if n == 0 {
        return None;
    }
    nth_mut(v, pred, &mut (k % n))
}

fn is_tag(v: &Value) -> bool {
    match v {
        Value::String(s) => s.starts_with(|c: char| c.is_ascii_uppercase()),
        Value::Object(o) => {
            o.len() == 1
                && o.keys()
                    .all(|k| k.starts_with(|c: char| c.is_ascii_uppercase()))
        }
        _ => false,
    }
}

fn mutate_value(v: &mut Value, m: &Mutation) {
    let nums = numbers();
    match m {
        Mutation::Number(k, i) => {
            if let Some(x) = pick(v, *k, &|x| x.is_number()) {
                *x = nums[*i].clone();
            }
        }
        Mutation::Index(k, d) => {
            let has = |x: &Value| {
                x.as_object().is_some_and(|o| {
                    INDEX_KEYS
                        .iter()
                        .any(|k| o.get(*k).is_some_and(|v| v.is_u64()))
                })
            };
            if let Some(Value::Object(o)) = pick(v, *k, &has) {
                let key = INDEX_KEYS
                    .iter()
                    .find(|k| o.get(**k).is_some_and(|v| v.is_u64()));
                if let Some(x) = key.and_then(|k| o.get_mut(*k)) {
                    let old = x.as_u64().unwrap_or(0) as i64;
                    *x = match *d {
                        i64::MAX => Value::from(u64::MAX),
                        d if d >= 1 << 40 => Value::from(d),
                        d => Value::from(old.saturating_add(d)),
                    };
                }
            }
        }
        Mutation::Empty(k) => {
            if let Some(Value::Array(a)) = pick(v, *k, &|x| x.is_array()) {
                a.clear();
            }
        }
        Mutation::Truncate(k, n) => {
            if let Some(Value::Array(a)) =
                pick(v, *k, &|x| x.as_array().is_some_and(|a| a.len() > 1))
            {
                a.truncate(*n);
            }
        }
        Mutation::Duplicate(k, i, n) => {
            if let Some(Value::Array(a)) =
                pick(v, *k, &|x| x.as_array().is_some_and(|a| !a.is_empty()))
            {
                let e = a[i % a.len()].clone();
                for _ in 0..*n {
                    a.push(e.clone());
                }
            }
        }
        Mutation::SwapElements(k, i, j) => {
            if let Some(Value::Array(a)) =
                pick(v, *k, &|x| x.as_array().is_some_and(|a| a.len() > 1))
            {
                let n = a.len();
                a.swap(i % n, j % n);
            }
        }
        Mutation::SwapFields(k, i, j) => {
            if let Some(Value::Object(o)) =
                pick(v, *k, &|x| x.as_object().is_some_and(|o| o.len() > 1))
            {
                let keys: Vec<String> = o.keys().cloned().collect();
                let (a, b) = (&keys[i % keys.len()], &keys[j % keys.len()]);
                let va = o.get(a).cloned().unwrap_or(Value::Null);
                let vb = o.insert(b.clone(), va).unwrap_or(Value::Null);
                o.insert(a.clone(), vb);
            }
        }
        Mutation::Remove(k, i) => {
            if let Some(Value::Object(o)) =
                pick(v, *k, &|x| x.as_object().is_some_and(|o| !o.is_empty()))
            {
                let key = o.keys().nth(i % o.len()).cloned().unwrap_or_default();
                o.remove(&key);
            }
        }
        Mutation::Other(k, i) => {
            let o = others();
            if let Some(x) = pick(v, *k, &|_| true) {
                *x = o[*i].clone();
            }
        }
        Mutation::Variant(k, i) => {
            let name = VARIANTS[*i].to_string();
            match pick(v, *k, &is_tag) {
                Some(Value::String(s)) => *s = name,
                Some(Value::Object(o)) => {
                    let (_, payload) = o
                        .iter()
                        .next()
                        .map(|(k, v)| (k.clone(), v.clone()))
                        .unwrap_or_default();
                    o.clear();
                    o.insert(name, payload);
                }
                _ => {}
            }
        }
        Mutation::Graft(from, to) => {
            let src = pick(v, *from, &|_| true).map(|x| x.clone());
            if let (Some(src), Some(dst)) = (src, pick(v, *to, &|_| true)) {
                *dst = src;
            }
        }
        _ => {}
    }
}

fn at(text: &[u8], f: u16) -> usize {
    text.len() * f as usize / 1000
}

fn mutate_text(text: &mut Vec<u8>, m: &Mutation) {
    match m {
        Mutation::Cut(f) => text.truncate(at(text, *f)),
        Mutation::Bytes(b) => {
            for (f, x) in b {
                let i = at(text, *f);
                if i < text.len() {
                    text[i] = *x;
                }
            }
        }
        Mutation::Insert(f, b) => {
            let i = at(text, *f);
            text.splice(i..i, b.iter().copied());
        }
        _ => {}
    }
}

/// Calls `f` on every float of the scene's rigid-body part, simulation settings and
/// reference, in a fixed order.
fn each_float(s: &mut Scene, f: &mut dyn FnMut(&mut f64)) {
    fn fn1(x: &mut Fn1, f: &mut dyn FnMut(&mut f64)) {
        match x {
            Fn1::Const(c) => f(c),
            Fn1::Var => {}
            Fn1::Add(a, b)
            | Fn1::Sub(a, b)
            | Fn1::Mul(a, b)
            | Fn1::Div(a, b)
            | Fn1::Min(a, b)
            | Fn1::Max(a, b) => {
                fn1(a, f);
                fn1(b, f);
            }
            Fn1::Neg(a) | Fn1::Unary(_, a) => fn1(a, f),
            Fn1::Powf(a, n) | Fn1::JacobiSn(a, n) | Fn1::JacobiCn(a, n) | Fn1::JacobiDn(a, n) => {
                fn1(a, f);
                f(n);
            }
            Fn1::Smoothstep(a, x0, x1) => {
                fn1(a, f);
                f(x0);
                f(x1);
            }
            Fn1::Table(a, t) => {
                fn1(a, f);
                t.iter_mut().flatten().for_each(&mut *f);
            }
        }
    }
    fn att(a: &mut Attachment, f: &mut dyn FnMut(&mut f64)) {
        a.point.iter_mut().for_each(&mut *f);
        a.frame.iter_mut().for_each(&mut *f);
    }
    if let Some(g) = &mut s.gravity {
        g.iter_mut().for_each(&mut *f);
    }
    for b in &mut s.bodies {
        f(&mut b.mass);
        b.inertia.iter_mut().flatten().for_each(&mut *f);
        b.position.iter_mut().for_each(&mut *f);
        b.orientation.iter_mut().for_each(&mut *f);
        b.velocity.iter_mut().for_each(&mut *f);
        b.angular_velocity.iter_mut().for_each(&mut *f);
    }
    for j in &mut s.joints {
        att(&mut j.a, f);
        att(&mut j.b, f);
        match &mut j.kind {
            JointKind::Distance { length: x } | JointKind::Rolling { radius: x } => f(x),
            JointKind::DriveAngle { angle: x, .. }
            | JointKind::DriveDisplacement {
                displacement: x, ..
            }
            | JointKind::Curve { curve: x } => fn1(x, f),
            JointKind::PointVelocity { velocity } => velocity.iter_mut().for_each(|x| fn1(x, f)),
            _ => {}
        }
    }
    for c in &mut s.forces {
        match &mut c.kind {
            ForceKind::Point { at, value, .. } => {
                att(at, f);
                value.iter_mut().for_each(|x| fn1(x, f));
            }
            ForceKind::Torque { value, .. } => value.iter_mut().for_each(|x| fn1(x, f)),
            ForceKind::Spring {
                a,
                b,
                stiffness,
                rest_length,
                damping,
            } => {
                att(a, f);
                att(b, f);
                f(stiffness);
                f(rest_length);
                f(damping);
            }
            ForceKind::RotationalSpring {
                stiffness,
                rest_angle,
                damping,
                lock_angle,
                ..
            } => {
                f(stiffness);
                f(rest_angle);
                f(damping);
                if let Some(l) = lock_angle {
                    f(l);
                }
            }
        }
    }
    for c in &mut s.contacts {
        for (a, shape) in [&mut c.a, &mut c.b] {
            att(a, f);
            match shape {
                Shape::Sphere { radius } => f(radius),
                Shape::Box { half_extents } => half_extents.iter_mut().for_each(&mut *f),
                Shape::Plane => {}
            }
        }
        f(&mut c.stiffness);
        f(&mut c.damping);
        f(&mut c.friction);
    }
    f(&mut s.simulate.duration);
    f(&mut s.simulate.step);
    match &mut s.simulate.method {
        MethodSpec::Staggered(o) => {
            if let Some(e) = &mut o.epsilon {
                f(e);
            }
        }
        MethodSpec::Baumgarte { alpha, beta } => {
            f(alpha);
            f(beta);
        }
        MethodSpec::Penalty { epsilon } => {
            if let Some(e) = epsilon {
                f(e);
            }
        }
        MethodSpec::ImplicitTrapezoid { tolerance, .. } => f(tolerance),
        MethodSpec::NaturalPartitioning {
            epsilon, tolerance, ..
        } => {
            if let Some(e) = epsilon {
                f(e);
            }
            f(tolerance);
        }
        MethodSpec::DormandPrince { tolerance } | MethodSpec::DormandPrince853 { tolerance } => {
            f(tolerance)
        }
        MethodSpec::CoordinatePartitioning
        | MethodSpec::RungeKutta4
        | MethodSpec::StateTime { .. } => {}
    }
    if let Some(r) = &mut s.reference {
        for b in &mut r.bodies {
            for x in b.position.iter_mut().flatten() {
                fn1(x, f);
            }
            for x in b.orientation.iter_mut().flatten() {
                fn1(x, f);
            }
        }
    }
}

/// Bad inertia tensors: indefinite, singular (zero, rank one), extreme, asymmetric.
fn bad_inertia(i: usize) -> [[f64; 3]; 3] {
    let d = |a: f64, b: f64, c: f64| [[a, 0.0, 0.0], [0.0, b, 0.0], [0.0, 0.0, c]];
    match i {
        0 => d(1.0, 1.0, -1.0),
        1 => d(0.0, 0.0, 0.0),
        2 => [[1.0, 1.0, 1.0], [1.0, 1.0, 1.0], [1.0, 1.0, 1.0]],
        3 => [[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        4 => d(1e308, 1e308, 1e308),
        5 => d(5e-324, 5e-324, 5e-324),
        6 => d(1e-300, 1.0, 1e300),
        _ => [[1.0, 0.0, 0.0], [0.5, 1.0, 0.0], [0.0, 0.0, 1.0]],
    }
}

/// Calls `f` on every time function of the rigid-body part (forces, drivers, curves).
fn each_fn(s: &mut Scene, f: &mut dyn FnMut(&mut Fn1)) {
    for j in &mut s.joints {
        match &mut j.kind {
            JointKind::DriveAngle { angle: x, .. }
            | JointKind::DriveDisplacement {
                displacement: x, ..
            }
            | JointKind::Curve { curve: x } => f(x),
            JointKind::PointVelocity { velocity } => velocity.iter_mut().for_each(&mut *f),
            _ => {}
        }
    }
    for c in &mut s.forces {
        if let ForceKind::Point { value, .. } | ForceKind::Torque { value, .. } = &mut c.kind {
            value.iter_mut().for_each(&mut *f);
        }
    }
}

const NASTY_FNS: usize = 12;

/// Time functions that are singular, overflow or are undefined somewhere near t = 0.
fn nasty_fn(i: usize) -> Fn1 {
    use mbdc_runtime::scene::UnaryFn;
    let t = || Box::new(Fn1::Var);
    let c = |x: f64| Box::new(Fn1::Const(x));
    match i {
        0 => Fn1::Div(c(1.0), t()),
        1 => Fn1::Unary(UnaryFn::Ln, t()),
        2 => Fn1::Unary(UnaryFn::Sqrt, Box::new(Fn1::Neg(t()))),
        3 => Fn1::Powf(t(), -1.5),
        4 => Fn1::Unary(UnaryFn::Tan, Box::new(Fn1::Mul(c(1e6), t()))),
        5 => Fn1::JacobiSn(t(), 1.0),
        6 => Fn1::Table(t(), vec![[0.0, 1e300]]),
        7 => Fn1::Unary(UnaryFn::Exp, Box::new(Fn1::Mul(c(1e5), t()))),
        8 => Fn1::Table(t(), vec![[0.0, 0.0], [1e-300, 1e300], [1.0, -1e300]]),
        9 => Fn1::Smoothstep(t(), 1.0, 1.0),
        10 => Fn1::Unary(UnaryFn::Acos, Box::new(Fn1::Mul(c(1e3), t()))),
        _ => Fn1::Const(1e300),
    }
}

const JOINT_KINDS: usize = 13;

fn joint_kind(i: usize, j: usize, joints: usize) -> JointKind {
    let joint = j % joints.max(1);
    let sin = || Fn1::Unary(mbdc_runtime::scene::UnaryFn::Sin, Box::new(Fn1::Var));
    match i {
        0 => JointKind::Spherical,
        1 => JointKind::Revolute,
        2 => JointKind::Prismatic,
        3 => JointKind::Cylindrical,
        4 => JointKind::Universal,
        5 => JointKind::Fixed,
        6 => JointKind::Planar,
        7 => JointKind::Distance { length: 0.5 },
        8 => JointKind::DriveAngle {
            joint,
            angle: sin(),
        },
        9 => JointKind::DriveDisplacement {
            joint,
            displacement: sin(),
        },
        10 => JointKind::Rolling { radius: 0.1 },
        11 => JointKind::PointVelocity {
            velocity: [sin(), Fn1::Const(0.0), Fn1::Var],
        },
        _ => JointKind::Curve { curve: sin() },
    }
}

fn side(nb: usize, k: usize) -> BodyRef {
    match k % (nb + 1) {
        0 => BodyRef::Ground,
        i => BodyRef::Body(i - 1),
    }
}

fn att(body: BodyRef, p: f64) -> Attachment {
    Attachment {
        body,
        point: [p, 0.0, -p],
        frame: [0.5, 0.5, 0.5, 0.5],
    }
}

const FORCE_KINDS: usize = 6;

fn add_force(s: &mut Scene, i: usize, a: usize, b: usize) {
    use mbdc_runtime::scene::{Force, ForceFrame};
    let nb = s.bodies.len();
    let nj = s.joints.len();
    let sin = || Fn1::Unary(mbdc_runtime::scene::UnaryFn::Sin, Box::new(Fn1::Var));
    let kind = match i {
        0 => ForceKind::Point {
            at: att(side(nb, a), 0.3),
            value: [sin(), Fn1::Const(1e3), Fn1::Var],
            frame: if b.is_multiple_of(2) {
                ForceFrame::World
            } else {
                ForceFrame::Body
            },
        },
        1 => ForceKind::Torque {
            body: side(nb, a),
            value: [Fn1::Const(1.0), sin(), Fn1::Const(0.0)],
            frame: if b.is_multiple_of(2) {
                ForceFrame::World
            } else {
                ForceFrame::Body
            },
        },
        2 => ForceKind::Spring {
            a: att(side(nb, a), 0.1),
            b: att(side(nb, b), -0.1),
            stiffness: 1e4,
            rest_length: 0.0,
            damping: 10.0,
        },
        3 => ForceKind::Spring {
            a: att(side(nb, a), 0.0),
            b: att(side(nb, b), 0.0),
            stiffness: 1e12,
            rest_length: 1.0,
            damping: 1e9,
        },
        _ => ForceKind::RotationalSpring {
            joint: a % nj.max(1),
            stiffness: 100.0,
            rest_angle: 0.5,
            damping: 1.0,
            lock_angle: (i == 5).then_some(0.0),
        },
    };
    s.forces.push(Force {
        name: format!("added{}", s.forces.len()),
        kind,
        origin: Default::default(),
    });
}

const CONTACT_KINDS: usize = 5;

fn add_contact(s: &mut Scene, i: usize, a: usize, b: usize) {
    let nb = s.bodies.len();
    let sphere = Shape::Sphere { radius: 0.2 };
    let boxed = Shape::Box {
        half_extents: [0.1, 0.2, 0.3],
    };
    let (sa, sb) = match i {
        0 => (sphere, Shape::Plane),
        1 => (Shape::Plane, sphere),
        2 => (sphere, sphere),
        3 => (boxed, Shape::Plane),
        _ => (boxed, boxed),
    };
    s.contacts.push(mbdc_runtime::scene::Contact {
        name: format!("contact{}", s.contacts.len()),
        a: (att(side(nb, a), 0.0), sa),
        b: (att(side(nb, b), 0.0), sb),
        stiffness: 1e7,
        damping: 100.0,
        friction: 0.5,
        origin: Default::default(),
    });
}

fn mutate_scene(s: &mut Scene, m: &Mutation) {
    match m {
        Mutation::Float(k, i) => {
            let mut n = 0;
            each_float(s, &mut |_| n += 1);
            if n == 0 {
                return;
            }
            let (target, mut seen) = (k % n, 0);
            each_float(s, &mut |x| {
                if seen == target {
                    *x = match i.checked_sub(SPECIAL.len()) {
                        None => SPECIAL[*i],
                        Some(0) => -*x,
                        Some(_) => *x * 1e200,
                    };
                }
                seen += 1;
            });
        }
        Mutation::Inertia(k, i) if !s.bodies.is_empty() => {
            let n = s.bodies.len();
            s.bodies[k % n].inertia = bad_inertia(*i);
        }
        Mutation::Inertia(..) => {}
        Mutation::Rewire(k, a, b) => {
            let (nb, nj) = (s.bodies.len(), s.joints.len());
            if nj > 0 {
                let j = &mut s.joints[k % nj];
                j.a.body = side(nb, *a);
                j.b.body = side(nb, *b);
            }
        }
        Mutation::Kind(k, i, j) => {
            let nj = s.joints.len();
            if nj > 0 {
                s.joints[k % nj].kind = joint_kind(*i, *j, nj);
            }
        }
        Mutation::Function(k, i) => {
            let mut n = 0;
            each_fn(s, &mut |_| n += 1);
            if n > 0 {
                let (target, mut seen) = (k % n, 0);
                each_fn(s, &mut |f| {
                    if seen == target {
                        *f = nasty_fn(*i);
                    }
                    seen += 1;
                });
            }
        }
        Mutation::AddForce(i, a, b) => add_force(s, *i, *a, *b),
        Mutation::AddContact(i, a, b) => add_contact(s, *i, *a, *b),
        _ => {}
    }
}

// ---------------------------------------------------------------------------------------
// Checks.

/// Whether `name` is a part of one of the scene's beams (`BEAM.node[k]`, `BEAM.clamp[k]`).
fn of_beam(scene: &Scene, name: &str) -> bool {
    scene.beams.iter().any(|b| {
        name.strip_prefix(b.name.as_str()).is_some_and(|rest| {
            rest.starts_with(".node[") || rest.starts_with(".clamp[") || rest.starts_with(".pin[")
        })
    })
}

/// Whether `e` names an item of `scene` of the kind it says.
fn names_an_item(scene: &Scene, e: &InterpError) -> bool {
    match e {
        InterpError::Beam { name, reason } => {
            !reason.is_empty() && scene.beams.iter().any(|b| &b.name == name)
        }
        InterpError::Mesh { name, .. } => scene.meshes.iter().any(|m| &m.name == name),
        InterpError::Invalid { item, name, reason } => {
            !reason.is_empty()
                && match *item {
                    // a beam's nodes are bodies `BEAM.node[k]`, its attachments joints
                    // `BEAM.clamp[k]` / `BEAM.pin[k]`
                    "body" => scene.bodies.iter().any(|b| &b.name == name) || of_beam(scene, name),
                    "joint" => scene.joints.iter().any(|j| &j.name == name) || of_beam(scene, name),
                    "force" => scene.forces.iter().any(|f| &f.name == name),
                    "contact" => scene.contacts.iter().any(|c| &c.name == name),
                    "simulate" | "scene" => &scene.name == name,
                    "reference" => &scene.name == name,
                    _ => false,
                }
        }
    }
}

struct Quiet;
impl Observer for Quiet {
    fn frame(&mut self, f: &Frame<'_>) {
        // the frame's buffers must be consistent
        assert_eq!(f.violation.len(), f.velocity_violation.len());
    }
}

static ACCEPTED: AtomicUsize = AtomicUsize::new(0);
static PARSED: AtomicUsize = AtomicUsize::new(0);
static RAN: AtomicUsize = AtomicUsize::new(0);

/// Everything that must hold for one input text.
fn check_text(
    text: &[u8],
    typed: &[Mutation],
    key: Option<(u64, u64)>,
    run: bool,
) -> Result<(), TestCaseError> {
    let Ok(text) = std::str::from_utf8(text) else {
        // not UTF-8: the byte reader must refuse it without panicking
        prop_assert!(serde_json::from_slice::<Scene>(text).is_err());
        return Ok(());
    };
    let parsed = serde_json::from_str::<Scene>(text);
    let loaded = compiled::scene_from_json(text);
    prop_assert_eq!(parsed.is_ok(), loaded.is_ok());
    if let Err(CompiledError::Data(m)) = &loaded {
        prop_assert!(!m.is_empty());
    }
    let Ok(mut scene) = parsed else {
        return Ok(());
    };
    PARSED.fetch_add(1, Ordering::Relaxed);
    for m in typed {
        mutate_scene(&mut scene, m);
    }
    check_scene(&scene, key, run)
}

fn check_scene(scene: &Scene, key: Option<(u64, u64)>, run: bool) -> Result<(), TestCaseError> {
    // serializing a scene never fails (non-finite floats become null)
    let _ = serde_json::to_string(scene);
    let sys = match bounded("Interp::new", || Interp::new(scene))? {
        Err(e) => {
            prop_assert!(
                names_an_item(scene, &e),
                "the error does not name an item of the scene: {e}"
            );
            // the compiled path refuses it with the same error
            match Plan::new(scene, Mode::Tables) {
                Err(e2) => prop_assert_eq!(e2, e),
                Ok(_) => prop_assert!(false, "Plan::new accepted what Interp::new refused"),
            }
            return Ok(());
        }
        Ok(sys) => sys,
    };
    ACCEPTED.fetch_add(1, Ordering::Relaxed);
    let layout = System::layout(&sys);
    // the scene's bodies, then every beam's nodes
    let nodes: usize = scene.beams.iter().map(|b| b.nodes.len()).sum();
    prop_assert_eq!(layout.bodies(), scene.bodies.len() + nodes);
    prop_assert_eq!(layout.row_joint.len(), layout.rows);
    for (i, m) in layout.mass.iter().enumerate() {
        let ok = m.m.is_finite()
            && m.m > 0.0
            && (1.0 / m.m).is_finite()
            && m.j.iter().chain(m.j_inv.iter()).all(|x| x.is_finite());
        prop_assert!(ok, "body {} has mass properties {:?}", i, m);
    }
    let st = State::initial(&sys);
    for p in &st.pose {
        prop_assert!(p.r.iter().chain(p.q.coords.iter()).all(|x| x.is_finite()));
        prop_assert!(
            (p.q.norm() - 1.0).abs() < 1e-12,
            "orientation {:?} not unit",
            p.q
        );
    }
    // what runs on an accepted scene
    let _ = mbdc_runtime::effects::Effects::of(scene);
    let _ = topology::Topology::new(scene);
    let est = step_limits::estimate(scene);
    let _ = (est.stable_step(), est.accurate_step());
    for mode in [Mode::Unrolled, Mode::Tables] {
        let plan = Plan::new(scene, mode);
        prop_assert!(plan.is_ok(), "Plan::new refused what Interp::new accepted");
        if let (Ok(plan), Some((ku, kt))) = (plan, key) {
            let expected = if mode == Mode::Unrolled { ku } else { kt };
            match Plan::checked(scene, mode, expected) {
                Ok(p) => prop_assert_eq!(p.key(), expected),
                Err(CompiledError::Structure { found, .. }) => prop_assert_eq!(found, plan.key()),
                Err(e) => prop_assert!(false, "unexpected {e}"),
            }
        }
    }
    let cfg = app::run_config(&sys, scene, &Settings::default());
    if !run {
        return Ok(());
    }
    RAN.fetch_add(1, Ordering::Relaxed);
    let mut sys = sys;
    let mut st = State::initial(&sys);
    let assembled = bounded("assemble", || {
        assemble::assemble(&sys, &mut st.pose, &mut st.twist)
    })?;
    if assembled.is_ok() && st.pose.iter().all(|p| p.r.iter().all(|x| x.is_finite())) {
        sys.set_initial_state(&st.pose, &st.twist);
    }
    // the scene's step if the settings accept it, else 1 ms
    let h = cfg.as_ref().map_or(1e-3, |c| c.step);
    let mut methods: Vec<MethodSpec> = MethodSpec::NAMES
        .iter()
        .filter_map(|n| MethodSpec::default_for(n))
        .collect();
    methods.push(scene.simulate.method.clone());
    for method in methods {
        let cfg = RunConfig {
            duration: 3.0 * h,
            step: h,
            method: method.clone(),
            every: 1,
            on_failure: OnFailure::HalveStep(1),
            watchdog: Watchdog::for_scale(run_loop::length_scale(&sys), true),
            checkpoint: None,
            resume: None,
        };
        let report = bounded(method.name(), || run_loop::run(&sys, &cfg, &mut Quiet))?;
        prop_assert!(report.steps <= 8, "{} steps for a run of 3", report.steps);
        prop_assert!(report.finished || report.failure.is_some());
    }
    Ok(())
}

fn describe(seed: &Seed, muts: &[Mutation]) -> String {
    format!("seed {} with {muts:?}", seed.name)
}

// ---------------------------------------------------------------------------------------
// The targets.

/// Mutated model JSON: 20,000 cases, a few steps of every method on six accepted scenes in
/// sixteen.
#[test]
fn mutated_scenes_never_panic() {
    let seeds = seeds();
    let hang = Hang::watch("mutated_scenes_never_panic");
    let mut runner = TestRunner::new(Config {
        cases: 20_000,
        failure_persistence: None,
        ..Config::default()
    });
    let strategy = (
        0..seeds.len(),
        proptest::collection::vec(mutation(), 1..5),
        0u8..16,
    );
    let t0 = Instant::now();
    runner
        .run(&strategy, |(i, muts, pick)| {
            let seed = &seeds[i];
            hang.begin(|| describe(seed, &muts));
            let mut v = seed.value.clone();
            for m in &muts {
                mutate_value(&mut v, m);
            }
            let mut text = serde_json::to_vec(&v).expect("JSON");
            for m in &muts {
                mutate_text(&mut text, m);
            }
            let r = check_text(&text, &muts, seed.keys, pick < 6);
            hang.end();
            r
        })
        .unwrap();
    let (parsed, accepted, ran) = (
        PARSED.load(Ordering::Relaxed),
        ACCEPTED.load(Ordering::Relaxed),
        RAN.load(Ordering::Relaxed),
    );
    eprintln!(
        "mutated scenes: {parsed} deserialized, {accepted} accepted by Interp::new, {ran} run, in {:.1} s",
        t0.elapsed().as_secs_f64()
    );
    // the mutations must exercise the validation and the runs, not only the parser
    assert!(parsed > 5_000, "only {parsed} mutated inputs deserialized");
    assert!(accepted > 1_000, "only {accepted} mutated scenes accepted");
    assert!(ran > 50, "only {ran} runs");
}

/// Random bytes and random JSON-ish token soup: the deserializer refuses them.
#[test]
fn random_bytes_never_panic() {
    let hang = Hang::watch("random_bytes_never_panic");
    let mut runner = TestRunner::new(Config {
        cases: 3_000,
        failure_persistence: None,
        ..Config::default()
    });
    let tokens = prop_oneof![
        Just("{".to_string()),
        Just("}".to_string()),
        Just("[".to_string()),
        Just("]".to_string()),
        Just(",".to_string()),
        Just(":".to_string()),
        Just("\"bodies\"".to_string()),
        Just("\"Body\"".to_string()),
        Just("null".to_string()),
        Just("1e400".to_string()),
        Just("-0".to_string()),
        Just("NaN".to_string()),
        "[a-z]{1,6}".prop_map(|s| format!("\"{s}\"")),
        any::<f64>().prop_map(|x| x.to_string()),
    ];
    let strategy = prop_oneof![
        proptest::collection::vec(any::<u8>(), 0..200),
        proptest::collection::vec(tokens, 0..60).prop_map(|t| t.concat().into_bytes()),
    ];
    runner
        .run(&strategy, |bytes| {
            hang.begin(|| format!("{bytes:?}"));
            let r = check_text(&bytes, &[], None, false);
            hang.end();
            r
        })
        .unwrap();
}

// ---------------------------------------------------------------------------------------
// Deterministic cases: sizes, deep nesting, the bounds of the run settings.

fn body(name: &str, x: f64) -> Body {
    Body {
        name: name.into(),
        mass: 1.0,
        inertia: [[0.1, 0.0, 0.0], [0.0, 0.1, 0.0], [0.0, 0.0, 0.1]],
        position: [x, 0.0, 0.0],
        orientation: [1.0, 0.0, 0.0, 0.0],
        velocity: [0.0; 3],
        angular_velocity: [0.0; 3],
        origin: Default::default(),
    }
}

fn chain(n: usize) -> Scene {
    let mut s: Scene = serde_json::from_value(seeds()[0].value.clone()).expect("seed");
    s.name = "chain".into();
    s.beams.clear();
    s.meshes.clear();
    s.forces.clear();
    s.contacts.clear();
    s.reference = None;
    s.gravity = Some([0.0, 0.0, -9.81]);
    s.bodies = (0..n)
        .map(|i| body(&format!("b{i}"), i as f64 + 0.5))
        .collect();
    s.joints = (0..n)
        .map(|i| Joint {
            name: format!("j{i}"),
            kind: JointKind::Spherical,
            a: Attachment {
                body: if i == 0 {
                    BodyRef::Ground
                } else {
                    BodyRef::Body(i - 1)
                },
                point: [if i == 0 { 0.0 } else { 0.5 }, 0.0, 0.0],
                frame: [1.0, 0.0, 0.0, 0.0],
            },
            b: Attachment {
                body: BodyRef::Body(i),
                point: [-0.5, 0.0, 0.0],
                frame: [1.0, 0.0, 0.0, 0.0],
            },
            origin: Default::default(),
        })
        .collect();
    s.simulate.step = 1e-3;
    s.simulate.duration = 1.0;
    s
}

/// A large scene as JSON: parsed and interpreted in memory proportional to its size; the
/// dense methods refuse it up front instead of allocating `(6n)²` matrices; the sparse
/// ones run it.
#[test]
fn a_large_scene_is_refused_by_dense_methods_and_run_by_sparse_ones() {
    // its scene and JSON are built outside the bounded runs: nobody else's case meanwhile
    let _alone = alone();
    let n = 20_000;
    let json = serde_json::to_string(&chain(n)).expect("JSON");
    let scene: Scene = bounded("parse", || serde_json::from_str(&json))
        .unwrap()
        .expect("parse");
    let sys = bounded("Interp::new", || Interp::new(&scene))
        .unwrap()
        .expect("a chain of 20,000 bodies is a valid scene");
    let st = State::initial(&sys);
    for name in ["coordinate_partitioning", "implicit_trapezoid"] {
        let m = MethodSpec::default_for(name).unwrap();
        let r = bounded(name, || integrators::make(&m, &sys, 1e-3, &st).map(|_| ())).unwrap();
        let e = r.expect_err("a dense method must refuse 20,000 bodies");
        assert!(e.to_string().contains("dense"), "{e}");
    }
    for name in ["staggered", "natural_partitioning"] {
        let cfg = RunConfig {
            duration: 2e-3,
            step: 1e-3,
            method: MethodSpec::default_for(name).unwrap(),
            every: 1,
            on_failure: OnFailure::Stop,
            watchdog: Watchdog::for_scale(run_loop::length_scale(&sys), false),
            checkpoint: None,
            resume: None,
        };
        let r = bounded(name, || run_loop::run(&sys, &cfg, &mut Quiet)).unwrap();
        assert!(r.finished, "{name}: {:?}", r.failure);
    }
}

/// More bodies, joints or force elements than the runtime's limits are refused by
/// `Interp::new` before it allocates anything per item.
#[test]
fn absurd_sizes_are_refused_up_front() {
    use mbdc_runtime::input_limits;
    let _alone = alone();
    let mut s = chain(1);
    s.bodies = vec![body("b", 0.0); input_limits::MAX_BODIES + 1];
    let e = bounded("Interp::new", || {
        let base = LIVE.load(Ordering::Relaxed);
        let r = Interp::new(&s);
        (r, PEAK.load(Ordering::Relaxed).saturating_sub(base))
    })
    .unwrap();
    let (r, _) = e;
    let e = r.expect_err("too many bodies").to_string();
    assert!(e.contains("bodies") && e.contains("limit"), "{e}");
    drop(s);
    // a driver nested deeper than the limit
    let mut s = chain(1);
    let mut f = Fn1::Var;
    for _ in 0..input_limits::MAX_FN_DEPTH + 1 {
        f = Fn1::Neg(Box::new(f));
    }
    s.forces.push(mbdc_runtime::scene::Force {
        name: "deep".into(),
        kind: ForceKind::Torque {
            body: BodyRef::Body(0),
            value: [f, Fn1::Const(0.0), Fn1::Const(0.0)],
            frame: mbdc_runtime::scene::ForceFrame::World,
        },
        origin: Default::default(),
    });
    let e = Interp::new(&s).expect_err("too deep").to_string();
    assert!(e.contains("force 'deep'") && e.contains("deep"), "{e}");
}

/// Steps and durations the run driver cannot honour end in a report (or an error from the
/// run settings), never in a hang: zero, negative, NaN and infinite steps, and step
/// counts above the limit.
#[test]
fn bad_steps_and_durations_are_refused() {
    let scene = chain(2);
    let sys = Interp::new(&scene).unwrap();
    let hang = Hang::watch("bad_steps_and_durations_are_refused");
    for (step, duration) in [
        (0.0, 1.0),
        (-1e-3, 1.0),
        (f64::NAN, 1.0),
        (f64::INFINITY, 1.0),
        (1e-3, f64::NAN),
        (1e-3, f64::INFINITY),
        (1e-3, -1.0),
        (5e-324, 1.0),
        (1e-300, 1e300),
    ] {
        hang.begin(|| format!("step {step}, duration {duration}"));
        let mut s = scene.clone();
        s.simulate.step = step;
        s.simulate.duration = duration;
        let e = Interp::new(&s)
            .expect_err("bad simulate settings")
            .to_string();
        assert!(e.contains("simulate"), "{e}");
        let settings = Settings {
            step: Some(step),
            duration: Some(duration),
            ..Settings::default()
        };
        assert!(app::run_config(&sys, &scene, &settings).is_err());
        let cfg = RunConfig {
            duration,
            step,
            method: MethodSpec::default_for("staggered").unwrap(),
            every: 1,
            on_failure: OnFailure::HalveStep(3),
            watchdog: Watchdog::for_scale(1.0, false),
            checkpoint: None,
            resume: None,
        };
        let r = run_loop::run(&sys, &cfg, &mut Quiet);
        assert!(
            !r.finished && r.steps == 0,
            "step {step}, duration {duration}: {r:?}"
        );
        let f = r.failure.expect("a failure report");
        assert!(
            f.cause.contains("step") || f.cause.contains("duration"),
            "{f}"
        );
        hang.end();
    }
}
