//! `mbdc sweep` on the torque-free asymmetric body of `models/torque_free.mbd` against its
//! exact solution: staggered and implicit_trapezoid converge at order 2 ± 0.2.
//!
//! The model has no `reference` block (the orientation of an asymmetric free body needs an
//! elliptic integral of the third kind, which the expression language does not have), so
//! the test writes one as a table: the body angular velocity in closed form with Jacobi
//! elliptic functions, and the orientation from it by integrating q̇ = ½ q ⊗ (0, ω) with
//! classical Runge–Kutta at a step so small that its error (~1e-13 rad) is far below the
//! swept errors. The scene is the model file itself with the `reference` block added.

mod common;
use common::root;

use std::process::Command;

use mbdc_runtime::fn1::sncndn;
use serde_json::Value;

/// Principal moments of the model, kg·m².
const J: [f64; 3] = [1.0, 2.0, 3.0];
/// Initial body angular velocity of the model, rad/s.
const W0: [f64; 3] = [0.01, 2.0, 0.0];

/// The exact body angular velocity of the model's brick.
///
/// With J = (1, 2, 3) kg·m² Euler's equations read ω̇₁ = −ω₂ω₃, ω̇₂ = ω₃ω₁,
/// ω̇₃ = −ω₁ω₂/3, and since L² < 2E·J₂ the polhode circles the axis of the smallest moment:
/// ω = (a dn u, b sn u, c cn u), u = λt + K(m). Substituting gives a m λ = b c, b λ = a c
/// and 3 c λ = a b; the initial value ω(0) = (a √(1 − m), b, 0) = (0.01, 2, 0) rad/s then
/// fixes b = 2, c = b/√3, a²m = b², (1 − m)/m = (0.01/b)² and λ = a c / b.
/// [`euler_residual_is_round_off`] checks the result against Euler's equations.
struct Exact {
    a: f64,
    b: f64,
    c: f64,
    lambda: f64,
    m: f64,
    k: f64,
}

impl Exact {
    fn new() -> Exact {
        let b = W0[1];
        let c = b / 3f64.sqrt();
        let r = (W0[0] / b).powi(2); // (1 − m)/m
        let m = 1.0 / (1.0 + r);
        let a = b / m.sqrt();
        let lambda = a * c / b;
        Exact {
            a,
            b,
            c,
            lambda,
            m,
            k: mbdc_runtime::fn1::ellipk(m),
        }
    }

    fn omega(&self, t: f64) -> [f64; 3] {
        let (sn, cn, dn) = sncndn(self.lambda * t + self.k, self.m);
        [self.a * dn, self.b * sn, self.c * cn]
    }
}

/// The closed form satisfies the initial condition and Euler's torque-free equations
/// J ω̇ = (Jω) × ω to round-off (central differences).
#[test]
fn euler_residual_is_round_off() {
    let e = Exact::new();
    let w = e.omega(0.0);
    for i in 0..3 {
        assert!((w[i] - W0[i]).abs() < 1e-12, "{w:?}");
    }
    let d = 1e-5;
    for k in 0..200 {
        let t = 0.05 * f64::from(k);
        let (wm, w, wp) = (e.omega(t - d), e.omega(t), e.omega(t + d));
        let l = [J[0] * w[0], J[1] * w[1], J[2] * w[2]];
        let cross = [
            l[1] * w[2] - l[2] * w[1],
            l[2] * w[0] - l[0] * w[2],
            l[0] * w[1] - l[1] * w[0],
        ];
        for i in 0..3 {
            let lhs = J[i] * (wp[i] - wm[i]) / (2.0 * d);
            assert!(
                (lhs - cross[i]).abs() < 1e-7,
                "t = {t}: component {i}: {lhs} vs {}",
                cross[i]
            );
        }
    }
}

fn qmul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

/// q̇ = ½ q ⊗ (0, ω(t)), ω in body components.
fn qdot(e: &Exact, q: [f64; 4], t: f64) -> [f64; 4] {
    let w = e.omega(t);
    qmul(q, [0.0, w[0], w[1], w[2]]).map(|x| 0.5 * x)
}

/// The reference table: `t, brick.qw, brick.qx, brick.qy, brick.qz` every `dt` to `t_end`
/// (RK4 with `sub` steps per row, from the identity orientation of the model).
fn table(t_end: f64, dt: f64, sub: u32) -> String {
    let e = Exact::new();
    let n = (t_end / dt).round() as u32;
    let h = dt / f64::from(sub);
    let mut q = [1.0, 0.0, 0.0, 0.0];
    let mut out = String::from("t,brick.qw,brick.qx,brick.qy,brick.qz\n");
    let row = |out: &mut String, t: f64, q: &[f64; 4]| {
        out.push_str(&format!(
            "{t:e},{:e},{:e},{:e},{:e}\n",
            q[0], q[1], q[2], q[3]
        ));
    };
    row(&mut out, 0.0, &q);
    for i in 0..n {
        for s in 0..sub {
            let t = f64::from(i) * dt + f64::from(s) * h;
            let add = |q: [f64; 4], k: [f64; 4], f: f64| -> [f64; 4] {
                std::array::from_fn(|c| q[c] + f * k[c])
            };
            let k1 = qdot(&e, q, t);
            let k2 = qdot(&e, add(q, k1, h / 2.0), t + h / 2.0);
            let k3 = qdot(&e, add(q, k2, h / 2.0), t + h / 2.0);
            let k4 = qdot(&e, add(q, k3, h), t + h);
            q = std::array::from_fn(|c| {
                q[c] + h / 6.0 * (k1[c] + 2.0 * k2[c] + 2.0 * k3[c] + k4[c])
            });
        }
        let norm = q.iter().map(|x| x * x).sum::<f64>().sqrt();
        q = q.map(|x| x / norm);
        row(&mut out, f64::from(i + 1) * dt, &q);
    }
    out
}

/// The run of 8 s covers the first flip of the body (its intermediate-axis spin
/// reverses around t = K(m)/λ ≈ 5.8 s). Steps from 20 ms down to 20 ms/64; frames every
/// 40 ms (on the table's 1 ms grid).
#[test]
fn second_order_on_the_torque_free_body() {
    let dir = std::env::temp_dir().join(format!("mbdc-sweep-torque-free-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    let model = std::fs::read_to_string(root().join("models/torque_free.mbd")).expect("model");
    let at = model.find("  simulate {").expect("a simulate block");
    let scene = format!(
        "{}  reference {{ table \"exact.csv\" }}\n\n{}",
        &model[..at],
        &model[at..]
    );
    let file = dir.join("torque_free.mbd");
    std::fs::write(&file, scene).expect("write scene");
    let duration = 8.0;
    std::fs::write(dir.join("exact.csv"), table(duration, 1e-3, 20)).expect("write table");

    let out = dir.join("out");
    let o = Command::new(env!("CARGO_BIN_EXE_mbdc"))
        .env("NO_COLOR", "1")
        .arg("sweep")
        .arg(&file)
        .arg("-o")
        .arg(&out)
        .args([
            "--interp",
            "--methods",
            "staggered,implicit_trapezoid",
            "--duration",
            "8",
            "--h-max",
            "0.02",
            "--levels",
            "7",
            "--frames",
            "200",
            "--min-time",
            "0",
            "-q",
        ])
        .output()
        .expect("mbdc runs");
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "mbdc sweep failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    eprintln!("{stdout}");
    let j: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("sweep.json")).expect("sweep.json"))
            .expect("valid JSON");
    assert_eq!(j["reference"]["kind"], "table", "{}", j["reference"]);
    assert_eq!(j["measure"], "rot_err_max_rad");
    for name in ["staggered", "implicit_trapezoid"] {
        let m = j["methods"]
            .as_array()
            .expect("methods")
            .iter()
            .find(|m| m["name"] == name)
            .unwrap_or_else(|| panic!("{name} in {j}"));
        let fit = &m["fit"];
        let order = fit["order"]
            .as_f64()
            .unwrap_or_else(|| panic!("{name}: no order in {fit}\n{stdout}"));
        assert!(
            (order - 2.0).abs() <= 0.2,
            "{name}: measured order {order}, expected 2 ± 0.2 ({fit})\n{stdout}"
        );
        assert!(
            fit["steps_used"].as_array().map_or(0, Vec::len) >= 3,
            "{name}: too few runs in the fit ({fit})"
        );
        assert_eq!(fit["flagged"], false);
    }
    let _ = std::fs::remove_dir_all(&dir);
}
