// Twin: src/twin/ghosh_bisect.rs (read its docs for the formulation and for
// why the host hands over scalars). One Ghosh short helix per segment:
// bisection on G = A N + B D = 0 over the full I0, unknown z = sqrt(w), w the
// offset of phi from the nearer end of I0.
// Prepended: the precision prelude (real, REAL_EPS, PIO2_*, BISECT_MAX) and
// math.wgsl (sincos, atan2_pos).
// The parameter block `params` and the buffers are declared in
// src/kernels/ghosh_bisect.rs and generated ahead of this body.

const IN_STRIDE: u32 = 6u;
const OUT_STRIDE: u32 = 12u;
const PARALLEL_EPS: real = 1e-12;
const ST_OK: u32 = 0u;
const ST_NON_FINITE: u32 = 1u;
const ST_COINCIDENT: u32 = 3u;
const ST_NOT_COHELICAL: u32 = 4u;
const ST_STRAIGHT: u32 = 6u;
const ST_HALF_CIRCLE: u32 = 7u;
const PI: real = 3.14159265358979323846;

// Finite test from arithmetic (x - x is NaN for inf/NaN). Best effort: the
// host already rejects non-finite data before upload.
fn finite(x: real) -> bool {
    return (x - x) == real(0.0);
}

fn half_angle_defect(phi: real, sin_x: real, cos_x: real) -> real {
    let x: real = real(0.5) * phi;
    if (x < real(0.5)) {
        let x2: real = x * x;
        var p: real = real(16.0 / 355687428096000.0);
        p = p * x2 - real(14.0 / 1307674368000.0);
        p = p * x2 + real(12.0 / 6227020800.0);
        p = p * x2 - real(10.0 / 39916800.0);
        p = p * x2 + real(8.0 / 362880.0);
        p = p * x2 - real(6.0 / 5040.0);
        p = p * x2 + real(4.0 / 120.0);
        p = p * x2 - real(2.0 / 6.0);
        return real(2.0) * x * x2 * p;
    }
    return phi * cos_x - real(2.0) * sin_x;
}

struct Segment {
    a: real,
    b: real,
    theta: real,
    sin_half: real,
    cos_half: real,
    sin_beta: real,
    cos_beta: real,
}

struct AtW {
    phi: real,
    q: real,
    sin_half_phi: real,
    cos_half_phi: real,
    g: real,
}

// Everything at phi = theta + w (side = 1) or phi = 2 pi - theta - w (side = -1).
fn at_w(s: Segment, side: real, w: real) -> AtW {
    let sc = sincos(real(0.5) * w);
    let sh = sc.x;
    let ch = sc.y;
    let sin_bmh: real = s.sin_beta * ch - s.cos_beta * sh;
    let q: real = real(2.0) * sin_bmh * sh;
    let sw: real = real(2.0) * sh * ch;
    let cw: real = real(1.0) - real(2.0) * sh * sh;
    let sin_phi: real = side * (s.sin_beta * cw - s.cos_beta * sw);
    var phi: real = s.theta + w;
    if (side < real(0.0)) {
        phi = real(6.28318530717958647693) - s.theta - w;
    }
    let sin_half_phi: real = s.sin_half * ch + s.cos_half * sh;
    let cos_half_phi: real = side * (s.cos_half * ch - s.sin_half * sh);
    let one_minus_c: real = real(2.0) * s.sin_half * s.sin_half;
    // N (A.14) and D (A.15)
    let n: real = one_minus_c * sin_phi + phi * q;
    let d: real = half_angle_defect(phi, sin_half_phi, cos_half_phi) * sqrt(max(q, real(0.0)));
    return AtW(phi, q, sin_half_phi, cos_half_phi, s.a * n + s.b * d);
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x + gid.y * params.row;
    if (i >= params.count) {
        return;
    }
    let b = i * IN_STRIDE;
    let o = i * OUT_STRIDE;
    for (var k = 0u; k < OUT_STRIDE; k++) {
        seg_out[o + k] = real(0.0);
    }
    var all_finite = true;
    for (var k = 0u; k < IN_STRIDE; k++) {
        all_finite = all_finite && finite(seg_in[b + k]);
    }
    if (!all_finite) {
        seg_out[o] = real(ST_NON_FINITE);
        return;
    }
    let dist: real = seg_in[b];
    let nd: real = seg_in[b + 1u];
    let ns: real = seg_in[b + 2u];
    let de1: real = seg_in[b + 3u];
    let de2: real = seg_in[b + 4u];
    let de3: real = seg_in[b + 5u];
    if (!(dist > real(0.0))) {
        seg_out[o] = real(ST_COINCIDENT);
        return;
    }
    if (nd <= PARALLEL_EPS) {
        seg_out[o] = real(ST_STRAIGHT);
        seg_out[o + 6u] = dist;
        return;
    }
    let residual: real = abs(de3) / dist;
    seg_out[o + 10u] = residual;
    if (residual > real(params.tol)) {
        seg_out[o] = real(ST_NOT_COHELICAL);
        return;
    }
    if (ns <= PARALLEL_EPS) {
        let omega: real = real(2.0) / dist;
        seg_out[o] = real(ST_HALF_CIRCLE);
        seg_out[o + 1u] = PI;
        seg_out[o + 2u] = omega;
        seg_out[o + 4u] = omega;
        seg_out[o + 6u] = PI / omega;
        return;
    }

    let sin_half: real = real(0.5) * nd;
    let cos_half: real = real(0.5) * ns;
    let theta: real = real(2.0) * atan2_pos(nd, ns);
    let beta: real = real(2.0) * atan2_pos(ns, nd);
    // sin(beta) = sin(theta), cos(beta) = -cos(theta) from the half angles
    // (beta near pi holds theta only to ulp(pi))
    let sin_beta: real = real(2.0) * sin_half * cos_half;
    let cos_beta: real = (sin_half - cos_half) * (sin_half + cos_half);
    let a: real = real(1.41421356237309504880) * abs(de2);
    let bb: real = real(2.0) * sin_half * de1;
    seg_out[o + 9u] = bb / a;

    let seg = Segment(a, bb, theta, sin_half, cos_half, sin_beta, cos_beta);
    // G(theta) > 0 > G(2 pi - theta); the sign of G(pi) picks the half.
    let g_mid = at_w(seg, real(1.0), beta).g;
    var side: real = real(1.0);
    if (g_mid > real(0.0)) {
        side = real(-1.0);
    }
    var w: real = beta;
    var steps = 0u;
    if (g_mid != real(0.0) && at_w(seg, side, real(0.0)).g != real(0.0)) {
        var lo: real = real(0.0);
        var hi: real = sqrt(beta);
        while (hi - lo > real(2.0) * REAL_EPS * hi && steps < BISECT_MAX) {
            let mid: real = real(0.5) * (lo + hi);
            if (at_w(seg, side, mid * mid).g * side > real(0.0)) {
                lo = mid;
            } else {
                hi = mid;
            }
            steps += 1u;
        }
        let z: real = real(0.5) * (lo + hi);
        w = z * z;
    } else if (g_mid != real(0.0)) {
        w = real(0.0);
    }

    // Lemma 5.2 (corrected)
    let at = at_w(seg, side, w);
    let phi = at.phi;
    let one_minus_cos_phi: real = real(2.0) * at.sin_half_phi * at.sin_half_phi;
    let tau_abs: real = min(sqrt(max(at.q, real(0.0)) / one_minus_cos_phi), real(1.0));
    var tau_bar: real = tau_abs;
    if (de2 < real(0.0)) {
        tau_bar = -tau_abs;
    }
    let kappa_bar: real = min(sin_half / at.sin_half_phi, real(1.0));
    let tp: real = tau_bar * phi;
    let omega: real = sqrt(real(4.0) * sin_half * sin_half + tp * tp) / dist;

    seg_out[o] = real(ST_OK);
    seg_out[o + 1u] = phi;
    seg_out[o + 2u] = omega;
    seg_out[o + 3u] = tau_bar;
    seg_out[o + 4u] = omega * kappa_bar;
    seg_out[o + 5u] = omega * tau_bar;
    seg_out[o + 6u] = phi / omega;
    // axis = a1 e1 + a2 e2 (ERRATA 1: minus sign on the cot term)
    seg_out[o + 7u] = tau_bar / cos_half;
    seg_out[o + 8u] = -(sin_half / cos_half) * (at.cos_half_phi / at.sin_half_phi);
    seg_out[o + 11u] = real(steps);
}
