//! Quantisation steps, all fractions of the tolerance `T`, and how the
//! error budget is split between fitting and quantisation.
//!
//! An element's end point is coded in the frame of its prediction: the
//! chord length along the predicted direction `u` (step `length_step`) and
//! the two perpendicular offsets (step `offset_step`). Only the
//! perpendicular offsets move the curve sideways; an error along `u` slides
//! the end along the curve, so its step can be coarser. Start points are on
//! a cubic grid (step `start_step`, error `≤ √3/2 · start_step`).
//!
//! The steps are stored in the container's header (as these fractions and
//! `T`), so a decoder needs nothing else.

use serde::{Deserialize, Serialize};

/// Steps as fractions of the tolerance.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Steps {
    /// Perpendicular end-point offsets and corner bulges.
    pub offset: f64,
    /// Chord lengths.
    pub length: f64,
    /// Start points (cubic grid).
    pub start: f64,
    /// Sagitta of the decoder's chords to its arcs.
    pub sagitta: f64,
    /// Grid of points-mode curves: just under `2/√3`, the largest step
    /// whose rounding moves a point by at most `T`.
    pub points: f64,
}

impl Default for Steps {
    /// Measured on the shared data (fornix, hair, field lines; offset and
    /// length steps 0.5/2.0, 0.8/1.6 and 1.1/1.1 tried): equal steps just
    /// under the grid's `2T/√3` are smallest everywhere. An end point then
    /// moves by at most `0.95 T`; the arcs between ends take what is left.
    fn default() -> Self {
        Steps {
            offset: 1.1,
            length: 1.1,
            start: 0.4,
            sagitta: 0.15,
            points: 1.1547,
        }
    }
}

/// Steps in the data's units for one tolerance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quantiser {
    pub offset: f64,
    pub length: f64,
    pub start: f64,
    pub sagitta: f64,
}

impl Quantiser {
    pub fn new(tolerance: f64, steps: Steps) -> Self {
        Quantiser {
            offset: steps.offset * tolerance,
            length: steps.length * tolerance,
            start: steps.start * tolerance,
            sagitta: steps.sagitta * tolerance,
        }
    }

    /// `round(x / step)` as an integer, or `None` when it is not finite or
    /// too large to code.
    pub fn index(x: f64, step: f64) -> Option<i64> {
        let k = (x / step).round();
        if k.is_finite() && k.abs() < (1u64 << super::entropy::MAX_BITS) as f64 {
            Some(k as i64)
        } else {
            None
        }
    }

    /// The index toward zero (`trunc`), a cheaper code within one step.
    pub fn index_toward_zero(x: f64, step: f64) -> Option<i64> {
        let k = (x / step).trunc();
        if k.is_finite() && k.abs() < (1u64 << super::entropy::MAX_BITS) as f64 {
            Some(k as i64)
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn indices_round_and_refuse_the_uncodable() {
        assert_eq!(Quantiser::index(0.74, 0.5), Some(1));
        assert_eq!(Quantiser::index(-0.76, 0.5), Some(-2));
        assert_eq!(Quantiser::index_toward_zero(-0.76, 0.5), Some(-1));
        assert_eq!(Quantiser::index(f64::NAN, 0.5), None);
        assert_eq!(Quantiser::index(1e30, 1e-9), None);
    }
}
