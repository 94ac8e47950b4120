//! `strandfit decompress IN.sfh -o OUT`: the container's helices back to
//! polylines in any supported format, in the source's coordinate convention
//! (the writer gets the source's affine and header back).

use anyhow::{bail, Result};

use super::inspect_cmd::parse_format;
use super::io_util::{check_losses, write_failed};
use super::usage;
use super::DecompressArgs;
use crate::io::{create_writer, ContainerReader, Curve, Format, Shape};

pub fn run(args: &DecompressArgs) -> Result<()> {
    if let Some(s) = args.step {
        if !(s > 0.0 && s.is_finite()) {
            usage!("--step must be positive, got {s}");
        }
    }
    if matches!(args.points, Some(m) if m < 2) {
        usage!("--points must be at least 2");
    }
    let to = args.to.as_deref().map(parse_format).transpose()?;
    if crate::codec::container_version(&args.input).is_some_and(|v| v >= 2) {
        return run_codec(args, to);
    }
    let reader = ContainerReader::open(&args.input)?;
    if args.curves.is_some() {
        bail!(
            "{}: --curves reads version-3 containers (blocks and an index); this is a \
             version-1 container",
            args.input.display()
        );
    }
    let mut writer = output_writer(args, to, &reader.header().source.to_metadata())?;
    let mut n = 0u64;
    for c in reader {
        let c = c?;
        let points = shape_points(&c.shape, args.points, args.step, c.source_points);
        writer
            .write_curve(&Curve {
                id: c.id,
                points,
                point_data: Vec::new(),
                curve_data: c.curve_data,
            })
            .map_err(|e| write_failed(&args.input, n, &[], e))?;
        n += 1;
    }
    writer.finish()?;
    eprintln!(
        "{} -> {}: {n} curves",
        args.input.display(),
        args.output.display()
    );
    Ok(())
}

/// The chain of a stored curve, or its verbatim points, as points: `m`
/// samples equally spaced in arc length, or at `step` apart (both ends
/// included).
fn shape_points(
    shape: &Shape,
    m: Option<usize>,
    step: Option<f64>,
    source_points: u64,
) -> Vec<glam::DVec3> {
    match shape {
        Shape::Empty => Vec::new(),
        Shape::Points(p) => p.clone(),
        Shape::Chain(c) => sample_chain(
            &crate::helix::PiecewiseHelix::from_params(c),
            m,
            step,
            source_points,
        ),
        Shape::Quantized(q) => sample_chain(
            &crate::helix::PiecewiseHelix::from_params(&q.dequantize()),
            m,
            step,
            source_points,
        ),
    }
}

fn sample_chain(
    chain: &crate::helix::PiecewiseHelix,
    m: Option<usize>,
    step: Option<f64>,
    source_points: u64,
) -> Vec<glam::DVec3> {
    let m = match (m, step) {
        (Some(m), _) => m,
        (None, Some(s)) => ((chain.length() / s).ceil() as usize + 1).min(1 << 24),
        (None, None) => (source_points as usize).clamp(2, 1 << 24),
    };
    chain.sample(m.max(2))
}

/// The writer of the output, in the source's convention, after the check of
/// what the target format cannot hold (warned about, or an error with
/// `--strict`).
fn output_writer(
    args: &DecompressArgs,
    to: Option<Format>,
    meta: &crate::io::Metadata,
) -> Result<Box<dyn crate::io::CurveWriter>> {
    let target = match to {
        Some(f) => f,
        None => Format::from_path(&args.output)?,
    };
    check_losses(&args.input, &args.output, &target.losses(meta), args.strict)?;
    Ok(create_writer(&args.output, Some(target), meta)?)
}

/// A version-3 container: the codec's points (the guarantee's), or a
/// resampling of them when asked.
fn run_codec(args: &DecompressArgs, to: Option<Format>) -> Result<()> {
    use crate::codec::{decompress_range, CodecReader};

    let mut reader = CodecReader::open(&args.input)?;
    let header = reader.header().clone();
    if args.points.is_some() || args.step.is_some() {
        eprintln!(
            "warning: {}: resampling with --points/--step gives up the guarantee that every \
             curve is within {} of its input (it holds for the default points)",
            args.input.display(),
            header.tolerance
        );
    }
    let mut meta = header.source.to_metadata();
    meta.point_data_names = header.point_data_names.clone();
    let mut writer = output_writer(args, to, &meta)?;
    let (points, step) = (args.points, args.step);
    let width = header.point_data_names.len();
    let map =
        move |c: crate::codec::DecodedCurve| crate::codec::output_curve(c, points, step, width);
    let total = reader.curve_count();
    let range = match args.curves {
        None => 0..total,
        Some((a, b)) => a.unwrap_or(0).min(total)..b.unwrap_or(total).min(total),
    };
    let mut bar = super::io_util::DelayedBar::new(Some(range.end - range.start));
    let n = decompress_range(&mut reader, &mut *writer, &map, range.clone(), &mut |n| {
        bar.set(n)
    })
    .map_err(|e| anyhow::anyhow!("{e}"))?;
    bar.finish();
    writer.finish()?;
    if args.curves.is_some() {
        eprintln!(
            "{} -> {}: curves {}..{} of {total} ({n} curves; read {} of {} bytes)",
            args.input.display(),
            args.output.display(),
            range.start,
            range.end,
            reader.bytes_read(),
            reader.size()
        );
    } else {
        eprintln!(
            "{} -> {}: {n} curves",
            args.input.display(),
            args.output.display()
        );
    }
    Ok(())
}
