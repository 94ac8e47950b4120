//! G1 piecewise helices, and their compact parameter form.

use glam::DVec3;

use super::element::{Frame, HelixElement};
use super::ghosh::orthonormalize;

/// A chain of helix elements, each starting where (and with the tangent
/// with which) the previous one ends, up to the fitting's rounding.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PiecewiseHelix {
    elements: Vec<HelixElement>,
    /// `cum[i]` = arc length at the start of element `i`; `cum[n]` = total.
    cum: Vec<f64>,
}

/// Per-element parameters of the compact form: three shape numbers plus the
/// rotation of the element's frame (equivalently of its axis) about its start
/// tangent.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ElementParams {
    /// Arc length `L`.
    pub length: f64,
    /// Curvature `κ ≥ 0`.
    pub curvature: f64,
    /// Torsion `τ`.
    pub torsion: f64,
    /// Signed angle (radians, about the start tangent) from the reference
    /// normal carried over from the previous element's end to this element's
    /// start normal. 0 for straight elements (which carry the reference on).
    pub twist: f64,
}

/// The compact form of a piecewise helix: a start point and frame, then
/// `(L, κ, τ, twist)` per element. Evaluation from this alone reproduces
/// the chain (see [`PiecewiseHelix::from_params`]).
#[derive(Clone, Debug, PartialEq)]
pub struct ChainParams {
    /// Start point.
    pub start: DVec3,
    /// Unit start tangent.
    pub tangent: DVec3,
    /// Reference normal at the start (the first curved element's normal).
    pub normal: DVec3,
    /// Per element, in order.
    pub elements: Vec<ElementParams>,
}

impl PiecewiseHelix {
    /// Build from elements (their start points are taken as given).
    ///
    /// ```
    /// use std::f64::consts::{FRAC_PI_2, PI};
    /// use strandfit::{DVec3, HelixElement, ParamCurve3, PiecewiseHelix};
    ///
    /// // Two quarters of the unit circle: a half circle from (1, 0, 0).
    /// let quarter = |start: DVec3, tangent: DVec3| HelixElement {
    ///     start, tangent, normal: -start, curvature: 1.0, torsion: 0.0, length: FRAC_PI_2,
    /// };
    /// let chain = PiecewiseHelix::new(vec![quarter(DVec3::X, DVec3::Y), quarter(DVec3::Y, -DVec3::X)]);
    /// assert_eq!(chain.len(), 2);
    /// assert!((chain.arc_length() - PI).abs() < 1e-15);
    /// assert!(chain.eval(1.0).distance(-DVec3::X) < 1e-12);
    /// assert!(PiecewiseHelix::new(vec![]).is_empty());
    /// ```
    pub fn new(elements: Vec<HelixElement>) -> Self {
        let mut cum = Vec::with_capacity(elements.len() + 1);
        let mut acc = 0.0;
        cum.push(0.0);
        for e in &elements {
            acc += e.length;
            cum.push(acc);
        }
        PiecewiseHelix { elements, cum }
    }

    /// The elements, in order.
    pub fn elements(&self) -> &[HelixElement] {
        &self.elements
    }

    /// Number of elements.
    pub fn len(&self) -> usize {
        self.elements.len()
    }

    /// No elements.
    pub fn is_empty(&self) -> bool {
        self.elements.is_empty()
    }

    /// Total arc length.
    ///
    /// The sum of the element lengths:
    /// ```
    /// use strandfit::{DVec3, HelixElement, PiecewiseHelix};
    ///
    /// let a = HelixElement::straight(DVec3::ZERO, DVec3::X, 1.0);
    /// let b = HelixElement::straight(DVec3::X, DVec3::X, 2.5);
    /// assert_eq!(PiecewiseHelix::new(vec![a, b]).length(), 3.5);
    /// ```
    pub fn length(&self) -> f64 {
        *self.cum.last().unwrap_or(&0.0)
    }

    /// The paper's complexity `∫√(κ² + τ²) ds` (Eq. 12): exactly `Σ ωᵢLᵢ`.
    ///
    /// A straight unit segment (`ω = 0`) then a quarter of the unit circle (`ω = 1`):
    /// ```
    /// use strandfit::{DVec3, HelixElement, PiecewiseHelix};
    /// use std::f64::consts::FRAC_PI_2;
    ///
    /// let a = HelixElement::straight(DVec3::ZERO, DVec3::X, 1.0);
    /// let b = HelixElement { start: DVec3::X, tangent: DVec3::X, normal: DVec3::Y,
    ///     curvature: 1.0, torsion: 0.0, length: FRAC_PI_2 };
    /// assert!((PiecewiseHelix::new(vec![a, b]).complexity() - FRAC_PI_2).abs() < 1e-15);
    /// ```
    pub fn complexity(&self) -> f64 {
        self.elements.iter().map(|e| e.phi()).sum()
    }

    /// Element index and local arc length for a global arc length `s`
    /// (clamped to `[0, length]`).
    ///
    /// ```
    /// use strandfit::{DVec3, HelixElement, PiecewiseHelix};
    ///
    /// let a = HelixElement::straight(DVec3::ZERO, DVec3::X, 1.0);
    /// let b = HelixElement::straight(DVec3::X, DVec3::X, 2.0);
    /// let chain = PiecewiseHelix::new(vec![a, b]);
    /// assert_eq!(chain.locate(1.5), Some((1, 0.5)));
    /// assert_eq!(chain.locate(9.0), Some((1, 2.0))); // clamped to the end
    /// assert_eq!(PiecewiseHelix::default().locate(0.0), None);
    /// ```
    pub fn locate(&self, s: f64) -> Option<(usize, f64)> {
        if self.elements.is_empty() {
            return None;
        }
        let s = s.clamp(0.0, self.length());
        // Last i with cum[i] <= s, limited to a valid element.
        let i = self.cum.partition_point(|&c| c <= s).saturating_sub(1);
        let i = i.min(self.elements.len() - 1);
        Some((i, s - self.cum[i]))
    }

    /// Point at global arc length `s` (clamped).
    ///
    /// A unit segment along `x`, then a quarter of the unit circle to `(2, 1, 0)`:
    /// ```
    /// use strandfit::{DVec3, HelixElement, PiecewiseHelix};
    /// use std::f64::consts::FRAC_PI_2;
    ///
    /// let a = HelixElement::straight(DVec3::ZERO, DVec3::X, 1.0);
    /// let b = HelixElement { start: DVec3::X, tangent: DVec3::X, normal: DVec3::Y,
    ///     curvature: 1.0, torsion: 0.0, length: FRAC_PI_2 };
    /// let chain = PiecewiseHelix::new(vec![a, b]);
    /// assert!((chain.point(0.5).unwrap() - DVec3::new(0.5, 0.0, 0.0)).length() < 1e-15);
    /// assert!((chain.point(1.0 + FRAC_PI_2).unwrap() - DVec3::new(2.0, 1.0, 0.0)).length() < 1e-15);
    /// ```
    pub fn point(&self, s: f64) -> Option<DVec3> {
        self.locate(s).map(|(i, u)| self.elements[i].point(u))
    }

    /// Frenet frame at global arc length `s` (clamped).
    ///
    /// Halfway round the quarter circle the normal points at its centre `(1, 1, 0)`:
    /// ```
    /// use strandfit::{DVec3, HelixElement, PiecewiseHelix};
    /// use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};
    ///
    /// let a = HelixElement::straight(DVec3::ZERO, DVec3::X, 1.0);
    /// let b = HelixElement { start: DVec3::X, tangent: DVec3::X, normal: DVec3::Y,
    ///     curvature: 1.0, torsion: 0.0, length: FRAC_PI_2 };
    /// let chain = PiecewiseHelix::new(vec![a, b]);
    /// let (p, f) = (chain.point(1.0 + FRAC_PI_4).unwrap(), chain.frame(1.0 + FRAC_PI_4).unwrap());
    /// assert!((f.normal - (DVec3::new(1.0, 1.0, 0.0) - p)).length() < 1e-15);
    /// ```
    pub fn frame(&self, s: f64) -> Option<Frame> {
        self.locate(s).map(|(i, u)| self.elements[i].frame(u))
    }

    /// Unit tangent at global arc length `s` (clamped).
    ///
    /// ```
    /// use strandfit::{DVec3, HelixElement, PiecewiseHelix};
    /// use std::f64::consts::FRAC_PI_2;
    ///
    /// let a = HelixElement::straight(DVec3::ZERO, DVec3::X, 1.0);
    /// let b = HelixElement { start: DVec3::X, tangent: DVec3::X, normal: DVec3::Y,
    ///     curvature: 1.0, torsion: 0.0, length: FRAC_PI_2 };
    /// let chain = PiecewiseHelix::new(vec![a, b]);
    /// assert!((chain.tangent(1.0 + FRAC_PI_2).unwrap() - DVec3::Y).length() < 1e-15);
    /// ```
    pub fn tangent(&self, s: f64) -> Option<DVec3> {
        self.frame(s).map(|f| f.tangent)
    }

    /// `m ≥ 2` points equally spaced in arc length, first and last included.
    ///
    /// ```
    /// use strandfit::{DVec3, HelixElement, PiecewiseHelix};
    ///
    /// let a = HelixElement::straight(DVec3::ZERO, DVec3::X, 1.0);
    /// let b = HelixElement::straight(DVec3::X, DVec3::X, 2.0);
    /// let chain = PiecewiseHelix::new(vec![a, b]);
    /// assert_eq!(chain.sample(4), vec![DVec3::ZERO, DVec3::X, 2.0 * DVec3::X, 3.0 * DVec3::X]);
    /// ```
    pub fn sample(&self, m: usize) -> Vec<DVec3> {
        let mut out = Vec::with_capacity(m);
        self.sample_into(m, &mut out);
        out
    }

    /// [`sample`](Self::sample) into a reusable buffer.
    ///
    /// ```
    /// use strandfit::{DVec3, HelixElement, PiecewiseHelix};
    ///
    /// let chain = PiecewiseHelix::new(vec![HelixElement::straight(DVec3::ZERO, DVec3::Y, 2.0)]);
    /// let mut buf = vec![DVec3::NAN; 7]; // cleared first
    /// chain.sample_into(3, &mut buf);
    /// assert_eq!(buf, vec![DVec3::ZERO, DVec3::Y, 2.0 * DVec3::Y]);
    /// ```
    pub fn sample_into(&self, m: usize, out: &mut Vec<DVec3>) {
        out.clear();
        if self.elements.is_empty() || m == 0 {
            return;
        }
        if m == 1 {
            out.push(self.elements[0].start);
            return;
        }
        let total = self.length();
        let mut i = 0;
        for k in 0..m {
            let s = total * k as f64 / (m - 1) as f64;
            while i + 1 < self.elements.len() && self.cum[i + 1] <= s {
                i += 1;
            }
            out.push(self.elements[i].point(s - self.cum[i]));
        }
    }

    /// The points of [`sample`](Self::sample) with their unit tangents
    /// (same arc lengths, same element choice).
    ///
    /// Three samples of a quarter of the unit circle:
    /// ```
    /// use strandfit::{DVec3, HelixElement, PiecewiseHelix};
    /// use std::f64::consts::FRAC_PI_2;
    ///
    /// let arc = HelixElement { start: DVec3::X, tangent: DVec3::Y, normal: -DVec3::X,
    ///     curvature: 1.0, torsion: 0.0, length: FRAC_PI_2 };
    /// let (p, t) = PiecewiseHelix::new(vec![arc]).sample_with_tangents(3);
    /// let mid = DVec3::new(1.0, 1.0, 0.0).normalize();
    /// assert!((p[1] - mid).length() < 1e-15);
    /// assert!((t[1] - DVec3::new(-1.0, 1.0, 0.0).normalize()).length() < 1e-15);
    /// ```
    pub fn sample_with_tangents(&self, m: usize) -> (Vec<DVec3>, Vec<DVec3>) {
        if self.elements.is_empty() || m == 0 {
            return (Vec::new(), Vec::new());
        }
        if m == 1 {
            let e = &self.elements[0];
            return (vec![e.start], vec![e.tangent]);
        }
        let total = self.length();
        let mut i = 0;
        (0..m)
            .map(|k| {
                let s = total * k as f64 / (m - 1) as f64;
                while i + 1 < self.elements.len() && self.cum[i + 1] <= s {
                    i += 1;
                }
                let (e, u) = (&self.elements[i], s - self.cum[i]);
                (e.point(u), e.tangent_at(u))
            })
            .unzip()
    }

    /// Points equally spaced in arc length at most `step` apart, both ends
    /// included: `⌈L/step⌉ + 1` of them (`L/(⌈L/step⌉)` apart, so the last
    /// gap is never a short remainder).
    ///
    /// ```
    /// use strandfit::{DVec3, HelixElement, PiecewiseHelix};
    ///
    /// let chain = PiecewiseHelix::new(vec![HelixElement::straight(DVec3::ZERO, DVec3::X, 2.5)]);
    /// let p = chain.sample_step(1.0);
    /// assert_eq!(p.len(), 4); // ⌈2.5⌉ + 1, spaced 2.5/3
    /// assert!((p[1] - DVec3::X * (2.5 / 3.0)).length() < 1e-15);
    /// assert!((p[3] - DVec3::X * 2.5).length() < 1e-15);
    /// ```
    pub fn sample_step(&self, step: f64) -> Vec<DVec3> {
        if !(step > 0.0) || self.elements.is_empty() {
            return Vec::new();
        }
        let m = (self.length() / step).ceil() as usize + 1;
        self.sample(m.max(2))
    }

    /// The largest gap between an element's end and the next one's start
    /// (position), and the largest tangent mismatch (radians).
    ///
    /// Two elements joined with a gap of `0.1` and a right-angle kink:
    /// ```
    /// use strandfit::{DVec3, HelixElement, PiecewiseHelix};
    ///
    /// let a = HelixElement::straight(DVec3::ZERO, DVec3::X, 1.0);
    /// let b = HelixElement::straight(DVec3::new(1.1, 0.0, 0.0), DVec3::Y, 1.0);
    /// let (gap, angle) = PiecewiseHelix::new(vec![a, b]).continuity_defects();
    /// assert!((gap - 0.1).abs() < 1e-15);
    /// assert!((angle - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
    /// ```
    pub fn continuity_defects(&self) -> (f64, f64) {
        let mut gap: f64 = 0.0;
        let mut angle: f64 = 0.0;
        for w in self.elements.windows(2) {
            let end = w[0].end_frame();
            gap = gap.max((w[0].end_point() - w[1].start).length());
            let c = end.tangent.cross(w[1].tangent).length();
            angle = angle.max(c.atan2(end.tangent.dot(w[1].tangent)));
        }
        (gap, angle)
    }

    /// The compact form (start frame + `(L, κ, τ, twist)` per element).
    ///
    /// The compact form rebuilds the same curve ([`from_params`](Self::from_params)):
    /// ```
    /// use strandfit::{DVec3, HelixElement, PiecewiseHelix};
    ///
    /// let a = HelixElement::straight(DVec3::ZERO, DVec3::X, 1.0);
    /// let b = HelixElement { start: DVec3::X, tangent: DVec3::X, normal: DVec3::new(0.0, 0.6, 0.8),
    ///     curvature: 0.7, torsion: -0.3, length: 2.0 };
    /// let chain = PiecewiseHelix::new(vec![a, b]);
    /// let params = chain.to_params().unwrap();
    /// assert_eq!((params.elements[1].curvature, params.elements[1].torsion), (0.7, -0.3));
    /// let back = PiecewiseHelix::from_params(&params);
    /// assert!((back.point(3.0).unwrap() - chain.point(3.0).unwrap()).length() < 1e-14);
    /// ```
    pub fn to_params(&self) -> Option<ChainParams> {
        let first = self.elements.first()?;
        // Reference normal: the first curved element's normal (twist 0 there),
        // carried back over any leading straight run.
        let mut reference = self
            .elements
            .iter()
            .find(|e| e.curvature > 0.0)
            .map(|e| e.normal)
            .unwrap_or(first.normal);
        reference = orthonormalize_or_any(reference, first.tangent);
        let start_normal = reference;
        let mut elements = Vec::with_capacity(self.elements.len());
        for e in &self.elements {
            let t = e.tangent;
            let r = orthonormalize_or_any(reference, t);
            if e.curvature > 0.0 {
                let twist = r.cross(e.normal).dot(t).atan2(r.dot(e.normal));
                elements.push(ElementParams {
                    length: e.length,
                    curvature: e.curvature,
                    torsion: e.torsion,
                    twist,
                });
                reference = e.end_frame().normal;
            } else {
                elements.push(ElementParams {
                    length: e.length,
                    curvature: 0.0,
                    torsion: 0.0,
                    twist: 0.0,
                });
                reference = r;
            }
        }
        Some(ChainParams {
            start: first.start,
            tangent: first.tangent,
            normal: start_normal,
            elements,
        })
    }

    /// Rebuild a chain from its compact form alone. Each element starts
    /// exactly at the previous one's end, with its end tangent (G1 by
    /// construction).
    ///
    /// A twist of `π/2` about `x` turns a quarter circle from the `xy` plane into `xz`:
    /// ```
    /// use strandfit::helix::{ChainParams, ElementParams, PiecewiseHelix};
    /// use strandfit::DVec3;
    /// use std::f64::consts::FRAC_PI_2;
    ///
    /// let arc = ElementParams { length: FRAC_PI_2, curvature: 1.0, torsion: 0.0, twist: FRAC_PI_2 };
    /// let params = ChainParams { start: DVec3::ZERO, tangent: DVec3::X, normal: DVec3::Y,
    ///     elements: vec![arc] };
    /// let end = PiecewiseHelix::from_params(&params).point(FRAC_PI_2).unwrap();
    /// assert!((end - DVec3::new(1.0, 0.0, 1.0)).length() < 1e-15);
    /// ```
    pub fn from_params(params: &ChainParams) -> Self {
        let mut p = params.start;
        let mut t = params.tangent.normalize();
        let mut r = orthonormalize_or_any(params.normal, t);
        let mut elements = Vec::with_capacity(params.elements.len());
        for ep in &params.elements {
            let (s, c) = ep.twist.sin_cos();
            // Rotate r about t by the twist (r ⊥ t).
            let n = c * r + s * t.cross(r);
            let e = HelixElement {
                start: p,
                tangent: t,
                normal: n,
                curvature: ep.curvature,
                torsion: ep.torsion,
                length: ep.length,
            };
            let end = e.end_frame();
            p = e.end_point();
            t = end.tangent.normalize();
            r = if ep.curvature > 0.0 {
                orthonormalize_or_any(end.normal, t)
            } else {
                orthonormalize_or_any(n, t)
            };
            elements.push(e);
        }
        PiecewiseHelix::new(elements)
    }
}

fn orthonormalize_or_any(v: DVec3, t: DVec3) -> DVec3 {
    let w = v - v.dot(t) * t;
    if w.length_squared() > 1e-24 {
        orthonormalize(v, t)
    } else {
        t.any_orthonormal_vector()
    }
}
