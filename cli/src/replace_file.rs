//! Writing a whole file so that it is either all there or not there: a plot or a page cut
//! short by a full disk would look like a result.

use std::path::{Path, PathBuf};

/// Write `bytes` to `path` through a temporary file in the same folder and a rename; on any
/// error the temporary file is removed and `path` is left as it was.
pub(crate) fn replace_file(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let tmp = temporary_for(path);
    let written = std::fs::write(&tmp, bytes).and_then(|()| std::fs::rename(&tmp, path));
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    written
}

/// `dir/.name.tmp` for `dir/name`.
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
        // a folder stands where the file would go: the rename fails
        let blocked = dir.path().join("b.svg");
        std::fs::create_dir(&blocked).unwrap();
        std::fs::write(blocked.join("x"), "").unwrap();
        assert!(replace_file(&blocked, b"<svg/>").is_err());
        assert!(!dir.path().join(".b.svg.tmp").exists());
    }
}
