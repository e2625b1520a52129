#!/usr/bin/python3
"""The layering of the sources, checked from their includes and imports (docs/architecture.md):

  * C++: a folder includes only its own layer and those below it,
        analysis < ingest, render < usecases < server < api, cli (cli beside api, without
        server);
    and no circle between modules (a module = x.h, x.cpp and the parts x_<part>.cpp without a
    header of their own in the same folder), so no include runs back up inside a layer either;
    a part with its own header (x_<part>.h) is a module of its own, so a part never includes
    its whole (x_<part>.h including x.h while x.cpp includes x_<part>.h is a circle: the
    types both need go to a header of their own). The floor of a layer (analysis/core,
    server/base) includes nothing else of its layer: every room of the layer stands on it.
  * The web page (web/static/*.js): no circle of imports, static or dynamic (import('./x.js')).
  * No source folder (tests included) holds more than 40 source files, and no tracked source
    file (C++, JavaScript, Python, shell) is longer than 600 lines.
Prints every violation and exits 1 if there is one."""
import os
import re
import subprocess
import sys
from collections import defaultdict

LAYERS = {"analysis": 0, "ingest": 1, "render": 1, "usecases": 2, "server": 3, "api": 4, "cli": 4}
FLOORS = {"analysis/core", "server/base"}
FORBIDDEN = {("cli", "server"), ("cli", "api"), ("api", "cli"), ("ingest", "render"),
             ("render", "ingest")}
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)
IMPORT = re.compile(r"""(?:\bfrom\s+|\bimport\s*\(\s*|^\s*import\s+)['"]\./([\w./-]+\.js)['"]""", re.M)
MAX_FILES = 40
MAX_LINES = 600


def sources(repo, exts):
    for top in LAYERS if exts != (".js",) else ["web/static"]:
        for root, _, files in os.walk(os.path.join(repo, top)):
            if "node_modules" in root:
                continue
            for f in files:
                if f.endswith(exts):
                    yield os.path.relpath(os.path.join(root, f), repo)


def modules(files):
    """Module of each file: its path without extension, or the module it is a part of — the
    longest name m in the same folder with path = m_<part> when the part has no header of its
    own (feed_drive_lugre.cpp). A part with a header is its own module: were a part and its
    whole one module when they include each other, the circle would be hidden."""
    names = {os.path.splitext(f)[0] for f in files}
    headers = {os.path.splitext(f)[0] for f in files if f.endswith(".h")}
    out = {}
    for f in files:
        mod = name = os.path.splitext(f)[0]
        base = name
        while "_" in os.path.basename(base):
            base = base.rsplit("_", 1)[0]
            if base in names and name not in headers:
                mod = base
                break
        out[f] = mod
    return out


def cycles(graph):
    """Strongly connected components with more than one node (Tarjan, iterative)."""
    index, low, on, stack, out, counter = {}, {}, set(), [], [], [0]
    for start in list(graph):
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = counter[0]
        counter[0] += 1
        stack.append(start)
        on.add(start)
        while work:
            node, it = work[-1]
            nxt = next(it, None)
            if nxt is not None:
                if nxt not in index:
                    index[nxt] = low[nxt] = counter[0]
                    counter[0] += 1
                    stack.append(nxt)
                    on.add(nxt)
                    work.append((nxt, iter(sorted(graph.get(nxt, ())))))
                elif nxt in on:
                    low[node] = min(low[node], index[nxt])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                comp = []
                while True:
                    w = stack.pop()
                    on.discard(w)
                    comp.append(w)
                    if w == node:
                        break
                if len(comp) > 1:
                    out.append(sorted(comp))
    return out


def check_cpp(repo, problems):
    files = list(sources(repo, (".h", ".cpp")))
    includes = {}
    for f in files:
        with open(os.path.join(repo, f), encoding="utf-8") as fh:
            includes[f] = [i for i in INCLUDE.findall(fh.read()) if i.split("/")[0] in LAYERS]
    module = modules(files)
    by_name = {os.path.splitext(f)[0]: m for f, m in module.items()}
    graph = defaultdict(set)
    for f in files:
        top = f.split("/")[0]
        graph.setdefault(module[f], set())
        for inc in includes[f]:
            itop = inc.split("/")[0]
            if LAYERS[itop] > LAYERS[top] or (top, itop) in FORBIDDEN:
                problems.append("%s includes %s: %s may not include %s" % (f, inc, top, itop))
            floor = os.path.dirname(f)
            if floor in FLOORS and itop == top and os.path.dirname(inc) != floor:
                problems.append("%s includes %s: the floor %s includes nothing above it" %
                                (f, inc, floor))
            target = by_name.get(os.path.splitext(inc)[0], os.path.splitext(inc)[0])
            if target != module[f]:
                graph[module[f]].add(target)
    for comp in cycles(graph):
        problems.append("include circle between modules: " + " ↔ ".join(comp))


def check_web(repo, problems):
    graph = defaultdict(set)
    for f in sources(repo, (".js",)):
        with open(os.path.join(repo, f), encoding="utf-8") as fh:
            text = fh.read()
        mod = os.path.basename(f)
        graph.setdefault(mod, set())
        for target in IMPORT.findall(text):
            graph[mod].add(os.path.basename(target))
    for comp in cycles(graph):
        problems.append("import circle in web/static: " + " ↔ ".join(comp))


SOURCE_EXTS = (".h", ".cpp", ".js", ".mjs", ".py", ".sh")


def tracked_sources(repo):
    """Tracked source files (git ls-files), or every file below the source folders outside git."""
    try:
        out = subprocess.run(["git", "-C", repo, "ls-files"], check=True, capture_output=True,
                             text=True).stdout.split("\n")
    except (OSError, subprocess.CalledProcessError):
        out = [os.path.relpath(os.path.join(r, f), repo)
               for top in list(LAYERS) + ["web", "tests", "deploy"]
               for r, _, fs in os.walk(os.path.join(repo, top)) if "node_modules" not in r
               for f in fs]
    return [f for f in out if f.endswith(SOURCE_EXTS) and os.path.isfile(os.path.join(repo, f))]


def check_folders(repo, problems):
    per_folder = defaultdict(int)
    for f in tracked_sources(repo):
        per_folder[os.path.dirname(f)] += 1
        with open(os.path.join(repo, f), encoding="utf-8", errors="replace") as fh:
            lines = sum(1 for _ in fh)
        if lines > MAX_LINES:
            problems.append("%s has %d lines (at most %d)" % (f, lines, MAX_LINES))
    for folder, n in sorted(per_folder.items()):
        if n > MAX_FILES:
            problems.append("%s holds %d source files (at most %d)" % (folder, n, MAX_FILES))


def main():
    repo = sys.argv[1] if len(sys.argv) > 1 else os.path.dirname(
        os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    problems = []
    check_cpp(repo, problems)
    check_web(repo, problems)
    check_folders(repo, problems)
    for p in problems:
        print(p)
    print("layering: %d problem%s" % (len(problems), "" if len(problems) == 1 else "s"))
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
