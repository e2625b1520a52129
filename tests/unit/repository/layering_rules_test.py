#!/usr/bin/python3
"""The layering check (tests/tools/check_layers.py) sees what it is meant to see, on small
checkouts written here: a part whose header includes its whole while the whole includes the
part is a circle; a headerless part is its whole's own file; a floor (server/base) including a
room above it is refused; a clean checkout has no problem."""
import os
import subprocess
import sys
import tempfile

TOOL = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools",
                    "check_layers.py")


def run(files):
    with tempfile.TemporaryDirectory() as repo:
        for path, text in files.items():
            os.makedirs(os.path.join(repo, os.path.dirname(path)), exist_ok=True)
            with open(os.path.join(repo, path), "w", encoding="utf-8") as fh:
                fh.write(text)
        out = subprocess.run([sys.executable, TOOL, repo], capture_output=True, text=True)
        return out.returncode, out.stdout


def inc(*paths):
    return "".join('#include "%s"\n' % p for p in paths)


def main():
    failures = []

    def expect(name, files, code, needle):
        rc, out = run(files)
        if rc != code or (needle and needle not in out):
            failures.append("%s: exit %d, output:\n%s" % (name, rc, out))

    clean = {
        "render/page_types.h": "",
        "render/report.h": inc("render/page_types.h"),
        "render/report.cpp": inc("render/report.h", "render/report_page.h"),
        "render/report_page.h": inc("render/page_types.h"),
        "render/report_plots.cpp": inc("render/report.h", "render/report_page.h"),
        "server/base/config.cpp": inc("server/base/url.h"),
        "server/base/url.h": "",
        "server/audits/webhook.h": inc("server/base/url.h"),
    }
    expect("clean", clean, 0, "layering: 0 problems")
    circle = dict(clean)
    circle["render/report_page.h"] = inc("render/report.h")
    expect("part includes its whole", circle, 1,
           "include circle between modules: render/report ↔ render/report_page")
    floor = dict(clean)
    floor["server/base/config.cpp"] = inc("server/audits/webhook.h")
    expect("floor includes a room", floor, 1, "the floor server/base includes nothing above it")
    up = dict(clean)
    up["render/report.h"] = inc("server/base/url.h")
    expect("include up a layer", up, 1, "render may not include server")
    for f in failures:
        print(f)
    print("layering rules: %d failure%s" % (len(failures), "" if len(failures) == 1 else "s"))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
