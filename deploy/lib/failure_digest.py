#!/usr/bin/env python3
"""After a failed ctest run: the lines that say why each failed test failed, printed last.

ctest --output-on-failure prints a failed test's whole output where the test ended, in the middle of the run; a
CI log shown by its head and tail then hides the reason. This reads the build's Testing/Temporary/LastTest.log
and, for each test in LastTestsFailed.log, prints the lines that carry a verdict: GoogleTest's failure lines and
the expressions around them, the Python tests' "FAILED:" checks, errors and sanitizer reports (at most
--max-lines per test, the last ones kept when there are more).

  deploy/lib/failure_digest.py BUILD_DIR [--max-lines N]
"""
import argparse
import os
import re
import sys

VERDICT = re.compile(
    r"FAILED|Failure|\bfailed\b|error:|\bError\b|Expected|Which is|Value of|Actual:|Timeout|Exception|"
    r"Sanitizer|runtime error|Traceback|Assertion|\[critical\]|\[error\]")
IGNORE = re.compile(r"^\s*ok:|^\[\s+OK\s+\]|^\[==========\]|^\[----------\]|^\[ RUN")


def sections(log_text):
    """Test name -> the output ctest recorded for it."""
    out = {}
    pattern = re.compile(r'^\d+/\d+ Testing: (.+?)\n.*?^Output:\n-+\n(.*?)^<end of output>', re.S | re.M)
    for m in pattern.finditer(log_text):
        out[m.group(1).strip()] = m.group(2)
    return out


def digest(output, max_lines):
    lines = [ln.rstrip() for ln in output.splitlines() if VERDICT.search(ln) and not IGNORE.search(ln)]
    if len(lines) > max_lines:
        return [f"  ... {len(lines) - max_lines} earlier lines left out"] + ["  " + ln for ln in lines[-max_lines:]]
    return ["  " + ln for ln in lines]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build_dir")
    ap.add_argument("--max-lines", type=int, default=25)
    args = ap.parse_args()
    tmp = os.path.join(args.build_dir, "Testing", "Temporary")
    failed_path, log_path = os.path.join(tmp, "LastTestsFailed.log"), os.path.join(tmp, "LastTest.log")
    if not os.path.exists(failed_path):
        print("failure digest: no LastTestsFailed.log (no test failed, or ctest did not run)")
        return 0
    names = [ln.split(":", 1)[1].strip() for ln in open(failed_path) if ":" in ln]
    outputs = sections(open(log_path, errors="replace").read()) if os.path.exists(log_path) else {}
    print(f"\n==== failure digest: {len(names)} failed test(s), the lines that say why ====")
    for name in names:
        print(f"-- {name}")
        if name not in outputs:
            print("  (no output recorded: see the test's lines above)")
            continue
        lines = digest(outputs[name], args.max_lines)
        print("\n".join(lines) if lines else "  (no verdict line in its output: see the test's lines above)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
