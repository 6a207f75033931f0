//! Reading `results.exo` back ([`ExodusFile`]): the mesh, the names, the times and any
//! frame's values, each variable read in `p′` slices on `p′` threads with positional reads
//! — independent of the number of partitions that wrote it. The manifest, when present, is
//! checked against the header (same record layout, slices that tile every variable).
//! A file cut short (a killed run, a full disk) reads up to its last complete frame.

use std::collections::BTreeMap;
use std::fs::File;
use std::path::{Path, PathBuf};

use super::exodus_manifest::{Manifest, MANIFEST_VERSION};
use super::netcdf3::{read_at, AttrValue, NcType, Schema};
use super::{OutputError, OutputErrorKind};

/// An element block of the file.
#[derive(Clone, Debug, PartialEq)]
pub struct Block {
    /// Its name (`eb_names`).
    pub name: String,
    /// Its Exodus element type (`BAR2`, `HEX8`, ..., `SPHERE`).
    pub elem_type: String,
    /// Nodes per element.
    pub nodes_per_element: usize,
    /// Node indices (0-based), element after element.
    pub connectivity: Vec<u32>,
}

/// An Exodus II file opened for reading.
#[derive(Debug)]
pub struct ExodusFile {
    path: PathBuf,
    file: File,
    schema: Schema,
    numrecs: u64,
    frames: u64,
    manifest: Option<Manifest>,
}

fn bad(path: &Path, msg: impl Into<String>) -> OutputError {
    OutputError::io(
        OutputErrorKind::Read,
        path,
        std::io::Error::new(std::io::ErrorKind::InvalidData, msg.into()),
    )
}

impl ExodusFile {
    /// Open a file and, if `FILE.manifest.json` is beside it, check it against the header.
    ///
    /// # Errors
    /// [`OutputError::Io`] naming the file when it cannot be read, is not a netCDF-3 64-bit
    /// offset file, or its manifest contradicts it.
    pub fn open(path: &Path) -> Result<ExodusFile, OutputError> {
        let file = File::open(path).map_err(|e| OutputError::io(OutputErrorKind::Read, path, e))?;
        let len = file
            .metadata()
            .map_err(|e| OutputError::io(OutputErrorKind::Read, path, e))?
            .len();
        let mut want = len.min(1 << 20);
        let (schema, numrecs) = loop {
            let mut head = vec![0u8; want as usize];
            read_at(&file, &mut head, 0)
                .map_err(|e| OutputError::io(OutputErrorKind::Read, path, e))?;
            match Schema::decode(&head) {
                Ok(x) => break x,
                Err(m) if m.contains("ends early") && want < len.min(1 << 28) => {
                    want = (want * 4).min(len);
                }
                Err(m) => return Err(bad(path, m)),
            }
        };
        let numrecs = u64::from(numrecs);
        let frames = len
            .saturating_sub(schema.records_begin)
            .checked_div(schema.record_size)
            .map_or(numrecs, |whole| numrecs.min(whole));
        let mut f = ExodusFile {
            path: path.to_path_buf(),
            file,
            schema,
            numrecs,
            frames,
            manifest: None,
        };
        let mpath = PathBuf::from(format!("{}.manifest.json", path.display()));
        if mpath.exists() {
            let text = std::fs::read_to_string(&mpath)
                .map_err(|e| OutputError::io(OutputErrorKind::Read, &mpath, e))?;
            let m: Manifest = serde_json::from_str(&text).map_err(|e| OutputError::Json {
                path: mpath.clone(),
                message: e.to_string(),
            })?;
            f.check_manifest(&m).map_err(|msg| bad(&mpath, msg))?;
            f.manifest = Some(m);
        }
        Ok(f)
    }

    fn check_manifest(&self, m: &Manifest) -> Result<(), String> {
        let s = &self.schema;
        if m.format_version != MANIFEST_VERSION {
            return Err(format!(
                "manifest format {} (this mbdc reads {MANIFEST_VERSION})",
                m.format_version
            ));
        }
        if m.record_size != s.record_size || m.records_begin != s.records_begin {
            return Err(format!(
                "it says frames of {} bytes from byte {}, the file's header {} from {}",
                m.record_size, m.records_begin, s.record_size, s.records_begin
            ));
        }
        let mut cover: BTreeMap<usize, Vec<(u64, u64)>> = BTreeMap::new();
        for sl in &m.slices {
            let v = s
                .var_id(&sl.variable)
                .filter(|&v| s.is_record(v))
                .ok_or_else(|| format!("no record variable `{}` in the file", sl.variable))?;
            let size = s.vars[v].ty.size();
            if sl.start + sl.count > s.values(v)
                || sl.offset != s.offset(v, 0, sl.start)
                || sl.length != sl.count * size
            {
                return Err(format!(
                    "partition {}'s slice of `{}` (values {}..{} at byte {}) is not where the header puts it",
                    sl.partition,
                    sl.variable,
                    sl.start,
                    sl.start + sl.count,
                    sl.offset
                ));
            }
            cover.entry(v).or_default().push((sl.start, sl.count));
        }
        for v in (0..s.vars.len()).filter(|&v| s.is_record(v)) {
            let mut sl = cover.remove(&v).unwrap_or_default();
            sl.sort_unstable();
            let mut at = 0;
            for (start, count) in sl {
                if start != at {
                    return Err(format!(
                        "the slices of `{}` do not tile it (a gap or an overlap at value {at})",
                        s.vars[v].name
                    ));
                }
                at += count;
            }
            if at != s.values(v) {
                return Err(format!(
                    "the slices of `{}` cover {at} of its {} values",
                    s.vars[v].name,
                    s.values(v)
                ));
            }
        }
        Ok(())
    }

    /// The file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Complete frames: the header's record count, less any record the file is too short
    /// to hold.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// The header's record count (more than [`ExodusFile::frames`] when the file was cut).
    pub fn header_frames(&self) -> u64 {
        self.numrecs
    }

    /// The manifest, when the file has one.
    pub fn manifest(&self) -> Option<&Manifest> {
        self.manifest.as_ref()
    }

    /// A global attribute's text or numbers, for inspection.
    pub fn attribute(&self, name: &str) -> Option<String> {
        self.schema
            .attrs
            .iter()
            .find(|a| a.name == name)
            .map(|a| match &a.value {
                AttrValue::Text(t) => t.clone(),
                AttrValue::Int(v) => format!("{v:?}"),
                AttrValue::Float(v) => format!("{v:?}"),
                AttrValue::Double(v) => format!("{v:?}"),
            })
    }

    /// A dimension's length (`None` if absent).
    pub fn dimension(&self, name: &str) -> Option<u64> {
        self.schema.dim_id(name).map(|d| self.schema.dims[d].len)
    }

    fn var(&self, name: &str) -> Result<usize, OutputError> {
        self.schema
            .var_id(name)
            .ok_or_else(|| bad(&self.path, format!("it has no variable `{name}`")))
    }

    fn bytes(&self, v: usize, rec: u64, start: u64, count: u64) -> Result<Vec<u8>, OutputError> {
        if self.schema.is_record(v) && rec >= self.frames {
            return Err(bad(
                &self.path,
                format!("frame {rec} asked, the file has {} complete", self.frames),
            ));
        }
        let size = self.schema.vars[v].ty.size();
        let mut b = vec![0u8; (count * size) as usize];
        read_at(&self.file, &mut b, self.schema.offset(v, rec, start))
            .map_err(|e| OutputError::io(OutputErrorKind::Read, &self.path, e))?;
        Ok(b)
    }

    fn ints(&self, name: &str) -> Result<Vec<i32>, OutputError> {
        let v = self.var(name)?;
        if self.schema.vars[v].ty != NcType::Int {
            return Err(bad(
                &self.path,
                format!("`{name}` is not an integer variable"),
            ));
        }
        Ok(self
            .bytes(v, 0, 0, self.schema.values(v))?
            .chunks_exact(4)
            .map(|c| i32::from_be_bytes([c[0], c[1], c[2], c[3]]))
            .collect())
    }

    fn names(&self, name: &str) -> Result<Vec<String>, OutputError> {
        let Some(v) = self.schema.var_id(name) else {
            return Ok(Vec::new());
        };
        let width = self.schema.vars[v]
            .dims
            .last()
            .map_or(1, |&d| self.schema.dims[d].len.max(1)) as usize;
        Ok(self
            .bytes(v, 0, 0, self.schema.values(v))?
            .chunks(width)
            .map(|c| {
                let end = c.iter().position(|&x| x == 0).unwrap_or(c.len());
                String::from_utf8_lossy(&c[..end]).into_owned()
            })
            .collect())
    }

    /// The nodal variables' names.
    pub fn nodal_names(&self) -> Result<Vec<String>, OutputError> {
        self.names("name_nod_var")
    }

    /// The element variables' names.
    pub fn element_names(&self) -> Result<Vec<String>, OutputError> {
        self.names("name_elem_var")
    }

    /// The global variables' names.
    pub fn global_names(&self) -> Result<Vec<String>, OutputError> {
        self.names("name_glo_var")
    }

    /// The element blocks, in file order.
    pub fn blocks(&self) -> Result<Vec<Block>, OutputError> {
        let n = self.dimension("num_el_blk").unwrap_or(0) as usize;
        let names = self.names("eb_names")?;
        let mut out = Vec::with_capacity(n);
        for k in 1..=n {
            let cname = format!("connect{k}");
            let v = self.var(&cname)?;
            let elem_type = self.schema.vars[v]
                .attrs
                .iter()
                .find(|a| a.name == "elem_type")
                .and_then(|a| match &a.value {
                    AttrValue::Text(t) => Some(t.clone()),
                    _ => None,
                })
                .unwrap_or_default();
            let npe = self.dimension(&format!("num_nod_per_el{k}")).unwrap_or(1) as usize;
            let connectivity = self
                .ints(&cname)?
                .into_iter()
                .map(|i| (i.max(1) - 1) as u32)
                .collect();
            out.push(Block {
                name: names.get(k - 1).cloned().unwrap_or_default(),
                elem_type,
                nodes_per_element: npe,
                connectivity,
            });
        }
        Ok(out)
    }

    /// The nodes' coordinates.
    pub fn coordinates(&self) -> Result<Vec<[f64; 3]>, OutputError> {
        let n = self.dimension("num_nodes").unwrap_or(0) as usize;
        let mut out = vec![[0.0; 3]; n];
        for (c, name) in ["coordx", "coordy", "coordz"].iter().enumerate() {
            let v = self.var(name)?;
            for (i, x) in self.doubles(v, 0, 1)?.into_iter().enumerate() {
                out[i][c] = x;
            }
        }
        Ok(out)
    }

    /// The time of every complete frame.
    pub fn times(&self) -> Result<Vec<f64>, OutputError> {
        let v = self.var("time_whole")?;
        (0..self.frames)
            .map(|r| Ok(self.doubles(v, r, 1)?[0]))
            .collect()
    }

    /// The global variables of a frame.
    pub fn globals(&self, frame: u64) -> Result<Vec<f64>, OutputError> {
        let v = self.var("vals_glo_var")?;
        self.doubles(v, frame, 1)
    }

    /// A nodal variable's values at a frame, read in `parts` slices on as many threads.
    pub fn nodal(&self, name: &str, frame: u64, parts: usize) -> Result<Vec<f64>, OutputError> {
        let i = self
            .nodal_names()?
            .iter()
            .position(|n| n == name)
            .ok_or_else(|| bad(&self.path, format!("it has no nodal variable `{name}`")))?;
        let v = self.var(&format!("vals_nod_var{}", i + 1))?;
        self.doubles(v, frame, parts)
    }

    /// Whether block `block` (0-based) has the element variable `name` (the truth table:
    /// a mesh block has the meshes' variables, a beam block the beams', the bodies' none).
    pub fn has_element_variable(&self, name: &str, block: usize) -> bool {
        self.element_names()
            .ok()
            .and_then(|names| names.iter().position(|n| n == name))
            .is_some_and(|i| {
                self.schema
                    .var_id(&format!("vals_elem_var{}eb{}", i + 1, block + 1))
                    .is_some()
            })
    }

    /// An element variable's values in block `block` (0-based) at a frame, read in `parts`
    /// slices on as many threads.
    pub fn element(
        &self,
        name: &str,
        block: usize,
        frame: u64,
        parts: usize,
    ) -> Result<Vec<f64>, OutputError> {
        let i = self
            .element_names()?
            .iter()
            .position(|n| n == name)
            .ok_or_else(|| bad(&self.path, format!("it has no element variable `{name}`")))?;
        let v = self.var(&format!("vals_elem_var{}eb{}", i + 1, block + 1))?;
        self.doubles(v, frame, parts)
    }

    /// Every value of a `double` variable at a record, in `parts` slices read concurrently.
    fn doubles(&self, v: usize, rec: u64, parts: usize) -> Result<Vec<f64>, OutputError> {
        if self.schema.vars[v].ty != NcType::Double {
            return Err(bad(
                &self.path,
                format!("`{}` is not a double variable", self.schema.vars[v].name),
            ));
        }
        let n = self.schema.values(v);
        let p = parts.max(1) as u64;
        let slices: Vec<(u64, u64)> = (0..p).map(|k| (n * k / p, n * (k + 1) / p)).collect();
        let read = |&(a, b): &(u64, u64)| -> Result<Vec<f64>, OutputError> {
            Ok(self
                .bytes(v, rec, a, b - a)?
                .chunks_exact(8)
                .map(|c| f64::from_be_bytes(c.try_into().unwrap_or([0; 8])))
                .collect())
        };
        let pieces: Vec<Result<Vec<f64>, OutputError>> = if p == 1 {
            vec![read(&slices[0])]
        } else {
            std::thread::scope(|s| {
                let hs: Vec<_> = slices.iter().map(|sl| s.spawn(move || read(sl))).collect();
                hs.into_iter()
                    .map(|h| {
                        h.join()
                            .unwrap_or_else(|_| Err(bad(&self.path, "a reader thread panicked")))
                    })
                    .collect()
            })
        };
        let mut out = Vec::with_capacity(n as usize);
        for piece in pieces {
            out.extend(piece?);
        }
        Ok(out)
    }
}
