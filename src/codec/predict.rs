//! The codec's primitive and predictor: a G1 chain of circular arcs, each
//! fixed by its end point.
//!
//! A circular arc that leaves `q` along the unit tangent `t` and ends at `e`
//! is unique (the `τ = 0` member of the short helices of
//! [`crate::helix`]): with the chord `d = e − q`, `c = |d|`, `u = d/c` and
//! `α = ∠(t, u)`, it lies in the plane of `t` and `u`, turns by `2α`, has
//! curvature `κ = 2 sin α / c` and length `L = c·α / sin α`, and its end
//! tangent is `t` reflected in the chord, `t' = 2(t·u)u − t`. So a chain of
//! arcs is coded by its end points alone, and an end point is cheap when it
//! is close to where the previous arc, continued with the same curvature in
//! the same plane, would have gone: that continuation is the prediction.
//!
//! A *corner* element does not inherit the tangent: it carries a bulge, the
//! arc's sagitta vector `h ⊥ u`, from which `tan(α/2) = 2|h|/c` and the start
//! tangent `t = cos α·u + sin α·ĥ`. The first element of a curve is a
//! corner; a bulge of zero is a straight segment.
//!
//! Everything here is plain `f64` arithmetic (`+ − × ÷ √`, `sin`, `cos`,
//! `atan2`) done in the same order by the encoder and the decoder, so the
//! encoder checks exactly the points that the decoder writes.

use glam::DVec3;

/// Chain state at the end of an element, from which the next is predicted.
#[derive(Clone, Copy, Debug)]
pub struct ChainState {
    /// The current point (end of the previous element).
    pub point: DVec3,
    /// Unit tangent at `point`.
    pub tangent: DVec3,
    /// Unit normal `⊥ tangent`: towards the centre of the previous arc, or
    /// carried over (projected) when it was straight. The prediction bends
    /// towards it and the residual frame is built on it.
    pub normal: DVec3,
    /// Curvature of the previous arc (0 for a straight one or at the start).
    pub curvature: f64,
    /// Chord length of the previous element, in length steps (the length
    /// residual is coded against it).
    pub chord_steps: i64,
    /// `normal` turned about `tangent` by the turn of the arc planes seen
    /// at the last junction ([`set_twist`](Self::set_twist)): the bend the
    /// prediction takes, so that a helix's arcs are predicted with its
    /// torsion. Equal to `normal` until a twist is set.
    pub bend: DVec3,
}

/// A unit vector perpendicular to the unit vector `v`, chosen
/// deterministically (Duff et al. 2017, "Building an orthonormal basis,
/// revisited").
pub fn any_perpendicular(v: DVec3) -> DVec3 {
    let sign = 1f64.copysign(v.z);
    let a = -1.0 / (sign + v.z);
    let b = v.x * v.y * a;
    DVec3::new(1.0 + sign * v.x * v.x * a, sign * b, -sign * v.x)
}

/// Unit component of `n` perpendicular to the unit vector `t`, or a
/// deterministic perpendicular when `n` is (nearly) parallel to `t`.
pub fn perpendicular_part(n: DVec3, t: DVec3) -> DVec3 {
    let p = n - t * n.dot(t);
    let l = p.length();
    if l > 1e-9 {
        p / l
    } else {
        any_perpendicular(t)
    }
}

impl ChainState {
    /// Chord length the prediction assumes: the previous chord's (at least
    /// one length step).
    pub fn frame_chord(&self, length_step: f64) -> f64 {
        self.chord_steps.max(1) as f64 * length_step
    }

    /// Predicted chord direction for a chord of length `c` (G1: continue
    /// the previous arc, same curvature, same plane) and the residual frame
    /// `(u, e1, e2)`: `e1` towards the predicted bend, `e2 = u × e1`.
    pub fn predicted_frame(&self, c: f64) -> (DVec3, DVec3, DVec3) {
        // The chord of an arc of curvature κ makes the angle α with the
        // start tangent, sin α = cκ/2 (arcs beyond a half turn are not
        // predicted: α ≤ π/2).
        let s = (0.5 * c * self.curvature).min(1.0);
        let co = (1.0 - s * s).sqrt();
        let normal = self.bend;
        let u = self.tangent * co + normal * s;
        let e1 = normal * co - self.tangent * s;
        let e2 = u.cross(e1);
        (u, e1, e2)
    }
}

impl ChainState {
    /// Sets the predicted bend to `normal` turned by `twist` (radians)
    /// about `tangent` (once per element, not per candidate).
    pub fn set_twist(&mut self, twist: f64) {
        self.bend = if twist == 0.0 {
            self.normal
        } else {
            let (s, c) = twist.sin_cos();
            self.normal * c + self.tangent.cross(self.normal) * s
        };
    }
}

/// One circular arc from `start` along `tangent` to `end`.
#[derive(Clone, Copy, Debug)]
pub struct Arc {
    pub start: DVec3,
    pub tangent: DVec3,
    pub end: DVec3,
    /// Unit in-plane normal at the start, towards the centre (any
    /// perpendicular for a straight arc).
    pub normal: DVec3,
    /// `α`, the angle between the start tangent and the chord, in [0, π).
    pub half_turn: f64,
    pub curvature: f64,
    pub length: f64,
}

/// Why an element cannot be built (the encoder skips such candidates; the
/// decoder reports a corrupt stream).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ArcError {
    /// The end coincides with the start.
    ZeroChord,
    /// The chord points (nearly) backwards: the arc would be almost a full
    /// circle.
    Backwards,
    /// Not finite.
    NonFinite,
}

/// Largest turning `2α` the encoder uses (and the decoder accepts): 0.95
/// of a full turn.
pub const MAX_HALF_TURN: f64 = 0.95 * std::f64::consts::PI;

/// The circle of an arc from `start` along the unit `tangent` to `end`,
/// before the arc's angle is found ([`Circle::arc`]): what a test of
/// distances from it needs, without the arc tangent that the angle costs.
#[derive(Clone, Copy, Debug)]
pub struct Circle {
    pub start: DVec3,
    pub tangent: DVec3,
    pub end: DVec3,
    /// The chord's length.
    pub chord: f64,
    /// `cos α` and `sin α`, α the angle between the tangent and the chord.
    pub cos_a: f64,
    pub sin_a: f64,
    /// Unit in-plane normal at the start, towards the centre (any
    /// perpendicular for a straight arc).
    pub normal: DVec3,
    pub curvature: f64,
}

impl Circle {
    /// The circle from `start` along the unit `tangent` through `end`.
    pub fn new(start: DVec3, tangent: DVec3, end: DVec3) -> Result<Circle, ArcError> {
        let d = end - start;
        let c = d.length();
        if !c.is_finite() || !tangent.is_finite() {
            return Err(ArcError::NonFinite);
        }
        if c == 0.0 {
            return Err(ArcError::ZeroChord);
        }
        let u = d / c;
        let along = tangent.dot(u);
        let perp = u - tangent * along;
        let sin_a = perp.length();
        let normal = if sin_a > 1e-300 {
            perp / sin_a
        } else {
            any_perpendicular(tangent)
        };
        Ok(Circle {
            start,
            tangent,
            end,
            chord: c,
            cos_a: along,
            sin_a,
            normal,
            curvature: 2.0 * sin_a / c,
        })
    }

    /// The arc along this circle from its start to its end.
    pub fn arc(&self) -> Result<Arc, ArcError> {
        // α from atan2 of the perpendicular and parallel parts: accurate
        // for small and large angles alike.
        let half_turn = self.sin_a.atan2(self.cos_a);
        if half_turn > MAX_HALF_TURN {
            return Err(ArcError::Backwards);
        }
        let length = if half_turn < 1e-8 {
            self.chord
        } else {
            self.chord * half_turn / self.sin_a
        };
        Ok(Arc {
            start: self.start,
            tangent: self.tangent,
            end: self.end,
            normal: self.normal,
            half_turn,
            curvature: self.curvature,
            length,
        })
    }
}

impl Arc {
    /// The arc from `start` along the unit `tangent` to `end`.
    pub fn new(start: DVec3, tangent: DVec3, end: DVec3) -> Result<Arc, ArcError> {
        Circle::new(start, tangent, end)?.arc()
    }

    /// Tangent at the end: the start tangent reflected in the chord.
    pub fn end_tangent(&self) -> DVec3 {
        let (s, c) = (2.0 * self.half_turn).sin_cos();
        (self.tangent * c + self.normal * s).normalize()
    }

    /// Normal at the end (towards the centre), in the arc's plane.
    pub fn end_normal(&self) -> DVec3 {
        let (s, c) = (2.0 * self.half_turn).sin_cos();
        (self.normal * c - self.tangent * s).normalize()
    }

    /// Point at arc length `s`: `start + t·sin(κs)/κ + n·(1 − cos κs)/κ`,
    /// written with `2 sin²(κs/2)` so that it is accurate as `κ → 0`.
    pub fn point_at(&self, s: f64) -> DVec3 {
        let phi = self.curvature * s;
        let (along, across) = if phi.abs() < 1e-6 {
            // Taylor: sin φ/κ = s(1 − φ²/6), (1 − cos φ)/κ = s φ/2 (1 − φ²/12).
            (
                s * (1.0 - phi * phi / 6.0),
                0.5 * s * phi * (1.0 - phi * phi / 12.0),
            )
        } else {
            let h = (0.5 * phi).sin();
            (phi.sin() / self.curvature, 2.0 * h * h / self.curvature)
        };
        self.start + self.tangent * along + self.normal * across
    }

    /// Number of equal pieces the decoder cuts the arc into so that each
    /// chord is within `sagitta` of the arc: a chord of length `ℓ` on a
    /// circle of curvature `κ` is at most `κℓ²/8` from it (sagitta bound).
    pub fn pieces(&self, sagitta: f64) -> usize {
        let need = self.length * (self.curvature / (8.0 * sagitta)).sqrt();
        if need.is_finite() && need > 1.0 {
            need.ceil().min(1e7) as usize
        } else {
            1
        }
    }

    /// Appends the decoder's points of this arc, without its start point
    /// (the previous element's end), ending exactly at `end`.
    ///
    /// The `k`-th point is `start + t·sin(kδ)/κ + n·(1 − cos kδ)/κ` with
    /// `δ = κL/n`; `sin kδ` and `1 − cos kδ` come from the angle-addition
    /// recurrence (one `sin_cos` per arc, not two `sin` per point), the
    /// latter carried as itself so that it keeps its relative accuracy on
    /// gentle arcs: `u' = 2 sin²(δ/2) + u cos δ + s sin δ`.
    pub fn sample_into(&self, sagitta: f64, out: &mut Vec<DVec3>) {
        let n = self.pieces(sagitta);
        out.reserve(n);
        let step = self.length / n as f64;
        let delta = self.curvature * step;
        if delta.abs() < 1e-6 {
            for k in 1..n {
                out.push(self.point_at(step * k as f64));
            }
        } else {
            let (sd, cd) = delta.sin_cos();
            let h = (0.5 * delta).sin();
            let one_minus_cd = 2.0 * h * h;
            let (mut s, mut u) = (0.0f64, 0.0f64);
            let inv = 1.0 / self.curvature;
            for _ in 1..n {
                let s_next = s * cd + (1.0 - u) * sd;
                u = one_minus_cd + u * cd + s * sd;
                s = s_next;
                out.push(self.start + self.tangent * (s * inv) + self.normal * (u * inv));
            }
        }
        out.push(self.end);
    }

    /// The chain state after this arc; its chord is kept in length steps
    /// (`length_step`) as the next prediction's chord.
    pub fn next_state(&self, length_step: f64) -> ChainState {
        let chord_steps = ((self.end - self.start).length() / length_step).round();
        let chord_steps = if chord_steps.is_finite() && chord_steps < 1e12 {
            chord_steps as i64
        } else {
            0
        };
        let normal = if self.curvature > 0.0 {
            self.end_normal()
        } else {
            self.normal
        };
        ChainState {
            point: self.end,
            tangent: self.end_tangent(),
            normal,
            curvature: self.curvature,
            chord_steps,
            bend: normal,
        }
    }
}

/// Start tangent of a corner element from its chord direction `u`, chord
/// length `c` and bulge (sagitta vector) `h ⊥ u`: `tan(α/2) = 2|h|/c`.
pub fn corner_tangent(u: DVec3, c: f64, h: DVec3) -> DVec3 {
    let hl = h.length();
    if hl == 0.0 || c == 0.0 {
        return u;
    }
    let a = 2.0 * (2.0 * hl / c).atan();
    let (s, co) = a.sin_cos();
    (u * co + h / hl * s).normalize()
}

/// The rotation that best takes each `from[i]` to `to[i]` in least squares
/// (`min Σ |R·from[i] − to[i]|²`), as Horn's unit quaternion: the
/// eigenvector of the largest eigenvalue `λ` of the symmetric, traceless
/// 4 × 4 matrix `N` built from `M = Σ from[i] to[i]ᵀ` (Horn 1987, J. Opt.
/// Soc. Am. A 4, 629, eq. 4.4 ff.). As in the QCP method (Theobald 2005,
/// Acta Cryst. A 61, 478), `λ` is the largest root of `N`'s characteristic
/// polynomial `λ⁴ − ½tr(N²)λ² − ⅓tr(N³)λ + det N`, found by Newton's
/// method from `E₀ = ½Σ(|from[i]|² + |to[i]|²) ≥ λ`, and the eigenvector is
/// the longest column of the adjugate of `N − λI`. Only `+ − × ÷ √` and a
/// fixed iteration count, so the decoder reproduces the encoder's rotation
/// bit for bit (Jacobi sweeps to the same rotation made the hair's
/// decoding 3.5 times slower; this, 1.6 times).
/// `None` where the rotation is not fixed: collinear or zero pairs (the
/// eigenvector's cofactors vanish).
pub fn best_rotation(from: &[DVec3], to: &[DVec3]) -> Option<glam::DMat3> {
    let mut m = [[0.0f64; 3]; 3];
    let mut e0 = 0.0;
    for (a, b) in from.iter().zip(to) {
        e0 += 0.5 * (a.length_squared() + b.length_squared());
        let (a, b) = (a.to_array(), b.to_array());
        for r in 0..3 {
            for c in 0..3 {
                m[r][c] += a[r] * b[c];
            }
        }
    }
    if !(e0 > 0.0 && e0.is_finite()) {
        return None;
    }
    let [[sxx, sxy, sxz], [syx, syy, syz], [szx, szy, szz]] = m;
    let n = [
        [sxx + syy + szz, syz - szy, szx - sxz, sxy - syx],
        [syz - szy, sxx - syy - szz, sxy + syx, szx + sxz],
        [szx - sxz, sxy + syx, -sxx + syy - szz, syz + szy],
        [sxy - syx, szx + sxz, syz + szy, -sxx - syy + szz],
    ];
    // ½tr(N²) = 2Σ Sᵢⱼ² and ⅓tr(N³) = 8 det M (Theobald 2005, eq. 6–7).
    let c2 = -2.0 * m.iter().flatten().map(|x| x * x).sum::<f64>();
    let det_m = sxx * (syy * szz - syz * szy) - sxy * (syx * szz - syz * szx)
        + sxz * (syx * szy - syy * szx);
    let (c1, c0) = (-8.0 * det_m, det4(&n));
    let mut lambda = e0;
    for _ in 0..30 {
        let l2 = lambda * lambda;
        let p = (l2 + c2) * l2 + c1 * lambda + c0;
        let dp = (4.0 * l2 + 2.0 * c2) * lambda + c1;
        if !(dp != 0.0) {
            break;
        }
        let next = lambda - p / dp;
        if !(next.is_finite()) || (next - lambda).abs() <= 1e-13 * lambda.abs() {
            lambda = if next.is_finite() { next } else { lambda };
            break;
        }
        lambda = next;
    }
    // Columns of the adjugate of A = N − λI are eigenvectors (where λ is
    // simple): the longest is the best conditioned.
    let mut a = n;
    for (k, row) in a.iter_mut().enumerate() {
        row[k] -= lambda;
    }
    // Cofactors are cubic in the entries: relative to E₀³ they vanish when
    // the top eigenvalue is not simple. The longest column of the
    // adjugate (symmetric: its rows) is the best conditioned.
    let e3 = e0 * e0 * e0;
    let (adj, _) = adjugate4(&a);
    let mut best = ([0.0f64; 4], 0.0f64);
    for q in adj {
        let len2: f64 = q.iter().map(|x| x * x).sum();
        if len2 > best.1 {
            best = (q, len2);
        }
    }
    let (q, q2) = best;
    if !(q2.sqrt() > 1e-12 * e3) {
        return None;
    }
    let (w, x, y, z) = (q[0], q[1], q[2], q[3]);
    let s = 2.0 / q2;
    Some(glam::DMat3::from_cols(
        DVec3::new(
            1.0 - s * (y * y + z * z),
            s * (x * y + w * z),
            s * (x * z - w * y),
        ),
        DVec3::new(
            s * (x * y - w * z),
            1.0 - s * (x * x + z * z),
            s * (y * z + w * x),
        ),
        DVec3::new(
            s * (x * z + w * y),
            s * (y * z - w * x),
            1.0 - s * (x * x + y * y),
        ),
    ))
}

/// The 2 × 2 minors of the rows `x`, `y` in columns (0 1), (0 2), (0 3),
/// (1 2), (1 3), (2 3).
#[inline(always)]
fn minors2(x: [f64; 4], y: [f64; 4]) -> [f64; 6] {
    [
        x[0] * y[1] - y[0] * x[1],
        x[0] * y[2] - y[0] * x[2],
        x[0] * y[3] - y[0] * x[3],
        x[1] * y[2] - y[1] * x[2],
        x[1] * y[3] - y[1] * x[3],
        x[2] * y[3] - y[2] * x[3],
    ]
}

/// The 2 × 2 minors of a 4 × 4 matrix's top row pair (`s`) and bottom row
/// pair (`c`), and its determinant from them (Laplace expansion by
/// complementary minors).
#[inline]
fn minors4(a: &[[f64; 4]; 4]) -> ([f64; 6], [f64; 6], f64) {
    let (s, c) = (minors2(a[0], a[1]), minors2(a[2], a[3]));
    let det = s[0] * c[5] - s[1] * c[4] + s[2] * c[3] + s[3] * c[2] - s[4] * c[1] + s[5] * c[0];
    (s, c, det)
}

/// The determinant of a 4 × 4 matrix, as [`adjugate4`] gives it (the same
/// operations, so the same bits) without the adjugate: the characteristic
/// polynomial needs only this, and the adjugate's sixteen cofactors were a
/// tenth of decoding the hair.
fn det4(a: &[[f64; 4]; 4]) -> f64 {
    minors4(a).2
}

/// The adjugate of a 4 × 4 matrix and its determinant, from the 2 × 2
/// minors of its top and bottom row pairs (Laplace expansion by
/// complementary minors).
fn adjugate4(a: &[[f64; 4]; 4]) -> ([[f64; 4]; 4], f64) {
    let [[a00, a01, a02, a03], [a10, a11, a12, a13], [a20, a21, a22, a23], [a30, a31, a32, a33]] =
        *a;
    let ([s0, s1, s2, s3, s4, s5], [c0, c1, c2, c3, c4, c5], det) = minors4(a);
    let adj = [
        [
            a11 * c5 - a12 * c4 + a13 * c3,
            -a01 * c5 + a02 * c4 - a03 * c3,
            a31 * s5 - a32 * s4 + a33 * s3,
            -a21 * s5 + a22 * s4 - a23 * s3,
        ],
        [
            -a10 * c5 + a12 * c2 - a13 * c1,
            a00 * c5 - a02 * c2 + a03 * c1,
            -a30 * s5 + a32 * s2 - a33 * s1,
            a20 * s5 - a22 * s2 + a23 * s1,
        ],
        [
            a10 * c4 - a11 * c2 + a13 * c0,
            -a00 * c4 + a01 * c2 - a03 * c0,
            a30 * s4 - a31 * s2 + a33 * s0,
            -a20 * s4 + a21 * s2 - a23 * s0,
        ],
        [
            -a10 * c3 + a11 * c1 - a12 * c0,
            a00 * c3 - a01 * c1 + a02 * c0,
            -a30 * s3 + a31 * s1 - a32 * s0,
            a20 * s3 - a21 * s1 + a22 * s0,
        ],
    ];
    (adj, det)
}

/// A neighbour's stretch walked from its anchor (`end` and `middle`,
/// relative to the anchor), the anchor's place `at` relative to the start
/// being predicted (start lattice units) and the sample's weight.
#[derive(Clone, Copy, Debug, Default)]
pub struct Walked {
    pub end: DVec3,
    pub middle: DVec3,
    pub at: [f64; 3],
    pub weight: f64,
}

/// Ridge of [`fit_at_origin`], a fraction of the samples' mean squared
/// distance (measured 0.03, 0.1, 0.3 and 1 on field lines and hair:
/// within 0.2 % of each other from 0.03 to 0.3; 1 gives back half the
/// gain over the weighted mean).
const RIDGE: f64 = 0.1;

/// The weighted least-squares linear fit of the walked stretches in their
/// anchors' places, taken at the start (the origin): per coordinate `v`
/// of `end` and `middle`, `v(x) ≈ c + g·x` minimising
/// `Σ wᵢ (vᵢ − c − g·xᵢ)² + λ|g|²`, with `λ = RIDGE · Σ wᵢ|xᵢ|² / 3` (the
/// anchors lie on a surface, or on a line, so the gradient across it is
/// not determined). With `x̄`, `v̄` the weighted means and
/// `S = Σ wᵢ (xᵢ − x̄)(xᵢ − x̄)ᵀ`, the fit at the origin is
/// `c = v̄ − yᵀ Σ wᵢ (xᵢ − x̄)(vᵢ − v̄)` with `(S + λI) y = x̄` (one 3×3
/// solve for all six coordinates). Without a gradient (`λ → ∞`) it is the
/// weighted mean. `None` without samples or where the solve is not finite.
pub fn fit_at_origin(samples: &[Walked]) -> Option<(DVec3, DVec3)> {
    let w: f64 = samples.iter().map(|s| s.weight).sum();
    if !(w > 0.0) {
        return None;
    }
    let at = |s: &Walked| DVec3::from_array(s.at);
    // The weighted means of the places, ends and middles (each summed in
    // sample order, as one fold each would).
    let (mut x_bar, mut end_bar, mut middle_bar) = (DVec3::ZERO, DVec3::ZERO, DVec3::ZERO);
    for s in samples {
        x_bar += at(s) * s.weight;
        end_bar += s.end * s.weight;
        middle_bar += s.middle * s.weight;
    }
    let (x_bar, end_bar, middle_bar) = (x_bar / w, end_bar / w, middle_bar / w);
    // The centred moments: S (symmetric) and the cross terms of each
    // coordinate of `end` and `middle` with x.
    let mut m = [0.0f64; 6];
    let (mut ce, mut cm) = ([DVec3::ZERO; 3], [DVec3::ZERO; 3]);
    let mut spread = 0.0;
    for s in samples {
        let x = at(s) - x_bar;
        let (e, mid) = (s.end - end_bar, s.middle - middle_bar);
        let wx = x * s.weight;
        m[0] += wx.x * x.x;
        m[1] += wx.x * x.y;
        m[2] += wx.x * x.z;
        m[3] += wx.y * x.y;
        m[4] += wx.y * x.z;
        m[5] += wx.z * x.z;
        for i in 0..3 {
            ce[i] += e * wx[i];
            cm[i] += mid * wx[i];
        }
        spread += s.weight * at(s).length_squared();
    }
    let lambda = RIDGE * spread / 3.0 + 1e-9;
    let [a, b, c, d, e, f] = m;
    let (a, d, f) = (a + lambda, d + lambda, f + lambda);
    // (S + λI)⁻¹ x̄ by the adjugate: S + λI is symmetric positive definite.
    let adj = [
        d * f - e * e,
        c * e - b * f,
        b * e - c * d,
        a * f - c * c,
        b * c - a * e,
        a * d - b * b,
    ];
    let det = a * adj[0] + b * adj[1] + c * adj[2];
    let y = DVec3::new(
        adj[0] * x_bar.x + adj[1] * x_bar.y + adj[2] * x_bar.z,
        adj[1] * x_bar.x + adj[3] * x_bar.y + adj[4] * x_bar.z,
        adj[2] * x_bar.x + adj[4] * x_bar.y + adj[5] * x_bar.z,
    ) / det;
    let end = end_bar - (ce[0] * y.x + ce[1] * y.y + ce[2] * y.z);
    let middle = middle_bar - (cm[0] * y.x + cm[1] * y.y + cm[2] * y.z);
    (end.is_finite() && middle.is_finite()).then_some((end, middle))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arc_through_circle_points_has_the_circle_curvature_and_tangents() {
        // Unit circle in the xy plane, from angle 0 to 1.3 rad.
        let r = 2.5;
        let p = |a: f64| DVec3::new(r * a.cos(), r * a.sin(), 1.0);
        let t0 = DVec3::new(0.0, 1.0, 0.0);
        let arc = Arc::new(p(0.0), t0, p(1.3)).unwrap();
        assert!((arc.curvature - 1.0 / r).abs() < 1e-14);
        assert!((arc.length - 1.3 * r).abs() < 1e-13);
        let te = DVec3::new(-(1.3f64).sin(), (1.3f64).cos(), 0.0);
        assert!((arc.end_tangent() - te).length() < 1e-14);
        for k in 0..=10 {
            let s = arc.length * k as f64 / 10.0;
            assert!((arc.point_at(s) - p(s / r)).length() < 1e-13);
        }
        // End normal points to the centre.
        let centre = DVec3::new(0.0, 0.0, 1.0);
        assert!((arc.end_normal() - (centre - p(1.3)) / r).length() < 1e-14);
    }

    #[test]
    fn straight_and_tiny_arcs_are_accurate() {
        let arc = Arc::new(DVec3::ZERO, DVec3::X, DVec3::new(3.0, 0.0, 0.0)).unwrap();
        assert_eq!(arc.curvature, 0.0);
        assert_eq!(arc.point_at(1.5), DVec3::new(1.5, 0.0, 0.0));
        let eps = 1e-9;
        let arc = Arc::new(DVec3::ZERO, DVec3::X, DVec3::new(1.0, eps, 0.0)).unwrap();
        assert!((arc.curvature - 2.0 * eps).abs() < 1e-20);
        assert!((arc.point_at(arc.length) - arc.end).length() < 1e-15);
    }

    #[test]
    fn sampled_chords_stay_within_the_sagitta() {
        let arc = Arc::new(DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.3)).unwrap();
        let mut pts = vec![arc.start];
        let sag = 1e-3;
        arc.sample_into(sag, &mut pts);
        assert_eq!(*pts.last().unwrap(), arc.end);
        let centre = arc.start + arc.normal / arc.curvature;
        for w in pts.windows(2) {
            let mid = 0.5 * (w[0] + w[1]);
            let dev = 1.0 / arc.curvature - (mid - centre).length();
            assert!(dev <= sag * (1.0 + 1e-9), "sagitta {dev}");
        }
    }

    #[test]
    fn prediction_continues_the_previous_arc() {
        let r = 4.0;
        let p = |a: f64| DVec3::new(r * a.cos(), r * a.sin(), 0.0);
        let arc = Arc::new(p(0.0), DVec3::Y, p(0.4)).unwrap();
        let st = arc.next_state(1.0);
        let c = (p(0.9) - p(0.4)).length();
        let (u, e1, e2) = st.predicted_frame(c);
        assert!((st.point + u * c - p(0.9)).length() < 1e-12);
        assert!(u.dot(e1).abs() < 1e-15 && u.dot(e2).abs() < 1e-15);
        assert!((e1.length() - 1.0).abs() < 1e-15);
    }

    #[test]
    fn corner_bulge_gives_the_arc_with_that_sagitta() {
        let u = DVec3::X;
        let h = DVec3::new(0.0, 0.2, 0.0);
        let t = corner_tangent(u, 2.0, h);
        let arc = Arc::new(DVec3::ZERO, t, DVec3::new(2.0, 0.0, 0.0)).unwrap();
        let mid = arc.point_at(0.5 * arc.length);
        assert!((mid - DVec3::new(1.0, 0.2, 0.0)).length() < 1e-12);
    }

    /// `det4` is `adjugate4`'s determinant bit for bit (the decoder's
    /// screw prediction depends on it), and the adjugate is the inverse
    /// times the determinant.
    #[test]
    fn det4_is_the_adjugates_determinant_bit_for_bit() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        for _ in 0..2000 {
            let a: [[f64; 4]; 4] =
                std::array::from_fn(|_| std::array::from_fn(|_| rng.gen_range(-10.0..10.0)));
            let (adj, det) = adjugate4(&a);
            assert_eq!(det4(&a).to_bits(), det.to_bits());
            // A · adj(A) = det(A) · I.
            for r in 0..4 {
                for c in 0..4 {
                    let v: f64 = (0..4).map(|k| a[r][k] * adj[k][c]).sum();
                    let want = if r == c { det } else { 0.0 };
                    // (Entries up to 10, cofactors up to 6·10³: rounding
                    // of order 10⁻¹¹.)
                    assert!((v - want).abs() <= 1e-8, "{v} {want}");
                }
            }
        }
    }

    #[test]
    fn best_rotation_recovers_a_rotation_from_noisy_pairs() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        for _ in 0..200 {
            let axis = DVec3::new(
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
            )
            .normalize();
            let r = glam::DMat3::from_axis_angle(axis, rng.gen_range(-3.0..3.0));
            let from: Vec<DVec3> = (0..3)
                .map(|_| {
                    DVec3::new(
                        rng.gen_range(-1.0..1.0),
                        rng.gen_range(-1.0..1.0),
                        rng.gen_range(-1.0..1.0),
                    )
                })
                .collect();
            let to: Vec<DVec3> = from.iter().map(|&a| r * a).collect();
            let got = best_rotation(&from, &to).unwrap();
            for (a, b) in from.iter().zip(&to) {
                assert!((got * *a - *b).length() < 1e-9, "{got:?} vs {r:?}");
            }
            assert!((got.determinant() - 1.0).abs() < 1e-12);
            // Planar pairs (the steps of a circle) fix the rotation too.
            let planar: Vec<DVec3> = (0..3)
                .map(|k| DVec3::new((k as f64).cos(), (k as f64).sin(), 0.0))
                .collect();
            let turned: Vec<DVec3> = planar.iter().map(|&a| r * a).collect();
            let got = best_rotation(&planar, &turned).unwrap();
            assert!((got * DVec3::Z - r * DVec3::Z).length() < 1e-9);
        }
        // Collinear pairs do not.
        let line = [DVec3::X, DVec3::X * 2.0];
        assert!(best_rotation(&line, &line).is_none());
    }
}

/// The along-step prediction of a points residual (codec model 10).
///
/// A curve sampled at equal steps (tractography tracked at a fixed step or
/// resampled to a fixed count, hair strands of equal segments) turns but
/// keeps its step length, so a prediction misses across the step, not
/// along it. With the predicted step `s = pred − g[k−1]` (lattice units)
/// and the last step's squared length `ℓ² = |g[k−1] − g[k−2]|²`, the axis
/// `m` on which `s` is longest is coded after the other two, against the
/// value that makes the step `t = s + d` as long as the last:
/// `t_m = sign(s_m)·√(ℓ² − Σ_{a≠m} t_a²)`. Where the root has no real
/// value, or the values are beyond any lattice's, the prediction is 0 (the
/// coding of model 9). [`AlongStep::at`] takes `ℓ²` as the mean over the
/// last [`AlongStep::STEPS`] steps.
///
/// ```
/// use strandfit::codec::AlongStep;
/// // Last step (10, 0, 0); the prediction repeats it; the curve turns by
/// // 6 lattice units in y: the step stays 10 long if x falls back by 2.
/// let a = AlongStep::new([10, 0, 0], [10, 0, 0]);
/// assert_eq!(a.axis(), 0);
/// // Residual (?, 6, 0) of parity 0: t = (8, 6, 0), so d_x = −2, half −1.
/// assert_eq!(a.half_prediction([0, 6, 0], 0), -1);
/// ```
#[derive(Clone, Copy, Debug)]
pub struct AlongStep {
    step: [f64; 3],
    axis: usize,
    last2: f64,
}

impl AlongStep {
    /// Beyond this (lattice units) the prediction is 0.
    const LIMIT: f64 = (1u64 << 30) as f64;

    /// From the predicted step `pred − g[k−1]` and the last step
    /// `g[k−1] − g[k−2]`.
    pub fn new(step: [i64; 3], last: [i64; 3]) -> Self {
        let l = last.map(|v| v as f64);
        AlongStep {
            step: step.map(|v| v as f64),
            axis: Self::axis_of(step),
            last2: l[0] * l[0] + l[1] * l[1] + l[2] * l[2],
        }
    }

    /// The prediction of point `k ≥ 2` of `g` against `pred`, the step
    /// length from `window`, the sum of the squared lengths of the last
    /// [`AlongStep::STEPS`] steps (fewer near the start: `predict::step_window`).
    pub fn at(g: &[[i64; 3]], k: usize, pred: [i64; 3], window: u64) -> Self {
        let step = [0, 1, 2].map(|a| pred[a].wrapping_sub(g[k - 1][a]));
        let n = (k - 1).min(Self::STEPS);
        AlongStep {
            step: step.map(|v| v as f64),
            axis: Self::axis_of(step),
            last2: window as f64 / n as f64,
        }
    }

    /// Steps whose mean squared length is the predicted one's. The lattice
    /// puts an error of up to a unit on each end of a step, so one step's
    /// length is noisy; a curve of equal steps keeps them along its length.
    /// Measured over the shared data at both tolerances and 10,000 fornix
    /// replicas at 0.1 mm with 1, 2, 3, 4, 5, 6, 7, 10 and 15: every longer
    /// mean smaller in all (the hair at 0.1 mm 142,106 → 135,542 B, CC at
    /// 0.1 mm 1,805 → 1,778 B, the replicas 339,289 → 337,594 B).
    pub const STEPS: usize = 15;

    /// The axis on which `step` is longest (the first of equal ones), in
    /// integers: all that a curve without the along flag needs.
    pub fn axis_of(step: [i64; 3]) -> usize {
        let s = step.map(i64::unsigned_abs);
        if s[1] > s[0] {
            if s[2] > s[1] {
                2
            } else {
                1
            }
        } else if s[2] > s[0] {
            2
        } else {
            0
        }
    }

    /// The axis coded last, against the prediction.
    pub fn axis(&self) -> usize {
        self.axis
    }

    /// The predicted halved residual `(d_m − b)/2` on [`AlongStep::axis`],
    /// given the residual's other two coordinates (`d[axis]` is not read)
    /// and its parity `b`.
    #[inline(always)]
    pub fn half_prediction(&self, d: [i64; 3], b: i64) -> i64 {
        let m = self.axis;
        let sm = self.step[m];
        if !(sm != 0.0 && sm.abs() < Self::LIMIT && self.last2 < Self::LIMIT * Self::LIMIT) {
            return 0;
        }
        let mut r = self.last2;
        for a in 0..3 {
            if a != m {
                let t = self.step[a] + d[a] as f64;
                r -= t * t;
            }
        }
        if !(r > 0.0) {
            return 0;
        }
        // |·| < 2^31 (r < LIMIT²): rounded by `round_small` (equal to
        // `round` there, without the libm call or a branch).
        let h = super::quantise::round_small((r.sqrt().copysign(sm) - sm - b as f64) / 2.0);
        if h.abs() < Self::LIMIT {
            h as i64
        } else {
            0
        }
    }

    /// The residual `d` as coded: its along coordinate less twice the
    /// prediction (the same parity), the others as they are.
    #[inline(always)]
    pub fn coded(&self, d: [i64; 3]) -> [i64; 3] {
        let b = d[0] & 1;
        let mut c = d;
        c[self.axis] = d[self.axis].wrapping_sub(2 * self.half_prediction(d, b));
        c
    }
}

/// `|g[i] − g[i−1]|²`, exact.
pub fn step_length2(g: &[[i64; 3]], i: usize) -> u64 {
    (0..3)
        .map(|a| {
            let l = g[i][a].wrapping_sub(g[i - 1][a]).unsigned_abs();
            l.saturating_mul(l)
        })
        .fold(0u64, u64::saturating_add)
}

/// The sum of the squared lengths of steps `max(1, k − STEPS)..k` of `g`
/// (those before point `k`), from `before`, the same sum for point `k − 1`
/// (0 for `k ≤ 1`): one step in, one out, in integers (saturating, which
/// only steps beyond `2^31` lattice units reach: the encoder's slide and
/// the decoder update it in the same order, so they agree even then).
#[inline]
pub fn step_window(g: &[[i64; 3]], k: usize, before: u64) -> u64 {
    if k < 2 {
        return 0;
    }
    let mut w = before.saturating_add(step_length2(g, k - 1));
    if k - 1 > AlongStep::STEPS {
        w = w.saturating_sub(step_length2(g, k - 1 - AlongStep::STEPS));
    }
    w
}
