#!/usr/bin/python3
"""Audit webhooks of a real kinemetricd against a receiver that answers one byte every 2 s
(docs/http.md, accuracy audits; docs/operations.md, stopping): each attempt ends at its 5 s
deadline, so a verdict whose attempts all drip is `failed` after them and the next verdict is
still delivered; SIGTERM during a dripping attempt stops the server within the documented 5 s
(the verdict stays `pending` and is delivered after a restart). A webhook URL in a loopback or
private range is refused at start unless audit_webhook_allow_private is set (the error names
the option, or the file and key), and a host resolved to a loopback address is refused at
delivery, without a connection."""
import argparse
import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ops_server import Checks, Server, example_dbb  # noqa: E402

ANSWER = b"HTTP/1.1 204 No Content\r\nContent-Length: 0\r\n\r\n"


class DripReceiver:
    """Takes POSTs on 127.0.0.1; the next `drips` connections are answered one byte every
    `every` seconds, the others at once. Keeps each POST's delivery id and arrival time."""

    def __init__(self, every=2.0):
        self.every, self.drips, self.got = every, 0, []
        self.lock = threading.Lock()
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(16)
        self.port = self.sock.getsockname()[1]
        self.url = "http://127.0.0.1:%d/hook" % self.port
        threading.Thread(target=self._accept, daemon=True).start()

    def _accept(self):
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            threading.Thread(target=self._serve, args=(conn,), daemon=True).start()

    def _serve(self, conn):
        with conn:
            data = b""
            while b"\r\n\r\n" not in data:
                chunk = conn.recv(4096)
                if not chunk:
                    return
                data += chunk
            head = data.split(b"\r\n\r\n")[0].decode("latin-1").split("\r\n")[1:]
            headers = dict(line.split(": ", 1) for line in head if ": " in line)
            with self.lock:
                drip = self.drips > 0
                self.drips -= 1 if drip else 0
                self.got.append((headers.get("X-Kinemetric-Delivery"), time.time()))
            try:
                if not drip:
                    conn.sendall(ANSWER)
                    return
                for i in range(len(ANSWER)):
                    conn.sendall(ANSWER[i:i + 1])
                    time.sleep(self.every)
            except OSError:
                pass  # the server gave up on the attempt

    def deliveries(self, delivery=None):
        with self.lock:
            return [t for d, t in self.got if delivery is None or d == delivery]

    def close(self):
        self.sock.close()


class Auditor:
    """A machine with one uploaded DBB test and rules that warn on it: each run is a level 2
    verdict, due to the webhook."""

    def __init__(self, srv, repo):
        self.srv = srv
        st, _, body = srv.request("POST", "/api/v1/measurements", body=example_dbb(repo),
                                  headers={"Content-Type": "text/plain", "X-Filename": "a.txt"})
        mid = json.loads(body)["id"]
        self.machine = json.loads(srv.request("GET", "/api/v1/measurements/%d" % mid)[2])
        self.machine = self.machine["machine_id"]
        rules = {"rules": [{"kind": "dbb", "metric": "circularity_um", "warn": 0.001,
                            "stop": 1e6}], "schedule": None}
        srv.request("PUT", "/api/v1/machines/%s/audit" % self.machine, body=rules)

    def run(self):
        path = "/api/v1/machines/%s/audit/run" % self.machine
        return json.loads(self.srv.request("POST", path, body=b"")[2])["id"]

    def wait_settled(self, verdict, timeout):
        return wait_settled(self.srv, verdict, timeout)


def webhook(srv, verdict):
    return json.loads(srv.request("GET", "/api/v1/audits/%d" % verdict)[2])["webhook"]


def wait_settled(srv, verdict, timeout):
    """The verdict's webhook status once it is no longer pending (or after timeout s)."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        w = webhook(srv, verdict)
        if w["status"] != "pending":
            return w
        time.sleep(0.1)
    return webhook(srv, verdict)


def server(a, data_dir, url, *extra):
    args = ["--audit-webhook-url", url, "--audit-webhook-first-delay-ms", "100", "--access-log",
            "off"] + list(extra)
    return Server(os.path.join(a.bin, "kinemetricd"), data_dir, args).start()


def later_verdicts_are_not_stuck(a, data_dir, rec, check):
    """Verdict A drips on both attempts (failed after two deadlines), B is delivered after."""
    srv = server(a, data_dir, rec.url, "--audit-webhook-allow-private",
                 "--audit-webhook-attempts", "2")
    try:
        audit = Auditor(srv, a.repo)
        rec.drips = 2
        t0 = time.time()
        first, second = audit.run(), audit.run()
        w1 = audit.wait_settled(first, 30)
        w2 = audit.wait_settled(second, 10)
        took = time.time() - t0
        check(w1 == {"status": "failed", "attempts": 2}, "dripping verdict failed: %s" % w1)
        check(w2 == {"status": "delivered", "attempts": 1}, "next verdict delivered: %s" % w2)
        tries = rec.deliveries("audit-%d" % first)
        gap = tries[1] - tries[0] if len(tries) == 2 else -1
        check(4.8 <= gap <= 6.5, "an attempt ends at its 5 s deadline (%.2f s)" % gap)
        check(took < 15, "both verdicts settled in %.1f s" % took)
        print("ops_webhook_drip: dripping attempt ended after %.2f s; both verdicts settled "
              "after %.1f s" % (gap, took))
    finally:
        check(srv.stop() == 0, "exit 0")


def sigterm_is_bounded(a, data_dir, rec, check):
    """SIGTERM during a dripping attempt; the verdict is delivered after a restart."""
    srv = server(a, data_dir, rec.url, "--audit-webhook-allow-private")
    audit = Auditor(srv, a.repo)
    rec.drips = 100
    verdict = audit.run()
    deadline = time.time() + 10
    while not rec.deliveries("audit-%d" % verdict) and time.time() < deadline:
        time.sleep(0.02)
    time.sleep(0.5)  # the answer drips
    t0 = time.time()
    srv.signal(signal.SIGTERM)
    try:
        rc = srv.wait(30)
    except subprocess.TimeoutExpired:
        srv.proc.kill()
        rc = srv.wait(10)
    stop_s = time.time() - t0
    check(rc == 0, "SIGTERM during a dripping attempt: exit 0 (%s)" % rc)
    check(stop_s <= 5.0, "stopped within the documented 5 s (%.2f s)" % stop_s)
    print("ops_webhook_drip: SIGTERM with a dripping receiver stopped in %.2f s" % stop_s)
    rec.drips = 0
    srv = server(a, data_dir, rec.url, "--audit-webhook-allow-private")
    try:
        w = wait_settled(srv, verdict, 10)
        check(w["status"] == "delivered", "the pending verdict delivered after a restart: %s" % w)
    finally:
        check(srv.stop() == 0, "exit 0 after the restart")


def refused(a, tmp, check):
    """Loopback and private webhook URLs without audit_webhook_allow_private."""
    binary = os.path.join(a.bin, "kinemetricd")
    base = [binary, "--listen", "127.0.0.1:0", "--data-dir", os.path.join(tmp, "refused")]
    out = subprocess.run(base + ["--audit-webhook-url", "http://127.0.0.1:9/hook"],
                         capture_output=True, text=True, timeout=20)
    check(out.returncode == 2 and "--audit-webhook-url" in out.stderr
          and "audit_webhook_allow_private" in out.stderr,
          "a loopback URL is refused naming the option: %s" % out.stderr.splitlines()[:1])
    conf = os.path.join(tmp, "private.conf")
    with open(conf, "w") as f:
        json.dump({"audit_webhook_url": "http://192.168.1.20/hook"}, f)
    out = subprocess.run(base + ["--config", conf], capture_output=True, text=True, timeout=20)
    check(out.returncode == 2 and conf in out.stderr and "audit_webhook_url" in out.stderr,
          "a private URL is refused naming the file and key: %s" % out.stderr.splitlines()[:1])


def resolved_loopback_refused(a, data_dir, rec, check):
    """127.1 is no address as written; it resolves to 127.0.0.1, refused at delivery."""
    url = "http://127.1:%d/hook" % rec.port
    srv = server(a, data_dir, url, "--audit-webhook-attempts", "1")
    try:
        audit = Auditor(srv, a.repo)
        before = len(rec.deliveries())
        w = audit.wait_settled(audit.run(), 10)
        check(w == {"status": "failed", "attempts": 1}, "resolved loopback refused: %s" % w)
        check(len(rec.deliveries()) == before, "no connection to the refused address")
    finally:
        check(srv.stop() == 0, "exit 0")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repo", required=True)
    ap.add_argument("--bin", required=True)
    a = ap.parse_args()
    check = Checks()
    rec = DripReceiver(every=2.0)
    try:
        with tempfile.TemporaryDirectory() as tmp:
            later_verdicts_are_not_stuck(a, os.path.join(tmp, "queue"), rec, check)
            sigterm_is_bounded(a, os.path.join(tmp, "stop"), rec, check)
            refused(a, tmp, check)
            resolved_loopback_refused(a, os.path.join(tmp, "resolved"), rec, check)
    finally:
        rec.close()
    return check.finish("ops_webhook_drip")


if __name__ == "__main__":
    sys.exit(main())
