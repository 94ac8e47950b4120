//! Curve distances and complexity.
