#!/usr/bin/env python3
"""Curve sets of kinds that ../shared/data does not hold, for checking the
codec on data it was never tuned on (issue 19: "other organs and other field
models").

heart.tck       3,000 fibres of a left ventricle, tracked as tractography does:
                a prolate ellipsoidal wall 10 mm thick, the fibres' helix angle
                turning from +60 deg at the endocardium to -60 deg at the
                epicardium (the classic transmural rotation), each fibre traced
                at a 0.5 mm step with a small random walk in its angle and
                0.05 mm of position noise, from a random seed in the wall until
                it leaves the wall or reaches its random length (20-150 mm).
                Units mm: compress at T = 0.1 and 0.5.
dipole.tck      2,000 field lines of a potential field that is not PFSS: a
                tilted dipole plus a quadrupole above the unit sphere (units:
                the sphere's radius, like R_sun), traced by RK4 from footpoints
                on the sphere at a step of 0.02 r until the line returns to
                r = 1 or leaves r = 2.5. Compress at T = 1e-3 and 1e-2.
bundles.tck     3,000 streamlines of 12 bundles tracked as a probabilistic
                tracker does: each bundle a smooth direction field (a random
                rotation of (1, 0.3 sin, 0.3 cos)), each streamline a walk of
                0.5 mm steps from a seed near the bundle's axis whose direction
                keeps 0.8 of itself, takes 0.2 of the field and 0.06 of
                Gaussian noise per step, 40-140 mm long. Units mm: T = 0.1
                and 0.5.
dense.tck       1,500 of those streamlines as a deterministic tracker with
                spline interpolation writes them: every fourth point kept as a
                knot (2 mm apart), a Catmull-Rom spline through the knots
                sampled every 0.2 mm (its curvature jumps at each knot).

All are float32 .tck (nibabel). numpy + nibabel only; deterministic (--seed).

    python benches/make_unseen.py -o /tmp/unseen
    python benches/codec_compare.py --data /tmp/unseen --files heart.tck bundles.tck dense.tck
    python benches/codec_compare.py --data /tmp/unseen --files dipole.tck \
        --tolerances 1e-3 1e-2
"""
import argparse
import os

import numpy as np
import nibabel as nib


def heart(rng, count, step=0.5, noise=0.05):
    a_in, c_in, wall = 25.0, 55.0, 10.0      # endocardium semi-axes, wall (mm)
    fibres = []
    while len(fibres) < count:
        e = rng.uniform(0.02, 0.98)          # transmural depth
        theta = rng.uniform(np.pi / 2 + 0.05, np.pi - 0.25)
        phi = rng.uniform(0, 2 * np.pi)
        length = rng.uniform(20, 150)
        wobble = 0.0
        pts = []
        s = 0.0
        while s < length:
            a, c = a_in + e * wall, c_in + e * wall
            st, ct = np.sin(theta), np.cos(theta)
            p = np.array([a * st * np.cos(phi), a * st * np.sin(phi), c * ct])
            pts.append(p)
            # |dp/dphi| and |dp/dtheta| on the ellipsoid of depth e.
            d_phi = a * st
            d_theta = np.hypot(a * ct, c * st)
            alpha = np.radians(60.0 - 120.0 * e) + wobble
            phi += step * np.cos(alpha) / max(d_phi, 1e-6)
            theta += step * np.sin(alpha) / d_theta
            e = np.clip(e + rng.normal(0, 0.002), 0.0, 1.0)
            wobble = 0.98 * wobble + rng.normal(0, 0.01)
            s += step
            if not (np.pi / 2 <= theta <= np.pi - 0.2):
                break
        if len(pts) >= 10:
            pts = np.array(pts) + rng.normal(0, noise, (len(pts), 3))
            fibres.append(pts.astype(np.float32))
    return fibres


def dipole(rng, count, step=0.02):
    # Tilted dipole m at the centre plus an axial quadrupole: B = -grad V.
    tilt = np.radians(25)
    m = np.array([np.sin(tilt), 0.0, np.cos(tilt)])
    q = 0.6

    def field(x):
        r = np.linalg.norm(x)
        rh = x / r
        b_dip = (3 * rh * (m @ rh) - m) / r ** 3
        # Axial quadrupole V = q P2(cos t) / r^3, B = -grad V.
        ct = rh[2]
        grad_r = -3 * q * 0.5 * (3 * ct ** 2 - 1) / r ** 4
        grad_t = q * 3 * ct / r ** 4                 # d/dcos(t) of V, / r
        ez = np.array([0.0, 0.0, 1.0])
        b_quad = -(grad_r * rh + grad_t * (ez - ct * rh))
        return b_dip + b_quad

    lines = []
    while len(lines) < count:
        u = rng.normal(size=3)
        x = 1.001 * u / np.linalg.norm(u)
        b = field(x)
        sign = 1.0 if b @ x > 0 else -1.0           # start outwards
        pts = [x.copy()]
        for _ in range(2000):
            h = step * np.linalg.norm(x)
            f = lambda y: sign * field(y) / np.linalg.norm(field(y))
            k1 = f(x)
            k2 = f(x + 0.5 * h * k1)
            k3 = f(x + 0.5 * h * k2)
            k4 = f(x + h * k3)
            x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            pts.append(x.copy())
            r = np.linalg.norm(x)
            if r < 1.0 or r > 2.5:
                break
        if len(pts) >= 3:
            lines.append(np.array(pts, dtype=np.float32))
    return lines


def bundles(rng, count, step=0.5):
    def field(x, c):
        return np.array([1.0, 0.3 * np.sin(x[0] / c[0] + c[1]), 0.3 * np.cos(x[0] / c[2] + c[3])])

    lines = []
    per = count // 12
    for b in range(12):
        c = rng.uniform([15, 0, 20, 0], [40, 6, 50, 6])
        rot = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        origin = rng.uniform(-40, 40, 3)
        for _ in range(per if b < 11 else count - 11 * per):
            x = rng.normal(0, 3, 3)
            x[0] = 0
            d = field(x, c)
            d /= np.linalg.norm(d)
            pts = [x.copy()]
            for _ in range(int(rng.uniform(40, 140) / step)):
                f = field(x, c)
                d = 0.8 * d + 0.2 * f / np.linalg.norm(f) + rng.normal(0, 0.06, 3)
                d /= np.linalg.norm(d)
                x = x + step * d
                pts.append(x.copy())
            lines.append((np.asarray(pts) @ rot.T + origin).astype(np.float32))
    return lines


def catmull_rom(knots, step):
    """Points every `step` (by arc length) along the Catmull-Rom spline
    through `knots`."""
    p = np.vstack([2 * knots[0] - knots[1], knots, 2 * knots[-1] - knots[-2]])
    t = np.linspace(0, 1, 20, endpoint=False)[:, None]
    dense = []
    for i in range(1, len(p) - 2):
        p0, p1, p2, p3 = p[i - 1], p[i], p[i + 1], p[i + 2]
        dense.append(0.5 * (2 * p1 + (p2 - p0) * t + (2 * p0 - 5 * p1 + 4 * p2 - p3) * t ** 2
                            + (3 * p1 - p0 - 3 * p2 + p3) * t ** 3))
    dense.append(knots[-1:])
    d = np.vstack(dense)
    s = np.concatenate([[0], np.cumsum(np.linalg.norm(np.diff(d, axis=0), axis=1))])
    at = np.linspace(0, s[-1], max(2, int(round(s[-1] / step)) + 1))
    return np.stack([np.interp(at, s, d[:, a]) for a in range(3)], -1).astype(np.float32)


def save(path, curves):
    t = nib.streamlines.Tractogram(curves, affine_to_rasmm=np.eye(4))
    nib.streamlines.save(t, path)
    n = sum(len(c) for c in curves)
    print(f"{path}: {len(curves)} curves, {n} points")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("-o", "--output", required=True, help="folder to write into")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--heart", type=int, default=3000, help="fibres")
    ap.add_argument("--dipole", type=int, default=2000, help="field lines")
    ap.add_argument("--heart-step", type=float, default=0.5, help="mm")
    ap.add_argument("--heart-noise", type=float, default=0.05, help="mm per coordinate")
    ap.add_argument("--dipole-step", type=float, default=0.02, help="of the radius")
    ap.add_argument("--bundles", type=int, default=3000, help="streamlines")
    ap.add_argument("--dense-step", type=float, default=0.2, help="mm")
    args = ap.parse_args()
    os.makedirs(args.output, exist_ok=True)
    rng = np.random.default_rng(args.seed)
    save(os.path.join(args.output, "heart.tck"), heart(rng, args.heart, args.heart_step, args.heart_noise))
    save(os.path.join(args.output, "dipole.tck"), dipole(rng, args.dipole, args.dipole_step))
    tracked = bundles(rng, args.bundles)
    save(os.path.join(args.output, "bundles.tck"), tracked)
    knots = [c[::4].astype(np.float64) for c in tracked[::2] if len(c) >= 8]
    save(os.path.join(args.output, "dense.tck"), [catmull_rom(k, args.dense_step) for k in knots])


if __name__ == "__main__":
    main()
