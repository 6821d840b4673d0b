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
  deploy/lib/timing_sensitive.py --seed-costs BUILD_DIR

--seed-costs, before a build directory's first ctest run (a fresh clone, CI): ctest has no measured times yet
(Testing/Temporary/CTestCostData.txt) and starts the tests in the order they were added, so the `two_process_cpu`
chain (about 300 s of tests that must run one after the other) and the `qemu_guest` chain start last and run on one
slot while the other idles. This writes a cost file that lists only the locked tests, the two_process_cpu chain
dearest, so ctest starts both chains first and fills the other slot with everything else (docs/testing.md). A run
with measured times (the file exists) is left alone; ctest rewrites the file with real times after every run.
"""
import argparse
import json
import os
import subprocess
import sys

TIMING_LOCKS = {"two_process_cpu", "qemu_guest"}


def properties(test):
    """A json-v1 test's properties by name, RESOURCE_LOCK always a list."""
    props = {p["name"]: p["value"] for p in test.get("properties", [])}
    locks = props.get("RESOURCE_LOCK", [])
    props["RESOURCE_LOCK"] = [locks] if isinstance(locks, str) else locks
    return props


def timing_sensitive(tests):
    """The names of the tests in ctest's json-v1 listing that hold a timing lock or run serially."""
    names = set()
    for test in tests:
        props = properties(test)
        if TIMING_LOCKS.intersection(props["RESOURCE_LOCK"]) or props.get("RUN_SERIAL") is True:
            names.add(test["name"])
    return names


# The seeded costs only order the locked tests before the rest (ctest runs the dearest first; a test the file does
# not list costs 0): the longer chain first, then the other.
SEED_COST = {"two_process_cpu": 100.0, "qemu_guest": 50.0}


def listing_of(build_dir, path=None):
    if path:
        return json.load(open(path))
    out = subprocess.run(["ctest", "--show-only=json-v1"], cwd=build_dir, capture_output=True, text=True,
                         check=True).stdout
    return json.loads(out)


def seed_costs(build_dir, listing):
    """Writes Testing/Temporary/CTestCostData.txt with the locked tests' seed costs unless it exists."""
    path = os.path.join(build_dir, "Testing", "Temporary", "CTestCostData.txt")
    if os.path.exists(path):
        print("timing-sensitive: measured test costs present, no seed")
        return 0
    lines = []
    for test in listing.get("tests", []):
        locks = properties(test)["RESOURCE_LOCK"]
        cost = max((SEED_COST[lock] for lock in locks if lock in SEED_COST), default=0.0)
        if cost > 0 and " " not in test["name"]:
            lines.append(f"{test['name']} 1 {cost}")
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w") as f:
        f.write("\n".join(lines + ["---", ""]))
    print(f"timing-sensitive: seeded {len(lines)} locked tests to start first (no measured test costs yet)")
    return 0


def failed_names(build_dir):
    path = os.path.join(build_dir, "Testing", "Temporary", "LastTestsFailed.log")
    if not os.path.exists(path):
        return []
    return [ln.split(":", 1)[1].strip() for ln in open(path) if ":" in ln]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build_dir")
    ap.add_argument("--listing", help="a saved `ctest --show-only=json-v1` (tests); default: ask ctest")
    ap.add_argument("--seed-costs", action="store_true", help="seed the first run's test order (see above)")
    args = ap.parse_args()
    if args.seed_costs:
        return seed_costs(args.build_dir, listing_of(args.build_dir, args.listing))
    failed = failed_names(args.build_dir)
    if not failed:
        print("timing-sensitive: no failed test recorded")
        return 1
    sensitive = timing_sensitive(listing_of(args.build_dir, args.listing).get("tests", []))
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
