#!/usr/bin/env python3
"""After a failed ctest run: may the failed tests be run once more, alone?

A test the project declares timing-sensitive is one that must not share the CPU with its kind: it holds the
`two_process_cpu` or `qemu_guest` resource lock or runs RUN_SERIAL (process pairs on an emulated bus or link,
the qemu guest's real-kernel CAN, the figure scripts). On CI's two loaded cores such a test can miss a watchdog
through a scheduler stall alone (docs/testing.md, "A second run for timing-sensitive tests"). When every failed
test is one of them, this prints them and exits 0: deploy/lib/common.sh then runs them once more, one at a time,
and the run passes only if each passes there. Any other failed test (unit, closed-loop, fuzz) exits 1: no second
run. The decision reads the build's Testing/Temporary/LastTestsFailed.log and `ctest --show-only=json-v1`.

  deploy/lib/timing_sensitive.py BUILD_DIR
"""
import argparse
import json
import os
import subprocess
import sys

TIMING_LOCKS = {"two_process_cpu", "qemu_guest"}


def timing_sensitive(tests):
    """The names of the tests in ctest's json-v1 listing that hold a timing lock or run serially."""
    names = set()
    for test in tests:
        props = {p["name"]: p["value"] for p in test.get("properties", [])}
        locks = props.get("RESOURCE_LOCK", [])
        if isinstance(locks, str):
            locks = [locks]
        if TIMING_LOCKS.intersection(locks) or props.get("RUN_SERIAL") is True:
            names.add(test["name"])
    return names


def failed_names(build_dir):
    path = os.path.join(build_dir, "Testing", "Temporary", "LastTestsFailed.log")
    if not os.path.exists(path):
        return []
    return [ln.split(":", 1)[1].strip() for ln in open(path) if ":" in ln]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build_dir")
    ap.add_argument("--listing", help="a saved `ctest --show-only=json-v1` (tests); default: ask ctest")
    args = ap.parse_args()
    failed = failed_names(args.build_dir)
    if not failed:
        print("timing-sensitive: no failed test recorded")
        return 1
    if args.listing:
        listing = json.load(open(args.listing))
    else:
        out = subprocess.run(["ctest", "--show-only=json-v1"], cwd=args.build_dir, capture_output=True, text=True,
                             check=True).stdout
        listing = json.loads(out)
    sensitive = timing_sensitive(listing.get("tests", []))
    others = [n for n in failed if n not in sensitive]
    if others:
        print(f"timing-sensitive: no second run: {', '.join(others)} "
              f"{'is' if len(others) == 1 else 'are'} not timing-sensitive (no two_process_cpu/qemu_guest lock, "
              "not RUN_SERIAL)")
        return 1
    print(f"timing-sensitive: every failed test holds a timing lock: {', '.join(failed)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
