#!/usr/bin/python3
"""GET /metrics and the access log of a real kinemetricd (docs/operations.md): after a known set
of requests every counter moved by exactly what was sent; the exposition follows the Prometheus
text grammar (# HELP, # TYPE, name{labels} value; histogram buckets cumulative, +Inf = count);
the access log has one JSON line per request with the route pattern, status, latency, bytes and
the token's id, and never the token or its hash; /metrics needs a viewer token unless the server
is started with --metrics-public."""
import argparse
import json
import os
import re
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ops_server import ADMIN_TOKEN, Checks, Server, distinct_dbb, example_dbb, sha256  # noqa: E402

NAME = r"[a-zA-Z_:][a-zA-Z0-9_:]*"
LABEL = r'[a-zA-Z_][a-zA-Z0-9_]*="(?:[^"\\\n]|\\.)*"'
SAMPLE = re.compile(r"^(%s)(\{(?:%s)(?:,%s)*\})? (\S+)$" % (NAME, LABEL, LABEL))
TYPES = {"counter", "gauge", "histogram", "summary", "untyped"}


def parse_exposition(text, check):
    """{(name, frozenset(labels)): value}; every grammar fault is a failed check."""
    samples, typed, helped = {}, {}, set()
    check(text.endswith("\n"), "the exposition ends with a newline")
    for n, line in enumerate(text.rstrip("\n").split("\n"), 1):
        if line.startswith("# HELP "):
            parts = line.split(" ", 3)
            check(len(parts) == 4 and re.fullmatch(NAME, parts[2]), "line %d: HELP" % n)
            helped.add(parts[2])
        elif line.startswith("# TYPE "):
            parts = line.split(" ")
            check(len(parts) == 4 and parts[3] in TYPES, "line %d: TYPE %r" % (n, line))
            check(parts[2] not in typed, "line %d: %s typed twice" % (n, parts[2]))
            typed[parts[2]] = parts[3]
        else:
            m = SAMPLE.match(line)
            if not check(m is not None, "line %d is not a sample: %r" % (n, line)):
                continue
            name, labels, value = m.group(1), m.group(2) or "", m.group(3)
            family = re.sub(r"_(bucket|sum|count)$", "", name) if name not in typed else name
            check(family in typed and family in helped, "line %d: %s has no TYPE/HELP" % (n, name))
            try:
                v = float(value)
            except ValueError:
                check(False, "line %d: value %r" % (n, value))
                continue
            pairs = frozenset(re.findall(r'([a-zA-Z_][a-zA-Z0-9_]*)="((?:[^"\\]|\\.)*)"', labels))
            check((name, pairs) not in samples, "line %d: repeated sample" % n)
            samples[(name, pairs)] = v
    return samples, typed


def value(samples, name, **labels):
    return samples.get((name, frozenset(labels.items())), 0.0)


def scrape(srv, check, token=ADMIN_TOKEN):
    status, headers, body = srv.request("GET", "/metrics", token=token)
    check(status == 200, "GET /metrics: %d" % status)
    check(headers.get("content-type", "").startswith("text/plain; version=0.0.4"),
          "content type %r" % headers.get("content-type"))
    return parse_exposition(body.decode(), check)


def check_histogram(samples, check):
    name = "kinemetric_http_request_duration_seconds"
    buckets = sorted(((float(dict(k[1])["le"]), v) for k, v in samples.items()
                      if k[0] == name + "_bucket"), key=lambda b: b[0])
    check(len(buckets) >= 5 and buckets[-1][0] == float("inf"), "histogram buckets and +Inf")
    check(all(a[1] <= b[1] for a, b in zip(buckets, buckets[1:])), "buckets are cumulative")
    check(buckets[-1][1] == value(samples, name + "_count"), "+Inf bucket = count")
    check(value(samples, name + "_sum") >= 0, "latency sum")


def drive_requests(srv, base, check):
    """The known requests; returns the two stored files."""
    a, b = distinct_dbb(base, 1, "metrics"), distinct_dbb(base, 2, "metrics")
    for _ in range(3):
        check(srv.request("GET", "/healthz", token=None)[0] == 200, "healthz")
    for _ in range(2):
        check(srv.request("GET", "/api/v1/measurements/999999")[0] == 404, "unknown id: 404")
    check(srv.request("GET", "/api/v1/measurements", token=None)[0] == 401, "no token: 401")
    check(srv.request("POST", "/api/v1/measurements", a)[0] == 201, "upload a")
    check(srv.request("POST", "/api/v1/measurements", b)[0] == 201, "upload b")
    check(srv.request("POST", "/api/v1/measurements", a)[0] == 200, "upload a again: 200")
    return a, b


def send_frames(srv, check):
    """One stream, three NDJSON frames of 10 + 10 + 5 samples with one counter jump."""
    status, s = srv.json("POST", "/api/v1/streams", {
        "machine_id": "metrics-m", "name": "metrics",
        "channels": [{"channel": 1, "name": "cap", "unit": "um", "rate_hz": 100}]})
    check(status == 201, "open stream: %d %s" % (status, s))
    frames = [(0, 10), (10, 10), (30, 5)]
    body = "".join(json.dumps({"channel": 1, "first_counter": c, "t0_us": 1793600000000000 + c
                               * 10000, "dt_us": 10000, "values_um": [0.5] * n}) + "\n"
                   for c, n in frames).encode()
    status, _, out = srv.request("POST", "/api/v1/streams/%d/frames" % s["id"], body,
                                 headers={"Content-Type": "application/x-ndjson"})
    j = json.loads(out)
    check(status == 200 and j["frames"] == 3 and j["samples"] == 25 and len(j["gaps"]) == 1,
          "frames answer %d %s" % (status, out[:300]))


def check_counters(before, after, a, b, check):
    def delta(name, **labels):
        return value(after, name, **labels) - value(before, name, **labels)

    req = "kinemetric_http_requests_total"
    expected = [
        ({"method": "GET", "route": "/healthz", "code": "2xx"}, 3),
        ({"method": "GET", "route": "/api/v1/measurements/{id}", "code": "4xx"}, 2),
        ({"method": "GET", "route": "/api/v1/measurements", "code": "4xx"}, 1),
        ({"method": "POST", "route": "/api/v1/measurements", "code": "2xx"}, 3),
        ({"method": "POST", "route": "/api/v1/streams", "code": "2xx"}, 1),
        ({"method": "POST", "route": "/api/v1/streams/{id}/frames", "code": "2xx"}, 1),
        ({"method": "GET", "route": "/metrics", "code": "2xx"}, 1),  # the first scrape
    ]
    for labels, n in expected:
        check(delta(req, **labels) == n, "%s %s: +%g, expected +%d" % (req, labels,
                                                                        delta(req, **labels), n))
    total = sum(v for (name, _), v in after.items() if name == req) - \
        sum(v for (name, _), v in before.items() if name == req)
    check(total == 12, "all requests between the scrapes: +%g, expected +12" % total)
    count = "kinemetric_http_request_duration_seconds_count"
    check(delta(count) == 12, "latency count +%g, expected +12" % delta(count))
    check(delta("kinemetric_measurements_stored_total") == 2, "measurements stored +2")
    check(delta("kinemetric_measurement_bytes_stored_total") == len(a) + len(b),
          "bytes stored +%g, expected %d" % (delta("kinemetric_measurement_bytes_stored_total"),
                                             len(a) + len(b)))
    check(delta("kinemetric_stream_frames_total") == 3, "frames +3")
    check(delta("kinemetric_stream_samples_total") == 25, "samples +25")
    check(delta("kinemetric_stream_gaps_total") == 1, "gaps +1")
    check(value(after, "kinemetric_http_requests_in_flight") == 1, "in flight: the scrape itself")
    for status in ("queued", "running", "done", "failed", "cancelled"):
        check(("kinemetric_jobs", frozenset({("status", status)})) in after, "jobs " + status)
    check(value(after, "process_start_time_seconds") > 1.7e9, "process start time")


def check_log(path, admin_id, check):
    text = open(path, encoding="utf-8").read()
    check(ADMIN_TOKEN not in text and sha256(ADMIN_TOKEN.encode()) not in text,
          "the log holds no token and no token hash")
    lines = [json.loads(line) for line in text.splitlines()]
    check(len(lines) == 13, "one log line per request: %d, expected 13" % len(lines))
    keys = ["time", "method", "route", "path", "status", "latency_ms", "bytes", "request_bytes",
            "token_id", "remote", "request_id"]
    check(all(list(j.keys()) == keys for j in lines), "log keys %s" % list(lines[0].keys()))
    check(all(re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{6}Z", j["time"]) for j in lines),
          "UTC ISO times")
    miss = [j for j in lines if j["path"] == "/api/v1/measurements/999999"]
    check(len(miss) == 2 and all(j["route"] == "/api/v1/measurements/{id}" and j["status"] == 404
                                 and j["token_id"] == admin_id for j in miss), "404 lines")
    ups = [j for j in lines if j["route"] == "/api/v1/measurements" and j["method"] == "POST"]
    check([j["status"] for j in ups] == [201, 201, 200], "upload statuses")
    check(all(j["request_bytes"] > 3000 and j["bytes"] > 0 and j["latency_ms"] >= 0
              and j["remote"] == "127.0.0.1" for j in ups), "upload lines")
    anon = [j for j in lines if j["status"] == 401]
    check(len(anon) == 1 and anon[0]["token_id"] == 0, "the 401 line has token id 0")


def check_roles(binary, tmp, check):
    """/metrics: viewer by default (401 without a token), public with --metrics-public."""
    srv = Server(binary, os.path.join(tmp, "public"), ["--metrics-public",
                                                        "--access-log", "off"]).start()
    try:
        check(srv.request("GET", "/metrics", token=None)[0] == 200, "public metrics")
        _, doc = srv.json("GET", "/api/v1/openapi.json", token=None)
        check(doc["paths"]["/metrics"]["get"]["x-required-role"] == "public", "openapi: public")
    finally:
        check(srv.stop() == 0, "exit 0")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repo", required=True)
    ap.add_argument("--bin", required=True)
    a = ap.parse_args()
    binary = os.path.join(a.bin, "kinemetricd")
    check = Checks()
    with tempfile.TemporaryDirectory() as tmp:
        log = os.path.join(tmp, "access.log")
        srv = Server(binary, os.path.join(tmp, "d"), ["--access-log", log]).start()
        try:
            _, who = srv.json("GET", "/api/v1/whoami")
            _, viewer = srv.json("POST", "/api/v1/tokens", {"name": "v", "role": "viewer"})
            check(srv.request("GET", "/metrics", token=None)[0] == 401, "metrics without token")
            check(srv.request("GET", "/metrics", token=viewer["token"])[0] == 200, "viewer")
            _, doc = srv.json("GET", "/api/v1/openapi.json", token=None)
            check(doc["paths"]["/metrics"]["get"]["x-required-role"] == "viewer", "openapi role")
            open(log, "w").close()  # the log from here on: the known requests only
            before, _ = scrape(srv, check)
            f1, f2 = drive_requests(srv, example_dbb(a.repo), check)
            send_frames(srv, check)
            after, types = scrape(srv, check)
            check(types.get("kinemetric_http_request_duration_seconds") == "histogram", "type")
            check_histogram(after, check)
            check_counters(before, after, f1, f2, check)
        finally:
            check(srv.stop() == 0, "exit 0 on SIGTERM")
        check_log(log, who["token_id"], check)
        check_roles(binary, tmp, check)
    return check.finish("ops_metrics_log")


if __name__ == "__main__":
    sys.exit(main())
