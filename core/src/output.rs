//! The one writer of every file the program produces: scenes, recovery files, PNGs, meshes of
//! every format. Nothing a user had is lost:
//!
//! - an output that is one of the command's inputs (the same file by device and inode, whatever
//!   its name) is refused before anything is written;
//! - a symlink is followed and its target written (the link stays a link);
//! - a regular file (or a new one) is written through a temporary file with a unique name in the
//!   target's folder, flushed to disk, given the old file's permissions, renamed over the
//!   target, and the folder flushed: a crash or `kill -9` leaves the old file or the new one,
//!   and the temporary file is removed on every error path (those of writers killed in their
//!   last milliseconds are removed by the next write of the same target);
//! - a target that is not a regular file (a device such as `/dev/full`, a FIFO) is written
//!   directly, so that its own write errors are reported rather than replaced by a rename;
//! - a folder as target is refused, and so is a read-only file (its owner marked it so; a
//!   rename would replace it all the same).
//!
//! Outputs made of several files (`.gltf` and its buffer) write their parts under names unique
//! to the write and the file that names them last ([`unique_id`]).

use std::fmt;
use std::fs::{self, File, OpenOptions};
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Why an output was not written; names the file.
#[derive(Debug)]
pub struct WriteError {
    /// The output as the user named it.
    pub file: PathBuf,
    /// What went wrong, in words.
    pub reason: String,
}

impl fmt::Display for WriteError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: cannot write: {}", self.file.display(), self.reason)
    }
}

impl std::error::Error for WriteError {}

/// Writes `bytes` to `path` as the module docs say, refusing to write over any of `inputs`.
///
/// # Errors
/// The output is an input or a folder, its folder is missing or read-only, the disk is full, a
/// device refused the bytes: one [`WriteError`] naming `path`.
pub fn write_file(path: &Path, bytes: &[u8], inputs: &[&Path]) -> Result<(), WriteError> {
    write_file_with(path, bytes, inputs, |_| Ok(()))
}

/// [`write_file`] with `before_rename` run on the flushed temporary file just before it replaces
/// the target (the tests make it fail there).
///
/// # Errors
/// As [`write_file`], and `before_rename`'s error.
pub fn write_file_with(
    path: &Path,
    bytes: &[u8],
    inputs: &[&Path],
    before_rename: impl FnOnce(&Path) -> io::Result<()>,
) -> Result<(), WriteError> {
    let fail = |reason: String| WriteError {
        file: path.to_path_buf(),
        reason,
    };
    refuse_inputs(path, inputs).map_err(fail)?;
    let target = follow_links(path).map_err(|e| fail(e.to_string()))?;
    match fs::metadata(&target) {
        Ok(meta) if meta.is_dir() => Err(fail("it is a folder".to_owned())),
        Ok(meta) if meta.is_file() && meta.permissions().readonly() => Err(fail(
            "it is read-only; make it writable or choose another output".to_owned(),
        )),
        Ok(meta) if !meta.is_file() => {
            write_in_place(&target, bytes).map_err(|e| fail(e.to_string()))
        }
        Ok(meta) => replace(&target, bytes, Some(meta.permissions()), before_rename)
            .map_err(|e| fail(e.to_string())),
        Err(e) if e.kind() == io::ErrorKind::NotFound => {
            replace(&target, bytes, None, before_rename).map_err(|e| fail(e.to_string()))
        }
        Err(e) => Err(fail(e.to_string())),
    }
}

/// `Err` naming the input when `path` is the same file as one of `inputs`.
fn refuse_inputs(path: &Path, inputs: &[&Path]) -> Result<(), String> {
    let Ok(out) = fs::metadata(path) else {
        return Ok(());
    };
    for input in inputs {
        if fs::metadata(input).is_ok_and(|meta| same_file(&meta, &out)) {
            return Err(format!(
                "it is the input {} of this command; choose another output",
                input.display()
            ));
        }
    }
    Ok(())
}

#[cfg(unix)]
fn same_file(a: &fs::Metadata, b: &fs::Metadata) -> bool {
    use std::os::unix::fs::MetadataExt;
    a.dev() == b.dev() && a.ino() == b.ino()
}

#[cfg(not(unix))]
fn same_file(a: &fs::Metadata, b: &fs::Metadata) -> bool {
    a.len() == b.len()
        && a.modified().ok() == b.modified().ok()
        && a.created().ok() == b.created().ok()
}

/// The file `path` names once its symlinks are followed (also a dangling link's target, which
/// the write then creates).
fn follow_links(path: &Path) -> io::Result<PathBuf> {
    let mut target = path.to_path_buf();
    for _ in 0..40 {
        match fs::symlink_metadata(&target) {
            Ok(meta) if meta.file_type().is_symlink() => {
                let link = fs::read_link(&target)?;
                target = match target.parent() {
                    Some(dir) if link.is_relative() => dir.join(link),
                    _ => link,
                };
            }
            _ => return Ok(target),
        }
    }
    Err(io::Error::other("too many levels of symbolic links"))
}

/// Writes a device or FIFO directly and flushes it.
fn write_in_place(target: &Path, bytes: &[u8]) -> io::Result<()> {
    let mut file = OpenOptions::new().write(true).open(target)?;
    file.write_all(bytes)?;
    file.flush()
}

/// The folder `path` is in (`.` for a bare name).
fn folder_of(path: &Path) -> &Path {
    path.parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
}

/// An identifier no other write of this or another process uses at the same time: the
/// process, a count within it and the clock's nanoseconds.
#[must_use]
pub fn unique_id() -> String {
    static COUNT: AtomicU64 = AtomicU64::new(0);
    let count = COUNT.fetch_add(1, Ordering::Relaxed);
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    format!("{}-{count}-{nanos:08x}", std::process::id())
}

/// A hidden name beside `path` that no other write uses: `.{name}.{unique_id}.{tag}`.
#[must_use]
pub fn unique_sibling(path: &Path, tag: &str) -> PathBuf {
    let name = path
        .file_name()
        .map_or_else(|| "output".into(), |n| n.to_string_lossy().into_owned());
    folder_of(path).join(format!(".{name}.{}.{tag}", unique_id()))
}

/// Removes the temporary files beside `target` that writes of processes no longer running
/// left (a `kill -9` inside their last milliseconds); Linux only, where `/proc` says which
/// processes run.
fn sweep_stale_temporaries(target: &Path) {
    if !cfg!(target_os = "linux") {
        return;
    }
    let Some(name) = target.file_name().map(|n| n.to_string_lossy().into_owned()) else {
        return;
    };
    let prefix = format!(".{name}.");
    let Ok(entries) = fs::read_dir(folder_of(target)) else {
        return;
    };
    for entry in entries.filter_map(Result::ok) {
        let file = entry.file_name().to_string_lossy().into_owned();
        let Some(rest) = file
            .strip_prefix(&prefix)
            .filter(|_| file.ends_with(".tmp"))
        else {
            continue;
        };
        let pid = rest.split('-').next().and_then(|p| p.parse::<u32>().ok());
        if let Some(pid) = pid
            && pid != std::process::id()
            && !Path::new(&format!("/proc/{pid}")).exists()
        {
            let _ = fs::remove_file(entry.path());
        }
    }
}

/// Writes a regular file through a temporary one renamed over it.
fn replace(
    target: &Path,
    bytes: &[u8],
    permissions: Option<fs::Permissions>,
    before_rename: impl FnOnce(&Path) -> io::Result<()>,
) -> io::Result<()> {
    let temp = unique_sibling(target, "tmp");
    let result = (|| {
        let mut file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&temp)?;
        file.write_all(bytes)?;
        if let Some(permissions) = permissions {
            file.set_permissions(permissions)?;
        }
        file.sync_all()?;
        drop(file);
        before_rename(&temp)?;
        fs::rename(&temp, target)
    })();
    if result.is_err() {
        let _ = fs::remove_file(&temp);
        return result;
    }
    sync_folder(folder_of(target));
    sweep_stale_temporaries(target);
    Ok(())
}

/// Flushes a folder's entries (the rename) to disk; not every platform can open a folder, and a
/// failure here leaves a complete file under one of its two names, so it is not reported.
fn sync_folder(folder: &Path) {
    if let Ok(dir) = File::open(folder) {
        let _ = dir.sync_all();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("skeletrace-output-{name}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
        dir
    }

    fn leftovers(dir: &Path) -> Vec<String> {
        fs::read_dir(dir)
            .map(|entries| {
                entries
                    .filter_map(Result::ok)
                    .map(|e| e.file_name().to_string_lossy().into_owned())
                    .filter(|n| n.ends_with(".tmp"))
                    .collect()
            })
            .unwrap_or_default()
    }

    #[test]
    fn an_input_is_never_overwritten_whatever_its_name() {
        let dir = scratch("input");
        let input = dir.join("scene.ron");
        fs::write(&input, "old").unwrap_or_else(|e| panic!("{e}"));
        let other_name = dir.join("alias.ron");
        fs::hard_link(&input, &other_name).unwrap_or_else(|e| panic!("{e}"));
        for out in [&input, &other_name] {
            let e = write_file(out, b"new", &[&input]).err();
            assert!(e.is_some_and(|e| e.to_string().contains("is the input")));
        }
        assert_eq!(fs::read_to_string(&input).unwrap_or_default(), "old");
        let _ = fs::remove_dir_all(&dir);
    }

    #[cfg(unix)]
    #[test]
    fn symlinks_are_followed_and_permissions_kept() {
        use std::os::unix::fs::PermissionsExt;
        let dir = scratch("link");
        let real = dir.join("real.png");
        fs::write(&real, "old").unwrap_or_else(|e| panic!("{e}"));
        fs::set_permissions(&real, fs::Permissions::from_mode(0o600))
            .unwrap_or_else(|e| panic!("{e}"));
        let link = dir.join("link.png");
        std::os::unix::fs::symlink("real.png", &link).unwrap_or_else(|e| panic!("{e}"));
        write_file(&link, b"new", &[]).unwrap_or_else(|e| panic!("{e}"));
        assert!(fs::symlink_metadata(&link).is_ok_and(|m| m.file_type().is_symlink()));
        assert_eq!(fs::read_to_string(&real).unwrap_or_default(), "new");
        let mode = fs::metadata(&real)
            .map(|m| m.permissions().mode() & 0o777)
            .unwrap_or(0);
        assert_eq!(mode, 0o600);
        assert!(leftovers(&dir).is_empty());
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_failure_before_the_rename_keeps_the_old_file_and_no_temporary() {
        let dir = scratch("fail");
        let path = dir.join("mesh.glb");
        fs::write(&path, "old").unwrap_or_else(|e| panic!("{e}"));
        let e = write_file_with(&path, b"new", &[], |_| Err(io::Error::other("injected")));
        assert!(e.is_err_and(|e| e.to_string().contains("injected")));
        assert_eq!(fs::read_to_string(&path).unwrap_or_default(), "old");
        assert!(leftovers(&dir).is_empty());
        let e = write_file(&dir, b"new", &[]);
        assert!(e.is_err_and(|e| e.to_string().contains("folder")));
        let mut read_only = fs::metadata(&path)
            .map(|m| m.permissions())
            .unwrap_or_else(|e| panic!("{e}"));
        read_only.set_readonly(true);
        fs::set_permissions(&path, read_only).unwrap_or_else(|e| panic!("{e}"));
        let e = write_file(&path, b"new", &[]);
        assert!(e.is_err_and(|e| e.to_string().contains("read-only")));
        assert_eq!(fs::read_to_string(&path).unwrap_or_default(), "old");
        let _ = fs::remove_dir_all(&dir);
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn a_device_is_written_in_place_and_its_error_reported() {
        let e = write_file(Path::new("/dev/full"), b"bytes", &[]);
        assert!(e.is_err_and(|e| e.to_string().contains("/dev/full")));
        assert!(fs::metadata("/dev/full").is_ok_and(|m| !m.is_file()));
        write_file(Path::new("/dev/null"), b"bytes", &[]).unwrap_or_else(|e| panic!("{e}"));
    }
}
