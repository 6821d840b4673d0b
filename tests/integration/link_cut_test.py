#!/usr/bin/env python3
"""Cuts the real UDP link between teleop-master and teleop-slave (the demo configs, loopback plants) while the
master moves, with a UDP relay between the processes (tests/test_utilities/udp_relay.py) that drops both directions
for a window, and checks from the slave's telemetry and summary:

  safe state   the age of the newest peer sample when the slave left `engaged` (summary `faults[].peer_sample_age_s`
               and the telemetry): link.timeout_ms plus at most 2 cycles, plus any stall of the process measured in
               the telemetry (a loaded host can deschedule a process; that delay is measured, not assumed);
  excursion    the slave's motion from the last packet until aligning starts: at most 1 mm;
  re-engage    the slave's largest one-cycle motion from aligning until 100 ms after engaged, and the summary's
               largest coupling-reference step: at most 0.1 mm.

Prints a table, one row per cut (100 ms and 2 s by default).
"""
import argparse
import json
import os
import re
import subprocess
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "test_utilities"))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from two_process_test import Output, free_udp_port, read_telemetry  # noqa: E402
from udp_relay import UdpRelay  # noqa: E402
import teleop_keys  # noqa: E402

ENGAGED, ALIGNING = 3, 2


class Failure(Exception):
    pass


def write_config(src, dst, bind_port, peer_port, csv):
    text = open(src).read()
    text = re.sub(r'(?m)^(\s*bind:\s*)"127\.0\.0\.1:\d+"', lambda m: f'{m.group(1)}"127.0.0.1:{bind_port}"', text)
    text = re.sub(r'(?m)^(\s*peer:\s*)"127\.0\.0\.1:\d+"', lambda m: f'{m.group(1)}"127.0.0.1:{peer_port}"', text)
    text = re.sub(r"(?m)^(\s*csv:).*$", lambda m: f'{m.group(1)} "{csv}"', text)
    with open(dst, "w") as f:
        f.write(text)
    teleop_keys.ensure_key(os.path.dirname(dst))  # link.security key_file: teleop.key, beside the config


def timeout_ms(path):
    m = re.search(r"(?m)^\s*timeout_ms:\s*([0-9.]+)", open(path).read())
    return float(m.group(1)) if m else 50.0


def run_cut(args, cut_s, cut_at_master_s):
    work = os.path.join(args.workdir, f"cut_{int(cut_s * 1000)}ms")
    os.makedirs(work, exist_ok=True)
    for f in os.listdir(work):
        os.remove(os.path.join(work, f))
    ports = {"master": free_udp_port(), "slave": free_udp_port()}
    relay = UdpRelay(("127.0.0.1", ports["master"]), ("127.0.0.1", ports["slave"]))
    relay.start()
    msrc, ssrc = os.path.join(args.configs, "master.yaml"), os.path.join(args.configs, "slave.yaml")
    mcfg, scfg = os.path.join(work, "master.yaml"), os.path.join(work, "slave.yaml")
    mcsv, scsv = os.path.join(work, "master.csv"), os.path.join(work, "slave.csv")
    write_config(msrc, mcfg, ports["master"], relay.master_side[1], mcsv)
    write_config(ssrc, scfg, ports["slave"], relay.slave_side[1], scsv)
    mjson, sjson = os.path.join(work, "master.json"), os.path.join(work, "slave.json")
    slave = subprocess.Popen([args.slave, "--config", scfg, "--duration", "30", "--summary-json", sjson],
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    slave_out = Output(slave)
    time.sleep(0.3)
    master = subprocess.Popen([args.master, "--config", mcfg, "--duration", "5", "--summary-json", mjson],
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    master_out = Output(master)
    try:
        if not (master_out.wait_for("engaged", 120) and slave_out.wait_for("engaged", 10)):
            raise Failure("the two processes never engaged")
        # The master's loop started about 50 ms before it engaged; its operator pushes from 0.5 s (the ramp).
        time.sleep(max(0.0, cut_at_master_s - 0.05))
        window = relay.cut(cut_s)
        master.wait(timeout=60)
        slave.wait(timeout=60)
    finally:
        for p in (master, slave):
            if p.poll() is None:
                p.kill()
        relay.stop()
    log = master_out.text() + slave_out.text()
    if master.returncode != 0 or slave.returncode != 0:
        print(log)
        raise Failure(f"exit codes master {master.returncode}, slave {slave.returncode}")
    with open(sjson) as f:
        s = json.load(f)
    rows = read_telemetry(scsv)
    period = 1.0 / s["rate_hz"]
    dropped = relay.dropped["master"] + relay.dropped["slave"]

    # The cut in the slave's telemetry: the longest run of cycles with the same peer sample (the master moves, so a
    # fresh sample differs from the one before) that starts engaged (not the wait for the master at start-up). Its
    # first row is the cycle the last packet arrived.
    best = (0, 0)
    start = 0
    for i in range(1, len(rows) + 1):
        if i == len(rows) or (rows[i]["peer_position_m_0"], rows[i]["peer_velocity_m_per_s_0"]) != \
                (rows[start]["peer_position_m_0"], rows[start]["peer_velocity_m_per_s_0"]):
            if i - start > best[1] - best[0] and rows[start]["engagement"] == ENGAGED:
                best = (start, i)
            start = i
    last_packet, resumed = best
    safe = next((i for i in range(last_packet, len(rows)) if rows[i]["engagement"] != ENGAGED), None)
    aligning = next((i for i in range(last_packet, len(rows)) if rows[i]["engagement"] == ALIGNING), None)
    if safe is None or aligning is None:
        print(log)
        raise Failure(f"cut of {cut_s} s: the slave never left engaged or never aligned again")
    engaged = next((i for i in range(aligning, len(rows)) if rows[i]["engagement"] == ENGAGED), len(rows) - 1)
    safe_after_s = rows[safe]["time_s"] - rows[last_packet]["time_s"]
    stall = max([0.0] + [rows[i + 1]["time_s"] - rows[i]["time_s"] - period for i in range(last_packet, safe)])
    x0 = rows[last_packet]["position_m_0"]
    excursion = max(abs(r["position_m_0"] - x0) for r in rows[last_packet:aligning + 1])
    window_end = min(len(rows) - 1, engaged + int(0.1 / period))
    step = max(abs(rows[i + 1]["position_m_0"] - rows[i]["position_m_0"]) for i in range(aligning - 1, window_end))
    lost = [f for f in s["faults"] if f["kind"] == "peer lost"]
    age = lost[0]["peer_sample_age_s"] if lost else float("nan")
    record = lost[0]["record"] if lost else ""
    return {
        "cut_ms": cut_s * 1e3, "dropped": dropped, "cut_cycles": resumed - last_packet,
        "safe_after_ms": safe_after_s * 1e3, "age_ms": age * 1e3, "stall_ms": stall * 1e3,
        "excursion_mm": excursion * 1e3, "step_mm": step * 1e3,
        "ref_step_mm": s["engagement"]["max_reengagement_step_m"] * 1e3,
        "force_rate": s["engagement"]["max_aligning_force_rate_N_per_s"],
        "aligning_ms": (rows[engaged]["time_s"] - rows[aligning]["time_s"]) * 1e3,
        "record": record, "timeout_ms": timeout_ms(scfg), "period_ms": period * 1e3,
        "faults": s["faults"], "reaction": s["engagement"]["reaction"],
    }


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--master", required=True)
    ap.add_argument("--slave", required=True)
    ap.add_argument("--configs", required=True)
    ap.add_argument("--workdir", required=True)
    ap.add_argument("--cuts-ms", default="100,2000")
    args = ap.parse_args()
    os.makedirs(args.workdir, exist_ok=True)
    results = []
    for cut_ms in [float(c) for c in args.cuts_ms.split(",")]:
        results.append(run_cut(args, cut_ms / 1e3, cut_at_master_s=0.9))
    print("\n| cut (ms) | datagrams dropped | slave safe after (ms) | peer sample age (ms) | stall (ms) | "
          "excursion (mm) | re-engage step (mm) | ref step (mm) | force rate (N/s) | aligning (ms) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in results:
        print(f"| {r['cut_ms']:.0f} | {r['dropped']} | {r['safe_after_ms']:.1f} | {r['age_ms']:.1f} | "
              f"{r['stall_ms']:.1f} | {r['excursion_mm']:.3f} | {r['step_mm']:.4f} | {r['ref_step_mm']:.4f} | "
              f"{r['force_rate']:.1f} | {r['aligning_ms']:.0f} |")
    print()
    failures = []

    def expect(cond, what):
        print(f"  {'ok' if cond else 'FAILED'}: {what}")
        if not cond:
            failures.append(what)
    for r in results:
        limit = r["timeout_ms"] + 2 * r["period_ms"] + r["stall_ms"]
        expect(r["dropped"] > 0, f"cut {r['cut_ms']:.0f} ms: the relay dropped {r['dropped']} datagrams")
        expect(r["timeout_ms"] <= r["age_ms"] <= limit,
               f"cut {r['cut_ms']:.0f} ms: safe state when the newest sample was {r['age_ms']:.1f} ms old "
               f"(timeout {r['timeout_ms']:.0f} ms + 2 cycles + {r['stall_ms']:.1f} ms measured stall)")
        expect(r["safe_after_ms"] <= limit, f"cut {r['cut_ms']:.0f} ms: telemetry agrees ({r['safe_after_ms']:.1f} ms)")
        expect(r["record"] and os.path.exists(r["record"]), f"cut {r['cut_ms']:.0f} ms: fault record {r['record']}")
        expect(r["excursion_mm"] <= 1.0, f"cut {r['cut_ms']:.0f} ms: excursion {r['excursion_mm']:.3f} mm <= 1 mm "
               f"(reaction {r['reaction']})")
        expect(r["step_mm"] <= 0.1, f"cut {r['cut_ms']:.0f} ms: re-engagement step {r['step_mm']:.4f} mm <= 0.1 mm")
        expect(r["ref_step_mm"] <= 0.1, f"cut {r['cut_ms']:.0f} ms: reference step {r['ref_step_mm']:.4f} mm")
    if failures:
        raise Failure("; ".join(failures))


if __name__ == "__main__":
    try:
        main()
    except Failure as e:
        print(f"FAILED: {e}")
        sys.exit(1)
    print("PASSED")
