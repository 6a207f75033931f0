//! Writing a whole small file atomically: `summary.json`, `scene.json`, a `.pvd` index, the
//! Exodus manifest, and the command line's plots and replay pages. A reader, a killed run or
//! a full disk never leaves half of one (a plot cut short would look like a result).

use std::io::Write;
use std::path::{Path, PathBuf};

use super::{OutputError, OutputErrorKind};

/// Write `bytes` to `path` through `.NAME.tmp` in the same folder and a rename. On any error
/// the temporary file is removed and `path` keeps what it held; the error names the file
/// that failed (the temporary one for creating and writing, `path` for the rename).
///
/// # Errors
/// [`OutputError::Io`] when the temporary file cannot be created or written, or the rename
/// fails.
pub fn replace_file(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    let tmp = temporary_for(path);
    let done = write_new(&tmp, bytes).and_then(|()| {
        std::fs::rename(&tmp, path).map_err(|e| OutputError::io(OutputErrorKind::Write, path, e))
    });
    if done.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    done
}

fn write_new(tmp: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    let mut f =
        std::fs::File::create(tmp).map_err(|e| OutputError::io(OutputErrorKind::Create, tmp, e))?;
    f.write_all(bytes)
        .map_err(|e| OutputError::io(OutputErrorKind::Write, tmp, e))
}

/// `dir/.NAME.tmp` for `dir/NAME`.
fn temporary_for(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.tmp"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failed_write_leaves_neither_the_file_nor_its_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let ok = dir.path().join("a.svg");
        replace_file(&ok, b"<svg/>").unwrap();
        assert_eq!(std::fs::read(&ok).unwrap(), b"<svg/>");
        assert!(!dir.path().join(".a.svg.tmp").exists());
        // a folder stands where the file would go: the rename fails, naming the file
        let blocked = dir.path().join("b.svg");
        std::fs::create_dir(&blocked).unwrap();
        std::fs::write(blocked.join("x"), "").unwrap();
        let e = replace_file(&blocked, b"<svg/>").unwrap_err();
        assert!(e.to_string().contains("b.svg"), "{e}");
        assert!(!dir.path().join(".b.svg.tmp").exists());
    }
}
