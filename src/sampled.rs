//! The one output shape of every sampling operation: points along a curve
//! with their unit tangents. Spline sampling, helix-chain evaluation and
//! Euler-spiral sampling all produce it, on either backend.

use glam::DVec3;

/// Points and unit tangents of one sampled curve, in order along it
/// (`points.len() == tangents.len()`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SampledCurve {
    /// The points.
    pub points: Vec<DVec3>,
    /// Their unit tangents.
    pub tangents: Vec<DVec3>,
}

impl SampledCurve {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// `true` when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }
}
