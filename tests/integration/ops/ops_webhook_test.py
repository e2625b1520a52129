#!/usr/bin/python3
"""Audit webhooks of a real kinemetricd as a receiver sees them (docs/http.md, accuracy audits):
a verdict of level 2 is POSTed, refused once with 500 and delivered on the retry; both attempts
carry the same X-Kinemetric-Delivery, their attempt number and a timestamp, and a signature that
Python's own hmac module verifies over "timestamp.body" with the secret given in the environment
(and one given in the config file); a body or secret changed on the way fails the check. A
server without a secret sends no signature."""
import argparse
import hashlib
import hmac
import json
import os
import sys
import tempfile
import threading
import time
from http.server import BaseHTTPRequestHandler, HTTPServer

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ops_server import Checks, Server, example_dbb  # noqa: E402


def verified(secret, headers, body, tolerance_s=300):
    """The receiver's check of docs/http.md."""
    ts = headers.get("X-Kinemetric-Timestamp", "0")
    mac = hmac.new(secret, ts.encode() + b"." + body, hashlib.sha256).hexdigest()
    return (hmac.compare_digest("sha256=" + mac, headers.get("X-Kinemetric-Signature", ""))
            and abs(time.time() - int(ts)) <= tolerance_s)


class Receiver:
    """Answers 500 to the first POST and 204 afterwards; keeps headers and bodies."""

    def __init__(self):
        self.got = []
        outer = self

        class Handler(BaseHTTPRequestHandler):
            def do_POST(self):
                body = self.rfile.read(int(self.headers["Content-Length"]))
                outer.got.append(({k: v for k, v in self.headers.items()}, body))
                self.send_response(500 if len(outer.got) == 1 else 204)
                self.end_headers()

            def log_message(self, *args):
                pass

        self.httpd = HTTPServer(("127.0.0.1", 0), Handler)
        threading.Thread(target=self.httpd.serve_forever, daemon=True).start()
        self.url = "http://127.0.0.1:%d/hook" % self.httpd.server_port

    def wait(self, n, timeout=15):
        deadline = time.time() + timeout
        while len(self.got) < n and time.time() < deadline:
            time.sleep(0.05)
        return self.got

    def close(self):
        self.httpd.shutdown()
        self.httpd.server_close()


def run_audit(srv, repo):
    """Uploads the example DBB test and runs an audit that warns on it; the verdict."""
    st, _, body = srv.request("POST", "/api/v1/measurements", body=example_dbb(repo),
                              headers={"Content-Type": "text/plain", "X-Filename": "a.txt"})
    machine = json.loads(srv.request("GET", "/api/v1/measurements/%d" % json.loads(body)["id"])[2])
    machine = machine["machine_id"]
    rules = {"rules": [{"kind": "dbb", "metric": "circularity_um", "warn": 0.001, "stop": 1e6}],
             "schedule": None}
    srv.request("PUT", "/api/v1/machines/%s/audit" % machine, body=rules)
    return json.loads(srv.request("POST", "/api/v1/machines/%s/audit/run" % machine, body=b"")[2])


def scenario(a, tmp, name, secret, how, check):
    rec = Receiver()
    extra = ["--audit-webhook-url", rec.url, "--audit-webhook-allow-private",
             "--audit-webhook-first-delay-ms", "100", "--access-log", "off"]
    env = {}
    if how == "env":
        env["KINEMETRIC_AUDIT_WEBHOOK_SECRET"] = secret.decode()
    elif how == "config":
        conf = os.path.join(tmp, name + ".conf")
        with open(conf, "w") as f:
            json.dump({"audit_webhook_secret": secret.decode()}, f)
        extra += ["--config", conf]
    srv = Server(os.path.join(a.bin, "kinemetricd"), os.path.join(tmp, name), extra, env=env)
    srv.start()
    try:
        verdict = run_audit(srv, a.repo)
        check(verdict.get("level") == 2, "%s: the audit warns (level %s)" % (name, verdict.get("level")))
        got = rec.wait(2)
        check(len(got) == 2, "%s: refused once, delivered on the retry (%d POSTs)" % (name, len(got)))
        for k, (headers, body) in enumerate(got[:2]):
            check(headers.get("X-Kinemetric-Delivery") == "audit-%d" % verdict["id"],
                  "%s: delivery id of attempt %d" % (name, k + 1))
            check(headers.get("X-Kinemetric-Attempt") == str(k + 1), "%s: attempt number" % name)
            check(json.loads(body)["id"] == verdict["id"], "%s: the verdict is the body" % name)
            if secret:
                check(verified(secret, headers, body), "%s: signature verified" % name)
                check(not verified(secret, headers, body + b" "), "%s: changed body fails" % name)
                check(not verified(secret + b"x", headers, body), "%s: other secret fails" % name)
            else:
                check("X-Kinemetric-Signature" not in headers, "%s: no signature" % name)
    finally:
        check(srv.stop() == 0, "%s: exit 0" % name)
        rec.close()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repo", required=True)
    ap.add_argument("--bin", required=True)
    a = ap.parse_args()
    check = Checks()
    with tempfile.TemporaryDirectory() as tmp:
        scenario(a, tmp, "env", b"a-webhook-secret-from-the-environment", "env", check)
        scenario(a, tmp, "config", b"0123456789abcdef0123", "config", check)
        scenario(a, tmp, "unsigned", b"", "none", check)
    return check.finish("ops_webhook")


if __name__ == "__main__":
    sys.exit(main())
