//! End-to-end: `mbdc view` and `mbdc run --view` write a self-contained replay page of a run,
//! and the page renders in a real browser (headless Chromium, installed by `.ci/run`): the
//! first frame is drawn with the bodies where the page says it projects them, the scrub
//! position moves them, and no script error is logged.

mod common;
use common::{mbdc, root, s, scratch};

use std::path::{Path, PathBuf};
use std::process::Command;

/// Run a model (interpreter, short) into `out`; panics with the stderr if it does not finish
/// as `ok` says.
fn run(model: &str, out: &Path, extra: &[&str], ok: bool) -> String {
    let mut args = vec!["run", "--interp", "-q", "-o", s(out)];
    args.extend_from_slice(extra);
    let m = root().join(model);
    args.push(s(&m));
    let o = mbdc(&args);
    let stderr = String::from_utf8_lossy(&o.stderr).to_string();
    assert_eq!(o.status.success(), ok, "{model}: {stderr}");
    stderr
}

/// The page's JSON data block.
fn page_data(page: &Path) -> serde_json::Value {
    let html = std::fs::read_to_string(page).unwrap();
    let open = r#"<script id="mbdc-view-data" type="application/json">"#;
    let start = html.find(open).expect("data block") + open.len();
    let end = start + html[start..].find("</script>").unwrap();
    serde_json::from_str(&html[start..end].replace("<\\/", "</")).expect("valid JSON")
}

/// `mbdc view DIR --no-open`, which must succeed; returns its stdout.
fn view(dir: &Path) -> String {
    let o = mbdc(&["view", s(dir), "--no-open"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout).to_string()
}

#[test]
fn the_page_holds_the_scene_and_every_frame() {
    let dir = scratch("view-dp");
    let out = dir.join("out");
    run(
        "models/double_pendulum_3d.mbd",
        &out,
        &["--duration", "0.5", "--every", "10"],
        true,
    );
    let said = view(&out);
    assert!(
        said.contains("view.html") && said.contains("51 frames"),
        "{said}"
    );
    let d = page_data(&out.join("view.html"));
    assert_eq!(d["status"], "finished");
    assert_eq!(d["bodies"].as_array().unwrap().len(), 2);
    // rod1: 1 m rod of radius 1 cm along its z axis — the box of its inertia is 1 m by
    // √3 cm, drawn no thinner than 2 % of its length
    let size = &d["bodies"][0]["shape"]["size"];
    assert!((size[2].as_f64().unwrap() - 1.0).abs() < 1e-9, "{size}");
    let thick = (0.01 * 3f64.sqrt()).max(0.02);
    assert!((size[0].as_f64().unwrap() - thick).abs() < 1e-9, "{size}");
    assert_eq!(d["joints"].as_array().unwrap().len(), 2);
    assert_eq!(d["up"], serde_json::json!([0.0, 0.0, 1.0]));
    let f = &d["frames"];
    assert_eq!(f["count"], 51);
    assert_eq!(f["shown_every"], 1);
    assert_eq!(f["floats"], 1 + 7 * 2);
    let names: Vec<&str> = d["curves"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["name"].as_str().unwrap())
        .collect();
    assert!(
        names.contains(&"kinetic") && names.contains(&"largest joint violation"),
        "{names:?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The page's frames, decoded.
fn page_frames(page: &Path) -> Vec<f32> {
    use base64::Engine as _;
    let html = std::fs::read_to_string(page).unwrap();
    let open = r#"<script id="mbdc-view-frames" type="application/octet-stream">"#;
    let start = html.find(open).expect("frames block") + open.len();
    let end = start + html[start..].find("</script>").unwrap();
    let bytes = base64::engine::general_purpose::STANDARD
        .decode(html[start..end].trim())
        .unwrap();
    bytes
        .chunks(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect()
}

#[test]
fn a_long_run_is_decimated_and_keeps_its_last_frame() {
    let dir = scratch("view-long");
    let out = dir.join("out");
    // 20 001 frames of 1 + 2·7 floats: 1.2 MB, over a budget of 1 MiB (17 476 frames;
    // under the cap of 20 000) → every 2nd frame
    run(
        "models/double_pendulum_3d.mbd",
        &out,
        &["--duration", "20", "--every", "1"],
        true,
    );
    let o = mbdc(&["view", s(&out), "--no-open", "--max-mb", "1"]);
    assert!(o.status.success());
    let d = page_data(&out.join("view.html"));
    let (lines, last_t) = common::last_frame(&out);
    let run_frames = lines - 1;
    assert_eq!(
        d["frames"]["run_frames"].as_u64().unwrap() as usize,
        run_frames
    );
    let floats = d["frames"]["floats"].as_u64().unwrap() as usize;
    let every = d["frames"]["shown_every"].as_u64().unwrap() as usize;
    let budget = (1usize << 20) / (4 * floats);
    assert_eq!(every, run_frames.div_ceil(budget), "{}", d["frames"]);
    assert_eq!(every, 2);
    let count = d["frames"]["count"].as_u64().unwrap() as usize;
    let frames = page_frames(&out.join("view.html"));
    assert_eq!(frames.len(), count * floats);
    // every k-th frame from the first, and the last: where the run ended
    assert_eq!(frames[0], 0.0);
    assert_eq!(frames[floats], (every as f64 * 0.001) as f32);
    assert_eq!(frames[(count - 1) * floats], last_t as f32);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_folders_are_refused_with_the_reason() {
    let dir = scratch("view-bad");
    let o = mbdc(&["view", s(&dir.join("nowhere")), "--no-open"]);
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("no such folder"), "{e}");
    let o = mbdc(&["view", s(&dir), "--no-open"]);
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("summary.json"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn beams_and_meshes_are_in_the_page() {
    let dir = scratch("view-structural");
    let beam = dir.join("beam");
    run(
        "models/cantilever.mbd",
        &beam,
        &["--duration", "0.01"],
        true,
    );
    view(&beam);
    let d = page_data(&beam.join("view.html"));
    let b = &d["beams"][0];
    let nodes = b["nodes"].as_array().unwrap().len();
    assert!(nodes >= 3, "{b}");
    assert!(b["radius"].as_f64().unwrap() > 0.0, "{b}");
    // beam nodes are slots drawn by their beam
    let none = d["bodies"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|x| x["shape"]["kind"] == "none")
        .count();
    assert_eq!(none, nodes);
    // the beam's section quantities are in the frames: N1, |M|, M1 per element, after the
    // bodies' poses (no meshes here)
    assert_eq!(b["elements"].as_u64().unwrap() as usize, nodes - 1, "{b}");
    for key in ["n_max", "m_max", "t_max"] {
        assert!(b[key].as_f64().unwrap() >= 0.0, "{b}");
    }
    assert!(
        b["m_max"].as_f64().unwrap() > 0.0,
        "the clamped beam bends: {b}"
    );
    let slots = d["bodies"].as_array().unwrap().len();
    let floats = d["frames"]["floats"].as_u64().unwrap() as usize;
    assert_eq!(floats, 1 + 7 * slots + 3 * (nodes - 1));
    let frames = page_frames(&beam.join("view.html"));
    let count = d["frames"]["count"].as_u64().unwrap() as usize;
    assert_eq!(frames.len(), count * floats);
    let last = &frames[(count - 1) * floats..];
    // the last frame's row of element 0 in beams.csv
    let text = std::fs::read_to_string(beam.join("beams.csv")).unwrap();
    let name = b["name"].as_str().unwrap();
    let row: Vec<f64> = text
        .lines()
        .rev()
        .find(|l| l.split(',').nth(1) == Some(name) && l.split(',').nth(2) == Some("0"))
        .expect("a row of element 0")
        .split(',')
        .enumerate()
        .filter(|(i, _)| *i != 1)
        .map(|(_, x)| x.parse().unwrap())
        .collect();
    // row: t, element, s, N1, N2, N3, M1, M2, M3, ...
    assert_eq!(last[0], row[0] as f32, "the last frames agree in time");
    let (n1, m1, m2, m3) = (row[3], row[6], row[7], row[8]);
    let at = 1 + 7 * slots;
    assert_eq!(
        &last[at..at + 3],
        &[n1 as f32, (m2 * m2 + m3 * m3).sqrt() as f32, m1 as f32],
        "element 0 of the last frame"
    );

    let mesh = dir.join("mesh");
    run("models/hex_bar.mbd", &mesh, &["--duration", "0.0005"], true);
    view(&mesh);
    let d = page_data(&mesh.join("view.html"));
    let m = &d["meshes"][0];
    assert!(!m["triangles"].as_array().unwrap().is_empty(), "{m}");
    let points = m["points"].as_array().unwrap().len() / 3;
    let floats = d["frames"]["floats"].as_u64().unwrap() as usize;
    let slots = d["bodies"].as_array().unwrap().len();
    assert_eq!(floats, 1 + 7 * slots + 4 * points);
    let _ = std::fs::remove_dir_all(&dir);
}

/// `run --view` after a failure: the page says why and marks what the failure names.
#[test]
fn a_failed_run_is_replayed_with_its_report() {
    let dir = scratch("view-failed");
    let out = dir.join("out");
    let stderr = run(
        "models/hard/stiff_spring.mbd",
        &out,
        &["--method", "staggered", "--force", "--view"],
        false,
    );
    assert!(stderr.contains("stopped at"), "{stderr}");
    let d = page_data(&out.join("view.html"));
    assert_eq!(d["status"], "failed");
    assert!(
        d["report"].as_str().unwrap().contains("energy balance"),
        "{d}"
    );
    let b = d["highlight"]["body"].as_u64().expect("a body is named") as usize;
    assert_eq!(d["bodies"][b]["name"], "mass1");
    let _ = std::fs::remove_dir_all(&dir);
}

// ---- in a real browser ----

/// Headless Chromium, or `None` when it is not installed and neither `CI` nor
/// `MBDC_BROWSER_TESTS` (set by `.ci/run`) is set: there it must be.
fn chromium() -> Option<PathBuf> {
    for name in ["chromium", "chromium-browser", "google-chrome"] {
        if let Ok(o) = Command::new("sh")
            .arg("-c")
            .arg(format!("command -v {name}"))
            .output()
        {
            let p = String::from_utf8_lossy(&o.stdout).trim().to_string();
            if o.status.success() && !p.is_empty() {
                return Some(PathBuf::from(p));
            }
        }
    }
    assert!(
        std::env::var_os("CI").is_none() && std::env::var_os("MBDC_BROWSER_TESTS").is_none(),
        "Chromium is not installed: .ci/run installs it (apt-get install chromium)"
    );
    eprintln!("skipped: no Chromium on this machine (apt-get install chromium)");
    None
}

/// Chromium on the page at `#hash`: with `--dump-dom` (returns the DOM) or `--screenshot`.
fn browse(chrome: &Path, page: &Path, hash: &str, shot: Option<&Path>) -> String {
    let url = format!("file://{}#{hash}", page.canonicalize().unwrap().display());
    let profile = page.with_file_name(format!("chrome-profile-{}", hash.len()));
    let mut c = Command::new(chrome);
    c.args([
        "--headless",
        "--no-sandbox",
        "--disable-gpu-sandbox",
        "--use-angle=swiftshader",
        "--enable-unsafe-swiftshader",
        "--hide-scrollbars",
        "--window-size=1000,800",
        "--virtual-time-budget=5000",
    ])
    .arg(format!("--user-data-dir={}", profile.display()));
    match shot {
        Some(p) => c.arg(format!("--screenshot={}", p.display())),
        None => c.arg("--dump-dom"),
    };
    let o = c.arg(&url).output().expect("chromium runs");
    assert!(
        o.status.success(),
        "chromium: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).to_string()
}

/// The page's test report (`<pre id="mbdc-test">`), from its DOM.
fn test_report(dom: &str) -> serde_json::Value {
    let open = "<pre id=\"mbdc-test\"";
    let at = dom.find(open).expect("the page's test report");
    let start = at + dom[at..].find('>').unwrap() + 1;
    let end = start + dom[start..].find("</pre>").unwrap();
    let text = dom[start..end]
        .replace("&quot;", "\"")
        .replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&amp;", "&");
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{e}: {text}"))
}

/// RGB pixels of a PNG file, with its width.
fn pixels(png_path: &Path) -> (Vec<[u8; 3]>, usize) {
    let decoder = png::Decoder::new(std::io::BufReader::new(
        std::fs::File::open(png_path).unwrap(),
    ));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    let step = info.color_type.samples();
    let px = buf[..info.buffer_size()]
        .chunks(step)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    (px, info.width as usize)
}

fn hue(c: [u8; 3]) -> Option<f64> {
    let [r, g, b] = c.map(|x| x as f64 / 255.0);
    let (max, min) = (r.max(g).max(b), r.min(g).min(b));
    if max - min < 0.08 {
        return None; // grey: no hue
    }
    let h = if max == r {
        (g - b) / (max - min)
    } else if max == g {
        2.0 + (b - r) / (max - min)
    } else {
        4.0 + (r - g) / (max - min)
    };
    Some((h * 60.0).rem_euclid(360.0))
}

fn parse_colour(hex: &str) -> [u8; 3] {
    let v = u32::from_str_radix(hex.trim_start_matches('#'), 16).unwrap();
    [(v >> 16) as u8, (v >> 8) as u8, v as u8]
}

/// Whether a pixel of the body's hue (±20°, lighting changes brightness, not hue) lies
/// within 6 pixels of `at`.
fn body_colour_near(px: &[[u8; 3]], width: usize, at: [f64; 2], colour: [u8; 3]) -> bool {
    let want = hue(colour).expect("bodies have coloured palettes");
    let (x0, y0) = (at[0].round() as i64, at[1].round() as i64);
    let height = (px.len() / width) as i64;
    for y in (y0 - 6).max(0)..(y0 + 7).min(height) {
        for x in (x0 - 6).max(0)..(x0 + 7).min(width as i64) {
            if let Some(h) = hue(px[(y as usize) * width + x as usize]) {
                let d = (h - want).abs();
                if d.min(360.0 - d) < 20.0 {
                    return true;
                }
            }
        }
    }
    false
}

#[test]
fn the_page_renders_in_a_browser_and_the_scrub_moves_the_bodies() {
    let Some(chrome) = chromium() else { return };
    let dir = scratch("view-browser");
    let out = dir.join("out");
    run(
        "models/double_pendulum_3d.mbd",
        &out,
        &["--duration", "1", "--every", "10"],
        true,
    );
    view(&out);
    let page = out.join("view.html");
    let mut shots = Vec::new();
    for (i, t) in ["0", "0.9"].iter().enumerate() {
        let hash = format!("t={t}");
        let report = test_report(&browse(&chrome, &page, &hash, None));
        assert_eq!(report["ready"], true, "{report}");
        assert_eq!(report["errors"], serde_json::json!([]), "{report}");
        let shot = dir.join(format!("shot{i}.png"));
        browse(&chrome, &page, &hash, Some(&shot));
        let (px, width) = pixels(&shot);
        // the screenshot is the page's size (device pixel ratio 1)
        assert_eq!(width as u64, report["width"].as_u64().unwrap(), "{report}");
        for b in report["bodies"].as_array().unwrap() {
            let at = [b["px"][0].as_f64().unwrap(), b["px"][1].as_f64().unwrap()];
            assert!(
                body_colour_near(&px, width, at, parse_colour(b["color"].as_str().unwrap())),
                "t = {t}: no pixel of {}'s colour near {at:?}",
                b["name"]
            );
        }
        shots.push((px, report));
    }
    // the bodies moved between the two times: on screen and in the page's projection
    let differ = shots[0]
        .0
        .iter()
        .zip(&shots[1].0)
        .filter(|(a, b)| a != b)
        .count();
    assert!(differ > 500, "{differ} pixels differ");
    assert_ne!(shots[0].1["bodies"], shots[1].1["bodies"]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn structural_and_failed_pages_run_without_script_errors() {
    let Some(chrome) = chromium() else { return };
    let dir = scratch("view-browser-structural");
    for (model, extra, ok) in [
        ("models/cantilever.mbd", &["--duration", "0.01"][..], true),
        ("models/hex_bar.mbd", &["--duration", "0.0005"][..], true),
        (
            "models/hard/stiff_spring.mbd",
            &["--method", "staggered", "--force"][..],
            false,
        ),
    ] {
        let out = dir.join(model.replace('/', "_"));
        run(model, &out, extra, ok);
        view(&out);
        let dom = browse(&chrome, &out.join("view.html"), "t=0", None);
        let report = test_report(&dom);
        assert_eq!(report["ready"], true, "{model}: {report}");
        assert_eq!(report["errors"], serde_json::json!([]), "{model}: {report}");
        if !ok {
            assert!(
                dom.contains("STOPPED"),
                "{model}: the report is not on the page"
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Every model in models/ that runs gets a page: a short run of each (interpreted, 0.2 ms),
/// then `mbdc view`. A run refused before its first step writes no folder and is skipped;
/// any folder a run wrote, finished or stopped, must give a page.
#[test]
fn every_model_that_runs_gets_a_page() {
    let dir = scratch("view-every-model");
    let mut models = Vec::new();
    for sub in ["models", "models/hard", "models/bench"] {
        for e in std::fs::read_dir(root().join(sub)).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|x| x == "mbd") {
                models.push(p);
            }
        }
    }
    models.sort();
    assert!(models.len() > 30, "{} models", models.len());
    let mut viewed = 0;
    for m in &models {
        let name = m.file_stem().unwrap().to_string_lossy().to_string();
        let out = dir.join(&name);
        let o = mbdc(&[
            "run",
            "--interp",
            "-q",
            "--duration",
            "0.0002",
            "-o",
            s(&out),
            s(m),
        ]);
        if !out.join("summary.json").exists() {
            assert!(
                !o.status.success(),
                "{name}: no folder from a run that succeeded"
            );
            continue;
        }
        view(&out);
        let d = page_data(&out.join("view.html"));
        assert!(d["frames"]["count"].as_u64().unwrap() >= 1, "{name}");
        viewed += 1;
        let _ = std::fs::remove_dir_all(&out);
    }
    assert!(
        viewed * 10 >= models.len() * 9,
        "only {viewed} of {} models ran",
        models.len()
    );
    let _ = std::fs::remove_dir_all(&dir);
}
