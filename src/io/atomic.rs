//! Output written to a temporary file next to the target and renamed over it
//! only on [`AtomicFile::commit`]: a failed or interrupted run never leaves a
//! partial file and never clobbers an existing one. Dropping an uncommitted
//! `AtomicFile` deletes the temporary.

use std::io::{self, BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use super::IoError;

pub struct AtomicFile {
    target: PathBuf,
    writer: BufWriter<tempfile::NamedTempFile>,
}

impl AtomicFile {
    /// A temporary file in the directory of `target` (so that the final
    /// rename stays on one file system).
    pub fn create(target: &Path) -> Result<Self, IoError> {
        let dir = match target.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let temp = tempfile::Builder::new()
            .prefix(".strandfit-")
            .suffix(".tmp")
            .tempfile_in(&dir)
            .map_err(|e| IoError::os(target, "cannot create a temporary file next to it", e))?;
        Ok(AtomicFile {
            target: target.to_path_buf(),
            writer: BufWriter::with_capacity(1 << 20, temp),
        })
    }

    /// The final path.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Flush, sync and rename over the target.
    pub fn commit(self) -> Result<(), IoError> {
        let target = self.target;
        let temp = self
            .writer
            .into_inner()
            .map_err(|e| IoError::os(&target, "cannot write", e.into_error()))?;
        temp.as_file()
            .sync_all()
            .map_err(|e| IoError::os(&target, "cannot sync", e))?;
        temp.persist(&target).map_err(|e| {
            IoError::os(
                &target,
                "cannot rename the temporary file into place",
                e.error,
            )
        })?;
        Ok(())
    }

    /// An `IoError` about this file from an I/O error while writing.
    pub fn err(&self, e: io::Error) -> IoError {
        IoError::os(&self.target, "cannot write", e)
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.writer.write(buf)
    }
    fn write_all(&mut self, buf: &[u8]) -> io::Result<()> {
        self.writer.write_all(buf)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.writer.flush()
    }
}

impl Seek for AtomicFile {
    /// Seeking flushes the buffer first (`BufWriter`'s behaviour), so use it
    /// for the occasional header patch, not per value.
    fn seek(&mut self, pos: SeekFrom) -> io::Result<u64> {
        self.writer.seek(pos)
    }
}
