#!/usr/bin/python3
"""Fails when a tracked file depends on something a fresh clone does not have.

Every file `git ls-files` lists (text files; binary files are skipped) is searched for
  * paths outside the repository: the sibling folder of source material that a clone does not
    have (its name is in OUTSIDE below), and absolute working paths of a developer's machine
    (the work tree, home directories);
  * citations of documents that are not in the repository: numbered source files
    ("seed" followed by a number) and sections of the old interchange contract ("contract"
    followed by a section sign). Sources are cited by their keys in docs/references.md
    ("[PM-600 report] eq. 4.3"); formats and commands by "docs/formats.md §N".
docs/references.md is exempt from the citation rule (it may say where a key came from).
Each finding is printed as FILE:LINE: text.
"""
import argparse
import os
import re
import subprocess
import sys

# Built from pieces so that this file does not match itself.
OUTSIDE = [
    re.compile(r"\.\./" + "shared"),
    re.compile(r"(?<![\w.-])" + "shared" + r"/(?:docs|data|seeds|hooks)/"),
    re.compile(r"/" + "work" + r"/"),
    re.compile(r"/" + "home" + r"/[A-Za-z_][\w.-]*"),
    re.compile(r"(?<![\w.])/" + "root" + r"/"),
    re.compile(r"/" + "Users" + r"/[A-Za-z_][\w.-]*"),
]
CITATIONS = [
    re.compile(r"\b" + "seed" + r"s?\s+0\d\d\b", re.IGNORECASE),
    re.compile(r"\b" + "contract" + r"\s*\u00a7", re.IGNORECASE),
]
EXEMPT_FROM_CITATIONS = {"docs/references.md"}


def tracked_files(repo):
    try:
        out = subprocess.run(["git", "-C", repo, "ls-files", "-z"], check=True,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE).stdout
        return [p for p in out.decode("utf-8", "surrogateescape").split("\0") if p]
    except (OSError, subprocess.CalledProcessError):
        # Not a git checkout (e.g. an exported tree): every file except build output.
        files = []
        for root, dirs, names in os.walk(repo):
            dirs[:] = [d for d in dirs if not d.startswith((".", "build")) and
                       d not in ("node_modules", "var")]
            for n in names:
                files.append(os.path.relpath(os.path.join(root, n), repo))
        return files


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repo", required=True)
    repo = os.path.abspath(ap.parse_args().repo)
    files = tracked_files(repo)
    if not files:
        print("FAIL: no files found in %s" % repo)
        return 1
    findings, scanned = [], 0
    for rel in sorted(files):
        path = os.path.join(repo, rel)
        if not os.path.isfile(path):
            continue  # deleted in the working tree
        with open(path, "rb") as f:
            data = f.read()
        if b"\0" in data:
            continue  # binary
        scanned += 1
        text = data.decode("utf-8", "replace")
        patterns = OUTSIDE + ([] if rel in EXEMPT_FROM_CITATIONS else CITATIONS)
        for n, line in enumerate(text.splitlines(), 1):
            for p in patterns:
                m = p.search(line)
                if m:
                    findings.append("%s:%d: '%s' in: %s" % (rel, n, m.group(0), line.strip()[:160]))
                    break
    if findings:
        print("FAIL: %d lines refer to something outside the repository "
              "(cite docs/references.md keys or docs/formats.md sections instead):" % len(findings))
        print("\n".join(findings))
        return 1
    print("ok: %d tracked text files refer only to the repository" % scanned)
    return 0


if __name__ == "__main__":
    sys.exit(main())
