//! Codec probe, a developer tool (not an example of the library's use):
//! bytes, curve kinds, two-sided error and speed of the codec on one file,
//! block by block as the container would code it, with the ideal bits
//! spent on each field of the stream. Optional quantisation steps (as
//! multiples of the tolerance) override the defaults, to try other steps.
//!
//! `cargo run --release --example codec_probe -- FILE TOL [OFFSET LENGTH START FIRST SAGITTA]`
//! (`STRANDFIT_EFFORT=best` in the environment: `--effort best`)
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{bail, Context};
use glam::DVec3;
use strandfit::codec::{decode_block, encode_block_tallied, CodecParams, Steps, FIELDS};

const USAGE: &str = "usage: codec_probe FILE TOL [OFFSET LENGTH START FIRST SAGITTA]\n\
    FILE: any curve file strandfit reads; TOL: the two-sided tolerance;\n\
    the five steps (multiples of TOL) replace the defaults, all or none";

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if !matches!(args.len(), 2 | 7) {
        eprintln!("{USAGE}");
        return ExitCode::from(2);
    }
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("codec_probe: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn number(what: &str, s: &str) -> anyhow::Result<f64> {
    let x: f64 = s
        .parse()
        .with_context(|| format!("{what} {s:?} is not a number"))?;
    if !(x.is_finite() && x > 0.0) {
        bail!("{what} {s:?} is not a positive finite number");
    }
    Ok(x)
}

fn run(args: &[String]) -> anyhow::Result<()> {
    let path = std::path::Path::new(&args[0]);
    let tol = number("the tolerance", &args[1])?;
    let mut params = CodecParams::new(tol);
    // `STRANDFIT_EFFORT=best`: the encoder's look-ahead (`--effort best`).
    if std::env::var("STRANDFIT_EFFORT").is_ok_and(|v| v == "best") {
        params.effort = strandfit::codec::Effort::Best;
    }
    if args.len() == 7 {
        let names = ["offset", "length", "start", "first", "sagitta"];
        let v = names
            .iter()
            .zip(&args[2..7])
            .map(|(n, s)| number(&format!("the {n} step"), s))
            .collect::<anyhow::Result<Vec<f64>>>()?;
        params.steps = Steps {
            offset: v[0],
            length: v[1],
            start: v[2],
            first: v[3],
            sagitta: v[4],
        };
    }
    let (_, curves) = strandfit::io::read_all(path, None)?;
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
        let (b, t) = encode_block_tallied(chunk, &params, true)?;
        for (a, x) in tally.iter_mut().zip(t.context("no tally")?) {
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
        let back = decode_block(&b.bytes, chunk.len(), &params)?;
        dt_dec += t1.elapsed().as_secs_f64();
        for (a, q) in chunk.iter().zip(&back) {
            if a.is_empty() {
                continue;
            }
            let q32: Vec<DVec3> = q.iter().map(|p| p.as_vec3().as_dvec3()).collect();
            let h = strandfit::metrics::hausdorff(a, &q32)?;
            worst = worst.max(h);
            if h > tol {
                over += 1;
            }
        }
    }
    println!(
        "{} T={tol}: {bytes} B ({:.3} bits/pt), kinds empty/points/arcs/raw {:?}, out pts {out_pts} ({:.2}x), worst {worst:.5}, over {over}, enc {:.2} Mpt/s, dec {:.1} Mpt/s(out)",
        path.file_name().unwrap_or(path.as_os_str()).to_string_lossy(), bytes as f64 * 8.0 / npts as f64, kinds,
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
    Ok(())
}
