#!/usr/bin/python3
"""Accuracy audits of a machine measured in several set-ups, on a real kinemetricd with its demo
data, as a plant's accuracy engineer walks it (docs/http.md "Accuracy audits"):
  * circularity warn 15 / stop 30: the level is the worst over the newest test of every DBB
    set-up (test_id and direction), worked out here from the measurement list, and each
    finding names the set-up's newest measurement, whichever test was uploaded last;
  * the hysteresis H of every test_id's pair is judged, each the value of its /pair answer;
  * a rule scoped to one test_id judges that set-up only;
  * a set-up measured two years ago is listed as stale with its date, and is a level-2 finding
    only when the audit asks for it ("stale": "warn");
  * the PDF of the measurement above stop says "level 3 — stop" for it, never "within limits".
Every value is read from the server's own answers for single measurements, not recomputed."""
import argparse
import os
import re
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ops_server import Checks, Server, example_dbb  # noqa

MACHINE = "demo-vmc"
AUDIT = "/api/v1/machines/%s/audit" % MACHINE


def newest_per_set_up(srv):
    """{(test_id, direction): (id, circularity)} of the machine's DBB tests, newest of each."""
    _, page = srv.json("GET", "/api/v1/measurements?machine_id=%s&kind=dbb&limit=1000" % MACHINE)
    newest = {}
    for m in page["items"]:
        key = (m["test_id"], m["direction"])
        when = m["timestamp"] or m["uploaded_at"]
        if key not in newest or when > newest[key][0]:
            newest[key] = (when, m["id"], m["key_result"]["value"])
    return {k: (v[1], v[2]) for k, v in newest.items()}


def level_of(value, warn, stop):
    return 3 if value > stop else 2 if value > warn else 1


def check_levels(srv, check):
    set_ups = newest_per_set_up(srv)
    check(len(set_ups) >= 4, "the demo machine has several DBB set-ups: %s" % sorted(set_ups))
    worst = max(v for _, v in set_ups.values())
    warn, stop = worst / 3, worst - 0.5
    rules = [{"kind": "dbb", "metric": "circularity_um", "warn": warn, "stop": stop},
             {"kind": "dbb", "metric": "circular_hysteresis_um", "warn": 0.001}]
    check(srv.json("PUT", AUDIT, {"rules": rules})[0] == 200, "rules stored")
    status, v = srv.json("POST", AUDIT + "/run")
    check(status == 201, "audit run: %s" % status)
    expected = max(level_of(c, warn, stop) for _, c in set_ups.values())
    check(v["level"] == expected == 3, "level %s, expected %s" % (v["level"], expected))
    above = sorted(mid for mid, c in set_ups.values() if c > stop)
    named = sorted(f["measurement_id"] for f in v["findings"] if f["rule"] == 0 and f["level"] == 3)
    check(named == above, "stop findings name %s, the set-ups above stop are %s" % (named, above))
    judged = sorted(c["measurement_id"] for c in v["checked"] if c["rule"] == 0)
    check(judged == sorted(mid for mid, _ in set_ups.values()),
          "every set-up's newest test judged: %s" % judged)
    for c in v["checked"]:
        if c["rule"] != 1 or c.get("status") not in ("ok", "finding"):
            continue
        pair = srv.json("GET", "/api/v1/measurements/%d/pair" % c["measurement_id"])[1]
        check(abs(pair["pair"]["circular_hysteresis_um"] - c["value"]) < 1e-9,
              "H of %s is its pair's" % c["set_up"])
    pairs = {k[0] for k in set_ups if (k[0], "cw") in set_ups and (k[0], "ccw") in set_ups}
    h_set_ups = {c["set_up"] for c in v["checked"] if c["rule"] == 1}
    check(pairs <= h_set_ups, "H judged for every pair: %s of %s" % (h_set_ups, pairs))
    return above[0], set_ups


def check_scope(srv, set_ups, check):
    test_id, direction = sorted(set_ups)[0]
    rule = {"kind": "dbb", "metric": "circularity_um", "warn": 1000, "test_id": test_id,
            "direction": direction.upper()}
    check(srv.json("PUT", AUDIT, {"rules": [rule]})[0] == 200, "scoped rule stored")
    v = srv.json("POST", AUDIT + "/run")[1]
    ids = [c["measurement_id"] for c in v["checked"]]
    check(ids == [set_ups[(test_id, direction)][0]], "scoped rule judged %s only: %s" % (
        (test_id, direction), ids))
    status, bad = srv.json("PUT", AUDIT, {"rules": [dict(rule, direction="sideways")]})
    check(status == 400 and "rules[0].direction" in str(bad), "bad direction: %s %s" % (status, bad))


def check_stale(srv, repo, check):
    old = example_dbb(repo).decode()
    old = re.sub(r"(?m)^# machine_id: .*$", "# machine_id: " + MACHINE, old, count=1)
    old = re.sub(r"(?m)^# test_id: .*$", "# test_id: zx-old", old, count=1)
    old = re.sub(r"(?m)^# timestamp: .*$", "# timestamp: 2024-06-01T08:00:00Z", old, count=1)
    status, up = srv.json("POST", "/api/v1/measurements", old.encode())
    check(status == 201, "old set-up stored: %s %s" % (status, up))
    rule = {"kind": "dbb", "metric": "circularity_um", "warn": 1000}
    for policy, level in (("ignore", 1), ("warn", 2)):
        srv.json("PUT", AUDIT, {"rules": [rule], "max_age_days": 365, "stale": policy})
        v = srv.json("POST", AUDIT + "/run")[1]
        stale = [s["measurement_id"] for s in v["stale"]]
        check(stale == [up["id"]], "%s: stale set-ups %s" % (policy, stale))
        check(v["level"] == level, "%s: level %s, expected %s" % (policy, v["level"], level))


def check_pdf(srv, mid, check):
    status, _, pdf = srv.request("GET", "/api/v1/measurements/%d/report.pdf" % mid)
    check(status == 200, "report of %d: %s" % (mid, status))
    text = subprocess.run(["pdftotext", "-layout", "-", "-"], input=pdf, capture_output=True,
                          check=True).stdout.decode()
    check("level 3 — stop" in text and "within limits" not in text,
          "the report of the set-up above stop judges it:\n" + text)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repo", required=True)
    ap.add_argument("--bin", required=True)
    args = ap.parse_args()
    check = Checks()
    with tempfile.TemporaryDirectory() as tmp:
        srv = Server(os.path.join(args.bin, "kinemetricd"), os.path.join(tmp, "d"),
                     ["--demo-data", "--access-log", "off"]).start()
        try:
            above, set_ups = check_levels(srv, check)
            check_pdf(srv, above, check)
            check_scope(srv, set_ups, check)
            check_stale(srv, args.repo, check)
        finally:
            srv.stop()
    return check.finish("ops_audit_setups_test")


if __name__ == "__main__":
    sys.exit(main())
