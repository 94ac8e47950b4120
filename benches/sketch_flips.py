#!/usr/bin/env python3
"""Compares two runs of `cargo bench --bench sketch_noise` lift by lift.

    python3 benches/sketch_flips.py BEFORE.txt AFTER.txt

A lift is right when it has the drawing's helix count and its depth is
within 2x of the exact drawing's. On noisy drawings about one lift in twenty
is decided by last-bit rounding (docs/reference.md, sketch section), so a
change is judged by how many lifts it turns right and how many wrong, over
many seeds (SKETCH_SEEDS=48 SKETCH_NOISES=1e-3,3e-3: 480 lifts), not by
single seeds. Prints the totals, the flips each way, and per drawing and
noise level the counts and mean times before and after.
"""
import sys

HELICES = {"two coils": 2, "1 curls": 1, "2 curls": 2, "3 curls": 3, "4 curls": 4}


def load(path):
    rows = {}
    with open(path) as f:
        for line in f:
            cells = [c.strip() for c in line.split("|")[1:-1]]
            # The per-lift rows: nine cells, the third a seed.
            if len(cells) != 9 or not cells[2].isdigit():
                continue
            drawing, noise, seed = cells[0], cells[1], int(cells[2])
            count = int(cells[3]) == HELICES[drawing]
            within = 0.5 <= float(cells[4]) <= 2.0
            rows[(drawing, noise, seed)] = (count and within, float(cells[8]))
    return rows


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    before, after = load(sys.argv[1]), load(sys.argv[2])
    common = sorted(set(before) & set(after))
    if not common:
        sys.exit("no lifts in common")
    worse = [k for k in common if before[k][0] and not after[k][0]]
    better = [k for k in common if not before[k][0] and after[k][0]]
    right = lambda rows: sum(rows[k][0] for k in common)
    print(f"{len(common)} lifts: right {right(before)} -> {right(after)}; "
          f"right -> wrong {len(worse)}, wrong -> right {len(better)}")
    groups = sorted({(k[0], k[1]) for k in common})
    for drawing, noise in groups:
        ks = [k for k in common if (k[0], k[1]) == (drawing, noise)]
        mean = lambda rows: sum(rows[k][1] for k in ks) / len(ks)
        print(f"  {drawing:10s} {noise:6s} right {sum(before[k][0] for k in ks):3d} -> "
              f"{sum(after[k][0] for k in ks):3d} of {len(ks):3d}   "
              f"ms {mean(before):6.1f} -> {mean(after):6.1f}")
    for k in worse:
        print("  right -> wrong:", *k)
    for k in better:
        print("  wrong -> right:", *k)


if __name__ == "__main__":
    main()
