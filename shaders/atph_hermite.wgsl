// Twin: src/twin/atph_hermite.rs (read its docs for the formulation and the
// host/kernel split). One ATPH G1 Hermite solve per invocation (paper 002,
// systems 3.1 and 4.1) for a spatial tangent field, on the unit problem
// (chord / |chord|, L / |chord|): the moment vectors V_k = int_0^1 t^k T
// from three frequencies (series below |omega| = 2, corrected closed form
// 2.5-2.6 above), the Bernstein columns, Gaussian elimination with partial
// pivoting, and |det| / prod |column| for the host's singularity test.
// Prepended: the precision prelude (real, PIO2_*) and math.wgsl (sincos).
// The parameter block `params` and the buffers are declared in
// src/kernels/atph_hermite.rs and generated ahead of this body.

const IN_STRIDE: u32 = 8u;
const OUT_STRIDE: u32 = 5u;
const SERIES_TERMS: u32 = 28u;

struct Moments {
    re: array<real, 4>,
    im: array<real, 4>,
}

// M_k = int_0^1 t^k exp(i(omega t + alpha)) dt, k = 0..3.
fn moments(omega: real, alpha: real) -> Moments {
    var m: Moments;
    if (abs(omega) < real(2.0)) {
        var sr: array<real, 4>;
        var si: array<real, 4>;
        for (var k = 0u; k < 4u; k++) {
            sr[k] = real(0.0);
            si[k] = real(0.0);
        }
        var p: real = real(1.0);
        for (var n = 0u; n < SERIES_TERMS; n++) {
            let nf: real = real(n);
            for (var k = 0u; k < 4u; k++) {
                let term: real = p / (nf + real(k + 1u));
                let q = n % 4u;
                if (q == 0u) {
                    sr[k] += term;
                } else if (q == 1u) {
                    si[k] += term;
                } else if (q == 2u) {
                    sr[k] -= term;
                } else {
                    si[k] -= term;
                }
            }
            p = p * omega / (nf + real(1.0));
        }
        let sc = sincos(alpha);
        for (var k = 0u; k < 4u; k++) {
            m.re[k] = sc.y * sr[k] - sc.x * si[k];
            m.im[k] = sc.y * si[k] + sc.x * sr[k];
        }
    } else {
        let e1 = sincos(omega + alpha);
        let e0 = sincos(alpha);
        let inv: real = real(1.0) / omega;
        m.re[0] = (e1.x - e0.x) * inv;
        m.im[0] = -(e1.y - e0.y) * inv;
        for (var k = 1u; k < 4u; k++) {
            let kf: real = real(k);
            let x: real = e1.y - kf * m.re[k - 1u];
            let y: real = e1.x - kf * m.im[k - 1u];
            m.re[k] = y * inv;
            m.im[k] = -x * inv;
        }
    }
    return m;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let id = gid.x + gid.y * params.row;
    if (id >= params.count) {
        return;
    }
    let base = id * IN_STRIDE;
    let a0: real = rec_in[base];
    let a1: real = rec_in[base + 1u];
    let b0: real = rec_in[base + 2u];
    let b1: real = rec_in[base + 3u];
    let len: real = rec_in[base + 7u];
    let half: real = real(0.5);
    let ma = moments(a1 + b1, a0 + b0);
    let mb = moments(a1 - b1, a0 - b0);
    let mz = moments(a1, a0);
    var v: array<array<real, 3>, 4>;
    for (var k = 0u; k < 4u; k++) {
        v[k][0] = half * (ma.re[k] + mb.re[k]);
        v[k][1] = half * (ma.im[k] - mb.im[k]);
        v[k][2] = mz.im[k];
    }
    let cubic = len > real(0.0);
    var n = 3u;
    if (cubic) {
        n = 4u;
    }
    var a: array<array<real, 4>, 4>;
    for (var i = 0u; i < 4u; i++) {
        for (var j = 0u; j < 4u; j++) {
            a[i][j] = real(0.0);
        }
    }
    let two: real = real(2.0);
    let three: real = real(3.0);
    let six: real = real(6.0);
    for (var i = 0u; i < 3u; i++) {
        if (cubic) {
            a[i][0] = v[0][i] - three * v[1][i] + three * v[2][i] - v[3][i];
            a[i][1] = three * v[1][i] - six * v[2][i] + three * v[3][i];
            a[i][2] = three * v[2][i] - three * v[3][i];
            a[i][3] = v[3][i];
        } else {
            a[i][0] = v[0][i] - two * v[1][i] + v[2][i];
            a[i][1] = two * v[1][i] - two * v[2][i];
            a[i][2] = v[2][i];
        }
    }
    if (cubic) {
        for (var j = 0u; j < 4u; j++) {
            a[3][j] = real(0.25);
        }
    }
    var b: array<real, 4>;
    b[0] = rec_in[base + 4u];
    b[1] = rec_in[base + 5u];
    b[2] = rec_in[base + 6u];
    b[3] = len;
    var scale2: real = real(1.0);
    for (var j = 0u; j < n; j++) {
        var s: real = real(0.0);
        for (var i = 0u; i < n; i++) {
            s += a[i][j] * a[i][j];
        }
        scale2 *= s;
    }
    var det: real = real(1.0);
    for (var k = 0u; k < n; k++) {
        var p = k;
        for (var i = k + 1u; i < n; i++) {
            if (abs(a[i][k]) > abs(a[p][k])) {
                p = i;
            }
        }
        if (p != k) {
            let row = a[p];
            a[p] = a[k];
            a[k] = row;
            let t: real = b[p];
            b[p] = b[k];
            b[k] = t;
            det = -det;
        }
        let piv: real = a[k][k];
        det *= piv;
        for (var i = k + 1u; i < n; i++) {
            let f: real = a[i][k] / piv;
            for (var j = k; j < n; j++) {
                a[i][j] -= f * a[k][j];
            }
            b[i] -= f * b[k];
        }
    }
    var x: array<real, 4>;
    for (var k = 0u; k < 4u; k++) {
        x[k] = real(0.0);
    }
    for (var kk = 0u; kk < n; kk++) {
        let k = n - 1u - kk;
        var s: real = b[k];
        for (var j = k + 1u; j < n; j++) {
            s -= a[k][j] * x[j];
        }
        x[k] = s / a[k][k];
    }
    let o = id * OUT_STRIDE;
    for (var k = 0u; k < 4u; k++) {
        rec_out[o + k] = x[k];
    }
    rec_out[o + 4u] = abs(det) / sqrt(scale2);
}
