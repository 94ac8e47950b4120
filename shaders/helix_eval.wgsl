// Twin: src/twin/helix_eval.rs (read its docs for the formula and for why
// the host hands over parameters relative to the element start). One sample
// per invocation: the offset alpha(s) - p0 and the tangent t(s) of a helix
// element, in element.rs's cancellation-free form, phi = omega s:
//   alpha(s) - p0 = (s - k^2 s^3 g) t0 + k s^2 h n0 + k tau s^3 g b0
//   t(s)          = (1 - k^2 s^2 h) t0 + k s sinc n0 + k tau s^2 h b0
// Prepended: the precision prelude (real, PIO2_*) and math.wgsl (sincos).
// The parameter block `params` and the buffers are declared in
// src/kernels/helix_eval.rs and generated ahead of this body.

const IN_STRIDE: u32 = 10u;
const OUT_STRIDE: u32 = 6u;

// (sinc phi, h(phi), g(phi)) from one sincos(phi / 2): sinc phi =
// sinc(phi/2) cos(phi/2), h = sinc(phi/2)^2 / 2, g = (phi - sin phi)/phi^3
// directly for |phi| >= 1, by its Taylor series (9 terms) below.
fn helix_coefficients(phi: real) -> vec3<real> {
    let x: real = real(0.5) * phi;
    let sc = sincos(x);
    let sh: real = sc.x;
    let ch: real = sc.y;
    var sinc_half: real;
    if (abs(x) < real(1e-4)) {
        let x2: real = x * x;
        sinc_half = real(1.0) - x2 / real(6.0) * (real(1.0) - x2 / real(20.0));
    } else {
        sinc_half = sh / x;
    }
    let sinc: real = sinc_half * ch;
    let h: real = real(0.5) * sinc_half * sinc_half;
    var g: real;
    if (abs(phi) < real(1.0)) {
        let p2: real = phi * phi;
        var acc: real = real(0.0);
        acc = acc * p2 + real(1.0 / 121645100408832000.0);
        acc = acc * p2 - real(1.0 / 355687428096000.0);
        acc = acc * p2 + real(1.0 / 1307674368000.0);
        acc = acc * p2 - real(1.0 / 6227020800.0);
        acc = acc * p2 + real(1.0 / 39916800.0);
        acc = acc * p2 - real(1.0 / 362880.0);
        acc = acc * p2 + real(1.0 / 5040.0);
        acc = acc * p2 - real(1.0 / 120.0);
        acc = acc * p2 + real(1.0 / 6.0);
        g = acc;
    } else {
        g = (phi - real(2.0) * sh * ch) / (phi * phi * phi);
    }
    return vec3<real>(sinc, h, g);
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x + gid.y * params.row;
    if (i >= params.count) {
        return;
    }
    let b = i * IN_STRIDE;
    let o = i * OUT_STRIDE;
    let s: real = rec_in[b];
    let k: real = rec_in[b + 1u];
    let tau: real = rec_in[b + 2u];
    let phi: real = rec_in[b + 3u];
    let t0 = vec3<real>(rec_in[b + 4u], rec_in[b + 5u], rec_in[b + 6u]);
    let n0 = vec3<real>(rec_in[b + 7u], rec_in[b + 8u], rec_in[b + 9u]);
    // b0 = t0 x n0, written out (GLSL.std.450 Cross is not defined for f64)
    let b0 = vec3<real>(
        t0.y * n0.z - t0.z * n0.y,
        t0.z * n0.x - t0.x * n0.z,
        t0.x * n0.y - t0.y * n0.x);
    let c = helix_coefficients(phi);
    let sinc: real = c.x;
    let h: real = c.y;
    let g: real = c.z;
    let s2: real = s * s;
    let s3: real = s2 * s;
    let ks3g: real = k * s3 * g;
    let pa: real = s - k * ks3g;
    let pb: real = k * s2 * h;
    let pc: real = tau * ks3g;
    let ks2h: real = k * s2 * h;
    let ta: real = real(1.0) - k * ks2h;
    let tb: real = k * s * sinc;
    let tc: real = tau * ks2h;
    for (var j = 0u; j < 3u; j++) {
        rec_out[o + j] = pa * t0[j] + pb * n0[j] + pc * b0[j];
        rec_out[o + 3u + j] = ta * t0[j] + tb * n0[j] + tc * b0[j];
    }
}
