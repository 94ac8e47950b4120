//! Codec probe: bytes, kinds and two-sided error of the codec on one file.
//!
//! `cargo run --release --example codec_probe -- FILE TOL [offset length start first sagitta]`
use std::time::Instant;

use glam::DVec3;
use strandfit::codec::{decode_block, encode_block_tallied, quantise::Steps, CodecParams, FIELDS};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = std::path::Path::new(&args[1]);
    let tol: f64 = args[2].parse().unwrap();
    let mut params = CodecParams::new(tol);
    if args.len() >= 8 {
        let v: Vec<f64> = args[3..8].iter().map(|s| s.parse().unwrap()).collect();
        params.steps = Steps {
            offset: v[0],
            length: v[1],
            start: v[2],
            first: v[3],
            sagitta: v[4],
        };
    }
    let (_, curves) = strandfit::io::read_all(path, None).unwrap();
    let curves: Vec<Vec<DVec3>> = curves.into_iter().map(|c| c.points).collect();
    let npts: usize = curves.iter().map(|c| c.len()).sum();
    let t0 = Instant::now();
    let mut bytes = 0;
    let mut kinds = [0usize; 4];
    let mut out_pts = 0;
    let mut elements = 0;
    let mut worst = 0f64;
    let mut over = 0;
    let mut dt_dec = 0.0;
    let mut blocks = Vec::new();
    let mut tally = vec![0.0; FIELDS.len()];
    for chunk in curves.chunks(4096) {
        let (b, t) = encode_block_tallied(chunk, &params, true).unwrap();
        for (a, x) in tally.iter_mut().zip(t.unwrap()) {
            *a += x;
        }
        bytes += b.bytes.len();
        for k in &b.kinds {
            kinds[*k as usize] += 1;
        }
        out_pts += b.output_points;
        elements += b.elements;
        blocks.push((b, chunk));
    }
    let dt_enc = t0.elapsed().as_secs_f64();
    for (b, chunk) in &blocks {
        let t1 = Instant::now();
        let back = decode_block(&b.bytes, chunk.len(), &params).unwrap();
        dt_dec += t1.elapsed().as_secs_f64();
        for (a, q) in chunk.iter().zip(&back) {
            if a.is_empty() {
                continue;
            }
            let q32: Vec<DVec3> = q.iter().map(|p| p.as_vec3().as_dvec3()).collect();
            let h = strandfit::metrics::hausdorff(a, &q32).unwrap();
            worst = worst.max(h);
            if h > tol {
                over += 1;
            }
        }
    }
    println!(
        "{} T={tol}: {bytes} B ({:.3} bits/pt), kinds empty/points/arcs/raw {:?}, out pts {out_pts} ({:.2}x), worst {worst:.5}, over {over}, enc {:.2} Mpt/s, dec {:.1} Mpt/s(out)",
        path.file_name().unwrap().to_string_lossy(), bytes as f64 * 8.0 / npts as f64, kinds,
        out_pts as f64 / npts as f64, npts as f64 / dt_enc / 1e6, out_pts as f64 / dt_dec / 1e6
    );
    println!(
        "  {elements} arc elements ({:.2} input points each)",
        npts as f64 / elements.max(1) as f64
    );
    let total: f64 = tally.iter().sum();
    for (name, bits) in FIELDS.iter().zip(&tally) {
        if *bits > 0.0 {
            println!(
                "  {name:>16}: {:>10.0} B {:>5.1} %",
                bits / 8.0,
                100.0 * bits / total
            );
        }
    }
}
