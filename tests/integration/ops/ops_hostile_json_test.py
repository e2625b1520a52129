#!/usr/bin/python3
"""Hostile JSON against a real kinemetricd: bodies nested tens of thousands deep (as arrays and
as objects) on every route that takes JSON, a machine model whose notes nest 400 000 deep,
numbers beyond a double (1e999) anywhere in a body, and repeated keys. Every one must be
refused with 400 naming the field (never a crash, never a 500), nothing may be stored, and the
server must still answer afterwards with its memory bounded. The routes come from the server's
own OpenAPI document, so a new JSON route is probed as soon as it exists."""
import argparse
import json
import os
import re
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ops_server import Checks, Server  # noqa: E402


def rss_mb(srv):
    with open("/proc/%d/status" % srv.proc.pid) as f:
        return int(re.search(r"VmRSS:\s+(\d+)", f.read()).group(1)) / 1024.0


def deep_array(n):
    return "[" * n + "]" * n


def deep_object(n):
    return '{"a":' * n + "1" + "}" * n


def post_raw(srv, method, path, text):
    status, _, body = srv.request(method, path, text.encode(),
                                  headers={"Content-Type": "application/json"})
    try:
        return status, json.loads(body) if body else {}
    except ValueError:
        return status, {"raw": body[:200].decode(errors="replace")}


def json_operations(srv):
    """(method, path) of every operation with a JSON request body, ids of things that exist."""
    _, doc = srv.json("GET", "/api/v1/openapi.json", token=None)
    out = []
    for pattern, item in doc["paths"].items():
        for method, op in item.items():
            content = op.get("requestBody", {}).get("content", {})
            if "application/json" not in content:
                continue
            path = pattern.replace("{machine_id}", "hostile-m").replace("{name}", "nobody")
            out.append((method.upper(), re.sub(r"\{[^}]+\}", "1", path)))
    return out


def check_deep(srv, check):
    # The cases of the report: a stream with x nested 60 000 deep, a calibration with an inline
    # machine 100 000 deep, a machine model with notes 400 000 deep.
    cases = [
        ("POST", "/api/v1/streams", '{"machine_id":"m","x":%s}' % deep_array(60000), "x"),
        ("POST", "/api/v1/calibrations",
         '{"machine_id":"m","measurement_ids":[1],"machine":{"notes":%s}}' % deep_array(100000),
         "machine.notes"),
        ("POST", "/api/v1/machines",
         '{"format":"kinemetric-machine/1","machine_id":"deep","kind":"hexapod","notes":%s}'
         % deep_array(400000), "notes"),
        ("POST", "/api/v1/streams", '{"machine_id":"m","x":%s}' % deep_object(20000), "x.a"),
    ]
    for method, path, text, field in cases:
        status, j = post_raw(srv, method, path, text)
        check(status == 400 and str(j.get("field", "")).startswith(field),
              "%s %s nested deep (%d KB): %d field %r" % (method, path, len(text) // 1024, status,
                                                          j.get("field")))
    status, j = srv.json("GET", "/api/v1/machines")
    check(status == 200 and "deep" not in json.dumps(j), "the deep machine was not stored")
    # Every JSON route, both shapes, 20 000 deep.
    for method, path in json_operations(srv):
        for text in ('{"x":%s}' % deep_array(20000), '{"x":%s}' % deep_object(20000)):
            status, j = post_raw(srv, method, path, text)
            check(status in (400, 404, 413) and status < 500,
                  "%s %s deep: %d %s" % (method, path, status, j))


def check_numbers_and_keys(srv, check):
    probes = 0
    for method, path in json_operations(srv):
        for text, field in (('{"x":1e999}', "x"), ('{"a":{"b":[0,-1e999]}}', "a.b[1]")):
            status, j = post_raw(srv, method, path, text)
            probes += 1
            # Where the route looks a resource up before reading the body a 404 is fine.
            check(status == 404 or (status == 400 and j.get("field") == field),
                  "%s %s %s: %d field %r" % (method, path, text, status, j.get("field")))
    check(probes >= 20, "%d probes of numbers beyond a double" % probes)
    status, j = post_raw(srv, "POST", "/api/v1/tokens",
                         '{"name":"dup","role":"viewer","role":"admin"}')
    check(status == 400 and j.get("field") == "role", "repeated role: %d %s" % (status, j))
    status, tokens = srv.json("GET", "/api/v1/tokens")
    check(all(t["name"] != "dup" for t in tokens["items"]), "no token made from a repeated key")
    status, j = post_raw(srv, "POST", "/api/v1/streams",
                         '{"machine_id":"a","name":"s","machine_id":"b"}')
    check(status == 400 and j.get("field") == "machine_id", "repeated key: %d %s" % (status, j))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repo", required=True)
    ap.add_argument("--bin", required=True)
    a = ap.parse_args()
    check = Checks()
    with tempfile.TemporaryDirectory() as tmp:
        srv = Server(os.path.join(a.bin, "kinemetricd"), os.path.join(tmp, "d"),
                     ["--access-log", "off"]).start()
        try:
            before = rss_mb(srv)
            check_deep(srv, check)
            check_numbers_and_keys(srv, check)
            status, _, _ = srv.request("GET", "/healthz", token=None)
            check(status == 200 and srv.proc.poll() is None, "the server still answers")
            after = rss_mb(srv)
            print("RSS %.0f MB before the probes, %.0f MB after" % (before, after))
            check(after < before + 300, "RSS bounded: %.0f → %.0f MB" % (before, after))
        finally:
            code = srv.stop()
        check(code == 0, "clean stop: exit %s" % code)
    return check.finish("ops_hostile_json_test")


if __name__ == "__main__":
    sys.exit(main())
