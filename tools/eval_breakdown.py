#!/usr/bin/env python3
"""Where two methods' AUC differ: reads densemap-eval --predictions-csv and splits the free test points by
their distance to the nearest occupied test point (a proxy for the distance to a surface). Per band it prints
the mean probability per method and the band's share of misordered (occupied, free) pairs, so the bands sum
to 1 - AUC (unknown answers count as 0.5, as in densemap-eval).

    tools/eval_breakdown.py predictions.csv
"""
import bisect
import csv
import math
import sys

BANDS = [0.0, 0.05, 0.1, 0.2, 0.4, 1.0, math.inf]


def main():
    if len(sys.argv) != 2 or sys.argv[1] in ("-h", "--help"):
        print(__doc__.strip())
        return 0 if len(sys.argv) == 2 else 2
    with open(sys.argv[1], newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        print("no test points in " + sys.argv[1], file=sys.stderr)
        return 1
    methods = [c for c in rows[0].keys() if c not in ("x", "y", "z", "occupied")]
    pts = [(float(r["x"]), float(r["y"]), float(r["z"])) for r in rows]
    occupied = [r["occupied"] == "1" for r in rows]
    # Nearest occupied test point through a 0.25 m voxel hash (search grows ring by ring up to 2 m).
    cell = 0.25
    grid = {}
    for p, o in zip(pts, occupied):
        if o:
            grid.setdefault(tuple(int(math.floor(c / cell)) for c in p), []).append(p)

    def nearest(p):
        key = tuple(int(math.floor(c / cell)) for c in p)
        best = math.inf
        for ring in range(0, 9):
            for dx in range(-ring, ring + 1):
                for dy in range(-ring, ring + 1):
                    for dz in range(-ring, ring + 1):
                        if max(abs(dx), abs(dy), abs(dz)) != ring:
                            continue
                        for q in grid.get((key[0] + dx, key[1] + dy, key[2] + dz), ()):
                            d = math.dist(p, q)
                            if 0 < d < best:
                                best = d
            if best <= ring * cell:
                break
        return best

    def prob(r, m):
        return float(r[m]) if r[m] != "" else 0.5

    occ_sorted = {m: sorted(prob(r, m) for r, o in zip(rows, occupied) if o) for m in methods}
    free_idx = [i for i, o in enumerate(occupied) if not o]
    dist = {i: nearest(pts[i]) for i in free_idx}
    print("free test points by distance to the nearest occupied test point (m):")
    print("%-12s %6s  " % ("band", "n") + "  ".join("%-22s" % (m + " mean / misordered") for m in methods))
    for lo, hi in zip(BANDS[:-1], BANDS[1:]):
        band = [i for i in free_idx if lo <= dist[i] < hi]
        cols = []
        for m in methods:
            occ = occ_sorted[m]
            mis = 0.0
            for i in band:
                p = prob(rows[i], m)
                below = bisect.bisect_left(occ, p)
                ties = bisect.bisect_right(occ, p) - below
                mis += (below + ties / 2) / len(occ)
            mean = sum(prob(rows[i], m) for i in band) / max(1, len(band))
            cols.append("%.3f / %.4f" % (mean, mis / len(free_idx)))
        print("%-12s %6d  " % ("%g-%g" % (lo, hi), len(band)) + "  ".join("%-22s" % c for c in cols))
    return 0


if __name__ == "__main__":
    sys.exit(main())
