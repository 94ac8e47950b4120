//! Rough timing of spline construction + equal-arc-length sampling.
//! Run with `cargo test --release --test spline_perf -- --ignored --nocapture`.

use std::hint::black_box;
use std::time::Instant;

use strandfit::spline::BezierSpline;
use strandfit::DVec3;

/// A 10-segment Hermite approximation of a helix with some wobble.
fn curve(seed: f64) -> Vec<DVec3> {
    let (r, c) = (1.0 + 0.1 * seed.sin(), 0.3);
    let p = |th: f64| DVec3::new(r * th.cos(), r * th.sin(), c * th + 0.05 * (3.0 * th).sin());
    let dp = |th: f64| {
        DVec3::new(-r * th.sin(), r * th.cos(), c + 0.15 * (3.0 * th).cos())
    };
    let n = 10;
    let h = 2.0 * std::f64::consts::TAU / n as f64;
    let mut pts = vec![p(0.0)];
    for i in 0..n {
        let (a, b) = (h * i as f64, h * (i + 1) as f64);
        pts.push(p(a) + h / 3.0 * dp(a));
        pts.push(p(b) - h / 3.0 * dp(b));
        pts.push(p(b));
    }
    pts
}

#[test]
#[ignore]
fn spline_build_and_sample_timing() {
    let curves: Vec<Vec<DVec3>> = (0..1000).map(|i| curve(i as f64)).collect();
    let s0 = BezierSpline::from_control_points(&curves[0]).unwrap();
    println!("panels for 10 segments: {}", s0.num_panels());
    let (mut ps, mut ts) = (Vec::new(), Vec::new());
    let reps = 20;
    let t = Instant::now();
    let mut splines = Vec::new();
    for _ in 0..reps {
        splines.clear();
        for c in &curves {
            splines.push(BezierSpline::from_control_points(black_box(c)).unwrap());
        }
    }
    let build = t.elapsed().as_secs_f64() / (reps * curves.len()) as f64;
    let t = Instant::now();
    for _ in 0..reps {
        for s in &splines {
            s.sample_equal_arclen_into(20, &mut ps, &mut ts).unwrap();
            black_box((&ps, &ts));
        }
    }
    let sample = t.elapsed().as_secs_f64() / (reps * curves.len()) as f64;
    println!("build: {:.2} µs/spline, sample N=20: {:.2} µs/spline", build * 1e6, sample * 1e6);
}
