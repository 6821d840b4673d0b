#!/usr/bin/env python3
"""deploy/can-up.sh and deploy/rt-check.sh in harmless modes.

can-up.sh: --dry-run prints exactly the ip commands for the options given; bad options are refused with status 2 and
a message naming the option; a real run on an interface that does not exist fails before it touches anything.
rt-check.sh: on this host it finishes (status 0 or 1) with one finding per check; on two fake hosts (a --root with
/proc and /sys files written here) it reports exactly what is wrong with the bad one and nothing with the good one.
"""
import argparse
import os
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "test_utilities"))
from teleop_process import check, run, run_test  # noqa: E402


def can_up(script):
    rc, out, err = run([script, "--dry-run"])
    check(rc == 0 and out.splitlines() == [
        "ip link set can0 down",
        "ip link set can0 type can bitrate 1000000 dbitrate 5000000 fd on restart-ms 100",
        "ip link set can0 txqueuelen 128",
        "ip link set can0 up",
    ], "can-up --dry-run: can0 at 1 Mbit/s, FD 5 Mbit/s, restart-ms 100, txqueuelen 128 (the rig configs' rates)")
    rc, out, err = run([script, "--dry-run", "--interface", "can1", "--bitrate", "500000", "--dbitrate", "2000000",
                        "--restart-ms", "0", "--txqueuelen", "64", "--sample-point", "0.875"])
    check(rc == 0 and out.splitlines()[1] ==
          "ip link set can1 type can bitrate 500000 sample-point 0.875 dbitrate 2000000 fd on restart-ms 0"
          and out.splitlines()[2] == "ip link set can1 txqueuelen 64", "can-up --dry-run with every option")
    rc, out, err = run([script, "--dry-run", "--no-fd", "--bitrate", "250000"])
    check(rc == 0 and out.splitlines()[1] == "ip link set can0 type can bitrate 250000 fd off restart-ms 100",
          "can-up --no-fd: classic CAN, no data bit rate")
    for bad, word in ((["--bitrate", "2000000"], "--bitrate"), (["--bitrate", "fast"], "--bitrate"),
                      (["--dbitrate", "500000", "--bitrate", "1000000"], "--dbitrate"),
                      (["--restart-ms", "-5"], "--restart-ms"), (["--txqueuelen", "0"], "--txqueuelen"),
                      (["--interface", "can0; reboot"], "--interface"), (["--sample-point", "87.5"], "--sample-point"),
                      (["--frobnicate"], "unknown option")):
        rc, out, err = run([script, "--dry-run"] + bad)
        check(rc == 2 and word in err and out == "", f"can-up refuses {' '.join(bad)}: {err.strip()}")
    if os.geteuid() == 0:
        rc, out, err = run([script, "--interface", "tlpnocan0"])
        check(rc == 2 and "no interface tlpnocan0" in err and "+ ip" not in out,
              f"can-up on a missing interface stops before any change: {err.strip()}")


CHECKS = ["preemption", "governor", "rtprio", "memlock", "isolcpus", "irq-affinity", "rt-throttling", "clocksource"]


def findings(out):
    """{check: level} from rt-check's output lines ('  ok    name  text', '  FIX   name  text')."""
    result = {}
    for line in out.splitlines():
        parts = line.split()
        if len(parts) >= 2 and parts[0] in ("ok", "warn", "FIX"):
            result[parts[1]] = parts[0]
    return result


def write(root, path, text):
    full = os.path.join(root, path.lstrip("/"))
    os.makedirs(os.path.dirname(full), exist_ok=True)
    with open(full, "w") as f:
        f.write(text)


def fake_host(root, good):
    limits = ("Limit                     Soft Limit           Hard Limit           Units\n"
              f"Max locked memory         {'unlimited' if good else '8388608'}            unlimited            bytes\n"
              f"Max realtime priority     {'95' if good else '0'}                    95\n")
    write(root, "/proc/self/limits", limits)
    write(root, "/proc/self/status", "Name:\tbash\nUid:\t1000\t1000\t1000\t1000\n")
    write(root, "/proc/version", "Linux version 6.1.0-rt (gcc) #1 SMP PREEMPT_RT Debian\n" if good
          else "Linux version 6.1.0 (gcc) #1 SMP Debian\n")
    write(root, "/proc/cmdline", "root=/dev/sda1 isolcpus=3 nohz_full=3\n" if good else "root=/dev/sda1 quiet\n")
    for c in range(4):
        write(root, f"/sys/devices/system/cpu/cpu{c}/cpufreq/scaling_governor",
              "performance\n" if good or c < 2 else "powersave\n")
    write(root, "/sys/devices/system/cpu/present", "0-3\n")
    write(root, "/sys/devices/system/cpu/isolated", "3\n" if good else "\n")
    for irq, aff in ((0, "0"), (9, "0-2"), (24, "0-3" if not good else "0-2"), (25, "1")):
        write(root, f"/proc/irq/{irq}/smp_affinity_list", aff + "\n")
    write(root, "/proc/irq/default_smp_affinity", "7\n" if good else "f\n")
    write(root, "/proc/sys/kernel/sched_rt_runtime_us", "950000\n")
    write(root, "/sys/devices/system/clocksource/clocksource0/current_clocksource", "tsc\n")


def rt_check(script):
    rc, out, err = run([script])
    print(out)
    got = findings(out)
    check(rc in (0, 1), f"rt-check on this host finishes (status {rc})")
    check(set(got) == set(CHECKS), f"rt-check on this host reports every check: {got}")
    check(out.strip().splitlines()[-1].startswith("rt-check: "), "rt-check ends with a count of what to fix")
    check((rc == 0) == ("FIX" not in got.values()), "its status says whether something needs fixing")

    with tempfile.TemporaryDirectory(prefix="teleop-rtcheck-") as tmp:
        good, bad = os.path.join(tmp, "good"), os.path.join(tmp, "bad")
        fake_host(good, True)
        fake_host(bad, False)
        rc, out, err = run([script, "--root", good, "--cpu", "3"])
        print(out)
        got = findings(out)
        check(rc == 0 and set(got.values()) == {"ok"} and set(got) == set(CHECKS),
              "a PREEMPT_RT host with performance governor, limits, isolated CPU 3 and no IRQ on it: all ok")
        rc, out, err = run([script, "--root", bad])
        print(out)
        got = findings(out)
        expected = {"preemption": "FIX", "governor": "FIX", "rtprio": "FIX", "memlock": "FIX", "isolcpus": "FIX",
                    "irq-affinity": "FIX", "rt-throttling": "ok", "clocksource": "ok"}
        check(rc == 1 and got == expected, f"the bad host: every problem found and nothing else ({got})")
        check("powersave" in out and "cpu2" in out and "cpu3" in out and "cpu0" not in out,
              "the governor finding names the CPUs that are not on performance")
        check("isolcpus=3" in out, "the isolcpus fix proposes the last CPU")
        check("1 IRQs may run on CPU(s) 3: 24" in out, "the IRQ finding names IRQ 24, the only one allowed on CPU 3")
        rc, out, err = run([script, "--root", good, "--cpu", "1"])
        got = findings(out)
        check(rc == 1 and got["isolcpus"] == "FIX" and got["irq-affinity"] == "FIX",
              "realtime.cpu 1 on the good host: not isolated, and IRQs 9, 24 and 25 may run there")
        rc, out, err = run([script, "--cpu", "x"])
        check(rc == 2 and "--cpu" in err, "rt-check refuses a bad --cpu")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--can-up", required=True)
    ap.add_argument("--rt-check", required=True)
    args = ap.parse_args()
    can_up(args.can_up)
    rt_check(args.rt_check)


if __name__ == "__main__":
    run_test(main)
