#!/usr/bin/python3
"""Large PDF reports on a real kinemetricd (docs/http.md, PDF reports): the report of a laser file
of 100 000 targets is a few pages that say its targets table is summarised; eight such reports
asked for at once are made a few at a time (the others answered 503 with Retry-After at once)
while /healthz keeps answering promptly; the memory they took is handed back; and a SIGTERM
while reports are being made stops the server within its shutdown deadline. Prints the figures
(pages, render time, /healthz latency, RSS peak and after, stop time)."""
import argparse
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ops_server import Checks, Server, percentile  # noqa: E402


def positioning_file(targets):
    """A laser positioning file (docs/formats.md §1.8): `targets` targets, 2 runs, both ways."""
    lines = ["# format: kinemetric-positioning/1", "# machine_id: long-axis", "# axis: X",
             "# timestamp: 2026-11-20T09:30:00Z", "# cycle: linear", "# datum_mm: 0",
             "# air_compensated: yes", "run,direction,target_mm,deviation_um"]
    for run in (1, 2):
        lines += ["%d,+,%d.0,%.3f" % (run, i, 0.5 * (i % 13) + 0.1 * run) for i in range(targets)]
        lines += ["%d,-,%d.0,%.3f" % (run, i, 0.5 * (i % 13) - 0.1 * run)
                  for i in range(targets - 1, -1, -1)]
    return ("\n".join(lines) + "\n").encode()


def memory_kb(pid):
    """(VmRSS, VmHWM) of a process in kB."""
    with open("/proc/%d/status" % pid) as f:
        fields = dict(line.split(":", 1) for line in f if ":" in line)
    return int(fields["VmRSS"].split()[0]), int(fields["VmHWM"].split()[0])


def pdf_facts(tmp, body):
    """(pages, text) of a PDF, read with poppler's pdfinfo and pdftotext."""
    path = os.path.join(tmp, "report.pdf")
    with open(path, "wb") as f:
        f.write(body)
    info = subprocess.run(["pdfinfo", path], capture_output=True, text=True).stdout
    pages = int(next((l.split()[1] for l in info.splitlines() if l.startswith("Pages:")), "-1"))
    text = subprocess.run(["pdftotext", path, "-"], capture_output=True, text=True).stdout
    return pages, " ".join(text.split())


class Burst:
    """`n` clients asking for the report at once (each once, or again and again until stopped),
    and a client asking /healthz every 50 ms meanwhile."""

    def __init__(self, srv, path, n, repeat=False):
        self.srv, self.path, self.n, self.repeat = srv, path, n, repeat
        self.answers, self.health, self.errors = [], [], []
        self.stop = threading.Event()
        self.lock = threading.Lock()

    def _client(self):
        while True:
            t0 = time.time()
            try:
                status, headers, body = self.srv.request("GET", self.path)
                with self.lock:
                    self.answers.append((status, headers.get("retry-after"), time.time() - t0,
                                         body[:5]))
            except OSError as e:
                with self.lock:
                    self.errors.append(str(e))
                return
            if not self.repeat or self.stop.is_set():
                return

    def _healthz(self):
        while not self.stop.is_set():
            t0 = time.time()
            try:
                status = self.srv.request("GET", "/healthz", token=None)[0]
            except OSError:
                return
            self.health.append((status, time.time() - t0))
            time.sleep(0.05)

    def start(self):
        self.threads = [threading.Thread(target=self._client) for _ in range(self.n)]
        self.health_thread = threading.Thread(target=self._healthz)
        self.health_thread.start()
        for t in self.threads:
            t.start()
        return self

    def join(self, timeout=120):
        for t in self.threads:
            t.join(timeout)
        self.stop.set()
        self.health_thread.join(timeout)


def one_report(srv, tmp, mid, check):
    t0 = time.time()
    status, headers, body = srv.request("GET", "/api/v1/measurements/%d/report.pdf" % mid)
    took = time.time() - t0
    check(status == 200, "the report: %d" % status)
    pages, text = pdf_facts(tmp, body)
    print("report of 100 000 targets: %d pages, %d bytes, %.2f s" % (pages, len(body), took))
    check(0 < pages <= 30, "the report has %d pages (at most 30)" % pages)
    check("200 of 100000 targets shown" in text, "the report says its table is summarised")
    check("/api/v1/measurements/%d/results" % mid in text, "the report names the full table")
    check(took < 15, "one report took %.1f s" % took)


def burst_of_eight(srv, mid, check):
    rss0, _ = memory_kb(srv.proc.pid)
    burst = Burst(srv, "/api/v1/measurements/%d/report.pdf" % mid, 8).start()
    burst.join()
    time.sleep(1.0)
    rss1, hwm = memory_kb(srv.proc.pid)
    made = [a for a in burst.answers if a[0] == 200]
    refused = [a for a in burst.answers if a[0] == 503]
    lat = [h[1] for h in burst.health]
    print("8 reports at once: %d made (slowest %.2f s), %d refused 503 (Retry-After %s, slowest "
          "answer %.3f s); /healthz %d answers, p50 %.3f s, p99 %.3f s, max %.3f s" %
          (len(made), max([a[2] for a in made] or [0]), len(refused),
           sorted({a[1] for a in refused}), max([a[2] for a in refused] or [0]), len(lat),
           percentile(lat, 50), percentile(lat, 99), max(lat or [0])))
    print("RSS before %d MB, peak %d MB, after %d MB" % (rss0 // 1024, hwm // 1024, rss1 // 1024))
    check(not burst.errors, "report requests failed: %s" % burst.errors[:3])
    check(len(made) + len(refused) == 8, "every report answered 200 or 503: %s" %
          [a[0] for a in burst.answers])
    check(len(made) >= 1, "at least one report made")
    check(all(a[1] for a in refused), "every 503 has Retry-After")
    check(all(a[3] == b"%PDF-" for a in made), "every 200 is a PDF")
    check(all(a[2] < 1.0 for a in refused), "a refused report is answered at once")
    check(lat and all(h[0] == 200 for h in burst.health), "/healthz answered 200 throughout")
    check(lat and max(lat) < 1.0, "/healthz waited at most %.3f s (bound 1 s)" % max(lat or [0]))
    check(hwm < 700 * 1024, "peak RSS %d MB (bound 700 MB)" % (hwm // 1024))
    check(rss1 - rss0 < 150 * 1024, "RSS kept after the reports: %d MB more than before (bound "
          "150 MB)" % ((rss1 - rss0) // 1024))


def stop_during_reports(srv, mid, check):
    burst = Burst(srv, "/api/v1/measurements/%d/report.pdf" % mid, 8, repeat=True).start()
    time.sleep(1.5)
    t0 = time.time()
    srv.signal(signal.SIGTERM)
    try:
        rc = srv.wait(timeout=30)
    except subprocess.TimeoutExpired:
        rc = None
        srv.proc.kill()
    took = time.time() - t0
    burst.stop.set()
    burst.join(30)
    print("SIGTERM while 8 clients ask for reports: stopped in %.2f s, exit %s" % (took, rc))
    check(rc == 0, "exit status %s after SIGTERM" % rc)
    check(took < 10.0, "stopped %.1f s after SIGTERM (deadline 10 s)" % took)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repo", required=True)
    ap.add_argument("--bin", required=True)
    a = ap.parse_args()
    binary = os.path.join(a.bin, "kinemetricd")
    check = Checks()
    with tempfile.TemporaryDirectory() as tmp:
        srv = Server(binary, os.path.join(tmp, "reports")).start()
        try:
            status, j = srv.json("POST", "/api/v1/measurements", positioning_file(100000))
            check(status == 201, "upload of 100 000 targets: %d %s" % (status, j))
            mid = j["id"] if status == 201 else 0
            one_report(srv, tmp, mid, check)
            burst_of_eight(srv, mid, check)
            stop_during_reports(srv, mid, check)
        finally:
            srv.stop()
    return check.finish("ops_report_load")


if __name__ == "__main__":
    sys.exit(main())
