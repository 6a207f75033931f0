//! The `build.rs` API: generate the Rust of a `.mbd` scene into `OUT_DIR`.
//!
//! ```no_run
//! // build.rs: `fn main() { ... }` runs this
//! mbdc_compiler::build("models/pendulum.mbd");
//! ```
//!
//! ```ignore
//! // src/main.rs
//! include!(concat!(env!("OUT_DIR"), "/pendulum.rs"));
//!
//! fn main() {
//!     let model = pendulum::Model::new(); // a `System`
//!     // run it: mbdc_runtime::run_loop::run(&model, &config, &mut observer)
//! }
//! ```
//!
//! [`build`] writes `<OUT_DIR>/<module>.rs` (one `pub mod <module>`, see [`crate::codegen`])
//! and `<OUT_DIR>/<module>.scene.json` (the scene's numbers, which the code
//! `include_str!`s), prints `cargo:rerun-if-changed` for every file it read (the model and
//! its imports), prints warnings as `cargo:warning`, and on errors panics with the rendered
//! diagnostics, which is how a build script fails. [`Builder`] sets options (parameter
//! overrides, module name, output folder, layout) and [`Builder::generate`] returns errors
//! instead of panicking.
//!
//! The crate using it needs `mbdc-runtime` as a dependency (the generated code uses
//! nothing else) and `mbdc-compiler` as a build dependency.

use std::path::{Path, PathBuf};

use mbdc_runtime::compiled::Mode;

use crate::codegen::{self, CodegenError, Options, SceneJson};
use crate::{Override, Severity};

/// What [`Builder::generate`] wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct Built {
    /// The Rust file (`include!` it).
    pub rs: PathBuf,
    /// The scene's JSON, next to it.
    pub json: PathBuf,
    /// The module name inside the Rust file.
    pub module: String,
    /// The structure key ([`codegen::Generated::key`]).
    pub key: u64,
    /// Every file read (the model and its imports).
    pub files: Vec<PathBuf>,
}

/// Why [`Builder::generate`] failed.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    /// The scene has errors; `rendered` shows them with their source lines.
    #[error("{rendered}")]
    Diagnostics {
        /// The rendered diagnostics.
        rendered: String,
        /// Every file read (so that cargo reruns when one changes).
        files: Vec<PathBuf>,
    },
    /// Code could not be generated for the scene.
    #[error("{path}: {error}")]
    Codegen {
        /// The model file.
        path: String,
        /// The reason.
        error: CodegenError,
    },
    /// No output folder: neither [`Builder::out_dir`] nor `OUT_DIR` is set.
    #[error("OUT_DIR is not set: call mbdc_compiler::build from a build script, or give Builder::out_dir")]
    NoOutDir,
    /// Writing the output failed.
    #[error("writing {path}: {error}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The error.
        error: std::io::Error,
    },
}

/// Options for generating a scene's Rust into a folder (see the module doc).
#[derive(Clone, Debug)]
pub struct Builder {
    path: PathBuf,
    overrides: Vec<Override>,
    module: Option<String>,
    out_dir: Option<PathBuf>,
    mode: Option<Mode>,
    cargo: bool,
    warnings: bool,
}

impl Builder {
    /// A builder for the model at `path` (relative paths are relative to
    /// `CARGO_MANIFEST_DIR` when it is set, i.e. in a build script).
    pub fn new(path: impl AsRef<Path>) -> Builder {
        Builder {
            path: path.as_ref().to_path_buf(),
            overrides: Vec::new(),
            module: None,
            out_dir: None,
            mode: None,
            cargo: true,
            warnings: true,
        }
    }

    /// Whether the model's warnings are printed as `cargo:warning` lines (on by default;
    /// errors are always reported).
    pub fn warnings(mut self, on: bool) -> Builder {
        self.warnings = on;
        self
    }

    /// Override a parameter, as `mbdc run --set NAME=VALUE` (value as `.mbd` text, e.g.
    /// `"2 m"`).
    pub fn set(mut self, name: &str, value: &str) -> Builder {
        self.overrides.push(Override::new(name, value));
        self
    }

    /// Name of the generated module (default: the scene's name).
    pub fn module(mut self, name: &str) -> Builder {
        self.module = Some(name.to_string());
        self
    }

    /// Output folder (default: `OUT_DIR`).
    pub fn out_dir(mut self, dir: impl AsRef<Path>) -> Builder {
        self.out_dir = Some(dir.as_ref().to_path_buf());
        self
    }

    /// Force the code layout (default: by size).
    pub fn mode(mut self, mode: Mode) -> Builder {
        self.mode = Some(mode);
        self
    }

    /// Whether to print `cargo:` directives (default: yes).
    pub fn cargo_directives(mut self, on: bool) -> Builder {
        self.cargo = on;
        self
    }

    fn resolved(&self) -> PathBuf {
        if self.path.is_relative() {
            if let Some(dir) = std::env::var_os("CARGO_MANIFEST_DIR") {
                return PathBuf::from(dir).join(&self.path);
            }
        }
        self.path.clone()
    }

    /// Generate, returning errors.
    pub fn generate(&self) -> Result<Built, BuildError> {
        let path = self.resolved();
        let loaded = crate::load_file(&path, &self.overrides);
        let files: Vec<PathBuf> = loaded
            .sources
            .files()
            .filter_map(|(_, f)| f.path.clone())
            .collect();
        let files = if files.is_empty() {
            vec![path.clone()]
        } else {
            files
        };
        if self.cargo {
            for f in &files {
                println!("cargo:rerun-if-changed={}", f.display());
            }
            for d in loaded
                .diagnostics
                .iter()
                .filter(|d| self.warnings && d.severity == Severity::Warning)
            {
                for line in d.render_plain(&loaded.sources).lines() {
                    println!("cargo:warning={line}");
                }
            }
        }
        let Some(scene) = loaded.scene.as_ref().filter(|_| !loaded.has_errors()) else {
            return Err(BuildError::Diagnostics {
                rendered: loaded.render_plain(),
                files,
            });
        };
        let out = match &self.out_dir {
            Some(d) => d.clone(),
            None => PathBuf::from(std::env::var_os("OUT_DIR").ok_or(BuildError::NoOutDir)?),
        };
        let module = self
            .module
            .clone()
            .unwrap_or_else(|| codegen::module_name(&scene.name));
        let json = out.join(format!("{module}.scene.json"));
        let rs = out.join(format!("{module}.rs"));
        let opts = Options {
            module: Some(module.clone()),
            mode: self.mode,
            scene_json: SceneJson::Include(json.to_string_lossy().replace('\\', "/")),
        };
        let g = codegen::generate(scene, &opts).map_err(|error| BuildError::Codegen {
            path: path.display().to_string(),
            error,
        })?;
        std::fs::create_dir_all(&out).map_err(|error| BuildError::Io {
            path: out.clone(),
            error,
        })?;
        write_if_changed(&json, &g.scene_json)?;
        write_if_changed(&rs, &g.source)?;
        Ok(Built {
            rs,
            json,
            module,
            key: g.key,
            files,
        })
    }

    /// Generate; on errors print the rendered diagnostics and panic (a build script
    /// failure).
    pub fn build(&self) -> Built {
        match self.generate() {
            Ok(b) => b,
            Err(e) => {
                eprintln!("{e}");
                panic!(
                    "mbdc: cannot generate code for {}:\n{e}",
                    self.path.display()
                );
            }
        }
    }
}

/// Write a file unless it already has this content (so that cargo does not rebuild).
pub fn write_if_changed(path: &Path, text: &str) -> Result<(), BuildError> {
    if std::fs::read_to_string(path).is_ok_and(|old| old == text) {
        return Ok(());
    }
    std::fs::write(path, text).map_err(|error| BuildError::Io {
        path: path.to_path_buf(),
        error,
    })
}

/// Generate the Rust of the model at `path` into `OUT_DIR` from a build script (see the
/// module doc). Panics with the rendered diagnostics when the model has errors.
pub fn build(path: impl AsRef<Path>) -> Built {
    Builder::new(path).build()
}
