//! Paths with moving frames for viewers, as legacy VTK: see
//! `write_framed_paths` (`io::write_framed_paths`).

use std::io::Write;
use std::path::Path;

use glam::DVec3;

use super::{AtomicFile, IoError};

/// One path: its points and the frame `(𝐟₁, 𝐟₂, 𝐟₃)` at each.
pub struct FramedPath {
    /// The path's points.
    pub points: Vec<DVec3>,
    /// The frame `(𝐟₁, 𝐟₂, 𝐟₃)` at each point.
    pub frames: Vec<[DVec3; 3]>,
}

/// Write `paths` to `target`, for viewers: a legacy VTK `POLYDATA` file
/// (ASCII, version 3.0) with one polyline per path and the frame vectors as
/// point data — `FIELD frame 3` with the 3-component arrays `f1`, `f2`,
/// `f3`. A `FIELD` rather than three `VECTORS`, because VTK's legacy reader
/// keeps only the first `VECTORS` array of a section; ParaView lists the
/// three arrays and glyphs them directly. Written atomically.
///
/// ```
/// use strandfit::io::{write_framed_paths, FramedPath};
/// use strandfit::DVec3;
///
/// let path = std::env::temp_dir().join(format!("strandfit-doc-frames-{}.vtk", std::process::id()));
/// let frame = [DVec3::X, DVec3::Y, DVec3::Z];
/// let line = FramedPath { points: vec![DVec3::ZERO, DVec3::X], frames: vec![frame; 2] };
/// write_framed_paths(&path, "frames", &[line]).unwrap();
/// let text = std::fs::read_to_string(&path).unwrap();
/// std::fs::remove_file(&path).unwrap();
/// assert!(text.contains("POINTS 2 double\n") && text.contains("LINES 1 3\n"));
/// let short = FramedPath { points: vec![DVec3::ZERO, DVec3::X], frames: vec![frame] };
/// let err = write_framed_paths(&path, "frames", &[short]).unwrap_err();
/// assert_eq!(err.reason, "path 0: 2 points but 1 frames");
/// ```
pub fn write_framed_paths(target: &Path, title: &str, paths: &[FramedPath]) -> Result<(), IoError> {
    let total: usize = paths.iter().map(|p| p.points.len()).sum();
    let io = |e: std::io::Error| IoError::new(target, format!("cannot write: {e}"));
    for (i, p) in paths.iter().enumerate() {
        if p.points.len() != p.frames.len() {
            return Err(IoError::new(
                target,
                format!(
                    "path {i}: {} points but {} frames",
                    p.points.len(),
                    p.frames.len()
                ),
            ));
        }
    }
    let mut f = AtomicFile::create(target)?;
    // The title line is one line of at most 255 characters.
    let title: String = title
        .chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .take(255)
        .collect();
    write!(
        f,
        "# vtk DataFile Version 3.0\n{title}\nASCII\nDATASET POLYDATA\nPOINTS {total} double\n"
    )
    .map_err(io)?;
    for p in paths.iter().flat_map(|p| &p.points) {
        writeln!(f, "{:e} {:e} {:e}", p.x, p.y, p.z).map_err(io)?;
    }
    let lines: Vec<&FramedPath> = paths.iter().filter(|p| !p.points.is_empty()).collect();
    let size: usize = lines.iter().map(|p| p.points.len() + 1).sum();
    writeln!(f, "LINES {} {size}", lines.len()).map_err(io)?;
    let mut first = 0usize;
    for p in paths {
        if !p.points.is_empty() {
            write!(f, "{}", p.points.len()).map_err(io)?;
            for k in 0..p.points.len() {
                write!(f, " {}", first + k).map_err(io)?;
            }
            writeln!(f).map_err(io)?;
        }
        first += p.points.len();
    }
    writeln!(f, "POINT_DATA {total}\nFIELD frame 3").map_err(io)?;
    for (k, name) in ["f1", "f2", "f3"].iter().enumerate() {
        writeln!(f, "{name} 3 {total} double").map_err(io)?;
        for fr in paths.iter().flat_map(|p| &p.frames) {
            let v = fr[k];
            writeln!(f, "{:e} {:e} {:e}", v.x, v.y, v.z).map_err(io)?;
        }
    }
    f.commit()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_through_our_vtk_reader() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.vtk");
        let frame = |a: f64| {
            let (s, c) = a.sin_cos();
            [DVec3::X, DVec3::new(0.0, c, s), DVec3::new(0.0, -s, c)]
        };
        let paths = vec![
            FramedPath {
                points: (0..4).map(|k| DVec3::new(k as f64, 0.5, -1.0)).collect(),
                frames: (0..4).map(|k| frame(0.1 * k as f64)).collect(),
            },
            FramedPath {
                points: vec![DVec3::ZERO, DVec3::ONE],
                frames: vec![frame(1.0), frame(2.0)],
            },
        ];
        write_framed_paths(&path, "strandfit motion", &paths).unwrap();
        let curves = crate::io::read_all(&path, None).unwrap();
        let (meta, curves) = (curves.0, curves.1);
        assert_eq!(curves.len(), 2);
        assert_eq!(
            meta.point_data_names.len(),
            9,
            "{:?}",
            meta.point_data_names
        );
        for (c, p) in curves.iter().zip(&paths) {
            assert_eq!(c.points, p.points);
            for (k, fr) in p.frames.iter().enumerate() {
                let row = &c.point_data[k * 9..k * 9 + 9];
                for j in 0..3 {
                    for a in 0..3 {
                        assert!((row[3 * j + a] as f64 - fr[j][a]).abs() < 1e-6);
                    }
                }
            }
        }
        // Mismatched lengths are refused, and nothing is written.
        let bad = [FramedPath {
            points: vec![DVec3::ZERO],
            frames: vec![],
        }];
        let other = dir.path().join("bad.vtk");
        assert!(write_framed_paths(&other, "x", &bad).is_err());
        assert!(!other.exists());
    }
}
