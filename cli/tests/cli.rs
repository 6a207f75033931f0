//! End-to-end runs of the `mbdc` binary: check and fmt.

mod common;
use common::{command, root};

use std::path::PathBuf;

fn tmp(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("mbdc-cli-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write");
    p
}

#[test]
fn check_prints_a_summary() {
    let out = command()
        .arg("check")
        .arg(root().join("models/slider_crank.mbd"))
        .output()
        .expect("runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let s = String::from_utf8_lossy(&out.stdout);
    assert!(s.contains("model slider_crank"), "{s}");
    assert!(s.contains("DOF          1"), "{s}");
    assert!(s.contains("Jacobian rank 17 of 17"), "{s}");
    assert!(s.contains("staggered (epsilon 1e-6"), "{s}");
}

#[test]
fn check_with_overrides_effects_and_json() {
    let out = command()
        .args(["check", "--set", "N=3", "--effects"])
        .arg(root().join("models/chain.mbd"))
        .output()
        .expect("runs");
    assert!(out.status.success());
    let s = String::from_utf8_lossy(&out.stdout);
    assert!(
        s.contains("bodies       3: link[0], link[1], link[2]"),
        "{s}"
    );
    assert!(s.contains("N = 3 (set)"), "{s}");
    assert!(
        s.contains("gravity          yes") && s.contains("contact          no"),
        "{s}"
    );

    let out = command()
        .args(["check", "--json"])
        .arg(root().join("models/torque_free.mbd"))
        .output()
        .expect("runs");
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
    assert_eq!(v["name"], "torque_free");
    assert_eq!(v["bodies"][0]["angular_velocity"][1], 2.0);

    let out = command()
        .args(["check", "--set", "M=3"])
        .arg(root().join("models/chain.mbd"))
        .output()
        .expect("runs");
    assert!(!out.status.success());
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(e.contains("there is no parameter `M`"), "{e}");
}

/// A `--set` of the wrong unit or kind, or of a name that is no parameter, is one clear error
/// from `check` and `run` alike: the value given, what the parameter expects, its
/// declaration in the file; nothing is written and nothing panics.
#[test]
fn bad_overrides_are_one_clear_error_at_the_parameter() {
    let model = root().join("models/pendulum.mbd");
    let out_dir = std::env::temp_dir().join(format!("mbdc-bad-set-{}", std::process::id()));
    let cases = [
        (
            "m=3 m",
            "`--set m=3 m`: expected a quantity in kg (mass), found a quantity in m (length)",
            "pendulum.mbd:16:13",
        ),
        (
            "L=2",
            "`--set L=2`: expected a quantity in m (length), found a number",
            "pendulum.mbd:15:13",
        ),
        (
            "m=abc",
            "`--set m=abc`: expected a quantity in kg (mass), found the name `abc`",
            "pendulum.mbd:16:13",
        ),
        (
            "g=9 m/s^2",
            "`--set g=9 m/s^2`: `g` is a `const`, not a `param`",
            "pendulum.mbd:19:9",
        ),
        (
            "mass=2 kg",
            "`--set mass=2 kg`: there is no parameter `mass`",
            "its parameters: `m`, `L`, `r`, `theta0`",
        ),
    ];
    for (set, message, at) in cases {
        for cmd in ["check", "run"] {
            let mut c = command();
            c.args([cmd, "--set", set]);
            if cmd == "run" {
                c.args(["--interp", "-o"]).arg(&out_dir);
            }
            let out = c.arg(&model).output().expect("runs");
            let e = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(1), "{cmd} --set {set}: {e}");
            assert!(e.contains(message), "{cmd} --set {set}: {e}");
            assert!(e.contains(at), "{cmd} --set {set}: {e}");
            assert!(e.contains("1 error"), "{cmd} --set {set}: {e}");
            assert!(!e.contains("panicked"), "{cmd} --set {set}: {e}");
            assert!(!out_dir.exists(), "{cmd} --set {set}: nothing written");
        }
    }
}

#[test]
fn check_fails_with_rendered_diagnostics() {
    let out = command()
        .arg("check")
        .arg(root().join("tests/failures/unknown_body.mbd"))
        .output()
        .expect("runs");
    assert!(!out.status.success());
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(e.contains("unknown body `rdo1`"), "{e}");
    assert!(e.contains("did you mean `rod1`?"), "{e}");
    assert!(e.contains("unknown_body.mbd:4:47"), "{e}");
    assert!(e.contains("1 error"), "{e}");
    let out = command()
        .arg("check")
        .arg("no/such/file.mbd")
        .output()
        .expect("runs");
    assert!(!out.status.success());
}

#[test]
fn fmt_rewrites_and_checks() {
    let messy = "model m {\n  body b { mass 1 kg ;inertia sphere( radius:1 cm ) }\n  simulate { duration 1 s; step 1 ms }\n}\n";
    let p = tmp("messy.mbd", messy);
    let out = command()
        .args(["fmt", "--check"])
        .arg(&p)
        .output()
        .expect("runs");
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout).contains("messy.mbd"));
    assert_eq!(
        std::fs::read_to_string(&p).unwrap(),
        messy,
        "--check must not write"
    );
    let out = command().arg("fmt").arg(&p).output().expect("runs");
    assert!(out.status.success());
    let formatted = std::fs::read_to_string(&p).unwrap();
    assert_ne!(formatted, messy);
    let out = command()
        .args(["fmt", "--check"])
        .arg(&p)
        .output()
        .expect("runs");
    assert!(out.status.success(), "formatted file is not stable");
    // The formatted file still checks.
    let out = command().arg("check").arg(&p).output().expect("runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // A file that does not parse is an error, and is left alone.
    let bad = tmp("bad.mbd", "model m {\n");
    let out = command().arg("fmt").arg(&bad).output().expect("runs");
    assert!(!out.status.success());
    assert_eq!(std::fs::read_to_string(&bad).unwrap(), "model m {\n");
}
