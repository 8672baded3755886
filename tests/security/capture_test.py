#!/usr/bin/env python3
"""A capture of the test's own DDS traffic (tshark on lo, the test's domain's ports only) holds the plaintext
coordinates of a known scan in plain mode, and neither them nor the discovery data in secure mode.

A robot (densemap-replay) sends one scan read from a PCD file with known points to a densemap-server over UDP
on 127.0.0.1 (--loopback --udp-only: no shared memory, which a capture cannot see). The pattern searched for
is the packed float32 x y z of the scan's points, as the Scan message carries them.

  tests/security/capture_test.py --build BUILD_DIR [--domain D] [--keep DIR]
Exit 0: plain mode leaks the points and secure mode does not; 1: otherwise; 77: skipped (no tshark or not
root: capturing needs CAP_NET_RAW).
"""
import argparse
import os
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))


def log(*a):
    print("capture-test:", *a, flush=True)


def write_scan(path, n=256):
    # Coordinates that float32 holds exactly (multiples of 1/64), so the bytes on the wire are known.
    pts = [(6.0 + i / 64.0, -3.0 + (i % 17) / 64.0, 0.5 + (i % 5) / 64.0) for i in range(n)]
    with open(path, "w") as f:
        f.write("# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n")
        f.write(f"WIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA ascii\n")
        for p in pts:
            f.write("%r %r %r\n" % p)
    # Eight consecutive points: 96 bytes that occur nowhere by chance.
    return b"".join(struct.pack("<3f", *p) for p in pts[100:108])


def run_mode(build, domain, work, pcd, keystore):
    mode = "secure" if keystore else "plain"
    pcap = os.path.join(work, mode + ".pcap")
    first = 7400 + 250 * domain
    cap = subprocess.Popen(["tshark", "-i", "lo", "-f", f"udp portrange {first}-{first + 249}", "-w", pcap, "-q"],
                           stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    # Capturing once tshark says so (or the file exists).
    deadline = time.time() + 20
    while time.time() < deadline and not os.path.exists(pcap):
        time.sleep(0.1)
    time.sleep(0.5)
    dds = ["--domain", str(domain), "--loopback", "--udp-only"]
    server_cmd = [os.path.join(build, "server", "densemap-server"), *dds, "--data-dir", os.path.join(work, mode + "-data"),
                  "--duplicate-check", "0"]
    robot_cmd = [os.path.join(build, "client", "densemap-replay"), *dds, "--source", pcd, "--wait", "30"]
    if keystore:
        server_cmd += ["--security-dir", os.path.join(keystore, "server")]
        robot_cmd += ["--security-dir", os.path.join(keystore, "robot-1")]
    server_log = open(os.path.join(work, mode + "-server.log"), "w")
    server = subprocess.Popen(server_cmd, stdout=server_log, stderr=subprocess.STDOUT)
    try:
        robot = subprocess.run(robot_cmd, capture_output=True, text=True, timeout=90)
    finally:
        server.send_signal(signal.SIGINT)
        try:
            server.wait(timeout=30)
        except subprocess.TimeoutExpired:
            server.kill()
        time.sleep(0.5)
        cap.send_signal(signal.SIGINT)
        try:
            cap.wait(timeout=20)
        except subprocess.TimeoutExpired:
            cap.kill()
    out = robot.stdout + robot.stderr
    applied = "acknowledged 1 (applied 1" in out
    data = open(pcap, "rb").read() if os.path.exists(pcap) else b""
    return applied, data, out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", required=True)
    ap.add_argument("--domain", type=int, default=211)
    ap.add_argument("--keep", help="keep the captures and logs in this directory")
    a = ap.parse_args()
    if shutil.which("tshark") is None or os.geteuid() != 0:
        log("skipped: needs tshark (apt-get install tshark) and root to capture on lo")
        return 77
    work = a.keep or tempfile.mkdtemp(prefix="densemap-capture.")
    os.makedirs(work, exist_ok=True)
    try:
        pcd = os.path.join(work, "known.pcd")
        pattern = write_scan(pcd)
        keystore = os.path.join(work, "keystore")
        subprocess.run([os.path.join(ROOT, "tools", "make-security.sh"), keystore, "--robots", "1", "--clients", "0"],
                       check=True, stdout=subprocess.DEVNULL)
        ok = True
        for keys, domain in ((None, a.domain), (keystore, a.domain + 1)):
            mode = "secure" if keys else "plain"
            applied, data, out = run_mode(a.build, domain, work, pcd, keys)
            has_points = pattern in data
            # The type name travels only in discovery (EDP), which the governance encrypts. (Topic names also
            # travel in the authentication handshake inside the signed permissions document, which
            # DDS-Security sends in clear, so they are not a test of discovery protection.)
            has_topic = b"densemap::msg::Scan" in data
            log(f"{mode}: scan applied {applied}, captured {len(data)} bytes, points in clear {has_points}, "
                f"type name (discovery) in clear {has_topic}")
            if not applied:
                log(f"{mode}: the robot's scan was not applied, so the capture proves nothing:\n{out[-2000:]}")
                ok = False
            if len(data) < 20000:
                log(f"{mode}: the capture is too small to hold a scan ({len(data)} bytes): is tshark capturing?")
                ok = False
            if keys is None and not (has_points and has_topic):
                log("plain: the known points (or the type name) are not in the capture: the search is broken")
                ok = False
            if keys is not None and (has_points or has_topic):
                log("secure: the known points or the discovery data travel in clear")
                ok = False
        log("PASS" if ok else "FAIL")
        return 0 if ok else 1
    finally:
        if not a.keep:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
