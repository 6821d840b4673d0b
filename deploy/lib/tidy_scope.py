#!/usr/bin/env python3
"""Which library sources clang-tidy must check: every one whose compiled inputs changed since a fully checked commit.

Usage: tidy_scope.py BUILD_DIR BASE_REV
Prints one absolute source path per line. A source is in scope when the source itself, or any project header the
compiler read for it (ninja's dependency log, `ninja -t deps`), differs between BASE_REV and the working tree. When
.clang-tidy changed or BASE_REV is not an ancestor of HEAD, every source is in scope. BASE_REV is the commit recorded in .ci/tidy-baseline: the last commit on
which the whole tree was checked clean (`TELEOP_CHECK_TIDY=full ./deploy/test.sh` or `deploy/lib/check_tidy.sh BUILD`).
"""
import json
import os
import re
import shlex
import subprocess
import sys

LIBRARY = re.compile(r"/(proto|common|master|slave)/.*\.cpp$")
# A change to the checks can change what clang-tidy reports anywhere: check everything. (Compiler flags do not: with
# `Checks: -*,...` the compiler's own warnings are filtered out of clang-tidy's report, and the build checks them.)
WHOLE_TREE_TRIGGERS = re.compile(r"^\.clang-tidy$")


def git(root, *args):
    return subprocess.run(["git", "-C", root, *args], check=True, capture_output=True, text=True).stdout


def main():
    build, base = os.path.abspath(sys.argv[1]), sys.argv[2]
    root = git(os.path.dirname(os.path.abspath(__file__)), "rev-parse", "--show-toplevel").strip()
    with open(os.path.join(build, "compile_commands.json")) as f:
        entries = json.load(f)
    sources = {}  # absolute object path -> absolute source path
    for e in entries:
        src = os.path.normpath(os.path.join(e["directory"], e["file"]))
        if not LIBRARY.search(src):
            continue
        args = shlex.split(e["command"])
        obj = args[args.index("-o") + 1] if "-o" in args else None
        if obj:
            sources[os.path.normpath(os.path.join(e["directory"], obj))] = src
    everything = sorted(set(sources.values()))

    ancestor = subprocess.run(["git", "-C", root, "merge-base", "--is-ancestor", base, "HEAD"],
                              capture_output=True).returncode == 0
    if not ancestor:
        print(f"tidy_scope: {base} is not an ancestor of HEAD: checking every source", file=sys.stderr)
        print("\n".join(everything))
        return
    changed = {os.path.normpath(os.path.join(root, p)) for p in git(root, "diff", "--name-only", base).split()}
    changed |= {os.path.normpath(os.path.join(root, p))
                for p in git(root, "ls-files", "--others", "--exclude-standard").split()}
    if any(WHOLE_TREE_TRIGGERS.search(os.path.relpath(p, root)) for p in changed):
        print(".clang-tidy changed: checking every source", file=sys.stderr)
        print("\n".join(everything))
        return

    deps = subprocess.run(["ninja", "-C", build, "-t", "deps"], check=True, capture_output=True, text=True).stdout
    in_scope, current, known = set(), None, set()
    for line in deps.splitlines():
        if line and not line[0].isspace():
            obj = line.split(":", 1)[0]
            current = sources.get(os.path.normpath(os.path.join(build, obj)))
            if current:
                known.add(current)
        elif current and line.strip():
            if os.path.normpath(os.path.join(build, line.strip())) in changed:
                in_scope.add(current)
    # A source ninja has no dependency record for (not built yet) is checked: unknown is not clean.
    in_scope |= set(everything) - known
    print(f"tidy_scope: {len(in_scope)} of {len(everything)} library sources read a file changed since "
          f"{base[:12]}", file=sys.stderr)
    print("\n".join(sorted(in_scope)))


if __name__ == "__main__":
    main()
