//! The compiled path: generate a scene's Rust, build it with cargo in one shared workspace,
//! run the program.
//!
//! ## The shared workspace
//!
//! Every compiled scene is a crate `scenes/<scene>-<key>/` of one cargo workspace,
//! `<target>/mbdc/ws/` (`<target>`: the mbdc source workspace's `target/` folder, or
//! `CARGO_TARGET_DIR`; `MBDC_BUILD_DIR` names the workspace folder directly). The workspace has
//! a copy of the mbdc workspace's `Cargo.lock`, a path dependency on the runtime and its own
//! target folder, so the runtime is compiled once (release) for all scenes and each scene
//! compiles only its own small crate.
//!
//! `<key>` is the [structure key](mbdc_runtime::compiled::Spec::key) of the scene with the
//! mbdc version: a scene whose numbers change (a `--set` override, an edited length) reuses
//! the program, which reads the numbers from the scene JSON passed with `--scene`. Cargo is
//! run every time (a no-op when nothing changed) so that a changed runtime is rebuilt.
//!
//! The runtime is found through the source path this program was compiled from
//! (`CARGO_MANIFEST_DIR` at compile time). An installed `mbdc` whose sources are gone
//! depends on the published `mbdc-runtime` of the same version instead (which cargo then
//! downloads once).
//!
//! Cargo's output is captured: a spinner says what is being built, and errors are reported
//! as mbdc errors with the compiler's messages (they mean a bug in the generator, or a broken
//! toolchain).

use std::io::{BufRead, BufReader, IsTerminal, Read};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use indicatif::{ProgressBar, ProgressStyle};
use mbdc_compiler::codegen::{self, Options, SceneJson};
use mbdc_runtime::compiled::Fnv;
use mbdc_runtime::scene::Scene;

/// The mbdc source workspace this program was compiled from.
const SOURCE_ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/..");
const VERSION: &str = env!("CARGO_PKG_VERSION");

/// The source workspace, if it still exists.
fn source_root() -> Option<PathBuf> {
    let root = Path::new(SOURCE_ROOT);
    root.join("runtime/Cargo.toml")
        .is_file()
        .then(|| root.canonicalize().unwrap_or_else(|_| root.to_path_buf()))
}

/// The shared workspace folder (see the module doc).
pub fn workspace_dir() -> PathBuf {
    if let Some(d) = std::env::var_os("MBDC_BUILD_DIR") {
        return PathBuf::from(d);
    }
    if let Some(t) = std::env::var_os("CARGO_TARGET_DIR") {
        return PathBuf::from(t).join("mbdc/ws");
    }
    if let Some(root) = source_root() {
        return root.join("target/mbdc/ws");
    }
    let cache = std::env::var_os("XDG_CACHE_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache")))
        .unwrap_or_else(std::env::temp_dir);
    cache.join("mbdc/ws")
}

/// The runtime dependency line of the workspace.
fn runtime_dependency() -> String {
    match source_root() {
        Some(root) => format!(
            "mbdc-runtime = {{ path = {:?} }}",
            root.join("runtime").to_string_lossy()
        ),
        None => format!("mbdc-runtime = \"={VERSION}\""),
    }
}

/// A scene's crate in the shared workspace.
#[derive(Clone, Debug)]
pub struct SceneCrate {
    /// The workspace.
    pub ws: PathBuf,
    /// The crate folder.
    pub dir: PathBuf,
    /// Package and binary name.
    pub package: String,
}

pub(crate) fn write(path: &Path, text: &str) -> Result<(), String> {
    if let Some(p) = path.parent() {
        std::fs::create_dir_all(p).map_err(|e| format!("creating {}: {e}", p.display()))?;
    }
    if std::fs::read_to_string(path).is_ok_and(|old| old == text) {
        return Ok(());
    }
    std::fs::write(path, text).map_err(|e| format!("writing {}: {e}", path.display()))
}

/// Write the workspace files (if needed) and the scene's crate (if it does not exist).
pub fn prepare(scene: &Scene) -> Result<SceneCrate, String> {
    let ws = workspace_dir();
    let dep = runtime_dependency();
    let plan = codegen::plan(scene, None).map_err(|e| e.to_string())?;
    let module = codegen::module_name(&scene.name);
    let mut h = Fnv::new();
    for part in [
        format!("{:016x}", plan.key()).as_str(),
        VERSION,
        dep.as_str(),
    ] {
        h.write(part.as_bytes());
        h.write(&[0]);
    }
    let key = format!("{:016x}", h.finish());
    let package = format!("mbdc-scene-{}-{}", module.replace('_', "-"), &key[..12]);
    let dir = ws.join("scenes").join(format!("{module}-{key}"));

    write(
        &ws.join("Cargo.toml"),
        &format!(
            "# Written by mbdc: the shared workspace of compiled scenes (one crate per scene\n\
             # structure under scenes/). Safe to delete; mbdc rewrites it.\n\
             [workspace]\nresolver = \"2\"\nmembers = [\"scenes/*\"]\n\n\
             [workspace.dependencies]\n{dep}\n\n\
             [profile.release]\ndebug = false\n"
        ),
    )?;
    // The lock file of the mbdc workspace, so that the runtime's dependencies are the tested
    // versions; copied again when it changes.
    if let Some(root) = source_root() {
        if let Ok(lock) = std::fs::read_to_string(root.join("Cargo.lock")) {
            let mut lh = Fnv::new();
            lh.write(lock.as_bytes());
            let stamp = format!("{:016x}", lh.finish());
            let stamp_path = ws.join(".lock-source");
            if std::fs::read_to_string(&stamp_path).ok().as_deref() != Some(stamp.as_str()) {
                write(&ws.join("Cargo.lock"), &lock)?;
                write(&stamp_path, &stamp)?;
            }
        }
    }
    if dir.join(".complete").is_file() {
        return Ok(SceneCrate { ws, dir, package });
    }
    let json_path = dir.join("scene.json");
    let opts = Options {
        module: Some(module.clone()),
        mode: None,
        scene_json: SceneJson::Include(json_path.to_string_lossy().replace('\\', "/")),
    };
    let g = codegen::generate(scene, &opts).map_err(|e| e.to_string())?;
    write(&json_path, &g.scene_json)?;
    write(
        &dir.join("Cargo.toml"),
        &format!(
            "# Written by mbdc for the scene `{}` (structure key {:016x}).\n\
             [package]\nname = \"{package}\"\nversion = \"0.0.0\"\nedition = \"2021\"\npublish = false\n\n\
             [dependencies]\nmbdc-runtime.workspace = true\n",
            scene.name,
            g.key
        ),
    )?;
    write(
        &dir.join("src/main.rs"),
        &format!(
            "{}\nfn main() -> std::process::ExitCode {{\n    mbdc_runtime::app::main::<{module}::Model>()\n}}\n",
            g.source
        ),
    )?;
    write(&dir.join(".complete"), "")?;
    Ok(SceneCrate { ws, dir, package })
}

/// Why a build failed.
#[derive(Debug)]
pub struct BuildFailure {
    /// One-line reason.
    pub reason: String,
    /// The compiler's messages (rendered) or cargo's output.
    pub details: String,
}

/// Build a scene's crate in release mode; returns the program.
pub fn build(c: &SceneCrate, quiet: bool) -> Result<PathBuf, BuildFailure> {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.arg("build")
        .arg("--release")
        .arg("--message-format=json-render-diagnostics")
        .arg("--manifest-path")
        .arg(c.ws.join("Cargo.toml"))
        .arg("-p")
        .arg(&c.package)
        .env_remove("CARGO_TARGET_DIR")
        .env("CARGO_TERM_COLOR", "never")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    let mut child = cmd.spawn().map_err(|e| BuildFailure {
        reason: format!("cannot run cargo: {e}"),
        details:
            "mbdc run builds scenes with cargo; install Rust (https://rustup.rs) or use --interp"
                .into(),
    })?;
    let spinner = (!quiet).then(|| {
        let s = ProgressBar::new_spinner();
        s.set_style(
            ProgressStyle::with_template("{spinner} {msg} [{elapsed}]")
                .unwrap_or_else(|_| ProgressStyle::default_spinner()),
        );
        s.enable_steady_tick(Duration::from_millis(120));
        s
    });
    // Without a terminal the spinner draws nothing: a line per phase instead (a CI log, a
    // pipe), so that a first build's minutes are not silent.
    let mut phases = (!quiet && !std::io::stderr().is_terminal()).then(PhaseLines::default);
    let mut stderr = child.stderr.take().expect("piped");
    let err_thread = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = stderr.read_to_string(&mut s);
        s
    });
    let stdout = child.stdout.take().expect("piped");
    let mut program = None;
    let mut errors = Vec::new();
    for line in BufReader::new(stdout).lines().map_while(Result::ok) {
        let Ok(v) = serde_json::from_str::<serde_json::Value>(&line) else {
            continue;
        };
        match v["reason"].as_str() {
            Some("compiler-artifact") => {
                let name = v["target"]["name"].as_str().unwrap_or("");
                if let Some(p) = &mut phases {
                    p.artifact(
                        name == c.package || name == c.package.replace('-', "_"),
                        v["fresh"].as_bool() == Some(false),
                    );
                }
                if let Some(s) = &spinner {
                    if name == c.package || name == c.package.replace('-', "_") {
                        s.set_message("building scene (first run)");
                    } else if v["fresh"].as_bool() == Some(false) {
                        s.set_message(format!(
                            "building the runtime for compiled scenes (once): {name}"
                        ));
                    }
                }
                if let Some(exe) = v["executable"].as_str() {
                    program = Some(PathBuf::from(exe));
                }
            }
            Some("compiler-message") => {
                if v["message"]["level"].as_str() == Some("error") {
                    if let Some(r) = v["message"]["rendered"].as_str() {
                        errors.push(r.to_string());
                    }
                }
            }
            _ => {
                if let Some(s) = &spinner {
                    if s.message().is_empty() {
                        s.set_message("building scene (first run)");
                    }
                }
            }
        }
    }
    let status = child.wait();
    let cargo_err = err_thread.join().unwrap_or_default();
    if let Some(s) = spinner {
        s.finish_and_clear();
    }
    if let Some(p) = phases {
        p.done();
    }
    match status {
        Ok(st) if st.success() => program.ok_or_else(|| BuildFailure {
            reason: "cargo did not report the program it built".into(),
            details: cargo_err,
        }),
        Ok(_) => Err(BuildFailure {
            reason: if errors.is_empty() {
                format!(
                    "cargo could not build the scene's program (workspace {})",
                    c.ws.display()
                )
            } else {
                format!(
                    "the generated code for this scene did not compile ({} error{}); this is a bug in mbdc's code generator — run with --interp meanwhile",
                    errors.len(),
                    if errors.len() == 1 { "" } else { "s" }
                )
            },
            details: if errors.is_empty() {
                cargo_err
            } else {
                errors.join("\n")
            },
        }),
        Err(e) => Err(BuildFailure {
            reason: format!("waiting for cargo: {e}"),
            details: cargo_err,
        }),
    }
}

/// The build's phases as plain lines, for a stderr that is not a terminal: a line when the
/// runtime's crates start building (a first run), and what was built in how long when the
/// build ends — nothing for a warm run, which builds nothing. (cargo reports a crate when it
/// is done, so the scene's own crate, built last, shows only in the closing line.)
#[derive(Default)]
struct PhaseLines {
    /// When the first crate finished building.
    start: Option<std::time::Instant>,
    /// Runtime (dependency) crates built.
    runtime: usize,
    /// Whether the scene's crate was built.
    scene: bool,
}

impl PhaseLines {
    /// A `compiler-artifact` message: the scene's own crate or a dependency, built or fresh.
    fn artifact(&mut self, is_scene: bool, built: bool) {
        if !built {
            return;
        }
        if is_scene {
            self.scene = true;
        } else {
            if self.runtime == 0 {
                eprintln!("building the runtime for compiled scenes (once; a few minutes)…");
            }
            self.runtime += 1;
        }
        self.start.get_or_insert_with(std::time::Instant::now);
    }

    /// The build ended.
    fn done(self) {
        if let Some(t0) = self.start {
            let what = match (self.runtime, self.scene) {
                (0, _) => "the scene's program".to_string(),
                (n, true) => format!("{n} runtime crate(s) and the scene's program"),
                (n, false) => format!("{n} runtime crate(s)"),
            };
            eprintln!("built {what} in {:.1} s", t0.elapsed().as_secs_f64());
        }
    }
}

/// Report a build failure as an mbdc error.
pub fn report_build_failure(f: &BuildFailure, c: &SceneCrate) {
    eprintln!("error: {}", f.reason);
    let details: String = f
        .details
        .lines()
        .filter(|l| !l.trim().is_empty())
        .take(60)
        .map(|l| format!("  | {l}\n"))
        .collect();
    if !details.is_empty() {
        eprint!("{details}");
    }
    eprintln!("  note: the generated crate is {}", c.dir.display());
}

pub(crate) fn unescape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    let mut it = s.chars();
    while let Some(c) = it.next() {
        if c == '\\' {
            match it.next() {
                Some('n') => out.push('\n'),
                Some(x) => out.push(x),
                None => out.push('\\'),
            }
        } else {
            out.push(c);
        }
    }
    out
}
