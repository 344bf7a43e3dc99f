//! All-or-nothing output files: write into a temporary file in the destination's directory and
//! rename it over the destination only on success, so a failed run leaves no partial file
//! (and an existing file untouched). `-` is standard output, and an existing destination that
//! is not a regular file (`/dev/null`, `/dev/stdout`, a pipe) is written in place: nothing is
//! renamed over it. [`refuse_overwriting_inputs`] keeps a command from writing over the files
//! it reads. An existing read-only file is refused, not replaced; a symbolic link stays a
//! link and its target is written (issue #39); errors name the user's path and directory,
//! never the temporary file.

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
    let dir = parent_dir(path);
    // The temporary file's own name is nobody's business: the error names the directory.
    let tmp = tempfile::Builder::new()
        .prefix(&format!(".{name}."))
        .suffix(suffix)
        .tempfile_in(&dir)
        .map_err(|e| {
            let kind = io::Error::from(e.kind());
            io::Error::new(e.kind(), format!("cannot write in {}: {kind}", dir.display()))
        })?;
    // Temporary files are created private (0600); the result is an ordinary output file.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        tmp.as_file().set_permissions(std::fs::Permissions::from_mode(0o644))?;
    }
    Ok(tmp)
}

/// The same file as `a` (both exist and are one file: the same device and inode, whatever the
/// path, `./x`, a symlink or a hard link).
fn same_file(a: &Path, b: &Path) -> bool {
    match (std::fs::metadata(a), std::fs::metadata(b)) {
        #[cfg(unix)]
        (Ok(ma), Ok(mb)) => {
            use std::os::unix::fs::MetadataExt;
            ma.dev() == mb.dev() && ma.ino() == mb.ino()
        }
        #[cfg(not(unix))]
        (Ok(_), Ok(_)) => {
            matches!((a.canonicalize(), b.canonicalize()), (Ok(x), Ok(y)) if x == y)
        }
        _ => false,
    }
}

/// An error when the output `out` is one of the command's `inputs` (it would be replaced by
/// the output: the input lost).
pub fn refuse_overwriting_inputs(out: &Path, inputs: &[&Path]) -> io::Result<()> {
    for i in inputs {
        if out.as_os_str() != "-" && same_file(out, i) {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!(
                    "{}: is the input {}; refusing to write over it",
                    out.display(),
                    i.display()
                ),
            ));
        }
    }
    Ok(())
}

/// Where `path` is written without a temporary file: standard output for `-`, or the existing
/// non-regular file itself (a device, a pipe), opened for writing.
fn direct(path: &Path) -> io::Result<Option<File>> {
    if path.as_os_str() == "-" {
        #[cfg(unix)]
        {
            use std::os::fd::AsFd;
            return Ok(Some(File::from(io::stdout().as_fd().try_clone_to_owned()?)));
        }
        #[cfg(not(unix))]
        return Err(io::Error::new(io::ErrorKind::Unsupported, "`-` (stdout) needs unix"));
    }
    match std::fs::metadata(path) {
        Ok(m) if !m.is_file() && !m.is_dir() => {
            Ok(Some(std::fs::OpenOptions::new().write(true).open(path)?))
        }
        _ => Ok(None),
    }
}

/// The file to replace for the output `path`: the final target of a symbolic link (the link
/// stays; a dangling link's target is created), else `path`. An existing read-only regular
/// file is refused: replacing it by renaming would ignore its mode.
fn target(path: &Path) -> io::Result<PathBuf> {
    let mut t = path.to_path_buf();
    // A chain of links, each relative to its own directory; bounded like the kernel's.
    for _ in 0..40 {
        match std::fs::symlink_metadata(&t) {
            Ok(m) if m.file_type().is_symlink() => {
                let next = std::fs::read_link(&t)?;
                t = if next.is_absolute() { next } else { parent_dir(&t).join(next) };
            }
            _ => break,
        }
    }
    if let Ok(m) = std::fs::metadata(&t) {
        if m.is_file() && m.permissions().readonly() {
            return Err(io::Error::new(
                io::ErrorKind::PermissionDenied,
                "read-only: not replaced (make it writable, or choose another name)",
            ));
        }
    }
    Ok(t)
}

/// Run `f` on a buffered writer to a temporary file next to `path`; on `Ok`, flush and rename
/// it to `path`. On `Err` (from `f` or the final flush/rename) the temporary file is removed.
/// `-` and existing non-regular files are written directly (see the module documentation).
pub fn write_atomically<T, E, F>(path: &Path, f: F) -> Result<T, E>
where
    E: From<io::Error>,
    F: FnOnce(&mut BufWriter<&File>) -> Result<T, E>,
{
    if let Some(file) = direct(path)? {
        let mut w = BufWriter::with_capacity(1 << 16, &file);
        let v = f(&mut w)?;
        w.flush()?;
        return Ok(v);
    }
    let path = &target(path)?;
    #[cfg(target_os = "linux")]
    if let Some(file) = unnamed_in(path) {
        let value = {
            let mut w = BufWriter::with_capacity(1 << 16, &file);
            let v = f(&mut w)?;
            w.flush()?;
            v
        };
        link_into(&file, path)?;
        return Ok(value);
    }
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

/// Linux: an unnamed file in `path`'s directory (`O_TMPFILE`), readable and writable, mode
/// 0644: it has no name until [`link_into`] gives it one, so a process killed while writing it
/// leaves nothing behind (issue #39 point 2: a killed `simulate` left a hidden `.tmp` file of
/// hundreds of MB). `None` where the file system cannot (the named temporary file then).
#[cfg(target_os = "linux")]
fn unnamed_in(path: &Path) -> Option<File> {
    use std::os::unix::fs::{OpenOptionsExt, PermissionsExt};
    let file = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .custom_flags(nix::fcntl::OFlag::O_TMPFILE.bits())
        .mode(0o644)
        .open(parent_dir(path))
        .ok()?;
    file.set_permissions(std::fs::Permissions::from_mode(0o644)).ok()?;
    Some(file)
}

/// Gives the unnamed `file` the name `path`: linked under a fresh hidden name in its directory
/// (`linkat` of `/proc/self/fd/N`), then renamed over `path`. Where the link cannot be made
/// (no `/proc`), the content is copied into a named temporary file instead.
#[cfg(target_os = "linux")]
fn link_into(file: &File, path: &Path) -> io::Result<()> {
    use std::os::fd::AsRawFd;
    let dir = parent_dir(path);
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let fd = format!("/proc/self/fd/{}", file.as_raw_fd());
    for k in 0..100 {
        let tmp = dir.join(format!(".{name}.{}.{k}.tmp", std::process::id()));
        let flags = nix::unistd::LinkatFlags::SymlinkFollow;
        match nix::unistd::linkat(None, std::path::Path::new(&fd), None, tmp.as_path(), flags) {
            Ok(()) => {
                return std::fs::rename(&tmp, path).inspect_err(|_| {
                    let _ = std::fs::remove_file(&tmp);
                });
            }
            Err(nix::errno::Errno::EEXIST) => continue,
            Err(_) => break,
        }
    }
    use std::io::{Read, Seek};
    let tmp = temp_in(path, ".tmp")?;
    let mut src = file;
    src.seek(io::SeekFrom::Start(0))?;
    let mut dst = tmp.as_file();
    let mut buf = vec![0u8; 1 << 16];
    loop {
        let n = src.read(&mut buf)?;
        if n == 0 {
            break;
        }
        dst.write_all(&buf[..n])?;
    }
    tmp.persist(path).map_err(|e| e.error)?;
    Ok(())
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
    let path = &target(path)?;
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

    #[test]
    fn the_input_is_never_the_output() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("in.csv");
        std::fs::write(&input, "t\n").unwrap();
        // The same file by another path: ./, .., a symlink.
        let other = dir.path().join(".").join("sub").join("..").join("in.csv");
        std::fs::create_dir(dir.path().join("sub")).unwrap();
        let link = dir.path().join("link.csv");
        #[cfg(unix)]
        std::os::unix::fs::symlink(&input, &link).unwrap();
        for out in [&input, &other, &link] {
            let e = refuse_overwriting_inputs(out, &[&input]).unwrap_err();
            assert!(e.to_string().contains("refusing to write over it"), "{e}");
        }
        assert!(refuse_overwriting_inputs(&dir.path().join("new.csv"), &[&input]).is_ok());
        assert!(refuse_overwriting_inputs(Path::new("-"), &[&input]).is_ok());
        assert_eq!(std::fs::read_to_string(&input).unwrap(), "t\n");
    }

    /// Issue #39, point 2: a read-only output is refused and stays as it was (it used to be
    /// replaced by a 0644 file); a symbolic link stays a link, its target written (it used to
    /// be replaced by a regular file); a missing or read-only directory is named in the error,
    /// not the temporary file.
    #[cfg(unix)]
    #[test]
    fn read_only_files_links_and_directories() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let ro = dir.path().join("ro.csv");
        std::fs::write(&ro, "keep\n").unwrap();
        std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o444)).unwrap();
        let e = write_atomically(&ro, |w| -> io::Result<()> { w.write_all(b"new") }).unwrap_err();
        assert!(e.to_string().starts_with("read-only: not replaced"), "{e}");
        assert_eq!(std::fs::read_to_string(&ro).unwrap(), "keep\n");
        assert_eq!(std::fs::metadata(&ro).unwrap().permissions().mode() & 0o777, 0o444);
        // A link, relative, to a file in a subdirectory: the file is written, the link stays.
        std::fs::create_dir(dir.path().join("sub")).unwrap();
        let real = dir.path().join("sub").join("real.csv");
        std::fs::write(&real, "old\n").unwrap();
        let link = dir.path().join("link.csv");
        std::os::unix::fs::symlink("sub/real.csv", &link).unwrap();
        write_atomically(&link, |w| -> io::Result<()> { w.write_all(b"new\n") }).unwrap();
        assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
        assert_eq!(std::fs::read_to_string(&real).unwrap(), "new\n");
        // Through `produce_atomically` too.
        produce_atomically(&link, |p| std::fs::write(p, "png\n")).unwrap();
        assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
        assert_eq!(std::fs::read_to_string(&real).unwrap(), "png\n");
        // A missing directory: its name in the error, no temporary file's.
        let missing = dir.path().join("nope").join("x.csv");
        let e = write_atomically(&missing, |w| -> io::Result<()> { w.write_all(b"x") })
            .unwrap_err()
            .to_string();
        assert!(e.contains("nope") && !e.contains(".x.csv."), "{e}");
    }

    #[cfg(unix)]
    #[test]
    fn devices_are_written_in_place() {
        // /dev/null is written, not replaced (the old code tried to create /dev/.null.*.tmp).
        write_atomically(Path::new("/dev/null"), |w| -> io::Result<()> { w.write_all(b"x") })
            .unwrap();
        let m = std::fs::metadata("/dev/null").unwrap();
        assert!(!m.is_file());
    }
}
