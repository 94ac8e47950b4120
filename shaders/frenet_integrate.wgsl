// Twin: src/twin/frenet_integrate.rs (read its docs for the integrator, the
// error argument and the record layout; the f64 reference is
// src/euler/frenet.rs). One 3D Euler spiral per invocation, in scaled arc
// length u = s/L in [0, 1], N steps of h = 1/N:
//   frame: two fourth-order Magnus rotations per step, in closed form
//     (omega is linear): over a half step of length l = h/2 centred at um,
//     Omega = (l (t0 + d um), l^3 c / 12, l (k0 + g um)), c = k0 d - t0 g,
//     as the quaternion r = (cos phi/2, sinc(phi/2) Omega / 2), composed
//     as q + q (r - 1) into a two-word q (hi + lo) so that f32 does not
//     drift by O(eps) per rotation (see the twin's docs);
//   position: Simpson on the tangents at the step's start, middle and end,
//     compensated (Neumaier) sum.
// Prepended: the precision prelude (real, PIO2_*), math.wgsl (sincos), and
// from the driver `const SAMPLES: u32` (0: end mode; m >= 1: sampled mode,
// m samples per problem) and `const OUT_STRIDE: u32` (13, or 1 + 6 m).
// The parameter block `params` and the buffers are declared in
// src/kernels/frenet_integrate.rs and generated ahead of this body.

const IN_STRIDE: u32 = 13u;
const STEP_ANGLE_MAX: real = real(64.0);
const STATUS_RANGE: real = real(1.0);

// h (max(|t0|, |t0 + d|) + max(|k0|, |k0 + g|)) + h^3 |c| / 12 >= |Omega_k|
fn step_bound(k0: real, g: real, t0: real, d: real, h: real) -> real {
    let c: real = k0 * d - t0 * g;
    return h * (max(abs(t0), abs(t0 + d)) + max(abs(k0), abs(k0 + g)))
        + h * h * h / real(12.0) * abs(c);
}

// Magnus vector over the interval of length len centred at um; rates =
// (k0, g, t0, d).
fn magnus(rates: vec4<real>, c: real, um: real, len: real) -> vec3<real> {
    return vec3<real>(
        len * (rates.z + rates.w * um),
        len * len * len / real(12.0) * c,
        len * (rates.x + rates.y * um));
}

// Quaternions are (w, x, y, z) in a vec4's (x, y, z, w) slots.

// r - 1 for r = exp of the cross-product matrix of v, the quaternion
// (cos phi/2, sinc(phi/2) v / 2): (cos phi/2 - 1, sinc(phi/2) v / 2), with
// cos - 1 = -sin^2 / (1 + cos) while cos > 0 (no cancellation).
fn exp_quat_m1(v: vec3<real>) -> vec4<real> {
    let phi: real = sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
    let x: real = real(0.5) * phi;
    let sc = sincos(x);
    var sinc: real;
    if (x < real(1e-4)) {
        let x2: real = x * x;
        sinc = real(1.0) - x2 / real(6.0) * (real(1.0) - x2 / real(20.0));
    } else {
        sinc = sc.x / x;
    }
    var cm1: real;
    if (sc.y > real(0.0)) {
        cm1 = -(sc.x * sc.x) / (real(1.0) + sc.y);
    } else {
        cm1 = sc.y - real(1.0);
    }
    let a: real = real(0.5) * sinc;
    return vec4<real>(cm1, a * v.x, a * v.y, a * v.z);
}

// Hamilton product a b.
fn qmul(a: vec4<real>, b: vec4<real>) -> vec4<real> {
    let aw = a.x;
    let ax = a.y;
    let ay = a.z;
    let az = a.w;
    let bw = b.x;
    let bx = b.y;
    let by = b.z;
    let bz = b.w;
    return vec4<real>(
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw);
}

// The accumulated rotation in two words per component (hi the rounded value).
struct TwoQuat {
    hi: vec4<real>,
    lo: vec4<real>,
}

// q <- q r as q + q (r - 1): TwoSum of the increment into hi, the error into
// lo, renormalised so that hi is the rounded sum.
fn rotate(q: TwoQuat, rm1: vec4<real>) -> TwoQuat {
    let d = qmul(q.hi, rm1);
    let t = q.hi + d;
    let e = select((d - t) + q.hi, (q.hi - t) + d, abs(q.hi) >= abs(d));
    let c = q.lo + e;
    let u = t + c;
    return TwoQuat(u, (t - u) + c);
}

// Columns of the rotation matrix of a quaternion of any length: T, N, B.
fn col_t(q: vec4<real>) -> vec3<real> {
    let w = q.x;
    let x = q.y;
    let y = q.z;
    let z = q.w;
    let n2: real = w * w + x * x + y * y + z * z;
    return vec3<real>(
        real(1.0) - real(2.0) * (y * y + z * z) / n2,
        real(2.0) * (x * y + w * z) / n2,
        real(2.0) * (x * z - w * y) / n2);
}

fn col_n(q: vec4<real>) -> vec3<real> {
    let w = q.x;
    let x = q.y;
    let y = q.z;
    let z = q.w;
    let n2: real = w * w + x * x + y * y + z * z;
    return vec3<real>(
        real(2.0) * (x * y - w * z) / n2,
        real(1.0) - real(2.0) * (x * x + z * z) / n2,
        real(2.0) * (y * z + w * x) / n2);
}

fn col_b(q: vec4<real>) -> vec3<real> {
    let w = q.x;
    let x = q.y;
    let y = q.z;
    let z = q.w;
    let n2: real = w * w + x * x + y * y + z * z;
    return vec3<real>(
        real(2.0) * (x * z + w * y) / n2,
        real(2.0) * (y * z - w * x) / n2,
        real(1.0) - real(2.0) * (x * x + y * y) / n2);
}

// F0 v = T0 v.x + N0 v.y + B0 v.z
fn world(t0: vec3<real>, n0: vec3<real>, b0: vec3<real>, v: vec3<real>) -> vec3<real> {
    return t0 * v.x + n0 * v.y + b0 * v.z;
}

fn write3(at: u32, v: vec3<real>) {
    rec_out[at] = v.x;
    rec_out[at + 1u] = v.y;
    rec_out[at + 2u] = v.z;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x + gid.y * params.row;
    if (i >= params.count) {
        return;
    }
    let b = i * IN_STRIDE;
    let o = i * OUT_STRIDE;
    let rates = vec4<real>(rec_in[b], rec_in[b + 1u], rec_in[b + 2u], rec_in[b + 3u]);
    let t0 = vec3<real>(rec_in[b + 4u], rec_in[b + 5u], rec_in[b + 6u]);
    let n0 = vec3<real>(rec_in[b + 7u], rec_in[b + 8u], rec_in[b + 9u]);
    let b0 = vec3<real>(rec_in[b + 10u], rec_in[b + 11u], rec_in[b + 12u]);
    let per: u32 = u32(params.steps);
    var steps: u32 = per;
    if (SAMPLES > 0u) {
        steps = (SAMPLES - 1u) * per;
    }
    for (var j = 0u; j < OUT_STRIDE; j++) {
        rec_out[o + j] = real(0.0);
    }
    let h: real = real(1.0) / real(max(steps, 1u));
    if (steps > 0u) {
        // !(a <= b): NaN is out of range too
        if (!(step_bound(rates.x, rates.y, rates.z, rates.w, h) <= STEP_ANGLE_MAX)) {
            rec_out[o] = STATUS_RANGE;
            return;
        }
    }
    let c: real = rates.x * rates.w - rates.z * rates.y;
    let h6: real = h / real(6.0);
    let half: real = real(0.5) * h;
    var q = TwoQuat(vec4<real>(real(1.0), real(0.0), real(0.0), real(0.0)), vec4<real>(real(0.0)));
    var t = vec3<real>(real(1.0), real(0.0), real(0.0));
    var ps = vec3<real>(real(0.0));
    var pc = vec3<real>(real(0.0));
    var j = 1u;
    for (var k = 0u; k < steps; k++) {
        let kf: real = real(k);
        let mid = rotate(q, exp_quat_m1(magnus(rates, c, (kf + real(0.25)) * h, half)));
        let next = rotate(mid, exp_quat_m1(magnus(rates, c, (kf + real(0.75)) * h, half)));
        let tm = col_t(mid.hi);
        let tn = col_t(next.hi);
        let x = h6 * ((t + real(4.0) * tm) + tn);
        let s = ps + x;
        pc = pc + select((x - s) + ps, (ps - s) + x, abs(ps) >= abs(x));
        ps = s;
        q = next;
        t = tn;
        if (SAMPLES > 0u) {
            if ((k + 1u) % per == 0u) {
                let at = o + 1u + 6u * j;
                write3(at, world(t0, n0, b0, ps + pc));
                write3(at + 3u, world(t0, n0, b0, tn));
                j++;
            }
        }
    }
    if (SAMPLES == 0u) {
        write3(o + 1u, world(t0, n0, b0, ps + pc));
        write3(o + 4u, world(t0, n0, b0, col_t(q.hi)));
        write3(o + 7u, world(t0, n0, b0, col_n(q.hi)));
        write3(o + 10u, world(t0, n0, b0, col_b(q.hi)));
    } else {
        write3(o + 1u, world(t0, n0, b0, vec3<real>(real(0.0))));
        write3(o + 4u, world(t0, n0, b0, vec3<real>(real(1.0), real(0.0), real(0.0))));
    }
}
