//! Reading columns of the output CSV files (`bodies.csv`, `energy.csv`,
//! `constraints.csv`; see `mbdc_runtime::output` for their columns).
//!
//! Files are streamed: only the requested columns are kept. A last line that is
//! incomplete (a run killed while writing) ends the data without an error; the number of
//! rows read says how far it got.

use std::collections::HashMap;
use std::path::Path;

use super::PlotError;

/// Selected columns of a CSV file.
#[derive(Clone, Debug, Default)]
pub struct Columns {
    /// One vector per selected column (in request order), all of the same length.
    pub data: Vec<Vec<f64>>,
    /// Name → position in `data` (a lookup per column must not search them all: the
    /// constraint plot looks up every joint's column).
    index: HashMap<String, usize>,
}

impl Columns {
    /// The column with this name.
    pub fn get(&self, name: &str) -> Option<&[f64]> {
        self.index.get(name).map(|&i| self.data[i].as_slice())
    }

    /// Number of rows read.
    pub fn rows(&self) -> usize {
        self.data.first().map_or(0, Vec::len)
    }
}

fn csv_err(path: &Path, e: impl std::fmt::Display) -> PlotError {
    PlotError::Csv {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

fn reader(path: &Path) -> Result<csv::Reader<std::fs::File>, PlotError> {
    let file = std::fs::File::open(path).map_err(|source| PlotError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    Ok(csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(true)
        .from_reader(file))
}

/// The column names of a CSV file.
///
/// # Errors
/// If the file cannot be read or has no header line.
pub fn header(path: &Path) -> Result<Vec<String>, PlotError> {
    let mut r = reader(path)?;
    let h = r.headers().map_err(|e| csv_err(path, e))?;
    if h.is_empty() {
        return Err(csv_err(path, "the file has no header line"));
    }
    Ok(h.iter().map(str::to_string).collect())
}

/// The position of each column name in a header, for lookups in constant time: a
/// `bodies.csv` has 13 columns per body, so a search of the header per body is quadratic
/// (a 100 000-body run has 1.3 million columns). The first of repeated names wins.
pub fn column_index(head: &[String]) -> HashMap<&str, usize> {
    let mut index = HashMap::with_capacity(head.len());
    for (i, h) in head.iter().enumerate() {
        index.entry(h.as_str()).or_insert(i);
    }
    index
}

/// Call `f` with the values of the columns `idx` (indices into the header) for every
/// complete row. Returns the number of rows.
///
/// # Errors
/// If the file cannot be read, or a field of a complete row is not a number.
pub fn for_each_row(
    path: &Path,
    idx: &[usize],
    mut f: impl FnMut(&[f64]),
) -> Result<usize, PlotError> {
    let mut r = reader(path)?;
    let width = r.headers().map_err(|e| csv_err(path, e))?.len();
    let mut rec = csv::StringRecord::new();
    let mut vals = vec![0.0; idx.len()];
    let mut rows = 0usize;
    loop {
        match r.read_record(&mut rec) {
            Ok(false) => break,
            Ok(true) => {}
            Err(e) => return Err(csv_err(path, e)),
        }
        if rec.len() != width {
            // an incomplete last line: the data end here
            break;
        }
        for (v, &i) in vals.iter_mut().zip(idx) {
            let field = rec.get(i).unwrap_or("").trim();
            *v = field.parse::<f64>().map_err(|_| {
                csv_err(
                    path,
                    format!(
                        "line {}: `{field}` is not a number",
                        rec.position().map_or(0, |p| p.line())
                    ),
                )
            })?;
        }
        f(&vals);
        rows += 1;
    }
    Ok(rows)
}

/// Read the named columns of a CSV file.
///
/// # Errors
/// If the file cannot be read, or a column is missing (the message lists close names).
pub fn read(path: &Path, names: &[String]) -> Result<Columns, PlotError> {
    let head = header(path)?;
    let index = column_index(&head);
    let mut idx = Vec::with_capacity(names.len());
    for n in names {
        match index.get(n.as_str()) {
            Some(&i) => idx.push(i),
            None => {
                return Err(PlotError::Request(format!(
                    "{}: no column `{n}`{}",
                    path.display(),
                    suggest(n, &head)
                )))
            }
        }
    }
    let mut data = vec![Vec::new(); names.len()];
    for_each_row(path, &idx, |vals| {
        for (d, v) in data.iter_mut().zip(vals) {
            d.push(*v);
        }
    })?;
    let mut index = HashMap::with_capacity(names.len());
    for (i, n) in names.iter().enumerate() {
        index.entry(n.clone()).or_insert(i);
    }
    Ok(Columns { data, index })
}

/// `; did you mean `a`, `b`?` for names close to `name`, or a list of what exists.
pub fn suggest(name: &str, candidates: &[String]) -> String {
    let lower = name.to_lowercase();
    let mut close: Vec<&String> = candidates
        .iter()
        .filter(|c| {
            let c = c.to_lowercase();
            c.contains(&lower)
                || (c.len() >= 3 && lower.contains(&c))
                || edit_distance(&c, &lower) <= 2
        })
        .collect();
    close.truncate(6);
    if !close.is_empty() {
        let list: Vec<String> = close.iter().map(|c| format!("`{c}`")).collect();
        return format!("; did you mean {}?", list.join(", "));
    }
    let mut list: Vec<String> = candidates
        .iter()
        .take(12)
        .map(|c| format!("`{c}`"))
        .collect();
    if candidates.len() > 12 {
        list.push(format!("… ({} in all)", candidates.len()));
    }
    format!("; the columns are {}", list.join(", "))
}

fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1; b.len() + 1];
        for (j, cb) in b.iter().enumerate() {
            let sub = prev[j] + usize::from(ca != *cb);
            cur[j + 1] = sub.min(prev[j + 1] + 1).min(cur[j] + 1);
        }
        prev = cur;
    }
    prev[b.len()]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_selected_columns_and_stops_at_a_partial_line() {
        let dir = std::env::temp_dir().join(format!("mbdc-plot-data-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let p = dir.join("e.csv");
        std::fs::write(&p, "t,kinetic,total\n0,1,2\n0.5,NaN,inf\n1,3").expect("write");
        let c = read(&p, &["t".into(), "total".into()]).expect("reads");
        assert_eq!(c.rows(), 2);
        assert_eq!(c.get("t"), Some(&[0.0, 0.5][..]));
        assert!(c.get("total").expect("col")[1].is_infinite());
        let e = read(&p, &["totl".into()]).expect_err("missing");
        assert!(e.to_string().contains("did you mean `total`"), "{e}");
        std::fs::write(&p, "t,x\n0,abc\n").expect("write");
        let e = read(&p, &["x".into()]).expect_err("bad number");
        assert!(e.to_string().contains("`abc` is not a number"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
