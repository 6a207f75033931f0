//! Code generation: a [`Scene`] → Rust specialized to that scene, implementing the runtime's
//! [`System`](mbdc_runtime::system::System) trait (and
//! [`CompiledModel`](mbdc_runtime::compiled::CompiledModel)), so that it runs on the same
//! integrators, solvers and writers as the interpreter.
//!
//! # Design
//!
//! **Structure in code, numbers in data.** The generated code is written from the scene's
//! [`Spec`] only ([`mbdc_runtime::compiled`]): which joint kernels with which bodies and rows,
//! which force terms, the shapes of the time functions, whether there is gravity, locks. Every
//! number — joint frames and offsets, masses, spring constants, the constants of the time
//! functions, the initial state — is data, read at start-up from the scene (the JSON of the
//! scene is embedded in the generated code; `mbdc run` passes the current one, with the user's
//! `--set` overrides, to the compiled program). The crate key of `mbdc run` is the spec's key,
//! so changing a number never rebuilds, and a program refuses a scene of another structure.
//! (Folding the numbers into the code as `const`s would not pay: without fast-math the
//! compiler may not drop a product with a constant 0 or fold `x + 0.0`, so the code would be
//! the same minus one load per number; keeping them as data keeps overrides free.)
//!
//! **Bit-identical to the interpreter.** The generated code evaluates the interpreter's plan
//! ([`mbdc_runtime::interp::Interp::joint_entries`] and `terms`) in the same order with the
//! same public kernels ([`mbdc_runtime::joints`], [`mbdc_runtime::forces`],
//! [`mbdc_runtime::contact`]), and time functions as `Jet2` expressions with the operations of
//! [`mbdc_runtime::fn1::eval`]: the two paths agree to the last bit.
//!
//! **Only the effects a scene calls for.** Code, fields and imports exist only for the
//! kernels and force kinds the plan contains: a pendulum's code has no spring, contact, time
//! function, lock or element code, and a hex8 mesh's no tet4 or quad4 kernel (`mbdc build
//! --emit` shows it).
//!
//! **Meshes: the element kernels in code, their constants in data.** For a scene with
//! meshes, the spec lists each element block's kernel (element kind, with the plane mode of
//! 2-D kinds, and the quadrature variant of hex8 and quad4: full or one point, whose code
//! paths are separate) and whether its material is plastic
//! ([`mbdc_runtime::compiled::MeshBlock`]);
//! the generated module writes the table of the blocks' element loops
//! (`mbdc_runtime::integrators::mesh_kernels::BlockKernels`), each monomorphized for its
//! kernel — `BlockKernel::elastic::<Hex8>()` is `elastic_block::<Hex8>` — naming only the
//! kernels its blocks use, plastic loops only for plastic blocks, and hands it to the
//! integrators through `System::mesh_kernels`. The material constants, thickness, B-bar
//! flag and hourglass coefficient stay data (the mesh layout the interpreter builds),
//! as joints' geometry does. A rigid scene's code has no mesh tokens at all (the method's
//! default is "none", which the interpreter also uses: then each block's loop is chosen by
//! a `match` on its kind before the run). The loops and kernels are the interpreter's, so
//! the two paths agree to the last bit here too.
//!
//! **Beams: the element variants in code, the sections in data.** For a scene with beams,
//! the spec lists the element variants its beams use, each once
//! ([`mbdc_runtime::compiled::BeamVariant`]: undamped, or with stiffness-proportional
//! damping), and the generated module writes their table
//! (`mbdc_runtime::integrators::beam_kernels::BeamKernels`), each entry the element force
//! function monomorphized for its variant — `BeamKernel::damped()` is
//! `element_forces::<true>`, which computes the element's frame once for the elastic and the
//! damping forces; `BeamKernel::elastic()` has no damping code — and hands it to the
//! integrators through `System::beam_kernels`. Each beam runs the entry of its variant. The
//! section constants (EA, GA, GJ, EI, inertia) and the damping coefficient stay data, for
//! the reason above: folding them would save a load per constant and cost a rebuild for
//! every `--set` of a section. A scene without beams has no beam tokens.
//!
//! **Two layouts** ([`Mode`]). Up to [`UNROLL_MAX_ITEMS`] row groups and force terms
//! (and [`UNROLL_MAX_BODIES`] bodies), [`Mode::Unrolled`]: one straight-line kernel call per
//! joint with constant body indices and row offsets, sizes as `const`s and fixed-size arrays
//! of geometry. Above, [`Mode::Tables`]: loops over per-item tables (bodies, rows, geometry,
//! constant offsets) with one `match` arm per distinct kind, so that the source of a
//! 1000-link chain is as long as that of a 100-link chain, and repeated structure (a `for`
//! loop in the model) costs nothing in source size.
//!
//! **Linear algebra is the runtime's.** The generated model supplies the residuals, Jacobian
//! rows, forces and energy; it has no solver of its own. The integrators build their
//! constraint solver (`mbdc_runtime::linalg::KSolver`: `εI + s·BM⁻¹Bᵀ` assembled on the
//! sparsity derived from the [`Layout`](mbdc_runtime::system::Layout), dense or sparse
//! Cholesky chosen by size and density) from the model's `layout()`, exactly as for the
//! interpreter, so the two paths also share every factorization.
//!
//! **Warning-free.** The generated module has no blanket `allow`: helpers, fields, imports
//! and parameter names follow what the bodies use, so that it compiles under
//! `#![deny(warnings)]` and `#![deny(clippy::all)]` in the including crate
//! (`tests/generated_lints.rs`).

mod emit;
mod shape;
mod token_scan;

use mbdc_runtime::compiled::{Mode, Plan};
use mbdc_runtime::interp::InterpError;
use mbdc_runtime::scene::Scene;
use proc_macro2::{Literal, TokenStream};

pub use mbdc_runtime::compiled::Spec;

/// Largest number of row groups plus force terms emitted as straight-line code.
pub const UNROLL_MAX_ITEMS: usize = 64;
/// Largest number of bodies emitted as straight-line code.
pub const UNROLL_MAX_BODIES: usize = 64;

/// Where the generated code finds the scene's JSON (its default numbers).
#[derive(Clone, Debug, PartialEq, Eq, Default)]
pub enum SceneJson {
    /// In a string literal in the code (proc-macros).
    #[default]
    Inline,
    /// `include_str!` of this path (build scripts and `mbdc run` write the JSON next to the
    /// code).
    Include(String),
}

/// Options of [`generate`].
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Options {
    /// Name of the generated module (default: the scene's name as a Rust identifier).
    pub module: Option<String>,
    /// Force a layout (default: by size, see [`choose_mode`]).
    pub mode: Option<Mode>,
    /// Where the scene's JSON lives.
    pub scene_json: SceneJson,
}

/// The generated code and what it was generated for.
#[derive(Clone, Debug, PartialEq)]
pub struct Generated {
    /// The Rust source: one `pub mod <module> { … }` with `Model` (formatted).
    pub source: String,
    /// The module's name.
    pub module: String,
    /// The spec's key: programs generated for equal keys are interchangeable.
    pub key: u64,
    /// The layout used.
    pub mode: Mode,
    /// The scene as JSON (what [`SceneJson::Include`] must point at).
    pub scene_json: String,
    /// The effects the scene uses (as [`mbdc_runtime::effects::Effects::names`]).
    pub effects: Vec<&'static str>,
}

/// Why code could not be generated.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CodegenError {
    /// The scene is not one the rigid-body runtime simulates.
    #[error(transparent)]
    Scene(#[from] InterpError),
    /// The generated tokens are not valid Rust (a bug in the generator).
    #[error("internal error: the generated code does not parse: {0}")]
    Internal(String),
}

/// The layout for a plan: [`Mode::Unrolled`] up to [`UNROLL_MAX_ITEMS`] items and
/// [`UNROLL_MAX_BODIES`] bodies, [`Mode::Tables`] above.
pub fn choose_mode(scene: &Scene) -> Mode {
    let items = scene.joints.len() + scene.forces.len() + scene.contacts.len();
    if items <= UNROLL_MAX_ITEMS && scene.bodies.len() <= UNROLL_MAX_BODIES {
        Mode::Unrolled
    } else {
        Mode::Tables
    }
}

/// The plan (spec and data) of a scene as [`generate`] would use it: its
/// [`Plan::key`] is what `mbdc run` caches compiled programs by.
pub fn plan(scene: &Scene, mode: Option<Mode>) -> Result<Plan, InterpError> {
    Plan::new(scene, mode.unwrap_or_else(|| choose_mode(scene)))
}

/// Generate the Rust of `scene` (see the module doc).
pub fn generate(scene: &Scene, options: &Options) -> Result<Generated, CodegenError> {
    let plan = plan(scene, options.mode)?;
    let module = options
        .module
        .clone()
        .unwrap_or_else(|| module_name(&scene.name));
    let scene_json =
        serde_json::to_string(scene).map_err(|e| CodegenError::Internal(e.to_string()))?;
    let effects = mbdc_runtime::effects::Effects::of(scene).names();
    let tokens = emit::file(
        &plan,
        scene,
        &module,
        &options.scene_json,
        &scene_json,
        &effects,
    );
    let file: syn::File = syn::parse2(tokens).map_err(|e| CodegenError::Internal(e.to_string()))?;
    Ok(Generated {
        source: prettyplease::unparse(&file),
        module,
        key: plan.key(),
        mode: plan.spec.mode,
        scene_json,
        effects,
    })
}

/// A scene name as a Rust module name: lowercase ASCII letters, digits and `_`, not starting
/// with a digit, not a keyword.
pub fn module_name(name: &str) -> String {
    let mut s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_lowercase()
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() || s.starts_with(|c: char| c.is_ascii_digit()) {
        s.insert_str(0, "scene_");
    }
    if syn::parse_str::<syn::Ident>(&s).is_err() {
        s.push('_');
    }
    s
}

pub(crate) fn lit_usize(i: usize) -> Literal {
    Literal::usize_unsuffixed(i)
}

/// Tokens of a `u64` in hexadecimal.
pub(crate) fn lit_hex(k: u64) -> TokenStream {
    format!("0x{k:016x}").parse().unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn module_names() {
        assert_eq!(module_name("double_pendulum_3d"), "double_pendulum_3d");
        assert_eq!(module_name("Four-Bar"), "four_bar");
        assert_eq!(module_name("3d"), "scene_3d");
        assert_eq!(module_name("type"), "type_");
        assert_eq!(module_name(""), "scene_");
    }
}
