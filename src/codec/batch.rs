//! Candidate checks in batches: how the encoder's per-curve search runs on
//! a backend that answers many checks at once (the GPU).
//!
//! The element search ([`super::encoder`]) is sequential within a curve —
//! each candidate depends on the verdict on the one before — but the
//! curves of a block are independent. So each curve's search is written
//! once, as an `async` function whose every acceptance test is a question
//! put in the curve's [`Mailbox`]. Run with no mailbox, every question is
//! answered at once on the asking thread ([`now`]): that is the CPU path.
//! Run by [`search_block`], all curves of a block advance together: each
//! runs until it asks, the questions of all curves go to the
//! [`ArcChecker`] in one batch, the verdicts come back, and every curve
//! runs on to its next question. How verdicts are used (so that the
//! container is the same bytes whichever backend checks) is described on
//! `ArcChecker`; the reference is [`crate::twin::arc_check`].

use std::cell::Cell;
use std::future::Future;
use std::pin::Pin;
use std::task::{Context, Poll, Waker};

use glam::DVec3;

use super::encoder::CurveEncoder;
use super::predict::Arc;
use super::CurveCode;

/// One acceptance test: `arc` for input vertices `(from, to]` of the
/// asking curve.
#[derive(Clone, Copy, Debug)]
pub struct CheckRequest {
    pub arc: Arc,
    pub from: usize,
    pub to: usize,
}

/// A batch checker's answer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// The reference accepts.
    Pass,
    /// The reference rejects.
    Fail,
    /// Too close to the tolerance to tell in the checker's precision: the
    /// reference decides.
    Unsure,
}

/// One candidate of a batch, in the form a checker takes: coordinates
/// relative to the curve's origin (its first input point), indices into
/// the block's flat points ([`ArcChecker::open`]).
#[derive(Clone, Copy, Debug)]
pub struct ArcCandidate {
    /// Start point of the arc.
    pub start: DVec3,
    /// Unit tangent at the start.
    pub tangent: DVec3,
    /// Unit in-plane normal at the start, towards the centre (any
    /// perpendicular for a straight arc).
    pub normal: DVec3,
    /// End point of the arc.
    pub end: DVec3,
    /// Curvature (0 for a straight arc).
    pub curvature: f64,
    /// Arc length of one piece (`length / pieces`).
    pub step: f64,
    /// Arc length.
    pub length: f64,
    /// Equal pieces the decoder cuts the arc into.
    pub pieces: u32,
    /// Covered input vertices, first and last (inclusive).
    pub cover: (u32, u32),
    /// The input window the samples are checked against (inclusive).
    pub window: (u32, u32),
    /// Squared acceptance distance.
    pub tol2: f64,
    /// Largest coordinate of the curve relative to its origin.
    pub radius: f64,
    /// Largest coordinate of the origin itself (the reference works in
    /// absolute coordinates).
    pub origin_scale: f64,
}

/// A backend that checks many candidates at once (on the GPU, the
/// `arc_check` kernel).
///
/// The element search is sequential within a curve — each candidate depends
/// on the verdict on the one before — but the curves of a block are
/// independent, so [`encode_block_on`](super::encode_block_on) advances all
/// curves of a block together and puts their questions to the checker in one
/// batch per round. A sure verdict ([`Verdict::Pass`], [`Verdict::Fail`])
/// must be the reference's; an [`Verdict::Unsure`] one is decided by the
/// reference on the asking thread, so the chosen elements, and so the
/// container, are the same bytes whichever backend checks.
pub trait ArcChecker: Sync {
    /// Takes a block's points (each curve's relative to its origin,
    /// curve after curve) for the checks that follow.
    fn open(&self, points: &[DVec3]) -> Result<Box<dyn ArcCheckBlock + '_>, String>;
}

/// The checks of one block.
pub trait ArcCheckBlock {
    /// One verdict per candidate.
    fn verdicts(&mut self, candidates: &[ArcCandidate]) -> Result<Vec<Verdict>, String>;
}

/// Where one curve's search puts its question and finds the verdict.
#[derive(Default)]
pub struct Mailbox {
    request: Cell<Option<CheckRequest>>,
    verdict: Cell<Option<Verdict>>,
}

impl Mailbox {
    /// Asks `request`; resolves when [`search_block`] has put a verdict.
    pub fn ask(&self, request: CheckRequest) -> Ask<'_> {
        Ask {
            mailbox: self,
            request: Some(request),
        }
    }
}

/// The future of [`Mailbox::ask`].
pub struct Ask<'a> {
    mailbox: &'a Mailbox,
    request: Option<CheckRequest>,
}

impl Future for Ask<'_> {
    type Output = Verdict;
    fn poll(mut self: Pin<&mut Self>, _: &mut Context<'_>) -> Poll<Verdict> {
        if let Some(r) = self.request.take() {
            self.mailbox.verdict.set(None);
            self.mailbox.request.set(Some(r));
            return Poll::Pending;
        }
        match self.mailbox.verdict.take() {
            Some(v) => Poll::Ready(v),
            None => Poll::Pending,
        }
    }
}

/// Runs a search that asks no mailbox: it completes at its first poll.
pub fn now<F: Future>(f: F) -> F::Output {
    let mut f = std::pin::pin!(f);
    match f.as_mut().poll(&mut Context::from_waker(Waker::noop())) {
        Poll::Ready(v) => v,
        Poll::Pending => unreachable!("a search without a mailbox never waits"),
    }
}

/// What the batched checks of one block came to: the candidates put to an
/// [`ArcChecker`], in how many rounds, and how many the reference decided
/// ([`EncodedBlock::checks`](super::EncodedBlock::checks)).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BatchStats {
    /// Candidates the checker was asked about.
    pub checked: u64,
    /// Of those, verdicts left to the reference (unsure, or the checker
    /// failed).
    pub unsure: u64,
    /// Batches (rounds).
    pub rounds: u64,
    /// Whether the checker failed and the block was finished on the CPU.
    pub fell_back: bool,
}

impl BatchStats {
    /// Adds the counts of `other` (a later part of the same block, or its
    /// other coding).
    pub fn add(&mut self, other: &BatchStats) {
        self.checked += other.checked;
        self.unsure += other.unsure;
        self.rounds += other.rounds;
        self.fell_back |= other.fell_back;
    }
}

/// The checker's form of `req`, asked by the search of `enc`, whose points
/// start at `base` in the block's flat points; `(origin, radius, origin
/// scale)` as [`ArcCandidate`] says.
pub(crate) fn candidate(
    enc: &CurveEncoder,
    req: &CheckRequest,
    base: usize,
    (o, radius, origin_scale): (DVec3, f64, f64),
) -> ArcCandidate {
    let base = base as u32;
    let pieces = req.arc.pieces(enc.q.sagitta);
    ArcCandidate {
        start: req.arc.start - o,
        tangent: req.arc.tangent,
        normal: req.arc.normal,
        end: req.arc.end - o,
        curvature: req.arc.curvature,
        step: req.arc.length / pieces as f64,
        length: req.arc.length,
        pieces: pieces as u32,
        cover: (base + req.from as u32 + 1, base + req.to as u32),
        window: (
            base + req.from.saturating_sub(1) as u32,
            base + (req.to + 1).min(enc.points.len() - 1) as u32,
        ),
        tol2: enc.tol2,
        radius: radius.max((req.arc.start - o).abs().max_element()),
        origin_scale,
    }
}

/// A curve's arcs and the points they decode to (what
/// [`CurveEncoder::arcs`] finds).
pub type FoundArcs = Option<(CurveCode, Vec<DVec3>)>;

type Search<'a> = Pin<Box<dyn Future<Output = FoundArcs> + 'a>>;

/// The arcs of every curve of a block (`None` where a curve has fewer than
/// three points or no element passes), all curves searched together with
/// their checks in batches on `checker`. The same result as
/// [`CurveEncoder::arcs`] run on each curve alone.
pub fn search_block(
    encoders: &[Option<CurveEncoder<'_>>],
    checker: &dyn ArcChecker,
) -> (Vec<FoundArcs>, BatchStats) {
    let mut stats = BatchStats::default();
    let n = encoders.len();
    // Flat points relative to each curve's origin.
    let mut offsets = Vec::with_capacity(n + 1);
    let mut flat = Vec::new();
    let mut geometry = Vec::with_capacity(n); // (origin, radius, origin scale)
    for enc in encoders {
        offsets.push(flat.len());
        match enc {
            Some(e) if e.points.len() >= 3 => {
                let o = e.points[0];
                let mut radius: f64 = 0.0;
                for p in e.points {
                    let d = *p - o;
                    radius = radius.max(d.abs().max_element());
                    flat.push(d);
                }
                geometry.push((o, radius, o.abs().max_element()));
            }
            _ => geometry.push((DVec3::ZERO, 0.0, 0.0)),
        }
    }
    offsets.push(flat.len());
    let mailboxes: Vec<Mailbox> = (0..n).map(|_| Mailbox::default()).collect();
    let asking: Vec<Option<CurveEncoder<'_>>> = encoders
        .iter()
        .zip(&mailboxes)
        .map(|(e, m)| {
            e.as_ref()
                .filter(|e| e.points.len() >= 3)
                .map(|e| CurveEncoder {
                    points: e.points,
                    q: e.q,
                    tol2: e.tol2,
                    grid: e.grid,
                    mailbox: Some(m),
                    give_up: e.give_up.clone(),
                    look_ahead: e.look_ahead,
                    bulge_prediction: e.bulge_prediction,
                    corner_first: e.corner_first,
                })
        })
        .collect();
    let mut results: Vec<FoundArcs> = (0..n).map(|_| None).collect();
    let mut searches: Vec<Option<Search<'_>>> = asking
        .iter()
        .map(|e| e.as_ref().map(|e| Box::pin(e.arcs()) as Search<'_>))
        .collect();
    let mut block = match checker.open(&flat) {
        Ok(b) => Some(b),
        Err(_) => {
            stats.fell_back = true;
            None
        }
    };
    let mut cx = Context::from_waker(Waker::noop());
    let mut live: Vec<usize> = (0..n).filter(|&c| searches[c].is_some()).collect();
    let mut candidates = Vec::new();
    let mut who = Vec::new();
    while !live.is_empty() {
        // Run every live search to its next question (or its end).
        live.retain(|&c| {
            let s = searches[c].as_mut().expect("live");
            match s.as_mut().poll(&mut cx) {
                Poll::Ready(r) => {
                    results[c] = r;
                    searches[c] = None;
                    false
                }
                Poll::Pending => true,
            }
        });
        candidates.clear();
        who.clear();
        for &c in &live {
            let Some(req) = mailboxes[c].request.take() else {
                unreachable!("a waiting search has asked");
            };
            let enc = asking[c].as_ref().expect("live");
            candidates.push(candidate(enc, &req, offsets[c], geometry[c]));
            who.push(c);
        }
        if candidates.is_empty() {
            break;
        }
        stats.rounds += 1;
        stats.checked += candidates.len() as u64;
        let verdicts = match block.as_mut().map(|b| b.verdicts(&candidates)) {
            Some(Ok(v)) if v.len() == candidates.len() => v,
            Some(_) => {
                // The checker failed: the reference decides from here on.
                stats.fell_back = true;
                block = None;
                vec![Verdict::Unsure; candidates.len()]
            }
            None => vec![Verdict::Unsure; candidates.len()],
        };
        for (&c, v) in who.iter().zip(verdicts) {
            if v == Verdict::Unsure {
                stats.unsure += 1;
            }
            mailboxes[c].verdict.set(Some(v));
        }
    }
    // The searches borrow the mailboxes and encoders: end them first.
    drop(searches);
    (results, stats)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::codec::quantise::{Quantiser, Steps};
    use crate::kernels::arc_check::verdicts_twin;
    use crate::twin::Real;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A wiggly curve far from the origin (where absolute rounding is
    /// largest), sampled every `step`.
    fn wiggle(rng: &mut ChaCha8Rng, n: usize, far: f64) -> Vec<DVec3> {
        let (a, b, c) = (
            rng.gen_range(0.1..2.0),
            rng.gen_range(0.1..2.0),
            rng.gen_range(0.0..1.0),
        );
        let step = rng.gen_range(0.2..2.0);
        let o = DVec3::new(far, -0.5 * far, 0.25 * far);
        (0..n)
            .map(|k| {
                let s = k as f64 * step;
                o + DVec3::new(
                    s,
                    a * (0.3 * s).sin() + 0.05 * rng.gen_range(-1.0..1.0),
                    b * (0.2 * s + c).cos(),
                )
            })
            .collect()
    }

    /// The reference's two-sided squared distance of a candidate (the
    /// largest of its points' exact distances, both ways).
    fn two_sided2(enc: &CurveEncoder, arc: &Arc, from: usize, to: usize) -> f64 {
        use crate::codec::check::dist2_to_segment;
        let mut poly = vec![arc.start];
        arc.sample_into(enc.q.sagitta, &mut poly);
        let n = enc.points.len();
        let window = &enc.points[from.saturating_sub(1)..=(to + 1).min(n - 1)];
        let near = |p: DVec3, line: &[DVec3]| {
            line.windows(2)
                .map(|w| dist2_to_segment(p, w[0], w[1]))
                .fold(f64::INFINITY, f64::min)
        };
        let a = enc.points[from + 1..=to].iter().map(|&p| near(p, &poly));
        let b = poly[1..].iter().map(|&p| near(p, window));
        a.chain(b).fold(0.0, f64::max)
    }

    /// Sure verdicts of the twin (`R`) against the reference on random
    /// candidates, half of them within a hair of the tolerance: returns
    /// (sure, unsure, reference passes, the largest relative distance from
    /// the tolerance of an unsure verdict).
    fn sure_verdicts_agree<R: Real>(seed: u64) -> (usize, usize, usize, f64) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let (mut sure, mut unsure, mut passes) = (0, 0, 0);
        let mut widest = 0f64;
        for _ in 0..300 {
            let far = [0.0, 100.0, 1e4][rng.gen_range(0..3)];
            let n = rng.gen_range(3..40);
            let pts = wiggle(&mut rng, n, far);
            let tol: f64 = rng.gen_range(0.01..1.0);
            let base_enc = CurveEncoder {
                points: &pts,
                q: Quantiser::new(tol, Steps::default()),
                tol2: tol * tol,
                grid: tol,
                mailbox: None,
                give_up: None,
                look_ahead: false,
                bulge_prediction: false,
                corner_first: false,
            };
            let o = pts[0];
            let radius = pts
                .iter()
                .map(|p| (*p - o).abs().max_element())
                .fold(0.0, f64::max);
            let flat: Vec<R> = pts
                .iter()
                .flat_map(|p| {
                    let d = *p - o;
                    [d.x, d.y, d.z]
                })
                .map(R::from_f64)
                .collect();
            for _ in 0..20 {
                let from = rng.gen_range(0..pts.len() - 1);
                let to = rng.gen_range(from + 1..pts.len());
                // A tangent near the chord's, an end near the vertex: some
                // pass, some fail, some within rounding of the tolerance.
                let jitter = |rng: &mut ChaCha8Rng, s: f64| {
                    DVec3::new(
                        rng.gen_range(-s..s),
                        rng.gen_range(-s..s),
                        rng.gen_range(-s..s),
                    )
                };
                let chord = pts[to] - pts[from];
                let t = (chord.normalize() + jitter(&mut rng, 0.3)).normalize();
                let end = pts[to] + jitter(&mut rng, tol);
                let Ok(arc) = Arc::new(pts[from], t, end) else {
                    continue;
                };
                let req = CheckRequest { arc, from, to };
                // Half the time, the tolerance within a hair (1e-16 to 1e-4
                // relative) of the candidate's own two-sided distance: the
                // band is what decides there.
                let mut enc = CurveEncoder {
                    mailbox: None,
                    give_up: None,
                    ..base_enc
                };
                let d2 = two_sided2(&enc, &arc, from, to);
                if rng.gen_bool(0.5) {
                    let rel = 10f64.powf(rng.gen_range(-16.0..-4.0)) * rng.gen_range(-1.0..1.0);
                    enc.tol2 = d2 * (1.0 + rel);
                }
                let reference = enc.accept_now(&arc, from, to);
                passes += reference as usize;
                let c = candidate(&enc, &req, 0, (o, radius, o.abs().max_element()));
                match verdicts_twin::<R>(&flat, &[c])[0] {
                    Verdict::Pass => {
                        assert!(
                            reference,
                            "twin {} passes what the reference fails: {c:?}",
                            R::WGSL
                        );
                        sure += 1;
                    }
                    Verdict::Fail => {
                        assert!(
                            !reference,
                            "twin {} fails what the reference passes: {c:?}",
                            R::WGSL
                        );
                        sure += 1;
                    }
                    Verdict::Unsure => {
                        unsure += 1;
                        widest = widest.max((d2 / enc.tol2 - 1.0).abs());
                    }
                }
            }
        }
        (sure, unsure, passes, widest)
    }

    #[test]
    fn arc_check_band_covers_the_reference() {
        // Both outcomes occur; many are left unsure (the tolerance is put
        // within 1e-16 of the distance), but only within a hair of it.
        let (sure, unsure, passes, widest) = sure_verdicts_agree::<f64>(7);
        assert!(
            passes > 300 && passes + 300 < sure + unsure,
            "{passes} of {}",
            sure + unsure
        );
        assert!(
            unsure > 100 && widest < 1e-8,
            "f64: {unsure} unsure, up to {widest:e}"
        );
        let (sure, unsure, _, widest) = sure_verdicts_agree::<f32>(8);
        // f32 is unsure of the near half (1e-4 is inside its band) and of
        // few others.
        assert!(
            unsure < 3060 && widest < 0.05,
            "f32: {unsure} unsure of {}, up to {widest:e}",
            sure + unsure
        );
    }

    /// A checker that answers every question unsure: the reference then
    /// decides everything, through the batch machinery.
    struct AllUnsure;
    struct AllUnsureBlock;
    impl ArcChecker for AllUnsure {
        fn open(&self, _: &[DVec3]) -> Result<Box<dyn ArcCheckBlock + '_>, String> {
            Ok(Box::new(AllUnsureBlock))
        }
    }
    impl ArcCheckBlock for AllUnsureBlock {
        fn verdicts(&mut self, c: &[ArcCandidate]) -> Result<Vec<Verdict>, String> {
            Ok(vec![Verdict::Unsure; c.len()])
        }
    }
    /// A checker that cannot take the block.
    struct Broken;
    impl ArcChecker for Broken {
        fn open(&self, _: &[DVec3]) -> Result<Box<dyn ArcCheckBlock + '_>, String> {
            Err("no device".into())
        }
    }

    #[test]
    fn f32_checks_of_huge_and_tiny_curves_defer_to_the_reference() {
        use crate::codec::{encode_block, encode_block_on, CodecParams};
        use crate::kernels::arc_check::TwinArcChecker;
        // Squared lengths beyond f32 (overflow to infinity), and a
        // tolerance whose square is below f32's normal range.
        let huge = vec![
            DVec3::ZERO,
            DVec3::new(4e19, 0.0, 0.0),
            DVec3::new(8e19, 5e14, 0.0),
            DVec3::new(1.2e20, 2e15, 1e14),
        ];
        let tiny: Vec<DVec3> = (0..12)
            .map(|k| DVec3::new(k as f64, (k as f64 * 0.7).sin(), 0.0) * 1e-22)
            .collect();
        for (curve, tol) in [(huge, 1e15), (tiny, 3e-23)] {
            let params = CodecParams::new(tol);
            let cpu = encode_block(std::slice::from_ref(&curve), &params).unwrap();
            let checker = TwinArcChecker::<f32>::default();
            let b = encode_block_on(&[curve], &params, false, Some(&checker)).unwrap();
            assert_eq!(b.bytes, cpu.bytes, "tolerance {tol}");
            assert!(
                b.checks.checked > 0 && b.checks.unsure == b.checks.checked,
                "{:?}",
                b.checks
            );
        }
    }

    #[test]
    fn batched_searches_write_the_bytes_of_the_cpu_path() {
        use crate::codec::{encode_block, encode_block_on, CodecParams};
        use crate::kernels::arc_check::TwinArcChecker;
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut curves: Vec<Vec<DVec3>> = (0..60)
            .map(|k| wiggle(&mut rng, 2 + k % 50, [0.0, 50.0][k % 2]))
            .collect();
        curves.push(Vec::new());
        curves.push(vec![DVec3::ONE]);
        for tol in [0.05, 0.3] {
            let params = CodecParams::new(tol);
            let cpu = encode_block(&curves, &params).unwrap();
            let checkers: [(&str, &dyn ArcChecker); 4] = [
                ("twin f64", &TwinArcChecker::<f64>::default()),
                ("twin f32", &TwinArcChecker::<f32>::default()),
                ("all unsure", &AllUnsure),
                ("broken", &Broken),
            ];
            for (name, checker) in checkers {
                let b = encode_block_on(&curves, &params, false, Some(checker)).unwrap();
                assert_eq!(b.bytes, cpu.bytes, "{name} at {tol}");
                assert_eq!(b.output_points, cpu.output_points, "{name}");
                assert!(
                    b.checks.checked > 100 || name == "broken",
                    "{name}: {:?}",
                    b.checks
                );
                assert_eq!(b.checks.fell_back, name == "broken", "{name}");
            }
        }
    }

    #[test]
    fn batched_searches_agree_across_chunks_and_give_ups() {
        // More curves than one chunk of searches, smooth and noisy mixed:
        // noisy fibres' searches give up (by the calibration the curves
        // before them taught), and the batched path must decide as the
        // CPU's.
        use crate::codec::{encode_block, encode_block_on, CodecParams};
        use crate::kernels::arc_check::TwinArcChecker;
        let tol = 0.05;
        let mut rng = ChaCha8Rng::seed_from_u64(12);
        let curves: Vec<Vec<DVec3>> = (0..300)
            .map(|k| {
                if k % 3 == 0 {
                    return wiggle(&mut rng, 40, 0.0);
                }
                // A bending fibre sampled every 0.75, jittered by up to 2 T.
                let phase = rng.gen_range(0.0..6.0);
                (0..60)
                    .map(|i| {
                        let s = 0.75 * i as f64;
                        DVec3::new(s, 5.0 * (s / 12.0 + phase).sin(), 3.0 * (s / 9.0).cos())
                            + DVec3::new(
                                rng.gen_range(-2.0 * tol..2.0 * tol),
                                rng.gen_range(-2.0 * tol..2.0 * tol),
                                rng.gen_range(-2.0 * tol..2.0 * tol),
                            )
                    })
                    .collect()
            })
            .collect();
        let params = CodecParams::new(tol);
        let twin = TwinArcChecker::<f64>::default();
        // Not exploring (the first of a small block's two codings), both
        // kinds come out, and the searches give up where points win.
        let once = |checker: Option<&dyn ArcChecker>| {
            crate::codec::encode_block_once(&curves, &params, false, false, checker, false)
                .unwrap()
                .0
        };
        let (cpu, gpu) = (once(None), once(Some(&twin)));
        assert!(
            cpu.kinds.contains(&1) && cpu.kinds.contains(&2),
            "points and arcs both"
        );
        assert_eq!((gpu.bytes, gpu.kinds), (cpu.bytes, cpu.kinds));
        // And the block as coded (the smaller of both codings).
        let cpu = encode_block(&curves, &params).unwrap();
        let b = encode_block_on(&curves, &params, false, Some(&twin)).unwrap();
        assert_eq!(b.bytes, cpu.bytes);
        assert_eq!(b.kinds, cpu.kinds);
    }
}
