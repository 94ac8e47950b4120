//! Inter-curve prediction: a curve's points predicted from a neighbour, as
//! `Reference` describes.

use std::cell::Cell;

use glam::DVec3;

use super::quantise::{bcc_nearest, bcc_point};

/// How far back a reference or an anchor may be, in curves of the same
/// block. Neighbours in space need not be neighbours in the file (field
/// lines traced from seeds spread over a sphere, hairs of a clump rooted
/// apart): 128 against 32 made the field lines 1.4 % / 3.5 % smaller at
/// 0.001 / 0.01 R☉ and the fornix replicas 1.2 % at 0.1 mm, for 5–10 %
/// more encoding time (256: no smaller, twice the time).
pub const MAX_BACK: usize = 128;
/// References whose end points are nearest are costed in full; the others
/// are not tried (the search stays `O(n)` per curve).
const SHORTLIST: usize = 4;

/// A curve's reference: `back` curves before it, maybe reversed; and maybe
/// a second one, whose steps are averaged with the first's.
///
/// Fibres of a bundle, hairs of a clump and field lines of an active region
/// run side by side: a curve's next step is better predicted by the step
/// its neighbour takes at the same place than by its own last step. A
/// points-mode curve may name one of the `MAX_BACK` (128) curves before it in
/// its block (either direction) as its *reference*; its step `i` is then
/// predicted as the reference's step between the matching points
/// `j(i − 1)` and `j(i)`, with `j(i) = round(i (m − 1) / (n − 1))` for a
/// curve of `n` and a reference of `m` points, and its start by the
/// reference's start. The reference is the decoded curve rounded to the
/// points grid, which the decoder computes exactly as the encoder does.
///
/// On the resampled bundles of the shared data (20 points 4–11 mm apart) the
/// best of the 32 previous curves cuts the residuals' entropy from 3.5 to 2.4
/// bits per coordinate at 0.5 mm (docs/reference.md, "Compression, measured");
/// the encoder picks by estimated cost, so a curve with no good neighbour keeps
/// its own second-order prediction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Reference {
    /// How many curves before this one it is (1: the previous curve).
    pub back: usize,
    /// Whether its points run the other way.
    pub reversed: bool,
    /// `(back, reversed)` of the second reference.
    pub second: Option<(usize, bool)>,
    /// Whether its steps are walked (from the point nearest the curve along the reference; codec model 12
    /// on, a flag per curve: matching indices predicts a fibre sampled as
    /// its neighbour is, walking one sampled elsewhere).
    pub walk: bool,
}

impl Reference {
    /// The curves this names among `earlier` (the regridded curves before
    /// the one it predicts, the last of them one back), for predictions by
    /// `rule`.
    pub fn resolve<'a>(&self, earlier: &'a [Vec<[i64; 3]>], rule: Rule) -> Resolved<'a> {
        let at_back = |b: usize| &earlier[earlier.len() - b][..];
        Resolved {
            first: (at_back(self.back), self.reversed),
            second: self.second.map(|(b, rev)| (at_back(b), rev)),
            trend: rule.trend,
            walk: rule.walk && self.walk,
        }
    }
}

/// The curves a [`Reference`] names, resolved: each with its direction.
#[derive(Clone, Copy)]
pub struct Resolved<'a> {
    pub first: (&'a [[i64; 3]], bool),
    pub second: Option<(&'a [[i64; 3]], bool)>,
    /// Whether the offset's trend corrects the prediction
    /// ([`predict_in`](Self::predict_in); codec model 8 on).
    pub trend: bool,
    /// Whether a step is predicted by walking along the reference from the
    /// point nearest the curve ([`predict_in`](Self::predict_in); codec
    /// model 12 on).
    pub walk: bool,
}

/// How a reference predicts, by codec model: with the offset's trend
/// (model 8 on); by walking where the curve's flag says so (model 12 on).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rule {
    pub trend: bool,
    pub walk: bool,
}

impl Rule {
    /// The rule of codec `model`.
    pub fn of_model(model: u8) -> Self {
        Rule {
            trend: model >= 8,
            walk: model >= 12,
        }
    }
}

impl Resolved<'_> {
    /// Prediction of the start: the first reference's start, or the lattice
    /// point nearest the two starts' midpoint.
    pub fn start(&self) -> [i64; 3] {
        let (r, rev) = self.first;
        let a = at(r, 0, rev);
        match self.second {
            None => a,
            Some((r2, rev2)) => midpoint(a, at(r2, 0, rev2)),
        }
    }

    /// Prediction of point `i ≥ 1` of `n` given the points before it
    /// (`g[..i]`; only the last two are read): from the last, the
    /// reference's matching step, or the mean of the two references' steps
    /// rounded to the lattice (two neighbours' wiggles are independent, so
    /// their mean step is a steadier prediction); and with
    /// [`trend`](Self::trend) a quarter of the
    /// change in the curve's offset from the (first) reference over its
    /// last step. Fibres of a bundle fan out and gather: the offset from a
    /// neighbour drifts smoothly (a quarter: 1–2 % smaller bundles than 0,
    /// ⅛, ⅜ or ½; a whole step, 5–13 % larger).
    #[inline]
    pub fn predict_in(&self, g: &[[i64; 3]], i: usize, n: usize) -> [i64; 3] {
        if self.walk && i >= 2 {
            if let Some(p) = self.walked(g, i, n) {
                return p;
            }
        }
        self.matched(g, i, n)
    }

    /// [`predict_in`](Self::predict_in) by matching point indices (what a
    /// walk falls back to).
    #[inline]
    fn matched(&self, g: &[[i64; 3]], i: usize, n: usize) -> [i64; 3] {
        self.matched_with(g, i, n, &Cell::new(None))
    }

    /// [`matched`](Self::matched), the first reference's matching indices
    /// of points `i − 2`, `i − 1` and `i` kept in `indices` (each index a
    /// division: predicted in order, one a point instead of three).
    // Inlined into the decoder's and the slide's point loops: a call on
    // the chain from one point to the next costs more than its
    // instructions (session 38: with `quarter_nearest` and
    // `AlongStep::half_prediction` also inlined, 2.5–4 % less time to
    // decode, 3 % less CPU to compress, 100,000 replicas at 0.1 mm).
    #[inline(always)]
    fn matched_with(
        &self,
        g: &[[i64; 3]],
        i: usize,
        n: usize,
        indices: &Cell<Option<(usize, [usize; 3])>>,
    ) -> [i64; 3] {
        // Each reference point looked up once: the lookups' divisions were a
        // tenth of decoding.
        let (r, rev) = self.first;
        let m = r.len();
        let j = match indices.get() {
            Some((k, j)) if k == i => j,
            Some((k, j)) if k + 1 == i => [j[1], j[2], matching(i, n, m)],
            _ => [
                if i >= 2 { matching(i - 2, n, m) } else { 0 },
                matching(i - 1, n, m),
                matching(i, n, m),
            ],
        };
        indices.set(Some((i, j)));
        let before = at(r, j[1], rev);
        let here = at(r, j[2], rev);
        let prev = g[i - 1];
        let p1 = [0, 1, 2].map(|a| prev[a].wrapping_add(here[a].wrapping_sub(before[a])));
        let base = match self.second {
            None => p1,
            Some((r2, rev2)) => midpoint(p1, predict(prev, i, n, r2, rev2)),
        };
        if !self.trend || i < 2 {
            return base;
        }
        let earlier = at(r, j[0], rev);
        let prev2 = g[i - 2];
        let trend = [0, 1, 2].map(|a| {
            let off1 = prev[a].wrapping_sub(before[a]);
            let off2 = prev2[a].wrapping_sub(earlier[a]);
            off1.wrapping_sub(off2)
        });
        quarter_nearest(base, trend)
    }
}

impl Resolved<'_> {
    /// The walked prediction of point `i ≥ 2` of `n` (codec model 12):
    /// from the last point `p`, the reference's chord from the point on it
    /// nearest `p` to the point as far along it as the curve's last step
    /// is long; with two references the mean of their chords; with
    /// [`trend`](Self::trend) a quarter of the change in the offset from
    /// the first reference's nearest point over the last step; rounded to
    /// the lattice. `None` where a reference has fewer than two points or
    /// the prediction is not codable (the index-matched prediction then).
    ///
    /// The index-matched step ([`predict`]) assumes the two curves are
    /// sampled alike from the same place; fibres of a bundle start and end
    /// at different depths and are resampled to the same count over
    /// different lengths, so point `i` of one lies beside another's point
    /// `j ≠ i·(m−1)/(n−1)` and its step is another length. Measured offline
    /// (empirical entropy of the rounded residuals, each curve against the
    /// best of the 128 before it): 0.3–0.5 bits per coordinate less on the
    /// resampled bundles at 0.1 mm, about 1 bit on the fornix.
    fn walked(&self, g: &[[i64; 3]], i: usize, n: usize) -> Option<[i64; 3]> {
        self.walked_with(g, i, n, &Cell::new(None))
    }

    /// [`walked`](Self::walked), with the first reference's nearest point
    /// to a point of the curve kept in `foot` for the next prediction's
    /// trend (the same point for the same point and index: a third less
    /// work where points are predicted in order).
    fn walked_with(
        &self,
        g: &[[i64; 3]],
        i: usize,
        n: usize,
        foot: &Cell<Option<(usize, [i64; 3], DVec3)>>,
    ) -> Option<[i64; 3]> {
        let v = |k: [i64; 3]| DVec3::new(k[0] as f64, k[1] as f64, k[2] as f64);
        let (p, before) = (v(g[i - 1]), v(g[i - 2]));
        let length = p.distance(before);
        let (r, rev) = self.first;
        let kept = foot.get();
        let (foot_here, step) = walk_step(r, rev, matching(i - 1, n, r.len()), p, length)?;
        foot.set(Some((i - 1, g[i - 1], foot_here)));
        let foot = foot_here;
        let mut x = match self.second {
            None => p + step,
            Some((r2, rev2)) => {
                let (_, step2) = walk_step(r2, rev2, matching(i - 1, n, r2.len()), p, length)?;
                p + (step + step2) * 0.5
            }
        };
        if self.trend {
            let foot_before = match kept {
                Some((k, q, f)) if k == i - 2 && q == g[i - 2] => f,
                _ => walk_step(r, rev, matching(i - 2, n, r.len()), before, 0.0)?.0,
            };
            x += ((p - foot) - (before - foot_before)) * 0.25;
        }
        bcc_nearest(x, 1.0)
    }

    /// [`predict_in`](Self::predict_in) for points predicted in order,
    /// keeping what the next prediction reuses in `foot`.
    #[inline]
    pub fn predict_next(
        &self,
        g: &[[i64; 3]],
        i: usize,
        n: usize,
        cache: &PredictionCache,
    ) -> [i64; 3] {
        if self.walk && i >= 2 {
            if let Some(p) = self.walked_with(g, i, n, &cache.foot) {
                return p;
            }
        }
        self.matched_with(g, i, n, &cache.indices)
    }
}

/// What [`Resolved::predict_next`] keeps between predictions of one curve
/// against one reference: the first reference's nearest point to point `k`
/// of the curve, `(k, the point, its nearest point)`, for walked
/// predictions; and the matching indices of the last point predicted by
/// index, `(i, [j(i − 2), j(i − 1), j(i)])`.
#[derive(Default)]
pub struct PredictionCache {
    foot: Cell<Option<(usize, [i64; 3], DVec3)>>,
    indices: Cell<Option<(usize, [usize; 3])>>,
}

/// Segments a nearest-point search moves from its start at most (each way):
/// the search stays `O(1)` per point, and a curve's time linear in its
/// length, however far apart along the bundle two fibres' points lie.
const WALK_SEARCH: usize = 32;

/// On the polyline `r` (lattice units; run backwards when `rev`): the point
/// nearest `p` (searched from segment `hint` towards nearer segments, at
/// most [`WALK_SEARCH`] of them; past the first and last vertex along the
/// end segments' lines), and the chord from it to the point `length`
/// further along the polyline (past its last vertex, along the last
/// segment's line). `None` with fewer than two points.
fn walk_step(
    r: &[[i64; 3]],
    rev: bool,
    hint: usize,
    p: DVec3,
    length: f64,
) -> Option<(DVec3, DVec3)> {
    let m = r.len();
    if m < 2 {
        return None;
    }
    let segs = m - 1;
    let point = |j: usize| {
        let k = at(r, j, rev);
        DVec3::new(k[0] as f64, k[1] as f64, k[2] as f64)
    };
    // Segment `k`: its start, direction, and the parameter of `p`'s foot on
    // its line (clamped to the segment for the distance).
    let foot_on = |k: usize| {
        let a = point(k);
        let d = point(k + 1) - a;
        let dd = d.length_squared();
        let t = if dd > 0.0 { (p - a).dot(d) / dd } else { 0.0 };
        let tc = t.clamp(0.0, 1.0);
        (a, d, t, (a + d * tc).distance_squared(p))
    };
    let mut k = hint.min(segs - 1);
    let mut best = foot_on(k);
    let mut moved = 0;
    while k + 1 < segs && moved < WALK_SEARCH {
        let e = foot_on(k + 1);
        if !(e.3 < best.3) {
            break;
        }
        best = e;
        k += 1;
        moved += 1;
    }
    if moved == 0 {
        while k > 0 && moved < WALK_SEARCH {
            let e = foot_on(k - 1);
            if !(e.3 < best.3) {
                break;
            }
            best = e;
            k -= 1;
            moved += 1;
        }
    }
    let (a, d, t, _) = best;
    // Beyond the ends the lines of the end segments continue the polyline.
    let lo = if k == 0 { f64::NEG_INFINITY } else { 0.0 };
    let hi = if k + 1 == segs { f64::INFINITY } else { 1.0 };
    let t = t.clamp(lo, hi);
    let foot = a + d * t;
    // Walk `length` on from the foot (in length units within segment `k`).
    let mut seg_len = d.length();
    let mut along = t * seg_len;
    let mut left = length;
    let (mut a, mut d) = (a, d);
    loop {
        if k + 1 == segs || along + left <= seg_len {
            let unit = if seg_len > 0.0 {
                d / seg_len
            } else {
                DVec3::ZERO
            };
            return Some((foot, a + unit * (along + left) - foot));
        }
        left -= seg_len - along;
        k += 1;
        a = point(k);
        d = point(k + 1) - a;
        seg_len = d.length();
        along = 0.0;
    }
}

/// The lattice point nearest `base + trend / 4` (half-step units), as
/// `bcc_nearest(base + 0.25 · trend, 1.0)` finds it (ties the same way:
/// rounding half away from zero, the even point where both are as near),
/// or `base` where that is not codable; in integers (quarter units), which
/// is exact where the `f64` form is (every codable input) and took a fifth
/// of the decoder's time in `f64`.
#[inline(always)]
fn quarter_nearest(base: [i64; 3], trend: [i64; 3]) -> [i64; 3] {
    // In `i64` where that does not overflow (every codable point's case;
    // 0.6 % fewer instructions decoding the fornix replicas than `i128`).
    let sum = |a: usize| base[a].checked_mul(4)?.checked_add(trend[a]);
    let x = match (sum(0), sum(1), sum(2)) {
        (Some(x), Some(y), Some(z)) => {
            let limit = 4u64 << super::entropy::MAX_BITS;
            [x, y, z]
                .iter()
                .all(|c| c.unsigned_abs() < limit)
                .then_some([x, y, z])
        }
        _ => quarters([0, 1, 2].map(|a| 4 * base[a] as i128 + trend[a] as i128)),
    };
    match x {
        Some(x) => nearest_in_quarters(x),
        None => base,
    }
}

/// Quarter-unit coordinates that are codable ([`bcc_nearest`]'s limit),
/// as `i64`, or `None`. In `i128`: a corrupt stream's wrapped lattice
/// values can be anything.
#[inline]
fn quarters(x: [i128; 3]) -> Option<[i64; 3]> {
    let limit = 4 * (1i128 << super::entropy::MAX_BITS);
    if x.iter().all(|c| c.abs() < limit) {
        Some(x.map(|c| c as i64))
    } else {
        None
    }
}

/// The lattice point (half-step units) nearest `x / 4` (codable quarter
/// units, see [`quarters`]), as [`bcc_nearest`] finds it.
#[inline]
fn nearest_in_quarters(x: [i64; 3]) -> [i64; 3] {
    // In quarter units: the nearest point of even coordinates at 8·round(x/8)
    // (half away from zero), of odd ones at 8·floor(x/8) + 4.
    let even = x.map(|c| {
        let r = (c.abs() + 4) >> 3;
        8 * if c < 0 { -r } else { r }
    });
    let odd = x.map(|c| 8 * (c >> 3) + 4);
    // On each axis the two are 4 apart with `x` between them (|e| + |o| =
    // 4), so Σe² − Σo² = 4·Σ(|e| − |o|) = 8·(Σ|e| − 6): the even point is
    // as near where its distances sum to at most 6.
    let e: i64 = (0..3).map(|a| (even[a] - x[a]).abs()).sum();
    let best = if e <= 6 { even } else { odd };
    best.map(|c| c >> 2)
}

/// The lattice point nearest the midpoint of two lattice points (in
/// half-step units; all coordinates of a point share a parity), or `a`
/// where that is not codable: as `bcc_nearest` finds it from the midpoint
/// in `f64`, exactly: in integers, which halved the time two-reference
/// curves take to decode, and in `f64` as before for coordinates from
/// 2^52 on (only a corrupt stream's), where the `f64` sum rounds.
fn midpoint(a: [i64; 3], b: [i64; 3]) -> [i64; 3] {
    const EXACT: u64 = 1 << 52;
    if a.iter().chain(&b).any(|v| v.unsigned_abs() >= EXACT) {
        let m = [0, 1, 2].map(|k| (a[k] as f64 + b[k] as f64) * 0.5);
        return bcc_nearest(DVec3::from_array(m), 1.0).unwrap_or(a);
    }
    match quarters([0, 1, 2].map(|k| 2 * (a[k] as i128 + b[k] as i128))) {
        Some(x) => nearest_in_quarters(x),
        None => a,
    }
}

/// The points of a decoded curve on the points lattice (half step
/// `half`; empty when a coordinate is beyond what the lattice codes: such a
/// curve is no reference).
pub fn regrid(points: &[DVec3], half: f64) -> Vec<[i64; 3]> {
    let mut out = Vec::with_capacity(points.len());
    for p in points {
        match bcc_nearest(*p, half) {
            Some(k) => out.push(k),
            None => return Vec::new(),
        }
    }
    out
}

/// The decoded curves of a block so far, as references: points-mode curves
/// as their lattice points, others as decoded points regridded on first use
/// (most blocks of smooth curves never need them, and regridding every
/// arc's points would cost a tenth of the encoding time).
pub struct Neighbours {
    half: f64,
    grids: Vec<Vec<[i64; 3]>>,
    /// Decoded points of the last [`MAX_BACK`] curves sent as arcs or raw
    /// (`None` for lattice curves, whose points `grids` holds, for empty
    /// ones, and once dropped).
    points: Vec<Option<Vec<DVec3>>>,
    /// The curves whose `grids[k]` does not hold them on the lattice yet
    /// (arcs and raw curves), oldest first: [`Self::window`] regrids those
    /// still in reach instead of looking at every curve in reach each time
    /// (that look was 1 % of decoding the fornix replicas at 0.1 mm).
    ungridded: Vec<usize>,
    /// First and last decoded point of each curve (none when empty): the
    /// anchors an arcs curve's start may be coded against.
    ends: Vec<Option<(DVec3, DVec3)>>,
    /// Half step of the starts' lattice, and each curve's first and last
    /// decoded point on it (computed once per curve: every arcs curve
    /// costs its start against 64 of them).
    start_half: f64,
    anchors: Vec<[Option<[i64; 3]>; 2]>,
    /// An arcs curve's first chord (its code: the first end on the start
    /// grid) and last chord (in length steps), model 14's prediction of
    /// the length of a curve's first chord anchored on it.
    chords: Vec<ArcChords>,
    /// `anchors` as real numbers, by axis (start and end of each curve one
    /// after the other, infinite where there is none), for
    /// [`Self::nearest_anchors`].
    anchor_coords: [Vec<f32>; 3],
    /// Storage of forgotten curves' lattice points, for the next ones: a
    /// block's curves would otherwise each take fresh memory, whose zeroing
    /// by the kernel was a fifth of decoding.
    spare_grids: Vec<Vec<[i64; 3]>>,
}

impl Neighbours {
    pub fn new(half: f64, start_half: f64, capacity: usize) -> Self {
        Neighbours {
            half,
            grids: Vec::with_capacity(capacity),
            points: Vec::with_capacity(capacity),
            ungridded: Vec::new(),
            ends: Vec::with_capacity(capacity),
            start_half,
            anchors: Vec::with_capacity(capacity),
            chords: Vec::with_capacity(capacity),
            anchor_coords: std::array::from_fn(|_| Vec::with_capacity(2 * capacity)),
            spare_grids: Vec::new(),
        }
    }

    /// An empty vector for a curve's lattice points, from a forgotten
    /// curve's where there is one.
    pub fn spare_grid(&mut self) -> Vec<[i64; 3]> {
        let mut g = self.spare_grids.pop().unwrap_or_default();
        g.clear();
        g
    }

    /// A points curve, on the lattice (its points are `k · half`, made
    /// when asked for: [`walk_with_middle`](Self::walk_with_middle),
    /// [`last_decoded`](Self::last_decoded)).
    pub fn push_lattice(&mut self, g: Vec<[i64; 3]>) {
        let h = self.half;
        self.push_ends(match (g.first(), g.last()) {
            (Some(&a), Some(&b)) => Some((bcc_point(a, h), bcc_point(b, h))),
            _ => None,
        });
        self.grids.push(g);
        self.points.push(None);
        self.forget_old();
    }

    /// The decoded points of the curve pushed last (empty for an empty
    /// curve).
    pub fn last_decoded(&self) -> Vec<DVec3> {
        match self.points.last() {
            Some(Some(p)) => p.clone(),
            Some(None) => {
                let g = self.grids.last().map_or(&[][..], |g| &g[..]);
                g.iter().map(|&k| bcc_point(k, self.half)).collect()
            }
            None => Vec::new(),
        }
    }

    /// The point of curve `k` (run backwards when `at_end`) reached by
    /// walking `distance` along it from its first point (the first vertex
    /// at or beyond it, or the last), relative to that first point: the
    /// prediction of a curve's first chord from the neighbour it is
    /// anchored on; and the first vertex at or beyond half the distance
    /// (relative to the same first point): the walked stretch's middle,
    /// from which its bulge is estimated.
    pub fn walk_with_middle(
        &self,
        k: usize,
        at_end: bool,
        distance: f64,
    ) -> Option<(DVec3, DVec3)> {
        match self.points.get(k)? {
            Some(p) => walk_with_middle(p.len(), |i| p[i], at_end, distance),
            None => {
                // A lattice curve (an empty grid: an empty or a dropped
                // curve, no walk).
                let (g, h) = (self.grids.get(k)?, self.half);
                walk_with_middle(g.len(), |i| bcc_point(g[i], h), at_end, distance)
            }
        }
    }

    fn push_ends(&mut self, ends: Option<(DVec3, DVec3)>) {
        let h = self.start_half;
        self.anchors.push(match ends {
            Some((a, b)) if h > 0.0 => [bcc_nearest(a, h), bcc_nearest(b, h)],
            _ => [None, None],
        });
        self.ends.push(ends);
        self.chords.push(ArcChords::default());
        let a = self.anchors[self.anchors.len() - 1];
        for end in a {
            let k = end.map_or([f32::INFINITY; 3], |k| k.map(|v| v as f32));
            for (c, v) in self.anchor_coords.iter_mut().zip(k) {
                c.push(v);
            }
        }
    }

    /// The last curve pushed is an arcs curve with these chords.
    pub fn set_chords(&mut self, chords: ArcChords) {
        if let Some(c) = self.chords.last_mut() {
            *c = chords;
        }
    }

    /// The [`NEAR`] anchors among the [`MAX_BACK`] curves before curve `k`
    /// nearest to `start` (on the starts' lattice), nearest first (of
    /// equal ones, the nearer curve back, its start before its end), as
    /// `(curve, at_end, squared distance in lattice units)`; fewer where
    /// there are fewer.
    pub fn nearest_anchors(&self, start: [i64; 3], k: usize) -> ([Near; NEAR], usize) {
        let k = k.min(self.anchors.len());
        let from = k - MAX_BACK.min(k);
        // In `f32`, 4 at once (exact for lattice coordinates under 2²⁴;
        // beyond, rounded the same way by the encoder and the decoder):
        // in `f64` one by one, the scan of 256 anchors a curve was a third
        // of decoding the fornix replicas at 0.5 mm.
        let s = start.map(|v| v as f32);
        let [xs, ys, zs] = self.anchor_coords.each_ref().map(|c| &c[2 * from..2 * k]);
        let mut near = [Near::default(); NEAR];
        let mut n = 0;
        let mut limit = f32::INFINITY;
        // Anchors `lo..hi` of the window, newest curve first and its start
        // before its end, as `best_anchor` takes them: of equal distances
        // the first found is kept first.
        let mut take = |d2: &[f32], lo: usize, limit: &mut f32| {
            for pair in (0..d2.len() / 2).rev() {
                for at_end in [false, true] {
                    let d = d2[2 * pair + at_end as usize];
                    if !(d < *limit) {
                        continue;
                    }
                    let mut at = n.min(NEAR - 1);
                    while at > 0 && near[at - 1].d2 > d as f64 {
                        near[at] = near[at - 1];
                        at -= 1;
                    }
                    near[at] = Near {
                        curve: from + (lo / 2) + pair,
                        at_end,
                        d2: d as f64,
                    };
                    n = (n + 1).min(NEAR);
                    if n == NEAR {
                        *limit = near[NEAR - 1].d2 as f32;
                    }
                }
            }
        };
        // Eight at a time from the newest (their distances and least in
        // vector registers), looked into only where one is under the
        // limit; the oldest few (`len % 8`, whole curves) one by one.
        const CHUNK: usize = 8;
        let len = xs.len();
        let mut hi = len;
        while hi >= CHUNK {
            let lo = hi - CHUNK;
            let (cx, cy, cz) = (&xs[lo..hi], &ys[lo..hi], &zs[lo..hi]);
            let mut d2 = [0.0f32; CHUNK];
            for j in 0..CHUNK {
                let (x, y, z) = (s[0] - cx[j], s[1] - cy[j], s[2] - cz[j]);
                d2[j] = x * x + y * y + z * z;
            }
            let least = d2
                .iter()
                .fold(f32::INFINITY, |m, &d| if d < m { d } else { m });
            if least < limit {
                take(&d2, lo, &mut limit);
            }
            hi = lo;
        }
        let mut d2 = [0.0f32; CHUNK];
        for j in 0..hi {
            let (x, y, z) = (s[0] - xs[j], s[1] - ys[j], s[2] - zs[j]);
            d2[j] = x * x + y * y + z * z;
        }
        take(&d2[..hi], 0, &mut limit);
        (near, n)
    }

    /// Curve `k`'s first and last chords, if it is an arcs curve.
    pub fn chords(&self, k: usize) -> ArcChords {
        self.chords.get(k).copied().unwrap_or_default()
    }

    /// Curve `k`'s start (or end) on the starts' lattice.
    pub fn anchor(&self, k: usize, at_end: bool) -> Option<[i64; 3]> {
        self.anchors.get(k)?[at_end as usize]
    }

    /// The anchor among the [`MAX_BACK`] curves before curve `k` (their
    /// starts and ends) nearest to `start` (on the starts' lattice):
    /// `(back, at_end, estimated bits)`.
    pub fn best_anchor(&self, start: [i64; 3], k: usize) -> Option<(usize, bool, u64)> {
        let mut best: Option<(usize, bool, u64)> = None;
        let k = k.min(self.anchors.len());
        // Nearest first (`back` 1, 2, …; the start before the end), over
        // the slice: this runs for every arcs curve against 256 anchors.
        let window = &self.anchors[k - MAX_BACK.min(k)..k];
        for (i, pair) in window.iter().rev().enumerate() {
            for (at_end, anchor) in pair.iter().enumerate() {
                let Some(r) = anchor else {
                    continue;
                };
                // A lattice difference: its parity, then halves.
                let d = [0, 1, 2].map(|a| start[a].wrapping_sub(r[a]));
                let bits = 7 + (0..3).map(|a| eg((d[a] - (d[0] & 1)) / 2)).sum::<u64>();
                if best.is_none_or(|b| bits < b.2) {
                    best = Some((i + 1, at_end == 1, bits));
                }
            }
        }
        best
    }

    pub fn len(&self) -> usize {
        self.grids.len()
    }

    pub fn is_empty(&self) -> bool {
        self.grids.is_empty()
    }

    /// An empty curve (no reference, no anchor, no walk).
    pub fn push_empty(&mut self) {
        self.grids.push(Vec::new());
        self.points.push(None);
        self.push_ends(None);
        self.forget_old();
    }

    /// A curve by its decoded points.
    pub fn push_points(&mut self, p: Vec<DVec3>) {
        self.grids.push(Vec::new());
        self.push_ends(match (p.first(), p.last()) {
            (Some(&a), Some(&b)) => Some((a, b)),
            _ => None,
        });
        self.ungridded.push(self.grids.len() - 1);
        self.points.push(Some(p));
        self.forget_old();
    }

    /// Points and grids further back than a reference can reach are
    /// dropped (the grids' storage kept for the next curves). The encoder pushes
    /// a curve before coding it and the decoder after decoding it, so one
    /// more than [`MAX_BACK`] is kept: both then see the same [`MAX_BACK`]
    /// curves before the one being coded.
    fn forget_old(&mut self) {
        /// Spare vectors kept at most (one or two are reused per curve).
        const SPARE: usize = 4;
        let n = self.points.len();
        if n > MAX_BACK + 1 {
            let old = n - MAX_BACK - 2;
            self.points[old] = None;
            let g = std::mem::take(&mut self.grids[old]);
            if g.capacity() > 0 && self.spare_grids.len() < SPARE {
                self.spare_grids.push(g);
            }
        }
    }

    /// The grids of all curves so far, the last [`MAX_BACK`] regridded.
    pub fn window(&mut self) -> &[Vec<[i64; 3]>] {
        let reach = self.grids.len().saturating_sub(MAX_BACK);
        // Those out of reach are never asked for again.
        for k in self.ungridded.drain(..).filter(|&k| k >= reach) {
            if let Some(p) = &self.points[k] {
                self.grids[k] = regrid(p, self.half);
            }
        }
        &self.grids
    }
}

/// Anchors [`Neighbours::nearest_anchors`] finds (for model 15's fit,
/// measured with 4 to 8 and 12: 4 to 7 within 0.3 % of each other on the
/// field lines, dipole lines and replicas, 12 up to 0.7 % larger; 4 walks
/// the fewest neighbours).
pub const NEAR: usize = 4;

/// One of the anchors nearest a start.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Near {
    pub curve: usize,
    pub at_end: bool,
    /// Squared distance from the start, in lattice units.
    pub d2: f64,
}

/// An arcs curve's first chord (its first end's code, on the grid of the
/// first step) and last chord (in length steps), where it has them.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ArcChords {
    pub first: Option<[i64; 3]>,
    pub last: Option<i64>,
}

/// [`Neighbours::walk_with_middle`] along the `n` points `point(i)`.
fn walk_with_middle(
    n: usize,
    point: impl Fn(usize) -> DVec3,
    at_end: bool,
    distance: f64,
) -> Option<(DVec3, DVec3)> {
    if n < 2 {
        return None;
    }
    let at = |i: usize| if at_end { point(n - 1 - i) } else { point(i) };
    let mut walked = 0.0;
    let mut middle = None;
    for i in 1..n {
        walked += at(i).distance(at(i - 1));
        if middle.is_none() && walked >= 0.5 * distance {
            middle = Some(at(i) - at(0));
        }
        if walked >= distance {
            return Some((at(i) - at(0), middle.unwrap_or(at(i) - at(0))));
        }
    }
    let end = at(n - 1) - at(0);
    Some((end, middle.unwrap_or(end)))
}

/// Index into a reference of `m` points matching point `i` of `n`.
#[inline]
pub fn matching(i: usize, n: usize, m: usize) -> usize {
    if n <= 1 {
        0
    } else {
        (i * (m - 1) + (n - 1) / 2) / (n - 1)
    }
}

/// Point `j` of `r`, counted from the end when `reversed`.
#[inline]
pub fn at(r: &[[i64; 3]], j: usize, reversed: bool) -> [i64; 3] {
    if reversed {
        r[r.len() - 1 - j]
    } else {
        r[j]
    }
}

/// Prediction of point `i ≥ 1` of a curve of `n` points from its decoded
/// previous point and the reference.
#[inline]
pub fn predict(prev: [i64; 3], i: usize, n: usize, r: &[[i64; 3]], reversed: bool) -> [i64; 3] {
    let m = r.len();
    let a = at(r, matching(i - 1, n, m), reversed);
    let b = at(r, matching(i, n, m), reversed);
    [0, 1, 2].map(|k| prev[k].wrapping_add(b[k].wrapping_sub(a[k])))
}

/// Bits of a signed Exp-Golomb code of `v` (the encoder's static cost).
fn eg(v: i64) -> u64 {
    // 1 at 0 too (64 leading zeros), without a branch.
    1 + 2 * (64 - v.unsigned_abs().leading_zeros() as u64)
}

fn l1(a: [i64; 3], b: [i64; 3]) -> i64 {
    (0..3)
        .map(|k| (a[k].wrapping_sub(b[k])).wrapping_abs())
        .fold(0i64, i64::wrapping_add)
}

/// Estimated bits of the grid points `g` predicted from `res` (`cost` of
/// one residual vector).
pub fn reference_bits(g: &[[i64; 3]], res: &Resolved, cost: impl Fn([i64; 3]) -> u64) -> u64 {
    reference_bits_under(g, res, cost, u64::MAX)
}

/// [`reference_bits`] summed only while under `limit`: at or above it the
/// sum so far (itself at or above `limit`) is returned.
fn reference_bits_under(
    g: &[[i64; 3]],
    res: &Resolved,
    cost: impl Fn([i64; 3]) -> u64,
    limit: u64,
) -> u64 {
    reference_bits_into(g, res, cost, limit, &mut Vec::new())
}

/// [`reference_bits_under`], the predictions made kept in `predicted`
/// (point `i`'s at `i`, the reference's start at 0; as far as the sum
/// went).
fn reference_bits_into(
    g: &[[i64; 3]],
    res: &Resolved,
    cost: impl Fn([i64; 3]) -> u64,
    limit: u64,
    predicted: &mut Vec<[i64; 3]>,
) -> u64 {
    let n = g.len();
    let start = res.start();
    predicted.clear();
    predicted.push(start);
    let mut bits = 8 + cost([0, 1, 2].map(|a| g[0][a].wrapping_sub(start[a])));
    if res.second.is_some() {
        bits += 6;
    }
    let foot = PredictionCache::default();
    for i in 1..n {
        if bits >= limit {
            break;
        }
        let p = res.predict_next(g, i, n, &foot);
        predicted.push(p);
        bits += cost([0, 1, 2].map(|a| g[i][a].wrapping_sub(p[a])));
    }
    bits
}

/// The cheapest reference for the grid points `g` (curve `k` of its block,
/// `grids[r]` the regridded decoded curves before it), with its estimated
/// cost in bits (`cost` of one residual vector): one of the curves whose
/// ends are nearest, index-matched or walked. The encoder no longer
/// chooses two references (their mean step, [`Reference::second`], which
/// the decoder still reads): measured 2026-11-28 over the shared data at
/// both tolerances, 10,000 fornix replicas and the heart fibres of
/// `benches/make_unseen.py`, trying the pairs of the three best singles
/// (and the best pair walked) changed no file by more than 14 bytes (CST_R
/// −0.9 % at 0.1 mm, +1.2 % at 0.5 mm; 555 bytes fewer without them over
/// all 19 files, 0.04 %) while it took 11 % of the encoder's instructions
/// on the replicas at 0.1 mm: the slide that follows evens out what the
/// mean step saves on the rounded points.
///
/// Only a reference estimated under `limit` can be used (the caller's
/// cheapest alternative): one is costed only until it reaches `limit`,
/// and a result at or above `limit` stands for "none under it" (the
/// walked reference is tried on the best index-matched one as far as it
/// is known: of singles over `limit`, the one with the least partial
/// sum).
///
/// Its predictions of `g`'s points are left in `predicted` (as
/// [`reference_bits_into`] keeps them: all of them where its estimate is
/// under `limit`), for the encoder's next look at the same predictions
/// (the along-step flag).
pub fn best_reference(
    g: &[[i64; 3]],
    grids: &[Vec<[i64; 3]>],
    rule: Rule,
    cost: impl Fn([i64; 3]) -> u64,
    limit: u64,
    predicted: &mut Vec<[i64; 3]>,
) -> Option<(Reference, u64)> {
    let k = grids.len();
    let n = g.len();
    if n < 2 {
        return None;
    }
    // Shortlist by how near the reference's ends are to the curve's: the
    // SHORTLIST nearest (ties: the nearer back first, then forwards), kept
    // in order as they are found (a selection over all 2·MAX_BACK was 1 %
    // of encoding the fornix replicas at 0.1 mm).
    type Key = (i64, usize, bool);
    let mut short: Vec<(Key, Reference)> = Vec::with_capacity(SHORTLIST + 1);
    for back in 1..=MAX_BACK.min(k) {
        let r = &grids[k - back];
        if r.len() < 2 {
            continue;
        }
        for reversed in [false, true] {
            let d = l1(g[0], at(r, 0, reversed))
                .saturating_add(l1(g[n - 1], at(r, r.len() - 1, reversed)));
            let key = (d, back, reversed);
            if short.len() == SHORTLIST && key >= short[SHORTLIST - 1].0 {
                continue;
            }
            let at = short.partition_point(|s| s.0 < key);
            short.insert(
                at,
                (
                    key,
                    Reference {
                        back,
                        reversed,
                        second: None,
                        walk: false,
                    },
                ),
            );
            short.truncate(SHORTLIST);
        }
    }
    // The predictions of the one being costed and of the best so far.
    let mut trial = Vec::with_capacity(g.len());
    predicted.clear();
    let bits_of = |rf: &Reference, limit: u64, trial: &mut Vec<[i64; 3]>| {
        reference_bits_into(g, &rf.resolve(grids, rule), &cost, limit, trial)
    };
    // Each costed only while it can still be the least: to one bit past
    // the least so far where that is under `limit` (what is past it is
    // dearer than that one, and the least and its ties come out exact);
    // while none is under `limit`, to `limit` as before (of those, the
    // least partial sum picks the one tried walked).
    let mut least = u64::MAX;
    let mut best: Option<(Reference, u64)> = None;
    for &(_, rf) in &short {
        let bits = bits_of(&rf, limit.min(least.saturating_add(1)), &mut trial);
        least = least.min(bits);
        // The least by (estimate, back, reversed), as sorting them would
        // find it.
        let order = |x: &(Reference, u64)| (x.1, x.0.back, x.0.reversed);
        if best.is_none_or(|b| order(&(rf, bits)) < order(&b)) {
            best = Some((rf, bits));
            std::mem::swap(predicted, &mut trial);
        }
    }
    let mut best = best?;
    // Walked: the best index-matched one. (Searching them all walked, with
    // no flag, coded the resampled bundles 0–2 % smaller than this, but the
    // jittered fornix replicas, sampled exactly as their neighbours are,
    // 2.5 % larger in twice the time. Walked only where 3–10 % cheaper
    // than matched: the replicas 0.15 % smaller, the bundles up to 2 %
    // larger, no faster: kept at 0.)
    if rule.walk {
        let walked = Reference {
            walk: true,
            ..best.0
        };
        let bits = bits_of(&walked, best.1.min(limit), &mut trial);
        if bits < best.1 {
            best = (walked, bits);
            std::mem::swap(predicted, &mut trial);
        }
    }
    Some(best)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quarter_nearest_is_the_f64_rounding_exactly() {
        // Every small case, then random large ones: the integer form finds
        // the point `bcc_nearest` finds (ties included), or `base` where
        // that is not codable.
        let f64_form = |base: [i64; 3], t: [i64; 3]| {
            let p = [0, 1, 2].map(|a| base[a] as f64 + 0.25 * t[a] as f64);
            bcc_nearest(DVec3::from_array(p), 1.0).unwrap_or(base)
        };
        let mut bases = Vec::new();
        for x in -3..=3 {
            for y in -3..=3 {
                for z in -3..=3 {
                    bases.push([x, y, z]);
                }
            }
        }
        for b in bases {
            for tx in -9..=9 {
                for ty in -9..=9 {
                    for tz in -9..=9 {
                        let t = [tx, ty, tz];
                        assert_eq!(quarter_nearest(b, t), f64_form(b, t), "{b:?} {t:?}");
                    }
                }
            }
        }
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let limit = 1i64 << crate::codec::entropy::MAX_BITS;
        for _ in 0..200_000 {
            let b = [0; 3].map(|_| rng.gen_range(-limit..limit));
            let t = [0; 3].map(|_| rng.gen_range(-(1i64 << 30)..(1 << 30)));
            assert_eq!(quarter_nearest(b, t), f64_form(b, t), "{b:?} {t:?}");
        }
        // Past the codable range: the base.
        assert_eq!(
            quarter_nearest([limit - 1, 0, 0], [8, 0, 0]),
            [limit - 1, 0, 0]
        );
        assert_eq!(quarter_nearest([i64::MAX, 0, 0], [0; 3]), [i64::MAX, 0, 0]);
        // Where 4·base leaves i64 but the sum comes back: as in i128 (the
        // f64 form rounds there; these only come from corrupt streams).
        assert_eq!(
            quarter_nearest([-(1 << 61), 1, 1], [0; 3]),
            [-(1 << 61), 1, 1]
        );
        assert_eq!(
            quarter_nearest([1 << 61, 0, 0], [i64::MIN, 0, 0]),
            [0, 0, 0]
        );
        assert_eq!(
            quarter_nearest([-(1 << 61) - 1, 1, 1], [i64::MAX, 0, 0]),
            [-1, 1, 1]
        );
    }

    #[test]
    fn midpoint_is_the_f64_rounding_exactly() {
        let f64_form = |a: [i64; 3], b: [i64; 3]| {
            let m = [0, 1, 2].map(|k| (a[k] as f64 + b[k] as f64) * 0.5);
            bcc_nearest(DVec3::from_array(m), 1.0).unwrap_or(a)
        };
        // Lattice points (one parity per point) near each other, every
        // combination, then random large ones of both parities.
        let mut pts = Vec::new();
        for x in -4..=4i64 {
            for y in -4..=4i64 {
                for z in -4..=4i64 {
                    if (x - y) % 2 == 0 && (y - z) % 2 == 0 {
                        pts.push([x, y, z]);
                    }
                }
            }
        }
        for &a in &pts {
            for &b in &pts {
                assert_eq!(midpoint(a, b), f64_form(a, b), "{a:?} {b:?}");
            }
        }
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let limit = 1i64 << crate::codec::entropy::MAX_BITS;
        for _ in 0..200_000 {
            let lattice = |rng: &mut rand_chacha::ChaCha8Rng| {
                let parity = rng.gen_range(0..2);
                [0; 3].map(|_| 2 * rng.gen_range(-limit / 2..limit / 2) + parity)
            };
            let (a, b) = (lattice(&mut rng), lattice(&mut rng));
            assert_eq!(midpoint(a, b), f64_form(a, b), "{a:?} {b:?}");
        }
        // Beyond the codable range (and beyond i64 when doubled): `a`; and
        // a corrupt stream's huge values, as the f64 form has them.
        assert_eq!(midpoint([limit, 0, 0], [limit, 0, 0]), [limit, 0, 0]);
        assert_eq!(midpoint([i64::MAX, 0, 0], [1, 0, 0]), [i64::MAX, 0, 0]);
        for (a, b) in [
            ([-(1i64 << 61), 0, 0], [-(1i64 << 61), 0, 0]),
            ([(1i64 << 60) + 3, 3, 3], [-(1i64 << 60) + 3, 3, 3]),
            ([i64::MIN, 1, 1], [i64::MAX, 1, 1]),
        ] {
            assert_eq!(midpoint(a, b), f64_form(a, b), "{a:?} {b:?}");
        }
    }

    #[test]
    fn a_lattice_curve_walks_and_decodes_as_its_points_do() {
        // The same curve pushed as lattice points (its points made when
        // asked for) and as decoded points: the same walks, ends, points.
        let half = 0.05;
        let g: Vec<[i64; 3]> = (0..30i64).map(|i| [2 * i, (i * i) % 7 * 2, 4]).collect();
        let pts: Vec<DVec3> = g.iter().map(|&k| bcc_point(k, half)).collect();
        let mut a = Neighbours::new(half, 0.2, 4);
        a.push_lattice(g);
        assert_eq!(a.last_decoded(), pts);
        let mut b = Neighbours::new(half, 0.2, 4);
        b.push_points(pts);
        for at_end in [false, true] {
            for d in [0.0, 0.3, 1.0, 2.5, 100.0] {
                assert_eq!(
                    a.walk_with_middle(0, at_end, d),
                    b.walk_with_middle(0, at_end, d)
                );
            }
            assert_eq!(a.anchor(0, at_end), b.anchor(0, at_end));
        }
        assert!(a.walk_with_middle(0, false, 1.0).is_some());
    }

    #[test]
    fn matching_covers_both_ends_and_is_monotone() {
        for (n, m) in [(2, 2), (5, 5), (5, 17), (17, 5), (100, 3)] {
            assert_eq!(matching(0, n, m), 0);
            assert_eq!(matching(n - 1, n, m), m - 1);
            for i in 1..n {
                assert!(matching(i, n, m) >= matching(i - 1, n, m));
            }
        }
    }

    #[test]
    fn a_parallel_neighbour_predicts_exactly() {
        // Curve = reference shifted: every residual is zero.
        let r: Vec<[i64; 3]> = (0..10).map(|i| [i * i, 3 * i, -i]).collect();
        let g: Vec<[i64; 3]> = r.iter().map(|p| [p[0] + 5, p[1] - 2, p[2] + 7]).collect();
        for i in 1..10 {
            assert_eq!(predict(g[i - 1], i, 10, &r, false), g[i]);
        }
        // Reversed reference: predict the curve run backwards.
        let rev: Vec<[i64; 3]> = r.iter().rev().cloned().collect();
        for i in 1..10 {
            assert_eq!(predict(g[i - 1], i, 10, &rev, true), g[i]);
        }
        let grids = vec![vec![[100, 100, 100], [200, 0, 0]], rev, vec![[0, 0, 0]]];
        let (rf, _) = best_reference(
            &g,
            &grids,
            Rule::of_model(7),
            |v| if v == [0, 0, 0] { 1 } else { 9 },
            u64::MAX,
            &mut Vec::new(),
        )
        .unwrap();
        assert_eq!(
            rf,
            Reference {
                back: 2,
                reversed: true,
                second: None,
                walk: false,
            }
        );
    }

    #[test]
    fn two_references_average_their_steps() {
        // Two neighbours wiggle in opposite directions about a straight
        // line; the curve runs straight between them. Each alone predicts
        // its own wiggle; their mean step is the straight step.
        let line: Vec<[i64; 3]> = (0..12).map(|i| [4 * i, 0, 0]).collect();
        let up: Vec<[i64; 3]> = (0..12).map(|i| [4 * i, 2 * (i % 2) + 10, 0]).collect();
        let down: Vec<[i64; 3]> = (0..12).map(|i| [4 * i, -2 * (i % 2) - 10, 0]).collect();
        let grids = vec![up.clone(), down.clone(), vec![[0, 0, 0]]];
        let cost = |v: [i64; 3]| v.iter().map(|x| x.unsigned_abs()).sum::<u64>() * 4 + 1;
        // The encoder no longer chooses pairs (see `best_reference`); the
        // decoder reads them.
        let rf = Reference {
            back: 3,
            reversed: false,
            second: Some((2, false)),
            walk: false,
        };
        let bits = reference_bits(&line, &rf.resolve(&grids, Rule::of_model(7)), cost);
        let res = Resolved {
            first: (&grids[3 - rf.back][..], rf.reversed),
            second: rf.second.map(|(b, rev)| (&grids[3 - b][..], rev)),
            trend: false,
            walk: false,
        };
        assert_eq!(res.start(), [0, 0, 0]);
        for i in 1..12 {
            assert_eq!(res.predict_in(&line, i, 12), line[i], "point {i}");
        }
        // Each alone misses by 2 at every point.
        let one = |b: usize| Resolved {
            first: (&grids[3 - b][..], false),
            second: None,
            trend: false,
            walk: false,
        };
        assert_ne!(one(1).predict_in(&line, 1, 12), line[1]);
        assert!(bits < 8 + 4 * 12 + 6 + 11 + 80);
    }

    #[test]
    fn the_offset_trend_follows_a_fanning_fibre() {
        // The curve leaves its straight neighbour at a steady 8 half steps
        // per point sideways: the neighbour's step alone misses by 8 at
        // every point, the trend by 6 (a quarter of the drift learnt), and
        // with no drift (the curve parallel) the two agree.
        let r: Vec<[i64; 3]> = (0..10).map(|i| [40 * i, 0, 0]).collect();
        let fan: Vec<[i64; 3]> = (0..10).map(|i| [40 * i, 8 * i, 0]).collect();
        let res = |trend| Resolved {
            first: (&r[..], false),
            second: None,
            trend,
            walk: false,
        };
        for i in 2..10 {
            let plain = res(false).predict_in(&fan, i, 10);
            let trend = res(true).predict_in(&fan, i, 10);
            assert_eq!(plain, [40 * i as i64, 8 * (i as i64 - 1), 0]);
            assert_eq!(trend, [40 * i as i64, 8 * (i as i64 - 1) + 2, 0]);
        }
        let parallel: Vec<[i64; 3]> = (0..10).map(|i| [40 * i, 6, 0]).collect();
        for i in 1..10 {
            assert_eq!(
                res(true).predict_in(&parallel, i, 10),
                res(false).predict_in(&parallel, i, 10)
            );
        }
    }

    #[test]
    fn kept_indices_and_feet_predict_as_a_fresh_search() {
        // `predict_next` keeps the matching indices and the walked foot
        // between calls; in the orders its callers use (each point once, as
        // the decoder; each point several times with other earlier points,
        // as the slide's partial choices; points skipped) it must predict
        // what `predict_in`, which keeps nothing, predicts. Random curves
        // and references of other lengths, both directions, walked or not.
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let walk = |rng: &mut rand_chacha::ChaCha8Rng, n: usize| {
            let mut p = [0i64; 3];
            (0..n)
                .map(|_| {
                    p = p.map(|c| c + 2 * rng.gen_range(-6..=6) + 12);
                    p
                })
                .collect::<Vec<_>>()
        };
        for case in 0..200 {
            let n = rng.gen_range(2..40);
            let m = rng.gen_range(2..50);
            let r = walk(&mut rng, m);
            let g = walk(&mut rng, n);
            let other = walk(&mut rng, n);
            let res = Resolved {
                first: (&r[..], case % 2 == 0),
                second: None,
                trend: case % 3 != 0,
                walk: case % 4 < 2,
            };
            let cache = PredictionCache::default();
            for i in 1..n {
                // Another partial choice's points first, then this one's.
                if i % 3 == 0 {
                    res.predict_next(&other, i, n, &cache);
                }
                assert_eq!(res.predict_next(&g, i, n, &cache), res.predict_in(&g, i, n));
                if i % 5 == 0 {
                    assert_eq!(res.predict_next(&g, i, n, &cache), res.predict_in(&g, i, n));
                }
            }
            let cache = PredictionCache::default();
            for i in (1..n).step_by(2) {
                assert_eq!(res.predict_next(&g, i, n, &cache), res.predict_in(&g, i, n));
            }
        }
    }

    #[test]
    fn a_limited_search_is_exact_under_its_limit() {
        // Random wiggly neighbours of a random curve: under the limit the
        // reported cost is the reference's own, a single found without a
        // limit is still found (or a cheaper one), and at or above the
        // limit the search says so.
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(17);
        let cost = |v: [i64; 3]| v.iter().map(|x| 2 * x.unsigned_abs()).sum::<u64>() + 1;
        let walk = |rng: &mut rand_chacha::ChaCha8Rng, n: usize, o: [i64; 3]| {
            let mut p = o;
            (0..n)
                .map(|_| {
                    let s = rng.gen_range(0..2) * 2 - 1;
                    p = [p[0] + 8, p[1] + s * rng.gen_range(0..3), p[2] + s];
                    p
                })
                .collect::<Vec<[i64; 3]>>()
        };
        let (mut under, mut over) = (0, 0);
        for case in 0..400 {
            // Both rules: index-matched and walked steps.
            let rule = Rule::of_model(if case % 2 == 0 { 11 } else { 12 });
            let n = rng.gen_range(2..30);
            let g = walk(&mut rng, n, [0, 0, 0]);
            let grids: Vec<Vec<[i64; 3]>> = (0..rng.gen_range(1..12))
                .map(|_| {
                    let m = rng.gen_range(1..40);
                    let o = [0, rng.gen_range(-9..9), rng.gen_range(-9..9)];
                    walk(&mut rng, m, o)
                })
                .collect();
            let Some((free, free_bits)) =
                best_reference(&g, &grids, rule, cost, u64::MAX, &mut Vec::new())
            else {
                continue;
            };
            let limit = rng.gen_range(free_bits / 2..free_bits * 2 + 2);
            let mut predicted = Vec::new();
            let (rf, bits) = best_reference(&g, &grids, rule, cost, limit, &mut predicted).unwrap();
            let res = rf.resolve(&grids, rule);
            let exact = reference_bits(&g, &res, cost);
            if bits < limit {
                assert_eq!(bits, exact, "{rf:?}");
                // The predictions kept are the chosen reference's, all of
                // them.
                let foot = PredictionCache::default();
                let again: Vec<[i64; 3]> = std::iter::once(res.start())
                    .chain((1..n).map(|i| res.predict_next(&g, i, n, &foot)))
                    .collect();
                assert_eq!(predicted, again, "{rf:?}");
                under += 1;
            } else {
                // (A pair, or a walked reference, is tried on the best
                // singles as the limit ranks them.)
                assert!(
                    free_bits >= limit || free.second.is_some() || free.walk,
                    "{free:?} {free_bits} {limit}"
                );
                over += 1;
            }
            if free.second.is_none() && !free.walk && free_bits < limit {
                assert!(bits <= free_bits, "{bits} {free_bits} {limit}");
            }
        }
        assert!(under > 50 && over > 50, "{under} {over}");
    }

    /// A resolved single reference `r` by `rule`.
    fn single(r: &[[i64; 3]], rule: Rule) -> Resolved<'_> {
        Resolved {
            first: (r, false),
            second: None,
            trend: rule.trend,
            walk: rule.walk,
        }
    }

    #[test]
    fn a_walk_follows_a_neighbour_sampled_elsewhere() {
        // A straight neighbour sampled every 4 half steps from 0, and a curve
        // beside it sampled as densely from 2 and on past its end: walked,
        // every step from the third point on is exact (past the end along
        // the last segment's line); matched by index (10 points against
        // 6), the steps are 0 or 8 long.
        let r: Vec<[i64; 3]> = (0..6).map(|i| [4 * i, 0, 0]).collect();
        let g: Vec<[i64; 3]> = (0..10).map(|i| [4 * i + 2, 6, 2]).collect();
        let walked = single(&r, Rule::of_model(12));
        let matched = single(&r, Rule::of_model(11));
        for i in 2..10 {
            assert_eq!(walked.predict_in(&g, i, 10), g[i], "point {i}");
        }
        assert!((2..10).any(|i| matched.predict_in(&g, i, 10) != g[i]));
        // The second point has no step of the curve's own to walk: both
        // rules predict it alike.
        assert_eq!(walked.predict_in(&g, 1, 10), matched.predict_in(&g, 1, 10));
        // Run backwards, the neighbour predicts the same.
        let back: Vec<[i64; 3]> = r.iter().rev().copied().collect();
        let reversed = Resolved {
            first: (&back[..], true),
            ..walked
        };
        for i in 2..10 {
            assert_eq!(reversed.predict_in(&g, i, 10), g[i], "point {i}");
        }
    }

    #[test]
    fn a_walk_turns_with_a_bent_neighbour_and_its_trend() {
        // A neighbour that runs along x and then turns to y, and a curve
        // parallel to it 4 half steps inside the bend, sampled at other
        // places: past the bend the walked step turns too. With the trend
        // a steady drift away from the neighbour is followed a quarter.
        let mut r: Vec<[i64; 3]> = (0..8).map(|i| [8 * i, 0, 0]).collect();
        r.extend((1..8).map(|i| [56, 8 * i, 0]));
        let g: Vec<[i64; 3]> = (0..5)
            .map(|i| [12 + 8 * i, 4, 0])
            .chain((0..4).map(|i| [52, 12 + 8 * i, 0]))
            .collect();
        let walked = single(
            &r,
            Rule {
                trend: false,
                walk: true,
            },
        );
        // Once the curve's own last step has turned (points 7 on), the
        // walked step runs along y.
        for i in 7..9 {
            assert_eq!(walked.predict_in(&g, i, 9), g[i], "point {i}");
        }
        let drift: Vec<[i64; 3]> = (0..8).map(|i| [10 * i, 8 * i, 0]).collect();
        let line: Vec<[i64; 3]> = (0..12).map(|i| [8 * i, 0, 0]).collect();
        let trend = single(&line, Rule::of_model(12));
        let plain = single(
            &line,
            Rule {
                trend: false,
                walk: true,
            },
        );
        let miss = |res: &Resolved, i: usize| l1(res.predict_in(&drift, i, 8), drift[i]);
        for i in 3..8 {
            assert!(miss(&trend, i) < miss(&plain, i), "point {i}");
        }
    }

    #[test]
    fn walked_references_predict_a_bundle_better() {
        // Fibres of a bundle: a smooth centre line, each fibre offset from
        // it, starting and ending at its own depths and resampled to 20
        // points (as tractography's bundles are): each fibre predicted from
        // the one before, walked against matched by index (the offsets'
        // trend both ways).
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(23);
        let centre = |s: f64| DVec3::new(s, 10.0 * (s / 20.0).sin(), 5.0 * (s / 30.0).cos());
        let half = 0.1;
        let fibres: Vec<Vec<[i64; 3]>> = (0..40)
            .map(|_| {
                let (a, b) = (rng.gen_range(0.0..25.0), rng.gen_range(75.0..120.0));
                let o = DVec3::new(0.0, rng.gen_range(-2.0..2.0), rng.gen_range(-2.0..2.0));
                (0..20)
                    .map(|i| {
                        let p = centre(a + (b - a) * i as f64 / 19.0) + o;
                        bcc_nearest(p, half).unwrap()
                    })
                    .collect()
            })
            .collect();
        let total = |rule: Rule| {
            fibres
                .windows(2)
                .map(|w| {
                    let res = single(&w[0], rule);
                    (1..20)
                        .map(|i| l1(res.predict_in(&w[1], i, 20), w[1][i]))
                        .sum::<i64>()
                })
                .sum::<i64>()
        };
        let (walked, matched) = (total(Rule::of_model(12)), total(Rule::of_model(11)));
        assert!(
            3 * walked < 2 * matched,
            "walked {walked}, matched {matched}"
        );
    }

    #[test]
    fn a_walk_is_linear_in_the_curves_length() {
        // However far along a long neighbour the curve lies, each foot is
        // searched at most WALK_SEARCH segments from the index-matched one
        // (the prediction is then worse, never wrong or slow): a curve
        // beside the far end of a neighbour of 10,000 points still gets a
        // lattice prediction for every point.
        let r: Vec<[i64; 3]> = (0..10_000).map(|i| [2 * i, 0, 0]).collect();
        let g: Vec<[i64; 3]> = (0..50).map(|i| [19_000 + 2 * i, 2, 2]).collect();
        let res = single(&r, Rule::of_model(12));
        for i in 1..50 {
            let p = res.predict_in(&g, i, 50);
            assert!(p.iter().all(|v| (v - p[0]) % 2 == 0), "{p:?}");
        }
        // A one-point neighbour: the index-matched prediction.
        let short = [[4, 4, 4]];
        let w = single(&short, Rule::of_model(12));
        let m = single(&short, Rule::of_model(11));
        assert_eq!(w.predict_in(&g, 5, 50), m.predict_in(&g, 5, 50));
    }

    #[test]
    fn regrid_refuses_uncodable_points() {
        // x/half = (0.52, -0.48, 2): the odd point (1, -1, 1) is 1.2 away
        // (squared 0.23 + 0.27 + 1), the even (0, 0, 2) 0.71 (squared 0.5).
        assert_eq!(
            regrid(&[DVec3::new(0.26, -0.24, 1.0)], 0.5),
            vec![[0, 0, 2]]
        );
        assert!(regrid(&[DVec3::ZERO, DVec3::splat(1e30)], 1e-6).is_empty());
    }
}
