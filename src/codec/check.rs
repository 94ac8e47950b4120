//! The encoder's acceptance test: two-sided, conservative, linear time.
//!
//! An element is accepted only if every input vertex it covers is within
//! `T` of the polyline the decoder will write for it, and every point the
//! decoder writes for it is within `T` of the input polyline. Both are
//! vertex-to-segment distances, the measure the codec promises
//! (`metrics::hausdorff`). Checking each element against a window of the
//! input makes the test stricter than the global one, never looser.
//!
//! Both polylines run along the same curve, so the nearest segment of a
//! point moves forward with it: the search starts at the segment that
//! answered for the previous point (enough where it is within the
//! tolerance) and looks a few segments either way. A distance found that
//! way is an upper bound of the true one, so a pass is always a true pass;
//! only when the local search fails is the whole window scanned. The
//! answer is therefore the exact one, whatever path the search took.

use glam::DVec3;

/// Squared distance from `p` to the segment `[a, b]`.
#[inline]
pub fn dist2_to_segment(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let d = b - a;
    let dd = d.length_squared();
    let w = p - a;
    let t = if dd > 0.0 {
        (w.dot(d) / dd).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (w - d * t).length_squared()
}

/// Whether every point of `points` is within `sqrt(tol2)` of the polyline
/// `poly` (a single point is a polyline of one point).
pub fn all_within(points: &[DVec3], poly: &[DVec3], tol2: f64) -> bool {
    match poly.len() {
        0 => return points.is_empty(),
        1 => return points.iter().all(|p| p.distance_squared(poly[0]) <= tol2),
        _ => {}
    }
    let segs = poly.len() - 1;
    let seg = |k: usize, p: DVec3| dist2_to_segment(p, poly[k], poly[k + 1]);
    let mut near = 0usize;
    for &p in points {
        // Any segment within the tolerance answers for `p` (the answer is
        // whether one exists, not which is nearest): the last point's
        // segment is tried first, and the walk is taken only past it.
        let mut best = seg(near, p);
        if best <= tol2 {
            continue;
        }
        // Walk forward while the next segment is nearer, then look one
        // back: along a curve the nearest segment moves forward.
        while near + 1 < segs {
            let d = seg(near + 1, p);
            if d > best {
                break;
            }
            best = d;
            near += 1;
        }
        if best > tol2 && near > 0 {
            let d = seg(near - 1, p);
            if d < best {
                best = d;
                near -= 1;
            }
        }
        if best > tol2 {
            // The local search missed: scan the whole window.
            for k in 0..segs {
                let d = seg(k, p);
                if d < best {
                    best = d;
                    near = k;
                }
            }
            if best > tol2 {
                return false;
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The exact answer by brute force.
    fn brute(points: &[DVec3], poly: &[DVec3], tol2: f64) -> bool {
        points.iter().all(|&p| {
            if poly.len() == 1 {
                return p.distance_squared(poly[0]) <= tol2;
            }
            poly.windows(2)
                .map(|w| dist2_to_segment(p, w[0], w[1]))
                .fold(f64::INFINITY, f64::min)
                <= tol2
        })
    }

    #[test]
    fn agrees_with_brute_force_on_random_wiggles() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for case in 0..2000 {
            let n = rng.gen_range(1..30);
            let m = rng.gen_range(1..30);
            let wig = |rng: &mut ChaCha8Rng, k: usize, n: usize| {
                let s = k as f64 / n.max(1) as f64 * 10.0;
                DVec3::new(
                    s,
                    (s * 1.3).sin() + rng.gen_range(-0.3..0.3),
                    rng.gen_range(-0.3..0.3),
                )
            };
            let a: Vec<DVec3> = (0..n).map(|k| wig(&mut rng, k, n)).collect();
            let b: Vec<DVec3> = (0..m).map(|k| wig(&mut rng, k, m)).collect();
            let tol: f64 = rng.gen_range(0.05..1.5);
            assert_eq!(
                all_within(&a, &b, tol * tol),
                brute(&a, &b, tol * tol),
                "case {case}"
            );
        }
    }
}
