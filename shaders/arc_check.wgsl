// Twin: src/twin/arc_check.rs (read its docs for the test, the sample
// formula and the band). One candidate arc per invocation: the codec's
// two-sided acceptance test, answered PASS (0), FAIL (1) or UNSURE (2).
// Prepended: the precision prelude (real, PIO2_*) and math.wgsl (sincos).
// The parameter block `params` and the buffers are declared in
// src/kernels/arc_check.rs and generated ahead of this body.

const IN_STRIDE: u32 = 16u;
const IDX_STRIDE: u32 = 8u;
const PASS: u32 = 0u;
const FAIL: u32 = 1u;
const UNSURE: u32 = 2u;

struct ArcIn {
    start: vec3<real>,
    tangent: vec3<real>,
    normal: vec3<real>,
    end: vec3<real>,
    kappa: real,
    step: real,
    pieces: u32,
}

fn dot3(a: vec3<real>, b: vec3<real>) -> real {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

fn dist2_to_segment(p: vec3<real>, a: vec3<real>, b: vec3<real>) -> real {
    let d = b - a;
    let dd = dot3(d, d);
    let w = p - a;
    var t: real = real(0.0);
    if (dd > real(0.0)) {
        t = min(max(dot3(w, d) / dd, real(0.0)), real(1.0));
    }
    let x = w - d * t;
    return dot3(x, x);
}

fn sample(arc: ArcIn, k: u32) -> vec3<real> {
    if (k == 0u) {
        return arc.start;
    }
    if (k >= arc.pieces) {
        return arc.end;
    }
    let s: real = arc.step * real(k);
    let x: real = real(0.5) * arc.kappa * s;
    let sc = sincos(x);
    var sinc_half: real;
    if (abs(x) < real(1e-4)) {
        let x2: real = x * x;
        sinc_half = real(1.0) - x2 / real(6.0) * (real(1.0) - x2 / real(20.0));
    } else {
        sinc_half = sc.x / x;
    }
    let along: real = s * sinc_half * sc.y;
    let across: real = s * x * sinc_half * sinc_half;
    return arc.start + arc.tangent * along + arc.normal * across;
}

fn point(i: u32) -> vec3<real> {
    return vec3<real>(points[3u * i], points[3u * i + 1u], points[3u * i + 2u]);
}

// A sure FAIL only for a finite excess: best - best == 0 is false for an
// infinity (and a NaN fails every comparison: UNSURE).
fn verdict_of(best: real, lo: real, hi: real) -> u32 {
    if (best <= lo) {
        return PASS;
    }
    if (best > hi && best - best == real(0.0)) {
        return FAIL;
    }
    return UNSURE;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let c = gid.x + gid.y * params.row;
    if (c >= params.count) {
        return;
    }
    let b = c * IN_STRIDE;
    let ib = c * IDX_STRIDE;
    var arc: ArcIn;
    arc.start = vec3<real>(rec_in[b], rec_in[b + 1u], rec_in[b + 2u]);
    arc.tangent = vec3<real>(rec_in[b + 3u], rec_in[b + 4u], rec_in[b + 5u]);
    arc.normal = vec3<real>(rec_in[b + 6u], rec_in[b + 7u], rec_in[b + 8u]);
    arc.end = vec3<real>(rec_in[b + 9u], rec_in[b + 10u], rec_in[b + 11u]);
    arc.kappa = rec_in[b + 12u];
    arc.step = rec_in[b + 13u];
    arc.pieces = max(idx_in[ib], 1u);
    let lo: real = rec_in[b + 14u];
    let hi: real = rec_in[b + 15u];
    var verdict: u32 = PASS;

    // Covered input vertices against the sample polyline: walk, then scan.
    var near: u32 = 0u;
    for (var i = idx_in[ib + 1u]; i <= idx_in[ib + 2u]; i++) {
        let p = point(i);
        var best = dist2_to_segment(p, sample(arc, near), sample(arc, near + 1u));
        loop {
            if (near + 1u >= arc.pieces) {
                break;
            }
            let d = dist2_to_segment(p, sample(arc, near + 1u), sample(arc, near + 2u));
            if (d > best) {
                break;
            }
            best = d;
            near += 1u;
        }
        if (best > lo) {
            for (var k = 0u; k < arc.pieces; k++) {
                let d = dist2_to_segment(p, sample(arc, k), sample(arc, k + 1u));
                if (d < best) {
                    best = d;
                    near = k;
                }
            }
            let v = verdict_of(best, lo, hi);
            if (v == FAIL) {
                verdicts[c] = FAIL;
                return;
            }
            verdict = max(verdict, v);
        }
    }

    // Samples (all but the start) against the input window.
    let w0 = idx_in[ib + 3u];
    let segs = idx_in[ib + 4u] - w0;
    near = 0u;
    for (var k = 1u; k <= arc.pieces; k++) {
        let q = sample(arc, k);
        var best: real;
        if (segs == 0u) {
            let d = q - point(w0);
            best = dot3(d, d);
        } else {
            best = dist2_to_segment(q, point(w0 + near), point(w0 + near + 1u));
            loop {
                if (near + 1u >= segs) {
                    break;
                }
                let d = dist2_to_segment(q, point(w0 + near + 1u), point(w0 + near + 2u));
                if (d > best) {
                    break;
                }
                best = d;
                near += 1u;
            }
            if (best > lo) {
                for (var j = 0u; j < segs; j++) {
                    let d = dist2_to_segment(q, point(w0 + j), point(w0 + j + 1u));
                    if (d < best) {
                        best = d;
                        near = j;
                    }
                }
            }
        }
        let v = verdict_of(best, lo, hi);
        if (v == FAIL) {
            verdicts[c] = FAIL;
            return;
        }
        verdict = max(verdict, v);
    }
    verdicts[c] = verdict;
}
