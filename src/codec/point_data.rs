//! Per-point values carried onto the decoded points: `carry`
//! (`codec::carry_point_data`), whose documentation describes how.

use glam::DVec3;

/// Values (`width` per point, row-major) at each point of `output`,
/// interpolated from `values` on the polyline `input` at the nearest
/// location found walking forward. An empty `input` gives no values; a
/// one-point `input` gives its values everywhere.
///
/// The codec's output points are not the input's (an arc's samples, a
/// lattice point near each vertex), so a per-point value (a `.trk` scalar,
/// a TRX `dpv` array) is stored for each *output* point: the input's values
/// linearly interpolated at the point's nearest location on the input
/// polyline. The locations are found in one forward walk, since both
/// polylines run the same way within the tolerance of each other; the cost
/// is linear in the points of both.
///
/// ```
/// use strandfit::codec::carry_point_data;
/// use strandfit::DVec3;
///
/// // A line whose value is x: other points near it get their own x.
/// let input: Vec<DVec3> = (0..5).map(|k| DVec3::new(k as f64, 0.0, 0.0)).collect();
/// let values: Vec<f32> = (0..5).map(|k| k as f32).collect();
/// let output = [
///     DVec3::new(0.5, 0.01, 0.0),
///     DVec3::new(2.25, -0.01, 0.0),
///     DVec3::new(4.0, 0.0, 0.01),
/// ];
/// assert_eq!(carry_point_data(&input, &values, 1, &output), vec![0.5, 2.25, 4.0]);
/// // No input, no values; a one-point input's values everywhere.
/// assert!(carry_point_data(&[], &[], 1, &output).is_empty());
/// assert_eq!(carry_point_data(&input[..1], &[7.0], 1, &output), vec![7.0; 3]);
/// ```
///
/// Through the codec:
///
/// ```
/// use std::path::Path;
/// use strandfit::codec::{compress_to_bytes, read_range, CodecHeader, CodecReader};
/// use strandfit::io::{Curve, Format, Metadata, SourceMeta, VecReader};
/// use strandfit::DVec3;
///
/// // A helix whose one per-point value is its height z, compressed to 0.01:
/// // each decoded point's value is the height there, to the tolerance.
/// let points: Vec<DVec3> = (0..60).map(|i| 0.2 * i as f64).map(|s| DVec3::new(s.cos(), s.sin(), 0.1 * s)).collect();
/// let point_data: Vec<f32> = points.iter().map(|p| p.z as f32).collect();
/// let mut meta = Metadata::new(Format::Json);
/// meta.point_data_names = vec!["z".into()];
/// let header = CodecHeader::new(0.01, SourceMeta::from_metadata(&meta, None), vec!["z".into()]);
/// let curve = Curve { point_data, ..Curve::from_points(points) };
/// let bytes = compress_to_bytes(&mut VecReader::new(meta, vec![curve]), Path::new("in.json"), &header, None).unwrap();
/// let back = read_range(&mut CodecReader::from_bytes(bytes).unwrap(), 0, 1).unwrap().remove(0);
/// assert_eq!(back.point_data.len(), back.points.len());
/// for (p, &z) in back.points.iter().zip(&back.point_data) {
///     assert!((p.z - z as f64).abs() <= 0.011, "{} vs {z}", p.z);
/// }
/// ```
pub fn carry(input: &[DVec3], values: &[f32], width: usize, output: &[DVec3]) -> Vec<f32> {
    debug_assert_eq!(values.len(), input.len() * width);
    let mut out = Vec::with_capacity(output.len() * width);
    if width == 0 || input.is_empty() {
        return out;
    }
    if input.len() == 1 {
        for _ in output {
            out.extend_from_slice(&values[..width]);
        }
        return out;
    }
    let segments = input.len() - 1;
    // Segment and parameter of the previous output point's location.
    let mut seg = 0usize;
    let mut previous: Option<DVec3> = None;
    for &q in output {
        // Search ahead as far as the output has moved (twice, and twice the
        // distance to the input, for the slack between the two polylines),
        // and at least eight segments (an input that zigzags within the
        // tolerance is longer than the output across it).
        let moved = previous.map_or(0.0, |p| p.distance(q));
        let (mut best_seg, mut best_t, mut best_d) = (seg, 0.0, f64::INFINITY);
        let mut ahead = 0.0;
        let mut k = seg;
        while k < segments {
            let (t, d) = nearest_on_segment(q, input[k], input[k + 1]);
            if d < best_d {
                (best_seg, best_t, best_d) = (k, t, d);
            }
            ahead += input[k].distance(input[k + 1]);
            if ahead > 2.0 * moved + 2.0 * best_d.sqrt() && k >= seg + 8 {
                break;
            }
            k += 1;
        }
        seg = best_seg;
        previous = Some(q);
        let (a, b) = (
            &values[seg * width..][..width],
            &values[(seg + 1) * width..][..width],
        );
        let t = best_t as f32;
        out.extend(
            a.iter()
                .zip(b)
                .map(|(&x, &y)| if t == 0.0 { x } else { x + (y - x) * t }),
        );
    }
    out
}

/// Parameter in `[0, 1]` of the point of segment `ab` nearest to `q`, and
/// the squared distance to it.
fn nearest_on_segment(q: DVec3, a: DVec3, b: DVec3) -> (f64, f64) {
    let d = b - a;
    let l2 = d.length_squared();
    let t = if l2 > 0.0 {
        ((q - a).dot(d) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (t, (a + d * t).distance_squared(q))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_follow_the_curve_onto_other_points() {
        // A line with the value equal to the arc length, 10 vertices.
        let input: Vec<DVec3> = (0..10).map(|k| DVec3::new(k as f64, 0.0, 0.0)).collect();
        let values: Vec<f32> = (0..10).flat_map(|k| [k as f32, -2.0 * k as f32]).collect();
        // Output points slightly off the line, denser and sparser.
        let output: Vec<DVec3> = [0.0, 0.25, 3.5, 3.6, 8.9, 9.0]
            .iter()
            .map(|&x| DVec3::new(x, 0.05, -0.05))
            .collect();
        let got = carry(&input, &values, 2, &output);
        assert_eq!(got.len(), 12);
        for (k, o) in output.iter().enumerate() {
            assert!(
                (got[2 * k] as f64 - o.x).abs() < 1e-6,
                "{k}: {}",
                got[2 * k]
            );
            assert!((got[2 * k + 1] as f64 + 2.0 * o.x).abs() < 1e-5);
        }
        // Identity: the input's own points get the input's own values.
        assert_eq!(carry(&input, &values, 2, &input), values);
    }

    #[test]
    fn a_curve_that_comes_back_near_itself_is_followed_not_jumped() {
        // A hairpin: out along y = 0, back along y = 0.3. The way back must
        // take the values of the way back although the way out is as near.
        let mut input: Vec<DVec3> = (0..=10).map(|k| DVec3::new(k as f64, 0.0, 0.0)).collect();
        input.extend((0..=10).rev().map(|k| DVec3::new(k as f64, 0.3, 0.0)));
        let values: Vec<f32> = (0..input.len()).map(|k| k as f32).collect();
        let output: Vec<DVec3> = input
            .iter()
            .step_by(3)
            .map(|p| *p + DVec3::new(0.0, 0.1, 0.0))
            .collect();
        let got = carry(&input, &values, 1, &output);
        for w in got.windows(2) {
            assert!(w[1] > w[0], "values run backwards: {got:?}");
        }
    }

    #[test]
    fn degenerate_inputs() {
        assert!(carry(&[], &[], 1, &[DVec3::ZERO]).is_empty());
        let one = [DVec3::ONE];
        assert_eq!(
            carry(&one, &[7.0], 1, &[DVec3::ZERO, DVec3::X]),
            vec![7.0, 7.0]
        );
        assert!(carry(&one, &[], 0, &[DVec3::ZERO]).is_empty());
    }
}
