#!/usr/bin/env python3
"""CPU seconds to compile a set of sources with other compiler or flags than a build directory uses.

Takes each file's command from <build>/compile_commands.json, swaps the compiler and the -g/-O flags, compiles it to a
scratch object and prints the user+system CPU time per file and in total (what a clean build would spend on them;
wall time on a shared machine is noise). How the sanitizer pass's options were compared (docs/testing.md, "Test time"):

  cmake --preset debug
  deploy/lib/compile_cost.py build-debug --opt "-g -O1" --cxx g++ FILES...     # the old preset: GCC, -g -O1
  deploy/lib/compile_cost.py build-debug --opt "-g1 -O1" FILES...              # the preset's compiler (clang)

--cxx clang++ drops the GCC-only warning flags. No -Werror: this measures cost, not warnings.
--as-built keeps the build's own flags (its -g/-O, -Werror, a precompiled header): how the test precompiled header was
measured, with FILES compiled in a build configured with -DTELEOP_TEST_PCH=OFF and in one with ON (its header built).
"""
import argparse
import json
import re
import os
import shlex
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor

COMPILER = re.compile(r"^(c\+\+|cc|g\+\+|gcc|clang\+\+|clang)(-[0-9.]+)?$")
GCC_ONLY = {"-Wno-stringop-overflow", "-Wno-array-bounds", "-Wno-restrict"}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("build", help="build directory with compile_commands.json")
    parser.add_argument("files", nargs="+", help="sources, relative to the source tree")
    parser.add_argument("--cxx", help="compiler instead of the build's (e.g. g++, clang++)")
    parser.add_argument("--opt", default="-g1 -O1", help="debug-info and optimisation flags (default: %(default)s)")
    parser.add_argument("-j", type=int, default=2, help="parallel compiles (default: %(default)s)")
    parser.add_argument("--as-built", action="store_true", help="keep the build's -g/-O flags and -Werror (no --opt)")
    args = parser.parse_args()

    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    with open(os.path.join(args.build, "compile_commands.json"), encoding="utf-8") as f:
        db = {os.path.relpath(e["file"], root): e for e in json.load(f)}
    missing = [f for f in args.files if f not in db]
    if missing:
        print(f"compile_cost: not in {args.build}/compile_commands.json: {' '.join(missing)}", file=sys.stderr)
        return 2
    scratch = tempfile.mkdtemp(prefix="compile_cost.")

    def command(path: str) -> list[str]:
        words = shlex.split(db[path]["command"])
        # A compiler launcher (ccache) goes; so do the old -g/-O flags, the dependency file and -Werror.
        while len(words) > 1 and not COMPILER.match(os.path.basename(words[0])):
            words.pop(0)
        out, skip = [], 0
        for i, w in enumerate(words):
            if skip:
                skip -= 1
                continue
            if w in ("-MF", "-MT", "-o"):
                skip = 1
                continue
            if w == "-MD":
                continue
            if not args.as_built and (w == "-Werror" or w.startswith("-O") or w.startswith("-g")):
                continue
            if args.cxx and "clang" in args.cxx and w in GCC_ONLY:
                continue
            out.append(w)
        if args.cxx:
            out[0] = args.cxx
        obj = os.path.join(scratch, path.replace("/", "_") + ".o")
        opt = [] if args.as_built else shlex.split(args.opt)
        return [out[0], *opt, *out[1:], "-o", obj]

    def cost(path: str) -> tuple[str, float, bool]:
        # os.wait4 gives this one compiler's own CPU time, exact even with compiles in parallel.
        proc = subprocess.Popen(command(path), cwd=db[path]["directory"], stdout=subprocess.DEVNULL,
                                stderr=subprocess.PIPE, text=True)
        stderr = proc.stderr.read()
        _, status, usage = os.wait4(proc.pid, 0)
        proc.returncode = os.waitstatus_to_exitcode(status)
        if proc.returncode != 0:
            print(f"compile_cost: {path} failed:\n{stderr[-1500:]}", file=sys.stderr)
        return path, usage.ru_utime + usage.ru_stime, proc.returncode == 0

    with ThreadPoolExecutor(args.j) as pool:
        results = list(pool.map(cost, args.files))
    total = 0.0
    for path, cpu, ok in results:
        total += cpu
        print(f"{cpu:7.1f} s  {path}{'' if ok else '  (FAILED)'}")
    flags = "--as-built" if args.as_built else f"--opt '{args.opt}'"
    print(f"{total:7.1f} s  total CPU, {len(results)} files, {flags}" + (f" --cxx {args.cxx}" if args.cxx else ""))
    return 0 if all(ok for _, _, ok in results) else 1


if __name__ == "__main__":
    sys.exit(main())
