#!/usr/bin/env python3
"""Native load test: one densemap-server, N robot processes and M query-client processes on DDS loopback.

Reports scans sent / processed / dropped per robot, publish-to-map latency p50/p99, query round trip
p50/p99 per query kind, and the server's CPU and resident memory over time. Exits 1 when a bound given on
the command line is broken (for CI), 2 on a usage or start-up error.

  docker/load_test.py --robots 2 --rate 10 --source sim:scans=20,beams=32,columns=512 \
      --query-clients 1 --duration 20 --max-dropped 0 --max-latency-p99-ms 1000
"""
import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def find_binary(name, build_dir):
    for path in (os.path.join(build_dir, sub, name) for sub in ("server", "client")):
        if os.path.exists(path):
            return path
    installed = os.path.join("/usr/local/bin", name)
    if os.path.exists(installed):
        return installed
    sys.exit(f"load_test: {name} not found under {build_dir}; build first (./tools/build.sh)")


def proc_sample(pid, clock_ticks):
    """CPU seconds used so far and resident bytes of a process, from /proc."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    cpu = (int(fields[11]) + int(fields[12])) / clock_ticks  # utime + stime
    with open(f"/proc/{pid}/statm") as f:
        rss = int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    return cpu, rss


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robots", type=int, default=2, help="robot processes (default 2)")
    ap.add_argument("--rate", type=float, default=10.0, help="scans per second per robot (default 10)")
    ap.add_argument("--source", default="sim", help="scan source for every robot (default: the simulator)")
    ap.add_argument("--robot-offset", default="0,30,0", help="robot k's scans shifted by k times x,y,z")
    ap.add_argument("--query-clients", type=int, default=1, help="query-client processes (default 1)")
    ap.add_argument("--query-points", type=int, default=1000, help="points per query (default 1000)")
    ap.add_argument("--query-rate", type=float, default=20.0, help="queries per second per client (default 20)")
    ap.add_argument("--duration", type=float, default=20.0, help="seconds of load (default 20)")
    ap.add_argument("--domain", type=int, default=91, help="DDS domain id (default 91)")
    ap.add_argument("--resolution", type=float, default=0.2, help="map resolution (default 0.2)")
    ap.add_argument("--server-args", default="", help="extra densemap-server flags")
    ap.add_argument("--build-dir", default=os.path.join(ROOT, "build"))
    ap.add_argument("--json", metavar="FILE", help="write the report as JSON here")
    ap.add_argument("--max-dropped", type=int, default=None, help="bound: dropped scans over all robots")
    ap.add_argument("--max-latency-p99-ms", type=float, default=None, help="bound: publish-to-map p99")
    ap.add_argument("--max-query-p99-ms", type=float, default=None, help="bound: query round trip p99")
    ap.add_argument("--max-rss-growth", type=float, default=None,
                    help="bound: resident memory growth after the first minute (or third), as a fraction")
    a = ap.parse_args()

    server_bin = find_binary("densemap-server", a.build_dir)
    replay_bin = find_binary("densemap-replay", a.build_dir)
    dds = ["--domain", str(a.domain), "--loopback"]
    work = tempfile.mkdtemp(prefix="densemap_load_")
    log = open(os.path.join(work, "server.log"), "w")
    server = subprocess.Popen([server_bin, *dds, "--resolution", str(a.resolution), "--statistics-period", "1",
                               *a.server_args.split()], stdout=log, stderr=subprocess.STDOUT)
    procs = []
    samples = []
    try:
        time.sleep(1.0)
        if server.poll() is not None:
            sys.exit(f"load_test: densemap-server exited at start (log: {work}/server.log)")
        loops = 1000000  # robots loop over the source; --max-scans ends them after `duration` seconds
        scans = max(1, int(a.duration * a.rate))
        for k in range(a.robots):
            summary = os.path.join(work, f"robot-{k}.json")
            # Robot k replays the source in a loop on its own stretch of road (k times the offset), `scans`
            # scans in `duration` seconds.
            cmd = [replay_bin, *dds, "--source", a.source, "--rate", str(a.rate), "--robot-prefix", "load",
                   "--first-robot", str(k), "--robot-offset", a.robot_offset, "--loops", str(loops),
                   "--max-scans", str(scans), "--summary-json", summary, "--log-level", "warn"]
            procs.append(("robot", k, summary, subprocess.Popen(cmd, stdout=subprocess.DEVNULL)))
        for c in range(a.query_clients):
            summary = os.path.join(work, f"query-{c}.json")
            cmd = [replay_bin, *dds, "--robots", "0", "--duration", str(a.duration), "--query-clients", "1",
                   "--query-points", str(a.query_points), "--query-rate", str(a.query_rate),
                   "--summary-json", summary, "--log-level", "warn"]
            procs.append(("query", c, summary, subprocess.Popen(cmd, stdout=subprocess.DEVNULL)))
        ticks = os.sysconf("SC_CLK_TCK")
        t0 = time.time()
        last_cpu = None
        while any(p.poll() is None for _, _, _, p in procs):
            cpu, rss = proc_sample(server.pid, ticks)
            now = time.time() - t0
            if last_cpu is not None:
                samples.append({"t": round(now, 1), "cpu_cores": round((cpu - last_cpu[1]) / (now - last_cpu[0]), 2),
                                "rss_mb": round(rss / 1e6, 1)})
            last_cpu = (now, cpu)
            time.sleep(1.0)
    finally:
        for _, _, _, p in procs:
            if p.poll() is None:
                p.terminate()
        server.send_signal(signal.SIGINT)
        try:
            server.wait(timeout=60)
        except subprocess.TimeoutExpired:
            server.kill()

    report = {"robots": [], "queries": [], "server": samples, "work_dir": work}
    for kind, idx, summary, p in procs:
        data = json.load(open(summary)) if os.path.exists(summary) else {}
        data["exit_status"] = p.returncode
        (report["robots"] if kind == "robot" else report["queries"]).append(data)
    dropped = sum(r.get("scans_dropped", 0) for r in report["robots"])
    lat99 = max((r.get("latency_p99_ms", 0) for r in report["robots"]), default=0)
    q99 = max((q.get("query_p99_ms", 0) for q in report["queries"]), default=0)
    steady = [s["rss_mb"] for s in samples if s["t"] >= min(60.0, a.duration / 3)]
    growth = (max(steady) - steady[0]) / steady[0] if len(steady) > 1 and steady[0] > 0 else 0.0
    report["summary"] = {"dropped": dropped, "latency_p99_ms": lat99, "query_p99_ms": q99,
                         "rss_growth": round(growth, 4),
                         "cpu_cores_mean": round(sum(s["cpu_cores"] for s in samples) / max(1, len(samples)), 2)}

    print(f"{'robot':<10}{'sent':>8}{'processed':>11}{'dropped':>9}{'rejected':>10}{'p50 ms':>9}{'p99 ms':>9}")
    for i, r in enumerate(report["robots"]):
        print(f"{'load' + str(i):<10}{r.get('scans_sent', 0):>8}{r.get('scans_processed', 0):>11}"
              f"{r.get('scans_dropped', 0):>9}{r.get('scans_rejected', 0):>10}{r.get('latency_p50_ms', 0):>9.1f}"
              f"{r.get('latency_p99_ms', 0):>9.1f}")
    for i, q in enumerate(report["queries"]):
        print(f"query client {i}: {q.get('queries', 0)} point queries of {a.query_points}, round trip p50 "
              f"{q.get('query_p50_ms', 0):.2f} ms, p99 {q.get('query_p99_ms', 0):.2f} ms")
    if samples:
        print(f"server: {report['summary']['cpu_cores_mean']} cores on average, resident "
              f"{samples[0]['rss_mb']} -> {samples[-1]['rss_mb']} MB (growth after warm-up {growth:.1%})")
    if a.json:
        json.dump(report, open(a.json, "w"), indent=2)

    broken = []
    if a.max_dropped is not None and dropped > a.max_dropped:
        broken.append(f"{dropped} scans dropped (bound {a.max_dropped})")
    if a.max_latency_p99_ms is not None and lat99 > a.max_latency_p99_ms:
        broken.append(f"publish-to-map p99 {lat99:.1f} ms (bound {a.max_latency_p99_ms})")
    if a.max_query_p99_ms is not None and q99 > a.max_query_p99_ms:
        broken.append(f"query p99 {q99:.2f} ms (bound {a.max_query_p99_ms})")
    if a.max_rss_growth is not None and growth > a.max_rss_growth:
        broken.append(f"resident memory grew {growth:.1%} (bound {a.max_rss_growth:.1%})")
    if any(r.get("exit_status", 1) not in (0,) for r in report["robots"] + report["queries"]):
        broken.append("a client process failed (see its summary in " + work + ")")
    for b in broken:
        print("BOUND BROKEN:", b)
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main())
