// Twin: src/twin/math.rs. sin, cos and atan2 from arithmetic only, in `real`
// (f32 or f64, from the prelude). The built-ins are not used: for f64 they
// compile but return garbage on lavapipe and NVIDIA, and lavapipe's f32 ones
// are less accurate than libm. Needs from the prelude: PIO2_A/B/C.

fn horner6(c0: real, c1: real, c2: real, c3: real, c4: real, c5: real, z: real) -> real {
    return ((((c0 * z + c1) * z + c2) * z + c3) * z + c4) * z + c5;
}

// (sin x, cos x): Cody-Waite reduction by pi/2, Cephes polynomials on
// [-pi/4, pi/4].
fn sincos(x: real) -> vec2<real> {
    let q: real = floor(x * real(0.63661977236758134308) + real(0.5));
    let y: real = ((x - q * PIO2_A) - q * PIO2_B) - q * PIO2_C;
    let z: real = y * y;
    let s: real = y + y * z * horner6(
        real(1.58962301576546568060e-10), real(-2.50507477628578072866e-8),
        real(2.75573136213857245213e-6), real(-1.98412698295895385996e-4),
        real(8.33333333332211858878e-3), real(-1.66666666666666307295e-1), z);
    let c: real = real(1.0) - real(0.5) * z + z * z * horner6(
        real(-1.13585365213876817300e-11), real(2.08757008419747316778e-9),
        real(-2.75573141792967388112e-7), real(2.48015872888517045348e-5),
        real(-1.38888888888730564116e-3), real(4.16666666666665929218e-2), z);
    let k: i32 = ((i32(q) % 4) + 4) % 4;
    if (k == 0) {
        return vec2<real>(s, c);
    } else if (k == 1) {
        return vec2<real>(c, -s);
    } else if (k == 2) {
        return vec2<real>(-s, -c);
    }
    return vec2<real>(-c, s);
}

// atan x for 0 <= x <= 1 (Cephes: reduction to [0, 0.66], rational P4/Q5).
fn atan_unit(x: real) -> real {
    var base: real = real(0.0);
    var t: real = x;
    if (x > real(0.66)) {
        base = real(0.78539816339744830962);
        t = (x - real(1.0)) / (x + real(1.0));
    }
    let z: real = t * t;
    let p: real = (((real(-8.750608600031904122785e-1) * z
        + real(-1.615753718733365076637e1)) * z
        + real(-7.500855792314704667340e1)) * z
        + real(-1.228866684490136173410e2)) * z
        + real(-6.485021904942025371773e1);
    let qq: real = ((((z + real(2.485846490142306297962e1)) * z
        + real(1.650270098316988542046e2)) * z
        + real(4.328810604912902668951e2)) * z
        + real(4.853903996359136964868e2)) * z
        + real(1.945506571482613964425e2);
    return base + (t + t * z * p / qq);
}

// atan2(y, x) for y, x >= 0, not both zero.
fn atan2_pos(y: real, x: real) -> real {
    if (y <= x) {
        return atan_unit(y / x);
    }
    return real(1.57079632679489661923) - atan_unit(x / y);
}
