//! `mbdc run --mpi` under Open MPI's `mpirun` (cargo feature `mpi`; `.ci/run` installs Open
//! MPI and runs these): issue 17's checks 4 and 5 across real processes.
//!
//! - The explicit method on 1, 2 and 4 ranks writes, byte for byte, the mesh files of the
//!   run in one process (`--interp`): the motion is bitwise the same, and the files carry
//!   every digit (shortest round-trip decimals).
//! - A rank killed with SIGKILL in the middle of a run ends the whole run (no hang):
//!   `mpirun` exits non-zero and names the rank and the signal; every rank's checkpoints
//!   stay whole, and `--restart` on the same ranks continues from the newest step all
//!   ranks saved to the end, writing the files of the run that was never stopped.
//!
//! On the 2-core CI machine 4 ranks are oversubscribed (`--oversubscribe`); as root, Open
//! MPI's allow-run-as-root variables are set for `mpirun`.

mod common;
use common::{command, root, s, scratch, summary};

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// `mpirun -n RANKS mbdc run --mpi ARGS…`, not yet started.
fn mpirun(ranks: usize, args: &[&str]) -> Command {
    let mut c = Command::new("mpirun");
    c.env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .env("NO_COLOR", "1")
        .args(["--oversubscribe", "-n", &ranks.to_string()])
        .arg(env!("CARGO_BIN_EXE_mbdc"))
        .args(["run", "--mpi"])
        .args(args);
    c
}

/// The hex8 bar model with a short duration.
fn bar() -> String {
    root().join("models/hex_bar.mbd").display().to_string()
}

/// Every `mesh/*.vtu` and `mesh.pvd` of `a` is byte for byte that of `b`.
fn same_mesh_files(a: &Path, b: &Path, what: &str) {
    let mut names: Vec<_> = std::fs::read_dir(a.join("mesh"))
        .expect("mesh/")
        .map(|e| e.unwrap().file_name())
        .collect();
    names.sort();
    assert!(names.len() > 2, "{what}: frames {names:?}");
    for n in &names {
        let (x, y) = (
            std::fs::read(a.join("mesh").join(n)).unwrap(),
            std::fs::read(b.join("mesh").join(n)).unwrap_or_default(),
        );
        assert!(x == y, "{what}: mesh/{} differs", n.to_string_lossy());
    }
    assert_eq!(
        std::fs::read(a.join("mesh.pvd")).unwrap(),
        std::fs::read(b.join("mesh.pvd")).unwrap(),
        "{what}: mesh.pvd"
    );
}

#[test]
fn explicit_on_1_2_4_ranks_writes_the_one_process_files_bitwise() {
    let dir = scratch("mpi-explicit");
    let one = dir.join("one");
    let out = command()
        .args([
            "run",
            "--interp",
            "-q",
            &bar(),
            "--duration",
            "1e-4",
            "--every",
            "40",
            "-o",
        ])
        .arg(&one)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for ranks in [1, 2, 4] {
        let o = dir.join(format!("ranks{ranks}"));
        let out = mpirun(
            ranks,
            &[&bar(), "--duration", "1e-4", "--every", "40", "-o", s(&o)],
        )
        .output()
        .expect("mpirun runs (Open MPI installed?)");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{ranks} ranks: {err}");
        assert!(
            err.contains(&format!("{ranks} ranks on MPI (Open MPI")),
            "{err}"
        );
        same_mesh_files(&one, &o, &format!("{ranks} ranks"));
        let sm = summary(&o);
        assert_eq!(sm["status"], "finished", "{sm}");
        if ranks > 1 {
            assert_eq!(sm["extra"]["ranks"], ranks as f64, "{sm}");
            assert!(
                sm["extra"]["rank0_exchange_bytes_per_step"]
                    .as_f64()
                    .unwrap()
                    > 0.0
            );
        }
    }
}

/// The pids of the processes whose environment carries `mark` and `OMPI_COMM_WORLD_RANK=rank`.
fn pids_of_rank(mark: &str, rank: usize) -> Vec<i32> {
    let mut out = Vec::new();
    for e in std::fs::read_dir("/proc").unwrap().flatten() {
        let Ok(pid) = e.file_name().to_string_lossy().parse::<i32>() else {
            continue;
        };
        let Ok(env) = std::fs::read(e.path().join("environ")) else {
            continue;
        };
        let vars: Vec<&[u8]> = env.split(|&b| b == 0).collect();
        let has = |v: &str| vars.contains(&v.as_bytes());
        if has(mark) && has(&format!("OMPI_COMM_WORLD_RANK={rank}")) {
            out.push(pid);
        }
    }
    out
}

#[test]
fn a_killed_rank_stops_the_run_and_its_checkpoints_restart_it() {
    let dir = scratch("mpi-kill");
    let o = dir.join("run");
    let mark = format!("MBDC_MPI_TEST={}", std::process::id());
    let args = [
        bar(),
        "--duration".into(),
        "2e-3".into(),
        "--every".into(),
        "50".into(),
        "--checkpoint-every".into(),
        "100".into(),
        "-o".into(),
        s(&o).into(),
    ];
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let mut child = mpirun(2, &args)
        // the ranks inherit mpirun's environment on this node: the mark finds them
        .env("MBDC_MPI_TEST", std::process::id().to_string())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("mpirun runs");
    let ck = |r: usize| o.join(format!("ranks/{r}/checkpoints"));
    let t0 = Instant::now();
    // wait for a checkpoint of every rank, then kill rank 1
    loop {
        let have = (0..2).all(|r| !mbdc_runtime::checkpoint::readable_steps(&ck(r)).is_empty());
        if have {
            break;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(120),
            "no checkpoint written"
        );
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run ended before the kill"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    let victims = pids_of_rank(&mark, 1);
    assert_eq!(victims.len(), 1, "rank 1's process: {victims:?}");
    // SAFETY: kill(2) on a pid of our own child's tree.
    unsafe {
        libc::kill(victims[0], libc::SIGKILL);
    }
    // the whole run stops, promptly
    let t1 = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        assert!(
            t1.elapsed() < Duration::from_secs(60),
            "the run hangs after a rank died"
        );
        std::thread::sleep(Duration::from_millis(50));
    };
    let mut err = String::new();
    std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut err).unwrap();
    assert!(!status.success(), "{err}");
    assert!(err.contains("rank 1") && err.contains("signal 9"), "{err}");
    // the checkpoints are whole, and the restart finishes the run as if never stopped
    for r in 0..2 {
        assert!(!mbdc_runtime::checkpoint::readable_steps(&ck(r)).is_empty());
    }
    let mut again: Vec<&str> = args.clone();
    again.push("--restart");
    let out = mpirun(2, &again).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "restart: {err}");
    assert!(err.contains("restarting from"), "{err}");
    assert_eq!(summary(&o)["status"], "finished");
    let straight = dir.join("straight");
    let out = command()
        .args([
            "run",
            "--interp",
            "-q",
            &bar(),
            "--duration",
            "2e-3",
            "--every",
            "50",
            "-o",
        ])
        .arg(&straight)
        .output()
        .unwrap();
    assert!(out.status.success());
    same_mesh_files(&straight, &o, "restarted after a killed rank");
}

/// The `displacement` array of a `.vtu` file.
fn displacements(vtu: &Path) -> Vec<f64> {
    let text = std::fs::read_to_string(vtu).expect("a .vtu");
    let start = text.find(r#"Name="displacement""#).expect("displacements");
    let body = &text[start..];
    let body = &body[body.find('>').unwrap() + 1..body.find("</DataArray>").unwrap()];
    body.split_whitespace()
        .map(|x| x.parse().expect("a number"))
        .collect()
}

/// FETI across ranks: the static hex8 cantilever with 8 subdomains on 2 and 4 ranks gives
/// the displacements of FETI in one process to round-off (10⁻¹⁰ relative: the interface
/// vectors are summed rank by rank, not subdomain by subdomain).
#[test]
fn feti_on_2_and_4_ranks_gives_the_one_process_displacements() {
    let dir = scratch("mpi-feti");
    let text = std::fs::read_to_string(root().join("models/cantilever_static.mbd"))
        .unwrap()
        .replace(
            "mesh_method static }",
            "mesh_method static; solver feti { subdomains 8; tolerance 1e-12 } }",
        );
    assert!(text.contains("solver feti"));
    let file = dir.join("cantilever_feti.mbd");
    std::fs::write(&file, text).unwrap();
    let one = dir.join("one");
    let out = command()
        .args(["run", "--interp", "-q", s(&file), "-o", s(&one)])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let last = |d: &Path| {
        let mut v: Vec<_> = std::fs::read_dir(d.join("mesh"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        v.sort();
        displacements(v.last().unwrap())
    };
    let want = last(&one);
    let scale = want.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    assert!(scale > 1e-4, "the tip deflects: {scale}");
    for ranks in [2, 4] {
        let o = dir.join(format!("ranks{ranks}"));
        let out = mpirun(ranks, &[s(&file), "-o", s(&o)]).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{ranks} ranks: {err}");
        let got = last(&o);
        assert_eq!(got.len(), want.len());
        let diff = got
            .iter()
            .zip(&want)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(
            diff <= 1e-10 * scale,
            "{ranks} ranks: {diff:e} of {scale:e}"
        );
    }
}
