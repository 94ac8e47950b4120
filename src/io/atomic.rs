//! Atomic output files: see `AtomicFile` and `remove_unfinished_outputs`.

use std::io::{self, BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use super::IoError;

/// Temporary files of outputs not yet committed, for
/// [`remove_unfinished_outputs`].
static UNFINISHED: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn unfinished() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    // A panic while the lock was held leaves a list that is still valid.
    UNFINISHED.lock().unwrap_or_else(|e| e.into_inner())
}

/// Delete the temporary files of every output not yet committed; returns
/// how many were deleted. For a signal handler or a panic hook: the process
/// is about to end without running destructors, and must leave nothing
/// behind. Committed outputs and the files they replace are untouched.
///
/// ```
/// use std::io::Write;
/// use strandfit::io::{remove_unfinished_outputs, AtomicFile};
///
/// let path = std::env::temp_dir().join(format!("strandfit-doc-unfinished-{}.txt", std::process::id()));
/// let mut out = AtomicFile::create(&path).unwrap();
/// out.write_all(b"half").unwrap();
/// assert_eq!(remove_unfinished_outputs(), 1); // the temporary, gone
/// assert!(!path.exists());
/// assert!(out.commit().is_err()); // nothing left to rename
/// ```
pub fn remove_unfinished_outputs() -> usize {
    unfinished()
        .drain(..)
        .filter(|p| std::fs::remove_file(p).is_ok())
        .count()
}

/// The file a write to `target` should replace: `target` itself, or the
/// end of its chain of symbolic links. Refuses anything that exists and is
/// not a regular file.
fn resolve_target(target: &Path) -> Result<PathBuf, IoError> {
    let mut path = target.to_path_buf();
    for _ in 0..40 {
        let md = match std::fs::symlink_metadata(&path) {
            Ok(md) => md,
            Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(path),
            Err(e) => return Err(IoError::os(target, "cannot inspect the output path", e)),
        };
        let ft = md.file_type();
        if ft.is_symlink() {
            let link = std::fs::read_link(&path)
                .map_err(|e| IoError::os(target, "cannot read the symbolic link", e))?;
            path = match path.parent() {
                Some(dir) => dir.join(link),
                None => link,
            };
            continue;
        }
        if ft.is_file() {
            return Ok(path);
        }
        let what = if ft.is_dir() {
            "a directory"
        } else {
            "not a regular file (a device, FIFO or socket)"
        };
        let via = if path != target {
            format!(" (the link leads to {})", path.display())
        } else {
            String::new()
        };
        return Err(IoError::new(
            target,
            format!("the output is {what}{via}; strandfit writes regular files only and will not replace it"),
        ));
    }
    Err(IoError::new(
        target,
        "too many levels of symbolic links in the output path",
    ))
}

/// A file written under a temporary name and moved into place by `commit`, so that readers never see a partial output.
///
/// Output is written to a temporary file next to the target and renamed over
/// it only on [`AtomicFile::commit`]: a failed or interrupted run never leaves a
/// partial file and never clobbers an existing one. Dropping an uncommitted
/// `AtomicFile` deletes the temporary, and so does
/// [`remove_unfinished_outputs`], which a program calls from its signal
/// handler or panic hook (the command line does, for SIGINT, SIGTERM and
/// SIGHUP), since a process killed by a signal runs no destructors.
///
/// What is replaced, and how:
/// - a symbolic link is followed: its target is written, the link stays;
/// - an existing regular file keeps its permissions;
/// - a new file gets `0o666` less the umask, as `touch` or `cp` would give;
/// - anything else (a directory, a device such as `/dev/full`, a FIFO, a
///   socket) is refused: it would be replaced by a regular file.
pub struct AtomicFile {
    /// The path the user named (for messages).
    target: PathBuf,
    /// The regular file that is replaced (the end of `target`'s links).
    destination: PathBuf,
    /// The temporary's path, as registered in `UNFINISHED`.
    temp_path: PathBuf,
    /// `None` once committed.
    writer: Option<BufWriter<tempfile::NamedTempFile>>,
    /// Bytes written since the kernel was last asked to start writing the
    /// file back ([`WRITEBACK_EVERY`]).
    unsent: u64,
}

/// Bytes after which the kernel is asked to start writing the temporary
/// back to disk (Linux `sync_file_range`, without waiting): otherwise a
/// large output waits in the page cache until the commit's `fsync`, which
/// for 600 MB of decompressed streamlines was a tenth of the run; started
/// early, the disk writes while the codec works. Every 32 MB left the last
/// part of a 59 MB output to the `fsync` (12 ms of a 0.25 s decompress);
/// every 4 MB, 1.6 ms.
const WRITEBACK_EVERY: u64 = 4 << 20;

impl AtomicFile {
    /// A temporary file in the directory of `target` (so that the final
    /// rename stays on one file system).
    ///
    /// A directory is not replaced:
    ///
    /// ```
    /// use strandfit::io::AtomicFile;
    ///
    /// let err = AtomicFile::create(&std::env::temp_dir()).err().unwrap();
    /// assert!(err.reason.starts_with("the output is a directory"));
    /// ```
    pub fn create(target: &Path) -> Result<Self, IoError> {
        let destination = resolve_target(target)?;
        let dir = match destination.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let existing = std::fs::metadata(&destination)
            .ok()
            .map(|m| m.permissions());
        let mut builder = tempfile::Builder::new();
        builder.prefix(".strandfit-").suffix(".tmp");
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            // Open applies the umask, as for any new file.
            builder.permissions(std::fs::Permissions::from_mode(0o666));
        }
        let temp = builder.tempfile_in(&dir).map_err(|e| {
            IoError::os(
                target,
                "cannot create a temporary file in the output's folder",
                e,
            )
        })?;
        if let Some(perm) = existing {
            // Replacing a file keeps its mode (no umask: it is the file's own).
            let _ = temp.as_file().set_permissions(perm);
        }
        let temp_path = temp.path().to_path_buf();
        unfinished().push(temp_path.clone());
        Ok(AtomicFile {
            target: target.to_path_buf(),
            destination,
            temp_path,
            writer: Some(BufWriter::with_capacity(1 << 20, temp)),
            unsent: 0,
        })
    }

    /// The final path.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Flush, sync and rename over the target.
    ///
    /// The target appears, whole, only at the commit:
    ///
    /// ```
    /// use std::io::Write;
    /// use strandfit::io::AtomicFile;
    ///
    /// let path = std::env::temp_dir().join(format!("strandfit-doc-commit-{}.txt", std::process::id()));
    /// let mut out = AtomicFile::create(&path).unwrap();
    /// out.write_all(b"all or nothing").unwrap();
    /// assert!(!path.exists());
    /// out.commit().unwrap();
    /// assert_eq!(std::fs::read_to_string(&path).unwrap(), "all or nothing");
    /// std::fs::remove_file(&path).unwrap();
    /// ```
    pub fn commit(mut self) -> Result<(), IoError> {
        let Some(writer) = self.writer.take() else {
            return Err(IoError::new(&self.target, "output already committed"));
        };
        let temp = writer
            .into_inner()
            .map_err(|e| IoError::os(&self.target, "cannot write", e.into_error()))?;
        temp.as_file()
            .sync_all()
            .map_err(|e| IoError::os(&self.target, "cannot write", e))?;
        // On failure the temporary is deleted by NamedTempFile's drop; on
        // success it has become the destination. Either way `Drop` below
        // takes it off the unfinished list.
        temp.persist(&self.destination).map_err(|e| {
            IoError::os(
                &self.target,
                "cannot rename the temporary file into place",
                e.error,
            )
        })?;
        Ok(())
    }

    fn writer(&mut self) -> io::Result<&mut BufWriter<tempfile::NamedTempFile>> {
        self.writer
            .as_mut()
            .ok_or_else(|| io::Error::other("output already committed"))
    }

    /// Counts `n` bytes written, and every [`WRITEBACK_EVERY`] asks the
    /// kernel to start writing back what has reached the file (advice:
    /// the commit's `fsync` is what makes the file durable).
    fn sent(&mut self, n: usize) {
        self.unsent += n as u64;
        if self.unsent < WRITEBACK_EVERY {
            return;
        }
        self.unsent = 0;
        #[cfg(target_os = "linux")]
        if let Some(w) = &self.writer {
            use std::os::unix::io::AsRawFd;
            let fd = w.get_ref().as_file().as_raw_fd();
            // SAFETY: `fd` is the open temporary's descriptor, borrowed for
            // the call; offset 0 and length 0 mean the whole file.
            unsafe {
                libc::sync_file_range(fd, 0, 0, libc::SYNC_FILE_RANGE_WRITE);
            }
        }
    }

    /// An `IoError` about this file from an I/O error while writing.
    pub fn err(&self, e: io::Error) -> IoError {
        IoError::os(&self.target, "cannot write", e)
    }
}

impl Drop for AtomicFile {
    /// Committed, or not (then the temporary is deleted by
    /// `NamedTempFile`'s own drop, after this): off the unfinished list.
    fn drop(&mut self) {
        unfinished().retain(|p| p != &self.temp_path);
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let n = self.writer()?.write(buf)?;
        self.sent(n);
        Ok(n)
    }
    fn write_all(&mut self, buf: &[u8]) -> io::Result<()> {
        self.writer()?.write_all(buf)?;
        self.sent(buf.len());
        Ok(())
    }
    fn flush(&mut self) -> io::Result<()> {
        self.writer()?.flush()
    }
}

impl Seek for AtomicFile {
    /// Seeking flushes the buffer first (`BufWriter`'s behaviour), so use it
    /// for the occasional header patch, not per value.
    fn seek(&mut self, pos: SeekFrom) -> io::Result<u64> {
        self.writer()?.seek(pos)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(target: &Path, text: &str) -> Result<(), IoError> {
        let mut f = AtomicFile::create(target)?;
        f.write_all(text.as_bytes()).map_err(|e| f.err(e))?;
        f.commit()
    }

    #[test]
    fn a_large_output_is_written_whole_past_the_early_writebacks() {
        // Past WRITEBACK_EVERY twice (the kernel asked to start writing
        // back on the way): every byte arrives, in order, only at commit.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.bin");
        let chunk = |k: u64| -> Vec<u8> { (0..1u64 << 20).map(|i| (i * 31 + k) as u8).collect() };
        let chunks = 2 * (WRITEBACK_EVERY >> 20) + 3;
        let mut f = AtomicFile::create(&path).unwrap();
        for k in 0..chunks {
            let c = chunk(k);
            if k % 2 == 0 {
                f.write_all(&c).unwrap();
            } else {
                let mut rest = &c[..];
                while !rest.is_empty() {
                    let n = f.write(rest).unwrap();
                    rest = &rest[n..];
                }
            }
        }
        assert!(!path.exists());
        f.commit().unwrap();
        let back = std::fs::read(&path).unwrap();
        assert_eq!(back.len() as u64, chunks << 20);
        for k in 0..chunks {
            let at = (k << 20) as usize;
            assert!(back[at..at + (1 << 20)] == chunk(k)[..], "chunk {k}");
        }
    }

    #[cfg(unix)]
    #[test]
    fn a_symlink_is_followed_and_kept() {
        let dir = tempfile::tempdir().unwrap();
        let real = dir.path().join("real.txt");
        let link = dir.path().join("link.txt");
        std::fs::write(&real, "old").unwrap();
        std::os::unix::fs::symlink("real.txt", &link).unwrap();
        write(&link, "new").unwrap();
        assert!(std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink());
        assert_eq!(std::fs::read_to_string(&real).unwrap(), "new");
        // A dangling link: its target is created.
        let dangling = dir.path().join("dangling.txt");
        std::os::unix::fs::symlink("made.txt", &dangling).unwrap();
        write(&dangling, "made").unwrap();
        assert_eq!(
            std::fs::read_to_string(dir.path().join("made.txt")).unwrap(),
            "made"
        );
    }

    #[cfg(unix)]
    #[test]
    fn devices_and_directories_are_refused_not_replaced() {
        let dir = tempfile::tempdir().unwrap();
        let e = AtomicFile::create(Path::new("/dev/null")).err().unwrap();
        assert!(e.to_string().contains("not a regular file"), "{e}");
        assert!(
            !std::fs::metadata("/dev/null").unwrap().is_file(),
            "still the device"
        );
        let e = AtomicFile::create(dir.path()).err().unwrap();
        assert!(e.to_string().contains("is a directory"), "{e}");
        // Through a link, the message says where it leads.
        let link = dir.path().join("to_null");
        std::os::unix::fs::symlink("/dev/null", &link).unwrap();
        let e = AtomicFile::create(&link).err().unwrap();
        assert!(e.to_string().contains("/dev/null"), "{e}");
        assert!(
            std::fs::read_dir(dir.path()).unwrap().count() == 1,
            "nothing left behind"
        );
    }

    #[cfg(unix)]
    #[test]
    fn new_files_get_0666_less_the_umask_and_old_ones_keep_their_mode() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        // The umask, read without changing it for other threads: a file
        // made by std (0o666 too) shows it.
        let probe = dir.path().join("probe");
        std::fs::write(&probe, "").unwrap();
        let want = std::fs::metadata(&probe).unwrap().permissions().mode() & 0o777;
        let new = dir.path().join("new.txt");
        write(&new, "x").unwrap();
        let mode = std::fs::metadata(&new).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, want, "{mode:o} vs {want:o}");
        assert_ne!(mode, 0o600, "not tempfile's private default");
        let old = dir.path().join("old.txt");
        std::fs::write(&old, "old").unwrap();
        std::fs::set_permissions(&old, std::fs::Permissions::from_mode(0o640)).unwrap();
        write(&old, "new").unwrap();
        assert_eq!(
            std::fs::metadata(&old).unwrap().permissions().mode() & 0o777,
            0o640
        );
    }
}
