//! The Exodus II output (`simulate { output { format exodus } }`, `results.exo`): a file
//! written by 2 partitions, read back by 1 and by 3, holds the run's values to the last bit;
//! a file cut in the middle of a frame reads up to its last complete frame; a manifest that
//! contradicts the file is refused naming it; and an independent reader (netCDF4's Python
//! package, on libnetcdf) opens it.
//!
//! References: for meshes the same run's `.vtu` frames (format `vtk`; ryu's shortest form
//! parses back to the same `f64`), for beams its `beams.csv`, for bodies and energies the
//! exodus run's own `bodies.csv` and `energy.csv` (the body displacement is `x − x₀` with
//! `x₀` the first frame's position, computed the same way). Tolerance: none — bitwise.

use std::path::{Path, PathBuf};

use mbdc_runtime::app::{run_config, Settings};
use mbdc_runtime::interp::Interp;
use mbdc_runtime::output::exodus::{self, ExodusFile};
use mbdc_runtime::output::RunMeta;
use mbdc_runtime::run_loop::{self, Frame, Observer};
use mbdc_runtime::scene::{OutputFormat, Scene};
use mbdc_tests::load_model;

struct Quiet;

impl Observer for Quiet {
    fn frame(&mut self, _: &Frame<'_>) {}
}

/// Run `model` for `duration` with a frame every `every` steps in `format`; the folder.
fn run(
    tag: &str,
    model: &str,
    duration: f64,
    every: u32,
    format: OutputFormat,
    parts: u32,
) -> PathBuf {
    let mut scene: Scene = load_model(&format!("{model}.mbd"));
    scene.simulate.output.format = format;
    scene.simulate.output.partitions = parts;
    let sys = Interp::new(&scene).expect("interpretable");
    let settings = Settings {
        duration: Some(duration),
        every: Some(every),
        ..Settings::default()
    };
    let cfg = run_config(&sys, &scene, &settings).expect("config");
    let dir = std::env::temp_dir().join(format!(
        "mbdc-exodus-{}-{tag}-{model}-{}",
        std::process::id(),
        format.name()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    let meta = RunMeta {
        model: model.into(),
        method: cfg.method.name().into(),
        step: cfg.step,
        duration: cfg.duration,
    };
    let (report, _) =
        run_loop::run_to_dir(&sys, &cfg, meta, &scene.simulate.output, &dir, &mut Quiet)
            .expect("output");
    assert!(report.finished, "{model}: {:?}", report.failure);
    dir
}

fn csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).expect("csv");
    let mut lines = text.lines();
    let head = lines
        .next()
        .expect("header")
        .split(',')
        .map(|s| s.trim().to_string())
        .collect();
    let rows = lines
        // (beams.csv names the beam in a column: NaN there)
        .map(|l| {
            l.split(',')
                .map(|x| x.trim().parse().unwrap_or(f64::NAN))
                .collect()
        })
        .collect();
    (head, rows)
}

/// A named `DataArray` of a `.vtu` file, flattened.
fn vtu_array(path: &Path, name: &str) -> Vec<f64> {
    let text = std::fs::read_to_string(path).expect("vtu");
    let tag = format!("Name=\"{name}\"");
    let at = text
        .find(&tag)
        .unwrap_or_else(|| panic!("{name} in {}", path.display()));
    let body = &text[at..];
    let body = &body[body.find('>').expect("tag end") + 1..];
    let body = &body[..body.find("</DataArray>").expect("array end")];
    body.split_whitespace()
        .map(|x| x.parse().expect("number"))
        .collect()
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// An element variable over the first `blocks` blocks, block after block.
fn elements(exo: &ExodusFile, name: &str, blocks: usize, frame: u64, parts: usize) -> Vec<f64> {
    (0..blocks)
        .flat_map(|b| exo.element(name, b, frame, parts).expect("element"))
        .collect()
}

/// Every frame's mesh values in the file, read with `parts` threads, against the `.vtu`s
/// (the meshes are the first `meshes` blocks).
fn check_mesh(exo: &ExodusFile, vtu_dir: &Path, parts: usize, plastic: bool, meshes: usize) {
    let nodes = exo.dimension("num_el_in_blk1").expect("a mesh block");
    assert!(nodes > 0);
    let mesh_nodes = vtu_array(&vtu_dir.join("mesh/mesh_000000.vtu"), "displacement").len() / 3;
    for frame in 0..exo.frames() {
        let vtu = vtu_dir.join(format!("mesh/mesh_{frame:06}.vtu"));
        for (what, names) in [
            (
                "displacement",
                ["displacement_x", "displacement_y", "displacement_z"],
            ),
            ("velocity", ["velocity_x", "velocity_y", "velocity_z"]),
        ] {
            let want = vtu_array(&vtu, what);
            for (c, n) in names.iter().enumerate() {
                let got = exo.nodal(n, frame, parts).expect("nodal");
                let want_c: Vec<f64> = want.iter().skip(c).step_by(3).copied().collect();
                assert_eq!(bits(&got[..mesh_nodes]), bits(&want_c), "{n} frame {frame}");
            }
        }
        let stress = vtu_array(&vtu, "stress");
        for (c, n) in [
            "stress_xx",
            "stress_yy",
            "stress_zz",
            "stress_yz",
            "stress_xz",
            "stress_xy",
        ]
        .iter()
        .enumerate()
        {
            let got = elements(exo, n, meshes, frame, parts);
            let want: Vec<f64> = stress.iter().skip(c).step_by(6).copied().collect();
            assert_eq!(bits(&got), bits(&want), "{n} frame {frame}");
        }
        let got = elements(exo, "von_mises", meshes, frame, parts);
        assert_eq!(bits(&got), bits(&vtu_array(&vtu, "von_mises")), "von_mises");
        if plastic {
            let got = elements(exo, "equivalent_plastic_strain", meshes, frame, parts);
            assert_eq!(
                bits(&got),
                bits(&vtu_array(&vtu, "equivalent_plastic_strain")),
                "equivalent_plastic_strain frame {frame}"
            );
        }
    }
}

/// Times and global energies against `energy.csv`.
fn check_energy(exo: &ExodusFile, dir: &Path) {
    let (head, rows) = csv(&dir.join("energy.csv"));
    let col = |n: &str| head.iter().position(|h| h == n).expect("column");
    assert_eq!(exo.frames() as usize, rows.len());
    let times = exo.times().expect("times");
    for (r, row) in rows.iter().enumerate() {
        assert_eq!(times[r].to_bits(), row[col("t")].to_bits(), "t frame {r}");
        let g = exo.globals(r as u64).expect("globals");
        assert_eq!(g[0].to_bits(), row[col("kinetic")].to_bits());
        assert_eq!(g[1].to_bits(), row[col("potential")].to_bits());
        assert_eq!(g[2].to_bits(), row[col("work")].to_bits());
    }
}

/// Body nodes (after the mesh nodes) against `bodies.csv`.
fn check_bodies(exo: &ExodusFile, dir: &Path, first_node: usize, parts: usize) {
    let (head, rows) = csv(&dir.join("bodies.csv"));
    let bodies = (head.len() - 1) / 13;
    let pairs = [
        ("displacement_x", 0),
        ("displacement_y", 1),
        ("displacement_z", 2),
        ("quaternion_w", 3),
        ("quaternion_x", 4),
        ("quaternion_y", 5),
        ("quaternion_z", 6),
        ("velocity_x", 7),
        ("velocity_y", 8),
        ("velocity_z", 9),
        ("angular_velocity_x", 10),
        ("angular_velocity_y", 11),
        ("angular_velocity_z", 12),
    ];
    let coords = exo.coordinates().expect("coordinates");
    for (r, row) in rows.iter().enumerate() {
        for (name, k) in pairs {
            let got = exo.nodal(name, r as u64, parts).expect("nodal");
            for b in 0..bodies {
                let x = row[1 + 13 * b + k];
                let want = if k < 3 {
                    x - rows[0][1 + 13 * b + k]
                } else {
                    x
                };
                assert_eq!(
                    got[first_node + b].to_bits(),
                    want.to_bits(),
                    "{name} body {b} frame {r}"
                );
                if r == 0 && k < 3 {
                    assert_eq!(coords[first_node + b][k].to_bits(), x.to_bits());
                }
            }
        }
    }
}

#[test]
fn a_mesh_run_written_by_2_partitions_reads_back_bitwise_with_1_and_3() {
    let (model, duration, every) = ("plastic_bar", 2e-3, 50);
    let vtk = run("a", model, duration, every, OutputFormat::Vtk, 0);
    let exo_dir = run("a", model, duration, every, OutputFormat::Exodus, 2);
    assert!(
        !exo_dir.join("mesh").exists(),
        "no per-frame files with exodus"
    );
    let exo = exodus::read(&exo_dir.join("results.exo")).expect("readable");
    let m = exo.manifest().expect("a manifest");
    assert_eq!(m.partitions, 2);
    assert_eq!(m.frames_complete, exo.frames());
    assert!(exo.frames() > 2);
    let blocks = exo.blocks().expect("blocks");
    assert_eq!(blocks[0].elem_type, "HEX8");
    // plastic_bar has two meshes, `bar` and `twin`.
    assert_eq!(blocks.len(), 2);
    assert_eq!(blocks[1].name, "twin");
    for parts in [1, 3] {
        check_mesh(&exo, &vtk, parts, true, 2);
    }
    check_energy(&exo, &exo_dir);
    let _ = std::fs::remove_dir_all(&vtk);
    let _ = std::fs::remove_dir_all(&exo_dir);
}

#[test]
fn beams_and_bodies_read_back_bitwise() {
    let (model, duration, every) = ("cantilever", 0.01, 10);
    let vtk = run("b", model, duration, every, OutputFormat::Vtk, 0);
    let exo_dir = run("b", model, duration, every, OutputFormat::Exodus, 2);
    let exo = exodus::read(&exo_dir.join("results.exo")).expect("readable");
    let blocks = exo.blocks().expect("blocks");
    assert_eq!(blocks[0].elem_type, "BAR2");
    let (head, rows) = csv(&vtk.join("beams.csv"));
    let elements = blocks[0].connectivity.len() / 2;
    let names = exo.element_names().expect("names");
    for parts in [1, 3] {
        for (r, chunk) in rows.chunks(elements).enumerate() {
            for name in names.iter() {
                let c = head.iter().position(|h| h == name).expect("beam column");
                let got = exo.element(name, 0, r as u64, parts).expect("element");
                let want: Vec<f64> = chunk.iter().map(|row| row[c]).collect();
                assert_eq!(bits(&got), bits(&want), "{name} frame {r}");
            }
        }
        check_bodies(&exo, &exo_dir, 0, parts);
    }
    check_energy(&exo, &exo_dir);
    let _ = std::fs::remove_dir_all(&vtk);
    let _ = std::fs::remove_dir_all(&exo_dir);
}

#[test]
fn a_file_cut_mid_frame_reads_up_to_its_last_complete_frame() {
    let dir = run("c", "double_pendulum_3d", 0.05, 5, OutputFormat::Exodus, 2);
    let path = dir.join("results.exo");
    let whole = exodus::read(&path).expect("readable");
    let m = whole.manifest().expect("manifest").clone();
    let n = whole.frames();
    assert!(n >= 4);
    let last = whole.nodal("velocity_x", 2, 1).expect("frame 2");
    let cut = dir.join("cut.exo");
    let bytes = std::fs::read(&path).expect("bytes");
    let keep = m.records_begin + 3 * m.record_size - m.record_size / 2;
    std::fs::write(&cut, &bytes[..keep as usize]).expect("write cut");
    let c = exodus::read(&cut).expect("a cut file still opens");
    assert_eq!(c.header_frames(), n);
    assert_eq!(c.frames(), 2, "frames 0 and 1 are complete, 2 is cut");
    assert_eq!(c.times().expect("times").len(), 2);
    assert!(c.nodal("velocity_x", 2, 1).is_err());
    assert_eq!(
        bits(&c.nodal("velocity_x", 1, 3).expect("frame 1")),
        bits(&whole.nodal("velocity_x", 1, 1).expect("frame 1"))
    );
    drop(last);
    // A manifest that puts a slice elsewhere is refused, naming the manifest.
    let mpath = dir.join("results.exo.manifest.json");
    let mut bad = m.clone();
    bad.slices[1].offset += 8;
    std::fs::write(&mpath, serde_json::to_string(&bad).unwrap()).unwrap();
    let e = exodus::read(&path).expect_err("refused").to_string();
    assert!(
        e.contains("manifest.json") && e.contains("not where"),
        "{e}"
    );
    let mut gap = m.clone();
    gap.slices
        .retain(|s| !(s.partition == 1 && s.variable == "vals_nod_var1"));
    std::fs::write(&mpath, serde_json::to_string(&gap).unwrap()).unwrap();
    let e = exodus::read(&path).expect_err("refused").to_string();
    assert!(e.contains("vals_nod_var1"), "{e}");
    // Not a netCDF file at all.
    std::fs::write(&cut, b"hello").unwrap();
    let e = exodus::read(&cut).expect_err("refused").to_string();
    assert!(e.contains("cut.exo"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The independent reader: `tests/python/check_exodus.py` with netCDF4 (libnetcdf).
/// Required when `CI` is set; skipped, saying so, when `MBDC_EXODUS_PYTHON` is not.
#[test]
fn an_independent_netcdf_reader_opens_the_file() {
    let python = match std::env::var_os("MBDC_EXODUS_PYTHON") {
        Some(p) => PathBuf::from(p),
        None => {
            assert!(
                std::env::var_os("CI").is_none(),
                "CI is set but MBDC_EXODUS_PYTHON is not: the independent Exodus reader must run in CI (see .ci/run)"
            );
            eprintln!("skipped: set MBDC_EXODUS_PYTHON to a python with netCDF4 to run the independent Exodus reader");
            return;
        }
    };
    let dir = run("d", "plastic_bar", 1e-3, 100, OutputFormat::Exodus, 2);
    let path = dir.join("results.exo");
    let exo = exodus::read(&path).expect("readable");
    let times = exo.times().expect("times");
    let frame = exo.frames() - 1;
    let ux = exo.nodal("displacement_x", frame, 1).expect("ux");
    let vm = exo.element("von_mises", 0, frame, 1).expect("vm");
    let nodes = exo.dimension("num_nodes").unwrap();
    let elements = exo.dimension("num_elem").unwrap();
    let blocks = exo.blocks().expect("blocks");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("python/check_exodus.py");
    let out = std::process::Command::new(&python)
        .arg(&script)
        .arg(&path)
        .args(["--nodes", &nodes.to_string()])
        .args(["--elements", &elements.to_string()])
        .args(["--frames", &exo.frames().to_string()])
        .args(["--elem-type", &blocks[0].elem_type])
        .args([
            "--connect-first",
            &blocks[0].connectivity[..blocks[0].nodes_per_element]
                .iter()
                .map(|n| (n + 1).to_string())
                .collect::<Vec<_>>()
                .join(","),
        ])
        .args(["--time", &format!("{frame}:{:e}", times[frame as usize])])
        .args(["--nodal", &format!("displacement_x:{frame}:7:{:e}", ux[7])])
        .args(["--element", &format!("von_mises:1:{frame}:3:{:e}", vm[3])])
        .output()
        .expect("python runs");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    eprintln!("{text}");
    assert!(out.status.success(), "check_exodus.py failed:\n{text}");
    let _ = std::fs::remove_dir_all(&dir);
}
