//! A binary reader that knows where it is: every short read becomes an
//! [`IoError`] naming the file, the byte offset and what was being read,
//! instead of a bare `UnexpectedEof`.

use std::fs::File;
use std::io::{BufRead, BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use super::IoError;

/// Byte order of binary values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Endian {
    Little,
    Big,
}

/// A buffered file with its path, length and current offset.
pub struct ByteSource {
    path: PathBuf,
    inner: BufReader<File>,
    pos: u64,
    len: u64,
}

impl ByteSource {
    pub fn open(path: &Path) -> Result<Self, IoError> {
        let file = File::open(path).map_err(|e| IoError::os(path, "cannot open", e))?;
        let len = file
            .metadata()
            .map_err(|e| IoError::os(path, "cannot stat", e))?
            .len();
        Ok(ByteSource {
            path: path.to_path_buf(),
            inner: BufReader::with_capacity(1 << 20, file),
            pos: 0,
            len,
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Current offset from the start of the file.
    pub fn pos(&self) -> u64 {
        self.pos
    }

    /// File length in bytes (at open time).
    pub fn len(&self) -> u64 {
        self.len
    }

    /// Bytes left after the current offset.
    pub fn remaining(&self) -> u64 {
        self.len.saturating_sub(self.pos)
    }

    /// An error at the current offset.
    pub fn error(&self, reason: impl Into<String>) -> IoError {
        IoError::new(&self.path, reason).at(format!("byte {}", self.pos))
    }

    /// Fill `buf`, or fail with "truncated" naming `what`.
    pub fn read_exact(&mut self, buf: &mut [u8], what: &str) -> Result<(), IoError> {
        match self.inner.read_exact(buf) {
            Ok(()) => {
                self.pos += buf.len() as u64;
                Ok(())
            }
            Err(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => Err(self.error(format!(
                "file truncated: it ends before the {} bytes of {what} ({} left)",
                buf.len(),
                self.remaining()
            ))),
            Err(e) => {
                Err(IoError::os(&self.path, "cannot read", e).at(format!("byte {}", self.pos)))
            }
        }
    }

    /// `N` bytes.
    pub fn array<const N: usize>(&mut self, what: &str) -> Result<[u8; N], IoError> {
        let mut b = [0u8; N];
        self.read_exact(&mut b, what)?;
        Ok(b)
    }

    pub fn u16(&mut self, e: Endian, what: &str) -> Result<u16, IoError> {
        let b = self.array::<2>(what)?;
        Ok(match e {
            Endian::Little => u16::from_le_bytes(b),
            Endian::Big => u16::from_be_bytes(b),
        })
    }

    pub fn u32(&mut self, e: Endian, what: &str) -> Result<u32, IoError> {
        let b = self.array::<4>(what)?;
        Ok(match e {
            Endian::Little => u32::from_le_bytes(b),
            Endian::Big => u32::from_be_bytes(b),
        })
    }

    pub fn i32(&mut self, e: Endian, what: &str) -> Result<i32, IoError> {
        Ok(self.u32(e, what)? as i32)
    }

    pub fn f32(&mut self, e: Endian, what: &str) -> Result<f32, IoError> {
        Ok(f32::from_bits(self.u32(e, what)?))
    }

    /// One text line (without the line ending), at most `max` bytes; `None`
    /// at the end of the file. A longer line or invalid UTF-8 is an error, so
    /// a binary file fed to a text reader fails fast.
    pub fn line(&mut self, max: usize) -> Result<Option<String>, IoError> {
        let mut buf = Vec::new();
        loop {
            let avail = self
                .inner
                .fill_buf()
                .map_err(|e| IoError::os(&self.path, "cannot read", e))?;
            if avail.is_empty() {
                if buf.is_empty() {
                    return Ok(None);
                }
                break;
            }
            let (take, done) = match avail.iter().position(|&b| b == b'\n') {
                Some(i) => (i + 1, true),
                None => (avail.len(), false),
            };
            if buf.len() + take > max + 2 {
                return Err(self.error(format!("a text line longer than {max} bytes")));
            }
            buf.extend_from_slice(&avail[..take]);
            self.inner.consume(take);
            self.pos += take as u64;
            if done {
                break;
            }
        }
        while matches!(buf.last(), Some(b'\n' | b'\r')) {
            buf.pop();
        }
        String::from_utf8(buf)
            .map(Some)
            .map_err(|_| self.error("a text line that is not UTF-8"))
    }

    /// Jump to `offset` (must lie within the file).
    pub fn seek_to(&mut self, offset: u64, what: &str) -> Result<(), IoError> {
        if offset > self.len {
            return Err(self.error(format!(
                "{what} at byte {offset} lies beyond the end of the file ({} bytes)",
                self.len
            )));
        }
        self.inner
            .seek(SeekFrom::Start(offset))
            .map_err(|e| IoError::os(&self.path, "cannot seek", e))?;
        self.pos = offset;
        Ok(())
    }
}
