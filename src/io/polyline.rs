//! Placeholder: being written.
use std::path::Path;
use super::{CurveReader, CurveWriter, IoError, Metadata};
pub fn open_json(path: &Path) -> Result<Box<dyn CurveReader>, IoError> {
    Err(IoError::new(path, "format not supported yet"))
}
pub fn create_json(path: &Path, _meta: &Metadata) -> Result<Box<dyn CurveWriter>, IoError> {
    Err(IoError::new(path, "format not supported yet"))
}
pub fn open_csv(path: &Path) -> Result<Box<dyn CurveReader>, IoError> {
    Err(IoError::new(path, "format not supported yet"))
}
pub fn create_csv(path: &Path, _meta: &Metadata) -> Result<Box<dyn CurveWriter>, IoError> {
    Err(IoError::new(path, "format not supported yet"))
}
