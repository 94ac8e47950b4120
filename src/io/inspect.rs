//! Summary statistics of a curve file, accumulated while streaming: counts,
//! points per curve, arc lengths, step sizes, bounding box and the problems
//! a fit cares about (empty and one-point curves, repeated points).

use glam::DVec3;
use serde::Serialize;

use super::Curve;

/// Running statistics over the curves of one file.
#[derive(Clone, Debug, Serialize)]
pub struct CurveStats {
    /// Number of curves.
    #[serde(rename = "curve_count")]
    pub curves: u64,
    /// Number of points.
    #[serde(rename = "point_count")]
    pub points: u64,
    /// Points per curve: min, median, max (0 for an empty file).
    #[serde(rename = "point_count_min")]
    pub points_min: u64,
    /// Median points per curve.
    #[serde(rename = "point_count_median")]
    pub points_median: u64,
    /// Most points in a curve.
    #[serde(rename = "point_count_max")]
    pub points_max: u64,
    /// Sum, min and max of the polyline arc lengths.
    pub length_total: f64,
    /// Shortest polyline.
    pub length_min: f64,
    /// Longest polyline.
    pub length_max: f64,
    /// Mean distance between consecutive distinct points.
    pub step_mean: f64,
    /// Axis-aligned bounding box of all points (`None` if there are none).
    pub bbox: Option<[[f64; 3]; 2]>,
    /// Curves without points.
    #[serde(rename = "empty_curve_count")]
    pub empty_curves: u64,
    /// Curves of a single (possibly repeated) point.
    #[serde(rename = "single_point_curve_count")]
    pub single_point_curves: u64,
    /// Consecutive points that coincide exactly, over all curves.
    #[serde(rename = "repeated_point_count")]
    pub repeated_points: u64,
    #[serde(skip)]
    counts: Vec<u32>,
    #[serde(skip)]
    steps: u64,
}

impl Default for CurveStats {
    fn default() -> Self {
        CurveStats {
            curves: 0,
            points: 0,
            points_min: 0,
            points_median: 0,
            points_max: 0,
            length_total: 0.0,
            length_min: f64::INFINITY,
            length_max: 0.0,
            step_mean: 0.0,
            bbox: None,
            empty_curves: 0,
            single_point_curves: 0,
            repeated_points: 0,
            counts: Vec::new(),
            steps: 0,
        }
    }
}

impl CurveStats {
    /// Count one curve.
    ///
    /// ```
    /// use strandfit::io::{Curve, CurveStats};
    /// use strandfit::DVec3;
    ///
    /// let mut stats = CurveStats::default();
    /// stats.add(&Curve::from_points(vec![DVec3::ZERO, DVec3::X, DVec3::X, DVec3::new(1.0, 2.0, 0.0)]));
    /// assert_eq!((stats.curves, stats.points, stats.repeated_points), (1, 4, 1));
    /// assert!((stats.length_total - 3.0).abs() < 1e-12);
    /// assert_eq!(stats.bbox, Some([[0.0, 0.0, 0.0], [1.0, 2.0, 0.0]]));
    /// ```
    pub fn add(&mut self, c: &Curve) {
        let n = c.points.len();
        self.curves += 1;
        self.points += n as u64;
        self.counts.push(n.min(u32::MAX as usize) as u32);
        let mut length = 0.0;
        let mut distinct = 0u64;
        for w in c.points.windows(2) {
            let d = w[0].distance(w[1]);
            if d == 0.0 {
                self.repeated_points += 1;
            } else {
                distinct += 1;
                length += d;
            }
        }
        match n {
            0 => self.empty_curves += 1,
            _ if distinct == 0 => self.single_point_curves += 1,
            _ => {}
        }
        self.steps += distinct;
        self.length_total += length;
        self.length_min = self.length_min.min(length);
        self.length_max = self.length_max.max(length);
        for p in &c.points {
            let b = self.bbox.get_or_insert([p.to_array(), p.to_array()]);
            b[0] = DVec3::from_array(b[0]).min(*p).to_array();
            b[1] = DVec3::from_array(b[1]).max(*p).to_array();
        }
    }

    /// Complete the order statistics.
    ///
    /// ```
    /// use strandfit::io::{Curve, CurveStats};
    /// use strandfit::DVec3;
    ///
    /// let mut stats = CurveStats::default();
    /// for n in [2, 5, 3] {
    ///     stats.add(&Curve::from_points((0..n).map(|i| DVec3::new(i as f64, 0.0, 0.0)).collect()));
    /// }
    /// stats.finish();
    /// assert_eq!((stats.points_min, stats.points_median, stats.points_max), (2, 3, 5));
    /// assert!((stats.step_mean - 1.0).abs() < 1e-12); // 7 unit steps
    /// ```
    pub fn finish(&mut self) {
        if self.curves == 0 {
            self.length_min = 0.0;
            return;
        }
        self.counts.sort_unstable();
        self.points_min = self.counts[0] as u64;
        self.points_max = *self.counts.last().unwrap_or(&0) as u64;
        self.points_median = self.counts[self.counts.len() / 2] as u64;
        self.step_mean = if self.steps > 0 {
            self.length_total / self.steps as f64
        } else {
            0.0
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_lengths_and_problems() {
        let mut s = CurveStats::default();
        let p = |x: f64| DVec3::new(x, 0.0, 0.0);
        s.add(&Curve::from_points(vec![p(0.0), p(1.0), p(1.0), p(3.0)]));
        s.add(&Curve::from_points(vec![]));
        s.add(&Curve::from_points(vec![p(5.0), p(5.0)]));
        s.finish();
        assert_eq!((s.curves, s.points), (3, 6));
        assert_eq!((s.points_min, s.points_median, s.points_max), (0, 2, 4));
        assert_eq!(
            (s.empty_curves, s.single_point_curves, s.repeated_points),
            (1, 1, 2)
        );
        assert_eq!(
            (s.length_total, s.length_min, s.length_max),
            (3.0, 0.0, 3.0)
        );
        assert_eq!(s.step_mean, 1.5);
        assert_eq!(s.bbox, Some([[0.0, 0.0, 0.0], [5.0, 0.0, 0.0]]));
    }
}
