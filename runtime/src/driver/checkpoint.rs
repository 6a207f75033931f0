//! Checkpoints: the whole state of a run at an output frame, written atomically so that a
//! run can be continued (`mbdc run --restart`) as if it had never stopped, bit for bit.
//!
//! # A checkpoint file
//!
//! `OUTDIR/checkpoints/checkpoint_<step>.mbdck`:
//!
//! ```text
//! "MBDC-CHECKPOINT\n"          16 bytes
//! format version               u32 LE (FORMAT)
//! identity                     u32 LE length + UTF-8 JSON (Identity: mbdc version, model,
//!                              method, step, output interval, sizes, scene hash)
//! step, time                   u64 LE, f64 LE (the frame's)
//! output position              u64 LE length + bytes (the writers' position: file lengths,
//!                              series frames, statistics; persist encoding)
//! run state                    u64 LE length + bytes (the run loop, the method, the watches)
//! CRC-32                       u32 LE of every byte before it
//! ```
//!
//! Written to a temporary file, synced, renamed into place, and the folder synced: a run
//! killed at any moment leaves either the previous checkpoints or the new one whole. The
//! newest `keep` are kept. Reading checks the magic, the format, the length of every part
//! and the CRC; a checkpoint that fails any is refused with what failed, and
//! [`latest`] then says so and falls back on the one before.

use std::io::Write as _;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

const MAGIC: &[u8; 16] = b"MBDC-CHECKPOINT\n";
/// The file format's version.
pub const FORMAT: u32 = 1;
/// The folder of the checkpoints in an output folder.
pub const FOLDER: &str = "checkpoints";
const EXT: &str = "mbdck";

/// What a checkpoint belongs to: a restart is refused when any of it differs from the run
/// that would continue it (except the duration, which a restart may extend).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Identity {
    /// The mbdc version that wrote it.
    pub mbdc: String,
    /// The model's name.
    pub model: String,
    /// The method.
    pub method: String,
    /// The step, s (as the bits of the f64, in hex: exact).
    pub step: String,
    /// Output every this many steps.
    pub every: u32,
    /// Bodies (beam nodes included).
    pub bodies: usize,
    /// Constraint rows.
    pub rows: usize,
    /// FNV-1a hash of the scene (its JSON, duration and checkpoint options left out), hex.
    pub scene: String,
    /// The output format the run writes (`csv`, `vtk`, `exodus`): a run continues the
    /// files of its format, so a restart in another format is refused. Empty in
    /// checkpoints written before the field existed (then not compared).
    #[serde(default)]
    pub format: String,
}

impl Identity {
    /// The identity of a run of `scene` with `method`, `step` and `every`, writing `format`.
    pub fn of(
        scene: &crate::contract::scene::Scene,
        layout: &crate::contract::system::Layout,
        method: &str,
        step: f64,
        every: u32,
        format: crate::contract::scene::OutputFormat,
    ) -> Identity {
        let mut s = scene.clone();
        s.simulate.duration = 0.0;
        // When checkpoints are written is not what the run computes.
        s.simulate.output.checkpoint = crate::contract::scene::CheckpointOptions::NONE;
        let json = serde_json::to_string(&s).unwrap_or_default();
        let mut hasher = crate::contract::fnv::Fnv::new();
        hasher.write(json.as_bytes());
        let h = hasher.finish();
        Identity {
            mbdc: env!("CARGO_PKG_VERSION").into(),
            model: scene.name.clone(),
            method: method.into(),
            step: format!("{:016x}", step.to_bits()),
            every,
            bodies: layout.bodies(),
            rows: layout.rows,
            scene: format!("{h:016x}"),
            format: format.name().into(),
        }
    }

    /// What differs between `self` (the checkpoint's) and `now` (the run's), in words;
    /// `None` if nothing does.
    pub fn difference(&self, now: &Identity) -> Option<String> {
        let step = |s: &str| {
            u64::from_str_radix(s, 16)
                .map(|b| format!("{:e} s", f64::from_bits(b)))
                .unwrap_or_else(|_| s.into())
        };
        let mut d = Vec::new();
        if self.mbdc != now.mbdc {
            d.push(format!(
                "written by mbdc {}, this is mbdc {}",
                self.mbdc, now.mbdc
            ));
        }
        if self.model != now.model {
            d.push(format!("model `{}`, not `{}`", self.model, now.model));
        }
        if self.method != now.method {
            d.push(format!("method {}, not {}", self.method, now.method));
        }
        if self.step != now.step {
            d.push(format!(
                "step {}, not {}",
                step(&self.step),
                step(&now.step)
            ));
        }
        if self.every != now.every {
            d.push(format!(
                "output every {} steps, not {}",
                self.every, now.every
            ));
        }
        if self.bodies != now.bodies || self.rows != now.rows {
            d.push(format!(
                "{} bodies and {} constraint rows, not {} and {}",
                self.bodies, self.rows, now.bodies, now.rows
            ));
        }
        if !self.format.is_empty() && self.format != now.format {
            d.push(format!(
                "output format {}, not {} (a run continues the files it wrote)",
                self.format, now.format
            ));
        }
        if d.is_empty() && self.scene != now.scene {
            d.push("the scene's numbers differ (a parameter, property or option changed since it was written)".into());
        }
        (!d.is_empty()).then(|| d.join("; "))
    }
}

/// When to write checkpoints and where.
#[derive(Clone, Debug, PartialEq)]
pub struct CheckpointSpec {
    /// The folder (`OUTDIR/checkpoints`).
    pub dir: PathBuf,
    /// At the first output frame at least this many steps after the last checkpoint.
    pub every_steps: Option<u64>,
    /// At the first output frame at least this many seconds of wall time after it.
    pub every_seconds: Option<f64>,
    /// Keep the newest this many (≥ 1).
    pub keep: usize,
    /// What the checkpoints belong to.
    pub identity: Identity,
}

/// A checkpoint read back.
#[derive(Clone, Debug, PartialEq)]
pub struct Checkpoint {
    /// Its file.
    pub path: PathBuf,
    /// What it belongs to.
    pub identity: Identity,
    /// The step of its frame.
    pub step: u64,
    /// The time of its frame, s.
    pub time: f64,
    /// The writers' position.
    pub output: Vec<u8>,
    /// The run's state.
    pub run: Vec<u8>,
}

/// Errors of checkpoints, with the file in the text.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CheckpointError {
    /// Reading or writing failed.
    #[error("{path}: {message}")]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// The file is not a whole checkpoint of this format.
    #[error("{path}: not a usable checkpoint: {why}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        why: String,
    },
    /// No checkpoint to restart from.
    #[error("{dir}: no checkpoint to restart from{tried}")]
    None {
        /// The folder.
        dir: PathBuf,
        /// What was refused there, if anything.
        tried: String,
    },
}

fn io(path: &Path, e: impl std::fmt::Display) -> CheckpointError {
    CheckpointError::Io {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// The file of the checkpoint at `step`.
pub fn file_name(step: u64) -> String {
    format!("checkpoint_{step:012}.{EXT}")
}

/// Encode a checkpoint.
pub fn encode(identity: &Identity, step: u64, time: f64, output: &[u8], run: &[u8]) -> Vec<u8> {
    let id = serde_json::to_string(identity).unwrap_or_default();
    let mut b = Vec::with_capacity(64 + id.len() + output.len() + run.len());
    b.extend_from_slice(MAGIC);
    b.extend_from_slice(&FORMAT.to_le_bytes());
    b.extend_from_slice(&(id.len() as u32).to_le_bytes());
    b.extend_from_slice(id.as_bytes());
    b.extend_from_slice(&step.to_le_bytes());
    b.extend_from_slice(&time.to_bits().to_le_bytes());
    for part in [output, run] {
        b.extend_from_slice(&(part.len() as u64).to_le_bytes());
        b.extend_from_slice(part);
    }
    let crc = crc32fast::hash(&b);
    b.extend_from_slice(&crc.to_le_bytes());
    b
}

/// Decode a checkpoint's bytes (`path` for messages).
pub fn decode(path: &Path, b: &[u8]) -> Result<Checkpoint, CheckpointError> {
    let bad = |why: &str| CheckpointError::Invalid {
        path: path.to_path_buf(),
        why: why.into(),
    };
    if b.len() < MAGIC.len() + 4 || &b[..MAGIC.len()] != MAGIC {
        return Err(bad("it does not start as a checkpoint of mbdc does"));
    }
    if b.len() < MAGIC.len() + 8 {
        return Err(bad("it is cut short (a run killed while writing it?)"));
    }
    let (body, crc) = b.split_at(b.len() - 4);
    let mut at = MAGIC.len();
    let mut take = |n: usize| -> Result<&[u8], CheckpointError> {
        let s = body
            .get(
                at..at
                    .checked_add(n)
                    .ok_or_else(|| bad("a part's length is absurd"))?,
            )
            .ok_or_else(|| bad("it is cut short (a run killed while writing it?)"))?;
        at += n;
        Ok(s)
    };
    let format = u32::from_le_bytes(take(4)?.try_into().unwrap_or([0; 4]));
    if format != FORMAT {
        return Err(bad(&format!(
            "its format is {format}, this mbdc reads format {FORMAT}"
        )));
    }
    let n = u32::from_le_bytes(take(4)?.try_into().unwrap_or([0; 4])) as usize;
    let id = take(n)?;
    let step = u64::from_le_bytes(take(8)?.try_into().unwrap_or([0; 8]));
    let time = f64::from_bits(u64::from_le_bytes(take(8)?.try_into().unwrap_or([0; 8])));
    let n = u64::from_le_bytes(take(8)?.try_into().unwrap_or([0; 8])) as usize;
    let output = take(n)?.to_vec();
    let n = u64::from_le_bytes(take(8)?.try_into().unwrap_or([0; 8])) as usize;
    let run = take(n)?.to_vec();
    if at != body.len() {
        return Err(bad("it has bytes after its last part"));
    }
    if crc32fast::hash(body).to_le_bytes() != crc {
        return Err(bad(
            "its checksum does not match its bytes (the file was damaged)",
        ));
    }
    let identity: Identity =
        serde_json::from_slice(id).map_err(|e| bad(&format!("its identity: {e}")))?;
    Ok(Checkpoint {
        path: path.to_path_buf(),
        identity,
        step,
        time,
        output,
        run,
    })
}

/// Write `bytes` as the checkpoint at `step` in `dir` atomically (temporary file, fsync,
/// rename, fsync of the folder), then remove all but the newest `keep`.
pub fn write(dir: &Path, step: u64, bytes: &[u8], keep: usize) -> Result<PathBuf, CheckpointError> {
    std::fs::create_dir_all(dir).map_err(|e| io(dir, e))?;
    let path = dir.join(file_name(step));
    let tmp = dir.join(format!(".{}.tmp", file_name(step)));
    let mut f = std::fs::File::create(&tmp).map_err(|e| io(&tmp, e))?;
    let written = f.write_all(bytes).and_then(|()| f.sync_all());
    drop(f);
    if let Err(e) = written {
        let _ = std::fs::remove_file(&tmp);
        return Err(io(&tmp, e));
    }
    std::fs::rename(&tmp, &path).map_err(|e| io(&path, e))?;
    if let Ok(d) = std::fs::File::open(dir) {
        let _ = d.sync_all();
    }
    let mut all = list(dir)?;
    while all.len() > keep.max(1) {
        let (_, old) = all.remove(0);
        let _ = std::fs::remove_file(old);
    }
    Ok(path)
}

/// The checkpoints in `dir`, oldest first, with their steps.
pub fn list(dir: &Path) -> Result<Vec<(u64, PathBuf)>, CheckpointError> {
    let mut out = Vec::new();
    let entries = match std::fs::read_dir(dir) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(out),
        Err(e) => return Err(io(dir, e)),
    };
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let step = name
            .strip_prefix("checkpoint_")
            .and_then(|r| r.strip_suffix(&format!(".{EXT}")))
            .and_then(|n| n.parse::<u64>().ok());
        if let Some(step) = step {
            out.push((step, e.path()));
        }
    }
    out.sort();
    Ok(out)
}

/// The newest checkpoint of `dir` that reads whole. Newer files that do not are refused:
/// their names and reasons are returned too, for the user to be told.
pub fn latest(dir: &Path) -> Result<(Checkpoint, Vec<CheckpointError>), CheckpointError> {
    latest_up_to(dir, u64::MAX)
}

/// [`latest`] among the checkpoints at or before step `last`.
pub fn latest_up_to(
    dir: &Path,
    last: u64,
) -> Result<(Checkpoint, Vec<CheckpointError>), CheckpointError> {
    let mut refused = Vec::new();
    for (_, path) in list(dir)?.into_iter().rev().filter(|(s, _)| *s <= last) {
        let bytes = std::fs::read(&path).map_err(|e| io(&path, e))?;
        match decode(&path, &bytes) {
            Ok(c) => return Ok((c, refused)),
            Err(e) => refused.push(e),
        }
    }
    Err(CheckpointError::None {
        dir: dir.to_path_buf(),
        tried: refused
            .iter()
            .map(|e| format!("\n  refused: {e}"))
            .collect(),
    })
}

/// The steps of the checkpoints in `dir` that read whole, oldest first.
pub fn readable_steps(dir: &Path) -> Vec<u64> {
    list(dir)
        .unwrap_or_default()
        .into_iter()
        .filter(|(_, p)| std::fs::read(p).is_ok_and(|b| decode(p, &b).is_ok()))
        .map(|(s, _)| s)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn id() -> Identity {
        Identity {
            mbdc: "0.1.0".into(),
            model: "m".into(),
            method: "staggered".into(),
            step: format!("{:016x}", 1e-3f64.to_bits()),
            every: 10,
            bodies: 2,
            rows: 6,
            scene: "00ff".into(),
            format: "vtk".into(),
        }
    }

    #[test]
    fn a_checkpoint_reads_back_and_any_damage_is_refused() {
        let b = encode(&id(), 42, 0.042, b"out", b"run state");
        let c = decode(Path::new("c"), &b).unwrap();
        assert_eq!((c.step, c.time, c.identity.clone()), (42, 0.042, id()));
        assert_eq!(
            (c.output.as_slice(), c.run.as_slice()),
            (&b"out"[..], &b"run state"[..])
        );
        for cut in [0, 10, 20, b.len() / 2, b.len() - 1] {
            let e = decode(Path::new("c"), &b[..cut]).unwrap_err().to_string();
            assert!(e.contains("not a usable checkpoint"), "{cut}: {e}");
        }
        for i in [17, 30, b.len() - 6, b.len() - 2] {
            let mut d = b.clone();
            d[i] ^= 0x40;
            assert!(decode(Path::new("c"), &d).is_err(), "byte {i} flipped");
        }
    }

    #[test]
    fn the_difference_is_named() {
        let mut now = id();
        assert_eq!(id().difference(&now), None);
        now.method = "baumgarte".into();
        now.step = format!("{:016x}", 5e-4f64.to_bits());
        let d = id().difference(&now).unwrap();
        assert!(d.contains("method staggered, not baumgarte"), "{d}");
        assert!(d.contains("step 1e-3 s, not 5e-4 s"), "{d}");
        let mut now = id();
        now.scene = "0100".into();
        assert!(id().difference(&now).unwrap().contains("numbers differ"));
        let mut now = id();
        now.format = "exodus".into();
        let d = id().difference(&now).unwrap();
        assert!(d.contains("output format vtk, not exodus"), "{d}");
        // a checkpoint from before the field existed does not compare it
        let mut old = id();
        old.format.clear();
        assert_eq!(old.difference(&now), None);
    }

    #[test]
    fn the_newest_whole_checkpoint_is_used_and_the_rest_pruned() {
        let dir = tempfile::tempdir().unwrap();
        for step in [10, 20, 30] {
            write(
                dir.path(),
                step,
                &encode(&id(), step, step as f64, b"", b""),
                2,
            )
            .unwrap();
        }
        let steps: Vec<u64> = list(dir.path()).unwrap().iter().map(|s| s.0).collect();
        assert_eq!(steps, vec![20, 30]);
        // the newest damaged: refused, said, the one before used
        let newest = dir.path().join(file_name(30));
        let mut b = std::fs::read(&newest).unwrap();
        b.truncate(b.len() - 3);
        std::fs::write(&newest, b).unwrap();
        let (c, refused) = latest(dir.path()).unwrap();
        assert_eq!(c.step, 20);
        assert_eq!(refused.len(), 1);
        assert!(
            refused[0].to_string().contains("checkpoint_000000000030"),
            "{}",
            refused[0]
        );
    }
}
