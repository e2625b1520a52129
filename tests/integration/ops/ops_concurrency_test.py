#!/usr/bin/python3
"""Concurrent uploaders and readers against a real kinemetricd (docs/operations.md): every
request succeeds (no error, no 503), every acknowledged upload is listed and stored byte for
byte afterwards (nothing lost), and the median and 99th-percentile latencies of uploads and of
reads are printed. Default: 8 uploaders + 8 readers for 5 s; --long: 32 + 32 for 60 s."""
import argparse
import http.client
import os
import random
import sys
import tempfile
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ops_server import (Checks, Server, check_database, distinct_dbb, example_dbb,  # noqa: E402
                        percentile, sha256)


def uploader(srv, base, first, until, acked, latencies, errors):
    conn, n = srv.conn(), first
    while time.time() < until:
        body = distinct_dbb(base, n, "conc")
        n += 1
        t0 = time.perf_counter()
        try:
            status, j = srv.json("POST", "/api/v1/measurements", body, conn=conn)
        except (OSError, ValueError, http.client.HTTPException) as e:
            errors.append("upload: %r" % e)
            conn = srv.conn()
            continue
        latencies.append(time.perf_counter() - t0)
        if status == 201 and j.get("sha256") == sha256(body):
            acked.append((j["id"], body))
        else:
            errors.append("upload: %d %s" % (status, j))
    conn.close()


def reader(srv, until, acked, latencies, errors, rng):
    conn = srv.conn()
    while time.time() < until:
        if acked and rng.random() < 0.5:
            i, body = acked[rng.randrange(len(acked))]
            path, want = "/api/v1/measurements/%d/results" % i, None
        else:
            path, want = "/api/v1/measurements?limit=20", "items"
        t0 = time.perf_counter()
        try:
            status, j = srv.json("GET", path, conn=conn)
        except (OSError, ValueError, http.client.HTTPException) as e:
            errors.append("read: %r" % e)
            conn = srv.conn()
            continue
        latencies.append(time.perf_counter() - t0)
        if status != 200 or (want and want not in j):
            errors.append("read %s: %d" % (path, status))
    conn.close()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repo", required=True)
    ap.add_argument("--bin", required=True)
    ap.add_argument("--long", action="store_true")
    a = ap.parse_args()
    n, seconds = (32, 60) if a.long else (8, 5)
    check = Checks()
    base = example_dbb(a.repo)
    acked, up_lat, rd_lat, errors = [], [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        srv = Server(os.path.join(a.bin, "kinemetricd"), os.path.join(tmp, "d"),
                     ["--access-log", "off", "--queue-limit", "256"]).start()
        try:
            until = time.time() + seconds
            threads = [threading.Thread(target=uploader, args=(srv, base, i * 1000000, until,
                                                               acked, up_lat, errors))
                       for i in range(n)]
            threads += [threading.Thread(target=reader, args=(srv, until, acked, rd_lat, errors,
                                                              random.Random(i)))
                        for i in range(n)]
            for t in threads:
                t.start()
            for t in threads:
                t.join()
            check(not errors, "%d errors, first: %s" % (len(errors), errors[:3]))
            status, listing = srv.json("GET", "/api/v1/measurements?limit=1")
            check(status == 200 and listing["total"] == len(acked),
                  "listed %s, acknowledged %d" % (listing.get("total"), len(acked)))
            integrity, orphans, raw = check_database(srv.data_dir)
            lost = [i for i, body in acked if raw.get(i) != sha256(body)]
            check(integrity == "ok" and orphans == 0, "integrity %s, %d without results" %
                  (integrity, orphans))
            check(not lost, "%d acknowledged uploads lost or changed" % len(lost))
            check(len(acked) > n and len(rd_lat) > n, "work was done")
        finally:
            check(srv.stop() == 0, "exit 0")
    ms = 1000.0
    print("%d uploaders + %d readers, %d s: %d uploads (p50 %.1f ms, p99 %.1f ms), %d reads "
          "(p50 %.1f ms, p99 %.1f ms), %d errors" %
          (n, n, seconds, len(up_lat), percentile(up_lat, 50) * ms, percentile(up_lat, 99) * ms,
           len(rd_lat), percentile(rd_lat, 50) * ms, percentile(rd_lat, 99) * ms, len(errors)))
    return check.finish("ops_concurrency")


if __name__ == "__main__":
    sys.exit(main())
