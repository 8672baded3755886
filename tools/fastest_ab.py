#!/usr/bin/env python3
"""fastest against the best of the four, two builds side by side.
Usage: tools/fastest_ab.py OLD_DENSEMAP_BENCH NEW_DENSEMAP_BENCH [RUNS=2]
       tools/fastest_ab.py --verdict DENSEMAP_BENCH
Runs both builds in alternation on kitti00 0-9, hilti2023 0-29, sim:scans=60 and la3dm sim_structured
(from ../shared/data) with --method all --repeat 5 at 0.1-0.8 m, and prints per source and backend the
median time_vs_best_of_four, old->new. Raw figures and what fastest ran: /tmp/fastest_ab.json.
--verdict runs one build once on the same sources and prints, per cell, time_vs_best_of_four, the best's
own interquartile spread over the 5 repeats, and whether fastest was slower beyond it (SLOWER); then the
paired verdict: whether fastest was slower than one of the four in all 5 repetitions (sign test, p < 5%;
PAIRED-SLOWER than which). The first compares with the least of four noisy medians, which is biased low;
the second has no such bias (eval/paired_timing.h)."""
import json,subprocess,sys,statistics as S
if len(sys.argv) < 3 or sys.argv[1] in ("-h", "--help"):
  print(__doc__); sys.exit(0 if len(sys.argv) > 1 and sys.argv[1] in ("-h", "--help") else 2)
from bench_sources import DATA, SOURCES as sources
def bench(exe,src,scans):
  cmd=[exe,"--no-octomap","--no-unnecessary","--json","--resolution","0.1,0.2,0.4,0.8","--method","all","--repeat","5","--source",src]
  if scans: cmd+=["--scans",scans]
  p=subprocess.run(cmd,capture_output=True,text=True)
  if p.returncode!=0:
    sys.exit("fastest_ab: %s failed (exit %d); is the data in %s?\n%s"%(" ".join(cmd),p.returncode,DATA,p.stderr[-2000:]))
  return list(map(json.loads,p.stdout.splitlines()))
FOUR=("baseline","superrays","culling","superrays+culling")
fixed_slower={}  # method -> cells where always running it would be measurably slower than another
def fixed_policies(rows):
  """What a fixed default would get: per cell, whether each of the four was slower than another one in all
  5 repetitions (the same paired sign test)."""
  by={(d["backend"],d["resolution"],d["method"]):d["total_ms_by_repeat"] for d in rows}
  for be,r in {(d["backend"],d["resolution"]) for d in rows}:
    for m in FOUR:
      a=by[(be,r,m)]
      worse=[o for o in FOUR if o!=m and all(x>y for x,y in zip(a,by[(be,r,o)])) and len(a)>=5]
      fixed_slower.setdefault(m,0)
      fixed_slower[m]+=bool(worse)
if sys.argv[1]=="--verdict":
  slower=paired=cells=0
  for name,src,scans in sources:
    rows=bench(sys.argv[2],src,scans)
    fixed_policies(rows)
    found={(d["backend"],d["resolution"]):d for d in rows if d["method"]=="fastest"}
    for be in ("grid","octree"):
      line=[]
      for r in (0.1,0.2,0.4,0.8):
        d=found[(be,r)]; cells+=1; slower+=d["slower_than_best_beyond_spread"]
        worse=d["measurably_slower_than"]; paired+=bool(worse)
        line.append("%.2f (%.1f%%)%s%s"%(d["time_vs_best_of_four"],100*d["best_of_four_spread"],
                                         " SLOWER" if d["slower_than_best_beyond_spread"] else "",
                                         " PAIRED-SLOWER than "+"+".join(worse) if worse else ""))
      print(name,be," / ".join(line),flush=True)
  print("slower than the best beyond its own spread: %d of %d cells"%(slower,cells))
  print("measurably slower than one of the four, paired over the 5 repetitions: %d of %d cells"%(paired,cells))
  for m in FOUR:
    print("  a fixed default of %s would be, by the same test: %d of %d cells"%(m,fixed_slower[m],cells))
  sys.exit(0)
old,new=sys.argv[1],sys.argv[2]
runs=int(sys.argv[3]) if len(sys.argv)>3 else 2
res={}
for name,src,scans in sources:
  for run in range(runs):
    order=[("old",old),("new",new)] if run%2==0 else [("new",new),("old",old)]
    for which,exe in order:
      for d in (d for d in bench(exe,src,scans) if d["method"]=="fastest"):
        res.setdefault((name,d["backend"],d["resolution"],which),[]).append(d["time_vs_best_of_four"])
        res.setdefault((name,d["backend"],d["resolution"],which+"_chosen"),[]).append(d["chosen"][0])
  for be in ("grid","octree"):
    line=[]
    for r in (0.1,0.2,0.4,0.8):
      o=S.median(res[(name,be,r,"old")]); n=S.median(res[(name,be,r,"new")])
      line.append("%.2f->%.2f"%(o,n))
    print(name,be," / ".join(line),flush=True)
json.dump({"|".join(map(str,k)):v for k,v in res.items()},open("/tmp/fastest_ab.json","w"))
