"""Write examples/curls.json: 12 smooth Bezier splines (hair-like curls,
a spring, a planar S-curve, a straight strand), as Hermite cubics of analytic
curves. Deterministic; standard library only.  Usage: python3 make_curls.py"""
import json, math, os

def hermite_spline(pos, u0, u1, segments):
    h = (u1 - u0) / segments
    def vel(u):
        e = 1e-6
        a, b = pos(u - e), pos(u + e)
        return [(b[i] - a[i]) / (2 * e) for i in range(3)]
    cps = [pos(u0)]
    for k in range(segments):
        a, b = u0 + k * h, u0 + (k + 1) * h
        pa, pb, va, vb = pos(a), pos(b), vel(a), vel(b)
        cps.append([pa[i] + va[i] * h / 3 for i in range(3)])
        cps.append([pb[i] - vb[i] * h / 3 for i in range(3)])
        cps.append(pb)
    return [[round(c, 9) for c in p] for p in cps]

splines = []
for k in range(9):
    r = 4.0 + 1.5 * math.sin(k)          # curl radius, mm
    pitch = 3.0 + k                       # mm per turn
    hand = 1 if k % 3 else -1             # a few left-handed curls
    droop = 0.02 * k
    def curl(u, r=r, pitch=pitch, hand=hand, droop=droop, k=k):
        return [r * math.cos(u) + 10 * k, hand * r * math.sin(u), pitch * u / (2 * math.pi) - droop * u * u]
    splines.append({"id": f"curl{k}", "control_points": hermite_spline(curl, 0.0, 6 * math.pi, 24)})
splines.append({"id": "spring", "control_points": hermite_spline(
    lambda u: [3 * math.cos(u), 3 * math.sin(u), 0.5 * u], 0.0, 10 * math.pi, 40)})
splines.append({"id": "s-curve", "control_points": hermite_spline(
    lambda u: [u, 5 * math.sin(u / 4), 0.0], 0.0, 8 * math.pi, 16)})
splines.append({"id": "straight", "control_points": [[0, 0, 0], [1, 1, 1], [2, 2, 2], [3, 3, 3], [5, 5, 5], [6, 6, 6], [9, 9, 9]]})
out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "curls.json")
with open(out, "w") as f:
    json.dump({"splines": splines}, f, indent=None, separators=(",", ":"))
print(out, len(splines), "splines")
