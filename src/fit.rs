//! The floating tangents pipeline: spline → N-element G1 piecewise helix.
