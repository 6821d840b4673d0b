#!/usr/bin/env python3
"""A rig's CAN configs over the emulated bus, each process writing the candump log of its own traffic.

The shipped deploy/configs/<rig>/{master,slave}-can.yaml (default: the hybrid rig, CAN FD, 2 DOF, 1 kHz) run for
about 1.5 s with only three changes for a test machine: real time relaxed, the SocketCAN interface swapped for the
emulated bus daemon (teleop-canbus, on a free port), and `link.can.log_path` set. Checks (docs/can.md, "A log of a
process's own frames"):

  - both processes run (exit 0) and couple over the bus;
  - each log is well-formed candump -L (the format canplayer and log2asc read), timestamps never go back, and it
    holds exactly what the process's summary says it wrote, with 0 drops: its own frames (the summary's frames
    sent, on its own identifiers) and the peer's it read (frames received, on the peer's identifiers);
  - can-utils' log2asc converts every line;
  - an unwritable log_path is refused at start-up with a message naming the file (exit 2), before any cycle.
"""
import argparse
import json
import os
import re
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "test_utilities"))
from teleop_process import (Failure, Output, Processes, check, free_udp_port, relax_realtime,  # noqa: E402
                            run, run_test, set_key, to_emulated_bus, write_text)

LINE = re.compile(r"^\((\d+\.\d{6})\) (vcan0) ([0-9A-F]{3}|[0-9A-F]{8})(#[0-9A-F]*|##[0-9A-F][0-9A-F]*|#R)$")


def counts(summary):
    """Frames sent and received, and the log's written/dropped counts, from the summary's CAN line."""
    detail = summary["link_detail"]
    m = re.search(r"CAN frames sent (\d+), received (\d+)", detail)
    e = re.search(r"error frames (\d+)", detail)
    w = re.search(r"candump log [^:]+: (\d+) frames logged, (\d+) dropped \(ring full\), (\d+) write errors", detail)
    if not (m and e and w):
        raise Failure(f"the summary's link detail lacks the CAN or candump log counts: {detail}")
    return {"sent": int(m[1]), "received": int(m[2]), "errors": int(e[1]), "logged": int(w[1]),
            "dropped": int(w[2]), "write_errors": int(w[3])}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--master", required=True)
    ap.add_argument("--slave", required=True)
    ap.add_argument("--canbus", required=True)
    ap.add_argument("--configs", required=True, help="deploy/configs/<rig> with master-can.yaml and slave-can.yaml")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="teleop-can-self-log-") as tmp:
        port = free_udp_port()
        cfg, log, summary = {}, {}, {}
        base = {}
        for role in ("master", "slave"):
            text = open(os.path.join(args.configs, f"{role}-can.yaml")).read()
            check("log_path:" in text, f"{role}-can.yaml shows the log_path key")
            log[role] = os.path.join(tmp, f"{role}.log")
            text = to_emulated_bus(relax_realtime(text), f"127.0.0.1:{port}")
            text = set_key(text, "log_path", f'"{log[role]}"')
            cfg[role] = write_text(os.path.join(tmp, f"{role}.yaml"), text)
            summary[role] = os.path.join(tmp, f"{role}.json")
            base[role] = int(re.search(rf"(?m)^\s*{role}_to_\w+_base_id:\s*(0x[0-9A-Fa-f]+)", text)[1], 16)
        fd = re.search(r"(?m)^\s*fd:\s*true", open(cfg["master"]).read()) is not None

        with Processes() as procs:
            bus = procs.start("bus", [args.canbus, "--port", str(port), "--bitrate", "1000000", "--data-bitrate",
                                      "5000000", "--duration-s", "60", "--stats-every-s", "0"])
            if not Output(bus).wait_for("listening", 30):
                raise Failure("teleop-canbus did not start")

            # Refused at start-up: a log in a folder that does not exist.
            bad = write_text(os.path.join(tmp, "bad.yaml"),
                             set_key(open(cfg["slave"]).read(), "log_path", f'"{tmp}/no/such/dir/slave.log"'))
            rc, out, err = run([args.slave, "--config", bad, "--duration", "5"], timeout_s=60)
            check(rc == 2 and "candump log: cannot open" in out + err and "no/such/dir/slave.log" in out + err
                  and "cycles" not in out, f"an unwritable log_path is refused at start-up (exit {rc})")
            slave = procs.start("slave", [args.slave, "--config", cfg["slave"], "--duration", "8",
                                          "--summary-json", summary["slave"]])
            slave_out = Output(slave)
            if not slave_out.wait_for("DOF at", 60):
                raise Failure("teleop-slave did not start its loop:\n" + slave_out.text())
            master = procs.start("master", [args.master, "--config", cfg["master"], "--duration", "1.5",
                                            "--summary-json", summary["master"]])
            master_out = Output(master)
            mrc, src = master.wait(timeout=90), slave.wait(timeout=90)
            print(master_out.text()[-1500:])
            check(mrc == 0 and src == 0, f"both processes ran over the emulated bus (exit {mrc}, {src})")

        for role in ("master", "slave"):
            peer = "slave" if role == "master" else "master"
            s = json.load(open(summary[role]))
            c = counts(s)
            check(s["packets"]["accepted"] > 100, f"{role}: coupled ({s['packets']['accepted']} samples accepted)")
            lines = open(log[role]).read().splitlines()
            parsed = [LINE.match(x) for x in lines]
            check(lines and all(parsed), f"{role}: {len(lines)} lines, each a candump -L frame")
            check(all((m[4].startswith("##") if fd else not m[4].startswith("##")) for m in parsed),
                  f"{role}: every frame {'CAN FD' if fd else 'classic'}, as configured")
            times = [float(m[1]) for m in parsed]
            check(all(b >= a for a, b in zip(times, times[1:])), f"{role}: timestamps never go back")
            own = sum(1 for m in parsed if base[role] <= int(m[3], 16) <= base[role] + 4)
            theirs = sum(1 for m in parsed if base[peer] <= int(m[3], 16) <= base[peer] + 4)
            check(c["dropped"] == 0 and c["write_errors"] == 0, f"{role}: no frame dropped, no write error")
            check(c["logged"] == len(lines) == c["sent"] + c["received"] + c["errors"],
                  f"{role}: the log holds every frame: {len(lines)} lines = {c['logged']} logged = "
                  f"{c['sent']} sent + {c['received']} received + {c['errors']} error frames")
            check(own == c["sent"] and theirs == c["received"],
                  f"{role}: {own} of its own frames (0x{base[role]:X}..) and {theirs} of the {peer}'s "
                  f"(0x{base[peer]:X}..)")
            asc = os.path.join(tmp, f"{role}.asc")
            r = subprocess.run(["log2asc", "-I", log[role], "-O", asc, "vcan0"], stdout=subprocess.PIPE,
                               stderr=subprocess.STDOUT, text=True, timeout=60)
            body = open(asc).read() if os.path.exists(asc) else ""
            frames = [x for x in body.splitlines() if re.search(r"\b(Rx|Tx)\b", x)]
            print("\n".join(body.splitlines()[:6]))
            check(r.returncode == 0 and len(frames) == len(lines),
                  f"{role}: log2asc converts it to ASC: {len(frames)} frames of {len(lines)}")
    return 0


if __name__ == "__main__":
    run_test(main)
