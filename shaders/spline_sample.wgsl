// Twin: src/twin/spline_sample.rs (read its docs for the design, the buffer
// layouts and why segments arrive relative to their start and scaled).
// Equal-arc-length samples of many cubic Bezier splines, ragged batches:
//   seg_table_main  one invocation per segment: FINE Gauss-Legendre-8 panels
//                   (halves of COARSE panels, whose difference flags
//                   near-cusps), cumulative lengths in the table;
//   prefix_main     one invocation per spline piece: cumulative segment
//                   ends, spline length and flag;
//   sample_main     one invocation per output sample: locate piece,
//                   segment, panel; safeguarded Newton for t; point, tangent.
// Prepended: the precision prelude (real, REAL_EPS), math.wgsl (unused
// here) and REAL_MAX. No WGSL built-ins on `real` except sqrt, abs, min,
// max, select (length/normalize/cross are avoided: order of operations must
// match the twin, and some are not defined for f64 on every driver).
// The parameter block `params` and the buffers are declared in
// src/kernels/spline_sample.rs and generated ahead of this body.

const COARSE: u32 = 16u;
const FINE: u32 = 32u;
const QUAD_TOL: real = real(16.0);
const QUAD_FLOOR: real = real(8.0);
const SEG_STRIDE: u32 = 9u;
const TABLE_STRIDE: u32 = 34u;
const T_FLAG: u32 = 32u;
const T_CUM_END: u32 = 33u;
const PIECE_STRIDE: u32 = 6u;
const SPL_STRIDE: u32 = 2u;
const OUT_STRIDE: u32 = 9u;
const NEWTON_STEP_EPS: real = real(32.0);
const NEWTON_MAX: u32 = 64u;
const NOISE_EPS: real = real(64.0);
const END_SNAP: real = real(1e-6);

fn finite(x: real) -> bool {
    return abs(x) <= REAL_MAX;
}

fn norm3(a: vec3<real>) -> real {
    return sqrt(a.x * a.x + a.y * a.y + a.z * a.z);
}

fn lerp3(a: vec3<real>, b: vec3<real>, t: real) -> vec3<real> {
    let u: real = real(1.0) - t;
    return vec3<real>(a.x * u + b.x * t, a.y * u + b.y * t, a.z * u + b.z * t);
}

fn max_abs3(a: vec3<real>) -> real {
    return max(max(abs(a.x), abs(a.y)), abs(a.z));
}

fn is_zero3(a: vec3<real>) -> bool {
    return a.x == real(0.0) && a.y == real(0.0) && a.z == real(0.0);
}

fn normalize3(a: vec3<real>) -> vec3<real> {
    let l: real = norm3(a);
    return vec3<real>(a.x / l, a.y / l, a.z / l);
}

struct Seg {
    p1: vec3<real>,
    p2: vec3<real>,
    p3: vec3<real>,
}

fn load_seg(i: u32) -> Seg {
    let b = i * SEG_STRIDE;
    return Seg(
        vec3<real>(segs[b], segs[b + 1u], segs[b + 2u]),
        vec3<real>(segs[b + 3u], segs[b + 4u], segs[b + 5u]),
        vec3<real>(segs[b + 6u], segs[b + 7u], segs[b + 8u]));
}

fn seg_is_point(s: Seg) -> bool {
    return is_zero3(s.p1) && is_zero3(s.p2) && is_zero3(s.p3);
}

// B(t) - P0 by de Casteljau.
fn seg_eval(s: Seg, t: real) -> vec3<real> {
    let z = vec3<real>(real(0.0), real(0.0), real(0.0));
    let a = lerp3(z, s.p1, t);
    let b = lerp3(s.p1, s.p2, t);
    let c = lerp3(s.p2, s.p3, t);
    let d = lerp3(a, b, t);
    let e = lerp3(b, c, t);
    return lerp3(d, e, t);
}

fn seg_deriv(s: Seg, t: real) -> vec3<real> {
    let d0 = s.p1;
    let d1 = s.p2 - s.p1;
    let d2 = s.p3 - s.p2;
    let a = lerp3(d0, d1, t);
    let b = lerp3(d1, d2, t);
    return real(3.0) * lerp3(a, b, t);
}

fn seg_deriv2(s: Seg, t: real) -> vec3<real> {
    let z = vec3<real>(real(0.0), real(0.0), real(0.0));
    let a = (s.p2 - real(2.0) * s.p1) + z;
    let b = (s.p3 - real(2.0) * s.p2) + s.p1;
    return real(6.0) * lerp3(a, b, t);
}

fn seg_deriv3(s: Seg) -> vec3<real> {
    return real(6.0) * ((s.p3 - real(3.0) * s.p2) + real(3.0) * s.p1);
}

// CubicBez::unit_tangent's rule; zero for a point segment.
fn seg_unit_tangent(s: Seg, t: real) -> vec3<real> {
    let z = vec3<real>(real(0.0), real(0.0), real(0.0));
    if (seg_is_point(s)) {
        return z;
    }
    let d0 = s.p1;
    let d1 = s.p2 - s.p1;
    let d2 = s.p3 - s.p2;
    let leg: real = max(max(norm3(d0), norm3(d1)), norm3(d2));
    let mag: real = max(max(max_abs3(s.p1), max_abs3(s.p2)), max_abs3(s.p3));
    let thr: real = NOISE_EPS * REAL_EPS * (leg + mag);
    let v = seg_deriv(s, t);
    if (norm3(v) > thr) {
        return normalize3(v);
    }
    let at_end = t == real(1.0)
        || (real(1.0) - t <= END_SNAP && norm3(seg_deriv(s, real(1.0))) <= thr);
    let v3 = seg_deriv3(s);
    if (at_end) {
        let v2 = seg_deriv2(s, real(1.0));
        if (norm3(v2) > real(4.0) * thr) {
            return real(-1.0) * normalize3(v2);
        }
    } else {
        let v2 = seg_deriv2(s, t);
        if (norm3(v2) > real(4.0) * thr) {
            return normalize3(v2);
        }
    }
    if (norm3(v3) > real(8.0) * thr) {
        return normalize3(v3);
    }
    if (norm3(s.p3) > real(0.0)) {
        return normalize3(s.p3);
    }
    if (norm3(d0) > real(0.0)) {
        return normalize3(d0);
    }
    if (norm3(d1) > real(0.0)) {
        return normalize3(d1);
    }
    if (norm3(d2) > real(0.0)) {
        return normalize3(d2);
    }
    return z;
}

// B'(t) = c0 + c1 t + c2 t^2 (power form).
struct Speed {
    c0: vec3<real>,
    c1: vec3<real>,
    c2: vec3<real>,
}

fn speed_new(s: Seg) -> Speed {
    let d0 = s.p1;
    let d1 = s.p2 - s.p1;
    let d2 = s.p3 - s.p2;
    return Speed(
        real(3.0) * d0,
        real(6.0) * (d1 - d0),
        real(3.0) * ((d0 - real(2.0) * d1) + d2));
}

fn speed_at(c: Speed, t: real) -> real {
    let v = vec3<real>(
        c.c0.x + t * (c.c1.x + t * c.c2.x),
        c.c0.y + t * (c.c1.y + t * c.c2.y),
        c.c0.z + t * (c.c1.z + t * c.c2.z));
    return norm3(v);
}

fn speed_accel(c: Speed, t: real) -> real {
    let t2: real = real(2.0) * t;
    return norm3(c.c1 + t2 * c.c2);
}

fn gl8(c: Speed, a: real, b: real) -> real {
    let mid: real = real(0.5) * (a + b);
    let hw: real = real(0.5) * (b - a);
    var sum: real = real(0.0);
    var dx: real;
    dx = hw * real(0.1834346424956498049394761423602);
    sum += real(0.3626837833783619829651504492772) * (speed_at(c, mid - dx) + speed_at(c, mid + dx));
    dx = hw * real(0.5255324099163289858177390491893);
    sum += real(0.3137066458778872873379622019866) * (speed_at(c, mid - dx) + speed_at(c, mid + dx));
    dx = hw * real(0.7966664774136267395915539364758);
    sum += real(0.2223810344533744705443559944262) * (speed_at(c, mid - dx) + speed_at(c, mid + dx));
    dx = hw * real(0.9602898564975362316835608685695);
    sum += real(0.1012285362903762591525313543099) * (speed_at(c, mid - dx) + speed_at(c, mid + dx));
    return sum * hw;
}

@compute @workgroup_size(64)
fn seg_table_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x + gid.y * params.row_seg;
    if (i >= params.n_segs) {
        return;
    }
    let o = i * TABLE_STRIDE;
    let s = load_seg(i);
    if (seg_is_point(s)) {
        for (var q = 0u; q <= FINE; q++) {
            table[o + q] = real(0.0);
        }
        return;
    }
    let sp = speed_new(s);
    let inv: real = real(0.0625);
    var whole: array<real, 16>;
    var est: real = real(0.0);
    for (var c = 0u; c < COARSE; c++) {
        let a: real = real(c) * inv;
        let b: real = real(c + 1u) * inv;
        whole[c] = gl8(sp, a, b);
        est += whole[c];
    }
    let tol: real = QUAD_TOL * REAL_EPS * est * inv;
    let floor_eps: real = QUAD_FLOOR * REAL_EPS;
    var flag: real = real(0.0);
    var acc: real = real(0.0);
    for (var c = 0u; c < COARSE; c++) {
        let a: real = real(c) * inv;
        let b: real = real(c + 1u) * inv;
        let m: real = real(0.5) * (a + b);
        let left: real = gl8(sp, a, m);
        let right: real = gl8(sp, m, b);
        let both: real = left + right;
        let err: real = abs(whole[c] - both);
        flag = select(real(1.0), flag, err <= max(tol, floor_eps * both));
        acc += left;
        table[o + 2u * c] = acc;
        acc += right;
        table[o + 2u * c + 1u] = acc;
    }
    flag = select(real(1.0), flag, finite(acc));
    table[o + T_FLAG] = flag;
}

@compute @workgroup_size(64)
fn prefix_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x + gid.y * params.row_piece;
    if (p >= params.n_pieces) {
        return;
    }
    let first = pieces[p * PIECE_STRIDE];
    let count = pieces[p * PIECE_STRIDE + 1u];
    var acc: real = real(0.0);
    var flag: real = real(0.0);
    for (var i = first; i < first + count; i++) {
        acc += table[i * TABLE_STRIDE + FINE - 1u];
        table[i * TABLE_STRIDE + T_CUM_END] = acc;
        flag = max(flag, table[i * TABLE_STRIDE + T_FLAG]);
    }
    flag = select(real(1.0), flag, finite(acc) && acc > real(0.0));
    spl[p * SPL_STRIDE] = acc;
    spl[p * SPL_STRIDE + 1u] = flag;
}

fn initial_fraction(v0: real, v1: real, f: real) -> real {
    let c: real = f * (v0 + v1);
    let den: real = v0 + sqrt((real(1.0) - f) * v0 * v0 + f * v1 * v1);
    let u: real = c / den;
    if (u >= real(0.0) && u <= real(1.0)) {
        return u;
    }
    return f;
}

// t in fine panel q of segment row `o` (table offset) with arc length
// `local` from the segment start: the reference's solve_panel.
fn solve_panel(sp: Speed, o: u32, q: u32, local: real) -> real {
    if (q >= FINE) {
        return real(1.0);
    }
    let inv: real = real(0.03125);
    let t0: real = real(q) * inv;
    let t1: real = real(q + 1u) * inv;
    var s0: real = real(0.0);
    if (q > 0u) {
        s0 = table[o + q - 1u];
    }
    let want: real = local - s0;
    let span: real = table[o + q] - s0;
    if (!(want > real(0.0))) {
        return t0;
    }
    if (!(want < span)) {
        return t1;
    }
    var lo: real = t0;
    var hi: real = t1;
    var t: real = lo + (hi - lo) * initial_fraction(speed_at(sp, lo), speed_at(sp, hi), want / span);
    let step_tol: real = NEWTON_STEP_EPS * REAL_EPS;
    for (var it = 0u; it < NEWTON_MAX; it++) {
        let g: real = gl8(sp, t0, t) - want;
        if (g == real(0.0)) {
            return t;
        }
        if (g > real(0.0)) {
            hi = t;
        } else {
            lo = t;
        }
        let speed: real = speed_at(sp, t);
        let stp: real = g / speed;
        let tn: real = t - stp;
        let a: real = abs(stp);
        if (a <= step_tol
            || (a <= real(1e-5) && a * a * speed_accel(sp, t) <= step_tol * real(2.0) * speed)) {
            return min(max(tn, lo), hi);
        }
        if (tn > lo && tn < hi) {
            t = tn;
        } else {
            let mid: real = real(0.5) * (lo + hi);
            if (mid <= lo || mid >= hi) {
                return mid;
            }
            t = mid;
        }
    }
    return t;
}

fn find_piece(i: u32) -> u32 {
    var lo: u32 = 0u;
    var hi: u32 = params.n_pieces;
    while (hi - lo > 1u) {
        let mid = (lo + hi) / 2u;
        if (pieces[mid * PIECE_STRIDE + 2u] <= i) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return lo;
}

fn cum_end(first: u32, l: u32) -> real {
    return table[(first + l) * TABLE_STRIDE + T_CUM_END];
}

@compute @workgroup_size(64)
fn sample_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x + gid.y * params.row_sample;
    if (i >= params.n_samples) {
        return;
    }
    let p = find_piece(i);
    let pb = p * PIECE_STRIDE;
    let first = pieces[pb];
    let k = pieces[pb + 1u];
    let n = pieces[pb + 4u];
    let j = pieces[pb + 5u] + (i - pieces[pb + 2u]);
    let total: real = spl[p * SPL_STRIDE];
    var flag: real = spl[p * SPL_STRIDE + 1u];
    var seg: u32;
    var t: real;
    if (j >= n) {
        // last segment that starts before the total
        var lo: u32 = 0u;
        var hi: u32 = k - 1u;
        while (lo < hi) {
            let mid = (lo + hi + 1u) / 2u;
            if (cum_end(first, mid - 1u) < total) {
                lo = mid;
            } else {
                hi = mid - 1u;
            }
        }
        seg = lo;
        t = real(1.0);
    } else {
        let s: real = total * (real(j) * (real(1.0) / real(n)));
        // first segment whose end lies beyond s
        var lo: u32 = 0u;
        var hi: u32 = k - 1u;
        while (lo < hi) {
            let mid = (lo + hi) / 2u;
            if (cum_end(first, mid) > s) {
                hi = mid;
            } else {
                lo = mid + 1u;
            }
        }
        seg = lo;
        var start: real = real(0.0);
        if (seg > 0u) {
            start = cum_end(first, seg - 1u);
        }
        let local: real = s - start;
        let o = (first + seg) * TABLE_STRIDE;
        // fine panel: the number of table entries <= local
        var plo: u32 = 0u;
        var phi: u32 = FINE;
        while (plo < phi) {
            let mid = (plo + phi) / 2u;
            if (table[o + mid] <= local) {
                plo = mid + 1u;
            } else {
                phi = mid;
            }
        }
        t = solve_panel(speed_new(load_seg(first + seg)), o, plo, local);
    }
    let sg = load_seg(first + seg);
    let pt = seg_eval(sg, t);
    let tng = seg_unit_tangent(sg, t);
    let b = i * OUT_STRIDE;
    rec_out[b + 1u] = real(seg);
    rec_out[b + 2u] = t;
    var ok: bool = finite(t) && norm3(tng) != real(0.0);
    for (var c = 0u; c < 3u; c++) {
        rec_out[b + 3u + c] = pt[c];
        rec_out[b + 6u + c] = tng[c];
        ok = ok && finite(pt[c]) && finite(tng[c]);
    }
    rec_out[b] = select(real(1.0), flag, ok);
}
