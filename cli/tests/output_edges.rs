//! The edges of what `mbdc` prints: a diagnostic far along a very long line, a closed output
//! pipe, and help text that must agree with the runtime and the docs.

mod common;
use common::{command, mbdc, root, s, scratch};

use std::process::Stdio;

/// A one-line model of 2000 bodies with an unknown body at its end, past column 70 000:
/// miette's renderer panicked there (formatting widths are 16-bit), and the whole line would
/// have been echoed.
#[test]
fn a_diagnostic_past_column_65535_is_rendered_short() {
    let mut text = String::from("model m { ");
    for i in 0..2000 {
        text.push_str(&format!(
            "body b{i} {{ mass 1 kg; inertia sphere(radius: 1 cm) }}; "
        ));
    }
    assert!(text.len() > 70_000);
    text.push_str("joint j = spherical(ground @ (0, 0, 0), bXX @ (0, 0, 0)) }\n");
    let dir = scratch("long-line");
    let file = dir.join("long.mbd");
    std::fs::write(&file, text).expect("write");
    let out = mbdc(&["check", s(&file)]);
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(!e.contains("panicked"), "{e}");
    assert_eq!(out.status.code(), Some(1), "{e}");
    assert!(e.contains("bXX"), "{e}");
    assert!(e.contains('…'), "{e}");
    assert!(e.len() < 2048, "{} bytes of stderr:\n{e}", e.len());
}

/// `mbdc … | head -1`: a closed stdout ends the program quietly (by SIGPIPE, as Unix tools
/// do), not with a panic from `println!`.
#[cfg(unix)]
#[test]
fn a_closed_pipe_ends_quietly() {
    use std::os::unix::process::ExitStatusExt;
    let chain = root().join("models/chain.mbd");
    let pendulum = root().join("models/pendulum.mbd");
    let out_dir = scratch("closed-pipe");
    let sweep_dir = out_dir.join("sweep");
    let runs: [Vec<&str>; 4] = [
        vec!["check", s(&chain)],
        vec!["fmt", "--check", s(&chain)],
        vec![
            "run",
            "--interp",
            s(&pendulum),
            "--duration",
            "0.01",
            "-o",
            s(&out_dir),
        ],
        vec![
            "sweep",
            "--interp",
            s(&pendulum),
            "--steps",
            "0.01,0.005",
            "-o",
            s(&sweep_dir),
        ],
    ];
    for args in runs {
        let mut child = command()
            .args(&args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("mbdc runs");
        // the reader goes away before mbdc writes anything
        drop(child.stdout.take());
        let out = child.wait_with_output().expect("mbdc ends");
        let e = String::from_utf8_lossy(&out.stderr);
        assert!(!e.contains("panicked"), "{args:?}: {e}");
        // ended by the signal, or finished with its own code (`fmt --check` reports on
        // stderr), never the panic's 101
        assert!(
            out.status.signal() == Some(libc::SIGPIPE) || matches!(out.status.code(), Some(0 | 1)),
            "{args:?}: {:?}\n{e}",
            out.status
        );
    }
}

/// The help of `--on-failure halve-step` and docs/stability.md give the runtime's retry limit.
#[test]
fn halve_step_help_and_docs_give_the_runtime_limit() {
    let n = mbdc_runtime::run_loop::MAX_HALVINGS;
    let out = mbdc(&["run", "--help"]);
    let help = String::from_utf8_lossy(&out.stdout);
    assert!(help.contains(&format!("up to {n} times")), "{help}");
    let doc = std::fs::read_to_string(root().join("docs/stability.md")).expect("docs");
    assert!(
        doc.contains(&format!("up to {n} times")),
        "docs/stability.md"
    );
}

/// A run that would write more than a gigabyte says so before it starts (`mbdc check`
/// applies the run's start gate), with its size and the output interval that brings it to
/// about 100 MB; one that would not, stays silent. The chain of models/ over 1000 s at
/// 0.1 ms writes 10⁷ frames of its 32 bodies:
/// 130 GB.
#[test]
fn a_run_that_would_fill_a_disk_warns_before_it_starts() {
    let text = std::fs::read_to_string(root().join("models/chain.mbd")).expect("chain");
    let long = text.replace("duration 1 s;", "duration 1000 s;");
    assert_ne!(long, text, "models/chain.mbd changed its simulate block");
    let dir = scratch("output-size");
    let file = dir.join("long_chain.mbd");
    std::fs::write(&file, long).expect("write");
    let out = mbdc(&["check", s(&file)]);
    let e = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{e}");
    assert!(
        e.contains("warning: this run will write up to about"),
        "{e}"
    );
    // 10⁷ frames of 13 kB (the 32 bodies' states, their joints' multipliers) → every 2000
    // steps writes about 65 MB (every 1000: 130 MB, above the 100 MB aimed at)
    assert!(e.contains(" GB (10000001 frames"), "{e}");
    assert!(e.contains("`--every 2000`"), "{e}");
    let out = mbdc(&["check", s(&root().join("models/chain.mbd"))]);
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(!e.contains("will write up to about"), "{e}");
}

/// A first build's minutes are not silent without a terminal (a CI log, a pipe): a line
/// when the runtime's crates start building and one with what was built in how long.
/// cargo is a script that reports two freshly built runtime crates and a program that ends
/// at once.
#[cfg(unix)]
#[test]
fn a_first_build_prints_its_phases_without_a_terminal() {
    use std::os::unix::fs::PermissionsExt;
    let dir = scratch("build-phases");
    let program = dir.join("program.sh");
    std::fs::write(&program, "#!/bin/sh\nexit 1\n").expect("program");
    let cargo = dir.join("cargo.sh");
    let artifact = |name: &str, fresh: bool, exe: &str| {
        format!(
            "echo '{{\"reason\":\"compiler-artifact\",\"target\":{{\"name\":\"{name}\"}},\"fresh\":{fresh}{exe}}}'\n"
        )
    };
    let script = format!(
        "#!/bin/sh\n{}{}{}",
        artifact("nalgebra", false, ""),
        artifact("mbdc_runtime", false, ""),
        artifact(
            "stand-in",
            true,
            &format!(",\"executable\":\"{}\"", program.display())
        ),
    );
    std::fs::write(&cargo, script).expect("cargo");
    for p in [&program, &cargo] {
        std::fs::set_permissions(p, std::fs::Permissions::from_mode(0o755)).expect("chmod");
    }
    let out = command()
        .args(["run", "--duration", "0.01", "-o"])
        .arg(dir.join("out"))
        .arg(root().join("models/pendulum.mbd"))
        .env("CARGO", &cargo)
        .env("MBDC_BUILD_DIR", dir.join("ws"))
        .stdin(Stdio::null())
        .output()
        .expect("mbdc runs");
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(
        e.contains("building the runtime for compiled scenes (once; a minute or more — --interp runs without building)…"),
        "{e}"
    );
    assert!(e.contains("built 2 runtime crate(s) in "), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}
