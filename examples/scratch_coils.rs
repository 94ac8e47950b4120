use glam::DVec2;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use strandfit::sketch::{lift_sketch, SketchOptions};
use strandfit::synthetic::synthetic_sketch;
fn gaussian(rng: &mut ChaCha8Rng) -> f64 {
    let u: f64 = rng.gen_range(f64::MIN_POSITIVE..1.0);
    let v: f64 = rng.gen();
    (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}
fn seg_dist(p: DVec2, a: DVec2, b: DVec2) -> f64 {
    let d = b - a;
    let t = ((p - a).dot(d) / d.length_squared()).clamp(0.0, 1.0);
    (p - a - t * d).length()
}
fn main() {
    let d = synthetic_sketch(500);
    let l: f64 = d.windows(2).map(|w| (w[1] - w[0]).length()).sum();
    let seed: u64 = std::env::args()
        .nth(1)
        .map(|s| s.parse().unwrap())
        .unwrap_or(3);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let sigma = 1e-3 * l;
    let x: Vec<DVec2> = d
        .iter()
        .map(|&p| p + sigma * DVec2::new(gaussian(&mut rng), gaussian(&mut rng)))
        .collect();
    let r = lift_sketch(&x, &SketchOptions::default()).unwrap();
    println!(
        "work {} resampled {} denoised {}",
        r.points_2d.len(),
        r.resampled,
        r.denoised
    );
    let dist = |p: DVec2| -> f64 {
        d.windows(2)
            .map(|w| seg_dist(p, w[0], w[1]))
            .fold(f64::MAX, f64::min)
    };
    let lo: usize = std::env::args()
        .nth(2)
        .map(|s| s.parse().unwrap())
        .unwrap_or(480);
    for k in (lo..(lo + 80).min(r.points_2d.len())).step_by(2) {
        let e = (r.points_2d[k] - r.points_2d[k - 1]).length() / sigma;
        print!("{k}:{:.1}({:.1}) ", dist(r.points_2d[k]) / sigma, e);
    }
    println!();
}
