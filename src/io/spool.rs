//! Scratch files for writers whose format puts counts (or whole arrays)
//! before the data they describe (VTK `POINTS n`, `.hair` arrays laid out by
//! attribute): the data is spooled to an unnamed temporary file next to the
//! target while curves stream in, then copied into the output at `finish`.
//! Memory stays bounded; the spool disappears when dropped, even on a crash.

use std::fs::File;
use std::io::{BufReader, BufWriter, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use super::IoError;

pub(crate) struct Spool {
    target: PathBuf,
    w: BufWriter<File>,
}

impl Spool {
    /// An empty spool in the directory of `target` (same file system as the
    /// output, so a spool never fills a small `/tmp`).
    pub(crate) fn new(target: &Path) -> Result<Self, IoError> {
        let dir = match target.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let file = tempfile::tempfile_in(&dir)
            .map_err(|e| IoError::os(target, "cannot create a spool file next to it", e))?;
        Ok(Spool {
            target: target.to_path_buf(),
            w: BufWriter::with_capacity(1 << 16, file),
        })
    }

    pub(crate) fn write(&mut self, bytes: &[u8]) -> Result<(), IoError> {
        self.w
            .write_all(bytes)
            .map_err(|e| IoError::os(&self.target, "cannot write the spool file", e))
    }

    /// The spooled bytes from the start.
    pub(crate) fn into_reader(self) -> Result<BufReader<File>, IoError> {
        let target = self.target;
        let mut file = self
            .w
            .into_inner()
            .map_err(|e| IoError::os(&target, "cannot write the spool file", e.into_error()))?;
        file.seek(SeekFrom::Start(0))
            .map_err(|e| IoError::os(&target, "cannot rewind the spool file", e))?;
        Ok(BufReader::with_capacity(1 << 16, file))
    }

    /// Copy everything spooled into `out`.
    pub(crate) fn copy_into(self, out: &mut impl Write) -> Result<u64, IoError> {
        let target = self.target.clone();
        let mut r = self.into_reader()?;
        std::io::copy(&mut r, out).map_err(|e| IoError::os(&target, "cannot write", e))
    }

    /// Feed the spooled bytes to `f` in chunks that are whole multiples of
    /// `unit` bytes (a value size), for re-encoding.
    pub(crate) fn for_each_chunk(
        self,
        unit: usize,
        mut f: impl FnMut(&[u8]) -> Result<(), IoError>,
    ) -> Result<(), IoError> {
        let target = self.target.clone();
        let mut r = self.into_reader()?;
        let unit = unit.max(1);
        let mut buf = vec![0u8; unit * (1 << 14)];
        let mut filled = 0;
        loop {
            let n = r
                .read(&mut buf[filled..])
                .map_err(|e| IoError::os(&target, "cannot read the spool file", e))?;
            filled += n;
            let whole = filled - filled % unit;
            if n == 0 || whole == buf.len() {
                f(&buf[..whole])?;
                buf.copy_within(whole..filled, 0);
                filled -= whole;
                if n == 0 {
                    return Ok(());
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chunks_are_whole_values_and_cover_everything() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out.bin");
        let mut s = Spool::new(&target).unwrap();
        // 3-byte values, more than one read buffer's worth, odd total.
        let data: Vec<u8> = (0..3 * 50_001u32).map(|i| (i % 251) as u8).collect();
        for piece in data.chunks(1000) {
            s.write(piece).unwrap();
        }
        let mut back = Vec::new();
        s.for_each_chunk(3, |c| {
            assert_eq!(c.len() % 3, 0);
            back.extend_from_slice(c);
            Ok(())
        })
        .unwrap();
        assert!(back == data);
        // Unnamed: nothing is left next to the target.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
}
