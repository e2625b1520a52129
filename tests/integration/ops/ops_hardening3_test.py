#!/usr/bin/python3
"""What a client sends may not reach a machine controller or slip past the HTTP framing, on a
real kinemetricd (docs/http.md, docs/formats.md §1 "Names and header values"):
- a positioning file whose machine_id or axis carries program lines behind CR, VT, FF, NEL,
  U+2028 is refused at upload (400 naming line and field) and by `kinemetric positioning
  export` (exit 2); machine ids with '/' or controls are refused; a stored file's SINUMERIK
  program holds only comment, assignment and end lines;
- a Transfer-Encoding that does not end in chunked is answered 400 and the connection closed:
  the body never runs as a second request;
- two Authorization headers, two Host headers, or no Host in HTTP/1.1: 400; the Bearer scheme in
  lower case is accepted;
- invented methods add no /metrics series;
- 400 half-open requests from one address leave /healthz answered at once;
- a symbolic link in the web root to a file outside it is not served."""
import argparse
import json
import os
import socket
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ops_server import ADMIN_TOKEN, Checks, Server  # noqa: E402


def positioning(repo, machine_id="vmc-3axis", axis="X"):
    with open(os.path.join(repo, "data", "examples", "positioning_x.txt"), "rb") as f:
        text = f.read()
    text = text.replace(b"# machine_id: vmc-3axis", b"# machine_id: " + machine_id.encode())
    return text.replace(b"# axis: X\n", b"# axis: " + axis.encode() + b"\n")


def raw(port, data, wait=3.0):
    """Everything the server sends back for `data` until it closes or `wait` passes, and
    whether it closed."""
    s = socket.create_connection(("127.0.0.1", port), timeout=wait)
    s.sendall(data)
    out, closed, deadline = b"", False, time.time() + wait
    try:
        while time.time() < deadline:
            piece = s.recv(65536)
            if not piece:
                closed = True
                break
            out += piece
    except socket.timeout:
        pass
    finally:
        s.close()
    return out, closed


def check_controller_text(srv, repo, binary_dir, tmp, check):
    for brk in ["\r", "\x0b", "\x0c", "\u0085", "\u2028"]:
        bad = "vmc" + brk + "$AA_ENC_COMP[0,0,AX1]=9.999" + brk + "M30"
        status, _, body = srv.request("POST", "/api/v1/measurements", positioning(repo, bad),
                                      headers={"X-Filename": "inj.txt"})
        problem = json.loads(body or b"{}")
        check(status == 400 and problem.get("field") == "machine_id" and problem.get("line") == 2,
              "machine id with %r refused naming line 2 and machine_id: %s %s" % (brk, status, body[:200]))
        path = os.path.join(tmp, "inj.txt")
        with open(path, "wb") as f:
            f.write(positioning(repo, bad))
        cli = subprocess.run([os.path.join(binary_dir, "kinemetric"), "positioning", "export", path,
                              "--format", "sinumerik"], capture_output=True, text=True)
        check(cli.returncode == 2 and "machine_id" in cli.stderr and "M30" not in cli.stdout,
              "the CLI refuses the injected id (exit %s): %s" % (cli.returncode, cli.stderr[:200]))
    status, _, body = srv.request("POST", "/api/v1/measurements", positioning(repo, "vmc", "X\rM30"))
    check(status == 400 and json.loads(body).get("field") == "axis", "axis with CR refused")
    for bad in ["plant/vmc", "vmc\x1b[31m", "..", "a\\b"]:
        status, _, body = srv.request("POST", "/api/v1/measurements", positioning(repo, bad))
        check(status == 400 and json.loads(body).get("field") == "machine_id",
              "machine id %r refused: %s %s" % (bad, status, body[:160]))
    status, _, body = srv.request("POST", "/api/v1/measurements", positioning(repo, "vmc-3axis"))
    check(status in (200, 201), "a plain positioning file is stored: %s" % status)
    mid = json.loads(body)["id"]
    status, _, prog = srv.request("GET", "/api/v1/measurements/%d/compensation?format=sinumerik" % mid)
    lines = prog.decode().split("\n")
    allowed = (";", "$AA_ENC_COMP", "%_N_AX_EEC_INI", "CHANDATA(1)", "M17")
    check(status == 200 and all(ln == "" or ln.startswith(allowed) for ln in lines),
          "the SINUMERIK program holds comments, compensation values and M17 only")
    check("\r" not in prog.decode(), "no carriage return in the program")


def check_framing(srv, check):
    smuggled = b"GET /api/v1/tokens HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer " + \
        ADMIN_TOKEN.encode() + b"\r\n\r\n"
    for te in [b"gzip", b"identity", b"chunked, identity", b"xchunked"]:
        out, closed = raw(srv.port, b"POST /api/v1/measurements HTTP/1.1\r\nHost: x\r\n"
                          b"Authorization: Bearer nobody\r\nTransfer-Encoding: " + te +
                          b"\r\n\r\n" + smuggled)
        check(out.startswith(b"HTTP/1.1 400") and out.count(b"HTTP/1.1 ") == 1 and closed,
              "Transfer-Encoding %r: one 400 and the connection closed: %r" % (te, out[:120]))
    auth = b"Authorization: Bearer " + ADMIN_TOKEN.encode() + b"\r\n"
    out, _ = raw(srv.port, b"GET /api/v1/tokens HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer x\r\n" +
                 auth + b"\r\n")
    check(out.startswith(b"HTTP/1.1 400"), "two Authorization headers: 400")
    out, _ = raw(srv.port, b"GET /healthz HTTP/1.1\r\n\r\n")
    check(out.startswith(b"HTTP/1.1 400"), "no Host in HTTP/1.1: 400")
    out, _ = raw(srv.port, b"GET /healthz HTTP/1.1\r\nHost: a\r\nHost: b\r\n\r\n")
    check(out.startswith(b"HTTP/1.1 400"), "two Host headers: 400")
    status, _, _ = srv.request("GET", "/api/v1/tokens", token=None,
                               headers={"Authorization": "bearer " + ADMIN_TOKEN})
    check(status == 200, "the Bearer scheme in lower case is accepted: %s" % status)


def check_metrics(srv, check):
    for i in range(300):
        raw(srv.port, b"KM%d /healthz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n" % i, 1.0)
    _, _, body = srv.request("GET", "/metrics")
    text = body.decode()
    check('method="KM1"' not in text and 'method="OTHER"' in text,
          "invented methods share one /metrics label")


def check_half_open(srv, check):
    held = []
    for _ in range(400):
        s = socket.create_connection(("127.0.0.1", srv.port))
        s.sendall(b"GET /healthz HTTP/1.1\r\nHo")
        held.append(s)
    worst = 0.0
    for _ in range(5):
        t0 = time.time()
        out, _ = raw(srv.port, b"GET /healthz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
        worst = max(worst, time.time() - t0)
        check(out.startswith(b"HTTP/1.1 200"), "healthz answered beside 400 half-open requests: %r" % out[:60])
    check(worst < 1.0, "healthz within 1 s beside half-open requests (worst %.3f s)" % worst)
    for s in held:
        s.close()


def check_web_root(binary, tmp, check):
    web = os.path.join(tmp, "web")
    os.makedirs(web)
    with open(os.path.join(web, "index.html"), "w") as f:
        f.write("<html></html>")
    with open(os.path.join(tmp, "secret.txt"), "w") as f:
        f.write("secret")
    os.symlink(os.path.join(tmp, "secret.txt"), os.path.join(web, "leak.txt"))
    srv = Server(binary, os.path.join(tmp, "w"), ["--web-root", web]).start()
    try:
        status, _, body = srv.request("GET", "/static/leak.txt", token=None)
        check(status == 404 and b"secret" not in body, "a link out of the web root is not served")
        status, _, _ = srv.request("GET", "/", token=None)
        check(status == 200, "the web root's own page is served")
    finally:
        srv.stop()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repo", required=True)
    ap.add_argument("--bin", required=True)
    ap.add_argument("--long", action="store_true")
    a = ap.parse_args()
    check = Checks()
    binary = os.path.join(a.bin, "kinemetricd")
    with tempfile.TemporaryDirectory() as tmp:
        srv = Server(binary, os.path.join(tmp, "d"),
                     ["--max-connections", "256", "--max-connections-per-client", "128"]).start()
        try:
            check_controller_text(srv, a.repo, a.bin, tmp, check)
            check_framing(srv, check)
            check_metrics(srv, check)
            check_half_open(srv, check)
        finally:
            code = srv.stop()
        check(code == 0, "clean stop: exit %s" % code)
        check_web_root(binary, tmp, check)
    return check.finish("ops_hardening3_test")


if __name__ == "__main__":
    sys.exit(main())
