#!/usr/bin/python3
"""The authorization matrix of a real kinemetricd, driven by its own OpenAPI document (so a new
route is covered as soon as it exists): every operation × {no token, a wrong token, an expired
token, a revoked token, a token of each role} is answered exactly as its x-required-role says:
401 for the first four (on every route that needs a token), 403 for a role below the route's,
and past authorization (neither 401 nor 403, and never 5xx) otherwise. Path parameters are filled
with values naming nothing stored, so a 404 counts as "past authorization" and nothing changes."""
import argparse
import os
import re
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ops_server import Checks, Server  # noqa: E402

ROLES = ["viewer", "operator", "engineer", "admin"]
RANK = {"public": 0, "viewer": 1, "operator": 2, "engineer": 3, "admin": 4}


def fill(path):
    """Every {param}: an id or a name that names nothing stored."""
    return re.sub(r"\{([^}]+)\}", lambda m: "987654321" if m.group(1) == "id" or
                  m.group(1).endswith("_id") and m.group(1) != "machine_id" else
                  "no-such-" + m.group(1).replace("_", "-"), path)


def make_tokens(srv, check):
    tokens = {}
    for role in ROLES:
        status, t = srv.json("POST", "/api/v1/tokens", {"name": "matrix " + role, "role": role})
        check(status == 201, "create %s token: %d" % (role, status))
        tokens[role] = t["token"]
    status, t = srv.json("POST", "/api/v1/tokens", {"name": "matrix expired", "role": "admin",
                                                    "expires_in_s": 1})
    check(status == 201, "create expiring token: %d" % status)
    tokens["expired"] = t["token"]
    status, t = srv.json("POST", "/api/v1/tokens", {"name": "matrix revoked", "role": "admin"})
    tokens["revoked"] = t["token"]
    # The revoked token is used once first, so that a cached acceptance must be dropped too.
    check(srv.request("GET", "/api/v1/whoami", token=t["token"])[0] == 200, "before revoking")
    status, _ = srv.json("DELETE", "/api/v1/tokens/%d" % t["id"])
    check(status == 200, "revoke: %d" % status)
    tokens["none"] = None
    tokens["wrong"] = "not-a-token-of-this-server-0123456789"
    time.sleep(2.2)  # the expiring token is past its expiry
    return tokens


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
            tokens = make_tokens(srv, check)
            _, doc = srv.json("GET", "/api/v1/openapi.json", token=None)
            ops = [(m.upper(), p, op["x-required-role"]) for p, item in doc["paths"].items()
                   for m, op in item.items()]
            check(len(ops) >= 40, "the OpenAPI document lists %d operations" % len(ops))
            check(("GET", "/metrics", "viewer") in ops, "/metrics is in the document")
            cells = 0
            conn = srv.conn()
            for method, pattern, role in sorted(ops):
                path = fill(pattern)
                for who, token in tokens.items():
                    status, _, body = srv.request(method, path, b"" if method != "GET" else None,
                                                  token=token, conn=conn)
                    if status in (401, 403) or status >= 500:
                        conn.close()  # a refused body closes the connection
                        conn = srv.conn()
                    cells += 1
                    what = "%s %s as %s (needs %s): %d %s" % (method, pattern, who, role, status,
                                                              body[:120])
                    if role == "public":
                        check(status not in (401, 403) and status < 500, what)
                    elif who in ("none", "wrong", "expired", "revoked"):
                        check(status == 401, what)
                    elif RANK[who] < RANK[role]:
                        check(status == 403, what)
                    else:
                        check(status not in (401, 403) and status < 500, what)
            conn.close()
            print("%d operations × %d callers = %d answers checked" % (len(ops), len(tokens),
                                                                       cells))
        finally:
            check(srv.stop() == 0, "exit 0")
    return check.finish("ops_authz_matrix")


if __name__ == "__main__":
    sys.exit(main())
