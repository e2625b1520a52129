#!/usr/bin/python3
"""The instrument register on a real kinemetricd over HTTP (docs/http.md "Instruments"):
  * an engineer registers a ballbar; a viewer reads it, an operator may not store one (403);
  * a DBB file naming its serial is analysed with the register's uncertainties where the file
    states none, its result says which came from where and the register version; a file
    stating its own u_reading_um keeps it ("file"); a file measured after the calibration was
    due carries the warning; the stored bytes are the uploaded bytes;
  * hostile serials (../, CR/LF, quotes, 10 kB, percent-encoded) and bodies (nested 10 000
    deep, huge numbers, NaN) are refused — 4xx, never 5xx — and the server keeps answering;
  * the register survives a restart."""
import argparse
import json
import os
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ops_server import Checks, Server, check_database, example_dbb, sha256  # noqa: E402

BALLBAR = {"instrument": "Renishaw QC20-W", "kind": "ballbar",
           "uncertainties": {"u_reading_um": 0.5, "u_bar_length_um": 0.7,
                             "bar_expansion_ppm_per_k": 11.5},
           "calibrated": "2026-01-15", "calibration_interval_days": 365,
           "certificate": "UKAS 0123 / 2026-004"}
WARNING = "instrument %s was past its calibration interval (due %s) when this was measured"


def with_header(dbb, lines):
    first, rest = dbb.split(b"\n", 1)
    return first + b"\n" + lines.encode() + rest


def token(srv, role):
    status, t = srv.json("POST", "/api/v1/tokens", {"name": "instruments " + role, "role": role})
    assert status == 201, status
    return t["token"]


def upload(srv, data, check, what):
    status, up = srv.json("POST", "/api/v1/measurements", data)
    check(status == 201, "%s: upload %s %s" % (what, status, up))
    mid = up["id"]
    return mid, srv.json("GET", "/api/v1/measurements/%d/results" % mid)[1]


def check_register_and_uploads(srv, dbb, check):
    viewer, operator = token(srv, "viewer"), token(srv, "operator")
    engineer = token(srv, "engineer")
    check(srv.json("PUT", "/api/v1/instruments/QC20-7", BALLBAR, token=operator)[0] == 403,
          "an operator may not register an instrument")
    status, v1 = srv.json("PUT", "/api/v1/instruments/QC20-7", BALLBAR, token=engineer)
    check(status == 200 and v1["version"] == 1 and v1["calibration_due"] == "2027-01-15",
          "register: %s %s" % (status, v1))
    status, got = srv.json("GET", "/api/v1/instruments/QC20-7", token=viewer)
    check(status == 200 and got["uncertainties"]["u_bar_length_um"] == 0.7, "read: %s" % got)
    # The file states u_reading_um; the bar's values come from the register.
    data = with_header(dbb, "# instrument_serial: QC20-7\n# u_reading_um: 0.3\n")
    mid, r = upload(srv, data, check, "registered serial")
    b = r.get("instrument") or {}
    check(b.get("register_version") == 1 and b.get("instrument") == "Renishaw QC20-W" and
          b.get("calibration_due") == "2027-01-15" and b.get("overdue") is False,
          "the instrument block: %s" % b)
    check(b.get("sources") == {"u_reading_um": "file", "u_bar_length_um": "register",
                               "bar_expansion_ppm_per_k": "register"},
          "sources: %s" % b.get("sources"))
    meta = srv.json("GET", "/api/v1/measurements/%d" % mid)[1]["metadata"]
    check("u_bar_length_um" not in meta and meta.get("u_reading_um") == "0.3",
          "the measurement's metadata is the file's own: %s" % meta)
    check(check_database(srv.data_dir)[2].get(mid) == sha256(data),
          "the stored bytes are the uploaded bytes")
    # A second version, calibrated a year earlier: due before the file's 2026-11-02.
    old = dict(BALLBAR, calibrated="2025-01-15")
    check(srv.json("PUT", "/api/v1/instruments/QC20-7", old, token=engineer)[1]["version"] == 2,
          "version 2")
    _, late = upload(srv, with_header(dbb, "# instrument_serial: QC20-7\n"), check, "overdue")
    check(late["instrument"]["overdue"] is True and late["instrument"]["register_version"] == 2
          and WARNING % ("QC20-7", "2026-01-15") in late.get("warnings", []),
          "the overdue warning: %s %s" % (late["instrument"], late.get("warnings")))
    _, none = upload(srv, with_header(dbb, "# room: metrology lab\n"), check, "no instrument")
    check("instrument" in none and none["instrument"] is None, "no instrument keys: null")


def check_hostile(srv, dbb, check):
    good = json.dumps(BALLBAR).encode()
    serials = ["..", "..%2F..%2Fetc%2Fpasswd", "a%0D%0ASet-Cookie:%20x=1", "%22quoted%22",
               "'q'", "%3Cimg%20src=x%3E", "S" * 10000, "-1", "a%20b", "%C3%A9", "a%00b",
               "../../etc/passwd"]
    for s in serials:
        for method, body in (("PUT", good), ("GET", None)):
            status, _, text = srv.request(method, "/api/v1/instruments/" + s, body,
                                          headers={"Content-Type": "application/json"})
            check(400 <= status < 500, "%s serial %r: %d %s" % (method, s[:40], status, text[:80]))
    bodies = [b"[" * 10000 + b"]" * 10000,
              b'{"a":' * 10000 + b"1" + b"}" * 10000,
              b'{"instrument":"x","kind":"laser","uncertainties":{"u_laser_ppm":1e400}}',
              b'{"instrument":"x","kind":"laser","uncertainties":{"u_laser_ppm":NaN}}',
              b'{"instrument":"x","kind":"laser","uncertainties":{"u_laser_ppm":1e300}}',
              b'{"instrument":"x","kind":"laser","calibration_interval_days":1e30}',
              b'{"instrument":"x","kind":"laser","kind":"tracker"}',
              b'{"instrument":"x\\r\\ny","kind":"laser"}', b"", b"{"]
    for body in bodies:
        status, _, text = srv.request("PUT", "/api/v1/instruments/SAFE-1", body,
                                      headers={"Content-Type": "application/json"})
        check(status == 400, "body %r: %d %s" % (body[:40], status, text[:80]))
    for line in ("# instrument_serial: ../x\n", "# instrument_serial: \"<b>\"\n",
                 "# u_reading_um: NaN\n", "# u_bar_length_um: 1e999\n"):
        status, _, text = srv.request("POST", "/api/v1/measurements", with_header(dbb, line))
        check(status == 400, "file with %r: %d %s" % (line, status, text[:80]))
    check(srv.request("GET", "/healthz", token=None)[0] == 200, "the server still answers")
    check(srv.json("GET", "/api/v1/instruments/SAFE-1")[0] == 404, "nothing was stored")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repo", required=True)
    ap.add_argument("--bin", required=True)
    a = ap.parse_args()
    check = Checks()
    dbb = example_dbb(a.repo)
    with tempfile.TemporaryDirectory() as tmp:
        srv = Server(os.path.join(a.bin, "kinemetricd"), os.path.join(tmp, "d"),
                     ["--access-log", "off"]).start()
        try:
            check_register_and_uploads(srv, dbb, check)
            check_hostile(srv, dbb, check)
            srv.stop()
            srv.start()
            status, got = srv.json("GET", "/api/v1/instruments")
            check(status == 200 and got["total"] == 1 and got["items"][0]["version"] == 2,
                  "the register after a restart: %s" % got)
        finally:
            srv.stop()
    return check.finish("ops_instruments_test")


if __name__ == "__main__":
    sys.exit(main())
