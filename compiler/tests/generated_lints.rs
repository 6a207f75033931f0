//! The generated code is warning-free: the Rust of every model in `models/` the runtime
//! simulates (rigid, with beams, with meshes) and of a scene with every kind of contact
//! (which no model has), in both layouts (so the small models' table code and the large
//! models' unrolled code are checked too), is written into one small crate with
//! `#![deny(warnings)]` and `#![deny(clippy::all)]`, which `cargo clippy` must accept. The generated module carries no `allow` of its own, so
//! an unused import, variable or helper, or a pattern clippy flags, fails this test.
//!
//! The crate lives under the target directory (`CARGO_TARGET_DIR` if set, else the
//! repository's `target/`) and builds there, so the runtime and its dependencies are not
//! rebuilt for it. It needs `cargo clippy` (`rustup component add clippy`; CI installs it).

use std::io::Read as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use mbdc_compiler::codegen::{self, generate, Options, SceneJson};
use mbdc_compiler::{load_file, load_str, Scene};
use mbdc_runtime::compiled::Mode;
use mbdc_runtime::interp::Interp;

/// Generous: the first run checks the runtime's dependencies.
const TIMEOUT: Duration = Duration::from_secs(30 * 60);

/// Every kind of contact (no model in `models/` has contact).
const CONTACTS: &str = "model contacts {
  gravity (0, 0, -9.81) m/s^2
  body ball { mass 1 kg; inertia sphere(radius: 0.1 m); position (0, 0, 1) m }
  body other { mass 1 kg; inertia sphere(radius: 0.1 m); position (0.5, 0, 1) m }
  body crate { mass 2 kg; inertia box(size: (0.2, 0.2, 0.2) m); position (2, 0, 1) m }
  contact floor = sphere_plane(ball @ (0, 0, 0), ground @ (0, 0, 0), radius: 0.1 m, normal: (0, 0, 1), stiffness: 1e5 N/m, damping: 20 N*s/m, friction: 0.3)
  contact balls = sphere_sphere(ball @ (0, 0, 0), other @ (0, 0, 0), radius_a: 0.1 m, radius_b: 0.1 m, stiffness: 1e5 N/m)
  contact crate_floor = box_plane(crate @ (0, 0, 0), ground @ (0, 0, 0), size: (0.2, 0.2, 0.2) m, normal: (0, 0, 1), stiffness: 1e5 N/m)
  simulate { duration 1 s; step 1 ms }
}";

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .canonicalize()
        .expect("repository root")
}

fn target_dir() -> PathBuf {
    match std::env::var_os("CARGO_TARGET_DIR") {
        Some(d) if !d.is_empty() => {
            let d = PathBuf::from(d);
            if d.is_relative() {
                repo().join(d)
            } else {
                d
            }
        }
        _ => repo().join("target"),
    }
}

/// Every `.mbd` file under `dir`, sorted.
fn model_files(dir: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    let mut dirs = vec![dir.to_path_buf()];
    while let Some(d) = dirs.pop() {
        for e in std::fs::read_dir(&d).expect("models/").flatten() {
            let p = e.path();
            if p.is_dir() {
                dirs.push(p);
            } else if p.extension().is_some_and(|e| e == "mbd") {
                files.push(p);
            }
        }
    }
    files.sort();
    files
}

/// Write `text` to `path` unless it is already there (so that cargo's fingerprints hold).
fn write(path: &Path, text: &str) {
    if std::fs::read_to_string(path).is_ok_and(|old| old == text) {
        return;
    }
    std::fs::write(path, text).unwrap_or_else(|e| panic!("writing {}: {e}", path.display()));
}

/// Run `cmd` to completion or `TIMEOUT`, returning (success, stdout + stderr).
fn run(mut cmd: Command) -> (bool, String) {
    let mut child = cmd
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot run {cmd:?}: {e}"));
    let pipe = |mut r: Box<dyn std::io::Read + Send>| {
        std::thread::spawn(move || {
            let mut s = String::new();
            let _ = r.read_to_string(&mut s);
            s
        })
    };
    let out = pipe(Box::new(child.stdout.take().expect("stdout")));
    let err = pipe(Box::new(child.stderr.take().expect("stderr")));
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().expect("waiting for cargo") {
            break Some(s);
        }
        if start.elapsed() > TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(200));
    };
    let text = format!(
        "{}{}",
        out.join().unwrap_or_default(),
        err.join().unwrap_or_default()
    );
    match status {
        Some(s) => (s.success(), text),
        None => (
            false,
            format!("{cmd:?} timed out after {TIMEOUT:?}; output so far:\n{text}"),
        ),
    }
}

fn cargo() -> Command {
    let mut c = Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()));
    // The outer `cargo test` is no business of the inner cargo.
    c.env_remove("CARGO_MANIFEST_DIR")
        .env_remove("CARGO_PKG_NAME")
        .env_remove("CARGO_PRIMARY_PACKAGE")
        .env_remove("CARGO_CRATE_NAME");
    c
}

#[test]
fn generated_code_passes_clippy_with_warnings_denied() {
    let (ok, version) = run({
        let mut c = cargo();
        c.args(["clippy", "--version"]);
        c
    });
    assert!(
        ok,
        "`cargo clippy` is not available (install it with `rustup component add clippy`; CI \
         installs it), so the generated code cannot be checked:\n{version}"
    );

    let repo = repo();
    let dir = target_dir().join("mbdc-generated-lints");
    let src = dir.join("src");
    std::fs::create_dir_all(&src).expect("crate folder");

    // The scenes: every rigid model, and the contacts.
    let mut scenes: Vec<(String, Scene)> = Vec::new();
    for file in model_files(&repo.join("models")) {
        let loaded = load_file(&file, &[]);
        let Some(scene) = loaded.scene else {
            panic!("{}: {}", file.display(), loaded.render_plain())
        };
        // Only scenes the runtime simulates (bodies, beams, meshes).
        if Interp::new(&scene).is_ok() {
            scenes.push((file.display().to_string(), scene));
        }
    }
    let contacts = load_str("contacts.mbd", CONTACTS, &[]);
    match contacts.scene {
        Some(s) => scenes.push(("contacts.mbd".into(), s)),
        None => panic!("contacts.mbd: {}", contacts.render_plain()),
    }

    // The modules: every scene in both layouts.
    let mut modules = Vec::new();
    let mut effects = std::collections::BTreeSet::new();
    let mut default_tables = Vec::new();
    for (file, scene) in &scenes {
        if codegen::choose_mode(scene) == Mode::Tables {
            default_tables.push(scene.name.clone());
        }
        for (mode, suffix) in [(Mode::Unrolled, "unrolled"), (Mode::Tables, "tables")] {
            let module = format!("{}_{suffix}", codegen::module_name(&scene.name));
            let json = src.join(format!("{module}.scene.json"));
            let options = Options {
                module: Some(module.clone()),
                mode: Some(mode),
                scene_json: SceneJson::Include(json.to_string_lossy().replace('\\', "/")),
            };
            let g = generate(scene, &options).unwrap_or_else(|e| panic!("{file}: {e}"));
            write(&json, &g.scene_json);
            write(&src.join(format!("{module}.rs")), &g.source);
            effects.extend(g.effects);
            modules.push(module);
        }
    }
    // The models cover the code paths that emit something of their own.
    for m in ["pendulum", "double_pendulum_3d", "four_bar"] {
        assert!(
            modules.contains(&format!("{m}_unrolled")),
            "models/{m}.mbd is not among the checked models"
        );
    }
    assert!(
        !default_tables.is_empty(),
        "no model large enough for the table layout by default"
    );
    for e in [
        "gravity",
        "springs",
        "contact",
        "locks",
        "time_dependence",
        "closed_loops",
    ] {
        assert!(effects.contains(e), "no checked model has {e}");
    }

    let runtime = repo.join("runtime");
    let manifest = format!(
        r#"[package]
name = "mbdc-generated-lints"
version = "0.0.0"
edition = "2021"
publish = false

[dependencies]
mbdc-runtime = {{ path = {:?} }}

# The workspace's profiles, so that the dependencies built for it are reused.
[profile.dev.package."*"]
opt-level = 2

# Not a member of the repository's workspace (the target folder may be inside it).
[workspace]
"#,
        runtime.to_string_lossy().replace('\\', "/")
    );
    write(&dir.join("Cargo.toml"), &manifest);
    // The workspace's lock file, so that the same dependency versions are used and nothing
    // is resolved anew (cargo trims it to this crate's dependencies).
    let lock = std::fs::read_to_string(repo.join("Cargo.lock")).expect("Cargo.lock");
    write(&dir.join("Cargo.lock"), &lock);
    let includes: String = modules
        .iter()
        .map(|m| format!("include!(\"{m}.rs\");\n"))
        .collect();
    write(
        &src.join("lib.rs"),
        &format!(
            "//! Generated code of mbdc's models under `deny(warnings)` and `deny(clippy::all)`.\n\n\
             #![deny(warnings)]\n#![deny(clippy::all)]\n\n{includes}"
        ),
    );

    let mut clippy = cargo();
    clippy
        .current_dir(&dir)
        .args(["clippy", "--quiet", "--manifest-path"])
        .arg(dir.join("Cargo.toml"))
        .env("CARGO_TARGET_DIR", target_dir());
    let (ok, output) = run(clippy);
    assert!(
        ok,
        "the generated code of {} modules has warnings or clippy findings (crate: {}):\n{output}",
        modules.len(),
        dir.display()
    );
}
