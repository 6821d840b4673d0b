#!/usr/bin/env python3
"""deploy/teleop-canlog: a candump -L log of the processes' CAN traffic on the emulated bus.

teleop-canbus, teleop-slave and teleop-master (the emulated-CAN demo configs, classic CAN, 1 DOF, 1 kHz) run for
about 1.5 s on 127.0.0.1 while tshark captures the bus port. teleop-canlog turns the capture into a candump -L log;
the test then checks it with the qemu test's independent checker (tests/qemu/can_capture_check.py: every frame one of
the DBC's identifiers with the right length, unused bits 0, values in range, cycle counters without a gap), that both
directions are there in the numbers the processes' summaries report, and that can-utils' log2asc reads it. Exit 77
(skip) only when capturing is not permitted here.
"""
import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "test_utilities"))
from teleop_process import (SKIP, check, free_udp_port, run_test,  # noqa: E402
                            start_capture, stop_capture)

def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--master", required=True)
    ap.add_argument("--slave", required=True)
    ap.add_argument("--canbus", required=True)
    ap.add_argument("--configs", required=True)
    ap.add_argument("--canlog", required=True)
    ap.add_argument("--checker", required=True)
    ap.add_argument("--dbc", required=True)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="teleop-canlog-") as tmp:
        port = free_udp_port()
        cfg = {}
        for role in ("master", "slave"):
            text = open(os.path.join(args.configs, f"{role}-can.yaml")).read()
            check("fd: false" in text, f"{role}-can.yaml is classic CAN")
            cfg[role] = os.path.join(tmp, f"{role}.yaml")
            with open(cfg[role], "w") as f:
                f.write(re.sub(r"127\.0\.0\.1:47300", f"127.0.0.1:{port}", text))
        pcap = os.path.join(tmp, "bus.pcapng")
        cap = start_capture(pcap, f"udp port {port}")
        if cap is None:
            return SKIP
        procs = []
        try:
            bus = subprocess.Popen([args.canbus, "--port", str(port), "--bitrate", "1000000", "--duration-s", "15",
                                    "--stats-every-s", "0"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            procs.append(bus)
            time.sleep(0.3)
            mjson, sjson = os.path.join(tmp, "master.json"), os.path.join(tmp, "slave.json")
            slave = subprocess.Popen([args.slave, "--config", cfg["slave"], "--duration", "8", "--summary-json", sjson],
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
            procs.append(slave)
            time.sleep(0.3)
            master = subprocess.Popen([args.master, "--config", cfg["master"], "--duration", "1.5",
                                       "--summary-json", mjson], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                      text=True)
            procs.append(master)
            mout, _ = master.communicate(timeout=60)
            sout, _ = slave.communicate(timeout=60)
            time.sleep(0.3)
        finally:
            for p in procs:
                if p.poll() is None:
                    p.kill()
                    p.wait()
            stop_capture(cap)
        check(master.returncode == 0 and slave.returncode == 0, "both processes ran over the emulated bus")
        m, s = json.load(open(mjson)), json.load(open(sjson))

        log = os.path.join(tmp, "run.log")
        with open(log, "w") as f:
            r = subprocess.run([args.canlog, pcap, "--bus-port", str(port)], stdout=f, stderr=subprocess.PIPE,
                               text=True, timeout=120)
        print(r.stderr.strip())
        check(r.returncode == 0, "teleop-canlog converted the capture")
        lines = open(log).read().splitlines()
        print("\n".join(lines[:4]))
        pattern = re.compile(r"^\(\d+\.\d{6}\) vcan0 [0-9A-F]{3}#[0-9A-F]*$")
        check(lines and all(pattern.match(x) for x in lines), f"{len(lines)} lines, each a classic candump -L frame")
        m2s = sum(1 for x in lines if x.split()[2].startswith("100#"))
        s2m = sum(1 for x in lines if x.split()[2].startswith("180#"))
        # The log has what each node put on the bus: the master's samples (0x100) and the slave's (0x180).
        check(m2s >= m["packets"]["sent"] - 2 and m2s <= m["packets"]["sent"] + 2,
              f"{m2s} master frames (0x100) for the master's {m['packets']['sent']} samples sent")
        check(abs(s2m - s["packets"]["sent"]) <= 2, f"{s2m} slave frames (0x180) for the slave's {s['packets']['sent']}")
        times = [float(x[1:18]) for x in lines]
        check(all(b >= a for a, b in zip(times, times[1:])), "timestamps never go back")

        r = subprocess.run([sys.executable, args.checker, "--dbc", args.dbc, "--log", log, "--dof", "1",
                            "--rate-hz", "1000", "--min-rate-fraction", "0.3"],
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=120)
        print(r.stdout.strip()[-1500:])
        check(r.returncode == 0, "the DBC checker accepts the log: identifiers, lengths, values, no lost cycle")

        asc = os.path.join(tmp, "run.asc")
        r = subprocess.run(["log2asc", "-I", log, "-O", asc, "vcan0"], stdout=subprocess.PIPE,
                           stderr=subprocess.STDOUT, text=True, timeout=60)
        body = open(asc).read() if os.path.exists(asc) else ""
        frames = [x for x in body.splitlines() if re.search(r"\b(100|180)\s+Rx\s+d\s+\d", x)]
        check(r.returncode == 0 and len(frames) == len(lines),
              f"log2asc converts it to ASC: {len(frames)} frames of {len(lines)}")
    return 0


if __name__ == "__main__":
    run_test(main)
