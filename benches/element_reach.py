#!/usr/bin/env python3
"""How far one element reaches along curves within a tolerance: a 3D circle
(the arc codec's element) against a helix (circle plus pitch), offline.

A design probe for a helical element kind (issue 19, the hair at 0.5 mm):
windows of each curve are fitted by least squares (scipy), each grown from
where the last ended as far as the fit's worst vertex stays within
FRAC * T (the rest of T left for quantisation), galloping then bisecting;
the output is the mean number of windows a curve takes per model, by the
curves' mean turn per step. The distance to a helix is approximated in
cylindrical coordinates about its axis (radial and pitch-direction parts),
good to a few percent for the windows that matter.

    python benches/element_reach.py /tmp/hair.tck --tolerance 0.5 --sample 12 --only curly

(`strandfit convert ../shared/data/hair/synthetic_hair.hair -o /tmp/hair.tck`.)
Measured 2026-11-29 on 12 curly strands of the hair (mean turn > 15 deg):
26.4 circle windows a strand, 14.1 helix windows (0.53x). Slow (scipy per
window): minutes for a dozen curves.
"""
import argparse
import numpy as np
import nibabel as nib
from scipy.optimize import least_squares

FRAC = 0.8
CLASSES = (("curly", 15.0, 999.0), ("wavy", 5.0, 15.0), ("straight", 0.0, 5.0))


def mean_turn(s):
    d = np.diff(s, axis=0)
    d /= np.linalg.norm(d, axis=1)[:, None]
    return np.degrees(np.arccos(np.clip((d[1:] * d[:-1]).sum(1), -1, 1))).mean()


def frame(n):
    n = n / np.linalg.norm(n)
    a = np.array([1.0, 0, 0]) if abs(n[0]) < 0.9 else np.array([0, 1.0, 0])
    u = np.cross(n, a)
    u /= np.linalg.norm(u)
    return u, np.cross(n, u), n


def unit(th, ph):
    return np.array([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)])


def circle_dist(x, p):
    c, n, r = x[:3], unit(x[3], x[4]), x[5]
    q = p - c
    h = q @ n
    rho = np.linalg.norm(q - np.outer(h, n), axis=1)
    return np.sqrt((rho - r) ** 2 + h ** 2)


def helix_dist(x, p):
    c, n, r, pitch, z0 = x[:3], unit(x[3], x[4]), x[5], x[6], x[7]
    u, v, _ = frame(n)
    q = p - c
    th = np.unwrap(np.arctan2(q @ v, q @ u))
    rho = np.hypot(q @ u, q @ v)
    dz = q @ n - (pitch * th + z0)
    return np.sqrt((rho - r) ** 2 + (dz * r / np.hypot(r, pitch)) ** 2)


def fit_circle(p):
    c0 = p.mean(0)
    n = np.linalg.svd(p - c0)[2][2]
    u, v, _ = frame(n)
    q = p - c0
    xy = np.c_[q @ u, q @ v]
    sol = np.linalg.lstsq(np.c_[2 * xy, np.ones(len(p))], (xy ** 2).sum(1), rcond=None)[0]
    r = np.sqrt(max(sol[2] + sol[0] ** 2 + sol[1] ** 2, 1e-9))
    r = r if np.isfinite(r) and r < 1e4 else 1e4
    x0 = np.r_[c0 + sol[0] * u + sol[1] * v, np.arccos(np.clip(n[2], -1, 1)), np.arctan2(n[1], n[0]), r]
    x = least_squares(lambda x: circle_dist(x, p), x0, method="trf", max_nfev=200).x
    return x, circle_dist(x, p).max()


def fit_helix(p, xc):
    best = np.inf
    n = unit(xc[3], xc[4])
    u, v, _ = frame(n)
    q = p - xc[:3]
    th = np.unwrap(np.arctan2(q @ v, q @ u))
    for pitch0 in (0.0, 0.3 * xc[5], -0.3 * xc[5]):
        x0 = np.r_[xc[:6], pitch0, (q @ n - pitch0 * th).mean()]
        x = least_squares(lambda x: helix_dist(x, p), x0, method="trf", max_nfev=300).x
        best = min(best, helix_dist(x, p).max())
    return best


def windows(s, model, tol):
    def fits(i, j):
        p = s[i:j + 1]
        if len(p) <= 3:
            return True
        xc, e = fit_circle(p)
        if e <= FRAC * tol or model == "circle":
            return e <= FRAC * tol
        return fit_helix(p, xc) <= FRAC * tol

    i, n, count = 0, len(s), 0
    while i < n - 1:
        lo, hi = i + 1, min(n - 1, i + 4)
        while hi < n - 1 and fits(i, hi):
            lo, hi = hi, min(n - 1, i + 2 * (hi - i))
        if fits(i, hi):
            lo = hi
        else:
            while hi - lo > 1:
                m = (lo + hi) // 2
                lo, hi = (m, hi) if fits(i, m) else (lo, m)
        count += 1
        i = lo
    return count


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("file", help="a .tck file")
    ap.add_argument("--tolerance", type=float, default=0.5)
    ap.add_argument("--sample", type=int, default=12, help="curves per class")
    ap.add_argument("--only", choices=[c[0] for c in CLASSES], help="one class")
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args()
    curves = [np.asarray(s, float) for s in nib.streamlines.load(a.file).streamlines]
    curves = [s for s in curves if len(s) >= 3]
    turns = np.array([mean_turn(s) for s in curves])
    rng = np.random.default_rng(a.seed)
    for name, lo, hi in CLASSES:
        if a.only and name != a.only:
            continue
        idx = np.where((turns >= lo) & (turns < hi))[0]
        if len(idx) == 0:
            print(f"{name}: no curves")
            continue
        pick = rng.choice(idx, min(a.sample, len(idx)), replace=False)
        c = np.mean([windows(curves[k], "circle", a.tolerance) for k in pick])
        h = np.mean([windows(curves[k], "helix", a.tolerance) for k in pick])
        print(f"{name} ({lo:g}-{hi:g} deg a step, {len(idx)} curves, {len(pick)} sampled): "
              f"circle {c:.1f} windows a curve, helix {h:.1f} ({h / c:.2f}x)", flush=True)


if __name__ == "__main__":
    main()
