#!/usr/bin/env python3
"""Two builds of densemap-bench side by side: runs them in alternation (A B, B A, ...) on the same
scans and prints, per backend and resolution, the median generation time (proc_ms) and time per scan of
each, and their ratio. For a code change's effect on one method: build the old commit into one directory,
the new into another, and compare. The machine's noise hits both builds alike; report the ratios."""
import argparse
import json
import statistics
import subprocess
import sys


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--a", required=True, help="densemap-bench of the baseline build (the 'old' one)")
    ap.add_argument("--b", required=True, help="densemap-bench of the changed build")
    ap.add_argument("--source", required=True, help="scan source, as densemap-bench --source")
    ap.add_argument("--scans", default="", help="scan range, as densemap-bench --scans")
    ap.add_argument("--resolution", default="0.2", help="comma list of voxel sizes (m)")
    ap.add_argument("--backend", default="grid", help="grid or octree")
    ap.add_argument("--method", default="superrays+culling", help="one method")
    ap.add_argument("--runs", type=int, default=4, help="runs of each build (alternating order)")
    args = ap.parse_args()
    times: dict = {}
    for run in range(args.runs):
        order = ("a", "b") if run % 2 == 0 else ("b", "a")
        for which in order:
            exe = args.a if which == "a" else args.b
            cmd = [exe, "--no-octomap", "--no-unnecessary", "--json", "--resolution", args.resolution,
                   "--backend", args.backend, "--method", args.method, "--source", args.source]
            if args.scans:
                cmd += ["--scans", args.scans]
            p = subprocess.run(cmd, capture_output=True, text=True)
            if p.returncode != 0:
                print(f"ab_bench: {exe} failed ({p.returncode}): {p.stderr.strip()[-400:]}", file=sys.stderr)
                return 1
            for line in p.stdout.splitlines():
                d = json.loads(line)
                t = times.setdefault((d["resolution"], which), {"proc": [], "scan": []})
                t["proc"].append(d["proc_ms"])
                t["scan"].append(1000.0 / d["fps"])
            print(f"run {run + 1}/{args.runs} of {which} done", file=sys.stderr)
    for res in sorted({k[0] for k in times}):
        a, b = times[(res, "a")], times[(res, "b")]
        pa, pb = statistics.median(a["proc"]), statistics.median(b["proc"])
        sa, sb = statistics.median(a["scan"]), statistics.median(b["scan"])
        print(f"{args.method} {args.backend} {res} m: generation a {pa:.3f} b {pb:.3f} ms (b/a {pb / pa:.2f}); "
              f"per scan a {sa:.3f} b {sb:.3f} ms (b/a {sb / sa:.2f}); medians of {args.runs} alternating runs")
    return 0


if __name__ == "__main__":
    sys.exit(main())
