#!/usr/bin/python3
"""The deployment files (docs/operations.md) against the code: deploy/kinemetricd.example.conf
documents every configuration key that server/base/config.cpp reads, each under a // comment, and
nothing else; a real kinemetricd starts with it and answers /healthz; docs/operations.md names
the operations options; the systemd unit runs as its own user with a
private data directory, restarts on failure and has the hardening options; the Containerfile
builds a Release from deploy/install-deps.sh with a data volume and a /healthz health check."""
import argparse
import json
import os
import re
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ops_server import Checks, Server  # noqa: E402


def code_keys(repo):
    """The config-file keys of server/base/config.cpp: the whole-number table and the named keys."""
    src = open(os.path.join(repo, "server", "base", "config.cpp"), encoding="utf-8").read()
    table = src[src.index("kNumberOptions[]"):]
    table = table[:table.index("};")]
    keys = set(re.findall(r'\{"([a-z_0-9]+)",\s*k[A-Za-z]+,', table))
    keys |= set(re.findall(r'key == "([a-z_0-9]+)"', src))
    return keys


def example_keys(text, check):
    """The top-level keys of the example file, each checked to follow a // comment line."""
    lines = text.split("\n")
    keys = []
    for i, line in enumerate(lines):
        m = re.match(r'^  "([a-z_0-9]+)":', line)
        if m:
            keys.append(m.group(1))
            check(i > 0 and lines[i - 1].strip().startswith("//"),
                  "example conf: key %s has no comment above it" % m.group(1))
    body = "\n".join(line for line in lines if not line.strip().startswith("//"))
    parsed = json.loads(body)
    check(sorted(parsed) == sorted(keys), "example conf: top-level keys parsed as listed")
    return keys


def check_unit(path, check):
    text = open(path, encoding="utf-8").read()
    for line in ["User=kinemetric", "StateDirectory=kinemetric", "Restart=on-failure",
                 "NoNewPrivileges=yes", "ProtectSystem=strict",
                 "ReadWritePaths=/var/lib/kinemetric", "ProtectHome=yes", "PrivateTmp=yes",
                 "KillSignal=SIGTERM", "WantedBy=multi-user.target"]:
        check(re.search(r"(?m)^%s$" % re.escape(line), text), "kinemetricd.service: " + line)
    m = re.search(r"(?m)^ExecStart=(\S+) (.*)$", text)
    check(m and "--config /etc/kinemetric/kinemetricd.conf" in m.group(2), "ExecStart --config")
    m = re.search(r"(?m)^TimeoutStopSec=(\d+)$", text)
    check(m and int(m.group(1)) > 10, "TimeoutStopSec above the default shutdown_timeout_s")


def check_containerfile(path, check):
    text = open(path, encoding="utf-8").read()
    for what, pattern in [("Debian base", r"(?m)^FROM debian:"),
                          ("deps", r"deploy/install-deps\.sh"),
                          ("Release", r"CMAKE_BUILD_TYPE=Release"),
                          ("volume", r'(?m)^VOLUME \["/var/lib/kinemetric"\]'),
                          ("health check", r"(?m)^HEALTHCHECK .*(\n .*)*/healthz"),
                          ("own user", r"(?m)^USER kinemetric$"),
                          ("entry", r'ENTRYPOINT \[".*kinemetricd".*"--data-dir", '
                                    r'"/var/lib/kinemetric"\]')]:
        check(re.search(pattern, text), "Containerfile: " + what)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repo", required=True)
    ap.add_argument("--bin", required=True)
    a = ap.parse_args()
    check = Checks()
    conf = os.path.join(a.repo, "deploy", "kinemetricd.example.conf")
    keys = example_keys(open(conf, encoding="utf-8").read(), check)
    known = code_keys(a.repo)
    check(len(known) >= 25, "config keys found in server/base/config.cpp: %d" % len(known))
    check(not known - set(keys), "undocumented in the example conf: %s" % sorted(known - set(keys)))
    check(not set(keys) - known, "unknown to the server: %s" % sorted(set(keys) - known))
    ops_doc = open(os.path.join(a.repo, "docs", "operations.md"), encoding="utf-8").read()
    for k in ("access_log", "metrics_public", "shutdown_timeout_s"):
        check("--" + k.replace("_", "-") in ops_doc, "docs/operations.md names --" + k)
    check_unit(os.path.join(a.repo, "deploy", "kinemetricd.service"), check)
    check_containerfile(os.path.join(a.repo, "deploy", "Containerfile"), check)
    with tempfile.TemporaryDirectory() as tmp:
        srv = Server(os.path.join(a.bin, "kinemetricd"), os.path.join(tmp, "d"),
                     ["--config", conf, "--access-log", "off"]).start()
        try:
            check(srv.request("GET", "/healthz", token=None)[0] == 200, "starts with the example")
        finally:
            check(srv.stop() == 0, "exit 0")
    return check.finish("ops_deploy")


if __name__ == "__main__":
    sys.exit(main())
