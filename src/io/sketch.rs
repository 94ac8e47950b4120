//! 2D sketches for `strandfit sketch`: reading a hand-drawn polyline from
//! JSON, CSV or SVG, and writing an SVG preview that overlays the fitted
//! (projected) helix pieces on it. The formats, the flattening of SVG
//! curves and the validation are described on `read_sketch`.

use std::io::Write;
use std::path::Path;

use glam::DVec2;

use super::{AtomicFile, IoError};

/// Chord deviation allowed when flattening SVG curves, relative to the
/// segment's size (see [`read_sketch`]).
pub const FLATTEN_TOLERANCE: f64 = 1e-3;

/// Most pieces one curve segment is flattened into (a guard; the tolerance
/// bound never asks for more than 28).
const MAX_PIECES: usize = 1024;

/// The file extensions [`read_sketch`] accepts.
pub const SKETCH_EXTENSIONS: &[&str] = &["json", "csv", "txt", "svg"];

/// Read a 2D sketch, choosing the format by the extension of `path` (see
/// [Formats](read_sketch#formats)). Points are in the file's own coordinates.
///
/// ```
/// use strandfit::io::read_sketch;
///
/// let path = std::env::temp_dir().join(format!("strandfit-doc-read-sketch-{}.txt", std::process::id()));
/// std::fs::write(&path, "x y\n0 0\n1 0.5 # a comment\n\n2 2\n").unwrap();
/// let points = read_sketch(&path).unwrap();
/// std::fs::remove_file(&path).unwrap();
/// assert_eq!(points.len(), 3);
/// assert_eq!((points[1].x, points[1].y), (1.0, 0.5));
/// ```
///
/// # Formats
///
/// The extension picks the format (case-insensitive):
///
/// * `.json`: a bare array `[[x, y], …]` or an object `{"points": [[x, y], …]}`
///   (other fields of the object are ignored). Each point is exactly two
///   finite numbers.
/// * `.csv`, `.txt`: one `x,y` per line, the two values separated by a comma,
///   a semicolon, or tabs/spaces. A first line that holds no number at all
///   is a header and is skipped; blank lines and `#` comments (to the end of
///   the line) are skipped anywhere.
/// * `.svg`: the first `<path>` element's `d` attribute, or, when the file
///   has no `<path>`, the first `<polyline>` or `<polygon>` element's
///   `points`. Path data is parsed fully per SVG 1.1 (all commands, absolute
///   and relative, implicit repetition, compact numbers and arc flags).
///   A sketch is one stroke, so **only the first subpath** is used: the
///   points up to the second moveto that follows some drawing, or up to and
///   including the first `Z`, which closes the stroke by repeating its start
///   point. A polygon is closed the same way. `transform` attributes (on the
///   element or on an enclosing element) are rejected with an error rather
///   than ignored, since ignoring them would give silently wrong points.
///
/// Coordinates are returned exactly as the file has them. In particular SVG's
/// y axis points down and is **not** flipped, so that the preview written by
/// [`write_preview_svg`] overlays the original drawing.
///
/// # Flattening of SVG curves
///
/// Cubic and quadratic Béziers and elliptical arcs are replaced by polylines
/// whose vertices lie on the curve at uniform parameter steps, with enough
/// pieces that the distance between the curve and its chords is at most
/// [`SVG_FLATTEN_TOLERANCE`](FLATTEN_TOLERANCE) (1e-3) times the segment's
/// size: its control-polygon length for Béziers, `max(rx, ry)·|Δθ|` for arcs
/// (both bound the arc length from above). The piece count comes from the bound
/// `M·h²/8` on the chord deviation of a curve with `|B''| ≤ M` over a parameter
/// step `h`; it is at most 28 per segment whatever the shape.
///
/// # Validation (all formats)
///
/// Non-finite values are errors; consecutive duplicate points (zero-length
/// segments) are removed; a sketch needs at least 3 distinct points and a
/// non-zero length. Errors name the file and where: `line N` (CSV, 1-based),
/// `point N` (JSON, 0-based index), `path data offset N` (SVG, byte offset
/// into the attribute, with the element's line). No input makes a reader
/// panic.
pub fn read_sketch(path: &Path) -> Result<Vec<DVec2>, IoError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    let parse: fn(&str, &Path) -> Result<Vec<DVec2>, IoError> = match ext.as_deref() {
        Some("json") => parse_sketch_json,
        Some("csv") | Some("txt") => parse_sketch_csv,
        Some("svg") => parse_sketch_svg,
        other => {
            let what = match other {
                Some(e) => format!("unknown sketch file extension `.{e}`"),
                None => "sketch file has no extension".to_string(),
            };
            return Err(IoError::new(
                path,
                format!("{what}; accepted: .json, .csv, .txt, .svg"),
            ));
        }
    };
    let text = std::fs::read_to_string(path).map_err(|e| IoError::os(path, "cannot read", e))?;
    parse(&text, path)
}

/// Parse a JSON sketch (`[[x, y], …]` or `{"points": [[x, y], …]}`; see
/// [`read_sketch`]); `path` only names the source in errors.
///
/// Repeated points are dropped; a 3D point is an error naming it:
///
/// ```
/// use std::path::Path;
/// use strandfit::io::parse_sketch_json;
///
/// let here = Path::new("stroke.json");
/// let points = parse_sketch_json(r#"{"points": [[0, 0], [0, 0], [1, 1], [2, 0]]}"#, here).unwrap();
/// assert_eq!(points.len(), 3);
/// let err = parse_sketch_json("[[0, 0], [1, 1, 1]]", here).unwrap_err();
/// assert_eq!(err.at.as_deref(), Some("point 1"));
/// ```
pub fn parse_sketch_json(text: &str, path: &Path) -> Result<Vec<DVec2>, IoError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let doc: serde_json::Value = serde_json::from_str(text).map_err(|e| {
        IoError::new(path, format!("not a JSON sketch: {e}")).at(format!(
            "line {}, column {}",
            e.line(),
            e.column()
        ))
    })?;
    let shape = "expected an array of [x, y] points or an object with a \"points\" array";
    let points = match &doc {
        serde_json::Value::Array(a) => a,
        serde_json::Value::Object(o) => match o.get("points") {
            Some(serde_json::Value::Array(a)) => a,
            Some(_) => return Err(IoError::new(path, shape).at("field `points`")),
            None => {
                return Err(IoError::new(
                    path,
                    format!("{shape}; the object has no `points`"),
                ))
            }
        },
        _ => return Err(IoError::new(path, shape)),
    };
    let mut out = Vec::with_capacity(points.len());
    for (i, p) in points.iter().enumerate() {
        let err = |reason: String| IoError::new(path, reason).at(format!("point {i}"));
        let coords = match p {
            serde_json::Value::Array(c) => c,
            _ => return Err(err("a point must be an array [x, y]".into())),
        };
        if coords.len() != 2 {
            let reason = if coords.len() == 3 {
                "point has 3 coordinates; sketches are 2D, expected [x, y]".to_string()
            } else {
                format!("point has {} coordinates, expected [x, y]", coords.len())
            };
            return Err(err(reason));
        }
        let mut xy = [0.0; 2];
        for (k, c) in coords.iter().enumerate() {
            let v = c
                .as_f64()
                .ok_or_else(|| err(format!("coordinate {c} is not a number")))?;
            if !v.is_finite() {
                return Err(err(format!("coordinate {v} is not finite")));
            }
            xy[k] = v;
        }
        out.push(DVec2::new(xy[0], xy[1]));
    }
    finish(out, path)
}

/// Parse a CSV/text sketch (one `x,y` per line; see [`read_sketch`]); `path`
/// only names the source in errors.
///
/// ```
/// use std::path::Path;
/// use strandfit::io::parse_sketch_csv;
///
/// let here = Path::new("stroke.csv");
/// let points = parse_sketch_csv("x;y\n0;0\n1;2\n3;1\n", here).unwrap();
/// assert_eq!((points.len(), points[2].x, points[2].y), (3, 3.0, 1.0));
/// let err = parse_sketch_csv("0,0\n1,1\n1,x\n", here).unwrap_err();
/// assert_eq!((err.at.as_deref(), err.reason.as_str()), (Some("line 3"), "`x` is not a number"));
/// ```
pub fn parse_sketch_csv(text: &str, path: &Path) -> Result<Vec<DVec2>, IoError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut out = Vec::new();
    let mut first = true;
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let err = |reason: String| IoError::new(path, reason).at(format!("line {line_no}"));
        let fields: Vec<&str> = if line.contains([',', ';']) {
            line.split([',', ';']).map(str::trim).collect()
        } else {
            line.split_whitespace().collect()
        };
        let header = first && fields.iter().all(|f| f.parse::<f64>().is_err());
        first = false;
        if header {
            continue;
        }
        if fields.len() != 2 {
            let reason = if fields.len() == 3 {
                "3 fields; sketches are 2D, expected x,y".to_string()
            } else {
                format!("{} fields, expected 2 (x,y)", fields.len())
            };
            return Err(err(reason));
        }
        let mut xy = [0.0; 2];
        for (k, f) in fields.iter().enumerate() {
            let v: f64 = f
                .parse()
                .map_err(|_| err(format!("`{f}` is not a number")))?;
            if !v.is_finite() {
                return Err(err(format!("value `{f}` is not finite")));
            }
            xy[k] = v;
        }
        out.push(DVec2::new(xy[0], xy[1]));
    }
    finish(out, path)
}

/// Parse an SVG sketch (the first `<path>`'s `d`, else the first
/// `<polyline>`/`<polygon>`'s `points`; see [`read_sketch`]); `path` only
/// names the source in errors.
///
/// A closed path repeats its start point:
///
/// ```
/// use std::path::Path;
/// use strandfit::io::parse_sketch_svg;
///
/// let svg = r#"<svg xmlns="http://www.w3.org/2000/svg"><path d="M 0 0 h 10 v 10 Z"/></svg>"#;
/// let points = parse_sketch_svg(svg, Path::new("stroke.svg")).unwrap();
/// let xy: Vec<(f64, f64)> = points.iter().map(|p| (p.x, p.y)).collect();
/// assert_eq!(xy, [(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 0.0)]);
/// ```
pub fn parse_sketch_svg(text: &str, path: &Path) -> Result<Vec<DVec2>, IoError> {
    let elements = scan_elements(text).map_err(|(at, reason)| {
        IoError::new(path, reason).at(format!("line {}", line_of(text, at)))
    })?;
    let chosen = elements
        .iter()
        .find(|e| e.name == "path")
        .or_else(|| {
            elements
                .iter()
                .find(|e| e.name == "polyline" || e.name == "polygon")
        })
        .ok_or_else(|| {
            IoError::new(
                path,
                "no <path>, <polyline> or <polygon> element found; not an SVG sketch",
            )
        })?;
    let line = line_of(text, chosen.offset);
    let elem_err =
        |reason: String| IoError::new(path, reason).at(format!("<{}> at line {line}", chosen.name));
    if let Some(t) = &chosen.transformed_by {
        let whose = if t == &chosen.name {
            "it has".to_string()
        } else {
            format!("an enclosing <{t}> has")
        };
        return Err(elem_err(format!(
            "{whose} a transform attribute; transforms are not supported (apply them to the \
             coordinates first, e.g. Inkscape's \"Apply Transform\")"
        )));
    }
    let (attr, points) = if chosen.name == "path" {
        let d = chosen
            .attr("d")
            .ok_or_else(|| elem_err("the <path> element has no d attribute".into()))?;
        ("path data", path_points(d))
    } else {
        let p = chosen.attr("points").ok_or_else(|| {
            elem_err(format!(
                "the <{}> element has no points attribute",
                chosen.name
            ))
        })?;
        ("points", list_points(p, chosen.name == "polygon"))
    };
    let points = points.map_err(|(off, reason)| {
        IoError::new(path, reason).at(format!(
            "<{}> at line {line}, {attr} offset {off}",
            chosen.name
        ))
    })?;
    finish(points, path)
}

/// Remove consecutive duplicates and check what every format must satisfy.
fn finish(mut points: Vec<DVec2>, path: &Path) -> Result<Vec<DVec2>, IoError> {
    if let Some(i) = points.iter().position(|p| !p.is_finite()) {
        return Err(IoError::new(path, "coordinate is not finite").at(format!("point {i}")));
    }
    points.dedup();
    // Distinct points overall (not just consecutively): A, B, A is 2.
    let mut keys: Vec<(u64, u64)> = points
        .iter()
        .map(|p| ((p.x + 0.0).to_bits(), (p.y + 0.0).to_bits()))
        .collect();
    keys.sort_unstable();
    keys.dedup();
    if keys.len() < 3 {
        return Err(IoError::new(
            path,
            format!(
                "a sketch needs at least 3 distinct points, found {}",
                keys.len()
            ),
        ));
    }
    let length: f64 = points.windows(2).map(|w| w[0].distance(w[1])).sum();
    if length.is_nan() || length <= 0.0 || length.is_infinite() {
        return Err(IoError::new(
            path,
            format!("the sketch's total length is {length}, it must be positive and finite"),
        ));
    }
    Ok(points)
}

/// 1-based line number of byte offset `at` in `text`.
fn line_of(text: &str, at: usize) -> usize {
    1 + text.as_bytes()[..at.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
}

// ---------------------------------------------------------------------------
// Minimal XML scanning: start tags with their attributes, the stack of open
// elements (for inherited transforms), comments/CDATA/PIs/doctypes skipped.

struct Element<'a> {
    /// Local name (namespace prefix removed), lower-case ASCII.
    name: String,
    /// Byte offset of the `<` in the file.
    offset: usize,
    attrs: Vec<(&'a str, &'a str)>,
    /// Name of the element (this one or an ancestor) with a `transform`.
    transformed_by: Option<String>,
}

impl<'a> Element<'a> {
    fn attr(&self, name: &str) -> Option<&'a str> {
        self.attrs.iter().find(|(k, _)| *k == name).map(|(_, v)| *v)
    }
}

fn find_from(s: &[u8], from: usize, pat: &[u8]) -> Option<usize> {
    if from > s.len() {
        return None;
    }
    s[from..]
        .windows(pat.len())
        .position(|w| w == pat)
        .map(|p| p + from)
}

/// The start tags of `text` that may hold a sketch (`path`, `polyline`,
/// `polygon`), in document order. Errors are (byte offset, reason).
fn scan_elements(text: &str) -> Result<Vec<Element<'_>>, (usize, String)> {
    let s = text.as_bytes();
    let mut out = Vec::new();
    // Open elements: (local name, name of the transformed one among them).
    let mut stack: Vec<(String, Option<String>)> = Vec::new();
    let mut i = 0;
    let skip_to = |from: usize, end: &[u8], what: &str| {
        find_from(s, from, end)
            .map(|p| p + end.len())
            .ok_or((from, format!("unterminated {what}")))
    };
    while let Some(lt) = find_from(s, i, b"<") {
        let rest = &s[lt..];
        if rest.starts_with(b"<!--") {
            i = skip_to(lt + 4, b"-->", "comment")?;
        } else if rest.starts_with(b"<![CDATA[") {
            i = skip_to(lt + 9, b"]]>", "CDATA section")?;
        } else if rest.starts_with(b"<?") {
            i = skip_to(lt + 2, b"?>", "processing instruction")?;
        } else if rest.starts_with(b"<!") {
            i = skip_to(lt + 2, b">", "declaration")?;
        } else if rest.starts_with(b"</") {
            let end = skip_to(lt + 2, b">", "end tag")?;
            let name = local_name(text[lt + 2..end - 1].trim());
            if let Some(k) = stack.iter().rposition(|(n, _)| *n == name) {
                stack.truncate(k);
            }
            i = end;
        } else if rest.len() > 1 && (rest[1].is_ascii_alphabetic() || rest[1] == b'_') {
            let (elem, end, self_closing) = start_tag(text, lt)?;
            let inherited = stack.last().and_then(|(_, t)| t.clone());
            let transformed_by = if elem.attr("transform").is_some() {
                Some(elem.name.clone())
            } else {
                inherited
            };
            if !self_closing {
                stack.push((elem.name.clone(), transformed_by.clone()));
            }
            if matches!(elem.name.as_str(), "path" | "polyline" | "polygon") {
                out.push(Element {
                    transformed_by,
                    ..elem
                });
            }
            i = end;
        } else {
            i = lt + 1; // a stray '<' in text
        }
    }
    Ok(out)
}

fn local_name(qname: &str) -> String {
    qname
        .rsplit(':')
        .next()
        .unwrap_or(qname)
        .to_ascii_lowercase()
}

/// Parse the start tag whose `<` is at `lt`: the element, the offset just
/// after its `>`, and whether it is self-closing.
fn start_tag(text: &str, lt: usize) -> Result<(Element<'_>, usize, bool), (usize, String)> {
    let s = text.as_bytes();
    let is_space = |b: u8| b.is_ascii_whitespace();
    let unterminated = || (lt, "unterminated start tag".to_string());
    let mut i = lt + 1;
    while i < s.len() && !is_space(s[i]) && s[i] != b'/' && s[i] != b'>' {
        i += 1;
    }
    let name = local_name(&text[lt + 1..i]);
    let mut attrs = Vec::new();
    loop {
        while i < s.len() && is_space(s[i]) {
            i += 1;
        }
        if i >= s.len() {
            return Err(unterminated());
        }
        match s[i] {
            b'>' => return Ok((element(name, lt, attrs), i + 1, false)),
            b'/' if s.get(i + 1) == Some(&b'>') => {
                return Ok((element(name, lt, attrs), i + 2, true))
            }
            b'/' => {
                i += 1;
                continue;
            }
            _ => {}
        }
        let k0 = i;
        while i < s.len() && !is_space(s[i]) && !matches!(s[i], b'=' | b'>' | b'/') {
            i += 1;
        }
        let key = &text[k0..i];
        while i < s.len() && is_space(s[i]) {
            i += 1;
        }
        if i < s.len() && s[i] == b'=' {
            i += 1;
            while i < s.len() && is_space(s[i]) {
                i += 1;
            }
            if i >= s.len() {
                return Err(unterminated());
            }
            let value = if s[i] == b'"' || s[i] == b'\'' {
                let q = s[i];
                let v0 = i + 1;
                let v1 = find_from(s, v0, &[q])
                    .ok_or((i, format!("unterminated value of attribute `{key}`")))?;
                i = v1 + 1;
                &text[v0..v1]
            } else {
                let v0 = i;
                while i < s.len() && !is_space(s[i]) && s[i] != b'>' {
                    i += 1;
                }
                &text[v0..i]
            };
            attrs.push((key, value));
        } else if !key.is_empty() {
            attrs.push((key, ""));
        }
    }
}

fn element<'a>(name: String, offset: usize, attrs: Vec<(&'a str, &'a str)>) -> Element<'a> {
    Element {
        name,
        offset,
        attrs,
        transformed_by: None,
    }
}

// ---------------------------------------------------------------------------
// SVG path data (SVG 1.1, section 8.3 and implementation notes F.6).

type SyntaxError = (usize, String);

struct Lexer<'a> {
    text: &'a str,
    s: &'a [u8],
    pos: usize,
}

/// SVG white space.
fn is_wsp(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\n' | b'\r' | b'\x0c')
}

impl<'a> Lexer<'a> {
    fn new(text: &'a str) -> Self {
        Lexer {
            text,
            s: text.as_bytes(),
            pos: 0,
        }
    }

    fn peek(&self) -> Option<u8> {
        self.s.get(self.pos).copied()
    }

    fn skip_wsp(&mut self) {
        while self.peek().is_some_and(is_wsp) {
            self.pos += 1;
        }
    }

    fn skip_comma_wsp(&mut self) {
        self.skip_wsp();
        if self.peek() == Some(b',') {
            self.pos += 1;
            self.skip_wsp();
        }
    }

    /// Whether a number starts here (after white space).
    fn at_number(&mut self) -> bool {
        self.skip_wsp();
        matches!(self.peek(), Some(b'0'..=b'9' | b'.' | b'+' | b'-'))
    }

    /// What is at the current position, for error messages.
    fn found(&self) -> String {
        match self.text.get(self.pos..).and_then(|r| r.chars().next()) {
            None => "the end of the data".to_string(),
            Some(c) => format!("`{c}`"),
        }
    }

    fn expected(&self, what: &str) -> SyntaxError {
        (self.pos, format!("expected {what}, found {}", self.found()))
    }

    /// A number (SVG grammar: sign, digits, optional fraction, optional
    /// exponent), then optional comma/white space. `1-2` and `.5.5` are two
    /// numbers each.
    fn number(&mut self) -> Result<f64, SyntaxError> {
        self.skip_wsp();
        let start = self.pos;
        let s = self.s;
        let mut i = self.pos;
        if matches!(s.get(i), Some(b'+' | b'-')) {
            i += 1;
        }
        let int0 = i;
        while s.get(i).is_some_and(u8::is_ascii_digit) {
            i += 1;
        }
        let mut digits = i - int0;
        if s.get(i) == Some(&b'.') {
            let f0 = i + 1;
            let mut j = f0;
            while s.get(j).is_some_and(u8::is_ascii_digit) {
                j += 1;
            }
            if digits > 0 || j > f0 {
                digits += j - f0;
                i = j;
            }
        }
        if digits == 0 {
            return Err(self.expected("a number"));
        }
        if matches!(s.get(i), Some(b'e' | b'E')) {
            let mut j = i + 1;
            if matches!(s.get(j), Some(b'+' | b'-')) {
                j += 1;
            }
            if s.get(j).is_some_and(u8::is_ascii_digit) {
                while s.get(j).is_some_and(u8::is_ascii_digit) {
                    j += 1;
                }
                i = j;
            }
        }
        let lexeme = &self.text[start..i];
        // Rust's parser wants digits on both sides of a '.' before an
        // exponent in some versions; normalise "1." and "1.e5".
        let v = lexeme
            .parse::<f64>()
            .or_else(|_| lexeme.replacen('.', ".0", 1).parse::<f64>())
            .map_err(|_| (start, format!("invalid number `{lexeme}`")))?;
        if !v.is_finite() {
            return Err((start, format!("number `{lexeme}` is out of range")));
        }
        self.pos = i;
        self.skip_comma_wsp();
        Ok(v)
    }

    fn pair(&mut self) -> Result<DVec2, SyntaxError> {
        let x = self.number()?;
        let y = self.number()?;
        Ok(DVec2::new(x, y))
    }

    /// An arc flag: a single `0` or `1` (so `014` is flags 0, 1 then 4).
    fn flag(&mut self) -> Result<bool, SyntaxError> {
        self.skip_wsp();
        let f = match self.peek() {
            Some(b'0') => false,
            Some(b'1') => true,
            _ => return Err(self.expected("an arc flag (0 or 1)")),
        };
        self.pos += 1;
        self.skip_comma_wsp();
        Ok(f)
    }
}

/// Where the points of the path go: only the first subpath is kept.
#[derive(PartialEq)]
enum Recording {
    /// Collecting the first subpath.
    On,
    /// The first subpath has ended; later geometry is parsed (so that syntax
    /// errors are still reported) but not kept.
    Done,
}

/// The flattened first subpath of SVG path data `d`. Errors are (byte
/// offset into `d`, reason).
fn path_points(d: &str) -> Result<Vec<DVec2>, SyntaxError> {
    let mut lx = Lexer::new(d);
    let mut out: Vec<DVec2> = Vec::new();
    let mut rec = Recording::On;
    let mut drawn = false;
    let mut cur = DVec2::ZERO;
    let mut start = DVec2::ZERO;
    // Second control point of the previous cubic (for S) or the control point
    // of the previous quadratic (for T).
    let mut prev_cubic: Option<DVec2> = None;
    let mut prev_quad: Option<DVec2> = None;
    let mut cmd: Option<u8> = None;

    lx.skip_wsp();
    if lx.peek().is_none() {
        return Err((0, "the path data is empty".into()));
    }
    loop {
        lx.skip_wsp();
        let Some(b) = lx.peek() else { break };
        let at = lx.pos;
        let this = if b.is_ascii_alphabetic() {
            if !b"MmLlHhVvCcSsQqTtAaZz".contains(&b) {
                return Err((at, format!("unknown path command `{}`", b as char)));
            }
            if cmd.is_none() && !matches!(b, b'M' | b'm') {
                return Err((at, "path data must begin with a moveto (M or m)".into()));
            }
            lx.pos += 1;
            b
        } else if lx.at_number() {
            match cmd {
                None => return Err((at, "path data must begin with a moveto (M or m)".into())),
                Some(b'Z' | b'z') => {
                    return Err((at, "a number cannot follow closepath (Z)".into()))
                }
                Some(b'M') => b'L',
                Some(b'm') => b'l',
                Some(c) => c,
            }
        } else {
            return Err(lx.expected("a path command or a number"));
        };
        let rel = this.is_ascii_lowercase();
        let base = if rel { cur } else { DVec2::ZERO };
        let mut seg: Vec<DVec2> = Vec::new();
        let mut cubic_ctrl = None;
        let mut quad_ctrl = None;
        match this.to_ascii_uppercase() {
            b'M' => {
                let p = base + lx.pair()?;
                if drawn {
                    rec = Recording::Done;
                } else if rec == Recording::On {
                    out.clear();
                    out.push(p);
                }
                cur = p;
                start = p;
            }
            b'Z' => {
                seg.push(start);
            }
            b'L' => seg.push(base + lx.pair()?),
            b'H' => {
                let x = lx.number()?;
                seg.push(DVec2::new(if rel { cur.x + x } else { x }, cur.y));
            }
            b'V' => {
                let y = lx.number()?;
                seg.push(DVec2::new(cur.x, if rel { cur.y + y } else { y }));
            }
            b'C' | b'S' => {
                let c1 = if this.eq_ignore_ascii_case(&b'C') {
                    base + lx.pair()?
                } else {
                    prev_cubic.map_or(cur, |c| 2.0 * cur - c)
                };
                let c2 = base + lx.pair()?;
                let p = base + lx.pair()?;
                flatten_cubic(cur, c1, c2, p, &mut seg);
                cubic_ctrl = Some(c2);
            }
            b'Q' | b'T' => {
                let c = if this.eq_ignore_ascii_case(&b'Q') {
                    base + lx.pair()?
                } else {
                    prev_quad.map_or(cur, |q| 2.0 * cur - q)
                };
                let p = base + lx.pair()?;
                flatten_quad(cur, c, p, &mut seg);
                quad_ctrl = Some(c);
            }
            b'A' => {
                let rx = lx.number()?;
                let ry = lx.number()?;
                let phi = lx.number()?;
                let large = lx.flag()?;
                let sweep = lx.flag()?;
                let p = base + lx.pair()?;
                flatten_arc(cur, rx, ry, phi, large, sweep, p, &mut seg);
            }
            _ => unreachable!("commands are checked above"),
        }
        if !cur.is_finite() || !seg.iter().all(|p| p.is_finite()) {
            return Err((at, "coordinates overflow (not finite)".into()));
        }
        if let Some(&last) = seg.last() {
            if rec == Recording::On {
                out.extend_from_slice(&seg);
            }
            drawn = true;
            cur = last;
        }
        if this.eq_ignore_ascii_case(&b'Z') {
            // The stroke is closed: whatever follows is another subpath.
            rec = Recording::Done;
        }
        prev_cubic = cubic_ctrl;
        prev_quad = quad_ctrl;
        cmd = Some(this);
    }
    Ok(out)
}

/// The points of a `<polyline>`/`<polygon>` `points` attribute (a polygon
/// closed by repeating its first point).
fn list_points(text: &str, close: bool) -> Result<Vec<DVec2>, SyntaxError> {
    let mut lx = Lexer::new(text);
    let mut out = Vec::new();
    loop {
        lx.skip_wsp();
        if lx.peek().is_none() {
            break;
        }
        let x = lx.number()?;
        if !lx.at_number() {
            return Err(lx.expected("the y coordinate (points come in x,y pairs)"));
        }
        let y = lx.number()?;
        out.push(DVec2::new(x, y));
    }
    if close {
        if let Some(&p) = out.first() {
            out.push(p);
        }
    }
    Ok(out)
}

/// Number of uniform pieces for a curve whose second derivative is at most
/// `m` in norm (over a unit parameter range) so that the chord deviation
/// `m·h²/8` stays within `tol`.
fn pieces(m: f64, tol: f64) -> usize {
    if tol.is_nan() || tol <= 0.0 || m.is_nan() || m <= 0.0 {
        return 1;
    }
    let n = (m / (8.0 * tol)).sqrt().ceil();
    if n.is_finite() {
        (n as usize).clamp(1, MAX_PIECES)
    } else {
        1
    }
}

/// Append the flattened cubic `p0 → p3` (without `p0`, ending exactly at `p3`).
fn flatten_cubic(p0: DVec2, p1: DVec2, p2: DVec2, p3: DVec2, out: &mut Vec<DVec2>) {
    let len = p0.distance(p1) + p1.distance(p2) + p2.distance(p3);
    let m = 6.0
        * (p0 - 2.0 * p1 + p2)
            .length()
            .max((p1 - 2.0 * p2 + p3).length());
    let n = pieces(m, FLATTEN_TOLERANCE * len);
    for i in 1..n {
        out.push(cubic_at(p0, p1, p2, p3, i as f64 / n as f64));
    }
    out.push(p3);
}

fn cubic_at(p0: DVec2, p1: DVec2, p2: DVec2, p3: DVec2, t: f64) -> DVec2 {
    let u = 1.0 - t;
    p0 * (u * u * u) + p1 * (3.0 * u * u * t) + p2 * (3.0 * u * t * t) + p3 * (t * t * t)
}

/// Append the flattened quadratic `p0 → p2` (without `p0`).
fn flatten_quad(p0: DVec2, p1: DVec2, p2: DVec2, out: &mut Vec<DVec2>) {
    let len = p0.distance(p1) + p1.distance(p2);
    let m = 2.0 * (p0 - 2.0 * p1 + p2).length();
    let n = pieces(m, FLATTEN_TOLERANCE * len);
    for i in 1..n {
        let t = i as f64 / n as f64;
        let u = 1.0 - t;
        out.push(p0 * (u * u) + p1 * (2.0 * u * t) + p2 * (t * t));
    }
    out.push(p2);
}

/// Append the flattened elliptical arc `p1 → p2` (without `p1`), converting
/// the endpoint parameterisation to the centre one per SVG 1.1 F.6.5, with
/// out-of-range radii handled per F.6.2 and F.6.6.
#[allow(clippy::too_many_arguments)]
fn flatten_arc(
    p1: DVec2,
    rx: f64,
    ry: f64,
    phi_deg: f64,
    large: bool,
    sweep: bool,
    p2: DVec2,
    out: &mut Vec<DVec2>,
) {
    // F.6.2: identical endpoints omit the arc; a zero radius makes it a line.
    if p1 == p2 {
        return;
    }
    let (mut rx, mut ry) = (rx.abs(), ry.abs());
    if rx == 0.0 || ry == 0.0 {
        out.push(p2);
        return;
    }
    let phi = (phi_deg % 360.0).to_radians();
    let (sin_phi, cos_phi) = phi.sin_cos();
    // Step 1: x1', y1'.
    let h = (p1 - p2) / 2.0;
    let x1 = cos_phi * h.x + sin_phi * h.y;
    let y1 = -sin_phi * h.x + cos_phi * h.y;
    // F.6.6: scale radii up when no ellipse through both points exists.
    let lambda = (x1 * x1) / (rx * rx) + (y1 * y1) / (ry * ry);
    let scaled = lambda > 1.0;
    if scaled {
        let s = lambda.sqrt();
        rx *= s;
        ry *= s;
    }
    // Step 2: centre in the primed frame. Scaled radii put the centre at the
    // chord's midpoint exactly (the radicand is 0 up to rounding, which the
    // square root would amplify).
    let (rx2, ry2, x12, y12) = (rx * rx, ry * ry, x1 * x1, y1 * y1);
    let num = rx2 * ry2 - rx2 * y12 - ry2 * x12;
    let den = rx2 * y12 + ry2 * x12;
    let mut coef = if den > 0.0 && !scaled {
        (num / den).max(0.0).sqrt()
    } else {
        0.0
    };
    if large == sweep {
        coef = -coef;
    }
    let cxp = coef * rx * y1 / ry;
    let cyp = -coef * ry * x1 / rx;
    // Step 3: centre.
    let mid = (p1 + p2) / 2.0;
    let c = DVec2::new(
        cos_phi * cxp - sin_phi * cyp + mid.x,
        sin_phi * cxp + cos_phi * cyp + mid.y,
    );
    // Step 4: start angle and sweep.
    let angle = |u: DVec2, v: DVec2| u.perp_dot(v).atan2(u.dot(v));
    let u = DVec2::new((x1 - cxp) / rx, (y1 - cyp) / ry);
    let v = DVec2::new((-x1 - cxp) / rx, (-y1 - cyp) / ry);
    let theta1 = angle(DVec2::X, u);
    let mut dtheta = angle(u, v);
    if !sweep && dtheta > 0.0 {
        dtheta -= std::f64::consts::TAU;
    } else if sweep && dtheta < 0.0 {
        dtheta += std::f64::consts::TAU;
    }
    // |E''| ≤ max(rx, ry) per unit of θ; tolerance relative to max(rx,ry)·|Δθ|.
    let r = rx.max(ry);
    let n = pieces(r * dtheta * dtheta, FLATTEN_TOLERANCE * r * dtheta.abs());
    for i in 1..n {
        let t = theta1 + dtheta * (i as f64 / n as f64);
        let (st, ct) = t.sin_cos();
        out.push(DVec2::new(
            c.x + rx * cos_phi * ct - ry * sin_phi * st,
            c.y + rx * sin_phi * ct + ry * cos_phi * st,
        ));
    }
    out.push(p2);
}

// ---------------------------------------------------------------------------
// Preview.

/// Colours the fitted pieces cycle through (red, blue, green), so that
/// neighbouring pieces can be told apart over the grey sketch.
const PIECE_COLOURS: [&str; 3] = ["#d62728", "#1f77b4", "#2ca02c"];

/// Write an SVG preview to `path` (atomically: a temporary file renamed into
/// place): the input `sketch` as a wide grey `<polyline>` (first, with
/// `id="sketch"`), then one `<polyline>` per fitted piece in `fits` (the
/// projections of the helix pieces, in the sketch's coordinates), colours
/// cycling through red, blue and green, then one `<circle>` per junction.
///
/// The `viewBox` fits all points with a 5% margin; strokes are 0.3% of its
/// diagonal (the sketch's twice that). Coordinates are written as given (no
/// y flip), so for an SVG sketch the preview overlays the original drawing;
/// reading the preview back with [`read_sketch`] gives the sketch again.
///
/// ```
/// use glam::DVec2;
/// use strandfit::io::{read_sketch, write_preview_svg};
///
/// let path = std::env::temp_dir().join(format!("strandfit-doc-preview-{}.svg", std::process::id()));
/// let sketch = [DVec2::ZERO, DVec2::new(1.0, 0.5), DVec2::new(2.0, 2.0)];
/// let fit = vec![DVec2::ZERO, DVec2::new(1.1, 0.4), DVec2::new(2.0, 2.0)];
/// write_preview_svg(&path, &sketch, &[fit], &[DVec2::new(1.1, 0.4)]).unwrap();
/// let svg = std::fs::read_to_string(&path).unwrap();
/// assert_eq!(svg.matches("<polyline").count(), 2); // the sketch, one piece
/// assert_eq!(svg.matches("<circle").count(), 1);
/// assert_eq!(read_sketch(&path).unwrap(), sketch);
/// std::fs::remove_file(&path).unwrap();
/// ```
pub fn write_preview_svg(
    path: &Path,
    sketch: &[DVec2],
    fits: &[Vec<DVec2>],
    junctions: &[DVec2],
) -> Result<(), IoError> {
    let bad = |what: String| IoError::new(path, "cannot draw a non-finite point").at(what);
    if let Some(i) = sketch.iter().position(|p| !p.is_finite()) {
        return Err(bad(format!("sketch point {i}")));
    }
    for (k, f) in fits.iter().enumerate() {
        if let Some(i) = f.iter().position(|p| !p.is_finite()) {
            return Err(bad(format!("piece {k}, point {i}")));
        }
    }
    if let Some(i) = junctions.iter().position(|p| !p.is_finite()) {
        return Err(bad(format!("junction {i}")));
    }
    let all = sketch.iter().chain(fits.iter().flatten()).chain(junctions);
    let (lo, hi) = all.fold(
        (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    if lo.x > hi.x {
        return Err(IoError::new(
            path,
            "nothing to draw: no points in the preview",
        ));
    }
    let size = hi - lo;
    let span = size.max_element();
    let span = if span > 0.0 { span } else { 1.0 };
    let margin = DVec2::new(
        0.05 * if size.x > 0.0 { size.x } else { span },
        0.05 * if size.y > 0.0 { size.y } else { span },
    );
    let origin = lo - margin;
    let extent = size + 2.0 * margin;
    let stroke = 0.003 * extent.length();
    // Display size: 1000 px along the longer side.
    let px = 1000.0 / extent.max_element();
    let (w_px, h_px) = (
        (extent.x * px).round().max(1.0),
        (extent.y * px).round().max(1.0),
    );

    let mut svg = String::new();
    svg.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    svg.push_str(&format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"{} {} {} {}\" width=\"{w_px}\" \
         height=\"{h_px}\">\n",
        origin.x, origin.y, extent.x, extent.y
    ));
    svg.push_str(&format!(
        "<title>strandfit sketch preview: {} sketch points, {} fitted pieces, {} junctions</title>\n",
        sketch.len(),
        fits.len(),
        junctions.len()
    ));
    let points = |pts: &[DVec2]| {
        pts.iter()
            .map(|p| format!("{},{}", p.x, p.y))
            .collect::<Vec<_>>()
            .join(" ")
    };
    svg.push_str(&format!(
        "<polyline id=\"sketch\" points=\"{}\" fill=\"none\" stroke=\"#9e9e9e\" \
         stroke-width=\"{}\" stroke-linecap=\"round\" stroke-linejoin=\"round\"/>\n",
        points(sketch),
        2.0 * stroke
    ));
    svg.push_str(
        "<g id=\"pieces\" fill=\"none\" stroke-linecap=\"round\" stroke-linejoin=\"round\">\n",
    );
    for (k, f) in fits.iter().enumerate() {
        svg.push_str(&format!(
            "<polyline id=\"piece-{k}\" points=\"{}\" stroke=\"{}\" stroke-width=\"{stroke}\"/>\n",
            points(f),
            PIECE_COLOURS[k % PIECE_COLOURS.len()]
        ));
    }
    svg.push_str("</g>\n<g id=\"junctions\" fill=\"white\" stroke=\"black\">\n");
    for j in junctions {
        svg.push_str(&format!(
            "<circle cx=\"{}\" cy=\"{}\" r=\"{}\" stroke-width=\"{}\"/>\n",
            j.x,
            j.y,
            2.0 * stroke,
            0.5 * stroke
        ));
    }
    svg.push_str("</g>\n</svg>\n");

    let mut file = AtomicFile::create(path)?;
    file.write_all(svg.as_bytes()).map_err(|e| file.err(e))?;
    file.commit()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn p(x: f64, y: f64) -> DVec2 {
        DVec2::new(x, y)
    }

    fn json(t: &str) -> Result<Vec<DVec2>, IoError> {
        parse_sketch_json(t, Path::new("s.json"))
    }
    fn csv(t: &str) -> Result<Vec<DVec2>, IoError> {
        parse_sketch_csv(t, Path::new("s.csv"))
    }
    fn svg(t: &str) -> Result<Vec<DVec2>, IoError> {
        parse_sketch_svg(t, Path::new("s.svg"))
    }
    fn svg_d(d: &str) -> Result<Vec<DVec2>, IoError> {
        svg(&format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\"><path d=\"{d}\"/></svg>"
        ))
    }
    /// The error's message, which must name the file.
    fn err_of(r: Result<Vec<DVec2>, IoError>, file: &str) -> String {
        let e = r.expect_err("expected an error").to_string();
        assert!(e.contains(file), "error does not name {file}: {e}");
        e
    }
    fn assert_has(msg: &str, parts: &[&str]) {
        for part in parts {
            assert!(msg.contains(part), "`{msg}` lacks `{part}`");
        }
    }
    fn close(a: DVec2, b: DVec2, tol: f64) -> bool {
        a.distance(b) <= tol
    }

    #[test]
    fn json_bare_array_and_object() {
        let want = vec![p(0.0, 0.0), p(1.0, 0.5), p(2.0, -1.0)];
        assert_eq!(json("[[0,0],[1,0.5],[2,-1]]").unwrap(), want);
        assert_eq!(
            json("{\"name\":\"s\",\"points\":[[0,0],[1,0.5],[1,0.5],[2,-1e0]]}").unwrap(),
            want
        );
    }

    #[test]
    fn json_errors_name_point_and_reason() {
        let e = err_of(json("[[0,0],[1,1],[2,2,3]]"), "s.json");
        assert_has(&e, &["point 2", "2D"]);
        let e = err_of(json("[[0,0],[1,\"a\"],[2,2]]"), "s.json");
        assert_has(&e, &["point 1", "not a number"]);
        let e = err_of(json("[[0,0],[1,NaN],[2,2]]"), "s.json");
        assert_has(&e, &["line 1", "not a JSON sketch"]);
        let e = err_of(json("[[0,0],[1,1],[2,"), "s.json");
        assert_has(&e, &["line 1, column", "not a JSON sketch"]);
        let e = err_of(json("{\"pts\":[]}"), "s.json");
        assert_has(&e, &["points"]);
        let e = err_of(json("[[0,0],[1,1]]"), "s.json");
        assert_has(&e, &["at least 3 distinct points, found 2"]);
        let e = err_of(json("[[1,1],[1,1],[1,1],[1,1]]"), "s.json");
        assert_has(&e, &["at least 3 distinct points, found 1"]);
        // Three points, but only two distinct.
        let e = err_of(json("[[0,0],[1,1],[0,0]]"), "s.json");
        assert_has(&e, &["found 2"]);
    }

    #[test]
    fn csv_header_comments_separators() {
        let want = vec![p(0.0, 0.0), p(1.5, 2.0), p(3.0, -4.0), p(5.0, 6.0)];
        let text = "\u{feff}x;y\n# a comment\n0;0\n\n1.5 ; 2 # trailing\n3,-4\n5\t6\r\n";
        assert_eq!(csv(text).unwrap(), want);
        assert_eq!(csv("0 0\n1.5   2\n3 -4\n5 6").unwrap(), want);
    }

    #[test]
    fn csv_errors_name_line() {
        let e = err_of(csv("x,y\n0,0\n1,NaN\n2,2\n"), "s.csv");
        assert_has(&e, &["line 3", "not finite"]);
        let e = err_of(csv("0,0\n1,inf\n2,2\n"), "s.csv");
        assert_has(&e, &["line 2", "not finite"]);
        let e = err_of(csv("0,0\n1,1,1\n2,2\n"), "s.csv");
        assert_has(&e, &["line 2", "2D"]);
        let e = err_of(csv("0,0\n1,a\n2,2\n"), "s.csv");
        assert_has(&e, &["line 2", "`a` is not a number"]);
        let e = err_of(csv("0,0\n1\n"), "s.csv");
        assert_has(&e, &["line 2", "1 fields"]);
        // Only the first content line may be a header.
        let e = err_of(csv("0,0\nx,y\n2,2\n"), "s.csv");
        assert_has(&e, &["line 2", "not a number"]);
        let e = err_of(csv("x,y\n0,0\n1,1\n"), "s.csv");
        assert_has(&e, &["found 2"]);
        let e = err_of(csv(""), "s.csv");
        assert_has(&e, &["found 0"]);
    }

    #[test]
    fn extension_dispatch() {
        let dir = tempfile::tempdir().unwrap();
        let e = read_sketch(&dir.path().join("stroke.png"))
            .unwrap_err()
            .to_string();
        assert_has(&e, &["stroke.png", ".png", ".json", ".csv", ".txt", ".svg"]);
        let e = read_sketch(&dir.path().join("stroke"))
            .unwrap_err()
            .to_string();
        assert_has(&e, &["no extension", ".svg"]);
        let f = dir.path().join("stroke.JSON");
        std::fs::write(&f, "[[0,0],[1,0],[1,1]]").unwrap();
        assert_eq!(read_sketch(&f).unwrap().len(), 3);
        let f = dir.path().join("stroke.txt");
        std::fs::write(&f, "0 0\n1 0\n1 1\n").unwrap();
        assert_eq!(read_sketch(&f).unwrap().len(), 3);
        let f = dir.path().join("missing.svg");
        let e = read_sketch(&f).unwrap_err().to_string();
        assert_has(&e, &["missing.svg", "cannot read"]);
    }

    #[test]
    fn svg_lines_absolute_and_relative() {
        let want = vec![
            p(1.0, 2.0),
            p(4.0, 2.0),
            p(4.0, 6.0),
            p(0.0, 6.0),
            p(1.0, 2.0),
        ];
        assert_eq!(svg_d("M1 2 L4 2 V6 H0 Z").unwrap(), want);
        assert_eq!(svg_d("m1 2 l3 0 v4 h-4 z").unwrap(), want);
        // Implicit lineto after moveto, absolute and relative.
        assert_eq!(svg_d("M1,2 4,2 4,6 0,6 1,2").unwrap(), want);
        assert_eq!(svg_d("m1,2 3,0 0,4 -4,0 1,-4").unwrap(), want);
        // Implicit repetition of H and duplicate removal.
        assert_eq!(
            svg_d("M0 0 H1 2 2 V1").unwrap(),
            vec![p(0.0, 0.0), p(1.0, 0.0), p(2.0, 0.0), p(2.0, 1.0)]
        );
    }

    #[test]
    fn svg_only_first_subpath() {
        // A second moveto after drawing ends the stroke.
        assert_eq!(
            svg_d("M0 0 L1 0 L1 1 M5 5 L6 6").unwrap(),
            vec![p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0)]
        );
        // Movetos before any drawing: the last one starts the stroke.
        assert_eq!(
            svg_d("M9 9 M0 0 L1 0 L1 1").unwrap(),
            vec![p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0)]
        );
        // Z ends it (a drawing command after Z would start a new subpath).
        assert_eq!(
            svg_d("M0 0 L1 0 L1 1 Z L7 7").unwrap(),
            vec![p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0), p(0.0, 0.0)]
        );
        // Syntax errors after the first subpath are still reported.
        let e = err_of(svg_d("M0 0 L1 0 L1 1 M5 5 L6"), "s.svg");
        assert_has(&e, &["expected a number"]);
    }

    #[test]
    fn svg_straight_cubic() {
        // Control points evenly spaced on a line: the curve is the segment.
        let pts = svg_d("M0 0 C1 1 2 2 3 3 L4 0").unwrap();
        assert_eq!(pts, vec![p(0.0, 0.0), p(3.0, 3.0), p(4.0, 0.0)]);
        // Collinear but unevenly spaced: points stay on the line, in order.
        let pts = svg_d("M0 0 C0.2 0 2.9 0 3 0 L3 1").unwrap();
        assert_eq!(*pts.last().unwrap(), p(3.0, 1.0));
        let line = &pts[..pts.len() - 1];
        assert!(line.len() > 2);
        assert!(line.iter().all(|q| q.y == 0.0));
        assert!(line.windows(2).all(|w| w[0].x < w[1].x));
    }

    /// Largest distance from the curve `f` over `[t0, t1]` to the chord
    /// `a b`, by dense sampling.
    fn chord_deviation(f: &dyn Fn(f64) -> DVec2, t0: f64, t1: f64, a: DVec2, b: DVec2) -> f64 {
        let d = b - a;
        (0..=64)
            .map(|k| {
                let q = f(t0 + (t1 - t0) * k as f64 / 64.0);
                let s = ((q - a).dot(d) / d.length_squared()).clamp(0.0, 1.0);
                q.distance(a + d * s)
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn svg_cubic_matches_direct_evaluation() {
        let (p0, p1, p2, p3) = (p(10.0, 80.0), p(40.0, 10.0), p(65.0, 10.0), p(95.0, 80.0));
        let pts = svg_d("M10 80 C 40 10, 65 10, 95 80").unwrap();
        let n = pts.len() - 1;
        assert!(n >= 8, "{n} pieces");
        let b = |t: f64| cubic_at(p0, p1, p2, p3, t);
        for (i, q) in pts.iter().enumerate() {
            assert!(close(*q, b(i as f64 / n as f64), 1e-12), "point {i}");
        }
        assert_eq!(pts[0], p0);
        assert_eq!(pts[n], p3);
        let tol = FLATTEN_TOLERANCE * (p0.distance(p1) + p1.distance(p2) + p2.distance(p3));
        for i in 0..n {
            let dev = chord_deviation(
                &b,
                i as f64 / n as f64,
                (i + 1) as f64 / n as f64,
                pts[i],
                pts[i + 1],
            );
            assert!(dev <= tol, "piece {i}: deviation {dev} > {tol}");
        }
        // Relative form and S reflection give the same curve: the S below
        // reflects (65,10) about (95,80) to (125,150).
        let rel = svg_d("m10 80 c30 -70 55 -70 85 0").unwrap();
        assert!(rel.iter().zip(&pts).all(|(a, b)| close(*a, *b, 1e-9)));
        let s = svg_d("M10 80 C 40 10, 65 10, 95 80 S 150 150, 180 80").unwrap();
        let c = svg_d("M10 80 C 40 10, 65 10, 95 80 C 125 150, 150 150, 180 80").unwrap();
        assert_eq!(s, c);
    }

    #[test]
    fn svg_quadratic_and_t_reflection() {
        let t = svg_d("M0 0 Q1 2 2 0 T4 0").unwrap();
        let q = svg_d("M0 0 Q1 2 2 0 Q3 -2 4 0").unwrap();
        assert_eq!(t, q);
        let n = q.iter().position(|&x| x == p(2.0, 0.0)).unwrap();
        for (i, v) in q[..=n].iter().enumerate() {
            let s = i as f64 / n as f64;
            let want = p(2.0 * s, 4.0 * s * (1.0 - s));
            assert!(close(*v, want, 1e-12));
        }
        // T with no preceding Q: the control point is the current point (a line).
        let pts = svg_d("M0 0 L1 1 T3 3 L3 0").unwrap();
        assert_eq!(*pts.last().unwrap(), p(3.0, 0.0));
        assert!(pts[..pts.len() - 1]
            .iter()
            .all(|q| (q.x - q.y).abs() < 1e-12));
    }

    #[test]
    fn svg_quarter_circle_arc() {
        let r = 10.0;
        let pts = svg_d("M10 0 A10 10 0 0 1 0 10").unwrap();
        assert_eq!(pts[0], p(10.0, 0.0));
        assert_eq!(*pts.last().unwrap(), p(0.0, 10.0));
        assert!(pts.len() > 8);
        for q in &pts {
            assert!((q.length() - r).abs() <= 1e-3 * r, "{q} off the circle");
            assert!((q.length() - r).abs() <= 1e-12 * r);
            assert!(
                q.x >= -1e-12 && q.y >= -1e-12,
                "{q} not in the first quadrant"
            );
        }
        // The chords stay within the tolerance of the circle.
        let tol = FLATTEN_TOLERANCE * r * PI / 2.0;
        for w in pts.windows(2) {
            let sagitta = r - ((w[0] + w[1]) / 2.0).length();
            assert!(sagitta <= tol && sagitta <= 2e-3 * r, "sagitta {sagitta}");
        }
        // The other sweep flag with the small arc: the quarter circle about
        // (10, 10).
        let other = svg_d("M10 0 A10 10 0 0 0 0 10").unwrap();
        for q in &other {
            assert!((q.distance(p(10.0, 10.0)) - r).abs() <= 1e-9);
        }
        // Large arc, sweep 1: three quarters around (10, 10).
        let big = svg_d("M10 0 A10 10 0 1 1 0 10").unwrap();
        for q in &big {
            assert!((q.distance(p(10.0, 10.0)) - r).abs() <= 1e-9);
        }
        assert!(big.iter().any(|q| q.x > 19.9));
    }

    #[test]
    fn svg_arc_radius_scaling_rotation_degenerate() {
        // Radii too small: scaled up to a half circle of radius 5 about (5, 0).
        let pts = svg_d("M0 0 A1 1 0 0 1 10 0 L10 5").unwrap();
        for q in &pts[..pts.len() - 1] {
            assert!((q.distance(p(5.0, 0.0)) - 5.0).abs() <= 1e-9, "{q}");
        }
        assert!(pts.iter().any(|q| close(*q, p(5.0, -5.0), 0.1)));
        // Rotating the ellipse by 90° swaps its radii.
        let a = svg_d("M0 0 A20 10 90 0 1 15 12").unwrap();
        let b = svg_d("M0 0 A10 20 0 0 1 15 12").unwrap();
        assert_eq!(a.len(), b.len());
        assert!(a.iter().zip(&b).all(|(x, y)| close(*x, *y, 1e-9)));
        // A zero radius is a straight line; same endpoints omit the arc.
        assert_eq!(
            svg_d("M0 0 A0 5 0 0 1 3 4 A5 5 0 0 1 3 4 L3 0").unwrap(),
            vec![p(0.0, 0.0), p(3.0, 4.0), p(3.0, 0.0)]
        );
    }

    #[test]
    fn svg_number_lexing() {
        assert_eq!(
            path_points("M0,0L.5.5").unwrap(),
            vec![p(0.0, 0.0), p(0.5, 0.5)]
        );
        assert_eq!(
            path_points("M0 0l1-2").unwrap(),
            vec![p(0.0, 0.0), p(1.0, -2.0)]
        );
        assert_eq!(
            path_points("M-1.5e-3,2E+1L+3.,-.25e1").unwrap(),
            vec![p(-1.5e-3, 20.0), p(3.0, -2.5)]
        );
        assert_eq!(path_points("M1e2-1e-2").unwrap(), vec![p(100.0, -0.01)]);
        // Compact arc flags: `014` is large-arc 0, sweep 1, x = 4.
        let compact = path_points("M0 0a1 1 0 014 4").unwrap();
        let spaced = path_points("M0 0 a1,1 0 0,1 4,4").unwrap();
        assert_eq!(compact, spaced);
        assert_eq!(*compact.last().unwrap(), p(4.0, 4.0));
        assert!(compact.len() > 3);
        let c = p(2.0, 2.0);
        for q in &compact {
            assert!((q.distance(c) - 8f64.sqrt()).abs() <= 1e-9);
        }
        // A flag must be 0 or 1.
        let (off, msg) = path_points("M0 0a1 1 0 2 1 4 4").unwrap_err();
        assert_eq!(off, 11);
        assert!(msg.contains("arc flag"), "{msg}");
    }

    #[test]
    fn svg_path_data_errors() {
        let e = err_of(svg_d("M 0 0 L 1 x"), "s.svg");
        assert_has(&e, &["path data offset 10", "line 1", "`x`"]);
        let e = err_of(svg_d("L 0 0 1 1 2 0"), "s.svg");
        assert_has(&e, &["path data offset 0", "moveto"]);
        let e = err_of(svg_d("M0 0 L1 1 L2"), "s.svg");
        assert_has(
            &e,
            &[
                "path data offset 12",
                "expected a number",
                "end of the data",
            ],
        );
        let e = err_of(svg_d("M0 0 L1 1 Z 3 3"), "s.svg");
        assert_has(&e, &["offset 12", "closepath"]);
        let e = err_of(svg_d("M0 0 L1e999 1 L2 0"), "s.svg");
        assert_has(&e, &["offset 6", "out of range"]);
        let e = err_of(svg_d("M0 0 X1 1"), "s.svg");
        assert_has(&e, &["offset 5", "unknown path command `X`"]);
        let e = err_of(svg_d("  "), "s.svg");
        assert_has(&e, &["empty"]);
        let e = err_of(svg_d("M0 0 L1 1"), "s.svg");
        assert_has(&e, &["at least 3 distinct points, found 2"]);
        let e = err_of(svg_d("M0 0 L0 0 L0 0 Z"), "s.svg");
        assert_has(&e, &["found 1"]);
    }

    #[test]
    fn svg_document_structure() {
        // Comments, namespaces, single quotes, spaces around `=`, and an
        // earlier <polyline> (a <path> takes precedence).
        let doc = "<?xml version='1.0'?>\n<!DOCTYPE svg>\n<!-- <path d=\"M9 9 L8 8 L7 9\"/> -->\n\
                   <svg:svg xmlns:svg='http://www.w3.org/2000/svg'>\n\
                   <svg:polyline points='5,5 6,6 7,5'/>\n\
                   <svg:path id='s' d = 'M0 0 L1 0 L1 1' stroke='black'></svg:path></svg:svg>";
        assert_eq!(
            svg(doc).unwrap(),
            vec![p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0)]
        );
        // Polyline and polygon (closed) without a path.
        let doc = "<svg><polyline fill='none' points='0,0 1,0 1,1 2,1'/></svg>";
        assert_eq!(svg(doc).unwrap().len(), 4);
        let doc = "<svg><polygon points='0 0 1 0 1 1'/></svg>";
        assert_eq!(
            svg(doc).unwrap(),
            vec![p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0), p(0.0, 0.0)]
        );
        let e = err_of(svg("<svg><polyline points='0,0 1,0 1'/></svg>"), "s.svg");
        assert_has(&e, &["points offset 9", "pairs"]);
        // Transforms are refused, on the element or inherited.
        let e = err_of(
            svg("<svg><path transform='scale(2)' d='M0 0 L1 0 L1 1'/></svg>"),
            "s.svg",
        );
        assert_has(&e, &["transform", "not supported", "<path>"]);
        let e = err_of(
            svg("<svg><g transform='translate(1,1)'><g><path d='M0 0 L1 0 L1 1'/></g></g></svg>"),
            "s.svg",
        );
        assert_has(&e, &["enclosing <g>", "transform"]);
        // ...but a transformed sibling group that is closed does not matter.
        let doc =
            "<svg><g transform='scale(2)'><circle r='1'/></g><path d='M0 0 L1 0 L1 1'/></svg>";
        assert_eq!(svg(doc).unwrap().len(), 3);
        // Missing attribute, missing element, truncated tag.
        let e = err_of(svg("<svg>\n<path fill='red'/></svg>"), "s.svg");
        assert_has(&e, &["no d attribute", "line 2"]);
        let e = err_of(svg("hello, world"), "s.svg");
        assert_has(&e, &["no <path>"]);
        let e = err_of(svg("<svg><path d='M0 0 L1 0"), "s.svg");
        assert_has(&e, &["unterminated value of attribute `d`"]);
        let e = err_of(
            svg("<svg><!-- never closed <path d='M0 0 L1 0 L1 1'/>"),
            "s.svg",
        );
        assert_has(&e, &["unterminated comment"]);
    }

    /// Deterministic garbage: every parser must return, never panic.
    #[test]
    fn no_panics_on_truncated_or_garbage_input() {
        let samples = [
            (
                "svg",
                "<svg><path d=\"M10 80 C40 10 65 10 95 80 S150 150 180 80 Q1 2 3 4 T5 6 \
                 A25 25 -30 0 1 50 -25 a1 1 0 014 4 h1 v1 z\"/></svg>",
            ),
            ("svg", "<svg><polygon points='0,0 1,0 1,1'/></svg>"),
            ("json", "{\"points\": [[0, 0], [1, 0.5], [2, -1e3]]}"),
            ("csv", "x;y\n# c\n0;0\n1;2\n3 4\n"),
        ];
        let parse = |kind: &str, t: &str| {
            let path = Path::new("g");
            let _ = match kind {
                "svg" => parse_sketch_svg(t, path),
                "json" => parse_sketch_json(t, path),
                _ => parse_sketch_csv(t, path),
            };
            let _ = path_points(t);
            let _ = list_points(t, true);
        };
        for (kind, text) in samples {
            for cut in 0..=text.len() {
                parse(kind, &text[..cut]);
                parse(kind, &text[cut..]);
            }
        }
        let alphabet = b"MmLlHhVvCcSsQqTtAaZzXe0123456789.,+-  \n\t<>/=\"'#;[]{}pathdpoints";
        let mut state = 0x2545_f491_4f6c_dd1du64;
        for len in 0..400 {
            let text: String = (0..len % 60)
                .map(|_| {
                    state ^= state << 13;
                    state ^= state >> 7;
                    state ^= state << 17;
                    alphabet[(state % alphabet.len() as u64) as usize] as char
                })
                .collect();
            for kind in ["svg", "json", "csv"] {
                parse(kind, &text);
            }
            parse("svg", &format!("<path d='{text}'/>"));
            parse("svg", &format!("<polyline points='{text}'/>"));
        }
        // Absurd values: overflow is an error, not a panic or a NaN point.
        let e = err_of(svg_d("M1e308 0 l1e308 0 l1e308 1 l0 1"), "s.svg");
        assert_has(&e, &["not finite"]);
        let _ = svg_d("M0 0 A1e308 1e-308 1e308 1 1 1e308 -1e308 L0 1 L 1 1");
        let _ = svg_d("M0 0 C1e308 1e308 -1e308 -1e308 1e308 0 L0 1");
    }

    #[test]
    fn preview_svg_written_atomically() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("preview.svg");
        let sketch: Vec<DVec2> = (0..20)
            .map(|i| p(i as f64, (i as f64 * 0.3).sin() * 5.0))
            .collect();
        let fits = vec![
            sketch[..8].to_vec(),
            sketch[7..15].to_vec(),
            sketch[14..].to_vec(),
        ];
        let junctions = vec![sketch[7], sketch[14]];
        write_preview_svg(&out, &sketch, &fits, &junctions).unwrap();

        let text = std::fs::read_to_string(&out).unwrap();
        assert_eq!(text.matches("<polyline").count(), fits.len() + 1);
        assert_eq!(text.matches("<circle").count(), junctions.len());
        assert!(text.contains("<title>"));
        for colour in PIECE_COLOURS {
            assert!(text.contains(colour));
        }
        // The viewBox holds every point with a margin.
        let vb = text
            .split("viewBox=\"")
            .nth(1)
            .unwrap()
            .split('"')
            .next()
            .unwrap();
        let v: Vec<f64> = vb.split(' ').map(|x| x.parse().unwrap()).collect();
        assert_eq!(v.len(), 4);
        for q in sketch.iter() {
            assert!(q.x > v[0] && q.x < v[0] + v[2] && q.y > v[1] && q.y < v[1] + v[3]);
        }
        // Only the preview is left in the directory (no temporary file).
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from("preview.svg")]);
        // Reading the preview back gives the sketch (first polyline, exact).
        assert_eq!(read_sketch(&out).unwrap(), sketch);

        // Degenerate box (a horizontal line) and empty input.
        let flat = vec![p(0.0, 1.0), p(1.0, 1.0), p(2.0, 1.0)];
        write_preview_svg(&out, &flat, std::slice::from_ref(&flat), &[]).unwrap();
        assert!(!std::fs::read_to_string(&out).unwrap().contains("NaN"));
        let e = write_preview_svg(&out, &[], &[], &[])
            .unwrap_err()
            .to_string();
        assert_has(&e, &["preview.svg", "nothing to draw"]);
        let e = write_preview_svg(&out, &flat, &[vec![p(f64::NAN, 0.0)]], &[])
            .unwrap_err()
            .to_string();
        assert_has(&e, &["piece 0, point 0", "non-finite"]);
    }
}
