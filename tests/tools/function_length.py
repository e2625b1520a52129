#!/usr/bin/python3
"""Size limits of the production C++ code (docs/architecture.md, "Conventions").

No function longer than --max-function-lines (120) lines and no source file longer than
--max-file-lines (600) lines, over the tracked *.cpp / *.h files outside tests/. A function's
length runs from the first line of its signature to its closing brace. Functions are found by
brace matching on the text with comments, string and character literals and preprocessor
directives blanked out: a brace block at file, namespace or class scope whose header (the text
since the previous `;`, `{` or `}`) has a parameter list and is not a namespace, class, enum or
initialised variable. Lambdas and local classes count as part of the function around them.

  function_length.py --repo DIR                  exit 1 and a line per offender
  function_length.py --repo DIR --list N         also print the N longest functions
"""

import argparse
import os
import re
import subprocess
import sys
from pathlib import Path

CONTROL = re.compile(r"^\s*(if|for|while|switch|catch|do|else|try)\b")
NAMESPACE = re.compile(r"\bnamespace\b|\bextern\s*$")
CLASS = re.compile(r"\b(class|struct|union|enum)\b")
NAME = re.compile(r"([A-Za-z_~][A-Za-z0-9_:<>~]*(?:\s*operator\s*[^\s(]+)?)\s*\($")


def blank(text):
    """The text with comments, literals and preprocessor lines replaced by spaces (newlines kept)."""
    out = []
    i, n = 0, len(text)
    at_line_start = True
    while i < n:
        c = text[i]
        if at_line_start and c == "#":
            # A preprocessor directive with its continuation lines.
            while i < n:
                if text[i] == "\n" and text[i - 1] != "\\":
                    break
                out.append("\n" if text[i] == "\n" else " ")
                i += 1
            continue
        if c == "\n":
            at_line_start = True
            out.append(c)
            i += 1
            continue
        if not c.isspace():
            at_line_start = False
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c == "R" and text.startswith('R"', i) and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            m = re.match(r'R"([^()\\\s]{0,16})\(', text[i:])
            if not m:
                out.append(c)
                i += 1
                continue
            end = ")" + m.group(1) + '"'
            j = text.find(end, i + m.end())
            j = n if j < 0 else j + len(end)
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c in "\"'":
            if c == "'" and i > 0 and text[i - 1].isalnum():  # digit separator 1'000
                out.append(" ")
                i += 1
                continue
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            j = min(j + 1, n)
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        else:
            out.append(c)
            i += 1
    return "".join(out)


def classify(header):
    """Kind of the block a `{` opens at file, namespace or class scope."""
    h = " ".join(header.split())
    h = re.sub(r"^template\s*<[^{;]*?>\s*(?=[A-Za-z_])", "", h)  # template <typename T = int>
    if not h or h.endswith("=") or h.endswith(","):
        return "data"
    if NAMESPACE.search(h) and "(" not in h:
        return "namespace"
    if "(" not in h:
        return "class" if CLASS.search(h) else "data"
    if CLASS.search(h.split("(")[0]) and not re.search(r"\)\s*(const|noexcept|override|final|->.*)?\s*$", h):
        return "class"
    if "=" in h.split("(")[0] and not re.search(r"\boperator\b", h):
        # An initialised variable; a lambda assigned at namespace scope counts as a function.
        return "function" if re.search(r"\]\s*\(", h) else "data"
    if CONTROL.match(h):
        return "data"
    return "function"


def functions(text):
    """(name, first line, last line) of every function defined in the text."""
    code = blank(text)
    found = []
    stack = []  # kinds of the open blocks
    header_start = 0
    line_of = [0] * (len(code) + 1)
    line = 1
    for k, ch in enumerate(code):
        line_of[k] = line
        if ch == "\n":
            line += 1
    for k, ch in enumerate(code):
        if ch == "{":
            scope = stack[-1][0] if stack else "namespace"
            if scope in ("namespace", "class"):
                header = code[header_start:k]
                kind = classify(header)
                first = header_start + (len(header) - len(header.lstrip()))
                stack.append((kind, first, header))
            else:
                stack.append(("inner", k, ""))
            header_start = k + 1
        elif ch == "}":
            if stack:
                kind, first, header = stack.pop()
                if kind == "function":
                    name = header.split("(")[0].split()
                    found.append((name[-1] if name else "?", line_of[first], line_of[k]))
            header_start = k + 1
        elif ch == ";":
            header_start = k + 1
        elif ch == ":" and stack and stack[-1][0] == "class":
            # Access specifiers (public:, private:) end a header inside a class.
            before = code[header_start:k].strip()
            if before in ("public", "private", "protected"):
                header_start = k + 1
    return found


def source_files(repo):
    """The tracked *.cpp / *.h files; every such file outside build output without git."""
    try:
        return subprocess.run(["git", "-C", str(repo), "ls-files", "*.cpp", "*.h"], check=True,
                              capture_output=True, text=True).stdout.split()
    except (OSError, subprocess.CalledProcessError):
        files = []
        for root, dirs, names in os.walk(repo):
            dirs[:] = [d for d in dirs if not d.startswith((".", "build")) and
                       d not in ("node_modules", "var")]
            files += [os.path.relpath(os.path.join(root, n), repo) for n in names
                      if n.endswith((".cpp", ".h"))]
        return sorted(files)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repo", required=True)
    ap.add_argument("--max-function-lines", type=int, default=120)
    ap.add_argument("--max-file-lines", type=int, default=600)
    ap.add_argument("--list", type=int, default=0, help="print the N longest functions")
    args = ap.parse_args()
    repo = Path(args.repo)
    files = [f for f in source_files(repo) if not f.startswith("tests/")]
    if not files:
        print("no C++ files found under", repo)
        return 1
    problems, all_functions = [], []
    for f in files:
        path = repo / f
        if not path.exists():  # deleted in the working tree
            continue
        text = path.read_text(encoding="utf-8")
        lines = text.count("\n") + (0 if text.endswith("\n") else 1)
        if lines > args.max_file_lines:
            problems.append(f"{f}: {lines} lines (file limit {args.max_file_lines})")
        for name, first, last in functions(text):
            length = last - first + 1
            all_functions.append((length, f, first, name))
            if length > args.max_function_lines:
                problems.append(f"{f}:{first}: {name} is {length} lines (function limit "
                                f"{args.max_function_lines})")
    for length, f, first, name in sorted(all_functions, reverse=True)[:args.list]:
        print(f"{length:5d}  {f}:{first}  {name}")
    print(f"{len(files)} files, {len(all_functions)} functions checked")
    for p in problems:
        print(p)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
