//! Errors of the distance functions.

/// Why a distance could not be computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum MetricsError {
    /// One of the point sequences was empty; no distance is defined.
    #[error("empty point sequence")]
    Empty,
    /// A coordinate was NaN or infinite. Checked up front because `f64::max`
    /// and `f64::min` silently drop NaN, which would give a plausible-looking
    /// but meaningless distance.
    #[error("non-finite coordinate in point sequence")]
    NonFinite,
}

/// Common input check: non-empty, all coordinates finite.
pub(crate) fn check(points: &[glam::DVec3]) -> Result<(), MetricsError> {
    if points.is_empty() {
        return Err(MetricsError::Empty);
    }
    if !points.iter().all(|p| p.is_finite()) {
        return Err(MetricsError::NonFinite);
    }
    Ok(())
}
