#!/usr/bin/python3
"""Edges of a real kinemetricd that a careless client or an attacker reaches:
- stream counters at the 64-bit edge (docs/streams.md, Counter range): 2⁶³ − 1 is the last
  counter, anything past it is refused 400, the stream list and the stream stay readable (also
  after a restart), and a resent last frame is a duplicate;
- the last admin: concurrent revocations of the last two lasting admins never both succeed, an
  expiring admin does not count as the one that remains, and `kinemetricd --reset-admin`
  recovers;
- a token revoked while its chunked upload is open stops writing at once (401);
- a frames upload cut mid-body and a chunked body over its route's limit each leave an audit
  entry and an access-log line."""
import argparse
import json
import os
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time
import zlib

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ops_server import ADMIN_TOKEN, Checks, Server, database_url  # noqa: E402

MAX_COUNTER = 2**63 - 1
NDJSON = {"Content-Type": "application/x-ndjson"}


def open_stream(srv, name):
    status, s = srv.json("POST", "/api/v1/streams", {
        "machine_id": "edges-m", "name": name,
        "channels": [{"channel": 1, "name": "cap", "unit": "um", "rate_hz": 100}]})
    assert status == 201, (status, s)
    return s["id"]


def sample(counter, t_us=1793600000000000):
    return json.dumps({"channel": 1, "counter": counter, "t_us": t_us, "value_um": 0.25}) + "\n"


def frames(srv, sid, text, token=ADMIN_TOKEN):
    status, _, body = srv.request("POST", "/api/v1/streams/%d/frames" % sid, text.encode(),
                                  token=token, headers=NDJSON)
    return status, json.loads(body) if body else {}


def binary_frame(first_counter, n):
    head = struct.pack("<4sBBHIQqI", b"KMSF", 1, 0, 1, n, first_counter, 1793600000000000, 1000)
    body = head + struct.pack("<%dd" % n, *([0.5] * n))
    return body + struct.pack("<I", zlib.crc32(body))


def check_counters(srv, check):
    sid = open_stream(srv, "edge")
    check(frames(srv, sid, sample(0))[0] == 200, "counter 0 stored")
    status, j = frames(srv, sid, sample(MAX_COUNTER, 1793600000001000))
    check(status == 200 and j["gaps"][0]["first_missing"] == 1
          and j["gaps"][0]["missing"] == MAX_COUNTER - 1, "counter 2^63-1: %d %s" % (status, j))
    status, j = frames(srv, sid, sample(2**64 - 1, 1793600000002000))
    check(status == 400 and j.get("field") == "counter", "counter 2^64-1 refused: %d %s" % (status, j))
    status, _, body = srv.request("POST", "/api/v1/streams/%d/frames" % sid,
                                  binary_frame(MAX_COUNTER, 2),
                                  headers={"Content-Type": "application/vnd.kinemetric.stream-frame"})
    check(status == 400 and json.loads(body).get("field") == "first_counter",
          "binary frame past 2^63-1 refused: %d %s" % (status, body[:200]))
    status, j = frames(srv, sid, sample(MAX_COUNTER, 1793600000001000))
    check(status == 200 and j["duplicates"] == 1 and j["stored"] == 0,
          "the last counter resent is a duplicate: %d %s" % (status, j))
    lone = open_stream(srv, "lone")
    frames(srv, lone, sample(MAX_COUNTER))
    status, j = frames(srv, lone, sample(MAX_COUNTER))
    check(status == 200 and j["duplicates"] == 1, "a lone last frame resent: %d %s" % (status, j))
    return sid, lone


def check_stream_reads(srv, sid, lone, check, when):
    status, listing = srv.json("GET", "/api/v1/streams")
    check(status == 200, "%s: stream list %d" % (when, status))
    status, s = srv.json("GET", "/api/v1/streams/%d" % sid)
    ch = (s or {}).get("channels", [{}])[0]
    check(status == 200 and ch.get("next_counter") == MAX_COUNTER + 1
          and ch.get("missing") == MAX_COUNTER - 1 and s.get("missing") == MAX_COUNTER - 1
          and ch.get("samples") == 2, "%s: stream %d %s" % (when, status, s))
    status, s = srv.json("GET", "/api/v1/streams/%d" % lone)
    check(status == 200 and s["channels"][0]["next_counter"] == MAX_COUNTER + 1,
          "%s: lone stream %d %s" % (when, status, s))
    status, g = srv.json("GET", "/api/v1/streams/%d/gaps" % sid)
    check(status == 200 and g["items"][0]["first_missing"] == 1, "%s: gaps %d %s" % (when, status, g))


def new_admin(srv, token, name, expires=None):
    body = {"name": name, "role": "admin"}
    if expires:
        body["expires_in_s"] = expires
    status, t = srv.json("POST", "/api/v1/tokens", body, token=token)
    assert status == 201, (status, t)
    return t


def check_last_admin(srv, check, trials):
    a = {"id": 1, "token": ADMIN_TOKEN}
    b = new_admin(srv, ADMIN_TOKEN, "second")
    both = 0
    for trial in range(trials):
        results = {}
        barrier = threading.Barrier(2)

        def revoke(me, other):
            barrier.wait()
            results[me["id"]] = srv.request("DELETE", "/api/v1/tokens/%d" % other["id"],
                                            token=me["token"])[0]
        threads = [threading.Thread(target=revoke, args=(a, b)),
                   threading.Thread(target=revoke, args=(b, a))]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        codes = sorted(results.values())
        if codes.count(200) > 1:
            both += 1
        # The survivor makes the next partner.
        survivor = next((x for x in (a, b) if srv.request("GET", "/api/v1/whoami",
                                                          token=x["token"])[0] == 200), None)
        if survivor is None:
            check(False, "trial %d: no admin token left (%s)" % (trial, codes))
            return
        a, b = survivor, new_admin(srv, survivor["token"], "partner %d" % trial)
    print("last admin: %d trials of two concurrent revocations, both succeeded in %d"
          % (trials, both))
    check(both == 0, "both of two concurrent revocations succeeded in %d of %d trials"
          % (both, trials))
    # An expiring admin is not the admin that remains.
    srv.request("DELETE", "/api/v1/tokens/%d" % b["id"], token=a["token"])
    new_admin(srv, a["token"], "short", expires=3)
    status, _, body = srv.request("DELETE", "/api/v1/tokens/%d" % a["id"], token=a["token"])
    check(status == 409, "revoking the last lasting admin beside an expiring one: %d %s"
          % (status, body[:200]))
    return a


def check_reset_admin(srv, binary, check):
    url = database_url(srv.data_dir)
    extra = ["--database", url] if url else []
    out = subprocess.run([binary, "--data-dir", srv.data_dir, "--reset-admin"] + extra,
                         capture_output=True, text=True, timeout=60)
    token = out.stdout.strip().rsplit(" ", 1)[-1]
    check(out.returncode == 0 and len(token) == 64, "--reset-admin: %d %r %r"
          % (out.returncode, out.stdout, out.stderr))
    status, who = srv.json("GET", "/api/v1/whoami", token=token)
    check(status == 200 and who["role"] == "admin", "the recovery token works: %d %s" % (status, who))


def chunked_upload(srv, path, token, headers):
    s = socket.create_connection(("127.0.0.1", srv.port), timeout=30)
    head = "POST %s HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer %s\r\nTransfer-Encoding: " \
           "chunked\r\n" % (path, token)
    head += "".join("%s: %s\r\n" % kv for kv in headers.items()) + "\r\n"
    s.sendall(head.encode())
    return s


def send_chunk(s, data):
    s.sendall(b"%x\r\n%s\r\n" % (len(data), data))


def read_status(s):
    data = b""
    try:
        while b"\r\n" not in data:
            piece = s.recv(4096)
            if not piece:
                break
            data += piece
    except OSError:
        pass
    parts = data.split(b" ", 2)
    return int(parts[1]) if len(parts) > 1 and parts[1].isdigit() else 0


def stored_samples(srv, sid):
    return srv.json("GET", "/api/v1/streams/%d" % sid)[1]["samples"]


def check_revoked_upload(srv, check):
    status, t = srv.json("POST", "/api/v1/tokens", {"name": "line 7", "role": "operator"})
    sid = open_stream(srv, "revoked")
    s = chunked_upload(srv, "/api/v1/streams/%d/frames" % sid, t["token"], NDJSON)
    counter = 0
    for _ in range(10):  # 10 pieces of 100 samples before the revocation
        send_chunk(s, "".join(sample(counter + k, 1793600000000000 + 1000 * (counter + k))
                              for k in range(100)).encode())
        counter += 100
        time.sleep(0.05)
    time.sleep(0.3)
    sent_before = counter
    status, _, _ = srv.request("DELETE", "/api/v1/tokens/%d" % t["id"])
    check(status == 200, "revoke the uploader's token: %d" % status)
    answer = 0
    for _ in range(10):
        try:
            send_chunk(s, "".join(sample(counter + k, 1793600000000000 + 1000 * (counter + k))
                                  for k in range(100)).encode())
        except OSError:
            break
        counter += 100
        time.sleep(0.1)
    try:
        s.sendall(b"0\r\n\r\n")
    except OSError:
        pass
    answer = read_status(s)
    s.close()
    check(answer == 401, "the open upload is ended with 401: %d" % answer)
    stored = stored_samples(srv, sid)
    print("revoked upload: answer %d, %d samples sent before the revocation, %d after, %d stored"
          % (answer, sent_before, counter - sent_before, stored))
    check(stored <= sent_before, "nothing written after the revocation: %d stored, %d sent before"
          % (stored, sent_before))


def audit_entries(srv, path):
    _, log = srv.json("GET", "/api/v1/audit-log?limit=1000")
    return [e for e in log["items"] if e["path"] == path]


def check_cut_and_too_large(srv, log_path, check):
    sid = open_stream(srv, "cut")
    path = "/api/v1/streams/%d/frames" % sid
    s = chunked_upload(srv, path, ADMIN_TOKEN, NDJSON)
    send_chunk(s, "".join(sample(k, 1793600000000000 + 1000 * k) for k in range(250)).encode())
    time.sleep(0.5)
    s.close()  # cut mid-body: no last chunk
    deadline = time.time() + 10
    while time.time() < deadline and not audit_entries(srv, path):
        time.sleep(0.1)
    entries = audit_entries(srv, path)
    check(len(entries) == 1 and entries[0]["status"] == 499, "cut upload audited: %s" % entries)
    check(stored_samples(srv, sid) == 250, "the cut upload kept its 250 samples")
    s = chunked_upload(srv, "/api/v1/machines", ADMIN_TOKEN, {"Content-Type": "application/json"})
    status = 0
    try:
        for _ in range(40):  # 40 × 64 KiB: past the route's 1 MiB
            send_chunk(s, b" " * 65536)
    except OSError:
        pass
    status = read_status(s)
    s.close()
    check(status == 413, "chunked machine over its limit: %d" % status)
    time.sleep(0.5)
    too_large = [e for e in audit_entries(srv, "/api/v1/machines") if e["status"] == 413]
    check(len(too_large) == 1, "the 413 is audited: %s" % too_large)
    lines = [json.loads(x) for x in open(log_path, encoding="utf-8").read().splitlines()]
    check(any(j["path"] == path and j["status"] == 499 for j in lines),
          "the cut upload has an access-log line")
    check(any(j["path"] == "/api/v1/machines" and j["status"] == 413 for j in lines),
          "the 413 has an access-log line")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repo", required=True)
    ap.add_argument("--bin", required=True)
    ap.add_argument("--long", action="store_true")
    a = ap.parse_args()
    check = Checks()
    binary = os.path.join(a.bin, "kinemetricd")
    with tempfile.TemporaryDirectory() as tmp:
        log_path = os.path.join(tmp, "access.log")
        srv = Server(binary, os.path.join(tmp, "d"), ["--access-log", log_path]).start()
        try:
            sid, lone = check_counters(srv, check)
            check_stream_reads(srv, sid, lone, check, "before a restart")
            srv.stop()
            srv.start()
            check_stream_reads(srv, sid, lone, check, "after a restart")
            check_revoked_upload(srv, check)
            check_cut_and_too_large(srv, log_path, check)
            # Last: the bootstrap admin token may be revoked in the trials.
            check_last_admin(srv, check, 300 if a.long else 30)
            check_reset_admin(srv, binary, check)
        finally:
            code = srv.stop()
        check(code == 0, "clean stop: exit %s" % code)
    return check.finish("ops_edges_test")


if __name__ == "__main__":
    sys.exit(main())
