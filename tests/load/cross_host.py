#!/usr/bin/env python3
"""The scenarios of tests/load/cross_host.sh (which makes the namespaces and removes them again).

Every program runs in its host's network namespace (`ip netns exec`) with --udp-only. Robots write a scan
log (--scan-log: every scan sent, refused and acknowledged, with times) that survives a SIGKILL; the
server's own per-robot counts come from its statistics topic (`densemap-query statistics`). Times are the
system clock of this one machine, the clock the programs stamp scans and acknowledgements with.

--secure: every program runs with DDS-Security, each with an identity of its own from a keystore made by
tools/make-security.sh (server, robot-ra on host ra, robot-rb on rb: a robot identity sends as its own
name and NAME-<k>, here robot-ra-0 and robot-rb-0; client-1 for the query client, operator for the
statistics and progress read from host q). The multicast scenario first checks, across the network,
that a participant without an identity gets no statistics and that a robot whose identity another CA signed
finds no server and is counted as refused.
"""
import argparse
import json
import os
import signal
import subprocess
import sys
import time

RATE = 10.0


def now():
    return time.time_ns()


def percentile(values, q):
    if not values:
        return None
    v = sorted(values)
    return v[min(len(v) - 1, int(q * len(v)))]


class Net:
    def __init__(self, prefix, hosts):
        self.prefix = prefix
        self.ip = dict(h.split("=") for h in hosts.split(","))

    def ns(self, host):
        return f"{self.prefix}-{host}"

    def ip_cmd(self, host, *args):
        subprocess.run(["ip", "-n", self.ns(host), *args], check=True)


class Run:
    """One scenario's processes and files."""

    def __init__(self, a, net, name, discovery):
        self.a, self.net, self.name, self.discovery = a, net, name, discovery
        self.dir = os.path.join(a.work, name)
        os.makedirs(self.dir, exist_ok=True)
        self.dds = ["--domain", str(a.domain), "--udp-only", *a.dds_args.split()]

    def identity(self, name):
        """--security-dir for identity `name` of the run's keystore (nothing in plain mode)."""
        return ["--security-dir", os.path.join(self.a.keystore, name)] if self.a.keystore else []

    def spawn(self, host, cmd, log_name):
        log = open(os.path.join(self.dir, log_name), "w")
        return subprocess.Popen(["ip", "netns", "exec", self.net.ns(host), *cmd], stdout=log,
                                stderr=subprocess.STDOUT)

    def server(self, tag):
        cmd = [os.path.join(self.a.build, "server", "densemap-server"), *self.dds, *self.identity("server"),
               "--statistics-period", "1",
               "--server-id", f"cross-host-{tag}", "--data-dir", os.path.join(self.dir, "data"),
               *self.discovery.get("srv", [])]
        return self.spawn("srv", cmd, f"server-{tag}.log")

    def robot(self, host, tag, scans, extra=None, wait_s=60, security=None):
        """A robot on `host`, robot id robot-<host>-0; in secure mode identity robot-<host>, or the flags `security`."""
        ident = self.identity(f"robot-{host}") if security is None else security
        cmd = [os.path.join(self.a.build, "client", "densemap-replay"), *self.dds, *ident, "--source", self.a.source,
               "--rate", str(RATE), "--loops", "1000000", "--max-scans", str(scans), "--robot-prefix",
               f"robot-{host}", "--scan-log", os.path.join(self.dir, f"scans-{tag}.jsonl"), "--summary-json",
               os.path.join(self.dir, f"summary-{tag}.json"), "--wait", str(wait_s), "--log-level", "warn",
               *(self.discovery.get("robot", []) if extra is None else extra)]
        return self.spawn(host, cmd, f"robot-{tag}.log")

    def query_client(self, seconds):
        cmd = [os.path.join(self.a.build, "client", "densemap-replay"), *self.dds, *self.identity("client-1"),
               "--robots", "0", "--duration", str(seconds), "--query-clients", "1", "--query-points", "1000", "--query-rate",
               "20", "--summary-json", os.path.join(self.dir, "summary-query.json"), "--wait", "60",
               "--log-level", "warn", *self.discovery.get("robot", [])]
        return self.spawn("q", cmd, "query.log")

    def start_stream(self, seconds):
        """Both robots and the query client, from now: (t0 in s, t0 in ns, robot A, robot B, query)."""
        t0, t0_ns = time.time(), now()
        scans = int(seconds * RATE)
        return t0, t0_ns, self.robot("ra", "ra", scans), self.robot("rb", "rb", scans), self.query_client(seconds)

    def query(self, what, security=None, timeout_s=15):
        """densemap-query WHAT --json, asked from the query client's host (None when it got no answer), as the
        operator in secure mode (or with `security`, the flags of another identity; [] for none)."""
        sec = self.identity("operator") if security is None else security
        cmd = ["ip", "netns", "exec", self.net.ns("q"), os.path.join(self.a.build, "client", "densemap-query"),
               *self.dds, *sec, *self.discovery.get("robot", []), "--wait", str(timeout_s), "--json", what]
        r = subprocess.run(cmd, capture_output=True, text=True)
        if r.returncode != 0:
            return None
        return json.loads(r.stdout)

    def statistics(self):
        """The server's next statistics message."""
        return self.query("statistics")

    def progress(self):
        """The sequence numbers the server holds durably, per robot: {robot: [(lo, hi), ...]}."""
        p = self.query("progress")
        return None if p is None else {r["robot"]: [tuple(i) for i in r["intervals"]] for r in p["robots"]}

    def scan_log(self, tag):
        sent, refused, acks = [], [], {}
        path = os.path.join(self.dir, f"scans-{tag}.jsonl")
        if os.path.exists(path):
            for line in open(path):
                try:
                    e = json.loads(line)
                except ValueError:
                    continue  # a line cut by SIGKILL
                if e["event"] == "sent":
                    sent.append(e)
                elif e["event"] == "refused":
                    refused.append(e)
                elif e["event"] == "ack":
                    acks.setdefault(e["seq"], []).append(e)
        # An acknowledgement is this process's when it names a scan it sent, published right then (a restarted
        # robot goes on numbering after what the server holds, so sequences do not repeat across processes).
        applied = []
        for s in sent:
            for e in acks.get(s["seq"], []):
                if e["outcome"] == "applied" and 0 <= e["publish_ns"] - s["t_ns"] < 1_000_000_000:
                    applied.append(e)
                    break
        # Durably acknowledged, by any server, also when resent (a resend of a held scan is a duplicate).
        durable = sorted({q for q, es in acks.items() if any(e.get("durable") for e in es)})
        return {"sent": sent, "refused": refused, "applied": applied, "durable": durable}


def sleep_until(t0, seconds):
    time.sleep(max(0.0, t0 + seconds - time.time()))


def wait_all(procs, timeout):
    deadline = time.time() + timeout
    for p in procs:
        try:
            p.wait(timeout=max(0.1, deadline - time.time()))
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()


def stop(p):
    if p.poll() is None:
        p.send_signal(signal.SIGINT)
        try:
            p.wait(timeout=60)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()


def in_map(stats, robot_id):
    """A robot's scans in the server's map, over every run of the server on its data directory."""
    if not stats:
        return None
    return sum(r.get("durable_scans", r["processed"]) for r in stats["robots"] if r["robot"] == robot_id)


def not_held(progress, robot_id, seqs):
    """The sequence numbers of `seqs` that the server's progress does not hold (None without progress)."""
    if progress is None:
        return None
    runs = progress.get(robot_id, [])
    return [q for q in seqs if not any(lo <= q <= hi for lo, hi in runs)]


def latencies(applied, t_from_ns=None, t_to_ns=None):
    return [(e["done_ns"] - e["publish_ns"]) / 1e6 for e in applied
            if (t_from_ns is None or e["publish_ns"] >= t_from_ns) and (t_to_ns is None or e["publish_ns"] < t_to_ns)]


def first_done_after(applied, t_ns):
    after = [e["done_ns"] for e in applied if e["done_ns"] > t_ns]
    return (min(after) - t_ns) / 1e9 if after else None


def wait_for_server(run, seconds):
    """Until the server publishes statistics (it is up and discoverable)."""
    deadline = time.time() + seconds
    while time.time() < deadline:
        if run.statistics() is not None:
            return True
    return False


def check_intruders(a, run, report, failures):
    """Secure mode: from host q, a participant without an identity and a robot of another CA get nothing."""
    plain = run.query("statistics", security=[], timeout_s=6)
    foreign = run.robot("q", "foreign", 1, wait_s=8, extra=[],
                        security=["--security-dir", os.path.join(a.foreign_keystore, "robot-q")])
    try:
        foreign.wait(timeout=60)
    except subprocess.TimeoutExpired:
        foreign.kill()
        foreign.wait()
    stats = run.statistics()
    refused = None if stats is None else stats.get("participants_refused")
    report["security"] = {"unauthenticated_got_statistics": plain is not None,
                          "other_ca_robot_found_server": foreign.returncode == 0,
                          "participants_refused": refused}
    if plain is not None:
        failures.append("secure: a participant without an identity read the server's statistics")
    if foreign.returncode == 0:
        failures.append("secure: a robot whose certificate another CA signed found the server")
    if not refused:
        failures.append(f"secure: the server counted no refused participant (participants_refused {refused})")


def scenario_multicast(a, net, report, failures):
    """Multicast discovery; faults (a) link down 5 s and (b) robot process killed and restarted."""
    run = Run(a, net, "multicast", {})
    duration = a.stream_s
    server = run.server("1")
    if not wait_for_server(run, 30):
        failures.append("multicast: the server's statistics never reached the query host")
        stop(server)
        return
    if a.keystore:
        check_intruders(a, run, report, failures)
    t0, t0_ns, ra, rb, query = run.start_stream(duration)
    # (a) robot A's link down for 5 s, mid-stream.
    sleep_until(t0, a.fault_at)
    down_ns = now()
    net.ip_cmd("ra", "link", "set", "eth0", "down")
    sleep_until(t0, a.fault_at + 5)
    net.ip_cmd("ra", "link", "set", "eth0", "up")
    up_ns = now()
    # (b) robot B killed and started again (same robot id, a new process; it goes on numbering after the
    # scans the server holds).
    sleep_until(t0, a.fault_at + 14)
    rb.kill()
    rb.wait()
    killed_ns = now()
    sleep_until(t0, a.fault_at + 16)
    restart_ns = now()
    rb2 = run.robot("rb", "rb2", int(max(10.0, duration - (a.fault_at + 16)) * RATE))
    wait_all([ra, rb2, query], duration + 90)
    stats = run.statistics()
    progress = run.progress()
    stop(server)

    la, lb, lb2 = run.scan_log("ra"), run.scan_log("rb"), run.scan_log("rb2")
    undisturbed = latencies(la["applied"], t0_ns, down_ns) + latencies(lb["applied"], t0_ns, down_ns)
    report["latency_p50_ms"] = percentile(undisturbed, 0.5)
    report["latency_p99_ms"] = percentile(undisturbed, 0.99)
    report["latency_scans"] = len(undisturbed)
    qs = json.load(open(os.path.join(run.dir, "summary-query.json"))) if os.path.exists(
        os.path.join(run.dir, "summary-query.json")) else {}
    report["query_p50_ms"], report["query_p99_ms"] = qs.get("query_p50_ms"), qs.get("query_p99_ms")
    report["queries"], report["query_failures"] = qs.get("queries", 0), qs.get("query_failures")
    report["discovery"]["multicast"] = {"server_found": bool(la["applied"] or lb["applied"])}

    ack_a = len(la["applied"])
    map_a = in_map(stats, "robot-ra-0")
    report["faults"].append({
        "name": "link_down_5s", "robot": "robot-ra-0", "sent": len(la["sent"]), "refused": len(la["refused"]),
        "acknowledged": ack_a, "in_map": map_a,
        "acknowledged_missing": None if progress is None else len(not_held(progress, "robot-ra-0", la["durable"])),
        "recovery_s": first_done_after(la["applied"], up_ns),
        "latency_during_p99_ms": percentile(latencies(la["applied"], down_ns, up_ns), 0.99)})
    # Durably acknowledged, whatever the outcome (a resend of a held scan is answered as a duplicate).
    ack_b = len(set(lb["durable"]) | set(lb2["durable"]))
    map_b = in_map(stats, "robot-rb-0")
    report["faults"].append({
        "name": "robot_killed_restarted", "robot": "robot-rb-0",
        "sent": len({e["seq"] for e in lb["sent"] + lb2["sent"]}),
        "refused": len(lb["refused"]) + len(lb2["refused"]),
        "acknowledged": ack_b, "in_map": map_b,
        "acknowledged_missing": None if progress is None else len(not_held(progress, "robot-rb-0",
                                                                           sorted(set(lb["durable"] + lb2["durable"])))),
        # Mapped but never seen acknowledged: in flight when the robot died.
        "unacknowledged_in_map": None if map_b is None else max(0, map_b - ack_b),
        "resumed_at": (lb2["sent"][0]["seq"] if lb2["sent"] else None),
        "down_s": (restart_ns - killed_ns) / 1e9,
        "recovery_s": first_done_after(lb2["applied"], restart_ns)})
    if stats is None:
        failures.append("multicast: no statistics from the server at the end")
    for f in report["faults"][-2:]:
        if f["acknowledged_missing"] != 0:
            failures.append(f"{f['name']}: {f['acknowledged_missing']} acknowledged scans are not in the map")
        if f["recovery_s"] is None:
            failures.append(f"{f['name']}: the robot's scans never reached the map again")
        if f["acknowledged"] < 0.8 * f["sent"]:
            failures.append(f"{f['name']}: only {f['acknowledged']} of {f['sent']} scans acknowledged")
    if not undisturbed:
        failures.append("multicast: no scan reached the map before the faults")
    if not report["queries"]:
        failures.append("multicast: the query client got no answers")


def scenario_initial_peers(a, net, report, failures):
    """Multicast blocked by the switch; discovery through --dds-peers; fault (c) server killed and restarted."""
    # The switch stops forwarding multicast (as many Wi-Fi and cloud networks do): every bridge port drops
    # multicast frames. (The interfaces' own "multicast off" flag does not stop a veth from sending.)
    for h in ("srv", "ra", "rb", "q"):
        subprocess.run(["bridge", "-n", f"{net.prefix}-br", "link", "set", "dev", f"p-{h}", "mcast_flood", "off"],
                       check=True)
    # Only the clients are configured: the server runs with the defaults and learns each client from the
    # client's unicast announcements (also after it restarts).
    peers = ["--dds-peers", net.ip["srv"], "--dds-no-multicast"]
    run = Run(a, net, "peers", {"robot": peers})
    duration = a.stream_s
    server = run.server("1")
    # With the default discovery (multicast) a robot must not find the server: multicast is really blocked.
    probe = run.robot("ra", "probe", 1, extra=[], wait_s=10)
    probe_cmd = probe.args
    try:
        probe.wait(timeout=60)
    except subprocess.TimeoutExpired:
        probe.kill()
    # replay's --wait 10: it gives up after 10 s without a server.
    found_without_peers = probe.returncode == 0
    report["discovery"]["initial_peers"] = {"default_discovery_found_server": found_without_peers}
    if found_without_peers:
        failures.append("peers: a robot found the server by multicast although multicast is off "
                        f"({' '.join(probe_cmd)})")
    if not wait_for_server(run, 30):
        failures.append("peers: the server's statistics never reached the query host through --dds-peers")
        stop(server)
        return
    t0, t0_ns, ra, rb, query = run.start_stream(duration)
    sleep_until(t0, a.fault_at)
    server.kill()
    server.wait()
    killed_ns = now()
    sleep_until(t0, a.fault_at + 2)
    restart_ns = now()
    server2 = run.server("2")
    wait_all([ra, rb, query], duration + 90)
    stats = run.statistics()
    progress = run.progress()
    stop(server2)

    la, lb = run.scan_log("ra"), run.scan_log("rb")
    report["discovery"]["initial_peers"]["server_found_through_peers"] = bool(la["applied"] or lb["applied"])
    before = latencies(la["applied"], t0_ns, killed_ns) + latencies(lb["applied"], t0_ns, killed_ns)
    report["discovery"]["initial_peers"]["latency_p50_ms"] = percentile(before, 0.5)
    report["discovery"]["initial_peers"]["latency_p99_ms"] = percentile(before, 0.99)
    # The restarted server recovers the first one's map from the data directory (journal + snapshots):
    # every scan either server acknowledged as durable must be in the final map, and what the robots sent
    # while it was down is resent by them (densemap-replay keeps every scan until it is durable).
    old = [e for log in (la, lb) for e in log["applied"] if e["done_ns"] < killed_ns]
    map_new = [in_map(stats, f"robot-{r}-0") for r in ("ra", "rb")]
    recovery = [first_done_after(log["applied"], restart_ns) for log in (la, lb)]
    missing = None if progress is None else [
        (r, q) for r, log in (("ra", la), ("rb", lb)) for q in not_held(progress, f"robot-{r}-0", log["durable"])]
    sent_seqs = {r: sorted({e["seq"] for e in log["sent"]}) for r, log in (("ra", la), ("rb", lb))}
    never = None if progress is None else sum(len(not_held(progress, f"robot-{r}-0", q)) for r, q in sent_seqs.items())
    report["faults"].append({
        "name": "server_killed_restarted", "robot": "robot-ra-0, robot-rb-0",
        "sent": len(la["sent"]) + len(lb["sent"]), "refused": len(la["refused"]) + len(lb["refused"]),
        "acknowledged": len(la["durable"]) + len(lb["durable"]),
        "in_map": None if None in map_new else sum(map_new),
        "acknowledged_missing": None if missing is None else len(missing),
        "acknowledged_before_kill": len(old),
        "sent_never_in_map": never,
        "down_s": (restart_ns - killed_ns) / 1e9,
        "recovery_s": None if None in recovery else max(recovery)})
    f = report["faults"][-1]
    if stats is None or progress is None:
        failures.append("peers: no statistics or progress from the restarted server")
    if f["recovery_s"] is None:
        failures.append("server_killed_restarted: a robot's scans never reached the restarted server's map")
    if missing:
        failures.append(f"server_killed_restarted: {len(missing)} durably acknowledged scans are not in the "
                        f"restarted server's map (first: {missing[:5]})")
    if never:
        failures.append(f"server_killed_restarted: {never} scans sent never reached the map (the robots resend "
                        "what is not durable)")
    if not before:
        failures.append("peers: no scan reached the map through --dds-peers before the fault")


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--build", required=True)
    ap.add_argument("--work", required=True)
    ap.add_argument("--ns-prefix", required=True)
    ap.add_argument("--hosts", required=True, help="name=address,...")
    ap.add_argument("--json", help="write the report here")
    ap.add_argument("--source", default="sim:scans=20", help="every robot's scans (default: 64x1024 simulator)")
    ap.add_argument("--domain", type=int, default=173, help="DDS domain id (default 173)")
    ap.add_argument("--stream-s", type=float, default=40.0, help="seconds each robot streams (default 40)")
    ap.add_argument("--fault-at", type=float, default=10.0, help="first fault, seconds into the stream")
    ap.add_argument("--dds-args", default="", help="more DDS flags for every program (e.g. --dds-lease-s 6)")
    ap.add_argument("--keep-logs", help="copy the programs' logs and scan logs into this directory")
    ap.add_argument("--secure", action="store_true", help="every program with DDS-Security (see above)")
    ap.add_argument("--scenarios", default="multicast,peers", help="which scenarios, in order (default both)")
    a = ap.parse_args()
    a.keystore = a.foreign_keystore = None
    if a.secure:
        make = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "tools",
                            "make-security.sh")
        a.keystore, a.foreign_keystore = os.path.join(a.work, "keystore"), os.path.join(a.work, "foreign-ca")
        # Robot identities named after their hosts: each may send only as robot-<host> and robot-<host>-<k>. The
        # foreign one may send as robot-q too, so it fails only because the server refuses its CA.
        for keystore, robots in ((a.keystore, ["robot-ra", "robot-rb"]), (a.foreign_keystore, ["robot-q"])):
            subprocess.run([make, keystore, "--robots", "0", "--clients", "1", "--days", "2"], check=True,
                           stdout=subprocess.DEVNULL)
            for r in robots:
                subprocess.run([make, keystore, "--add", "robot", r, "--days", "2"], check=True, stdout=subprocess.DEVNULL)
    net = Net(a.ns_prefix, a.hosts)
    report = {"transport": "UDPv4 only (--udp-only), each program in its own network namespace, veth + bridge",
              "secure": a.secure,
              "source": a.source, "dds_args": a.dds_args, "rate_hz": RATE, "robots": 2, "query_clients": 1, "discovery": {},
              "faults": []}
    failures = []
    t = time.time()
    scenarios = {"multicast": scenario_multicast, "peers": scenario_initial_peers}
    for name in a.scenarios.split(","):
        if name not in scenarios:
            ap.error(f"--scenarios: unknown scenario '{name}' (multicast, peers)")
        scenarios[name](a, net, report, failures)
    report["duration_s"] = round(time.time() - t, 1)
    report["failures"] = failures

    print(f"cross-host ({report['transport']}{', DDS-Security' if a.secure else ''}), {a.source} at {RATE:.0f} Hz"
          " x 2 robots + 1 query client")
    if "security" in report:
        sec = report["security"]
        print(f"  secure: no identity read statistics: {sec['unauthenticated_got_statistics']}; robot of another CA "
              f"found the server: {sec['other_ca_robot_found_server']}; server counted "
              f"{sec['participants_refused']} refused participant(s)")
    fmt = lambda v, p=1: "-" if v is None else f"{v:.{p}f}"
    print(f"  publish-to-map over UDP (multicast discovery, before faults): p50 {fmt(report.get('latency_p50_ms'))}"
          f" ms, p99 {fmt(report.get('latency_p99_ms'))} ms; 1,000-point queries p50 "
          f"{fmt(report.get('query_p50_ms'), 2)} ms, p99 {fmt(report.get('query_p99_ms'), 2)} ms")
    ip = report["discovery"].get("initial_peers", {})
    print(f"  multicast off: default discovery found the server: {ip.get('default_discovery_found_server')}; "
          f"--dds-peers found it: {ip.get('server_found_through_peers')}, publish-to-map p50 "
          f"{fmt(ip.get('latency_p50_ms'))} ms, p99 {fmt(ip.get('latency_p99_ms'))} ms")
    print(f"  {'fault':<26}{'sent':>6}{'refused':>8}{'acked':>7}{'in map':>8}{'acked missing':>15}{'recovery s':>12}")
    for f in report["faults"]:
        print(f"  {f['name']:<26}{f['sent']:>6}{f['refused']:>8}{f['acknowledged']:>7}{fmt(f['in_map'], 0):>8}"
              f"{fmt(f['acknowledged_missing'], 0):>15}{fmt(f['recovery_s'], 2):>12}")
    for f in report["faults"]:
        if "acknowledged_before_kill" in f:
            print(f"  server_killed_restarted: {f['acknowledged_before_kill']} scans acknowledged before the kill, "
                  f"all kept by the restarted server unless 'acked missing' says otherwise; "
                  f"{fmt(f['sent_never_in_map'], 0)} sent scans never reached the map")
    if a.json:
        with open(a.json, "w") as out:
            json.dump(report, out, indent=2)
    if a.keep_logs:
        subprocess.run(["cp", "-r", a.work + "/.", a.keep_logs], check=False)
    for f in failures:
        print("CHECK FAILED:", f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
