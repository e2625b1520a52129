#!/usr/bin/python3
"""Certificates on a real kinemetricd over HTTP (docs/http.md "Certificates"):
  * a measurement's PDF is a draft certificate (number, revision) until an engineer approves it;
    an operator may not approve (403); the approval is in the audit log, and the approved PDF is
    answered byte for byte afterwards and after a restart;
  * ten approvals of one revision at once: exactly one 200, the others 409, never a 5xx;
  * a new tolerance table makes revision 2 (a draft naming the approved revision it
    supersedes); revision 1 stays readable; an approval of revision 1 is 409;
  * hostile queries and bodies on the new routes (huge, nested, non-numeric, out-of-range
    revisions and as-left ids, unknown keys, 300 kB bodies) are 4xx, never 5xx, and nothing is
    approved by them."""
import argparse
import os
import subprocess
import sys
import tempfile
import threading

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ops_server import Checks, Server, example_dbb, sha256  # noqa: E402


def token(srv, role, name):
    status, t = srv.json("POST", "/api/v1/tokens", {"name": name, "role": role})
    assert status == 201, status
    return t["token"]


def pdf_text(data, tmp):
    path = os.path.join(tmp, "r.pdf")
    with open(path, "wb") as f:
        f.write(data)
    return subprocess.run(["pdftotext", "-layout", path, "-"], capture_output=True,
                          text=True).stdout


def tolerances(srv, g_um, engineer):
    body = {"tolerances": [{"kind": "dbb", "metric": "circular_deviation_um",
                            "tolerance": g_um}], "decision_rule": "guarded"}
    return srv.json("PUT", "/api/v1/machines/vmc-3axis/tolerances", body, token=engineer)[0]


def check_approval(srv, mid, tmp, check):
    operator = token(srv, "operator", "olga")
    engineer = token(srv, "engineer", "erik")
    base = "/api/v1/measurements/%d/report" % mid
    number = "KM-M%06d" % mid
    check(tolerances(srv, 15, engineer) == 200, "tolerance table 1")
    status, _, draft = srv.request("GET", base + ".pdf")
    text = pdf_text(draft, tmp)
    check(status == 200 and number + ", revision 1" in text and "draft" in text,
          "the draft names its certificate: %s" % text[:300])
    check(srv.request("POST", base + "/approve", b"", token=operator)[0] == 403,
          "an operator may not approve")
    results = []

    def approve():
        results.append(srv.request("POST", base + "/approve", {"revision": 1},
                                   token=engineer)[0])
    threads = [threading.Thread(target=approve) for _ in range(10)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    # One approval wins; the others are 409, or 503 with Retry-After while the render gate is
    # full (docs/http.md "PDF reports").
    check(results.count(200) == 1 and all(r in (200, 409, 503) for r in results),
          "ten approvals at once: %s" % sorted(results))
    check(srv.request("POST", base + "/approve", {"revision": 1}, token=engineer)[0] == 409,
          "an approved revision is not approved again")
    status, headers, frozen = srv.request("GET", base + ".pdf")
    check(status == 200 and headers.get("content-type") == "application/pdf",
          "the approved PDF: %s" % status)
    check("approved by erik at" in pdf_text(frozen, tmp), "the approver is printed")
    check(srv.request("GET", base + ".pdf")[2] == frozen, "answered byte for byte")
    log = srv.json("GET", "/api/v1/audit-log?limit=20")[1]["items"]
    check(any(e["token_name"] == "erik" and e["status"] == 200 and
              ("certificate %s revision 1 approved" % number) in e["subject"] for e in log),
          "the audit log names the approval")
    return engineer, sha256(frozen)


def check_revision(srv, mid, engineer, frozen_sha, tmp, check):
    base = "/api/v1/measurements/%d/report" % mid
    check(tolerances(srv, 1, engineer) == 200, "tolerance table 2")
    text = pdf_text(srv.request("GET", base + ".pdf")[2], tmp)
    check("revision 2" in text and "draft" in text and "revision 1, approved by erik" in text,
          "revision 2 supersedes the approved one: %s" % text[:400])
    check(sha256(srv.request("GET", base + ".pdf?revision=1")[2]) == frozen_sha,
          "revision 1 as approved")
    check(srv.request("POST", base + "/approve", {"revision": 1}, token=engineer)[0] == 409,
          "a stale revision is not approved")
    status, revs = srv.json("GET", base + "/revisions")
    check(status == 200 and revs["current_revision"] == 2 and
          revs["revisions"][0]["approved_by"] == "erik", "revisions: %s" % revs)


def check_hostile(srv, mid, engineer, check):
    base = "/api/v1/measurements/%d/report" % mid
    queries = ["?revision=0", "?revision=-1", "?revision=99999999999999999999", "?revision=x",
               "?revision=1e3", "?as_left=abc", "?as_left=0", "?as_left=%d" % mid,
               "?as_left=999999", "?revision=%00", "?as_left=1%0D%0AX:1"]
    for q in queries:
        paths = [("GET", base + ".pdf" + q), ("POST", base + "/approve" + q)]
        if "as_left" in q:
            paths.append(("GET", base + "/revisions" + q))
        for method, path in paths:
            status, _, body = srv.request(method, path, b"" if method == "POST" else None,
                                          token=engineer)
            check(400 <= status < 500, "%s %s: %d %s" % (method, path[-30:], status, body[:80]))
    bodies = [b"[" * 10000 + b"]" * 10000, b'{"revision":' * 5000 + b"1" + b"}" * 5000,
              b'{"revision":1e400}', b'{"revision":"2"}', b'{"revision":2.5}',
              b'{"revision":2,"revision":2}', b'{"revision":2,"by":"x"}', b"[2]", b"{",
              b'{"revision":NaN}', b'{"revision":' + b"9" * 400 + b"}", b"x" * 300000]
    for body in bodies:
        status, _, text = srv.request("POST", base + "/approve", body, token=engineer,
                                      headers={"Content-Type": "application/json"})
        check(400 <= status < 500, "body %r: %d %s" % (body[:30], status, text[:80]))
    for path in ("/api/v1/jobs/abc/report/approve", "/api/v1/jobs/99/report/approve",
                 "/api/v1/machines/..%2F..%2Fx/audit/report/approve",
                 "/api/v1/machines/nowhere/audit/report/approve"):
        status = srv.request("POST", path, b"", token=engineer)[0]
        check(400 <= status < 500, "%s: %d" % (path, status))
    status, revs = srv.json("GET", base + "/revisions")
    check(status == 200 and "approved_by" not in revs["revisions"][-1],
          "nothing hostile approved the current revision: %s" % revs)
    check(srv.request("GET", "/healthz", token=None)[0] == 200, "the server still answers")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repo", required=True)
    ap.add_argument("--bin", required=True)
    a = ap.parse_args()
    check = Checks()
    dbb = example_dbb(a.repo).replace(b"# operator:", b"# u_reading_um: 0.3\n# operator:", 1)
    with tempfile.TemporaryDirectory() as tmp:
        srv = Server(os.path.join(a.bin, "kinemetricd"), os.path.join(tmp, "d"),
                     ["--access-log", "off"]).start()
        try:
            status, up = srv.json("POST", "/api/v1/measurements", dbb)
            check(status == 201, "upload: %s %s" % (status, up))
            mid = up["id"]
            engineer, frozen = check_approval(srv, mid, tmp, check)
            check_revision(srv, mid, engineer, frozen, tmp, check)
            check_hostile(srv, mid, engineer, check)
            srv.stop()
            srv.start()
            got = srv.request("GET", "/api/v1/measurements/%d/report.pdf?revision=1" % mid)[2]
            check(sha256(got) == frozen, "the approved PDF after a restart")
        finally:
            srv.stop()
    return check.finish("ops_certificates_test")


if __name__ == "__main__":
    sys.exit(main())
