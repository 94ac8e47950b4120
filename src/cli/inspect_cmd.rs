//! `strandfit inspect FILE`: what a curve file holds (format, header,
//! counts, lengths, sizes, problems), streamed, as text or `--json`.

use std::path::Path;

use anyhow::Result;
use serde_json::json;

use super::InspectArgs;
use crate::io::{open_reader, CurveStats, Format};

pub fn run(args: &InspectArgs) -> Result<()> {
    if let (Some(out), Some(source)) = (&args.preview, &args.source) {
        return preview(args, source, out);
    }
    if crate::codec::container_version(&args.input).is_some_and(|v| v >= 2) {
        return inspect_codec_container(args);
    }
    if crate::io::is_container(&args.input) {
        return inspect_container(args);
    }
    let format = args.from.as_deref().map(parse_format).transpose()?;
    let bytes = std::fs::metadata(&args.input)
        .map_err(|e| anyhow::anyhow!("{}: cannot stat: {e}", args.input.display()))?
        .len();
    let mut reader = open_reader(&args.input, format)?;
    let meta = reader.metadata().clone();
    let mut stats = CurveStats::default();
    let mut error = None;
    for c in reader.by_ref() {
        match c {
            Ok(c) => stats.add(&c),
            Err(e) => {
                error = Some(e);
                break;
            }
        }
    }
    stats.finish();
    let count_mismatch = match meta.count {
        Some(n) if error.is_none() && n != stats.curves => Some(n),
        _ => None,
    };
    if args.json {
        let mut report = json!({
            "version": super::JSON_VERSION,
            "input": args.input.display().to_string(),
            "format": meta.format.extension(),
            "bytes": bytes,
            "bytes_per_point": if stats.points > 0 { bytes as f64 / stats.points as f64 } else { 0.0 },
            "header_curve_count": meta.count,
            "units": meta.units,
            "vox_to_world": meta.vox_to_world.transpose().to_cols_array_2d(),
            "voxel_size": meta.voxel_size,
            "dimensions": meta.dimensions,
            "point_data_names": meta.point_data_names,
            "curve_data_names": meta.curve_data_names,
            "stats": stats,
        });
        with_failure(&mut report, error.as_ref());
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print_text(&args.input, bytes, &meta, &stats);
    }
    if let Some(n) = count_mismatch {
        eprintln!(
            "warning: {}: the header announces {n} curves, the file holds {}",
            args.input.display(),
            stats.curves
        );
    }
    match error {
        Some(e) => Err(anyhow::anyhow!(
            "{e} (after {} complete curves)",
            stats.curves
        )),
        None => Ok(()),
    }
}

/// The report's `"failure"`: why reading stopped (absent when it did not).
fn with_failure(report: &mut serde_json::Value, error: Option<&impl std::fmt::Display>) {
    if let Some(e) = error {
        report["failure"] = e.to_string().into();
    }
}

/// A `--from`/`--to` format name; an unknown one is a usage error.
pub fn parse_format(name: &str) -> Result<Format> {
    Format::from_name(name).ok_or_else(|| {
        anyhow::Error::new(super::UsageError(format!(
            "unknown format {name:?}; one of {}",
            Format::ALL.map(|f| f.extension()).join(", ")
        )))
    })
}

fn print_text(path: &Path, bytes: u64, meta: &crate::io::Metadata, s: &CurveStats) {
    let unit = meta.units.as_deref().unwrap_or("units");
    println!("{}: {} file, {bytes} bytes", path.display(), meta.format);
    if let Some(n) = meta.count {
        println!("  header count    {n}");
    }
    println!("  curves          {}", s.curves);
    println!(
        "  points          {} (per curve min {} / median {} / max {})",
        s.points, s.points_min, s.points_median, s.points_max
    );
    if s.points > 0 {
        println!("  bytes/point     {:.2}", bytes as f64 / s.points as f64);
    }
    println!(
        "  length          total {:.6e} {unit}, per curve min {:.6} / max {:.6}, mean step {:.6}",
        s.length_total, s.length_min, s.length_max, s.step_mean
    );
    if let Some(b) = s.bbox {
        println!("  bounding box    {:?} .. {:?}", b[0], b[1]);
    }
    if meta.voxel_size.is_some() || meta.vox_to_world != glam::DMat4::IDENTITY {
        println!(
            "  voxel size      {:?}, dimensions {:?}",
            meta.voxel_size, meta.dimensions
        );
        let m = meta.vox_to_world.transpose().to_cols_array_2d();
        println!("  vox_to_world    {:?}", m);
    }
    if !meta.point_data_names.is_empty() {
        println!("  per-point data  {}", meta.point_data_names.join(", "));
    }
    if !meta.curve_data_names.is_empty() {
        println!("  per-curve data  {}", meta.curve_data_names.join(", "));
    }
    println!(
        "  problems        {} empty, {} single-point curves, {} repeated consecutive points",
        s.empty_curves, s.single_point_curves, s.repeated_points
    );
}

/// Summary of a `.sfh` container: its header, and counts read from every
/// block (which also verifies every checksum).
fn inspect_container(args: &InspectArgs) -> Result<()> {
    use crate::io::{ContainerReader, Shape};
    let bytes = std::fs::metadata(&args.input)?.len();
    let mut reader = ContainerReader::open(&args.input)?;
    let header = reader.header().clone();
    let (mut curves, mut elements, mut verbatim, mut empty, mut source_points) =
        (0u64, 0u64, 0u64, 0u64, 0u64);
    let mut length = 0.0;
    let mut error = None;
    for c in reader.by_ref() {
        match c {
            Ok(c) => {
                curves += 1;
                source_points += c.source_points;
                match &c.shape {
                    Shape::Empty => empty += 1,
                    Shape::Points(_) => verbatim += 1,
                    Shape::Chain(ch) => {
                        elements += ch.elements.len() as u64;
                        length += ch.elements.iter().map(|e| e.length).sum::<f64>();
                    }
                    Shape::Quantized(_) => {}
                }
            }
            Err(e) => {
                error = Some(e);
                break;
            }
        }
    }
    if args.json {
        let mut report = json!({
            "version": super::JSON_VERSION,
            "input": args.input.display().to_string(),
            "format": "sfh",
            "container_version": 1,
            "bytes": bytes,
            "header": header,
            "curve_count": curves,
            "element_count": elements,
            "verbatim_count": verbatim,
            "empty_curve_count": empty,
            "source_point_count": source_points,
            "helix_length": length,
            "bytes_per_curve": if curves > 0 { bytes as f64 / curves as f64 } else { 0.0 },
        });
        with_failure(&mut report, error.as_ref());
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        println!(
            "{}: strandfit container, {bytes} bytes",
            args.input.display()
        );
        println!("  storage         {:?}, {}", header.storage, header.mode);
        println!(
            "  source          {} ({}), units {}",
            header.source.format,
            header.source.file.as_deref().unwrap_or("?"),
            header.source.units.as_deref().unwrap_or("unknown")
        );
        println!("  curves          {curves} ({verbatim} verbatim, {empty} empty), {source_points} source points");
        println!(
            "  elements        {elements} (mean {:.2} per curve), helix length {length:.6e}",
            elements as f64 / curves.max(1) as f64
        );
        println!(
            "  bytes/curve     {:.2}",
            bytes as f64 / curves.max(1) as f64
        );
        if !header.dropped_point_data.is_empty() {
            println!(
                "  dropped         per-point data {}",
                header.dropped_point_data.join(", ")
            );
        }
    }
    match error {
        Some(e) => Err(anyhow::anyhow!("{e} (after {curves} complete curves)")),
        None => Ok(()),
    }
}

/// Summary of a version-3 container: its header, and counts from decoding
/// every block (which also verifies every checksum).
fn inspect_codec_container(args: &InspectArgs) -> Result<()> {
    use crate::codec::CodecReader;
    let bytes = std::fs::metadata(&args.input)?.len();
    let mut reader = CodecReader::open(&args.input)?;
    let header = reader.header().clone();
    let path = args.input.clone();
    let (mut curves, mut points, mut empty) = (0u64, 0u64, 0u64);
    let mut error = None;
    for b in 0..reader.block_count() {
        match reader
            .read_block_bytes(b)
            .and_then(|raw| raw.decode(&path, &header))
        {
            Ok(cs) => {
                for c in cs {
                    curves += 1;
                    points += c.points.len() as u64;
                    empty += c.points.is_empty() as u64;
                }
            }
            Err(e) => {
                error = Some(e);
                break;
            }
        }
    }
    if args.json {
        let mut report = json!({
            "version": super::JSON_VERSION,
            "input": args.input.display().to_string(),
            "format": "sfh",
            "container_version": crate::codec::CONTAINER_VERSION,
            "bytes": bytes,
            "header": header,
            "curve_count": curves,
            "block_count": reader.block_count(),
            "empty_curve_count": empty,
            "decoded_point_count": points,
            "bytes_per_curve": if curves > 0 { bytes as f64 / curves as f64 } else { 0.0 },
        });
        with_failure(&mut report, error.as_ref());
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        println!(
            "{}: strandfit container version {}, {bytes} bytes",
            args.input.display(),
            crate::codec::CONTAINER_VERSION
        );
        println!(
            "  codec           arcs (model {}, strandfit {}) within {} (two-sided Hausdorff at default decompression)",
            header.model, header.written_by, header.tolerance
        );
        println!(
            "  source          {}{}, units {}",
            header.source.format,
            header
                .source
                .file
                .as_deref()
                .map(|f| format!(" ({f})"))
                .unwrap_or_default(),
            header.source.units.as_deref().unwrap_or("unknown")
        );
        println!(
            "  curves          {curves} in {} blocks ({empty} empty), {points} decoded points",
            reader.block_count()
        );
        println!(
            "  size            {:.2} bytes/curve",
            bytes as f64 / curves.max(1) as f64
        );
        if !header.point_data_names.is_empty() {
            println!(
                "  per-point data  {} (on the decoded points)",
                header.point_data_names.join(", ")
            );
        }
    }
    match error {
        Some(e) => Err(anyhow::anyhow!("{e} (after {curves} complete curves)")),
        None => Ok(()),
    }
}

/// `inspect CONTAINER --preview OUT.svg --source INPUT`: the picture of
/// [`crate::metrics::preview_svg`], written atomically.
fn preview(args: &InspectArgs, source: &std::path::Path, out: &std::path::Path) -> Result<()> {
    use crate::codec::{container_version, read_range, CodecReader};
    use std::io::Write;

    if let Some(v) = container_version(&args.input).filter(|&v| v != 3) {
        anyhow::bail!(
            "{}: --preview draws a version-3 container (written by compress --tolerance); \
             this is version {v}",
            args.input.display()
        );
    }
    let mut reader = CodecReader::open(&args.input)?;
    let tolerance = reader.header().tolerance;
    let n = reader.curve_count().min(args.preview_curves);
    let decoded: Vec<Vec<glam::DVec3>> = read_range(&mut reader, 0, n)?
        .into_iter()
        .map(|c| c.points)
        .collect();
    let format = args.from.as_deref().map(parse_format).transpose()?;
    // The source's bad curves are left out, as `compress --skip-bad` left
    // them out (without it, a source with bad curves could not have been
    // compressed): the curves then pair by index.
    let mut input = Vec::with_capacity(decoded.len());
    let bad = crate::io::BadCurves::Skip;
    for c in crate::io::open_reader_with(source, format, bad)?.take(n as usize) {
        input.push(c?.points);
    }
    if input.len() != decoded.len() {
        anyhow::bail!(
            "{}: {} curves, but {} holds at least {}: is it the file the container was made from?",
            source.display(),
            input.len(),
            args.input.display(),
            decoded.len()
        );
    }
    let svg = crate::metrics::preview_svg(&input, &decoded, tolerance);
    let worst = input
        .iter()
        .zip(&decoded)
        .flat_map(|(i, d)| {
            d.iter()
                .map(move |p| crate::metrics::distance_to_polyline(*p, i))
        })
        .fold(0.0, f64::max);
    let mut file = crate::io::AtomicFile::create(out)?;
    file.write_all(svg.as_bytes()).map_err(|e| file.err(e))?;
    file.commit()?;
    eprintln!(
        "{}: {} curves of {} drawn over {}; largest distance of a decoded point from its input {:.4} (tolerance {tolerance})",
        out.display(),
        decoded.len(),
        args.input.display(),
        source.display(),
        worst
    );
    Ok(())
}
