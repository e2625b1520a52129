#!/usr/bin/python3
"""HTTP load benchmark of kinemetricd with a real load generator (wrk).

Starts the server (demo data, its own data dir), holds IDLE idle connections and SLOW
connections that send one header byte every second (reopened when the server closes them),
measures /healthz latency meanwhile, then drives keep-alive result queries with wrk and
reports requests/s, latency percentiles and the server's peak RSS.

  tests/bench/http/load_bench.py build/bin/kinemetricd [--seconds 10] [--idle 1000] [--slow 100]
"""
import argparse
import os
import re
import shutil
import socket
import subprocess
import sys
import tempfile
import threading
import time

TOKEN = "bench-token"


def start_server(binary, data_dir, database=None):
    env = dict(os.environ, KINEMETRIC_BOOTSTRAP_TOKEN=TOKEN)
    proc = subprocess.Popen(
        [binary, "--listen", "127.0.0.1:0", "--data-dir", data_dir, "--demo-data"] +
        (["--database", database] if database else []),
        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=env, text=True)
    for line in proc.stdout:
        m = re.search(r"listening on http://127\.0\.0\.1:(\d+)/", line)
        if m:
            threading.Thread(target=lambda: [None for _ in proc.stdout], daemon=True).start()
            return proc, int(m.group(1))
    raise SystemExit("kinemetricd did not start")


def get(port, path, timeout=5.0):
    t0 = time.perf_counter()
    with socket.create_connection(("127.0.0.1", port), timeout=timeout) as s:
        s.sendall(f"GET {path} HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n".encode())
        data = b""
        while True:
            chunk = s.recv(65536)
            if not chunk:
                break
            data += chunk
    return time.perf_counter() - t0, int(data[9:12] or 0)


class Holders:
    """Idle connections, and slow ones that dribble a header byte every second."""

    def __init__(self, port, idle, slow):
        self.port, self.stop = port, False
        self.idle = [socket.create_connection(("127.0.0.1", port)) for _ in range(idle)]
        self.slow_count = slow
        self.thread = threading.Thread(target=self.run_slow, daemon=True)
        self.thread.start()

    def run_slow(self):
        conns = []
        while not self.stop:
            while len(conns) < self.slow_count:
                c = socket.create_connection(("127.0.0.1", self.port))
                c.sendall(b"GET /healthz HTTP/1.1\r\n")
                conns.append(c)
            alive = []
            for c in conns:
                try:
                    c.sendall(b"X")
                    alive.append(c)
                except OSError:
                    c.close()
            conns = alive
            time.sleep(1.0)
        for c in conns:
            c.close()

    def close(self):
        self.stop = True
        self.thread.join()
        for c in self.idle:
            c.close()


def rss_mb(pid, key):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith(key):
                return int(line.split()[1]) / 1024.0
    return 0.0


def run_wrk(port, seconds, connections, path):
    script = tempfile.NamedTemporaryFile("w", suffix=".lua", delete=False)
    script.write(f'wrk.headers["Authorization"] = "Bearer {TOKEN}"\n')
    script.close()
    out = subprocess.run(
        ["wrk", "-t2", f"-c{connections}", f"-d{seconds}s", "--latency", "-s", script.name,
         f"http://127.0.0.1:{port}{path}"], capture_output=True, text=True, check=True).stdout
    os.unlink(script.name)
    rps = float(re.search(r"Requests/sec:\s+([\d.]+)", out).group(1))
    lat = {}
    for pct in ("50", "90", "99"):
        m = re.search(rf"\s{pct}(?:\.000)?%\s+([\d.]+)(us|ms|s)\b", out)
        value, unit = float(m.group(1)), m.group(2)
        lat[pct] = value / 1000.0 if unit == "us" else value * 1000.0 if unit == "s" else value
    non2xx = re.search(r"Non-2xx or 3xx responses:\s+(\d+)", out)
    errors = re.search(r"Socket errors:(.*)", out)
    return rps, lat, int(non2xx.group(1)) if non2xx else 0, errors.group(1).strip() if errors else ""


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("binary")
    ap.add_argument("--seconds", type=int, default=10)
    ap.add_argument("--idle", type=int, default=1000)
    ap.add_argument("--slow", type=int, default=100)
    ap.add_argument("--connections", type=int, default=16)
    ap.add_argument("--database", help="postgresql://… (default: the SQLite file)")
    args = ap.parse_args()
    import resource
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (hard, hard))

    data_dir = tempfile.mkdtemp(prefix="km-load-")
    proc, port = start_server(args.binary, data_dir, args.database)
    try:
        holders = Holders(port, args.idle, args.slow)
        time.sleep(1.5)
        lat = []
        for _ in range(20):
            dt, status = get(port, "/healthz")
            assert status == 200, status
            lat.append(dt * 1000)
            time.sleep(0.05)
        lat.sort()
        print(f"healthz with {args.idle} idle + {args.slow} slow-header connections: "
              f"median {lat[len(lat) // 2]:.2f} ms, max {lat[-1]:.2f} ms")
        holders.close()
        rps, pct, non2xx, errors = run_wrk(port, args.seconds, args.connections,
                                           "/api/v1/measurements/1/results")
        print(f"keep-alive GET /api/v1/measurements/1/results, {args.connections} connections, "
              f"{args.seconds} s: {rps:.0f} req/s, p50 {pct['50']:.2f} ms, p90 {pct['90']:.2f} ms, "
              f"p99 {pct['99']:.2f} ms, non-2xx {non2xx}{', socket errors ' + errors if errors else ''}")
        print(f"server RSS now {rss_mb(proc.pid, 'VmRSS'):.0f} MB, peak {rss_mb(proc.pid, 'VmHWM'):.0f} MB")
        if non2xx:
            sys.exit("non-2xx answers under load")
    finally:
        proc.terminate()
        proc.wait(timeout=30)
        shutil.rmtree(data_dir, ignore_errors=True)


if __name__ == "__main__":
    main()
