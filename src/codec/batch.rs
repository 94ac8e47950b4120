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
//! runs on to its next question. A sure verdict is the reference's
//! ([`crate::twin::arc_check`]); an unsure one is decided by the reference
//! on the asking thread, so the chosen elements, and so the container, are
//! the same bytes whichever backend checks.

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
    pub start: DVec3,
    pub tangent: DVec3,
    pub normal: DVec3,
    pub end: DVec3,
    pub curvature: f64,
    /// Arc length of one piece (`length / pieces`).
    pub step: f64,
    pub length: f64,
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

/// A backend that checks many candidates at once.
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

/// What [`search_block`] tells about the checks it ran.
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

type Search<'a> = Pin<Box<dyn Future<Output = Option<(CurveCode, Vec<DVec3>)>> + 'a>>;

/// The arcs of every curve of a block (`None` where a curve has fewer than
/// three points or no element passes), all curves searched together with
/// their checks in batches on `checker`. The same result as
/// [`CurveEncoder::arcs`] run on each curve alone.
pub fn search_block(
    encoders: &[Option<CurveEncoder<'_>>],
    checker: &dyn ArcChecker,
) -> (Vec<Option<(CurveCode, Vec<DVec3>)>>, BatchStats) {
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
            e.as_ref().filter(|e| e.points.len() >= 3).map(|e| CurveEncoder {
                points: e.points,
                q: e.q,
                tol2: e.tol2,
                grid: e.grid,
                mailbox: Some(m),
            })
        })
        .collect();
    let mut results: Vec<Option<(CurveCode, Vec<DVec3>)>> = (0..n).map(|_| None).collect();
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
            let (o, radius, origin_scale) = geometry[c];
            let n_pts = enc.points.len();
            let base = offsets[c] as u32;
            let pieces = req.arc.pieces(enc.q.sagitta);
            candidates.push(ArcCandidate {
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
                    base + (req.to + 1).min(n_pts - 1) as u32,
                ),
                tol2: enc.tol2,
                radius: radius.max((req.arc.start - o).abs().max_element()),
                origin_scale,
            });
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
