//! Output files: atomic replacement (temporary file in the same directory, fsync, rename)
//! that never overwrites an input, and SHA-256 of a file.

use std::fmt;
use std::fs::{self, File};
use std::io::{self, BufWriter, Read, Write};
use std::path::{Path, PathBuf};

use sha2::{Digest, Sha256};

/// Why an output could not be written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputErrorKind {
    /// The output path is (or resolves to) one of the input files.
    SameAsInput,
    /// The file system refused, or the writer failed.
    Io,
}

/// An output that was not written. The target is left as it was and no temporary file
/// remains.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OutputError {
    pub path: String,
    pub kind: OutputErrorKind,
    pub reason: String,
}

impl fmt::Display for OutputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.path, self.reason)
    }
}

impl std::error::Error for OutputError {}

/// Canonical form of `p`, also when `p` itself does not exist yet (then its directory is
/// canonicalised and the file name appended). `None` if neither can be resolved.
fn resolve(p: &Path) -> Option<PathBuf> {
    if let Ok(c) = fs::canonicalize(p) {
        return Some(c);
    }
    let name = p.file_name()?;
    let dir = match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    fs::canonicalize(dir).ok().map(|d| d.join(name))
}

#[cfg(unix)]
fn same_inode(a: &Path, b: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (fs::metadata(a), fs::metadata(b)) {
        (Ok(ma), Ok(mb)) => ma.dev() == mb.dev() && ma.ino() == mb.ino(),
        _ => false,
    }
}

#[cfg(not(unix))]
fn same_inode(_a: &Path, _b: &Path) -> bool {
    false
}

/// True if writing `output` would replace `input`. A symlink at `output` is resolved, so a
/// link pointing at an input counts as that input.
pub fn is_same_file(output: &Path, input: &Path) -> bool {
    if let (Some(o), Some(i)) = (resolve(output), resolve(input))
        && o == i
    {
        return true;
    }
    // Also catches hard links and paths the canonical forms do not unify.
    same_inode(output, input)
}

/// What an output path is before it is written: the file that will really be replaced
/// (a symlink is followed to its final target) and its permission bits, if it exists.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OutputTarget {
    /// The path the new file is renamed onto: `path` itself, or the final target of the
    /// symlink `path` names.
    pub path: PathBuf,
    /// Unix permission bits of the existing file (kept by the replacement); `None` for a
    /// new file.
    pub mode: Option<u32>,
}

/// Checks that `path` may be written: absent, or a regular file that is not
/// write-protected; a symlink is followed to its final target, which must be such a file
/// (a dangling symlink is refused: kincal never creates a file at a link's far end). Device
/// nodes, FIFOs, sockets and directories are refused: an atomic rename would replace the
/// node itself (as root, `--out /dev/null` would replace the system's /dev/null). The
/// containing folder must exist. The error says why, in words for the user.
pub fn output_target(path: &Path) -> Result<OutputTarget, String> {
    if path.file_name().is_none() {
        return Err("the path names no file".into());
    }
    let link = fs::symlink_metadata(path);
    let target = match &link {
        Ok(m) if m.file_type().is_symlink() => fs::canonicalize(path).map_err(|e| {
            format!("it is a symlink whose target cannot be resolved ({e}); kincal writes through a symlink only to an existing regular file")
        })?,
        _ => path.to_path_buf(),
    };
    let dir = parent_dir(&target);
    match fs::metadata(dir) {
        Ok(m) if m.is_dir() => {}
        Ok(_) => return Err(format!("'{}' is not a folder", dir.display())),
        Err(_) => {
            return Err(format!(
                "the folder '{}' does not exist (kincal creates no folders: create it first)",
                dir.display()
            ));
        }
    }
    let meta = match fs::metadata(&target) {
        Ok(m) => m,
        Err(e) if e.kind() == io::ErrorKind::NotFound => {
            return Ok(OutputTarget {
                path: target,
                mode: None,
            });
        }
        Err(e) => return Err(format!("cannot inspect it: {e}")),
    };
    if !meta.is_file() {
        return Err(format!(
            "it is {}, not a regular file: kincal writes only regular files",
            kind_of(&meta)
        ));
    }
    if meta.permissions().readonly() {
        return Err(
            "it is write-protected (no write permission bits): kincal does not replace it; \
             make it writable or choose another path"
                .into(),
        );
    }
    Ok(OutputTarget {
        path: target,
        mode: mode_of(&meta),
    })
}

/// The folder a file path lives in (`.` for a bare name).
fn parent_dir(p: &Path) -> &Path {
    match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

#[cfg(unix)]
fn kind_of(m: &fs::Metadata) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    let t = m.file_type();
    if t.is_dir() {
        "a directory"
    } else if t.is_fifo() {
        "a FIFO (named pipe)"
    } else if t.is_char_device() {
        "a character device"
    } else if t.is_block_device() {
        "a block device"
    } else if t.is_socket() {
        "a socket"
    } else {
        "a special file"
    }
}

#[cfg(not(unix))]
fn kind_of(m: &fs::Metadata) -> &'static str {
    if m.is_dir() {
        "a directory"
    } else {
        "a special file"
    }
}

/// The read/write/execute bits (setuid, setgid and sticky are not carried over to the new
/// file).
#[cfg(unix)]
fn mode_of(m: &fs::Metadata) -> Option<u32> {
    use std::os::unix::fs::PermissionsExt;
    Some(m.permissions().mode() & 0o777)
}

#[cfg(not(unix))]
fn mode_of(_m: &fs::Metadata) -> Option<u32> {
    None
}

/// Prefix of the temporary file for `name`: `.kincal-<name>-<pid>-`, so that a leftover is
/// recognisable (which output, which process) and can be removed once its process is gone.
fn temp_prefix(name: &str, pid: u32) -> String {
    format!(".kincal-{name}-{pid}-")
}

/// Removes temporary files of earlier runs writing `name` in `dir` whose process no longer
/// exists (a run killed between creating and renaming its temporary file). Linux only
/// (liveness from /proc); elsewhere nothing is removed.
fn remove_stale_temporaries(dir: &Path, name: &str) {
    let proc_root = Path::new("/proc/self");
    if !proc_root.exists() {
        return;
    }
    let head = format!(".kincal-{name}-");
    let Ok(entries) = fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let file_name = entry.file_name();
        let Some(rest) = file_name
            .to_str()
            .and_then(|f| f.strip_prefix(&head))
            .filter(|r| r.ends_with(".tmp"))
        else {
            continue;
        };
        // Exactly `<pid>-<random>.tmp` (the random part has no '-'), so that the file of
        // another output whose name extends this one (`a` and `a-5`) is never taken.
        let mut parts = rest.split('-');
        let (Some(pid), Some(_), None) = (parts.next(), parts.next(), parts.next()) else {
            continue;
        };
        let Ok(pid) = pid.parse::<u32>() else {
            continue;
        };
        let alive = Path::new("/proc").join(pid.to_string()).exists();
        let is_file = entry.file_type().is_ok_and(|t| t.is_file());
        if !alive && is_file {
            let _ = fs::remove_file(entry.path());
        }
    }
}

/// Writes `path` atomically: `write` fills a temporary file in the same directory, which is
/// flushed, fsynced and then renamed over `path`. Refuses (kind `SameAsInput`) if `path`
/// is one of `inputs` (same canonical path, or same device and inode), and (kind `Io`) a
/// path [`output_target`] refuses: only regular files or absent paths are written; a
/// symlink is followed and its target replaced (the link stays). An existing file keeps its
/// permission bits (not its owner). The temporary file is `.kincal-<name>-<pid>-<random>.tmp`;
/// on any error the target is untouched and the temporary file is removed, and leftovers of
/// killed runs are removed by the next write of the same output.
pub fn write_atomic(
    path: &Path,
    inputs: &[&Path],
    write: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> Result<(), OutputError> {
    let shown = path.display().to_string();
    let io_err = |what: &str, e: io::Error| OutputError {
        path: shown.clone(),
        kind: OutputErrorKind::Io,
        reason: format!("{what}: {e}"),
    };

    for input in inputs {
        if is_same_file(path, input) {
            return Err(OutputError {
                path: shown.clone(),
                kind: OutputErrorKind::SameAsInput,
                reason: format!(
                    "refusing to write: this is the input file '{}' (an input is never \
                     overwritten; choose another output path)",
                    input.display()
                ),
            });
        }
    }
    let target = output_target(path).map_err(|reason| OutputError {
        path: shown.clone(),
        kind: OutputErrorKind::Io,
        reason: format!("cannot write: {reason}"),
    })?;
    let dir = parent_dir(&target.path);
    let name = target
        .path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    remove_stale_temporaries(dir, &name);

    let mut builder = tempfile::Builder::new();
    let prefix = temp_prefix(&name, std::process::id());
    builder.prefix(&prefix).suffix(".tmp");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        // An existing output keeps its bits; a new one is like any newly created file:
        // 0666 less the umask (tempfile's default is 0600).
        builder.permissions(fs::Permissions::from_mode(target.mode.unwrap_or(0o666)));
    }
    let tmp = builder
        .tempfile_in(dir)
        .map_err(|e| io_err("cannot create a temporary file in the output directory", e))?;
    #[cfg(unix)]
    if let Some(mode) = target.mode {
        // Creation applies the umask; the existing file's bits are restored exactly.
        use std::os::unix::fs::PermissionsExt;
        tmp.as_file()
            .set_permissions(fs::Permissions::from_mode(mode))
            .map_err(|e| io_err("cannot set the permissions of the temporary file", e))?;
    }

    {
        let mut out = BufWriter::new(tmp.as_file());
        write(&mut out).map_err(|e| io_err("write failed", e))?;
        out.flush().map_err(|e| io_err("write failed", e))?;
    }
    tmp.as_file()
        .sync_all()
        .map_err(|e| io_err("fsync failed", e))?;
    // On failure the returned PersistError owns the temporary file and deletes it on drop.
    tmp.persist(&target.path)
        .map_err(|e| io_err("cannot rename the temporary file into place", e.error))?;
    #[cfg(unix)]
    {
        // Make the rename itself durable; failure here does not undo a completed write.
        if let Ok(d) = File::open(dir) {
            let _ = d.sync_all();
        }
    }
    Ok(())
}

/// Lower-case hex SHA-256 of a file's bytes (streamed).
pub fn sha256_file(path: &Path) -> io::Result<String> {
    let mut f = File::open(path)?;
    let mut hasher = Sha256::new();
    let mut buf = vec![0u8; 64 * 1024];
    loop {
        let n = match f.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        hasher.update(&buf[..n]);
    }
    let digest = hasher.finalize();
    let mut s = String::with_capacity(64);
    for b in digest.iter() {
        use fmt::Write as _;
        let _ = write!(s, "{b:02x}");
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entries(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    fn put(w: &mut dyn Write, s: &str) -> io::Result<()> {
        w.write_all(s.as_bytes())
    }

    #[test]
    fn creates_and_replaces_content() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("in.csv");
        fs::write(&input, "input").unwrap();
        let out = dir.path().join("out.csv");
        write_atomic(&out, &[&input], |w| put(w, "first version, long")).unwrap();
        assert_eq!(fs::read_to_string(&out).unwrap(), "first version, long");
        write_atomic(&out, &[&input], |w| put(w, "second")).unwrap();
        assert_eq!(fs::read_to_string(&out).unwrap(), "second");
        assert_eq!(fs::read_to_string(&input).unwrap(), "input");
        assert_eq!(entries(dir.path()), vec!["in.csv", "out.csv"]);
    }

    #[cfg(unix)]
    #[test]
    fn new_file_gets_ordinary_permissions() {
        use std::os::unix::fs::PermissionsExt;
        let umask = fs::read_to_string("/proc/self/status").ok().and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("Umask:"))
                .and_then(|m| u32::from_str_radix(m.trim(), 8).ok())
        });
        let Some(umask) = umask else { return };
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out.csv");
        write_atomic(&out, &[], |w| put(w, "x")).unwrap();
        let mode = fs::metadata(&out).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o666 & !umask);
    }

    #[track_caller]
    fn assert_refused(out: &Path, input: &Path, dir: &Path) {
        let before = entries(dir);
        let content = fs::read(input).unwrap();
        let e = write_atomic(out, &[Path::new("/elsewhere/other.csv"), input], |w| {
            put(w, "clobbered")
        })
        .unwrap_err();
        assert_eq!(e.kind, OutputErrorKind::SameAsInput, "{e}");
        assert!(e.to_string().contains("input"), "{e}");
        assert_eq!(fs::read(input).unwrap(), content);
        assert_eq!(entries(dir), before);
    }

    #[test]
    fn refuses_to_overwrite_an_input() {
        let dir = tempfile::tempdir().unwrap();
        fs::create_dir(dir.path().join("sub")).unwrap();
        let input = dir.path().join("in.csv");
        fs::write(&input, "precious").unwrap();
        assert_refused(&input, &input, dir.path());
        // The same file through another spelling.
        let other = dir.path().join("sub").join("..").join(".").join("in.csv");
        assert_refused(&other, &input, dir.path());
        assert_refused(&input, &other, dir.path());
    }

    #[test]
    fn refuses_a_relative_spelling_of_an_input() {
        // A relative path (against the current directory) naming an absolute input.
        let cwd = std::env::current_dir().unwrap();
        let dir = tempfile::tempdir_in(&cwd).unwrap();
        let input = dir.path().join("in.csv");
        fs::write(&input, "precious").unwrap();
        let name = dir.path().file_name().unwrap();
        let relative = Path::new(".").join(name).join("in.csv");
        assert!(relative.is_relative());
        assert_refused(&relative, &input, dir.path());
    }

    #[cfg(unix)]
    #[test]
    fn refuses_symlinks_and_hard_links_to_an_input() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("in.csv");
        fs::write(&input, "precious").unwrap();
        let link = dir.path().join("link.csv");
        std::os::unix::fs::symlink("in.csv", &link).unwrap();
        assert_refused(&link, &input, dir.path());
        let hard = dir.path().join("hard.csv");
        fs::hard_link(&input, &hard).unwrap();
        assert_refused(&hard, &input, dir.path());
        // A symlinked directory.
        let dlink = dir.path().join("dlink");
        std::os::unix::fs::symlink(dir.path(), &dlink).unwrap();
        assert_refused(&dlink.join("in.csv"), &input, dir.path());
    }

    #[test]
    fn failed_write_leaves_target_and_no_temporary_file() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out.csv");
        fs::write(&out, "old").unwrap();
        let e = write_atomic(&out, &[], |w| {
            put(w, "partial")?;
            Err(io::Error::other("model diverged"))
        })
        .unwrap_err();
        assert_eq!(e.kind, OutputErrorKind::Io);
        assert!(e.to_string().contains("model diverged"), "{e}");
        assert_eq!(fs::read_to_string(&out).unwrap(), "old");
        assert_eq!(entries(dir.path()), vec!["out.csv"]);

        // A new target that fails is not created at all.
        let new = dir.path().join("new.csv");
        write_atomic(&new, &[], |_| Err(io::Error::other("no"))).unwrap_err();
        assert!(!new.exists());
        assert_eq!(entries(dir.path()), vec!["out.csv"]);
    }

    #[test]
    fn rename_failure_leaves_no_temporary_file() {
        let dir = tempfile::tempdir().unwrap();
        // The target is a non-empty directory: rename fails after the data were written.
        let target = dir.path().join("taken");
        fs::create_dir(&target).unwrap();
        fs::write(target.join("x"), "x").unwrap();
        let e = write_atomic(&target, &[], |w| put(w, "data")).unwrap_err();
        assert_eq!(e.kind, OutputErrorKind::Io);
        assert_eq!(entries(dir.path()), vec!["taken"]);
    }

    #[test]
    fn missing_directory_is_an_io_error() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("no").join("such").join("out.csv");
        let e = write_atomic(&out, &[], |w| put(w, "x")).unwrap_err();
        assert_eq!(e.kind, OutputErrorKind::Io);
        assert!(e.to_string().starts_with(&out.display().to_string()), "{e}");
    }

    #[test]
    fn sha256_of_a_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("abc");
        fs::write(&p, "abc").unwrap();
        assert_eq!(
            sha256_file(&p).unwrap(),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
        fs::write(&p, "").unwrap();
        assert_eq!(
            sha256_file(&p).unwrap(),
            "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855"
        );
        assert!(sha256_file(&dir.path().join("missing")).is_err());
    }
}
