#!/usr/bin/env python3
"""Command-line and start-up checks that must refuse bad input at once, with a clear message and a non-zero exit:

  - teleop-slave --duration nan (CLI11's range check lets NaN through: it ran forever) and --duration inf;
  - an unwritable --summary-json (a missing folder, a directory) is found at start-up, before any cycle, not after
    the run; a writable one is written at the end and a refused start leaves no file behind;
  - teleop-analyze max-stiffness when the model has no limit below its search ceiling (absurd operators: it printed
    the ceiling, 1e9, as the limit) and when no stiffness is stable (kp 1e300: it printed 0 and exited 0); the
    ordinary case still prints a positive limit with exit 0.
"""
import argparse
import os
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "test_utilities"))
from teleop_process import check, free_udp_port, run, run_test, write_text  # noqa: E402
import teleop_keys  # noqa: E402


def one_machine_slave(configs, tmp):
    """deploy/configs/slave.yaml on free ports (no master: the slave runs alone)."""
    text = open(os.path.join(configs, "slave.yaml")).read()
    text = text.replace("127.0.0.1:47002", f"127.0.0.1:{free_udp_port()}").replace("127.0.0.1:47001", "127.0.0.1:9")
    teleop_keys.ensure_key(tmp)  # link.security key_file: teleop.key, beside the config
    return write_text(os.path.join(tmp, "slave.yaml"), text)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--slave", required=True)
    ap.add_argument("--analyze", required=True)
    ap.add_argument("--configs", required=True)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="teleop-cli-") as tmp:
        cfg = one_machine_slave(args.configs, tmp)

        for bad in ("nan", "NaN", "inf", "-1"):
            rc, out, err = run([args.slave, "--config", cfg, "--duration", bad], timeout_s=30)
            check(rc != 0 and "--duration" in out + err and "cycles" not in out,
                  f"--duration {bad} is refused at once (exit {rc}): {(out + err).strip().splitlines()[0]}")
        rc, out, err = run([args.slave, "--config", cfg, "--duration", "nan"], timeout_s=30)
        check("finite" in out + err, "the message says the duration must be finite")

        missing = os.path.join(tmp, "no", "such", "dir", "summary.json")
        for path, what in ((missing, "a missing folder"), (tmp, "a directory")):
            rc, out, err = run([args.slave, "--config", cfg, "--duration", "30", "--summary-json", path], timeout_s=60)
            text = out + err
            check(rc == 2 and f"cannot write the summary to {path}" in text and "checked at start-up" in text
                  and "cycles" not in out,
                  f"--summary-json in {what} is refused at start-up, before any cycle (exit {rc})")
        check(not os.path.exists(os.path.dirname(missing)), "nothing was created for the refused path")

        fine = os.path.join(tmp, "summary.json")
        # Writable, but the start is refused afterwards (a fixture above the predicted limit): no file left behind.
        unstable = write_text(os.path.join(tmp, "unstable.yaml"),
                              open(cfg).read().replace("stiffness_N_per_m: 2000", "stiffness_N_per_m: 9000"))
        rc, out, err = run([args.slave, "--config", unstable, "--duration", "0.3", "--summary-json", fine],
                           timeout_s=60)
        check(rc == 2 and "refusing to start" in out + err and not os.path.exists(fine),
              f"a start refused after the check leaves no summary file behind (exit {rc})")
        rc, out, err = run([args.slave, "--config", cfg, "--duration", "0.3", "--summary-json", fine], timeout_s=60)
        # Alone, the slave never connects: exit 5 (kExitNeverConnected), the summary written all the same.
        check(rc == 5 and os.path.getsize(fine) > 0 and '"cycles"' in open(fine).read()
              and '"connected": false' in open(fine).read(),
              f"a writable --summary-json is written at the end of a run that never connected (exit {rc})")

        rc, out, err = run([args.analyze, "max-stiffness", "--side", "slave", "--rate", "1000", "--kp", "600",
                            "--kd", "2"], timeout_s=120)
        check(rc == 0 and float(out.strip()) > 100, f"max-stiffness, ordinary gains: {out.strip()} N/m, exit 0")

        rc, out, err = run([args.analyze, "max-stiffness", "--side", "slave", "--rate", "1000", "--kp", "1e300",
                            "--kd", "2"], timeout_s=120)
        check(rc != 0 and out.strip() == "" and "no fixture stiffness is stable" in err,
              f"kp 1e300: no number, a message, exit {rc}: {err.strip()}")

        rc, out, err = run([args.analyze, "max-stiffness", "--side", "slave", "--rate", "1000", "--kp", "600",
                            "--kd", "2", "--slave-mass", "1e9", "--slave-damping", "1e9"], timeout_s=300)
        check(rc != 0 and out.strip() == "" and "no limit found" in err and "search ceiling" in err,
              f"absurd parameters: the ceiling is not printed as a limit, exit {rc}: {err.strip()}")
    return 0


if __name__ == "__main__":
    run_test(main)
