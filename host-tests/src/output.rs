//! All-or-nothing output files: write into a temporary file in the destination's directory and
//! rename it over the destination only on success, so a failed run leaves no partial file
//! (and an existing file untouched).

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

fn parent_dir(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

fn temp_in(path: &Path, suffix: &str) -> io::Result<tempfile::NamedTempFile> {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp = tempfile::Builder::new()
        .prefix(&format!(".{name}."))
        .suffix(suffix)
        .tempfile_in(parent_dir(path))?;
    // Temporary files are created private (0600); the result is an ordinary output file.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        tmp.as_file().set_permissions(std::fs::Permissions::from_mode(0o644))?;
    }
    Ok(tmp)
}

/// Run `f` on a buffered writer to a temporary file next to `path`; on `Ok`, flush and rename
/// it to `path`. On `Err` (from `f` or the final flush/rename) the temporary file is removed.
pub fn write_atomically<T, E, F>(path: &Path, f: F) -> Result<T, E>
where
    E: From<io::Error>,
    F: FnOnce(&mut BufWriter<&File>) -> Result<T, E>,
{
    let tmp = temp_in(path, ".tmp")?;
    let value = {
        let mut w = BufWriter::with_capacity(1 << 16, tmp.as_file());
        let v = f(&mut w)?;
        w.flush()?;
        v
    };
    tmp.persist(path).map_err(|e| E::from(e.error))?;
    Ok(value)
}

/// Like [`write_atomically`] for code that writes a file by path (e.g. an image encoder that
/// picks the format from the extension): `f` gets a temporary path in the destination's
/// directory with the same extension.
pub fn produce_atomically<T, E, F>(path: &Path, f: F) -> Result<T, E>
where
    E: From<io::Error>,
    F: FnOnce(&Path) -> Result<T, E>,
{
    let ext = path.extension().map(|e| format!(".{}", e.to_string_lossy())).unwrap_or_default();
    let tmp = temp_in(path, &format!(".tmp{ext}"))?;
    let value = f(tmp.path())?;
    tmp.persist(path).map_err(|e| E::from(e.error))?;
    Ok(value)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn success_renames_failure_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out.csv");
        write_atomically(&out, |w| -> io::Result<()> { w.write_all(b"hello\n") }).unwrap();
        assert_eq!(std::fs::read_to_string(&out).unwrap(), "hello\n");

        let out2 = dir.path().join("fail.csv");
        let r = write_atomically(&out2, |w| -> io::Result<()> {
            w.write_all(b"partial")?;
            Err(io::Error::other("boom"))
        });
        assert!(r.is_err());
        assert!(!out2.exists());
        // Only the successful output remains in the directory.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);

        // A failed rewrite leaves the previous file as it was.
        let r = write_atomically(&out, |_| -> io::Result<()> { Err(io::Error::other("x")) });
        assert!(r.is_err());
        assert_eq!(std::fs::read_to_string(&out).unwrap(), "hello\n");
    }
}
