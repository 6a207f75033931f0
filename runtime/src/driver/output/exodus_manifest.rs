//! The manifest of `results.exo`, `results.exo.manifest.json`: which partition wrote which
//! slice of every frame, at which offset (the papers' I/O table), so that a file written by
//! `p` partitions is read, checked, or continued by `p′`.

use serde::{Deserialize, Serialize};

/// Version of the manifest's format.
pub const MANIFEST_VERSION: u32 = 1;

/// One entry of the manifest: what a partition wrote in every frame.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ManifestSlice {
    /// The partition.
    pub partition: u32,
    /// The netCDF variable.
    pub variable: String,
    /// First value of the slice (index into the variable's values of one frame).
    pub start: u64,
    /// Values in the slice.
    pub count: u64,
    /// Byte offset of the slice in frame 0; frame `r`'s is `offset + r · record_size`.
    pub offset: u64,
    /// Bytes of the slice.
    pub length: u64,
}

/// `results.exo.manifest.json`: who wrote what where (the papers' I/O table).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Manifest {
    /// [`MANIFEST_VERSION`].
    pub format_version: u32,
    /// The data file's name.
    pub file: String,
    /// Partitions that wrote it.
    pub partitions: u32,
    /// Offset of frame 0 (the end of the fixed data), bytes.
    pub records_begin: u64,
    /// Bytes per frame.
    pub record_size: u64,
    /// Frames complete when the manifest was written (the header's `numrecs` may be ahead).
    pub frames_complete: u64,
    /// The slices, partition by partition.
    pub slices: Vec<ManifestSlice>,
}
