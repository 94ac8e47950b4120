//! Per-curve encoding: arcs grown along the curve, each accepted only by the
//! two-sided test, with quantised points as the fallback.
//!
//! From the current end of the chain, the element that reaches furthest
//! along the input is found by galloping (1, 2, 4, … vertices) and then
//! bisection, so a curve of `n` vertices costs `O(n log m)` checks of
//! `O(m)` each for elements of `m` vertices: linear in the curve's length.
//! Every candidate is quantised *before* it is checked, and the chain is
//! continued from the decoded element (closed loop), so quantisation errors
//! never accumulate and the decoder reproduces exactly what was checked.
//!
//! Each element is searched as a G1 arc (tangent inherited), a straight
//! segment and a corner (tangent reset by a coded bulge), and the one that
//! reaches furthest kept, the cheapest on a tie. With
//! [`super::Effort::Best`] an element may end a few vertices short of the
//! furthest reach, where the next one then goes as far for fewer bits
//! ([`CurveEncoder::look_ahead`]). Where no
//! element passes, or the arcs would cost more than the curve's points on a
//! grid of step `2T/√3` with second-order prediction (the baseline's own
//! representation, error `≤ T` by construction), the points are stored.

use glam::DVec3;

use super::check::all_within;
use super::predict::{corner_tangent, perpendicular_part, Arc, ArcError, ChainState, Circle};
use super::quantise::Quantiser;
use super::{CurveCode, ElementCode, ElementKind};

/// What the encoder needs for one curve.
pub struct CurveEncoder<'a> {
    pub points: &'a [DVec3],
    pub q: Quantiser,
    /// Squared acceptance distance (the tolerance less a rounding margin).
    pub tol2: f64,
    /// Points-mode lattice half step.
    pub grid: f64,
    /// Where candidates are checked in batches (the GPU backend): each
    /// check waits there for a verdict ([`super::batch`]); `None` checks
    /// at once on this thread.
    pub mailbox: Option<&'a super::batch::Mailbox>,
    /// Where the arcs search stops early, the points being cheaper
    /// ([`GiveUp`]); `None` searches to the end.
    pub give_up: Option<GiveUp>,
    /// Whether each element is chosen looking one element ahead
    /// ([`CurveEncoder::look_ahead`], `--effort best`).
    pub look_ahead: bool,
    /// Whether a corner's bulge is coded against
    /// [`CornerChord::bulge_prediction`] (codec model 16 on).
    pub bulge_prediction: bool,
    /// Whether an element after a corner searches the corner first, then
    /// the cheaper kinds only from its reach on ([`CORNER_FIRST`]); else
    /// always the cheapest kind first. The block turns it on where its
    /// arcs are known to pay: searched so on the noisy heart fibres of
    /// `benches/make_unseen.py`, whose arcs save little once coded, the
    /// corners found made the arcs look cheaper, and the block searched
    /// them in full (30,000 fibres at 0.1 mm 14 % slower for 0.06 % fewer
    /// bytes).
    pub corner_first: bool,
}

/// How many input vertices short of the furthest reach the look-ahead
/// tries ending an element ([`CurveEncoder::look_ahead`]). Measured with 1,
/// 2, 4, 8 and 12 (and 4 or 6 of the 8, spread): the deeper, the smaller
/// up to 8; at 8, 1.8 times the CPU of the greedy search on 100,000 fornix
/// replicas at 0.5 mm.
const LOOK_BACK: usize = 8;

/// When a curve's arcs search gives up: past a quarter of the curve (and
/// 8 vertices), once the arcs so far are estimated (scaled by the block's
/// calibration, [`GiveUp::arcs_scale`]) at more than 1.3× the rounded
/// points' second-order estimate to the same vertex, plus a byte. On noisy
/// fibres, where points win, most of the search is then skipped. The
/// points' estimate it is held to is their residuals' by their own
/// second-order prediction (a neighbour's prediction or the screw may
/// only lower it; their start, which the choice counts too, is left out,
/// which the margin covers).
///
/// Measured (estimates logged over the shared data at both tolerances and
/// 10,000 fornix replicas at 0.1 mm): the fornix replicas skip 66 % of
/// their search work for 24 bytes of 342 kB where a curve that would have
/// gone as arcs goes as points; the resampled bundles about half; the hair
/// 4 % and no byte; the fornix and the field lines nothing. From a fifth
/// of the curve or at 1.2×, more bytes were lost (up to 81 B); at 1.4×,
/// less work was skipped (59 %).
#[derive(Clone, Debug)]
pub struct GiveUp {
    /// The factor on the arcs' estimate the block has learned so far.
    pub arcs_scale: f64,
    /// The rounded points' estimate to each vertex, once asked for (`None`
    /// where a point has no lattice point: then no give-up).
    points_bits: std::cell::OnceCell<Option<Vec<u64>>>,
}

impl GiveUp {
    const MARGIN: f64 = 1.3;
    const SLACK_BITS: f64 = 8.0;

    pub fn new(arcs_scale: f64) -> Self {
        GiveUp {
            arcs_scale,
            points_bits: std::cell::OnceCell::new(),
        }
    }

    /// Whether `enc`'s arcs, estimated at `bits` to input vertex `reach`,
    /// give up.
    fn now(&self, enc: &CurveEncoder, bits: u64, reach: usize) -> bool {
        let n = enc.points.len();
        if reach < (n / 4).max(8) || reach >= n {
            return false;
        }
        let scaled = bits as f64 * self.arcs_scale;
        // A vertex costs the points 4 bits at least (`lattice_bits`): below
        // that the arcs cannot lose, and the points are not rounded (the
        // smooth curves' case, where arcs take 1–3 bits a vertex).
        if scaled <= Self::MARGIN * 4.0 * reach as f64 + Self::SLACK_BITS {
            return false;
        }
        let points_bits = self.points_bits.get_or_init(|| match enc.points_code() {
            Some(CurveCode::Points { grid, .. }) => Some(super::points_bits_to(&grid)),
            _ => None,
        });
        points_bits
            .as_ref()
            .is_some_and(|p| scaled > Self::MARGIN * p[reach] as f64 + Self::SLACK_BITS)
    }
}

/// A checked candidate element.
struct Candidate {
    code: ElementCode,
    arc: Arc,
    /// Last input vertex it covers.
    reach: usize,
}

/// Rounding margin for the acceptance test: output points are written as
/// `f32` (relative rounding `2^-24`), and arcs are evaluated in `f64`.
pub fn acceptance_tolerance(tolerance: f64, points: &[DVec3]) -> f64 {
    let scale = points
        .iter()
        .map(|p| p.abs().max_element())
        .fold(0.0, f64::max);
    tolerance * (1.0 - 1e-9) - 4.0 * scale * f32::EPSILON as f64
}

/// [`CurveEncoder::candidate`]'s body, written once for both of its
/// forms: `$with_code` checks an element the one way or the other
/// ([`with_code_queued`], [`with_code_now`]).
macro_rules! candidate_body {
    (
        $self:ident, $state:ident, $frame:ident, $from:ident, $j:ident, $kind:ident,
        $with_code:ident
    ) => {{
        let (state, frame, from, j, kind) = ($state, $frame, $from, $j, $kind);
        let d = $self.points[j] - state.point;
        let x = d.dot(frame.0) / $self.q.length;
        let near = x.round();
        let other = if x >= near { near + 1.0 } else { near - 1.0 };
        let [x1, x2] = $self.offsets_to(state, frame, j);
        let a1 = Quantiser::index(x1, $self.q.offset)?;
        let a2 = Quantiser::index(x2, $self.q.offset)?;
        for steps in [near, other] {
            if steps.abs() >= (1u64 << super::entropy::MAX_BITS) as f64 {
                continue;
            }
            if let Some(c) = $with_code!($self, state, frame, from, j, kind, steps as i64, [a1, a2])
            {
                return Some(c);
            }
        }
        None
    }};
}

/// [`CurveEncoder::candidate_with_code`]'s body, written once for both of
/// its forms: `$accept` checks an arc the one way or the other
/// ([`accept_queued`], [`accept_now`]).
macro_rules! with_code_body {
    (
        $self:ident, $state:ident, $frame:ident, $from:ident, $j:ident, $kind:ident,
        $steps:ident, $offset:ident, $accept:ident
    ) => {{
        let (state, frame, from, j, kind, steps, offset) =
            ($state, $frame, $from, $j, $kind, $steps, $offset);
        let [a1, a2] = offset;
        let end = element_end_in(state.point, frame, steps, a1, a2, &$self.q);
        let mut code = ElementCode {
            kind,
            length: steps - state.chord_steps,
            offset: [a1, a2],
            bulge: [0, 0],
            bulge_base: [0, 0],
            jump: [0; 3],
            span: state.chord_steps,
        };
        if kind == ElementKind::Corner {
            // (The frame found once for the prediction and every bulge.)
            let chord = CornerChord::new(state.point, end, state.normal);
            if $self.bulge_prediction {
                code.bulge_base = chord.map_or([0, 0], |c| {
                    c.bulge_prediction(state.tangent, $self.q.offset)
                });
            }
            let chord = chord?;
            let (tries, count) =
                $self.corner_bulges(&chord, state.point, end, from, j, code.bulge_base)?;
            for b in tries.into_iter().take(count) {
                // (The residual is what is coded: within the coder's range.)
                let residual = [0, 1].map(|a| b[a].wrapping_sub(code.bulge_base[a]));
                if !residual.into_iter().all(super::entropy::codable) {
                    continue;
                }
                let t = chord.tangent(b, $self.q.offset);
                let arc = match $self.candidate_arc(state.point, t, end, from, j) {
                    Err(_) => return None,
                    Ok(None) => continue,
                    Ok(Some(arc)) => arc,
                };
                if $accept!($self, &arc, from, j) {
                    code.bulge = b;
                    return Some(Candidate {
                        code,
                        arc,
                        reach: j,
                    });
                }
            }
            return None;
        }
        let tangent = match kind {
            ElementKind::Straight => (end - state.point).normalize(),
            _ => state.tangent,
        };
        let arc = $self
            .candidate_arc(state.point, tangent, end, from, j)
            .ok()??;
        $accept!($self, &arc, from, j).then_some(Candidate {
            code,
            arc,
            reach: j,
        })
    }};
}

/// A candidate element's check through the mailbox.
macro_rules! with_code_queued {
    ($self:ident, $($arg:expr),* $(,)?) => {
        $self.candidate_with_code($($arg),*).await
    };
}

/// A candidate element's check here and now.
macro_rules! with_code_now {
    ($self:ident, $($arg:expr),* $(,)?) => {
        $self.candidate_with_code_now($($arg),*)
    };
}

/// An arc's check through the mailbox.
macro_rules! accept_queued {
    ($self:ident, $arc:expr, $from:expr, $to:expr) => {
        $self.accept($arc, $from, $to).await
    };
}

/// An arc's check here and now.
macro_rules! accept_now {
    ($self:ident, $arc:expr, $from:expr, $to:expr) => {
        $self.accept_now($arc, $from, $to)
    };
}

/// Vertices past the reach to beat that [`CurveEncoder::furthest`] tries
/// for the first that passes, before it gallops from there, in the
/// cheapest-first order ([`CHEAPEST_FIRST`]; after a corner,
/// [`TRIES_AFTER_CORNER`]). Session 56:
/// the straight and corner kinds were searched from the chain's end like
/// the G1 arc, though only a reach beyond the G1 arc's (or the straight
/// one's) is kept. Searched only beyond it, the tracker's streamlines of
/// `benches/make_unseen.py` took 7 % fewer cycles at 0.1 mm and 0.5 mm
/// (cachegrind's instructions and mispredicted branches), the dense ones
/// and 10,000 fornix replicas at 0.5 mm 5–6 %, at 0.1 mm 1 %. Bytes, trying 1 / 2 / 3
/// / 4 vertices beyond: over the 20 file and tolerance pairs checked
/// +0.03 / −0.11 / −0.15 / −0.18 % (the tracker's streamlines at 0.1 mm
/// +0.3 / −0.7 / −1.0 / −1.2 %: a kind's passing reaches are not a prefix,
/// and the first of four from the chain's end seldom found the far ones;
/// the fornix at 0.5 mm +0.4 / +0.3 / +0.3 / +0.3 %), the cycles of 2, 3
/// and 4 within 2 %.
const TRIES_BEYOND: usize = 3;

/// [`TRIES_BEYOND`] for the cheaper kinds searched after a corner
/// ([`CORNER_FIRST`]): one try past the reach kept so far (for the G1 arc
/// after a corner that passed, the corner's own reach, where the cheaper
/// kind wins the tie), and the guess. Measured (session 58, cachegrind's
/// cycles proxy, single thread, against 3; at 0.1 mm unless stated): the
/// tracker's streamlines of `benches/make_unseen.py` 5.1 % fewer cycles for
/// 0.21 % more bytes (0.07 % at 0.5 mm), the dense ones 4.7 % for 0.07 %,
/// the hair at 0.5 mm 3.6 % for 0.003 %; the solar field lines at 0.001 R☉
/// 0.05 % larger, every other of the 20 file and tolerance pairs checked
/// within 0.03 %. (2 tries: under half the cycles for under a third of the
/// bytes.) Where corners follow corners the G1 and straight elements that
/// pass beyond the corner's reach but not at it are few: on the tracker's
/// streamlines the cheaper kinds' searches drew 309,000 candidates (with
/// one try 220,000) for the 10,000 G1 and straight elements kept of
/// 46,000.
const TRIES_AFTER_CORNER: usize = 1;

/// The kinds of an element in the order they are searched: the cheapest
/// first ([`CurveEncoder::chain`]).
const CHEAPEST_FIRST: [ElementKind; 3] =
    [ElementKind::G1, ElementKind::Straight, ElementKind::Corner];

/// The order after a corner: the corner first, then the cheaper kinds only
/// from its reach on ([`TRIES_AFTER_CORNER`] tries). Measured (session 57)
/// on the tracker's streamlines of `benches/make_unseen.py` at 0.1 mm,
/// where 83 % of the elements are corners: the G1 and straight searches
/// from the chain's end drew 15 of the 27 candidate arcs an element and
/// won 16 % of them.
const CORNER_FIRST: [ElementKind; 3] =
    [ElementKind::Corner, ElementKind::G1, ElementKind::Straight];

/// How a kind ranks by its cost in bits (a straight segment costs a kind
/// flag more than a G1 arc, a corner also a bulge): on equal reach the
/// cheaper is kept.
fn cost_rank(kind: ElementKind) -> u8 {
    match kind {
        ElementKind::G1 => 0,
        ElementKind::Straight => 1,
        ElementKind::Corner => 2,
        ElementKind::Jump => 3,
    }
}

/// [`CurveEncoder::furthest`]'s body, written once for both of its forms
/// (`queued` or `now`: how a candidate is checked).
macro_rules! furthest_body {
    ($self:ident, $state:ident, $frame:ident, $from:ident, $kind:ident, $guess:ident, $beat:ident, queued) => {
        furthest_body!(@ $self, $state, $frame, $from, $kind, $guess, $beat,
            |j| $self.candidate($state, $frame, $from, j, $kind).await,
            |good, bad, step, last| gallop(good, bad, step, last, async |j| {
                $self.candidate($state, $frame, $from, j, $kind).await
            }).await)
    };
    ($self:ident, $state:ident, $frame:ident, $from:ident, $kind:ident, $guess:ident, $beat:ident, now) => {
        furthest_body!(@ $self, $state, $frame, $from, $kind, $guess, $beat,
            |j| $self.candidate_now($state, $frame, $from, j, $kind),
            |good, bad, step, last| gallop_now(good, bad, step, last, |j| {
                $self.candidate_now($state, $frame, $from, j, $kind)
            }))
    };
    (@ $self:ident, $state:ident, $frame:ident, $from:ident, $kind:ident, $guess:ident,
        $beat:ident,
        |$j:ident| $candidate:expr,
        |$good:ident, $bad:ident, $step:ident, $last:ident| $gallop:expr) => {{
        let (from, guess, beat): (usize, usize, Option<(usize, usize)>) = ($from, $guess, $beat);
        let last = $self.points.len() - 1;
        let mut good = None;
        let mut bad = None;
        if guess > 4 && from + guess < last && beat.is_none_or(|(b, _)| from + guess > b) {
            let $j = from + guess;
            match $candidate {
                Some(c) => good = Some(c),
                None => bad = Some(from + guess),
            }
        }
        if good.is_none() {
            // The first of a few vertices that passes, short of a vertex
            // known to fail: after the chain's end (the nearest vertex may
            // be too close for the length step), or with `beat` after it
            // (only a reach beyond it is wanted; the search takes the
            // reaches that pass for a prefix, which they are not always,
            // hence more than one try in the cheapest-first order,
            // [`TRIES_BEYOND`]; after a corner only
            // [`TRIES_AFTER_CORNER`]).
            let (first, tries) = beat.map_or((from + 1, 4), |(b, tries)| (b + 1, tries));
            let end = (first + tries - 1).min(last).min(bad.map_or(usize::MAX, |x| x - 1));
            for $j in first..=end {
                good = $candidate;
                if good.is_some() {
                    break;
                }
            }
        }
        let ($good, $bad, $step, $last) = (good?, bad, (guess / 2).max(1), last);
        Some($gallop)
    }};
}

/// [`gallop`]'s body, written once for both of its forms (`$try` asks for
/// the candidate ending at vertex `$j`, awaiting it or not).
macro_rules! gallop_body {
    ($good:ident, $bad:ident, $step:ident, $last:ident, |$j:ident| $try:expr) => {{
        let (mut good, mut bad, mut step, last) = ($good, $bad, $step, $last);
        if bad.is_none() {
            loop {
                let next = (good.reach + step).min(last);
                if next == good.reach {
                    break;
                }
                let $j = next;
                match $try {
                    Some(c) => {
                        good = c;
                        step *= 2;
                    }
                    None => {
                        bad = Some(next);
                        break;
                    }
                }
            }
        }
        if let Some(mut bad) = bad {
            while bad > good.reach + 1 {
                let mid = (good.reach + bad) / 2;
                let $j = mid;
                match $try {
                    Some(c) => good = c,
                    None => bad = mid,
                }
            }
        }
        good
    }};
}

impl<'a> CurveEncoder<'a> {
    /// The start point on its lattice (`None` if not codable).
    fn start_index(&self) -> Option<[i64; 3]> {
        super::quantise::bcc_nearest(self.points[0], self.q.start)
    }

    /// Bulge estimate for an arc from `q` to `e` following input vertices
    /// `from..=to`: the sagitta vector of the circle through `q`, the middle
    /// vertex and `e` (parabolic approximation `y = 4hλ(1 − λ)`).
    fn bulge_estimate(&self, q: DVec3, e: DVec3, from: usize, to: usize) -> DVec3 {
        let d = e - q;
        let c2 = d.length_squared();
        if c2 == 0.0 || to <= from + 1 {
            return DVec3::ZERO;
        }
        let mid = self.points[(from + to) / 2];
        let w = mid - q;
        let lambda = w.dot(d) / c2;
        if !(0.1..=0.9).contains(&lambda) {
            return DVec3::ZERO;
        }
        let perp = w - d * lambda;
        perp / (4.0 * lambda * (1.0 - lambda))
    }

    /// The arc from `start` along `tangent` to `end` as a candidate for
    /// input vertices `from + 1..=to` ([`Arc::new`]'s error where there is
    /// none), or `None` where (on the CPU) one of them is certainly beyond
    /// the tolerance of what it decodes to ([`surely_fails`]: asked before
    /// the arc's angle is found and its samples drawn, where the chord
    /// turns less than 2.6 rad from the tangent, so that the angle could
    /// not have refused the arc: the same answers as drawing them).
    fn candidate_arc(
        &self,
        start: DVec3,
        tangent: DVec3,
        end: DVec3,
        from: usize,
        to: usize,
    ) -> Result<Option<Arc>, ArcError> {
        let circle = Circle::new(start, tangent, end)?;
        if self.mailbox.is_none()
            && circle.cos_a > -0.85
            && surely_fails(
                &circle,
                &self.points[from + 1..=to],
                self.tol2,
                self.q.sagitta,
            )
        {
            return Ok(None);
        }
        circle.arc().map(Some)
    }

    /// Accepts `arc` for input vertices `(from, to]` if the two-sided test
    /// passes (on the samples the decoder draws). With a mailbox the test is
    /// asked there first: a sure verdict is the reference's
    /// ([`crate::twin::arc_check`]), an unsure one is decided here.
    async fn accept(&self, arc: &Arc, from: usize, to: usize) -> bool {
        if let Some(mailbox) = self.mailbox {
            // Boxed: the question's future is large, and every search
            // future above this one would carry (and move) it. Measured
            // (release): `accept`'s future 224 → 80 bytes, a candidate's
            // 768 → 576; moving them was 9 % of compressing the fornix
            // replicas. (Since session 54 the CPU's search does not come
            // here but for a curve's first element: its candidates and
            // furthest reaches are checked by `accept_now` directly.)
            let verdict = Box::pin(mailbox.ask(super::batch::CheckRequest {
                arc: *arc,
                from,
                to,
            }))
            .await;
            match verdict {
                super::batch::Verdict::Fail => return false,
                super::batch::Verdict::Pass => return true,
                super::batch::Verdict::Unsure => {}
            }
        }
        self.accept_now(arc, from, to)
    }

    /// The reference acceptance test ([`accept`](Self::accept)), here and
    /// now.
    pub fn accept_now(&self, arc: &Arc, from: usize, to: usize) -> bool {
        // The samples in a buffer of this thread's: most candidates are
        // checked and dropped, and the chosen one's are drawn again
        // (`Arc::sample_into` is deterministic).
        thread_local! {
            static SAMPLES: std::cell::RefCell<Vec<DVec3>> = const { std::cell::RefCell::new(Vec::new()) };
        }
        SAMPLES.with_borrow_mut(|samples| {
            samples.clear();
            samples.push(arc.start);
            arc.sample_into(self.q.sagitta, samples);
            let n = self.points.len();
            // Input vertices covered by this element are near its samples.
            if !all_within(&self.points[from + 1..=to], samples, self.tol2) {
                return false;
            }
            // Samples are near the input window around the element.
            let lo = from.saturating_sub(1);
            let hi = (to + 1).min(n - 1);
            all_within(&samples[1..], &self.points[lo..=hi], self.tol2)
        })
    }

    /// The G1 element from `state` towards input vertex `j` (or a corner,
    /// with its bulge), quantised and checked. The chord length is rounded
    /// to the nearest step first, then to the other neighbour: a coarse
    /// length step slides the end along the curve, and one of the two
    /// usually stays within the input.
    ///
    /// Without a mailbox (on the CPU) the check is made here and now
    /// ([`candidate_now`](Self::candidate_now)), and the one that may wait
    /// on the mailbox is boxed: this future is then a few words, where it
    /// was 576 bytes that every call moved into place, and the searches
    /// above it, which hold it, as much smaller. Measured (session 54, 2
    /// cores, alternated runs, the same containers): 30,000 tracked
    /// streamlines and 30,000 dense ones (`benches/make_unseen.py --seed 7`)
    /// at 0.1 mm 8.6 % and 6.7 % faster.
    async fn candidate(
        &self,
        state: &ChainState,
        frame: &Frame,
        from: usize,
        j: usize,
        kind: ElementKind,
    ) -> Option<Candidate> {
        if self.mailbox.is_none() {
            return self.candidate_now(state, frame, from, j, kind);
        }
        // (Boxed, the checks asked of the mailbox: its future is large.)
        Box::pin(
            async move { candidate_body!(self, state, frame, from, j, kind, with_code_queued) },
        )
        .await
    }

    /// [`candidate`](Self::candidate), each check made here and now.
    fn candidate_now(
        &self,
        state: &ChainState,
        frame: &Frame,
        from: usize,
        j: usize,
        kind: ElementKind,
    ) -> Option<Candidate> {
        candidate_body!(self, state, frame, from, j, kind, with_code_now)
    }

    /// Input vertex `j`'s offsets from `state` across its predicted chord
    /// (before quantisation), `frame` the chord's
    /// ([`ChainState::predicted_frame`]).
    fn offsets_to(&self, state: &ChainState, frame: &Frame, j: usize) -> [f64; 2] {
        let d = self.points[j] - state.point;
        [d.dot(frame.1), d.dot(frame.2)]
    }

    /// A G1 or straight element ending a chord of `steps` and offsets
    /// `offset` (a corner: also its bulge) from `state`, as
    /// [`candidate`](Self::candidate) checks it for reach `j` (here and
    /// now without a mailbox, as it does).
    #[allow(clippy::too_many_arguments)]
    async fn candidate_with_code(
        &self,
        state: &ChainState,
        frame: &Frame,
        from: usize,
        j: usize,
        kind: ElementKind,
        steps: i64,
        offset: [i64; 2],
    ) -> Option<Candidate> {
        if self.mailbox.is_none() {
            return self.candidate_with_code_now(state, frame, from, j, kind, steps, offset);
        }
        Box::pin(async move {
            with_code_body!(
                self,
                state,
                frame,
                from,
                j,
                kind,
                steps,
                offset,
                accept_queued
            )
        })
        .await
    }

    /// [`candidate_with_code`](Self::candidate_with_code), its checks made
    /// here and now.
    #[allow(clippy::too_many_arguments)]
    fn candidate_with_code_now(
        &self,
        state: &ChainState,
        frame: &Frame,
        from: usize,
        j: usize,
        kind: ElementKind,
        steps: i64,
        offset: [i64; 2],
    ) -> Option<Candidate> {
        with_code_body!(self, state, frame, from, j, kind, steps, offset, accept_now)
    }

    /// The element `c` (from input vertex `from`) with its end's offsets
    /// rounded toward the prediction instead of to the nearest step, where
    /// that still passes: the same reach for fewer bits (rate-aware
    /// rounding; both, then each alone). Measured: field lines 0.44 %
    /// smaller at 0.001 R☉, 0.2 % larger at 0.01 (an end off the curve
    /// predicts the next element worse); fornix −0.05 / +0.5 %, hair
    /// −0.03 / −0.17 % at 0.1 / 0.5 mm; 0.15 % fewer bytes over the
    /// shared data in all; no slower within the noise.
    async fn cheapen(
        &self,
        state: &ChainState,
        frame: &Frame,
        from: usize,
        c: Candidate,
    ) -> Candidate {
        if !matches!(c.code.kind, ElementKind::G1 | ElementKind::Straight) {
            return c;
        }
        let j = c.reach;
        let t = self
            .offsets_to(state, frame, j)
            .map(|x| Quantiser::index_toward_zero(x, self.q.offset));
        let [Some(t1), Some(t2)] = t else {
            return c;
        };
        let [a1, a2] = c.code.offset;
        let steps = c.code.length + state.chord_steps;
        let mut tries = Vec::with_capacity(3);
        if t1 != a1 && t2 != a2 {
            tries.push([t1, t2]);
        }
        if t1 != a1 {
            tries.push([t1, a2]);
        }
        if t2 != a2 {
            tries.push([a1, t2]);
        }
        for o in tries {
            if let Some(better) = self
                .candidate_with_code(state, frame, from, j, c.code.kind, steps, o)
                .await
            {
                return better;
            }
        }
        c
    }

    /// Bulge codes to try for a corner from `q` to `end` (`chord`, with
    /// its bulge frame): the estimate,
    /// then `base`, the bulge's prediction (its residual is the cheapest;
    /// zero, a straight segment's tangent, before model 16), and how many of
    /// the two are distinct. (With the prediction, zero as a third try made
    /// 11 of 28 file and tolerance pairs 0.01–0.3 % larger and 2 smaller,
    /// the heart fibres at 0.1 mm by 0.14 %; the prediction tried first,
    /// 0.1–0.6 % larger on most.)
    fn corner_bulges(
        &self,
        chord: &CornerChord,
        q: DVec3,
        end: DVec3,
        from: usize,
        to: usize,
        base: [i64; 2],
    ) -> Option<([[i64; 2]; 2], usize)> {
        let h = self.bulge_estimate(q, end, from, to);
        let (f1, f2) = chord.frame();
        let b = [
            Quantiser::index(h.dot(f1), self.q.offset)?,
            Quantiser::index(h.dot(f2), self.q.offset)?,
        ];
        Some(([b, base], if b == base { 1 } else { 2 }))
    }

    /// Furthest-reaching element from `state` past input vertex `from`, or
    /// with `beat = Some((vertex, tries))`, only one reaching past that
    /// vertex (the guess where it lies beyond, else the first of `tries`
    /// vertices after it that passes, galloped from: [`TRIES_BEYOND`], or
    /// [`TRIES_AFTER_CORNER`]).
    /// `guess`: the span of the previous element. Curves change slowly, so
    /// the search starts there: one check usually confirms it, and the
    /// galloping or bisection then takes a few more, instead of growing
    /// from one vertex each time. (Here and now without a mailbox, as
    /// [`candidate`](Self::candidate) is, for the same reason: 30,000
    /// tracked streamlines at 0.1 mm 2.12 → 2.01 s, 5 runs alternated;
    /// 2.51 s before either.)
    async fn furthest(
        &self,
        state: &ChainState,
        frame: &Frame,
        from: usize,
        kind: ElementKind,
        guess: usize,
        beat: Option<(usize, usize)>,
    ) -> Option<Candidate> {
        if self.mailbox.is_none() {
            return self.furthest_now(state, frame, from, kind, guess, beat);
        }
        Box::pin(async move { furthest_body!(self, state, frame, from, kind, guess, beat, queued) })
            .await
    }

    /// [`furthest`](Self::furthest), each check made here and now.
    fn furthest_now(
        &self,
        state: &ChainState,
        frame: &Frame,
        from: usize,
        kind: ElementKind,
        guess: usize,
        beat: Option<(usize, usize)>,
    ) -> Option<Candidate> {
        furthest_body!(self, state, frame, from, kind, guess, beat, now)
    }

    /// The arcs for this curve and the points they decode to, or `None`
    /// where some stretch has no element that passes or the search gives
    /// up ([`GiveUp`]). With [`look_ahead`](Self::look_ahead) the curve is
    /// searched both with and without it and the chain of fewer estimated
    /// bits kept: the look-ahead weighs the next element as a G1 arc, and
    /// where corners follow (session 51: every kind is searched for every
    /// element) its choice may cost more (the hair at 0.5 mm 5 % larger
    /// than without it).
    pub async fn arcs(&self) -> Option<(CurveCode, Vec<DVec3>)> {
        let plain = self.chain(false).await;
        if !self.look_ahead {
            return plain;
        }
        let ahead = self.chain(true).await;
        match (plain, ahead) {
            (Some(p), Some(a)) => Some(
                if super::estimated_bits(&a.0) < super::estimated_bits(&p.0) {
                    a
                } else {
                    p
                },
            ),
            (p, a) => p.or(a),
        }
    }

    /// [`arcs`](Self::arcs) with each element chosen looking one ahead
    /// ([`look_ahead`](Self::look_ahead)) or not.
    async fn chain(&self, look_ahead: bool) -> Option<(CurveCode, Vec<DVec3>)> {
        let n = self.points.len();
        let start = self.start_index()?;
        let q0 = DVec3::new(
            start[0] as f64 * self.q.start,
            start[1] as f64 * self.q.start,
            start[2] as f64 * self.q.start,
        );
        if q0.distance_squared(self.points[0]) > self.tol2 {
            return None;
        }
        let mut decoded = vec![q0];
        // First element: its end on the start grid, and a bulge.
        let first = self.first_element(q0).await?;
        first.arc.sample_into(self.q.sagitta, &mut decoded);
        let mut state = first.arc.next_state(self.q.length);
        let mut from = first.reach;
        let mut span = first.reach;
        let mut elements = Vec::new();
        let first_end = first.code.offset;
        let first_end_z = first.code.length;
        let first_bulge = first.code.bulge;
        // The estimate so far, as `estimated_bits` counts it.
        let mut bits =
            super::first_element_bits([first_end[0], first_end[1], first_end_z], first_bulge);
        // The G1 search from the chain's end, where the look-ahead made it.
        let mut ahead: Option<Option<Candidate>> = None;
        // The kind of the element before (none before the first after
        // the first element).
        let mut last_kind: Option<ElementKind> = None;
        while from < n - 1 {
            // Every kind is searched (the cheapest first, but after a
            // corner where `corner_first`, below), and a costlier one
            // kept where it reaches further than the one kept so far (a
            // straight segment costs a kind flag more, a corner also a
            // bulge): a corner leaves the tangent the G1 arcs inherit, whose
            // error bounds their reach where the curve's curvature changes
            // (a droop, a tracker's noise between samples). Until session
            // 51 the other kinds were searched only where the G1 arc
            // reached at most two vertices: searching them always made the
            // hair at 0.5 mm 13 % smaller, the field lines 13–16 %, the
            // fornix 3 % / 14 % (0.1 / 0.5 mm), 10,000 fornix replicas at
            // 0.5 mm 13 %, and curves sampled densely (0.2 mm steps) 24–40 %,
            // in about the same time (the chains have fewer elements). A
            // corner kept only where it reaches a vertex further (the rule
            // before) was 0.1–1.4 % larger; the kind of fewer estimated bits
            // per vertex, 0.2–1.5 % larger; a corner also at equal reach,
            // 0.2–2.5 % larger.
            // The predicted chord's frame, the same for every candidate of
            // every kind here.
            let frame = &state.predicted_frame(state.frame_chord(self.q.length));
            // After a corner the corner is searched first, then the
            // cheaper kinds only as far as it reaches or beyond (on a tie
            // the cheaper kind is kept, as in the usual order): where
            // corners follow corners (a tracker's noisy steps, every
            // element's tangent off the curve's), the G1 and straight
            // searches from the chain's end were most of the candidates
            // (`CORNER_FIRST`'s note).
            let order =
                if self.corner_first && ahead.is_none() && last_kind == Some(ElementKind::Corner) {
                    CORNER_FIRST
                } else {
                    CHEAPEST_FIRST
                };
            let mut chosen: Option<Candidate> = None;
            for (i, kind) in order.into_iter().enumerate() {
                // (The look-ahead's search is a G1 search from the chain's
                // end: only ever the first of the cheapest-first order.)
                debug_assert!(ahead.is_none() || (i == 0 && kind == ElementKind::G1));
                let found = match ahead.take() {
                    Some(found) => found,
                    None => {
                        // (Searched only as far as the reach kept so far,
                        // or beyond it where this kind is not the cheaper.)
                        let tries = if order == CORNER_FIRST {
                            TRIES_AFTER_CORNER
                        } else {
                            TRIES_BEYOND
                        };
                        let beat = chosen.as_ref().map(|g| {
                            let wins_ties = cost_rank(kind) < cost_rank(g.code.kind);
                            (if wins_ties { g.reach - 1 } else { g.reach }, tries)
                        });
                        self.furthest(&state, frame, from, kind, span, beat).await
                    }
                };
                if let Some(c) = found {
                    if chosen.as_ref().is_none_or(|g| {
                        c.reach > g.reach
                            || (c.reach == g.reach && cost_rank(kind) < cost_rank(g.code.kind))
                    }) {
                        chosen = Some(c);
                    }
                }
            }
            let chosen = match chosen {
                Some(c) => c,
                None => match self.jump(&state, from).await {
                    Jump::To(c) => *c,
                    // The next vertex is within a start step of the chain's
                    // end, which is on the output: already covered.
                    Jump::Covered => {
                        from += 1;
                        continue;
                    }
                    Jump::Impossible => return None,
                },
            };
            let chosen = if look_ahead && chosen.code.kind != ElementKind::Jump {
                // (Cheapened first: the search ahead from it is then kept
                // unless a shorter element wins.)
                let chosen = self.cheapen(&state, frame, from, chosen).await;
                let reach = chosen.reach;
                let (chosen, next) = self.look_ahead(&state, frame, from, chosen).await;
                let code = chosen.code;
                let chosen = if chosen.reach == reach {
                    chosen
                } else {
                    self.cheapen(&state, frame, from, chosen).await
                };
                // (The search ahead was from the element before `cheapen`.)
                if chosen.code == code {
                    ahead = next;
                }
                chosen
            } else {
                self.cheapen(&state, frame, from, chosen).await
            };
            chosen.arc.sample_into(self.q.sagitta, &mut decoded);
            state = next_state(&chosen.arc, &state, chosen.code.kind, self.q.length);
            span = chosen.reach - from;
            from = chosen.reach;
            bits += super::element_bits(&chosen.code);
            if self
                .give_up
                .as_ref()
                .is_some_and(|g| g.now(self, bits, from))
            {
                return None;
            }
            last_kind = Some(chosen.code.kind);
            elements.push(chosen.code);
        }
        Some((
            CurveCode::Arcs {
                start,
                first_end: [first_end[0], first_end[1], first_end_z],
                first_bulge,
                elements,
            },
            decoded,
        ))
    }

    /// The element from `state` (at input vertex `from`) chosen one element
    /// ahead: the furthest-reaching `c`, or one ending up to [`LOOK_BACK`]
    /// vertices short of it from which the next G1 element reaches at least
    /// as far, for fewer estimated bits per vertex over the two
    /// ([`super::element_bits`]). Returns it and the next G1 element's
    /// search from its end (`None` where not made: `c` ends the curve or
    /// its next element cannot pass).
    ///
    /// Why: the furthest-reaching arc meets the tolerance's edge, its end
    /// tangent turned away from the curve's, so that the next arc, which
    /// inherits it, reaches little or needs a corner (on the hair at 0.5 mm,
    /// 36 % of the greedy search's elements were corners). A slightly
    /// shorter arc often leaves a tangent the next one follows much
    /// further. (The next element is taken at the furthest reach its
    /// galloping finds from the reach to beat.)
    async fn look_ahead(
        &self,
        state: &ChainState,
        frame: &Frame,
        from: usize,
        c: Candidate,
    ) -> (Candidate, Option<Option<Candidate>>) {
        let last = self.points.len() - 1;
        if c.reach >= last {
            return (c, None);
        }
        let after = |c: &Candidate| {
            let st = next_state(&c.arc, state, c.code.kind, self.q.length);
            let fr = st.predicted_frame(st.frame_chord(self.q.length));
            (st, fr)
        };
        let (st, fr) = after(&c);
        let next = self
            .furthest(&st, &fr, c.reach, ElementKind::G1, c.reach - from, None)
            .await;
        let per_vertex = |a: &ElementCode, b: &ElementCode, reach: usize| {
            (super::element_bits(a) + super::element_bits(b)) as f64 / (reach - from) as f64
        };
        // Where no G1 arc follows `c` (a corner or a straight segment
        // will), `c` stays. (Measured: taking instead the shorter arc
        // cheapest per vertex that a G1 arc follows past `c`'s end made
        // every file 0.05–0.5 % larger, and the heart fibres of
        // `benches/make_unseen.py` at 0.1 mm 5 %, more of them as arcs.)
        let (mut best_bits, mut target) = match &next {
            Some(n) => (per_vertex(&c.code, &n.code, n.reach), n.reach),
            None => return (c, Some(None)),
        };
        let mut best = (c, next);
        let top = best.0.reach;
        for back in 1..=LOOK_BACK.min(top - from - 1) {
            let Some(alt) = self
                .candidate(state, frame, from, top - back, best.0.code.kind)
                .await
            else {
                continue;
            };
            let (st, fr) = after(&alt);
            let Some(n) = self
                .candidate(&st, &fr, alt.reach, target, ElementKind::G1)
                .await
            else {
                continue;
            };
            let n = gallop(n, None, 1, last, async |j| {
                self.candidate(&st, &fr, alt.reach, j, ElementKind::G1)
                    .await
            })
            .await;
            let bits = per_vertex(&alt.code, &n.code, n.reach);
            if bits < best_bits {
                best_bits = bits;
                target = n.reach;
                best = (alt, Some(n));
            }
        }
        let (c, next) = best;
        (c, Some(next))
    }

    /// A straight segment from the chain's end to the next input vertex,
    /// rounded to the start grid relative to it (within `√3/2 · start` of
    /// the vertex), where no element passes: the vertex is then within the
    /// tolerance of the segment's end and the end of the vertex, so the test
    /// passes but for absurd margins.
    async fn jump(&self, state: &ChainState, from: usize) -> Jump {
        let d = self.points[from + 1] - state.point;
        let k = [d.x, d.y, d.z].map(|x| Quantiser::index(x, self.q.first));
        let [Some(a), Some(b), Some(c)] = k else {
            return Jump::Impossible;
        };
        let k = [a, b, c];
        if k == [0, 0, 0] {
            return if self.points[from + 1].distance_squared(state.point) <= self.tol2 {
                Jump::Covered
            } else {
                Jump::Impossible
            };
        }
        let end = jump_end(state.point, k, self.q.first);
        let Ok(arc) = Arc::new(state.point, (end - state.point).normalize(), end) else {
            return Jump::Impossible;
        };
        match self.accept(&arc, from, from + 1).await {
            true => Jump::To(Box::new(Candidate {
                code: ElementCode {
                    kind: ElementKind::Jump,
                    length: 0,
                    offset: [0, 0],
                    bulge: [0, 0],
                    bulge_base: [0, 0],
                    jump: k,
                    span: state.chord_steps,
                },
                arc,
                reach: from + 1,
            })),
            false => Jump::Impossible,
        }
    }

    /// The first element: end on the start grid relative to `q0`, furthest
    /// reach by galloping as for the others.
    async fn first_element(&self, q0: DVec3) -> Option<Candidate> {
        let last = self.points.len() - 1;
        let try_j = async |j: usize| -> Option<Candidate> {
            let d = self.points[j] - q0;
            let k = [
                Quantiser::index(d.x, self.q.first)?,
                Quantiser::index(d.y, self.q.first)?,
                Quantiser::index(d.z, self.q.first)?,
            ];
            if k == [0, 0, 0] {
                return None;
            }
            let end = first_end(q0, k, self.q.first);
            let h = self.bulge_estimate(q0, end, 0, j);
            let chord = CornerChord::new(q0, end, DVec3::ZERO)?;
            let (f1, f2) = chord.frame();
            let b = [
                Quantiser::index(h.dot(f1), self.q.offset)?,
                Quantiser::index(h.dot(f2), self.q.offset)?,
            ];
            for bulge in [b, [0, 0]] {
                let t = chord.tangent(bulge, self.q.offset);
                let arc = match self.candidate_arc(q0, t, end, 0, j) {
                    Err(_) => return None,
                    Ok(None) if b == [0, 0] => break,
                    Ok(None) => continue,
                    Ok(Some(arc)) => arc,
                };
                if self.accept(&arc, 0, j).await {
                    return Some(Candidate {
                        code: ElementCode {
                            kind: ElementKind::Corner,
                            length: k[2],
                            offset: [k[0], k[1]],
                            bulge,
                            bulge_base: [0, 0],
                            jump: [0; 3],
                            span: 0,
                        },
                        arc,
                        reach: j,
                    });
                }
                if b == [0, 0] {
                    break;
                }
            }
            None
        };
        // The nearest vertex may round onto the start: take the first
        // codable one.
        let mut good = None;
        let mut j = 1;
        while good.is_none() && j <= last.min(8) {
            good = try_j(j).await;
            j += 1;
        }
        Some(gallop(good?, None, 1, last, try_j).await)
    }

    /// The points on the body-centred cubic lattice (nearest point within
    /// `T`); `None` if a point is not codable or lands so near the edge of
    /// its cell that the output's `f32` rounding could take it past the
    /// tolerance. Every decoded point within `T` of its input
    /// point puts each output segment within `T` of its input segment
    /// (distance to a segment is convex), both ways.
    ///
    /// Rounding towards the prediction on a finer grid (steps 0.35, 0.5 and
    /// 0.7 T, the residual shrunk by what the tolerance ball leaves) was
    /// measured and lost: 10-15 % larger on the sparse bundles and hair.
    pub fn points_code(&self) -> Option<CurveCode> {
        let half = self.grid;
        let mut idx: Vec<[i64; 3]> = Vec::with_capacity(self.points.len());
        for p in self.points {
            let q = super::quantise::bcc_nearest(*p, half)?;
            if super::quantise::bcc_point(q, half).distance_squared(*p) > self.tol2 {
                return None;
            }
            idx.push(q);
        }
        Some(CurveCode::Points {
            grid: idx,
            reference: None,
            own: super::OwnPrediction::SecondOrder,
            along: false,
        })
    }
}

/// End of a G1 or corner element from its code: `steps` length steps along
/// the predicted chord direction (the previous arc continued for the
/// previous chord's length) and the perpendicular offsets.
pub fn element_end(state: &ChainState, steps: i64, a1: i64, a2: i64, q: &Quantiser) -> DVec3 {
    let frame = state.predicted_frame(state.frame_chord(q.length));
    element_end_in(state.point, &frame, steps, a1, a2, q)
}

/// A predicted chord's frame `(u, e1, e2)` ([`ChainState::predicted_frame`]).
type Frame = (DVec3, DVec3, DVec3);

/// [`element_end`] from `point` with the chord's `frame` already found.
fn element_end_in(
    point: DVec3,
    frame: &Frame,
    steps: i64,
    a1: i64,
    a2: i64,
    q: &Quantiser,
) -> DVec3 {
    let (u, e1, e2) = *frame;
    point + u * (steps as f64 * q.length) + (e1 * a1 as f64 + e2 * a2 as f64) * q.offset
}

/// From a passing candidate `good` (and a failing vertex `bad`, if one is
/// known), the furthest-reaching candidate: reaches grow by `step`, doubling,
/// up to vertex `last` until one fails, then bisection between the last pass
/// and the first failure. `try_j(j)` is the candidate ending at vertex `j`.
async fn gallop(
    good: Candidate,
    bad: Option<usize>,
    step: usize,
    last: usize,
    try_j: impl AsyncFn(usize) -> Option<Candidate>,
) -> Candidate {
    gallop_body!(good, bad, step, last, |j| try_j(j).await)
}

/// [`gallop`] with `try_j` answering here and now.
fn gallop_now(
    good: Candidate,
    bad: Option<usize>,
    step: usize,
    last: usize,
    try_j: impl Fn(usize) -> Option<Candidate>,
) -> Candidate {
    gallop_body!(good, bad, step, last, |j| try_j(j))
}

/// End of a jump from `q`: `q + k·step`.
pub fn jump_end(q: DVec3, k: [i64; 3], step: f64) -> DVec3 {
    q + DVec3::new(k[0] as f64, k[1] as f64, k[2] as f64) * step
}

/// What [`CurveEncoder::jump`] found.
enum Jump {
    To(Box<Candidate>),
    Covered,
    Impossible,
}

/// End of a curve's first element: `q0 + k·step`.
pub fn first_end(q0: DVec3, k: [i64; 3], step: f64) -> DVec3 {
    q0 + DVec3::new(k[0] as f64, k[1] as f64, k[2] as f64) * step
}

/// A corner's chord from `q` to `e` with its bulge frame, found once for
/// the bulge's prediction ([`CornerChord::bulge_prediction`]) and the
/// tangents of the bulges tried ([`CornerChord::tangent`]): before session
/// 57 each of those found the frame again, four times a corner candidate
/// (on the tracker's streamlines of `benches/make_unseen.py`, where 83 % of
/// the elements are corners, 8 % of compress's cycles in the frame alone).
/// The arithmetic is the same in every form, so the decoder, which builds
/// one per corner, finds the encoder's tangents bit for bit.
#[derive(Clone, Copy, Debug)]
pub struct CornerChord {
    /// The chord `e − q`, its length `c` and direction `u`.
    d: DVec3,
    c: f64,
    u: DVec3,
    /// The bulge frame: unit vectors across the chord, `f1` towards the
    /// perpendicular part of the chain's normal, `f2 = u × f1`.
    f1: DVec3,
    f2: DVec3,
}

impl CornerChord {
    /// The chord from `q` to `e` and its bulge frame, `f1` towards
    /// `normal`'s perpendicular part (a deterministic perpendicular when
    /// `normal` is zero); `None` for a chord of zero or non-finite length.
    pub fn new(q: DVec3, e: DVec3, normal: DVec3) -> Option<CornerChord> {
        let d = e - q;
        let c = d.length();
        if c == 0.0 || !c.is_finite() {
            return None;
        }
        let u = d / c;
        let f1 = if normal == DVec3::ZERO {
            super::predict::any_perpendicular(u)
        } else {
            perpendicular_part(normal, u)
        };
        Some(CornerChord {
            d,
            c,
            u,
            f1,
            f2: u.cross(f1),
        })
    }

    /// The bulge frame `(f1, f2)`.
    pub fn frame(&self) -> (DVec3, DVec3) {
        (self.f1, self.f2)
    }

    /// The prediction a corner's bulge code is coded against (model 16 on):
    /// half the bulge of the G1 arc along this chord, whose start tangent is
    /// the chain's `tangent`, in the chord's bulge frame, rounded to offset
    /// steps of `step`. A circular arc's sagitta vector is `(c/2)·tan(θ/2)` along the tangent's
    /// part across the chord (`c` the chord's length, `θ` the tangent's angle
    /// to it), and `tan(θ/2) = sin θ / (1 + cos θ)`: only `+ − × ÷ √`, so the
    /// decoder computes the same integers on every platform. A corner is
    /// chosen where the G1 arc's tangent has drifted from the curve's, so the
    /// coded one lies between it and the chord's: measured on the hair, the
    /// field lines, the fornix and the replicas at 0.5 mm, the whole G1 bulge
    /// as the prediction left the residuals of densely sampled fibres larger
    /// than none, half of it smaller everywhere. Zero where the tangent points
    /// back along the chord or the bulge is not codable.
    pub fn bulge_prediction(&self, tangent: DVec3, step: f64) -> [i64; 2] {
        let predict = || -> Option<[i64; 2]> {
            let cos = tangent.dot(self.u);
            if !(1.0 + cos > 1e-9) {
                return None;
            }
            let across = tangent - self.u * cos;
            let h = across * (0.25 * self.c / (1.0 + cos));
            let b = [h.dot(self.f1) / step, h.dot(self.f2) / step].map(f64::round);
            b.iter()
                .all(|x| x.is_finite() && x.abs() < (1u64 << 20) as f64)
                .then(|| b.map(|x| x as i64))
        };
        predict().unwrap_or([0, 0])
    }

    /// The corner's start tangent from its bulge code ([`corner_from_code`]).
    pub fn tangent(&self, bulge: [i64; 2], step: f64) -> DVec3 {
        let h = (self.f1 * bulge[0] as f64 + self.f2 * bulge[1] as f64) * step;
        corner_tangent(self.d / self.c, self.c, h)
    }
}

/// The bulge frame of a corner from `q` to `e`: two unit vectors
/// perpendicular to the chord, the first towards `normal`'s perpendicular
/// part (a deterministic perpendicular when `normal` is zero).
pub fn bulge_frame(q: DVec3, e: DVec3, normal: DVec3) -> Option<(DVec3, DVec3)> {
    CornerChord::new(q, e, normal).map(|c| c.frame())
}

/// Start tangent of a corner element from its bulge code.
pub fn corner_from_code(
    q: DVec3,
    e: DVec3,
    normal: DVec3,
    bulge: [i64; 2],
    step: f64,
) -> Option<DVec3> {
    CornerChord::new(q, e, normal).map(|c| c.tangent(bulge, step))
}

/// The chain state after an element. After a straight segment the
/// prediction turns on by the angle it turned (a polyline's discrete
/// curvature), in the same direction.
pub fn next_state(
    arc: &Arc,
    before: &ChainState,
    kind: ElementKind,
    length_step: f64,
) -> ChainState {
    let mut st = arc.next_state(length_step);
    if kind == ElementKind::G1 {
        st.set_twist(observed_twist(arc, before, length_step));
    }
    if matches!(kind, ElementKind::Straight | ElementKind::Jump) {
        let turn = arc.tangent - before.tangent;
        let sin_turn = arc.tangent.cross(before.tangent).length();
        if sin_turn > 1e-12 {
            st.normal = perpendicular_part(turn, arc.tangent);
            st.bend = st.normal;
            st.curvature = 2.0 * sin_turn / st.frame_chord(length_step);
        }
    }
    st
}

/// The turn of the arc plane at the junction before a G1 `arc`: the signed
/// angle about the tangent from the previous arc's normal to this one's.
/// On a helix of curvature `κ` and torsion `τ` the osculating arcs' planes
/// turn by about `τ·L` per element, so the next arc is predicted turned by
/// as much again. Only where both normals are well defined: both arcs bend
/// by several length steps (a nearly straight arc's plane is noise).
fn observed_twist(arc: &Arc, before: &ChainState, length_step: f64) -> f64 {
    const MIN_BEND_STEPS: f64 = 2.0;
    let bend = |curvature: f64, chord: f64| 0.5 * curvature * chord * chord;
    let chord = (arc.end - arc.start).length();
    let before_chord = before.frame_chord(length_step);
    if bend(arc.curvature, chord) < MIN_BEND_STEPS * length_step
        || bend(before.curvature, before_chord) < MIN_BEND_STEPS * length_step
    {
        return 0.0;
    }
    let t = arc.tangent;
    let (from, to) = (before.normal, arc.normal);
    let angle = t.dot(from.cross(to)).atan2(from.dot(to));
    // A turn of more than a right angle is a change of bend, not torsion.
    if angle.abs() > std::f64::consts::FRAC_PI_2 {
        0.0
    } else {
        angle
    }
}

/// Whether one of `points` is certainly farther than `√tol2` from the
/// polyline the decoder writes for `arc`: a bound that needs no samples,
/// asked before [`CurveEncoder::accept_now`] draws them. That polyline is
/// within `sagitta` of the arc ([`Arc::pieces`]), its chords inside the
/// arc's circle, so a point inside the circle's cylinder farther than
/// `√tol2 + sagitta` from the circle, or outside it farther than `√tol2`,
/// fails the check (for a nearly straight arc: farther than `√tol2 +
/// sagitta` plus the arc's own sagitta from its chord's line); a margin of
/// a thousandth of the tolerance covers the rounding. Never true where the
/// check would pass: the same elements, fewer samples drawn (compress at
/// 0.5 mm 3 % less CPU time on 100,000 fornix replicas).
fn surely_fails(arc: &Circle, points: &[DVec3], tol2: f64, sagitta: f64) -> bool {
    let tol = tol2.sqrt();
    let reach = tol * 1.001 + sagitta;
    let reach2 = reach * reach;
    // (Two thirds of the candidates fail, most of them at a vertex near
    // their start: the first vertex that fails here ends the test.)
    let mut probes = points.iter();
    let radius = 1.0 / arc.curvature;
    if radius.is_finite() && radius <= 1e6 * tol {
        let centre = arc.start + arc.normal * radius;
        let axis = arc.tangent.cross(arc.normal);
        // Outside the circle's cylinder the chords, inside its disc, are no
        // nearer than the circle itself.
        let outside2 = tol2 * (1.001 * 1.001);
        probes.any(|&x| {
            let w = x - centre;
            let h = w.dot(axis);
            let rho = (w - axis * h).length();
            let d2 = h * h + (rho - radius) * (rho - radius);
            d2 > if rho >= radius { outside2 } else { reach2 }
        })
    } else {
        // A nearly straight arc: within κL²/8 of its chord, its length L
        // below 1.000001 times the chord where sin α ≤ 10⁻³ (α/sin α);
        // beyond that (a chord of thousands of tolerances) no bound.
        if !(arc.cos_a > 0.0 && arc.sin_a <= 1e-3) {
            return false;
        }
        let length = 1.000001 * arc.chord;
        let bow = arc.curvature * length * length / 8.0;
        let reach = reach + bow;
        let chord = arc.end - arc.start;
        let c2 = chord.length_squared();
        if !(c2 > 0.0) || !reach.is_finite() {
            return false;
        }
        probes.any(|&x| {
            let w = x - arc.start;
            let along = w.dot(chord);
            (w.length_squared() - along * along / c2) > reach * reach
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The order the kinds are searched in rests on `cost_rank`: of the
    /// same chord, a G1 arc is estimated at fewer bits than a straight
    /// segment, and a straight segment at fewer than a corner of any
    /// bulge, so a tie is kept by the cheaper whichever kind was searched
    /// first.
    #[test]
    fn cost_rank_orders_the_kinds_as_their_estimated_bits() {
        let mut rng = ChaCha8Rng::seed_from_u64(57);
        for _ in 0..2000 {
            let mut v = || rng.gen_range(-300i64..300);
            let (length, offset, bulge) = (v(), [v(), v()], [v(), v()]);
            let code = |kind| ElementCode {
                kind,
                length,
                offset,
                bulge,
                bulge_base: [0, 0],
                jump: [0; 3],
                span: 0,
            };
            let kinds = [ElementKind::G1, ElementKind::Straight, ElementKind::Corner];
            for w in kinds.windows(2) {
                assert!(cost_rank(w[0]) < cost_rank(w[1]));
                assert!(
                    super::super::element_bits(&code(w[0]))
                        < super::super::element_bits(&code(w[1])),
                    "{:?} {length} {offset:?} {bulge:?}",
                    w
                );
            }
            // The two orders search every kind once.
            for order in [CHEAPEST_FIRST, CORNER_FIRST] {
                let mut o = order.map(cost_rank);
                o.sort();
                assert_eq!(o, [0, 1, 2]);
            }
        }
    }

    /// `surely_fails` never refuses what the check passes, on arcs from
    /// nearly straight to over a half turn, with points scattered up to
    /// twice the tolerance off them; and it does refuse most of those
    /// farther than the tolerance plus the sagitta.
    #[test]
    fn surely_fails_only_where_the_check_fails() {
        let mut rng = ChaCha8Rng::seed_from_u64(19);
        let (mut refused, mut failing_far) = (0, 0);
        for case in 0..4000 {
            let tol: f64 = rng.gen_range(0.01..1.0);
            let sagitta = 0.15 * tol;
            let start = DVec3::new(
                rng.gen_range(-50.0..50.0),
                rng.gen_range(-50.0..50.0),
                rng.gen_range(-50.0..50.0),
            );
            let tangent = DVec3::new(
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
            )
            .normalize();
            // Chords of 1-40 tolerances, turned from the tangent by up to
            // 0.9π (or by almost nothing).
            let turn: f64 = if case % 4 == 0 {
                rng.gen_range(0.0..1e-7)
            } else {
                rng.gen_range(0.0..2.8)
            };
            let side = tangent.any_orthonormal_vector();
            let dir = tangent * (turn / 2.0).cos() + side * (turn / 2.0).sin();
            let end = start + dir * tol * rng.gen_range(1.0..40.0);
            let Ok(circle) = Circle::new(start, tangent, end) else {
                continue;
            };
            let Ok(arc) = circle.arc() else {
                continue;
            };
            let mut poly = vec![arc.start];
            arc.sample_into(sagitta, &mut poly);
            let points: Vec<DVec3> = (0..rng.gen_range(1..12))
                .map(|_| {
                    let s = rng.gen_range(0.0..arc.length);
                    let off = DVec3::new(
                        rng.gen_range(-1.0..1.0),
                        rng.gen_range(-1.0..1.0),
                        rng.gen_range(-1.0..1.0),
                    );
                    arc.point_at(s) + off * rng.gen_range(0.0..2.0) * tol
                })
                .collect();
            let passes = all_within(&points, &poly, tol * tol);
            let refuses = surely_fails(&circle, &points, tol * tol, sagitta);
            assert!(
                !(refuses && passes),
                "case {case}: refused a passing candidate"
            );
            refused += refuses as usize;
            let far = points.iter().any(|&p| {
                let d2 = poly
                    .windows(2)
                    .map(|w| super::super::check::dist2_to_segment(p, w[0], w[1]))
                    .fold(f64::INFINITY, f64::min);
                d2.sqrt() > 1.2 * tol + sagitta
            });
            failing_far += far as usize;
        }
        assert!(failing_far > 500, "{failing_far}");
        assert!(
            2 * refused > failing_far,
            "{refused} refused of {failing_far} far off"
        );
    }
}
