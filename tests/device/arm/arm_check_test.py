#!/usr/bin/env python3
"""teleop-arm check --config (docs/arms.md, "Stability"): the stylus rig's slave with a 13600 N/m fixture, below the
limit at its start configuration (14057 N/m) but above the smallest over the arm's configurations near the plane
(13222 N/m with the default sweep), is refused (exit 3) with the worst configuration named (q, tool position,
apparent mass, limit); a config whose URDF is missing is an error naming the file (exit 1)."""
import argparse
import os
import re
import subprocess
import sys


def variant(src, dst, stiffness, urdf):
    text = open(src).read()
    text = re.sub(r"(?m)^(\s*stiffness_N_per_m:).*$", lambda m: f"{m.group(1)} {stiffness}", text, count=1)
    text = re.sub(r"(?m)^(\s*urdf:).*$", lambda m: f"{m.group(1)} {urdf}", text)
    with open(dst, "w") as f:
        f.write(text)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--teleop-arm", required=True)
    parser.add_argument("--config", required=True)
    parser.add_argument("--workdir", required=True)
    args = parser.parse_args()
    os.makedirs(args.workdir, exist_ok=True)
    robots = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(args.config)), "..", "..", "robots"))
    failures = []

    stiff = os.path.join(args.workdir, "slave-stiff.yaml")
    variant(args.config, stiff, 13600, os.path.join(robots, "arm_7dof.urdf"))
    r = subprocess.run([args.teleop_arm, "check", "--config", stiff], capture_output=True, text=True, timeout=60)
    print(r.stdout, r.stderr)
    if r.returncode != 3:
        failures.append(f"exit {r.returncode} for a 13600 N/m fixture, expected 3 (would refuse)")
    pattern = (r"would refuse to start: .*slave fixture 13600 N/m is above the predicted stability limit (\d+) N/m at "
               r"the worst of \d+ configurations near fixture plane 0: q = \([-0-9., ]+\) rad, tool at "
               r"\([-0-9., ]+\) m, apparent mass [0-9.e+-]+ kg")
    m = re.search(pattern, r.stdout)
    if not m:
        failures.append("the refusal does not name the worst configuration")
    elif not 2000 < int(m.group(1)) < 13600:
        failures.append(f"limit {m.group(1)} N/m is not between the rig's 2000 and 13600")

    missing = os.path.join(args.workdir, "slave-missing-urdf.yaml")
    variant(args.config, missing, 2000, os.path.join(args.workdir, "absent.urdf"))
    r = subprocess.run([args.teleop_arm, "check", "--config", missing], capture_output=True, text=True, timeout=60)
    print(r.stdout, r.stderr)
    if r.returncode != 1 or "absent.urdf" not in r.stderr:
        failures.append(f"a missing URDF: exit {r.returncode}, expected 1 with the file named in: {r.stderr}")

    for f in failures:
        print("FAIL:", f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
