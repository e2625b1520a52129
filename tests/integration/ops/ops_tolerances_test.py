#!/usr/bin/python3
"""Tolerance tables on a real kinemetricd (docs/http.md "Tolerances and conformance"):
  * a measurement is judged on the fly: "no tolerance" at upload, "pass" and "fail" as the
    machine's newest table changes, the same in the upload answer, the list, the measurement and
    its results, each naming the table version;
  * tables PUT by 8 clients at once get the versions 1..8, each once; the same entries again
    store nothing (created false);
  * after a restart the versions and the verdicts are the same;
  * two instances on one PostgreSQL database: a table stored through one judges the
    measurements listed through the other at once (no instance keeps an old table).
The PostgreSQL server is KINEMETRIC_TEST_DATABASE's, else a private cluster started here with
tests/tools/pg_cluster.sh (the instances test's)."""
import argparse
import os
import subprocess
import sys
import tempfile
import threading

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ops_instances_test import shared_database  # noqa
from ops_server import TOOLS, Checks, Server, example_dbb  # noqa

MACHINE = "vmc-3axis"  # the example file's machine
PATH = "/api/v1/machines/%s/tolerances" % MACHINE


def g(tolerance, test_id=None):
    e = {"kind": "dbb", "metric": "circular_deviation_um", "tolerance": tolerance}
    if test_id:
        e["test_id"] = test_id
    return e


def verdicts(srv, mid):
    """The conformance of measurement mid in every answer that carries it."""
    out = {}
    _, page = srv.json("GET", "/api/v1/measurements?machine_id=" + MACHINE)
    out["list"] = next(i["conformance"] for i in page["items"] if i["id"] == mid)
    out["measurement"] = srv.json("GET", "/api/v1/measurements/%d" % mid)[1]["conformance"]
    out["results"] = srv.json("GET", "/api/v1/measurements/%d/results" % mid)[1]["conformance"]
    return out


def same_verdict(srv, mid, verdict, version, check, what):
    for where, c in verdicts(srv, mid).items():
        check(c["verdict"] == verdict and c["tolerance_version"] == version,
              "%s: %s says %s by version %s" % (what, where, c["verdict"], c["tolerance_version"]))


def check_one_server(binary, tmp, dbb, check):
    srv = Server(binary, os.path.join(tmp, "one"), ["--access-log", "off"]).start()
    try:
        status, up = srv.json("POST", "/api/v1/measurements", dbb)
        check(status == 201 and up["conformance"]["verdict"] == "no tolerance",
              "upload judged without a table: %s %s" % (status, up))
        mid = up["id"]
        gv = srv.json("GET", "/api/v1/measurements/%d/results" % mid)[1]["iso230_4"][
            "circular_deviation_um"]
        check(srv.json("PUT", PATH, {"tolerances": [g(gv + 1, "xy-*")]})[0] == 200, "table 1")
        same_verdict(srv, mid, "pass", 1, check, "G within its tolerance")
        check(srv.json("PUT", PATH, {"tolerances": [g(gv - 0.1, "xy-r150")]})[0] == 200, "table 2")
        same_verdict(srv, mid, "fail", 2, check, "G above its tolerance")
        status, again = srv.json("POST", "/api/v1/measurements", dbb)
        check(status == 200 and again["conformance"]["verdict"] == "fail",
              "the same bytes again are judged by the newest table: %s" % again)
        # Eight clients at once, each its own table: versions 3..10, each once.
        answers = []

        def put(n):
            answers.append(srv.json("PUT", PATH, {"tolerances": [g(100 + n)]}))

        threads = [threading.Thread(target=put, args=(n,)) for n in range(8)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        versions = sorted(a[1]["version"] for a in answers if a[0] == 200)
        check(versions == list(range(3, 11)), "concurrent tables numbered in turn: %s" % versions)
        newest = srv.json("GET", PATH)[1]
        status, same = srv.json("PUT", PATH, {"tolerances": newest["tolerances"]})
        check(status == 200 and same["created"] is False and same["version"] == 10,
              "the same entries store nothing: %s" % same)
        srv.stop()
        srv.start()
        check(srv.json("GET", PATH)[1]["version"] == 10, "versions kept across a restart")
        check(srv.json("GET", PATH + "?version=2")[1]["tolerances"][0]["tolerance"] == gv - 0.1,
              "version 2 kept")
        same_verdict(srv, mid, "pass", 10, check, "after a restart")
    finally:
        srv.stop()


def check_two_instances(binary, tmp, dbb, check):
    url, cluster = shared_database(tmp)
    a = b = None
    try:
        a = Server(binary, os.path.join(tmp, "a"), ["--database", url, "--access-log", "off"])
        b = Server(binary, os.path.join(tmp, "b"), ["--database", url, "--access-log", "off"])
        a.start()
        b.start()
        mid = a.json("POST", "/api/v1/measurements", dbb)[1]["id"]
        same_verdict(b, mid, "no tolerance", None, check, "instance b before any table")
        check(a.json("PUT", PATH, {"tolerances": [g(0.001)]})[0] == 200, "table through a")
        same_verdict(b, mid, "fail", 1, check, "instance b after a's table")
        check(b.json("PUT", PATH, {"tolerances": [g(1000)]})[1]["version"] == 2, "table through b")
        same_verdict(a, mid, "pass", 2, check, "instance a after b's table")
    finally:
        for s in (a, b):
            if s:
                s.stop()
        if cluster:
            subprocess.run([os.path.join(TOOLS, "pg_cluster.sh"), "stop", cluster], check=False)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repo", required=True)
    ap.add_argument("--bin", required=True)
    args = ap.parse_args()
    binary = os.path.join(args.bin, "kinemetricd")
    check = Checks()
    dbb = example_dbb(args.repo)
    with tempfile.TemporaryDirectory() as tmp:
        check_one_server(binary, tmp, dbb, check)
        check_two_instances(binary, tmp, dbb, check)
    return check.finish("ops_tolerances_test")


if __name__ == "__main__":
    sys.exit(main())
