#!/usr/bin/env python3
"""The shape of the library's source at two commits, as Markdown on stdout.

    python3 benches/structure.py BEFORE AFTER

For each commit (read from git, not from the working tree): the five largest files of `src/`,
the files over 800 lines, the functions over 120 lines, the methods of the core trait
`LogDensity`, and the crate's `pub` items (`pub` alone, not `pub(crate)` or `pub(super)`).
Functions are measured by matching braces from their signature, skipping strings, characters
and comments; test modules (`mod tests`, files named `tests.rs`) are left out of the function
count, as the issue that set the bounds leaves them out.
"""

import re
import subprocess
import sys

PUB_ITEM = re.compile(r"^\s*pub (fn|struct|enum|trait|type|const|static|mod|use|unsafe fn|async fn)\b")
FN_START = re.compile(r"^\s*(pub(\([^)]*\))?\s+)?(const\s+)?(unsafe\s+)?fn\s+(\w+)")


def git(*args):
    return subprocess.run(["git", *args], check=True, capture_output=True, text=True).stdout


def sources(rev):
    files = [f for f in git("ls-tree", "-r", "--name-only", rev, "src").split() if f.endswith(".rs")]
    return {f: git("show", f"{rev}:{f}") for f in files}


def code_only(text):
    """The text with strings, characters and comments blanked (newlines kept)."""
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append("\n" * text.count("\n", i, j))
            i = j
        elif c == "r" and re.match(r'r#*"', text[i:i + 10]) and (i == 0 or not text[i - 1].isalnum()):
            hashes = re.match(r'r(#*)"', text[i:]).group(1)
            end = '"' + hashes
            j = text.find(end, i + len(hashes) + 2)
            j = n if j < 0 else j + len(end)
            out.append("\n" * text.count("\n", i, j))
            i = j
        elif c == '"':
            j = i + 1
            while j < n and text[j] != '"':
                j += 2 if text[j] == "\\" else 1
            out.append("\n" * text.count("\n", i, j + 1))
            i = j + 1
        elif c == "'" and re.match(r"'(\\.|[^\\'])'", text[i:i + 4]):
            i += len(re.match(r"'(\\.|[^\\'])'", text[i:i + 4]).group(0))
        elif c == "'" and re.match(r"'\\u\{[0-9a-fA-F]+\}'", text[i:i + 12]):
            i += len(re.match(r"'\\u\{[0-9a-fA-F]+\}'", text[i:i + 12]).group(0))
        else:
            out.append(c)
            i += 1
    return "".join(out)


def without_tests(path, text):
    """Lines of the file but its test module (`#[cfg(test)] mod tests` to the end, where it sits
    at the end as in this code base); a `tests.rs` file is all test."""
    if path.endswith("/tests.rs"):
        return 0
    m = re.search(r"^#\[cfg\(test\)\]\s*\nmod tests\b", text, re.M)
    return text[: m.start()].count("\n") if m else text.count("\n")


def long_functions(path, text, limit=120):
    """(name, lines) of each function over `limit` lines outside test modules."""
    if path.endswith("/tests.rs"):
        return []
    lines = code_only(text).split("\n")
    found, depth, test_depth = [], 0, None
    i = 0
    while i < len(lines):
        line = lines[i]
        if test_depth is None and re.match(r"^\s*mod tests\b", line):
            test_depth = depth
        m = FN_START.match(line)
        if m and test_depth is None:
            # From the signature to the matching close of its body.
            d, started, j = 0, False, i
            while j < len(lines):
                for ch in lines[j]:
                    if ch == "{":
                        d, started = d + 1, True
                    elif ch == "}":
                        d -= 1
                if started and d == 0:
                    break
                if not started and lines[j].rstrip().endswith(";"):
                    break  # a declaration without a body
                j += 1
            if started and j - i + 1 > limit:
                found.append((m.group(5), j - i + 1))
        depth += line.count("{") - line.count("}")
        if test_depth is not None and depth <= test_depth and "}" in line:
            test_depth = None
        i += 1
    return found


def trait_methods(files, trait):
    for text in files.values():
        code = code_only(text)
        m = re.search(r"pub trait " + trait + r"\b[^{]*\{", code)
        if not m:
            continue
        depth, j = 1, m.end()
        while depth:
            depth += {"{": 1, "}": -1}.get(code[j], 0)
            j += 1
        body = code[m.end():j]
        # Only the trait's own level: skip bodies of provided methods.
        names, d = [], 0
        for line in body.split("\n"):
            if d == 0:
                f = re.match(r"^\s*fn\s+(\w+)", line)
                if f:
                    names.append(f.group(1))
            d += line.count("{") - line.count("}")
        return names
    return []


def measure(rev):
    files = sources(rev)
    sizes = sorted(((t.count("\n"), f) for f, t in files.items()), reverse=True)
    pub_items = sum(1 for t in files.values() for l in t.split("\n") if PUB_ITEM.match(l))
    pub_fns = sum(1 for t in files.values() for l in t.split("\n") if re.match(r"^\s*pub fn\b", l))
    long = sorted(((n, f, name) for f, t in files.items() for name, n in long_functions(f, t)), reverse=True)
    return {
        "commit": git("rev-parse", "--short", rev).strip(),
        "files": len(files),
        "lines": sum(s for s, _ in sizes),
        "largest": sizes[:5],
        "over800": sorted(((without_tests(f, t), f) for f, t in files.items() if without_tests(f, t) > 800), reverse=True),
        "long": long,
        "log_density": trait_methods(files, "LogDensity"),
        "pub_items": pub_items,
        "pub_fns": pub_fns,
    }


def main():
    before, after = measure(sys.argv[1]), measure(sys.argv[2])
    print("| | before (`%s`) | after (`%s`) |" % (before["commit"], after["commit"]))
    print("|---|---|---|")
    rows = [
        ("files in `src/`", "files"),
        ("lines in `src/`", "lines"),
        ("`pub` items of the crate", "pub_items"),
        ("of which `pub fn`", "pub_fns"),
    ]
    for label, key in rows:
        print(f"| {label} | {before[key]:,} | {after[key]:,} |")
    print(f"| methods of `LogDensity` | {len(before['log_density'])} | {len(after['log_density'])} |")
    print(f"| files over 800 lines (test modules aside) | {len(before['over800'])} | {len(after['over800'])} |")
    print(f"| functions over 120 lines (tests aside) | {len(before['long'])} | {len(after['long'])} |")
    print()
    for m in (before, after):
        print(f"The five largest files at `{m['commit']}`:\n")
        for s, f in m["largest"]:
            print(f"- `{f}`: {s:,} lines")
        print()
    print(f"`LogDensity` at `{after['commit']}`: " + ", ".join(f"`{n}`" for n in after["log_density"]) + ".\n")
    if after["over800"]:
        print(f"Files over 800 lines (test modules aside) at `{after['commit']}`:\n")
        for s, f in after["over800"]:
            print(f"- `{f}`: {s:,} lines")
        print()
    if after["long"]:
        print(f"Functions over 120 lines at `{after['commit']}`:\n")
        for n, f, name in after["long"]:
            print(f"- `{name}` in `{f}`: {n} lines")
        print()


if __name__ == "__main__":
    main()
