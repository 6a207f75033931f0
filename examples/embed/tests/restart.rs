//! The program of a compiled scene (`src/bin/scene_program.rs`, what `mbdc run` builds and
//! runs) writes checkpoints and continues from them (`--checkpoint-every`, `--restart`): a
//! run that stopped after its checkpoint and was continued writes the same bytes as the run
//! made straight through.

use std::path::{Path, PathBuf};

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("mbdc-embed-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn program(out: &Path, args: &[&str]) -> String {
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_scene_program"))
        .args(["--every", "10", "--checkpoint-every", "300", "--out"])
        .arg(out)
        .args(args)
        .output()
        .expect("the scene program runs");
    let stderr = String::from_utf8_lossy(&o.stderr).to_string();
    assert!(o.status.success(), "{stderr}");
    stderr
}

#[test]
fn the_compiled_program_restarts_bitwise() {
    let (straight, cut) = (scratch("restart-straight"), scratch("restart-cut"));
    program(&straight, &["--duration", "2", "-q"]);
    program(&cut, &["--duration", "1.25", "-q"]);
    let said = program(&cut, &["--duration", "2", "--restart"]);
    assert!(said.contains("restarting from"), "{said}");
    assert!(said.contains("checkpoint_000000001200"), "{said}");
    for f in ["bodies.csv", "energy.csv", "constraints.csv"] {
        assert!(
            std::fs::read(straight.join(f)).unwrap() == std::fs::read(cut.join(f)).unwrap(),
            "{f} differs"
        );
    }
    let _ = std::fs::remove_dir_all(&straight);
    let _ = std::fs::remove_dir_all(&cut);
}
