//! Placeholder: being written.
use super::{CurveReader, CurveWriter, IoError, Metadata};
use std::path::Path;
pub fn open(path: &Path) -> Result<Box<dyn CurveReader>, IoError> {
    Err(IoError::new(path, "format not supported yet"))
}
pub fn create(path: &Path, _meta: &Metadata) -> Result<Box<dyn CurveWriter>, IoError> {
    Err(IoError::new(path, "format not supported yet"))
}
