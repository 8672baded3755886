#!/usr/bin/env python3
"""Load test for densemap-server: N robots publishing scans and M query clients, with a report and bounds.

Two ways to run it:
  native (default)  starts one densemap-server, N robot processes and M query-client processes on DDS
                    loopback, on this host;
  --attach DIR      (the compose load-test runner) starts nothing: the server, robots and query clients
                    are other containers; it samples the server process it can see (compose shares the
                    server's PID namespace with the runner) and reads the clients' JSON summaries from DIR.

Report: scans sent / processed / dropped per robot, publish-to-map latency p50/p99, query round trip
p50/p99 per query kind, and the server's CPU and resident memory over time. Exit status 1 when a bound
given on the command line is broken (for CI), 2 on a usage or start-up error.

  docker/load_test.py --robots 2 --rate 10 --source sim:scans=20,beams=32,columns=512 \\
      --query-clients 4 --query-mix points,points,box,ray --duration 20 --max-dropped 0

--secure runs every program with DDS-Security: native, it makes a keystore with tools/make-security.sh
(server, robot-1..N, client-1..M) and gives each program its own identity; attached, it only records that
the containers were secure. The report then also holds each robot's time to be authenticated and matched.
"""
import argparse
import glob
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
    for prefix in (os.path.dirname(os.path.abspath(__file__)), "/usr/local/bin", "/usr/bin"):
        if os.path.exists(os.path.join(prefix, name)):
            return os.path.join(prefix, name)
    sys.exit(f"load_test: {name} not found under {build_dir}; build first (./tools/build.sh)")


def processes(name):
    """(pid, argv) of every process whose command is `name` (with pid: host, every one of the machine)."""
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/comm") as f:
                if f.read().strip() != name[:15]:
                    continue
            with open(f"/proc/{entry}/cmdline") as f:
                yield int(entry), f.read().rstrip("\0").split("\0")
        except OSError:
            continue


def find_pid(name, match=None):
    """The pid of the first process whose command is `name` and, if given, whose command line contains
    `match` (the server, in attach mode: with pid: host the runner sees every process of the machine)."""
    for pid, args in processes(name):
        if match is None or match in " ".join(args):
            return pid
    return None


def proc_sample(pid, clock_ticks):
    """CPU seconds used so far and resident bytes of a process, from /proc (None once it has gone)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        with open(f"/proc/{pid}/statm") as f:
            rss = int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except OSError:
        return None
    return (int(fields[11]) + int(fields[12])) / clock_ticks, rss  # utime + stime


def resident_parts(pid):
    """What the resident memory is made of, in MB, from /proc/PID/status: anonymous (heap, stacks, arenas),
    file-backed (the program and its libraries) and shared memory (Fast DDS's shared-memory transport
    segments, resident once touched). Empty once the process has gone."""
    parts = {}
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                key, _, value = line.partition(":")
                if key in ("RssAnon", "RssFile", "RssShmem"):
                    parts[key[3:].lower() + "_mb"] = round(int(value.split()[0]) / 1e3, 1)  # kB
    except OSError:
        return {}
    return parts


def thread_cpu(pid, clock_ticks):
    """CPU seconds so far per thread name of a process (threads we start are named dm-<role>; OpenMP
    workers inherit their creator's name; unnamed library threads carry the program's name)."""
    out = {}
    try:
        tids = os.listdir(f"/proc/{pid}/task")
    except OSError:
        return out
    for tid in tids:
        try:
            with open(f"/proc/{pid}/task/{tid}/stat") as f:
                data = f.read()
        except OSError:
            continue
        name = data[data.index("(") + 1:data.rindex(")")]
        fields = data.rsplit(")", 1)[1].split()
        out[name] = out.get(name, 0.0) + (int(fields[11]) + int(fields[12])) / clock_ticks
    return out


def machine_busy():
    """(busy, total) jiffies of all cores since boot, from /proc/stat."""
    with open("/proc/stat") as f:
        v = [int(x) for x in f.readline().split()[1:]]
    idle = v[3] + v[4]
    return sum(v) - idle, sum(v)


def percentile(values, q):
    if not values:
        return 0.0
    v = sorted(values)
    return v[min(len(v) - 1, int(q * len(v)))]


class Sampler:
    """Server CPU (cores) and resident memory once a second."""

    def __init__(self, pid):
        self.pid, self.ticks, self.samples, self.t0, self.last = pid, os.sysconf("SC_CLK_TCK"), [], time.time(), None
        self.threads_start, self.threads_end = thread_cpu(pid, self.ticks), {}
        self.machine_start, self.machine_end = machine_busy(), None
        self.clients = {}  # pid -> CPU seconds last seen

    def watch_clients(self, pids):
        for pid in pids:
            s = proc_sample(pid, self.ticks)
            if s is not None:
                self.clients[pid] = s[0]

    def breakdown(self):
        """Where the CPU went over the run: the server per thread name, the clients, the whole machine."""
        elapsed = max(1e-9, self.last[0]) if self.last else 1e-9
        threads = {k: round((v - self.threads_start.get(k, 0.0)) / elapsed, 3)
                   for k, v in self.threads_end.items()}
        threads = dict(sorted(((k, v) for k, v in threads.items() if v >= 0.005), key=lambda kv: -kv[1]))
        busy = total = 0
        if self.machine_end:
            busy = self.machine_end[0] - self.machine_start[0]
            total = self.machine_end[1] - self.machine_start[1]
        return {"server_threads_cores": threads, "clients_cores": round(sum(self.clients.values()) / elapsed, 3),
                "machine_busy_fraction": round(busy / total, 3) if total else 0.0, "cores": os.cpu_count()}

    def sample(self):
        s = proc_sample(self.pid, self.ticks)
        if s is None:
            return
        now = time.time() - self.t0
        if self.last is not None and now > self.last[0]:
            self.samples.append({"t": round(now, 1), "cpu_cores": round((s[0] - self.last[1]) / (now - self.last[0]), 2),
                                 "rss_mb": round(s[1] / 1e6, 1), **resident_parts(self.pid)})
        self.last = (now, s[0])
        self.threads_end = thread_cpu(self.pid, self.ticks) or self.threads_end
        self.machine_end = machine_busy()


def run_native(a, work):
    """Starts the server and the clients, samples the server until the clients end, stops the server."""
    server_bin = find_binary("densemap-server", a.build_dir)
    replay_bin = find_binary("densemap-replay", a.build_dir)
    dds = ["--domain", str(a.domain), "--loopback"]
    identity = lambda name: []
    if a.secure:
        keystore = os.path.join(work, "security")
        subprocess.run([os.path.join(ROOT, "tools", "make-security.sh"), keystore, "--robots", str(max(1, a.robots)),
                        "--clients", str(max(1, a.query_clients)), "--days", "2"], check=True,
                       stdout=subprocess.DEVNULL)
        identity = lambda name: ["--security-dir", os.path.join(keystore, name)]
    log = open(os.path.join(work, "server.log"), "w")
    server = subprocess.Popen([server_bin, *dds, *identity("server"), "--resolution", str(a.resolution),
                               "--statistics-period", "1", "--data-dir", os.path.join(work, "server-data"),
                               *a.server_args.split()], stdout=log, stderr=subprocess.STDOUT)
    procs = []
    sampler = Sampler(server.pid)
    try:
        time.sleep(1.0)
        if server.poll() is not None:
            print(f"load_test: densemap-server exited at start (log: {work}/server.log)", file=sys.stderr)
            sys.exit(2)
        scans = max(1, int(a.duration * a.rate))
        for k in range(a.robots):
            # Robot k loops over the source on its own stretch of road (k times the offset): `scans` scans in
            # `duration` seconds.
            cmd = [replay_bin, *dds, *identity(f"robot-{k + 1}"), "--source", a.source, "--rate", str(a.rate),
                   # secure: a robot identity sends only as its own name and NAME-<k>
                   "--robot-prefix", f"robot-{k + 1}" if a.secure else "load",
                   "--first-robot", str(k), "--robot-offset", a.robot_offset, "--loops", "1000000",
                   "--max-scans", str(scans), "--summary-json", os.path.join(work, f"robot-{k}.json"),
                   "--log-level", "warn"]
            procs.append(subprocess.Popen(cmd, stdout=subprocess.DEVNULL))
        kinds = a.query_mix.split(",")
        for c in range(a.query_clients):
            cmd = [replay_bin, *dds, *identity(f"client-{c + 1}"), "--robots", "0", "--duration", str(a.duration),
                   "--query-clients", "1",
                   "--query-kind", kinds[c % len(kinds)], "--query-points", str(a.query_points),
                   "--query-rate", str(a.query_rate), "--summary-json", os.path.join(work, f"query-{c}.json"),
                   "--log-level", "warn"]
            procs.append(subprocess.Popen(cmd, stdout=subprocess.DEVNULL))
        next_sample = time.time()
        perf = None
        while any(p.poll() is None for p in procs):
            sampler.sample()
            sampler.watch_clients([p.pid for p in procs if p.poll() is None])
            if a.profile and perf is None and time.time() - sampler.t0 > a.duration / 3:
                # A sampling profile of the server in the steady part of the run: what limits it.
                perf = subprocess.Popen(["perf", "record", "-F", "499", "-g", "-p", str(server.pid), "-o",
                                         os.path.join(work, "perf.data"), "--", "sleep", str(a.profile)],
                                        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            next_sample += 1.0
            time.sleep(max(0.0, next_sample - time.time()))
        if perf is not None:
            perf.wait()
    finally:
        for p in procs:
            if p.poll() is None:
                p.terminate()
        server.send_signal(signal.SIGINT)
        try:
            server.wait(timeout=60)
        except subprocess.TimeoutExpired:
            server.kill()
    return sampler, [p.returncode for p in procs]


def summaries(directory):
    """The clients' summary files (robot-*.json, query-*.json) in a directory."""
    return sorted(glob.glob(os.path.join(directory, "robot-*.json")) + glob.glob(os.path.join(directory, "query-*.json")))


def client_pids(domain):
    """The densemap-replay processes on `domain` this runner can see."""
    return [pid for pid, args in processes("densemap-replay")
            if "--domain" in args[:-1] and args[args.index("--domain") + 1] == str(domain)]


def run_attached(a):
    """Samples the server container's process until every expected client summary is in a.attach."""
    pid = a.server_pid
    deadline = time.time() + 60
    while pid is None and time.time() < deadline:
        pid = find_pid("densemap-server", a.server_match)
        time.sleep(0.5)
    if pid is None:
        print("load_test: no densemap-server process visible (compose: give the runner pid: service:server)",
              file=sys.stderr)
        sys.exit(2)
    sampler = Sampler(pid)
    expected = a.robots + a.query_clients
    t0 = time.time()
    deadline = t0 + a.duration + a.grace
    # Past the grace, clients that are still running are waited for (up to --max-wait): a server starved of
    # CPU (a busy CI machine) finishes late but loses nothing, which the report's latencies show; a client
    # that died or never started ends the wait at once.
    hard_deadline = t0 + a.duration + max(a.grace, a.max_wait)
    said = 0.0
    while len(summaries(a.attach)) < expected:
        now = time.time()
        if now >= hard_deadline:
            break
        if now >= deadline:
            running = client_pids(a.domain)
            if not running:
                break
            if now - said >= 30:
                print(f"load_test: {expected - len(summaries(a.attach))} client summaries missing "
                      f"{now - t0:.0f} s after the start; {len(running)} client process(es) still running "
                      f"(pids {' '.join(map(str, running))}): waiting up to {hard_deadline - now:.0f} s more",
                      file=sys.stderr, flush=True)
                said = now
        sampler.sample()
        time.sleep(1.0)
    found = len(summaries(a.attach))
    if found < expected:
        print(f"load_test: only {found} of {expected} client summaries arrived in {a.attach} within "
              f"{time.time() - t0:.0f} s", file=sys.stderr)
    elif time.time() > deadline:
        print(f"load_test: the last client summary arrived {time.time() - t0:.0f} s after the start, "
              f"past the {a.duration + a.grace:.0f} s grace (the server was behind: see the latencies)",
              file=sys.stderr)
    return sampler, None


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robots", type=int, default=2, help="robot processes (default 2)")
    ap.add_argument("--rate", type=float, default=10.0, help="scans per second per robot (default 10)")
    ap.add_argument("--source", default="sim", help="scan source for every robot (default: the simulator)")
    ap.add_argument("--robot-offset", default="0,30,0", help="robot k's scans shifted by k times x,y,z")
    ap.add_argument("--query-clients", type=int, default=1, help="query-client processes (default 1)")
    ap.add_argument("--query-mix", default="points",
                    help="query kinds handed to the clients in turn, from points, box, ray (default points)")
    ap.add_argument("--query-points", type=int, default=1000,
                    help="points per point query; most cells per box query (default 1000)")
    ap.add_argument("--query-rate", type=float, default=20.0, help="queries per second per client (default 20)")
    ap.add_argument("--duration", type=float, default=20.0, help="seconds of load (default 20)")
    ap.add_argument("--domain", type=int, default=91, help="DDS domain id (default 91)")
    ap.add_argument("--resolution", type=float, default=0.2, help="map resolution (default 0.2)")
    ap.add_argument("--server-args", default="", help="extra densemap-server flags")
    ap.add_argument("--build-dir", default=os.path.join(ROOT, "build"))
    ap.add_argument("--profile", type=float, default=0, metavar="SECONDS",
                    help="native: record a perf profile of the server for this long, a third into the run")
    ap.add_argument("--attach", metavar="DIR",
                    help="compose runner: start nothing, sample the visible server, read client summaries here")
    ap.add_argument("--server-pid", type=int, default=None,
                    help="attach: the server's pid (default: the first process named densemap-server)")
    ap.add_argument("--containers", action="store_true",
                    help="attach: the server and clients are containers (recorded in the report)")
    ap.add_argument("--server-match", default=None,
                    help="attach: the server is the densemap-server whose command line contains this text")
    ap.add_argument("--grace", type=float, default=120.0, help="attach: extra seconds to wait for summaries")
    ap.add_argument("--max-wait", type=float, default=600.0,
                    help="attach: past the grace, wait this long after the duration for clients still running")
    ap.add_argument("--secure", action="store_true",
                    help="DDS-Security: native, every program gets its own identity (tools/make-security.sh); "
                         "attached, the containers were started secure (recorded in the report)")
    ap.add_argument("--json", metavar="FILE", help="write the report as JSON here")
    ap.add_argument("--max-dropped", type=int, default=None, help="bound: dropped scans over all robots")
    ap.add_argument("--max-latency-p99-ms", type=float, default=None, help="bound: publish-to-map p99")
    ap.add_argument("--max-query-p99-ms", type=float, default=None, help="bound: query round trip p99, any kind")
    ap.add_argument("--max-rss-growth", type=float, default=None,
                    help="bound: resident memory growth after the first minute (or third), as a fraction")
    a = ap.parse_args()
    bad = [k for k in a.query_mix.split(",") if k not in ("points", "box", "ray")]
    if bad:
        ap.error(f"--query-mix: unknown kind(s) {bad}; use points, box, ray")

    if a.attach:
        work = a.attach
        sampler, statuses = run_attached(a)
    else:
        work = tempfile.mkdtemp(prefix="densemap_load_")
        sampler, statuses = run_native(a, work)
    samples = sampler.samples

    robots, queries = [], []
    for path in summaries(work):
        data = json.load(open(path))
        (queries if "query_kind" in data and data.get("robots", 0) == 0 else robots).append(data)
    failed = [s for s in (statuses or []) if s != 0]
    expected = a.robots + a.query_clients
    if len(robots) + len(queries) < expected:
        failed.append(f"{expected - len(robots) - len(queries)} summaries missing")

    by_kind = {}
    for q in queries:
        by_kind.setdefault(q["query_kind"], []).extend(q.get("query_latencies_ms", []))
    kinds = {k: {"queries": len(v), "p50_ms": round(percentile(v, 0.5), 3), "p99_ms": round(percentile(v, 0.99), 3)}
             for k, v in by_kind.items()}
    dropped = sum(r.get("scans_dropped", 0) for r in robots)
    lat99 = max((r.get("latency_p99_ms", 0) for r in robots), default=0)
    q99 = max((k["p99_ms"] for k in kinds.values()), default=0)
    steady = [s["rss_mb"] for s in samples if s["t"] >= min(60.0, a.duration / 3)]
    growth = (max(steady) - steady[0]) / steady[0] if len(steady) > 1 and steady[0] > 0 else 0.0
    busy = [s["cpu_cores"] for s in samples]
    summary = {"robots": len(robots), "scans_sent": sum(r.get("scans_sent", 0) for r in robots),
               "scans_processed": sum(r.get("scans_processed", 0) for r in robots), "dropped": dropped,
               "latency_p99_ms": lat99, "query_kinds": kinds, "query_p99_ms": q99, "rss_growth": round(growth, 4),
               "cpu_cores_mean": round(sum(busy) / max(1, len(busy)), 2),
               "rss_mb_first": samples[0]["rss_mb"] if samples else 0,
               "rss_mb_last": samples[-1]["rss_mb"] if samples else 0, "cpu": sampler.breakdown(),
               "secure": a.secure,
               # Start of a robot's process to its scan writer and ack reader matched with the server's, and
               # to the server's first statistics seen (authentication and permissions included when secure).
               "robot_matched_ms": sorted(round(r["matched_ms"], 1) for r in robots if "matched_ms" in r),
               "robot_ready_ms": sorted(round(r["server_ready_ms"], 1) for r in robots if "server_ready_ms" in r)}
    for q in queries:
        q.pop("query_latencies_ms", None)  # pooled above; keeps the JSON report readable

    print(f"{'robot':<24}{'sent':>8}{'processed':>11}{'dropped':>9}{'rejected':>10}{'p50 ms':>9}{'p99 ms':>9}")
    for i, r in enumerate(robots):
        print(f"{r.get('robot_ids', ['robot ' + str(i)])[0]:<24}{r.get('scans_sent', 0):>8}"
              f"{r.get('scans_processed', 0):>11}{r.get('scans_dropped', 0):>9}{r.get('scans_rejected', 0):>10}"
              f"{r.get('latency_p50_ms', 0):>9.1f}{r.get('latency_p99_ms', 0):>9.1f}")
    for kind, k in sorted(kinds.items()):
        print(f"{kind} queries ({a.query_points} points/cells): {k['queries']} from "
              f"{sum(1 for q in queries if q['query_kind'] == kind)} client(s), round trip p50 {k['p50_ms']:.2f} ms, "
              f"p99 {k['p99_ms']:.2f} ms")
    if samples:
        print(f"server: {summary['cpu_cores_mean']} cores on average (of {os.cpu_count()}), resident "
              f"{samples[0]['rss_mb']} -> {samples[-1]['rss_mb']} MB (growth after warm-up {growth:.1%})")
        step = max(1, len(samples) // 10)
        print("server over time: " + "  ".join(f"{s['t']:.0f}s {s['cpu_cores']:.2f}c {s['rss_mb']:.0f}MB"
                                               for s in samples[::step]))
        if "anon_mb" in samples[0]:
            print("resident parts over time (anonymous / file / shared memory MB): " + "  ".join(
                f"{s['t']:.0f}s {s.get('anon_mb', 0):.0f}/{s.get('file_mb', 0):.0f}/{s.get('shmem_mb', 0):.0f}"
                for s in samples[::step]))
    if summary["robot_matched_ms"]:
        m = summary["robot_matched_ms"]
        print(f"robots {'(secure) ' if a.secure else ''}matched with the server after {percentile(m, 0.5):.0f} ms "
              f"(median; max {m[-1]:.0f} ms), first statistics seen after "
              f"{percentile(summary['robot_ready_ms'], 0.5):.0f} ms")
    cpu = summary["cpu"]
    print(f"CPU: machine {cpu['machine_busy_fraction']:.0%} busy of {cpu['cores']} cores; clients "
          f"{cpu['clients_cores']:.2f} cores; server threads (cores): "
          + ", ".join(f"{k} {v:.2f}" for k, v in cpu["server_threads_cores"].items()))
    perf_data = os.path.join(work, "perf.data")
    if a.profile and os.path.exists(perf_data):
        rep = subprocess.run(["perf", "report", "-i", perf_data, "--stdio", "--no-children", "--sort",
                              "comm,dso,symbol", "--percent-limit", "1.5", "-g", "none"],
                             capture_output=True, text=True)
        lines = [" ".join(l.split()[:5])[:140] for l in rep.stdout.splitlines() if l.strip() and not l.startswith("#")]
        open(os.path.join(work, "profile.txt"), "w").write(rep.stdout)
        summary["profile_top"] = lines[:25]
        print("server profile (perf, self time, top entries):")
        for l in lines[:25]:
            print("  " + l.strip())

    broken = []
    if a.max_dropped is not None and dropped > a.max_dropped:
        broken.append(f"{dropped} scans dropped (bound {a.max_dropped})")
    if a.max_latency_p99_ms is not None and lat99 > a.max_latency_p99_ms:
        broken.append(f"publish-to-map p99 {lat99:.1f} ms (bound {a.max_latency_p99_ms})")
    if a.max_query_p99_ms is not None and q99 > a.max_query_p99_ms:
        broken.append(f"query p99 {q99:.2f} ms (bound {a.max_query_p99_ms})")
    if a.max_rss_growth is not None and growth > a.max_rss_growth:
        broken.append(f"resident memory grew {growth:.1%} (bound {a.max_rss_growth:.1%})")
    if failed:
        broken.append(f"client processes failed or are missing: {failed} (summaries in {work})")
    if a.json:
        all_lat = [x for r in robots for x in r.get("latencies_ms", [])]
        all_q = [x for v in by_kind.values() for x in v]
        report = {
            "containers": a.containers,
            "secure": a.secure,
            "duration_s": a.duration,
            "robots": [{"robot": (r.get("robot_ids") or ["?"])[0], "sent": r.get("scans_sent", 0),
                        "processed": r.get("scans_processed", 0), "dropped": r.get("scans_dropped", 0),
                        "rejected": r.get("scans_rejected", 0), "acknowledged": r.get("scans_acknowledged", 0),
                        "latency_p50_ms": r.get("latency_p50_ms"), "latency_p99_ms": r.get("latency_p99_ms")}
                       for r in robots],
            "latency_p50_ms": round(percentile(all_lat, 0.5), 2), "latency_p99_ms": round(percentile(all_lat, 0.99), 2),
            "query_p50_ms": round(percentile(all_q, 0.5), 3), "query_p99_ms": round(percentile(all_q, 0.99), 3),
            "queries": len(all_q), "query_failures": sum(q.get("query_failures", 0) for q in queries),
            "server_cpu_percent": round(100 * summary["cpu_cores_mean"], 1),
            "server_rss_mb": {"start": summary["rss_mb_first"], "end": summary["rss_mb_last"]},
            "summary": summary, "clients": {"robots": robots, "queries": queries}, "server": samples,
            "work_dir": work, "bounds_broken": broken}
        for r in robots:
            r.pop("latencies_ms", None)
        json.dump(report, open(a.json, "w"), indent=2)
    for b in broken:
        print("BOUND BROKEN:", b)
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main())
