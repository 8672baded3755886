#!/usr/bin/env python3
"""Each exact update method's time per scan, against the baseline's, with what the scans are.
Usage: tools/method_table.py DENSEMAP_BENCH [REPEAT=3]
Runs densemap-bench --method all --repeat REPEAT at 0.1-0.8 m on kitti00 0-9, hilti2023 0-29,
sim:scans=60 and la3dm sim_structured (from ../shared/data) and prints per source, backend and resolution:
the fastest concrete method, the baseline's ms per scan, each other method's time as a ratio to the
baseline's (medians over the repeats), and the scans' shape: points per super ray, cells walked per ray
(the baseline's), points per scan. Raw rows: /tmp/method_table.json."""
import json, subprocess, sys
if len(sys.argv) < 2 or sys.argv[1] in ("-h", "--help"):
  print(__doc__); sys.exit(0 if len(sys.argv) > 1 else 2)
exe = sys.argv[1]
repeat = sys.argv[2] if len(sys.argv) > 2 else "3"
from bench_sources import DATA, SOURCES as sources
out = []
print("source    backend res best               | base ms  culling superrays sr+culling fastest | pts/super ray cells/ray pts/scan")
for name, src, scans in sources:
  cmd = [exe, "--no-octomap", "--no-unnecessary", "--json", "--resolution", "0.1,0.2,0.4,0.8", "--method", "all",
         "--repeat", repeat, "--source", src]
  if scans: cmd += ["--scans", scans]
  p = subprocess.run(cmd, capture_output=True, text=True)
  if p.returncode != 0:
    sys.exit("method_table: %s failed (exit %d); is the data in %s?\n%s" % (" ".join(cmd), p.returncode, DATA, p.stderr[-2000:]))
  rows = [json.loads(l) for l in p.stdout.splitlines() if l.startswith("{")]
  for r in rows: r["source"] = name
  out += rows
  cells = {}
  for r in rows: cells.setdefault((r["backend"], r["resolution"]), {})[r["method"]] = r
  for (be, res), m in sorted(cells.items()):
    ms = {k: 1000.0 / v["fps"] for k, v in m.items()}
    best = min((k for k in ms if k != "fastest"), key=ms.get)
    b = m["baseline"]
    print("%-9s %-7s %.1f %-18s | %7.1f  %7.2f %9.2f %10.2f %7.2f | %13.2f %9.0f %8.0f" % (
        name, be, res, best, ms["baseline"], ms["culling"] / ms["baseline"], ms["superrays"] / ms["baseline"],
        ms["superrays+culling"] / ms["baseline"], ms["fastest"] / ms["baseline"], m["superrays"]["points_per_ray"],
        b["traversed"] / max(1, b["rays"]), b["points"] / max(1, b["scans"])), flush=True)
json.dump(out, open("/tmp/method_table.json", "w"))
