//! Compress a tractogram from code: read the fornix bundle bundled with the
//! tests (300 streamlines, MRtrix `.tck`), compress it in memory with the
//! arc codec, decompress it, and check that every streamline came back
//! within the tolerance in the two-sided Hausdorff distance.
//!
//! `cargo run --example compress_tractogram [-- FILE.tck TOLERANCE]`

use std::error::Error;
use std::path::PathBuf;

use strandfit::metrics::hausdorff;
use strandfit::{compress_polylines, decompress_polylines, Backend, DVec3, Polylines};

fn main() -> Result<(), Box<dyn Error>> {
    run(std::env::args().skip(1).collect())
}

/// The example on `args` (none: the bundled fornix at 0.1 mm).
pub fn run(args: Vec<String>) -> Result<(), Box<dyn Error>> {
    let mut args = args.into_iter();
    let (path, tolerance) = match (args.next(), args.next()) {
        (Some(p), Some(t)) => (PathBuf::from(p), t.parse()?),
        _ => (
            PathBuf::from(env!("CARGO_MANIFEST_DIR"))
                .join("tests/data/fibres/dipy_fornix_tracks300.tck"),
            0.1, // mm
        ),
    };

    // Any supported format (TCK, TRK, TRX, VTK, …), told by its extension.
    let (_meta, curves) = strandfit::io::read_all(&path, None)?;
    let mut positions: Vec<DVec3> = Vec::new();
    let mut offsets = vec![0];
    for c in &curves {
        positions.extend_from_slice(&c.points);
        offsets.push(positions.len());
    }
    let input = Polylines::new(&positions, &offsets)?;

    let bytes = compress_polylines(input, tolerance, &Backend::Cpu)?;
    let (decoded, decoded_offsets) = decompress_polylines(&bytes)?;
    let output = Polylines::new(&decoded, &decoded_offsets)?;
    assert_eq!(output.len(), input.len());

    let mut worst = 0.0f64;
    for (a, b) in input.iter().zip(output.iter()) {
        worst = worst.max(hausdorff(a, b)?);
    }
    let raw = positions.len() * 3 * 4; // as float32, the usual on-disk size
    println!(
        "{}: {} streamlines, {} points; {} bytes as f32, {} compressed (ratio {:.1}); \
         {} points decoded; worst two-sided Hausdorff distance {worst:.4} (tolerance {tolerance})",
        path.display(),
        input.len(),
        positions.len(),
        raw,
        bytes.len(),
        raw as f64 / bytes.len() as f64,
        decoded.len(),
    );
    if worst > tolerance {
        return Err(format!("distance {worst} exceeds the tolerance {tolerance}").into());
    }
    Ok(())
}
