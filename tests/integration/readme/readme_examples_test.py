#!/usr/bin/python3
"""Runs every runnable command block of README.md, so that no README example can rot.

Convention (also stated in README.md): a fenced block opened with ```sh is runnable when one
of its command lines runs the command-line tool, `build/bin/kinemetric ...` (or `kinemetric
...`). Blocks that do not (e.g. `deploy/run.sh`, which installs packages) are only shown.

Each runnable block is run as one bash script with `set -e -o pipefail`, in README order, in
one fresh temporary directory that looks like the repository root: `build/bin` points at the
programs under test (--bin) and every top-level entry of the repository (data/, docs/, tests/,
...) is linked in, so a command reads the repository's files and writes its outputs (plots,
simulated files) into the temporary directory. build/bin is also first on PATH. A line that
starts the service (`kinemetricd`) runs for at most a few seconds and counts as passed if it
was still running then. The test fails if any block fails, or if README.md has no runnable
block at all.
"""
import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

RUNS_CLI = re.compile(r"^\s*(?:\S*/)?kinemetric(?:\s|$)")
RUNS_SERVER = re.compile(r"^\s*(?:\S*/)?kinemetricd(?:\s|$)")
SERVER_SECONDS = 5


def blocks_of(readme_text):
    """(first line number, [lines]) of every ```sh block."""
    out, current, start = [], None, 0
    for n, line in enumerate(readme_text.splitlines(), 1):
        stripped = line.strip()
        if current is None:
            if stripped.startswith("```") and stripped[3:].split()[:1] == ["sh"]:
                current, start = [], n + 1
        elif stripped.startswith("```"):
            out.append((start, current))
            current = None
        else:
            current.append(line)
    if current is not None:
        raise SystemExit("README.md: a ```sh block opened at line %d is never closed" % (start - 1))
    return out


def commands(lines):
    return [l for l in lines if l.strip() and not l.strip().startswith("#")]


def runnable(lines):
    return any(RUNS_CLI.match(l) for l in commands(lines))


def script_of(lines):
    body = ["set -e -o pipefail", "set -x"]
    for l in lines:
        if RUNS_SERVER.match(l):
            body.append("rc=0; timeout %d %s || rc=$?; [ $rc -eq 0 ] || [ $rc -eq 124 ]"
                        % (SERVER_SECONDS, l.strip().rstrip("&")))
        else:
            body.append(l)
    return "\n".join(body) + "\n"


def make_root(repo, bin_dir, tmp):
    for name in sorted(os.listdir(repo)):
        if name.startswith(".") or name.startswith("build") or name in ("var",):
            continue
        os.symlink(os.path.join(repo, name), os.path.join(tmp, name))
    os.makedirs(os.path.join(tmp, "build"))
    os.symlink(bin_dir, os.path.join(tmp, "build", "bin"))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repo", required=True, help="repository root (holds README.md)")
    ap.add_argument("--bin", required=True, help="directory with the kinemetric program")
    args = ap.parse_args()
    repo = os.path.abspath(args.repo)
    bin_dir = os.path.abspath(args.bin)
    if not os.access(os.path.join(bin_dir, "kinemetric"), os.X_OK):
        print("FAIL: no kinemetric program in %s (build the target kinemetric)" % bin_dir)
        return 1
    with open(os.path.join(repo, "README.md"), encoding="utf-8") as f:
        readme = f.read()
    todo = [(start, lines) for start, lines in blocks_of(readme) if runnable(lines)]
    if not todo:
        print("FAIL: README.md has no runnable ```sh block (one that runs build/bin/kinemetric)")
        return 1
    tmp = tempfile.mkdtemp(prefix="km-readme-")
    failed = []
    try:
        make_root(repo, bin_dir, tmp)
        env = dict(os.environ)
        env["PATH"] = os.path.join(tmp, "build", "bin") + os.pathsep + env.get("PATH", "")
        for start, lines in todo:
            n = len(commands(lines))
            t0 = time.monotonic()
            p = subprocess.run(["bash", "-c", script_of(lines)], cwd=tmp, env=env,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               timeout=800)
            dt = time.monotonic() - t0
            if p.returncode == 0:
                print("ok   README.md line %d: %d commands, %.1f s" % (start, n, dt))
                continue
            failed.append(start)
            print("FAIL README.md line %d: exit status %d after %.1f s" % (start, p.returncode, dt))
            print("---- commands run (bash -x) and their errors ----")
            print(p.stderr[-6000:])
            print("---- end of stdout ----")
            print(p.stdout[-2000:])
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    if failed:
        print("FAIL: %d of %d runnable README blocks failed (lines %s)"
              % (len(failed), len(todo), ", ".join(map(str, failed))))
        return 1
    print("all %d runnable README blocks pass" % len(todo))
    return 0


if __name__ == "__main__":
    sys.exit(main())
