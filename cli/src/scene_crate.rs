//! The compiled path: generate a scene's Rust, build it with cargo in one shared workspace,
//! run the program.
//!
//! ## The shared workspace
//!
//! Every compiled scene is a crate `scenes/<scene>-<key>/` of one cargo workspace,
//! `<target>/mbdc/ws/` (`<target>`: the mbdc source workspace's `target/` folder, or
//! `CARGO_TARGET_DIR`; `MBDC_BUILD_DIR` names the workspace folder directly). The workspace has
//! a copy of the mbdc workspace's `Cargo.lock` and its release profile, and a path dependency
//! on the runtime, so the runtime is compiled once (release) for all scenes and each scene
//! compiles only its own small crate.
//!
//! ## What is shared with mbdc's own build
//!
//! When this program is itself a release build in a cargo target folder of its sources (as
//! `cargo mbdc run` makes it: `<T>/release/mbdc`), the scenes are built into that same folder
//! `<T>`, with the mbdc workspace's lock file and release profile, and each scene crate
//! declares [`FEATURE_MIRROR`]: the features mbdc's own build turns on in crates the runtime
//! uses too. The scene's dependency graph then gives every crates.io crate the versions,
//! features and profile of mbdc's build, so cargo finds them built and compiles only the
//! runtime and the scene's crate. (The runtime itself is compiled again: cargo names a path
//! crate's build by its path relative to the workspace root, which differs between the two
//! workspaces.) A first compiled run on a fresh clone no longer builds some 150 crates a
//! second time (BENCHMARKS.md, "First run"). Otherwise (a debug build, an installed program,
//! `MBDC_BUILD_DIR`) the workspace keeps its own target folder `ws/target`.
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

/// The cargo target folder this program was built in, when its build can be shared with the
/// scenes (see the module doc): the program is `<T>/release/mbdc` of a target folder `<T>`
/// (cargo marks those with `CACHEDIR.TAG`) holding the build of the sources it came from, and
/// `MBDC_BUILD_DIR` does not ask for a workspace of its own.
fn shared_target() -> Option<PathBuf> {
    if std::env::var_os("MBDC_BUILD_DIR").is_some() || cfg!(debug_assertions) {
        return None;
    }
    source_root()?;
    let exe = std::env::current_exe().ok()?.canonicalize().ok()?;
    let release = exe.parent()?;
    if release.file_name()? != "release" {
        return None;
    }
    let target = release.parent()?;
    target
        .join("CACHEDIR.TAG")
        .is_file()
        .then(|| target.to_path_buf())
}

/// The shared workspace folder (see the module doc).
pub fn workspace_dir() -> PathBuf {
    if let Some(d) = std::env::var_os("MBDC_BUILD_DIR") {
        return PathBuf::from(d);
    }
    if let Some(t) = shared_target() {
        return t.join("mbdc/ws");
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

/// What a scene crate that shares mbdc's build declares besides the runtime, only for the
/// features: those mbdc's own build (its command line, compiler and plots) turns on in crates
/// the runtime uses too. Without them those crates — and all that depend on them — would be
/// other units, built a second time. `syn` is a build dependency because the runtime uses
/// it through its derive macros, which run on the host. The test
/// `the_feature_mirror_matches_mbdcs_build` compares the two graphs with `cargo tree` and
/// names what to add here when a dependency of mbdc changes.
pub const FEATURE_MIRROR: &str = "\
# Only for their features: what mbdc's own build turns on in crates the runtime shares with
# it, so that cargo reuses the crates mbdc's build compiled.
bitflags = { version = \"2\", features = [\"std\"] }
num-traits = \"0.2\"
once_cell = \"1\"
signal-hook = { version = \"0.4\", default-features = false, features = [\"iterator\"] }

[build-dependencies]
syn = { version = \"3\", features = [\"full\", \"extra-traits\", \"fold\", \"visit\"] }
";

/// The `[profile.release…]` tables of the mbdc workspace's `Cargo.toml`, copied verbatim so
/// that a scene's units are the units mbdc's build made (a different profile is a different
/// build); the runtime's own choice when the sources are gone.
fn release_profile() -> String {
    let manifest = source_root()
        .and_then(|root| std::fs::read_to_string(root.join("Cargo.toml")).ok())
        .unwrap_or_default();
    release_profile_of(&manifest)
}

/// The `[profile.release]` and `[profile.release.*]` tables of a manifest, verbatim.
fn release_profile_of(manifest: &str) -> String {
    // The manifest as tables: a header line and the lines up to the next header.
    let mut tables: Vec<Vec<&str>> = vec![Vec::new()];
    for line in manifest.lines() {
        if line.trim_start().starts_with('[') {
            tables.push(Vec::new());
        }
        tables.last_mut().expect("one table at least").push(line);
    }
    let kept: Vec<String> = tables
        .iter()
        .filter(|t| {
            let head = t.first().map_or("", |l| l.trim());
            head.starts_with("[profile.release]") || head.starts_with("[profile.release.")
        })
        .map(|t| {
            // Comments and blank lines at a table's end introduce the next table.
            let end = t
                .iter()
                .rposition(|l| !l.trim().is_empty() && !l.trim_start().starts_with('#'))
                .map_or(0, |i| i + 1);
            t[..end].join("\n") + "\n"
        })
        .collect();
    if kept.is_empty() {
        "[profile.release]\ndebug = false\n".to_string()
    } else {
        kept.join("\n")
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
    /// The target folder shared with mbdc's own build, if any (else the workspace's own).
    pub target: Option<PathBuf>,
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
    let target = shared_target();
    let shared = target.is_some();
    let dep = runtime_dependency();
    let plan = codegen::plan(scene, None).map_err(|e| e.to_string())?;
    let module = codegen::module_name(&scene.name);
    let mut h = Fnv::new();
    for part in [
        format!("{:016x}", plan.key()).as_str(),
        VERSION,
        dep.as_str(),
        if shared { "shared" } else { "own" },
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
             [workspace.dependencies]\n{dep}\n\n{profile}",
            profile = release_profile()
        ),
    )?;
    // The lock file of the mbdc workspace, so that the runtime's dependencies are the tested
    // versions — and, when sharing mbdc's build, the very units it built. Copied before every
    // build: cargo prunes a lock to the packages its builds used and would later resolve the
    // pruned ones afresh (to newer versions, other units).
    if let Some(root) = source_root() {
        if let Ok(lock) = std::fs::read_to_string(root.join("Cargo.lock")) {
            write(&ws.join("Cargo.lock"), &lock)?;
        }
    }
    if dir.join(".complete").is_file() {
        return Ok(SceneCrate {
            ws,
            dir,
            package,
            target,
        });
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
             [dependencies]\nmbdc-runtime.workspace = true\n{}",
            scene.name,
            g.key,
            if shared { FEATURE_MIRROR } else { "" }
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
    Ok(SceneCrate {
        ws,
        dir,
        package,
        target,
    })
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
        .env("CARGO_TERM_COLOR", "never")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    match &c.target {
        Some(t) => cmd.env("CARGO_TARGET_DIR", t),
        None => cmd.env_remove("CARGO_TARGET_DIR"),
    };
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
    let mut phases = (!quiet && !std::io::stderr().is_terminal()).then(|| PhaseLines {
        start: std::time::Instant::now(),
        built: false,
        runtime: 0,
        scene: false,
    });
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
                        s.set_message("building scene (first run; --interp runs without building)");
                    } else if v["fresh"].as_bool() == Some(false) {
                        s.set_message(format!(
                            "building the runtime for compiled scenes (once; --interp runs without building): {name}"
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
                        s.set_message("building scene (first run; --interp runs without building)");
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
struct PhaseLines {
    /// When cargo was started.
    start: std::time::Instant,
    /// Whether anything was built (a warm run builds nothing and prints nothing).
    built: bool,
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
                eprintln!(
                    "building the runtime for compiled scenes (once; a minute or more — --interp runs without building)…"
                );
            }
            self.runtime += 1;
        }
        self.built = true;
    }

    /// The build ended.
    fn done(self) {
        if self.built {
            let what = match (self.runtime, self.scene) {
                (0, _) => "the scene's program".to_string(),
                (n, true) => format!("{n} runtime crate(s) and the scene's program"),
                (n, false) => format!("{n} runtime crate(s)"),
            };
            eprintln!(
                "built {what} in {:.1} s",
                self.start.elapsed().as_secs_f64()
            );
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

#[cfg(test)]
mod tests {
    use super::{release_profile, release_profile_of, runtime_dependency, FEATURE_MIRROR};
    use std::collections::BTreeSet;
    use std::path::Path;

    /// `cargo tree` of `package` in the workspace `manifest`: one line per crate, its
    /// version and features.
    fn graph(manifest: &Path, package: &str) -> BTreeSet<String> {
        let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
        let out = std::process::Command::new(cargo)
            .args([
                "tree",
                "--offline",
                "-e",
                "normal,build",
                "--prefix",
                "none",
            ])
            .args(["-f", "{p} {f}", "-p", package, "--manifest-path"])
            .arg(manifest)
            .output()
            .expect("cargo runs");
        assert!(
            out.status.success(),
            "cargo tree: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8_lossy(&out.stdout)
            .lines()
            .map(|l| l.trim_end_matches(" (*)").trim_end().to_string())
            .filter(|l| !l.is_empty())
            .collect()
    }

    /// A scene crate that shares mbdc's build must give every crate it has in common with
    /// mbdc's build the same version and features, or cargo builds it (and everything above
    /// it) a second time: every crate of the scene's graph, with its features, is in the
    /// graph of `mbdc` itself. When this fails after a dependency of mbdc changed, add to
    /// `FEATURE_MIRROR` what the message shows mbdc's build has.
    #[test]
    fn the_feature_mirror_matches_mbdcs_build() {
        let root = Path::new(super::SOURCE_ROOT);
        let mbdc = graph(&root.join("Cargo.toml"), "mbdc");
        let ws = tempfile::tempdir().expect("temp dir");
        let w = |p: &str, text: &str| {
            let path = ws.path().join(p);
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            std::fs::write(path, text).unwrap();
        };
        w(
            "Cargo.toml",
            &format!(
                "[workspace]\nresolver = \"2\"\nmembers = [\"scene\"]\n\n\
                 [workspace.dependencies]\n{}\n\n{}",
                runtime_dependency(),
                release_profile()
            ),
        );
        w(
            "Cargo.lock",
            &std::fs::read_to_string(root.join("Cargo.lock")).unwrap(),
        );
        w(
            "scene/Cargo.toml",
            &format!(
                "[package]\nname = \"mirror-scene\"\nversion = \"0.0.0\"\nedition = \"2021\"\n\n\
                 [dependencies]\nmbdc-runtime.workspace = true\n{FEATURE_MIRROR}"
            ),
        );
        w("scene/src/main.rs", "fn main() {}\n");
        let scene = graph(&ws.path().join("Cargo.toml"), "mirror-scene");
        let missing: Vec<String> = scene
            .iter()
            .filter(|l| !l.starts_with("mirror-scene ") && !mbdc.contains(*l))
            .map(|l| {
                let name = l.split(' ').next().unwrap_or("");
                let there: Vec<&String> = mbdc
                    .iter()
                    .filter(|m| m.split(' ').next() == Some(name))
                    .collect();
                format!("{l}    (mbdc's build: {there:?})")
            })
            .collect();
        assert!(
            missing.is_empty(),
            "crates a scene would build again, with other features than mbdc's build:\n{}",
            missing.join("\n")
        );
    }

    #[test]
    fn the_release_profile_is_copied_table_by_table() {
        let manifest =
            "[workspace]\nmembers = [\"a\"]\n\n[profile.release]\ndebug = \"line-tables-only\"\n\n\
                        # the test profile\n[profile.test]\nopt-level = 2\n\n\
                        [profile.release.package.foo]\nopt-level = 1\n# trailing\n";
        assert_eq!(
            release_profile_of(manifest),
            "[profile.release]\ndebug = \"line-tables-only\"\n\n[profile.release.package.foo]\nopt-level = 1\n"
        );
        assert_eq!(
            release_profile_of("[package]\nname = \"x\"\n"),
            "[profile.release]\ndebug = false\n"
        );
    }

    /// The workspace's own manifest: what the scenes get is what mbdc's build used.
    #[test]
    fn this_workspace_has_a_release_profile_to_share() {
        let manifest = include_str!("../../Cargo.toml");
        assert!(release_profile_of(manifest).starts_with("[profile.release]\n"));
    }
}
