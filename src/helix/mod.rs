//! Helices: Ghosh interpolation, point relaxation, piecewise helices.
