//! Generates the Rust of every model in `models/` the runtime simulates (and its subfolders) through the
//! `build.rs` API — small scenes in both code layouts, large ones in the table layout they
//! get by default — and a registry that visits each generated model.

use std::fmt::Write as _;
use std::path::PathBuf;

use mbdc_runtime::compiled::Mode;

fn main() {
    let models = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../models");
    println!("cargo:rerun-if-changed={}", models.display());
    let mut files = Vec::new();
    let mut dirs = vec![models.clone()];
    while let Some(d) = dirs.pop() {
        println!("cargo:rerun-if-changed={}", d.display());
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
    let out = PathBuf::from(std::env::var("OUT_DIR").expect("OUT_DIR"));
    let mut reg = String::new();
    let mut visits = String::new();
    for f in &files {
        let loaded = mbdc_compiler::load_file(f, &[]);
        let Some(scene) = loaded.scene else { continue };
        // Only scenes the runtime simulates.
        if mbdc_runtime::interp::Interp::new(&scene).is_err() {
            continue;
        }
        // The path under models/, with `/` separators, as the tests load it.
        let file = f
            .strip_prefix(&models)
            .expect("under models/")
            .components()
            .map(|c| c.as_os_str().to_string_lossy())
            .collect::<Vec<_>>()
            .join("/");
        for (mode, suffix) in [(Mode::Unrolled, "unrolled"), (Mode::Tables, "tables")] {
            let module = format!(
                "{}_{suffix}",
                mbdc_compiler::codegen::module_name(&scene.name)
            );
            let built = mbdc_compiler::Builder::new(f)
                .module(&module)
                .mode(mode)
                .warnings(false) // redundant joints of models/hard are meant
                .out_dir(&out)
                .build();
            writeln!(reg, "include!({:?});", built.rs.display().to_string()).unwrap();
            writeln!(
                visits,
                "    v.visit::<{module}::Model>({file:?}, {suffix:?});"
            )
            .unwrap();
        }
    }
    let text = format!(
        "{reg}\n/// Visit every generated model: (model file, layout).\npub fn visit_all<V: crate::Visitor>(v: &mut V) {{\n{visits}}}\n"
    );
    mbdc_compiler::embed::write_if_changed(&out.join("registry.rs"), &text).expect("registry");
}
