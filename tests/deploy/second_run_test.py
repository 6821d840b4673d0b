#!/usr/bin/env python3
"""deploy/lib/common.sh's teleop::ctest, the second run for timing-sensitive tests, on a miniature ctest project.

The project has three tests: `locked_flaky` (RESOURCE_LOCK two_process_cpu) and `unlocked_flaky` (no lock) fail the
first time they run and pass after (a marker file), `locked_broken` (RESOURCE_LOCK qemu_guest) always fails.
Checks: with only `locked_flaky` selected the run passes and names it as passed on the second run; with
`unlocked_flaky` there is no second run and the run fails; with `locked_broken` the second run happens and the run
fails; TELEOP_SECOND_RUN=0 turns the second run off.
"""
import argparse
import os
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "test_utilities"))
from teleop_process import check, run_test  # noqa: E402

PROJECT = """cmake_minimum_required(VERSION 3.16)
project(second_run NONE)
enable_testing()
set(flaky [[if [ -e "$0" ]; then exit 0; fi; touch "$0"; echo "[error] first run fails"; exit 1]])
add_test(NAME locked_flaky COMMAND sh -c "${flaky}" ${CMAKE_BINARY_DIR}/locked.mark)
set_tests_properties(locked_flaky PROPERTIES RESOURCE_LOCK two_process_cpu)
add_test(NAME unlocked_flaky COMMAND sh -c "${flaky}" ${CMAKE_BINARY_DIR}/unlocked.mark)
add_test(NAME locked_broken COMMAND sh -c "echo '[error] always fails'; exit 1")
set_tests_properties(locked_broken PROPERTIES RESOURCE_LOCK qemu_guest)
"""


def run_ctest(common, build, selection, env=None):
    for mark in ("locked.mark", "unlocked.mark"):
        if os.path.exists(os.path.join(build, mark)):
            os.remove(os.path.join(build, mark))
    script = f'source "{common}"; teleop::ctest "{build}" --output-on-failure -R "^{selection}$"'
    p = subprocess.run(["bash", "-c", script], capture_output=True, text=True, env={**os.environ, **(env or {})})
    return p.returncode, p.stdout + p.stderr


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--common", required=True)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        src, build = os.path.join(tmp, "src"), os.path.join(tmp, "build")
        os.makedirs(src)
        open(os.path.join(src, "CMakeLists.txt"), "w").write(PROJECT)
        subprocess.run(["cmake", "-S", src, "-B", build], check=True, capture_output=True)

        rc, out = run_ctest(args.common, build, "locked_flaky")
        check("seeded 2 locked tests to start first" in out,
              "the first run (no measured costs) seeds both locked tests to start first")
        check(rc == 0 and "a second run, one at a time, of the timing-sensitive tests that failed: locked_flaky" in out
              and "passed on the second run, alone (failed the first time beside other tests): locked_flaky" in out
              and "first run fails" in out,
              f"a locked test that fails once passes on its second run, named, its first failure kept (rc {rc})")

        rc, out = run_ctest(args.common, build, "unlocked_flaky")
        check(rc != 0 and "second run, one at a time" not in out and "unlocked_flaky is not timing-sensitive" in out,
              f"a test without a timing lock gets no second run (rc {rc})")

        rc, out = run_ctest(args.common, build, "locked_broken")
        check(rc != 0 and "second run, one at a time" in out and "passed on the second run" not in out
              and out.count("***Failed") >= 2, f"a locked test that fails twice fails the run (rc {rc})")

        rc, out = run_ctest(args.common, build, "locked_flaky", {"TELEOP_SECOND_RUN": "0"})
        check(rc != 0 and "second run, one at a time" not in out, f"TELEOP_SECOND_RUN=0: no second run (rc {rc})")


if __name__ == "__main__":
    run_test(main)
