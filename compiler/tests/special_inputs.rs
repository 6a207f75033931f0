//! Inputs that are not regular files, or are too large: the main model, an import and a mesh
//! import of `/dev/zero` (read forever until the process aborted), a FIFO (blocked until a
//! writer came), a directory, and a file past the size limit are refused by their kind or
//! size, naming the file, before anything is read.

use std::path::Path;

use mbdc_compiler::load::{read_input, MAX_SOURCE_BYTES};

fn first_error(loaded: &mbdc_compiler::Loaded) -> String {
    loaded
        .errors()
        .next()
        .map(|d| d.message.clone())
        .unwrap_or_else(|| panic!("expected an error:\n{}", loaded.render_plain()))
}

#[cfg(unix)]
fn fifo(dir: &Path) -> Option<std::path::PathBuf> {
    let p = dir.join("fifo.mbd");
    let made = std::process::Command::new("mkfifo").arg(&p).status();
    made.is_ok_and(|s| s.success()).then_some(p)
}

#[test]
fn special_files_are_refused_as_the_model() {
    let dir = tempfile::tempdir().expect("temp dir");
    let m = first_error(&mbdc_compiler::load_file(dir.path(), &[]));
    assert!(m.contains("a directory is not a regular file"), "{m}");
    #[cfg(unix)]
    {
        let m = first_error(&mbdc_compiler::load_file("/dev/zero", &[]));
        assert_eq!(
            m,
            "cannot read `/dev/zero`: a character device is not a regular file"
        );
        if let Some(p) = fifo(dir.path()) {
            let m = first_error(&mbdc_compiler::load_file(&p, &[]));
            assert!(
                m.contains("a FIFO (named pipe) is not a regular file"),
                "{m}"
            );
        }
    }
}

#[cfg(unix)]
#[test]
fn special_files_are_refused_as_imports_and_meshes() {
    let dir = tempfile::tempdir().expect("temp dir");
    let main = dir.path().join("main.mbd");
    let model = |import: &str| {
        format!(
            "import \"{import}\"\nmodel m {{\n  body b {{ mass 1 kg; inertia sphere(radius: 1 m) }}\n  simulate {{ duration 1 s; step 1 ms }}\n}}\n"
        )
    };
    std::fs::write(&main, model("/dev/zero")).expect("write");
    let m = first_error(&mbdc_compiler::load_file(&main, &[]));
    assert!(
        m.contains("/dev/zero") && m.contains("a character device is not a regular file"),
        "{m}"
    );
    if let Some(p) = fifo(dir.path()) {
        std::fs::write(&main, model(&p.to_string_lossy())).expect("write");
        let m = first_error(&mbdc_compiler::load_file(&main, &[]));
        assert!(
            m.contains("a FIFO (named pipe) is not a regular file"),
            "{m}"
        );
    }
    let mesh = "model m {\n  material alu { E 70 GPa; nu 0.33; rho 2700 kg/m^3 }\n  mesh p {\n    element quad4\n    thickness 1 cm\n    import \"/dev/zero\"\n    material alu\n  }\n  simulate { duration 1 ms; step 1 us }\n}\n";
    std::fs::write(&main, mesh).expect("write");
    let m = first_error(&mbdc_compiler::load_file(&main, &[]));
    assert!(
        m.contains("/dev/zero") && m.contains("a character device is not a regular file"),
        "{m}"
    );
}

#[test]
fn a_file_past_the_size_limit_is_refused_with_its_size() {
    let dir = tempfile::tempdir().expect("temp dir");
    let p = dir.path().join("huge.mbd");
    // sparse: no disk is used for the hole
    let f = std::fs::File::create(&p).expect("create");
    f.set_len(MAX_SOURCE_BYTES + 1).expect("set_len");
    let e = read_input(&p, MAX_SOURCE_BYTES).unwrap_err();
    assert_eq!(
        e.to_string(),
        format!(
            "the file has {} bytes, more than the 64 MiB mbdc reads",
            MAX_SOURCE_BYTES + 1
        )
    );
    let m = first_error(&mbdc_compiler::load_file(&p, &[]));
    assert!(
        m.contains("huge.mbd") && m.contains("more than the 64 MiB"),
        "{m}"
    );
    // at the limit it is read
    f.set_len(16).expect("set_len");
    assert_eq!(read_input(&p, 16).expect("read").len(), 16);
}
