//! The scene's tabulated reference: `reference { table "file.csv" }`, a CSV file with the
//! columns of `bodies.csv`, interpolated in time — cubic Hermite with the velocities where
//! the table has them (`vx vy vz` for positions, `wx wy wz` for orientations), linear
//! otherwise.

use std::path::{Path, PathBuf};

use crate::contract::scene::Scene;

use super::error::ReferenceError;
use super::reference::{RefBody, RefSolution, SAME_TIME};
use super::track::{dot4, qnormalize, Track};

/// `reference { table "file.csv" }`: a table with the columns of `bodies.csv`.
#[derive(Clone, Debug)]
pub struct Table {
    path: PathBuf,
    t: Vec<f64>,
    /// Per scene body: (has position, has velocity, has orientation, has angular velocity).
    has: Vec<[bool; 4]>,
    track: Track,
}

/// Largest reference table read: 1 GiB (the `bodies.csv` of a long run of a small scene).
pub const MAX_TABLE_BYTES: u64 = 1 << 30;

/// Opens a reference table, refusing what is not a regular file (a character device such
/// as `/dev/zero` would be read forever, a FIFO blocks until a writer comes, a directory has
/// no rows) and a file larger than [`MAX_TABLE_BYTES`]. The reader stops at one byte past
/// the limit, so a file that grows while it is read is caught too (see [`past_limit`]).
fn open_table(path: &Path) -> Result<std::io::Take<std::fs::File>, ReferenceError> {
    use std::io::Read;
    let err = |message: String| ReferenceError::Table {
        path: path.to_path_buf(),
        message,
    };
    let meta = std::fs::metadata(path).map_err(|e| err(e.to_string()))?;
    if !meta.is_file() {
        return Err(err(format!(
            "{} is not a regular file; a reference table must be a CSV file",
            file_kind(&meta.file_type())
        )));
    }
    if meta.len() > MAX_TABLE_BYTES {
        return Err(err(too_large(meta.len())));
    }
    let f = std::fs::File::open(path).map_err(|e| err(e.to_string()))?;
    Ok(f.take(MAX_TABLE_BYTES + 1))
}

fn too_large(bytes: u64) -> String {
    format!(
        "the file has {bytes} bytes, more than the {} MiB mbdc reads as a reference table",
        MAX_TABLE_BYTES >> 20
    )
}

/// Whether a reader of [`open_table`] went past the limit (the file grew while read).
fn past_limit<R: std::io::Read>(r: &csv::Reader<R>) -> bool {
    r.position().byte() > MAX_TABLE_BYTES
}

/// What a file that is not a regular file is, for messages ("a character device", "a FIFO
/// (named pipe)", …). Also what the compiler's input reader says of a model or mesh file.
pub fn file_kind(t: &std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if t.is_dir() {
        "a directory"
    } else {
        "a special file"
    }
}

/// The header and the selected columns of a CSV file.
///
/// Every row must have the header's number of columns; the one exception is a last line cut
/// short (no line end after it, as a table still being written leaves it), where the data
/// end. Any other ragged row is refused with its line number: skipping or truncating there
/// would silently drop the rest of the reference.
///
/// Returns the columns and the line of each row.
fn read_columns(
    path: &Path,
    wanted: &[String],
) -> Result<(Vec<Vec<f64>>, Vec<u64>), ReferenceError> {
    let err = |message: String| ReferenceError::Table {
        path: path.to_path_buf(),
        message,
    };
    let mut r = csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(true)
        .from_reader(open_table(path)?);
    let head: Vec<String> = r
        .headers()
        .map_err(|e| err(e.to_string()))?
        .iter()
        .map(str::to_string)
        .collect();
    let idx: Vec<usize> = wanted
        .iter()
        .map(|w| {
            head.iter()
                .position(|h| h == w)
                .ok_or_else(|| err(format!("no column `{w}`")))
        })
        .collect::<Result<_, _>>()?;
    let mut data = vec![Vec::new(); wanted.len()];
    let mut lines = Vec::new();
    let ends_with_newline = ends_with_newline(path).map_err(|e| err(e.to_string()))?;
    let mut rec = csv::StringRecord::new();
    let mut short: Option<(u64, usize)> = None; // (line, columns) of a row cut short
    while r.read_record(&mut rec).map_err(|e| err(e.to_string()))? {
        let line = rec.position().map_or(0, csv::Position::line);
        if let Some((at, found)) = short {
            // the short row was not the last line: a ragged row, not a cut-off end
            return Err(ragged(&err, at, head.len(), found));
        }
        if rec.len() > head.len() || (rec.len() < head.len() && ends_with_newline) {
            return Err(ragged(&err, line, head.len(), rec.len()));
        }
        if rec.len() < head.len() {
            // possibly the incomplete last line of a table being written: the data end
            // here if nothing follows
            short = Some((line, rec.len()));
            continue;
        }
        for (d, &i) in data.iter_mut().zip(&idx) {
            let field = rec.get(i).unwrap_or("").trim();
            d.push(
                field
                    .parse::<f64>()
                    .map_err(|_| err(format!("line {line}: `{field}` is not a number")))?,
            );
        }
        lines.push(line);
    }
    if past_limit(&r) {
        return Err(err(too_large(r.position().byte())));
    }
    Ok((data, lines))
}

/// The error for a row whose column count differs from the header's.
fn ragged(
    err: &impl Fn(String) -> ReferenceError,
    line: u64,
    expected: usize,
    found: usize,
) -> ReferenceError {
    err(format!(
        "line {line}: expected {expected} columns (as in the header), found {found}"
    ))
}

/// Whether the file's last byte is a line end (an empty file counts as ended).
fn ends_with_newline(path: &Path) -> std::io::Result<bool> {
    use std::io::{Read, Seek, SeekFrom};
    let mut f = std::fs::File::open(path)?;
    if f.metadata()?.len() == 0 {
        return Ok(true);
    }
    f.seek(SeekFrom::End(-1))?;
    let mut last = [0u8; 1];
    f.read_exact(&mut last)?;
    Ok(matches!(last[0], b'\n' | b'\r'))
}

/// The column names of a CSV file.
fn read_header(path: &Path) -> Result<Vec<String>, ReferenceError> {
    let err = |message: String| ReferenceError::Table {
        path: path.to_path_buf(),
        message,
    };
    let mut r = csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(true)
        .from_reader(open_table(path)?);
    let h = r.headers().map_err(|e| err(e.to_string()))?.clone();
    if past_limit(&r) {
        return Err(err(too_large(r.position().byte())));
    }
    if h.is_empty() {
        return Err(err("the file has no header line".into()));
    }
    Ok(h.iter().map(str::to_string).collect())
}

impl Table {
    /// Read the table for `scene` (bodies matched by name; other columns are ignored).
    ///
    /// # Errors
    /// If the file cannot be read, has no `t` column, no column of any scene body, or its
    /// times do not increase.
    pub fn read(path: &Path, scene: &Scene) -> Result<Table, ReferenceError> {
        let err = |message: &str| ReferenceError::Table {
            path: path.to_path_buf(),
            message: message.to_string(),
        };
        let head = read_header(path)?;
        if !head.iter().any(|h| h == "t") {
            return Err(err("the table has no `t` column"));
        }
        let n = scene.bodies.len();
        let groups: [&[&str]; 4] = [
            &["x", "y", "z"],
            &["vx", "vy", "vz"],
            &["qw", "qx", "qy", "qz"],
            &["wx", "wy", "wz"],
        ];
        let mut has = vec![[false; 4]; n];
        let mut names = vec!["t".to_string()];
        let mut cols: Vec<(usize, usize, usize, usize)> = Vec::new(); // (body, group, comp, column)
        for (b, body) in scene.bodies.iter().enumerate() {
            for (g, comps) in groups.iter().enumerate() {
                let want: Vec<String> =
                    comps.iter().map(|c| format!("{}.{c}", body.name)).collect();
                if want.iter().all(|w| head.contains(w)) {
                    has[b][g] = true;
                    for (c, w) in want.into_iter().enumerate() {
                        cols.push((b, g, c, names.len()));
                        names.push(w);
                    }
                }
            }
        }
        if has.iter().all(|h| !h[0] && !h[2]) {
            return Err(err(
                "the table has no position (`BODY.x .y .z`) or orientation (`BODY.qw .qx .qy .qz`) columns of the scene's bodies",
            ));
        }
        let (data, lines) = read_columns(path, &names)?;
        let t = data[0].clone();
        if t.len() < 2 {
            return Err(err("the table needs at least two rows with increasing `t`"));
        }
        if let Some(k) = (1..t.len()).find(|&k| t[k] <= t[k - 1]) {
            return Err(ReferenceError::Table {
                path: path.to_path_buf(),
                message: format!(
                    "line {}: t = {} does not increase (the row before has t = {}); the times must increase",
                    lines[k],
                    t[k],
                    t[k - 1]
                ),
            });
        }
        let mut track = Track::new(n);
        track.t = t.clone();
        track.r = vec![[0.0; 3]; t.len() * n];
        track.v = vec![[0.0; 3]; t.len() * n];
        track.q = vec![[1.0, 0.0, 0.0, 0.0]; t.len() * n];
        track.w = vec![[0.0; 3]; t.len() * n];
        for &(b, g, comp, col) in &cols {
            for (f, x) in data[col].iter().enumerate() {
                let k = f * n + b;
                match g {
                    0 => track.r[k][comp] = *x,
                    1 => track.v[k][comp] = *x,
                    2 => track.q[k][comp] = *x,
                    _ => track.w[k][comp] = *x,
                }
            }
        }
        for q in &mut track.q {
            *q = qnormalize(*q).unwrap_or(*q);
        }
        Ok(Table {
            path: path.to_path_buf(),
            t,
            has,
            track,
        })
    }
}

impl RefSolution for Table {
    fn at(&self, t: f64, out: &mut [RefBody]) -> Result<(), ReferenceError> {
        let (first, last) = (self.t[0], self.t[self.t.len() - 1]);
        let tol = SAME_TIME * t.abs().max(1.0);
        if t < first - tol || t > last + tol {
            return Err(ReferenceError::NotCovered(format!(
                "{}: the reference table covers t = {first} … {last} s, not t = {t} s",
                self.path.display()
            )));
        }
        let i = self
            .t
            .partition_point(|x| *x <= t)
            .clamp(1, self.t.len() - 1)
            - 1;
        let n = self.track.bodies;
        let (t0, t1) = (self.t[i], self.t[i + 1]);
        let s = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
        for (b, o) in out.iter_mut().enumerate() {
            let [pos, vel, ori, ang] = self.has[b];
            *o = RefBody::default();
            if !pos && !ori {
                continue;
            }
            let (rh, qh) = self.track.interpolate(i, t, b);
            let (k0, k1) = (i * n + b, (i + 1) * n + b);
            if pos {
                o.r = Some(if vel {
                    rh
                } else {
                    std::array::from_fn(|c| {
                        (1.0 - s) * self.track.r[k0][c] + s * self.track.r[k1][c]
                    })
                });
            }
            if ori {
                o.q = Some(if ang {
                    qh
                } else {
                    let q0 = self.track.q[k0];
                    let mut q1 = self.track.q[k1];
                    if dot4(&q0, &q1) < 0.0 {
                        q1 = q1.map(|x| -x);
                    }
                    let q: [f64; 4] = std::array::from_fn(|c| (1.0 - s) * q0[c] + s * q1[c]);
                    qnormalize(q).unwrap_or(q0)
                });
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::error_measures::rotation_angle;

    pub(super) fn scene_with(bodies: &[&str]) -> Scene {
        Scene {
            name: "t".into(),
            gravity: None,
            bodies: bodies
                .iter()
                .map(|n| crate::contract::scene::Body {
                    name: n.to_string(),
                    mass: 1.0,
                    inertia: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
                    position: [0.0; 3],
                    orientation: [1.0, 0.0, 0.0, 0.0],
                    velocity: [0.0; 3],
                    angular_velocity: [0.0; 3],
                    origin: Default::default(),
                })
                .collect(),
            joints: vec![],
            forces: vec![],
            beams: vec![],
            meshes: vec![],
            contacts: vec![],
            simulate: Default::default(),
            reference: None,
            params: vec![],
        }
    }

    #[test]
    fn a_table_is_interpolated_and_checked() {
        let dir = tempfile::tempdir().expect("temp dir");
        let p = dir.path().join("ref.csv");
        // b: a position with velocities (Hermite) and an orientation without (linear)
        let mut text = String::from("t,b.x,b.y,b.z,b.vx,b.vy,b.vz,b.qw,b.qx,b.qy,b.qz,other\n");
        for i in 0..=10 {
            let t = i as f64 * 0.1;
            let a = t / 2.0;
            text.push_str(&format!(
                "{t},{},{},0,{},{},0,{},0,0,{},7\n",
                t.cos(),
                t.sin(),
                -t.sin(),
                t.cos(),
                a.cos(),
                a.sin()
            ));
        }
        text.push_str("1.1,0,0"); // an incomplete last line ends the data
        std::fs::write(&p, text).expect("write");
        let tab = Table::read(&p, &scene_with(&["b", "c"])).expect("table");
        let mut out = vec![RefBody::default(); 2];
        tab.at(0.55, &mut out).expect("covered");
        let r = out[0].r.expect("position");
        assert!((r[0] - 0.55f64.cos()).abs() < 1e-6, "{r:?}");
        let exact = [0.275f64.cos(), 0.0, 0.0, 0.275f64.sin()];
        assert!(rotation_angle(&out[0].q.expect("orientation"), &exact) < 1e-3);
        assert_eq!(out[1], RefBody::default(), "no columns of body c");
        assert!(matches!(
            tab.at(1.05, &mut out),
            Err(ReferenceError::NotCovered(_))
        ));
        assert!(Table::read(&p, &scene_with(&["z"])).is_err());
    }

    /// Times that do not increase are refused at the row that goes back.
    #[test]
    fn times_that_do_not_increase_are_refused_at_their_line() {
        let dir = tempfile::tempdir().expect("temp dir");
        let p = dir.path().join("ref.csv");
        std::fs::write(
            &p,
            "t,b.x,b.y,b.z\n0,0,0,0\n0.1,0,0,0\n0.1,0,0,0\n0.3,0,0,0\n",
        )
        .expect("write");
        let e = Table::read(&p, &scene_with(&["b"])).expect_err("refused");
        assert!(
            e.to_string()
                .ends_with("line 4: t = 0.1 does not increase (the row before has t = 0.1); the times must increase"),
            "{e}"
        );
    }

    /// A ragged row in the middle used to end the data there silently, so the table no
    /// longer covered the run and every error column of `mbdc sweep` came out blank.
    #[test]
    fn a_ragged_row_is_refused_with_its_line_and_counts() {
        let dir = tempfile::tempdir().expect("temp dir");
        let p = dir.path().join("ref.csv");
        let rows = |bad: &str, tail: &str| {
            let mut text = String::from("t,b.x,b.y,b.z\n");
            for i in 0..6 {
                if i == 3 {
                    text.push_str(bad);
                } else {
                    text.push_str(&format!("{},{i},0,0\n", i as f64 * 0.1));
                }
            }
            text.push_str(tail);
            text
        };
        let message = |text: String| {
            std::fs::write(&p, text).expect("write");
            match Table::read(&p, &scene_with(&["b"])) {
                Err(ReferenceError::Table { message, .. }) => message,
                other => panic!("expected a table error, got {other:?}"),
            }
        };
        // header is line 1, row i is line i + 2: the bad row is line 5
        let short = message(rows("0.3,3,0\n", ""));
        assert!(
            short.contains("line 5") && short.contains("expected 4") && short.contains("found 3"),
            "{short}"
        );
        let long = message(rows("0.3,3,0,0,9\n", ""));
        assert!(
            long.contains("line 5") && long.contains("expected 4") && long.contains("found 5"),
            "{long}"
        );
        // a short last line that ends in a line end is a ragged row too
        let last = message(rows("0.3,3,0,0\n", "0.6,6\n"));
        assert!(
            last.contains("line 8") && last.contains("found 2"),
            "{last}"
        );
        // but a last line cut off mid-row (no line end) is the end of a table being written
        std::fs::write(&p, rows("0.3,3,0,0\n", "0.6,6")).expect("write");
        let tab = Table::read(&p, &scene_with(&["b"])).expect("cut-off last line accepted");
        assert_eq!(tab.t.len(), 6);
    }

    /// `reference { table "/dev/zero" }` used to read zeros until the process aborted for
    /// lack of memory; a FIFO blocked forever. Special files are refused by their kind,
    /// before they are opened, with the file named.
    #[test]
    fn special_files_are_refused_by_their_kind() {
        let message = |p: &Path| match Table::read(p, &scene_with(&["b"])) {
            Err(e @ ReferenceError::Table { .. }) => e.to_string(),
            other => panic!("expected a table error, got {other:?}"),
        };
        let dir = tempfile::tempdir().expect("temp dir");
        let m = message(dir.path());
        assert!(m.contains("a directory is not a regular file"), "{m}");
        assert!(m.starts_with(&dir.path().display().to_string()), "{m}");
        #[cfg(unix)]
        {
            let m = message(Path::new("/dev/zero"));
            assert!(
                m.starts_with("/dev/zero: a character device is not a regular file"),
                "{m}"
            );
            let fifo = dir.path().join("fifo.csv");
            let made = std::process::Command::new("mkfifo").arg(&fifo).status();
            if made.is_ok_and(|s| s.success()) {
                let m = message(&fifo);
                assert!(
                    m.contains("a FIFO (named pipe) is not a regular file"),
                    "{m}"
                );
            }
        }
    }

    #[test]
    fn the_size_limit_is_named() {
        let m = too_large(MAX_TABLE_BYTES + 1);
        assert!(m.contains("more than the 1024 MiB"), "{m}");
    }
}

/// Property tests of the table reader: on mutated and arbitrary files it never panics, and
/// every error names the file, and the line when it is about a row.
#[cfg(test)]
mod props {
    use super::*;
    use proptest::prelude::*;
    use proptest::test_runner::{Config, TestRunner};
    use std::sync::atomic::{AtomicUsize, Ordering};

    fn scene() -> Scene {
        let mut s = tests::scene_with(&["b", "c"]);
        s.name = "props".into();
        s
    }

    /// A valid table: positions with velocities, orientations without, an extra column.
    fn seed() -> String {
        let mut text = String::from("t,b.x,b.y,b.z,b.vx,b.vy,b.vz,b.qw,b.qx,b.qy,b.qz,other\n");
        for i in 0..6 {
            let t = f64::from(i) * 0.1;
            text.push_str(&format!(
                "{t},{},{},0,{},{},0,{},0,0,{},7\n",
                t.cos(),
                t.sin(),
                -t.sin(),
                t.cos(),
                (t / 2.0).cos(),
                (t / 2.0).sin()
            ));
        }
        text
    }

    /// Words a mutation writes in place of a field.
    const WORDS: &[&str] = &[
        "", "0", "-1", "1e308", "1e309", "nan", "inf", "-inf", "x", "t", "b.x", "b.qw", "\"",
        "\"a,b\"", "0.3", "0.25", " 1 ", "1,2", "\r",
    ];

    #[derive(Clone, Debug)]
    enum Edit {
        Field {
            line: usize,
            field: usize,
            word: usize,
        },
        Delete(usize),
        Duplicate(usize),
        Swap(usize, usize),
        Truncate(usize),
        Insert(usize, String),
        /// Bytes that are not UTF-8 at a byte offset.
        Bytes(usize),
    }

    fn edit() -> impl Strategy<Value = Edit> {
        prop_oneof![
            4 => (any::<usize>(), any::<usize>(), 0..WORDS.len())
                .prop_map(|(line, field, word)| Edit::Field { line, field, word }),
            1 => any::<usize>().prop_map(Edit::Delete),
            1 => any::<usize>().prop_map(Edit::Duplicate),
            1 => (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Edit::Swap(a, b)),
            1 => any::<usize>().prop_map(Edit::Truncate),
            1 => (any::<usize>(), "[0-9,.\"a-z \\-]{0,30}").prop_map(|(at, s)| Edit::Insert(at, s)),
            1 => any::<usize>().prop_map(Edit::Bytes),
        ]
    }

    fn apply(bytes: &[u8], e: &Edit) -> Vec<u8> {
        let text = String::from_utf8_lossy(bytes).into_owned();
        let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
        let n = lines.len().max(1);
        match e {
            Edit::Field { line, field, word } => {
                if let Some(l) = lines.get_mut(line % n) {
                    let mut f: Vec<&str> = l.split(',').collect();
                    let k = field % f.len();
                    f[k] = WORDS[*word];
                    *l = f.join(",");
                }
            }
            Edit::Delete(i) => {
                if !lines.is_empty() {
                    lines.remove(i % n);
                }
            }
            Edit::Duplicate(i) => {
                if let Some(l) = lines.get(i % n).cloned() {
                    lines.insert(i % n, l);
                }
            }
            Edit::Swap(a, b) => {
                if !lines.is_empty() {
                    lines.swap(a % n, b % n);
                }
            }
            Edit::Truncate(at) => return bytes[..at % (bytes.len() + 1)].to_vec(),
            Edit::Insert(at, s) => lines.insert(at % (lines.len() + 1), s.clone()),
            Edit::Bytes(at) => {
                let mut b = bytes.to_vec();
                b.splice(at % (b.len() + 1).., [0xff, 0xfe]);
                return b;
            }
        }
        let mut out = lines.join("\n");
        out.push('\n');
        out.into_bytes()
    }

    /// Errors about the whole file rather than one row: no line to name.
    const WHOLE_FILE: &[&str] = &[
        "no column `",
        "the table has no",
        "the table needs at least two rows",
        "the file has no header line",
    ];

    /// The property: no panic; an error names the file, and a row's error its line. Returns
    /// whether the table was read.
    fn check(path: &Path, bytes: &[u8]) -> Result<bool, TestCaseError> {
        std::fs::write(path, bytes).expect("write");
        match Table::read(path, &scene()) {
            Ok(_) => Ok(true),
            Err(ReferenceError::Table { path: p, message }) => {
                prop_assert_eq!(&p, path);
                prop_assert!(
                    message.contains("line") || WHOLE_FILE.iter().any(|w| message.starts_with(w)),
                    "no line in: {}",
                    message
                );
                Ok(false)
            }
            Err(e) => Err(TestCaseError::fail(format!("not a table error: {e}"))),
        }
    }

    #[test]
    fn mutated_tables_never_panic_and_errors_name_the_file_and_line() {
        static READ: AtomicUsize = AtomicUsize::new(0);
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("ref.csv");
        assert_eq!(check(&path, seed().as_bytes()).ok(), Some(true));
        let mut runner = TestRunner::new(Config {
            cases: 1000,
            failure_persistence: None,
            ..Config::default()
        });
        runner
            .run(&proptest::collection::vec(edit(), 1..4), |edits| {
                let bytes = edits.iter().fold(seed().into_bytes(), |b, e| apply(&b, e));
                if check(&path, &bytes)? {
                    READ.fetch_add(1, Ordering::Relaxed);
                }
                Ok(())
            })
            .unwrap();
        let read = READ.load(Ordering::Relaxed);
        assert!(read > 10, "only {read} of 1000 mutated tables were read");
    }

    #[test]
    fn arbitrary_files_never_panic() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("ref.csv");
        let mut runner = TestRunner::new(Config {
            cases: 500,
            failure_persistence: None,
            ..Config::default()
        });
        let head = prop_oneof![
            Just("t,b.x,b.y,b.z\n"),
            Just("t,b.qw,b.qx,b.qy,b.qz\n"),
            Just("")
        ];
        runner
            .run(
                &(head, proptest::collection::vec(any::<u8>(), 0..200)),
                |(h, body)| {
                    let mut bytes = h.as_bytes().to_vec();
                    bytes.extend(body);
                    check(&path, &bytes)?;
                    Ok(())
                },
            )
            .unwrap();
    }
}
