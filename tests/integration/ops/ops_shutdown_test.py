#!/usr/bin/python3
"""Graceful stop of a real kinemetricd (docs/operations.md): on SIGTERM it stops accepting, an
upload in flight (headers sent, body still arriving) is finished and answered 201, a new request
on an open keep-alive connection is answered 503, the process exits 0 within the bound, and after
a restart the upload is there byte for byte and the database is intact. A request that never
ends does not hold the stop past --shutdown-timeout-s; SIGINT stops it the same way."""
import argparse
import os
import signal
import socket
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ops_server import (ADMIN_TOKEN, Checks, Server, check_database, distinct_dbb,  # noqa: E402
                        example_dbb, sha256, wait_in_flight)


def open_upload(port, body):
    """A socket with the request headers of an upload of `body` sent, and none of the body."""
    s = socket.create_connection(("127.0.0.1", port), timeout=30)
    head = ("POST /api/v1/measurements HTTP/1.1\r\nHost: 127.0.0.1\r\nAuthorization: Bearer %s\r\n"
            "Content-Length: %d\r\nX-Filename: slow.txt\r\n\r\n" % (ADMIN_TOKEN, len(body)))
    s.sendall(head.encode())
    return s


def read_status(s):
    data = b""
    while b"\r\n" not in data:
        chunk = s.recv(4096)
        if not chunk:
            break
        data += chunk
    parts = data.split(b" ", 2)
    return int(parts[1]) if len(parts) > 2 else 0


def slow_upload_survives(binary, repo, tmp, check):
    srv = Server(binary, os.path.join(tmp, "graceful")).start()
    body = distinct_dbb(example_dbb(repo), 7, "shutdown")
    keep = srv.conn()
    check(srv.request("GET", "/healthz", token=None, conn=keep)[0] == 200, "keep-alive healthz")
    up = open_upload(srv.port, body)
    up.sendall(body[:1000])
    check(wait_in_flight(srv, 1), "the upload is in flight")
    t0 = time.time()
    srv.signal(signal.SIGTERM)
    time.sleep(0.5)
    refused = False
    try:
        socket.create_connection(("127.0.0.1", srv.port), timeout=2).close()
    except OSError:
        refused = True
    check(refused, "no new connections after SIGTERM")
    status = srv.request("GET", "/healthz", token=None, conn=keep)[0]
    check(status == 503, "a new request on an open connection: %d, expected 503" % status)
    check(srv.proc.poll() is None, "the server waits for the upload in flight")
    for i in range(1000, len(body), 1000):  # the rest of the body, slowly
        up.sendall(body[i:i + 1000])
        time.sleep(0.1)
    status = read_status(up)
    up.close()
    check(status == 201, "the upload in flight is answered %d, expected 201" % status)
    rc = srv.wait(timeout=15)
    elapsed = time.time() - t0
    check(rc == 0, "exit status %d after SIGTERM" % rc)
    check(elapsed < 10.0, "stopped %.1f s after SIGTERM (bound 10 s)" % elapsed)
    print("graceful stop with one upload in flight: %.2f s" % elapsed)
    srv.start()
    try:
        st, listing = srv.json("GET", "/api/v1/measurements?limit=10")
        shas = [m.get("sha256") for m in listing["items"]] if st == 200 else []
        check(sha256(body) in shas, "the upload is stored after the restart")
        integrity, orphans, raw = check_database(srv.data_dir)
        check(integrity == "ok", "integrity_check: %s" % integrity)
        check(orphans == 0, "measurements without results: %d" % orphans)
        check(sha256(body) in raw.values(), "the stored bytes are the bytes sent")
    finally:
        check(srv.stop() == 0, "exit 0")


def stalled_request_bounded(binary, tmp, check):
    srv = Server(binary, os.path.join(tmp, "stalled"), ["--shutdown-timeout-s", "1"]).start()
    up = open_upload(srv.port, b"x" * 5000)
    up.sendall(b"x" * 100)
    check(wait_in_flight(srv, 1), "the stalled upload is in flight")
    t0 = time.time()
    srv.signal(signal.SIGTERM)
    rc = srv.wait(timeout=15)
    elapsed = time.time() - t0
    up.close()
    check(rc == 0, "stalled request: exit status %d" % rc)
    check(0.8 < elapsed < 6.0, "stalled request: stopped after %.2f s (bound 1 s)" % elapsed)
    check(any("still in flight" in line for line in srv.lines), "the stop names what it cut")


def sigint_stops(binary, tmp, check):
    srv = Server(binary, os.path.join(tmp, "sigint")).start()
    t0 = time.time()
    srv.signal(signal.SIGINT)
    rc = srv.wait(timeout=15)
    check(rc == 0 and time.time() - t0 < 5, "SIGINT: exit status %d" % rc)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repo", required=True)
    ap.add_argument("--bin", required=True)
    a = ap.parse_args()
    binary = os.path.join(a.bin, "kinemetricd")
    check = Checks()
    with tempfile.TemporaryDirectory() as tmp:
        slow_upload_survives(binary, a.repo, tmp, check)
        stalled_request_bounded(binary, tmp, check)
        sigint_stops(binary, tmp, check)
    return check.finish("ops_shutdown")


if __name__ == "__main__":
    sys.exit(main())
