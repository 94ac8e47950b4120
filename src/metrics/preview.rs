//! A picture of a compression: `preview_svg`, whose documentation
//! describes it.

use std::fmt::Write;

use glam::DVec3;

/// Colour bins of the error scale.
pub const BINS: usize = 10;

/// Distance from `p` to the polyline `line` (a point: to it; empty:
/// infinite).
///
/// ```
/// use glam::DVec3;
/// use strandfit::metrics::distance_to_polyline;
///
/// let l = [DVec3::ZERO, DVec3::X * 4.0, DVec3::new(4.0, 4.0, 0.0)];
/// assert_eq!(distance_to_polyline(DVec3::new(2.0, -3.0, 0.0), &l), 3.0); // to the first segment
/// assert_eq!(distance_to_polyline(DVec3::new(7.0, 8.0, 0.0), &l), 5.0); // to the last vertex
/// assert_eq!(distance_to_polyline(DVec3::ZERO, &[]), f64::INFINITY);
/// ```
pub fn distance_to_polyline(p: DVec3, line: &[DVec3]) -> f64 {
    match line.len() {
        0 => f64::INFINITY,
        1 => p.distance(line[0]),
        _ => line
            .windows(2)
            .map(|w| crate::codec::dist2_to_segment(p, w[0], w[1]))
            .fold(f64::INFINITY, f64::min)
            .sqrt(),
    }
}

/// The colour of relative error `x` (0: blue, 0.5: orange, 1 and beyond:
/// red), as `#rrggbb`.
///
/// ```
/// use strandfit::metrics::error_colour;
///
/// assert_eq!(error_colour(0.0), "#2c7bb6");
/// assert_eq!(error_colour(0.5), "#fdae61");
/// assert_eq!(error_colour(2.0), error_colour(1.0)); // clamped: red
/// assert_eq!(error_colour(f64::NAN), "#d7191c");
/// ```
pub fn error_colour(x: f64) -> String {
    // ColorBrewer RdYlBu's ends, and its orange (its yellow middle is
    // too near the grey of the input on white).
    const STOPS: [(f64, [f64; 3]); 3] = [
        (0.0, [44.0, 123.0, 182.0]),
        (0.5, [253.0, 174.0, 97.0]),
        (1.0, [215.0, 25.0, 28.0]),
    ];
    let x = if x.is_finite() {
        x.clamp(0.0, 1.0)
    } else {
        1.0
    };
    let (a, b) = if x <= 0.5 {
        (STOPS[0], STOPS[1])
    } else {
        (STOPS[1], STOPS[2])
    };
    let t = (x - a.0) / (b.0 - a.0);
    let c = [0, 1, 2].map(|k| (a.1[k] + t * (b.1[k] - a.1[k])).round() as u8);
    format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2])
}

/// The bin of relative error `x` (`0..BINS`).
///
/// ```
/// use strandfit::metrics::{error_bin, BINS};
///
/// assert_eq!(error_bin(0.0), 0);
/// assert_eq!(error_bin(0.55), 5);
/// assert_eq!(error_bin(1.0), BINS - 1); // the tolerance itself is in the top bin
/// assert_eq!(error_bin(-1.0), 0);
/// assert_eq!(error_bin(f64::INFINITY), BINS - 1);
/// ```
pub fn error_bin(x: f64) -> usize {
    if !x.is_finite() {
        return BINS - 1;
    }
    ((x.max(0.0) * BINS as f64) as usize).min(BINS - 1)
}

/// Path data in tenths of a pixel: a move to an absolute point, lines as
/// relative steps from the last point written (rounded, so no drift).
#[derive(Default)]
struct Pen {
    path: String,
    at: (i64, i64),
}

impl Pen {
    fn to(&mut self, (x, y): (f64, f64), move_to: bool) {
        let p = ((x * 10.0).round() as i64, (y * 10.0).round() as i64);
        let tenths = |v: i64| {
            let sign = if v < 0 { "-" } else { "" };
            let a = v.unsigned_abs();
            if a.is_multiple_of(10) {
                format!("{sign}{}", a / 10)
            } else {
                format!("{sign}{}.{}", a / 10, a % 10)
            }
        };
        if move_to {
            let _ = write!(self.path, "M{} {}", tenths(p.0), tenths(p.1));
        } else {
            let _ = write!(
                self.path,
                "l{} {}",
                tenths(p.0 - self.at.0),
                tenths(p.1 - self.at.1)
            );
        }
        self.at = p;
    }
}

/// The SVG of `input` and `decoded` curves (paired by index) at
/// `tolerance`: a picture of a compression, the input curves and the
/// decoded ones over each other in three orthographic views (x–y, x–z,
/// y–z), each decoded segment coloured by its local error — the distance of
/// its farther end from the input polyline, as a fraction of the tolerance —
/// from blue (0) through orange to red (the tolerance). An SVG document,
/// written by hand (a few kinds of element): input curves as one grey path
/// per view, decoded segments as one path per colour bin.
///
/// A decoded curve 0.09 off a straight input at tolerance 0.1 is drawn
/// in the colour of the top error bin (its relative error is 0.9):
/// ```
/// use glam::DVec3;
/// use strandfit::metrics::{error_colour, preview_svg, BINS};
///
/// let input = vec![vec![DVec3::ZERO, DVec3::X * 10.0]];
/// let decoded = vec![vec![DVec3::new(0.0, 0.09, 0.0), DVec3::new(10.0, 0.09, 0.0)]];
/// let svg = preview_svg(&input, &decoded, 0.1);
/// let top = format!(r#"class="decoded" data-bin="{}""#, BINS - 1);
/// assert_eq!(svg.matches(r#"class="decoded""#).count(), 3); // one path per view
/// assert_eq!(svg.matches(&top).count(), 3);
/// assert!(svg.contains(&format!(r#"stroke="{}""#, error_colour(0.95))));
/// ```
///
/// A whole document:
///
/// ```
/// use glam::DVec3;
/// let input = vec![vec![DVec3::ZERO, DVec3::new(10.0, 0.0, 0.0)]];
/// let decoded = vec![vec![DVec3::new(0.0, 0.05, 0.0), DVec3::new(10.0, 0.09, 0.0)]];
/// let svg = strandfit::metrics::preview_svg(&input, &decoded, 0.1);
/// assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
/// ```
pub fn preview_svg(input: &[Vec<DVec3>], decoded: &[Vec<DVec3>], tolerance: f64) -> String {
    const VIEW: f64 = 360.0;
    const PAD: f64 = 24.0;
    const TOP: f64 = 28.0;
    const LEGEND: f64 = 56.0;
    let views: [(usize, usize, &str); 3] = [(0, 1, "x–y"), (0, 2, "x–z"), (1, 2, "y–z")];
    // One scale for all views: the largest extent of the data.
    let all = input.iter().chain(decoded).flatten();
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for p in all.clone() {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    if !(lo.is_finite() && hi.is_finite()) {
        lo = DVec3::ZERO;
        hi = DVec3::ONE;
    }
    let extent = (hi - lo).max_element().max(1e-12);
    let scale = (VIEW - 2.0 * PAD) / extent;
    let width = 3.0 * VIEW;
    let height = TOP + VIEW + LEGEND;
    // Local errors of the decoded points, relative to the tolerance.
    let errors: Vec<Vec<f64>> = input
        .iter()
        .zip(decoded)
        .map(|(i, d)| {
            d.iter()
                .map(|p| distance_to_polyline(*p, i) / tolerance)
                .collect()
        })
        .collect();
    let mut svg = String::new();
    let _ = writeln!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0}" height="{height:.0}" viewBox="0 0 {width:.0} {height:.0}" font-family="sans-serif" font-size="13">"#
    );
    let _ = writeln!(
        svg,
        r##"<rect width="{width:.0}" height="{height:.0}" fill="#ffffff"/>"##
    );
    for (v, &(a, b, name)) in views.iter().enumerate() {
        let x0 = v as f64 * VIEW;
        // Screen coordinates: axis a to the right, axis b up.
        let at = |p: &DVec3| {
            let x = x0 + PAD + (p[a] - lo[a]) * scale;
            let y = TOP + VIEW - PAD - (p[b] - lo[b]) * scale;
            (x, y)
        };
        let _ = writeln!(
            svg,
            r##"<text x="{:.0}" y="20" text-anchor="middle">{name}</text>"##,
            x0 + VIEW / 2.0
        );
        let _ = writeln!(
            svg,
            r##"<rect x="{:.1}" y="{:.1}" width="{:.1}" height="{:.1}" fill="none" stroke="#cccccc"/>"##,
            x0 + 4.0,
            TOP,
            VIEW - 8.0,
            VIEW - 8.0
        );
        // The input, thin and grey.
        let mut d = Pen::default();
        for c in input {
            for (k, p) in c.iter().enumerate() {
                d.to(at(p), k == 0);
            }
        }
        let d = d.path;
        let _ = writeln!(
            svg,
            r##"<path class="input" d="{d}" fill="none" stroke="#9a9a9a" stroke-width="2.2" stroke-opacity="0.5"/>"##
        );
        // The decoded segments, one path per error bin; a run of segments
        // in one bin is one subpath.
        let mut bins: Vec<Pen> = (0..BINS).map(|_| Pen::default()).collect();
        for (c, e) in decoded.iter().zip(&errors) {
            let mut open = None;
            for k in 1..c.len() {
                let bin = error_bin(e[k - 1].max(e[k]));
                if open != Some(bin) {
                    bins[bin].to(at(&c[k - 1]), true);
                }
                bins[bin].to(at(&c[k]), false);
                open = Some(bin);
            }
        }
        for (bin, pen) in bins.iter().enumerate() {
            let d = &pen.path;
            if d.is_empty() {
                continue;
            }
            let colour = error_colour((bin as f64 + 0.5) / BINS as f64);
            let _ = writeln!(
                svg,
                r##"<path class="decoded" data-bin="{bin}" d="{d}" fill="none" stroke="{colour}" stroke-width="0.9"/>"##
            );
        }
    }
    // Legend: the colour scale from 0 to the tolerance.
    let y = TOP + VIEW + 12.0;
    let bar = 300.0;
    for bin in 0..BINS {
        let _ = writeln!(
            svg,
            r##"<rect x="{:.1}" y="{y:.1}" width="{:.1}" height="12" fill="{}"/>"##,
            PAD + bin as f64 * bar / BINS as f64,
            bar / BINS as f64,
            error_colour((bin as f64 + 0.5) / BINS as f64)
        );
    }
    let _ = writeln!(
        svg,
        r##"<text x="{PAD:.0}" y="{:.0}">0</text><text x="{:.0}" y="{:.0}" text-anchor="end">{tolerance}</text><text x="{:.0}" y="{:.0}">distance of each decoded segment from the input (grey), {} curves</text>"##,
        y + 28.0,
        PAD + bar,
        y + 28.0,
        PAD + bar + 16.0,
        y + 11.0,
        decoded.len()
    );
    svg.push_str("</svg>\n");
    svg
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether `svg` is well-formed XML of the kinds written here: every
    /// element closed in order, attribute values quoted, no stray `<`/`&`.
    fn well_formed(svg: &str) -> Result<(), String> {
        let mut open: Vec<&str> = Vec::new();
        let mut rest = svg;
        while let Some(i) = rest.find('<') {
            let text = &rest[..i];
            if text.contains('&') || text.contains('>') {
                return Err(format!("stray character in {text:?}"));
            }
            let end = rest[i..].find('>').ok_or("unclosed tag")? + i;
            let tag = &rest[i + 1..end];
            if let Some(name) = tag.strip_prefix('/') {
                match open.pop() {
                    Some(o) if o == name => {}
                    o => return Err(format!("</{name}> closes {o:?}")),
                }
            } else {
                let self_closing = tag.ends_with('/');
                let body = tag.trim_end_matches('/');
                let name = body.split_whitespace().next().ok_or("empty tag")?;
                // Attributes: name="value" pairs, values without < or ".
                let attrs = body[name.len()..].trim();
                let mut a = attrs;
                while !a.is_empty() {
                    let eq = a
                        .find("=\"")
                        .ok_or(format!("attribute without a quoted value in <{name}>"))?;
                    let close = a[eq + 2..].find('"').ok_or("unterminated value")? + eq + 2;
                    if a[eq + 2..close].contains('<') {
                        return Err("< in a value".into());
                    }
                    a = a[close + 1..].trim_start();
                }
                if !self_closing {
                    open.push(name);
                }
            }
            rest = &rest[end + 1..];
        }
        if !open.is_empty() {
            return Err(format!("unclosed {open:?}"));
        }
        if !rest.trim().is_empty() {
            return Err("text after the root".into());
        }
        Ok(())
    }

    /// The `d` of the decoded path of `bin` (empty if absent).
    fn bin_path(svg: &str, bin: usize) -> Vec<&str> {
        let key = format!("data-bin=\"{bin}\" d=\"");
        svg.match_indices(&key)
            .map(|(i, _)| {
                let from = i + key.len();
                &svg[from..from + svg[from..].find('"').unwrap()]
            })
            .collect()
    }

    #[test]
    fn the_picture_is_well_formed_and_its_colours_follow_the_error() {
        let t = 0.5;
        let line: Vec<DVec3> = (0..=20).map(|k| DVec3::new(k as f64, 0.0, 0.0)).collect();
        // Curve 0 decoded 0.15 T away from its input, curve 1 0.85 T away,
        // curve 2 at 0.15 T then at 0.85 T from its seventh point on.
        let shifted = |d: f64| {
            line.iter()
                .map(|p| *p + DVec3::new(0.0, d, d) / 2f64.sqrt())
                .collect::<Vec<_>>()
        };
        let mut mixed = shifted(0.15 * t);
        for p in mixed.iter_mut().skip(7) {
            *p = DVec3::new(p.x, 0.85 * t / 2f64.sqrt(), 0.85 * t / 2f64.sqrt());
        }
        let input = vec![line.clone(), line.clone(), line.clone()];
        let decoded = vec![shifted(0.15 * t), shifted(0.85 * t), mixed];
        let svg = preview_svg(&input, &decoded, t);
        well_formed(&svg).unwrap();
        assert!(well_formed("<svg><path d=\"M0 0\"></svg>").is_err());
        assert!(svg.starts_with("<svg xmlns=\"http://www.w3.org/2000/svg\""));
        // Three views, each with the two bins of the errors, and no other.
        for bin in 0..BINS {
            let n = bin_path(&svg, bin).len();
            assert_eq!(n, if bin == 1 || bin == 8 { 3 } else { 0 }, "bin {bin}");
        }
        // Bin 8 (0.85 T) is drawn redder than bin 1 (0.15 T).
        let colour_of = |bin: usize| {
            let key = format!("data-bin=\"{bin}\"");
            let i = svg.find(&key).unwrap();
            let s = &svg[i..];
            let c = s.find("stroke=\"#").unwrap() + 9;
            u8::from_str_radix(&s[c..c + 2], 16).unwrap()
        };
        assert!(colour_of(8) > colour_of(1));
        // Per view: curve 0's 20 segments, the mixed curve's first 6 (and
        // the one into its jump, whose far end is 0.85 T off) in bin 1 or 8.
        let segments = |d: &str| d.matches('l').count();
        assert_eq!(segments(bin_path(&svg, 1)[0]), 20 + 6);
        assert_eq!(segments(bin_path(&svg, 8)[0]), 20 + 14);
        // Empty data still make a picture.
        well_formed(&preview_svg(&[], &[], 1.0)).unwrap();
    }

    #[test]
    fn colours_run_from_blue_through_orange_to_red() {
        assert_eq!(error_colour(0.0), "#2c7bb6");
        assert_eq!(error_colour(0.5), "#fdae61");
        assert_eq!(error_colour(1.0), "#d7191c");
        assert_eq!(error_colour(7.0), "#d7191c");
        // Red less blue rises with the error, all the way.
        let warmth = |x: f64| {
            let c = error_colour(x);
            let v = |k: usize| u8::from_str_radix(&c[1 + 2 * k..3 + 2 * k], 16).unwrap() as i32;
            v(0) - v(2)
        };
        for k in 1..=20 {
            let (a, b) = (warmth((k - 1) as f64 / 20.0), warmth(k as f64 / 20.0));
            assert!(b > a, "not warmer at {k}: {a} -> {b}");
        }
        assert_eq!(error_bin(0.0), 0);
        assert_eq!(error_bin(0.95), 9);
        assert_eq!(error_bin(2.0), 9);
        assert_eq!(error_bin(f64::NAN), 9);
    }
}
