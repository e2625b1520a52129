#!/usr/bin/python3
"""kill -9 of a real kinemetricd in the middle of a stream of uploads (docs/operations.md):
after each restart every upload that was acknowledged (201) is there, its stored bytes are the
bytes sent (SHA-256 of the raw column and of the API's answer), the SQLite file passes
PRAGMA integrity_check, every measurement has its results (nothing half-written), and sending
an acknowledged file again is answered 200 with the same id. Default: 2 kills in a few seconds;
--long: 20 kills with 4 uploaders."""
import argparse
import http.client
import os
import random
import sys
import tempfile
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ops_server import Checks, Server, check_database, distinct_dbb, example_dbb, sha256  # noqa


class Uploader(threading.Thread):
    """Uploads distinct files one after the other until the server goes away."""

    def __init__(self, srv, base, first, acked):
        super().__init__(daemon=True)
        self.srv, self.base, self.n, self.acked = srv, base, first, acked
        self.errors = []

    def run(self):
        conn = self.srv.conn(timeout=10)
        while True:
            body = distinct_dbb(self.base, self.n, "kill9")
            self.n += 1
            try:
                status, j = self.srv.json("POST", "/api/v1/measurements", body, conn=conn)
            except (OSError, ValueError, http.client.HTTPException):
                return  # killed: this upload was never acknowledged
            if status == 201 and j.get("created") and j.get("sha256") == sha256(body):
                self.acked.append((j["id"], body))
            else:
                self.errors.append("upload %d: %d %s" % (self.n, status, j))
                return


def verify(srv, acked, check):
    integrity, orphans, raw = check_database(srv.data_dir)
    check(integrity == "ok", "integrity_check: %s" % integrity)
    check(orphans == 0, "%d measurements without results" % orphans)
    missing = [i for i, body in acked if raw.get(i) != sha256(body)]
    check(not missing, "acknowledged uploads missing or changed: %s" % missing[:10])
    conn = srv.conn()
    for i, body in random.sample(acked, min(len(acked), 25)):
        status, j = srv.json("GET", "/api/v1/measurements/%d" % i, conn=conn)
        check(status == 200 and j.get("sha256") == sha256(body), "GET measurement %d" % i)
        status, _ = srv.json("GET", "/api/v1/measurements/%d/results" % i, conn=conn)
        check(status == 200, "results of %d: %d" % (i, status))
    i, body = acked[-1] if acked else (0, b"")
    if acked:
        status, j = srv.json("POST", "/api/v1/measurements", body, conn=conn)
        check(status == 200 and j["id"] == i and not j["created"], "the same bytes again: 200")
    conn.close()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repo", required=True)
    ap.add_argument("--bin", required=True)
    ap.add_argument("--long", action="store_true")
    a = ap.parse_args()
    kills, uploaders = (20, 4) if a.long else (2, 2)
    rng = random.Random(5)
    random.seed(5)
    base = example_dbb(a.repo)
    check = Checks()
    acked = []
    with tempfile.TemporaryDirectory() as tmp:
        srv = Server(os.path.join(a.bin, "kinemetricd"), os.path.join(tmp, "d"),
                     ["--access-log", "off"])
        counter = 0
        for k in range(kills):
            srv.start()
            threads = []
            for _ in range(uploaders):
                threads.append(Uploader(srv, base, counter, acked))
                counter += 100000
            before = len(acked)
            for t in threads:
                t.start()
            deadline = time.time() + 20
            while len(acked) == before and time.time() < deadline:
                time.sleep(0.02)  # a slow machine: the first acknowledgement, then the kill
            time.sleep(rng.uniform(0.3, 1.2))
            srv.kill9()
            for t in threads:
                t.join(timeout=15)
                for e in t.errors:
                    check(False, e)
            print("kill %d: %d uploads acknowledged before it" % (k + 1, len(acked) - before))
            check(len(acked) > before, "kill %d: uploads were acknowledged" % (k + 1))
            srv.start()
            verify(srv, acked, check)
            check(srv.stop() == 0, "exit 0 after the checks")
        print("%d kills, %d acknowledged uploads, all present and intact" % (kills, len(acked)))
    return check.finish("ops_kill9")


if __name__ == "__main__":
    sys.exit(main())
