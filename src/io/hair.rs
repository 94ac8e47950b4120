//! Placeholder: being written.
use std::path::Path;
use super::{CurveReader, CurveWriter, IoError, Metadata};
pub fn open(path: &Path) -> Result<Box<dyn CurveReader>, IoError> {
    Err(IoError::new(path, "format not supported yet"))
}
pub fn create(path: &Path, _meta: &Metadata) -> Result<Box<dyn CurveWriter>, IoError> {
    Err(IoError::new(path, "format not supported yet"))
}
