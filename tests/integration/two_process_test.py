#!/usr/bin/env python3
"""Runs teleop-slave and teleop-master as real processes on 127.0.0.1 and checks their JSON summaries.

Scenarios:
  clean_run  both run; the master stops after its duration and tells the slave, which stops too.
  sigterm    the master is stopped with SIGTERM mid-run: clean summary, exit 0; the slave sees the shutdown.
  dead_peer  the master is killed with SIGKILL: the slave's watchdog trips, it keeps its loop running and exits 0.
  garbage    malformed datagrams are sent to the slave's port during a run: all rejected and counted by reason,
             the loop is not disturbed.
  kv_kf      clean_run with every law term on (tests/integration/configs/*-kv-kf.yaml): K_v damping on both sides,
             and the master's K_f feed-forward of the force the slave measures on a simulated wall.

clean_run and kv_kf also record telemetry and check the physics against predictions made here from the configs
(not from the library): the law's command term by term, the tracking lag on the free-space ramp, and the static
balance in contact (see check_physics).
"""
import argparse
import csv
import json
import os
import random
import re
import signal
import socket
import subprocess
import sys
import time
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "test_utilities"))
import teleop_keys  # noqa: E402  (tests/test_utilities)
# Other tests import these from here.
from teleop_process import Failure, Output, check, free_udp_port, set_ports  # noqa: E402,F401


def write_config(src, dst, ports, telemetry_csv=""):
    text = open(src).read()
    text = set_ports(text, ports)
    # Telemetry only where the physics is checked from it; elsewhere keep the run light.
    text = re.sub(r"(?m)^(\s*csv:).*$", lambda m: f'{m.group(1)} "{telemetry_csv}"', text)
    # Fault records (the last cycles before a fault) next to the config, not in the working directory.
    if not re.search(r"(?m)^safety:", text):
        text += f'\nsafety: {{fault_record_dir: "{os.path.dirname(os.path.abspath(dst))}"}}\n'
    with open(dst, "w") as f:
        f.write(text)
    teleop_keys.ensure_key(os.path.dirname(dst))  # link.security key_file: teleop.key, beside the config


def read_yaml_scalars(path):
    """The scalar keys of a config as dotted paths ("law.kp_N_per_m" -> 600.0), read with the standard library
    (block mappings only, which is all the shipped configs use for the keys read here)."""
    values = {}
    stack = []  # (indent, key)
    for raw in open(path):
        line = raw.split("#", 1)[0].rstrip()
        m = re.match(r"^(\s*)([A-Za-z_][A-Za-z0-9_]*):\s*(.*)$", line)
        if not m:
            continue
        indent, key, value = len(m.group(1)), m.group(2), m.group(3).strip()
        while stack and stack[-1][0] >= indent:
            stack.pop()
        if value == "":
            stack.append((indent, key))
            continue
        dotted = ".".join([k for _, k in stack] + [key])
        if value.startswith("{") and value.endswith("}"):  # a flow mapping of scalars: {axis: 0, offset_m: 0.01}
            for item in value[1:-1].split(","):
                k, v = item.split(":", 1)
                values[f"{dotted}.{k.strip()}"] = scalar(v)
        else:
            values[dotted] = scalar(value)
    return values


def scalar(text):
    text = text.strip()
    try:
        return float(text)
    except ValueError:
        return text.strip('"')


def read_telemetry(path):
    with open(path) as f:
        return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]


def median(xs):
    xs = sorted(xs)
    n = len(xs)
    if n == 0:
        raise Failure("no telemetry samples in the window (test bug or a run far too short)")
    return xs[n // 2] if n % 2 else 0.5 * (xs[n // 2 - 1] + xs[n // 2])


ENGAGED = 3  # node::EngagementState::kEngaged, the telemetry column `engagement`


def rejected_on_clean_link(summary):
    """Rejections other than a handshake race: on a loaded machine the master may send its next hello before the
    welcome to the first arrives (link.security.handshake_retry_ms); that late welcome is then refused
    (bad_handshake_tag, or unexpected_handshake once a session exists) - counted, harmless, and never a sample."""
    by_reason = summary.get("security", {}).get("rejected_by_reason", {})
    race = by_reason.get("bad_handshake_tag", 0) + by_reason.get("unexpected_handshake", 0)
    return summary["packets"]["rejected"] - race


def load(path):
    with open(path) as f:
        return json.load(f)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--master", required=True)
    ap.add_argument("--slave", required=True)
    ap.add_argument("--configs", required=True)
    ap.add_argument("--scenario", required=True, choices=["clean_run", "sigterm", "dead_peer", "garbage", "kv_kf"])
    ap.add_argument("--workdir", required=True)
    args = ap.parse_args()
    os.makedirs(args.workdir, exist_ok=True)
    ports = (free_udp_port(), free_udp_port())
    mcfg = os.path.join(args.workdir, "master.yaml")
    scfg = os.path.join(args.workdir, "slave.yaml")
    physics = args.scenario in ("clean_run", "kv_kf")
    suffix = "-kv-kf" if args.scenario == "kv_kf" else ""
    msrc = os.path.join(args.configs, f"master{suffix}.yaml")
    ssrc = os.path.join(args.configs, f"slave{suffix}.yaml")
    mcsv = os.path.join(args.workdir, "master.csv") if physics else ""
    scsv = os.path.join(args.workdir, "slave.csv") if physics else ""
    write_config(msrc, mcfg, ports, mcsv)
    write_config(ssrc, scfg, ports, scsv)
    mjson = os.path.join(args.workdir, "master.json")
    sjson = os.path.join(args.workdir, "slave.json")
    for p in (mjson, sjson, mcsv, scsv):
        if p and os.path.exists(p):
            os.remove(p)

    # 3.5 s of wall-clock time: even at 90 % of the rate on a loaded machine the master's simulated time (one
    # period per cycle) passes 3.1 s, so the whole 2.0-3.0 s hold of its script is in the record.
    master_duration = 3.5
    slave_duration = 6.0 if args.scenario == "dead_peer" else 8.0
    slave = subprocess.Popen([args.slave, "--config", scfg, "--duration", str(slave_duration),
                              "--summary-json", sjson], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    slave_out = Output(slave)
    time.sleep(0.3)
    master = subprocess.Popen([args.master, "--config", mcfg, "--duration",
                               str(0 if args.scenario in ("sigterm", "dead_peer") else master_duration),
                               "--summary-json", mjson], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    master_out = Output(master)
    garbage_sent = 0
    # Act only once both loops run and are coupled (not on a fixed delay: start-up takes longer in sanitizer builds).
    coupled = master_out.wait_for("peer connected", 120) and slave_out.wait_for("peer connected", 10)
    if not coupled:
        master.kill()
        slave.kill()
        print(master_out.text(), slave_out.text())
        raise Failure("the two processes never coupled")
    if args.scenario in ("sigterm", "dead_peer"):
        time.sleep(1.0)
        master.send_signal(signal.SIGTERM if args.scenario == "sigterm" else signal.SIGKILL)
    elif args.scenario == "garbage":
        rng = random.Random(7)
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            # The slave's socket is connect()ed to the master's address and port, so the kernel drops garbage from
            # another port before it reaches the link (docs/security.md): none of it may be counted or applied.
            for i in range(200):
                n = rng.randint(0, 120)
                s.sendto(bytes(rng.getrandbits(8) for _ in range(n)), ("127.0.0.1", ports[1]))
                garbage_sent += 1
                time.sleep(0.002)
    try:
        master.wait(timeout=60)
        slave.wait(timeout=60)
    except subprocess.TimeoutExpired:
        master.kill()
        slave.kill()
        raise Failure("processes did not stop")
    print("---- master output ----\n" + master_out.text())
    print("---- slave output ----\n" + slave_out.text())

    check(slave.returncode == 0, f"slave exits 0 (got {slave.returncode})")
    s = load(sjson)
    rate = s["rate_hz"]
    # No assertion on the achieved rate: these machines are shared and noisy (the rate is printed above).
    check(s["cycles"] > 100, f"slave ran {s['cycles']} cycles ({s['achieved_rate_hz']:.1f} Hz of {rate:.0f})")
    # An authenticated link sends nothing before its session exists (counted as send_no_session, not an error).
    unsent = s.get("security", {}).get("send_no_session", 0)
    check(s["packets"]["sent"] + unsent >= s["cycles"], f"slave sent one sample per cycle ({unsent} before the "
                                                         "session)")

    if args.scenario == "dead_peer":
        check(master.returncode == -signal.SIGKILL, "master was killed")
        check(s["watchdog_trips"] >= 1, f"slave watchdog tripped ({s['watchdog_trips']})")
        check(s["stop_reason"] == "duration", f"slave ran to its duration ({s['stop_reason']})")
        check(s["cycles_with_peer"] < s["cycles"], "slave decoupled after the master died and kept its loop")
        check(s["stop_reason"] == "duration" and s["device_fault_cycles"] == 0, "slave stayed in a safe state")
        lost = [f for f in s["faults"] if f["kind"] == "peer lost"]
        check(len(lost) >= 1 and lost[0]["reaction"] == s["engagement"]["reaction"] == "hold",
              f"the summary names the fault and the reaction ({lost[:1]})")
        check(lost[0]["record"].endswith(".csv") and os.path.exists(lost[0]["record"]),
              f"the fault record was written ({lost[0]['record']})")
        check(s["engagement"]["final_state"] == "handshaking", "the slave waits for a master, reaction latched")
        return
    check(master.returncode == 0, f"master exits 0 (got {master.returncode})")
    m = load(mjson)
    check(s["stop_reason"] == "peer shutdown", f"slave stopped on the master's shutdown ({s['stop_reason']})")
    expected_master = "signal" if args.scenario == "sigterm" else "duration"
    check(m["stop_reason"] == expected_master, f"master stop reason {m['stop_reason']}")
    check(m["cycles"] > 100, f"master ran {m['cycles']} cycles ({m['achieved_rate_hz']:.1f} Hz)")
    for name, x, peer in (("master", m, s), ("slave", s, m)):
        pk = x["packets"]
        check(pk["received"] > 0 and pk["accepted"] > 0, f"{name} received {pk['received']} samples")
        in_order = pk["accepted"] + pk["superseded"]
        check(in_order >= 0.99 * (pk["received"] - pk["rejected"]),
              f"{name}: {in_order} of {pk['received'] - pk['rejected']} valid samples arrived in order")
        check(pk["lost"] <= 0.01 * pk["accepted"] + 2, f"{name} lost {pk['lost']} (loopback: ~none)")
        check(x["rtt_ms"]["count"] >= 0.9 * x["packets"]["accepted"], f"{name} measured {x['rtt_ms']['count']} RTTs")
        check(0 < x["rtt_ms"]["p50"] < 1000, f"{name} RTT p50 {x['rtt_ms']['p50']:.3f} ms is a plausible value")
        check(x["tracking_error_rms_m"] < 0.005, f"{name} tracking error rms {x['tracking_error_rms_m']*1e3:.3f} mm")
        check(x["nonfinite_inputs"] == 0 and x["device_fault_cycles"] == 0, f"{name} had no faults")
        check(x["engagement"]["times_engaged"] >= 1, f"{name} engaged {x['engagement']['times_engaged']} time(s)")
    if physics:
        check(rejected_on_clean_link(m) == 0 and rejected_on_clean_link(s) == 0, "nothing rejected on a clean link")
        check(m["cycles_with_peer"] > 0.5 * m["cycles"], "master coupled for most of the run")
        check_physics(read_yaml_scalars(msrc), read_yaml_scalars(ssrc), m, s, read_telemetry(mcsv),
                      read_telemetry(scsv))
    if args.scenario == "clean_run":
        check_session(args.workdir, mjson, sjson, m, s)
    if args.scenario == "garbage":
        rej = rejected_on_clean_link(s)
        check(garbage_sent == 200 and rej == 0,
              f"none of the {garbage_sent} garbage datagrams from another port reached the slave ({rej} rejected)")
        check(rejected_on_clean_link(m) == 0, "master saw no garbage")
        # Not "no watchdog trip": a loaded machine can stall a process for longer than the timeout. What garbage
        # must never do is reach the law: no fault, no non-finite input, no loss of the real samples.
        check(s["packets"]["lost"] == 0 and s["packets"]["accepted"] > 0, "real samples kept flowing")


def check_session(workdir, mjson, sjson, m, s):
    """One record of the session (deploy/teleop-session): both telemetries on the master's clock. Both processes
    share this host's CLOCK_MONOTONIC, so the true offset is 0 and must lie within the stated uncertainty; the slave
    started 0.3 s or more before the master, so its rows start before the master's on that axis; and the master's
    position reaches the slave's peer_position within a few cycles on the merged axis (it was 0.3 s and more off
    when each side was plotted on its own clock)."""
    tool = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "deploy", "teleop-session")
    out = os.path.join(workdir, "session.csv")
    r = subprocess.run([tool, mjson, sjson, "-o", out], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    print(r.stdout)
    check(r.returncode == 0, "teleop-session merged the two summaries and telemetries")
    with open(out) as f:
        check(f.readline().strip() == "# teleop-session 1", "the session file says what it is")
        meta = json.loads(f.readline()[1:])
        rows = list(csv.DictReader(f))
    for side, x in (("master", m), ("slave", s)):
        check(meta[side]["config_yaml"].startswith("# ") and f"role: {side}" in meta[side]["config_yaml"],
              f"the {side}'s config text is in the record")
        check("stability check passed" in meta[side]["startup_analysis"], f"the {side}'s start-up analysis too")
        check(meta["software_version"][side] == x["software_version"] != "", f"and its software version")
    clock = meta["clock"]
    check(abs(clock["slave_minus_master_ns"]) <= clock["uncertainty_ns"] + 20e3,
          f"offset {clock['slave_minus_master_ns'] / 1e3:.1f} us within its uncertainty "
          f"{clock['uncertainty_ns'] / 1e3:.1f} us (+20 us) of the true 0 (one host, one clock)")
    master = [(float(r["time_s"]), float(r["position_m_0"])) for r in rows if r["side"] == "master"]
    slave = [(float(r["time_s"]), float(r["peer_position_m_0"])) for r in rows if r["side"] == "slave"]
    check(len(master) == m["telemetry_records"] and len(slave) == s["telemetry_records"], "every row of both sides")
    check(slave[0][0] < master[0][0] - 0.2, f"the slave's first row ({slave[0][0]:.3f} s) before the master's "
                                            f"({master[0][0]:.3f} s): it started first")

    def at(series, t):  # the newest value at or before t (series sorted by time)
        lo, hi = 0, len(series) - 1
        if t < series[0][0]:
            return None
        while lo < hi:
            mid = (lo + hi + 1) // 2
            lo, hi = (mid, hi) if series[mid][0] <= t else (lo, mid - 1)
        return series[lo][1]
    moving = [p for p in master[::10] if p[0] > 0.2]

    def mismatch(lag):
        d = [abs(at(slave, t + lag) - x) for t, x in moving if at(slave, t + lag) is not None]
        return sum(d) / len(d) if d else float("inf")
    lags = [i * 0.002 for i in range(-150, 151)]
    best = min(lags, key=mismatch)
    check(-0.002 <= best <= 0.02, f"the slave receives the master's position {best * 1e3:.0f} ms later on the merged "
                                  f"axis (0..20 ms: transport and a cycle or two)")
    plot = os.path.join(os.path.dirname(tool), "teleop-plot")
    r = subprocess.run([plot, out, "--out", workdir], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    print(r.stdout)
    pngs = [os.path.join(workdir, f"session-{v}.png") for v in ("positions", "forces")]
    check(r.returncode == 0 and all(os.path.getsize(p) > 5000 for p in pngs if os.path.exists(p)) and
          all(os.path.exists(p) for p in pngs), "teleop-plot draws both sides of the session on one time axis")


def check_physics(mc, sc, m, s, mt, st):
    """The physics of a run, predicted from the two configs with the equations written out here.

    mc/sc: the master's and slave's config scalars; m/s: their summaries; mt/st: their telemetry records.
    Every check runs (a failure is reported, not raised, until the end), so one run shows each one that a broken
    law trips."""
    failures = []

    def expect(cond, what):
        print(f"  {'ok' if cond else 'FAILED'}: {what}")
        if not cond:
            failures.append(what)
    period = 1.0 / mc["rate_hz"]
    kp, kd = mc["law.kp_N_per_m"], mc["law.kd_Ns_per_m"]
    expect(kp == sc["law.kp_N_per_m"] and kd == sc["law.kd_Ns_per_m"], "symmetric K_p, K_d (the predictions need it)")
    kvm, kfm = mc["law.kv_Ns_per_m"], mc["law.kf"]
    kvs = sc["law.kv_Ns_per_m"]
    b_s = sc["device.loopback.damping_Ns_per_m"]
    k_h = mc["device.loopback.operator.stiffness_N_per_m"]
    k_vf = sc.get("fixture.stiffness_N_per_m", 0.0)
    fixture_at = sc.get("fixture.half_space.offset_m", 0.0)
    wall = sc["device.loopback.environment.type"] == "wall"
    k_w = sc["device.loopback.environment.stiffness_N_per_m"] if wall else 0.0
    wall_at = sc["device.loopback.environment.position_m"] if wall else 0.0
    contact_at = fixture_at if k_vf > 0 else wall_at
    expect(k_vf == 0 or not wall or fixture_at == wall_at, "fixture and wall at the same place (test assumption)")
    f_hold = 3.0  # N: the scripts' hold level from 2.0 to 3.0 s (master*.yaml, device.loopback.operator.script)

    # 1. The command, term by term (eqs. 8-9 as the header of three_channel_law.hpp writes them), on every cycle the
    #    law ran coupled and unsaturated (law_status 0). The fixture force is recomputed from the position (eq. 7),
    #    not taken from the record. Tolerance: 1e-9 N, rounding only (the CSV holds shortest round-trip doubles).
    def expected_command(r, kv, kf, k_fixture, at):
        fixture = -k_fixture * max(0.0, r["position_m_0"] - at)
        return (-kp * (r["position_m_0"] - r["peer_position_m_0"]) - kd * (r["velocity_m_per_s_0"] -
                r["peer_velocity_m_per_s_0"]) - kv * r["velocity_m_per_s_0"] - kf * r["peer_force_N_0"] + fixture)

    for name, rows, kv, kf, k_fixture, at in (("master", mt, kvm, kfm, 0.0, 0.0),
                                              ("slave", st, kvs, 0.0, k_vf, fixture_at)):
        # Engaged (telemetry column `engagement` 3): aligning cycles run the law against a moving reference with a
        # rate-limited coupling force, and the safe-state reaction against a virtual peer; neither is eq. 8/9.
        coupled = [r for r in rows if r["law_status"] == 0 and r["engagement"] == ENGAGED]
        expect(len(coupled) > 0.5 * len(rows), f"{name}: {len(coupled)} of {len(rows)} records coupled and unsaturated")
        worst = max(abs(r["command_N_0"] - expected_command(r, kv, kf, k_fixture, at)) for r in coupled)
        expect(worst < 1e-9, f"{name}: command = eq. {8 if name == 'master' else 9} on every coupled cycle "
              f"(worst difference {worst:.2e} N)")

    # 2. Free-space ramp (master script time 0.7-1.3 s: F_h* rises 2 N/s, the handle follows at
    #    v = 2 N/s / k_h = 10 mm/s). With no acceleration, eq. 9 balances the slave's own damping:
    #    K_p (x_m,received - x_s) + K_d (v_m,received - v_s) = (b_s + K_vs) v_s, so the slave's tracking error,
    #    corrected by the K_d term, is (b_s + K_vs) v_s / K_p whatever the delay. The K_d term is zero when both
    #    loops keep real time; it is not when one of them stalls on a starved host: each plant integrates its own
    #    nominal period, so a master that lost 7 % of its cycles over the ramp reports 10 mm/s in its time while the
    #    slave follows it at 9.3 mm/s in its own, and K_d = 4 b_s turns that into a 25 % shorter lag (a CI run
    #    measured 0.609 ms against 0.817 before the correction).
    #    The master sees the slave's position late: its error is the slave's actual position lag plus v × D, where
    #    D is the sum of the two sides' data ages. When the transport is faster than the phase between the two loops,
    #    D = one period (the one-sample-delay prediction velocity × period); when the loops run nearly in phase, one
    #    side waits a further period, D = 2 periods.
    #    Every estimate is a ratio of sums over the ramp, not a median of per-cycle ratios: near in phase, jitter
    #    makes some slave cycles see no new master sample (the error used is v·T smaller) and the next one two; the
    #    force balance holds on average, while the median of that two-valued mix lands anywhere between the values.
    lag_s = (b_s + kvs) / kp  # s: tracking error per unit velocity of the slave
    slave_ramp = [r for r in st if r["law_status"] == 0 and r["engagement"] == ENGAGED
                  and contact_at * 0.2 < r["position_m_0"] < contact_at * 0.8 and r["velocity_m_per_s_0"] > 2e-3]
    v_sum = sum(r["velocity_m_per_s_0"] for r in slave_ramp)
    position_lag = sum(r["peer_position_m_0"] - r["position_m_0"] for r in slave_ramp) / v_sum
    velocity_gap = sum(r["peer_velocity_m_per_s_0"] - r["velocity_m_per_s_0"] for r in slave_ramp) / v_sum
    lag = position_lag + kd / kp * velocity_gap
    # ±20 %: the estimate over the ramp, which the velocity filter and the loops' jitter disturb by a few per cent
    # (measured: within 5 %); a halved K_p or a lost K_vs changes it by 50 % or more.
    expect(abs(lag / lag_s - 1) < 0.2, f"slave lag on the ramp {lag*1e3:.3f} ms of velocity, predicted "
          f"(b_s + K_vs)/K_p = {lag_s*1e3:.3f} ms ({len(slave_ramp)} samples; position lag {position_lag*1e3:.3f} ms, "
          f"peer velocity {100 * velocity_gap:+.1f} % of the slave's)")
    master_ramp = [r for r in mt if r["law_status"] == 0 and r["engagement"] == ENGAGED
                   and contact_at * 0.2 < r["position_m_0"] < contact_at * 0.8 and r["velocity_m_per_s_0"] > 2e-3]
    delay = (sum(r["position_m_0"] - r["peer_position_m_0"] for r in master_ramp) /
             sum(r["velocity_m_per_s_0"] for r in master_ramp)) - position_lag
    # 0.8..2.2 periods: D is one or two periods (above), ±20 % for the same estimate noise as the slave's.
    expect(0.8 * period < delay < 2.2 * period, f"master sees the slave {delay/period:.2f} samples late on the ramp "
          f"(one-sample-delay prediction: 1..2 periods; error = slave's position lag + v·D)")

    # 3. Static balance in contact, during the hold (F_h* = 3 N). Positions from the contact point, p = x_s - x_c:
    #    slave (eq. 9):  K_p (x_m - x_s) = (K_VF + k_w) p
    #    master (eq. 8): F_h* - k_h x_m = K_p (x_m - x_s) + K_f k_w p      (the finger's spring, eq. 2, about 0)
    #    => p = (F_h* - k_h x_c) / (k_h (1 + K_s / K_p) + K_s + K_f k_w), K_s = K_VF + k_w.
    k_s = k_vf + k_w
    p_static = (f_hold - k_h * contact_at) / (k_h * (1 + k_s / kp) + k_s + kfm * k_w)
    e_static = k_s * p_static / kp
    print(f"  static balance: penetration {p_static*1e3:.4f} mm, tracking error {e_static*1e3:.4f} mm, "
          f"environment force {k_w*p_static:.4f} N")
    # The last 0.65 s of the hold (from 2.3 s): the contact mode settles with time constant 2 m_s / b_s ≈ 0.15 s,
    # so 0.3 s after the ramp ends the transient (measured: < 2 % of p at the ramp's end) is below 0.1 %.
    hold = [r for r in mt if r["law_status"] == 0 and r["engagement"] == ENGAGED and 2.3 <= r["cycle"] * period <= 2.95]
    expect(len(hold) > 300, f"master recorded {len(hold)} cycles of the settled hold")
    p_hold = median([r["peer_position_m_0"] - contact_at for r in hold])
    e_hold = median([r["position_m_0"] - r["peer_position_m_0"] for r in hold])
    # 2 %: settled (above) and still (v ≈ 0, so the one-sample delay adds nothing); the planted bugs move p by
    # 19 % (K_p halved) to 87 % (fixture force halved).
    expect(abs(p_hold / p_static - 1) < 0.02, f"held penetration {p_hold*1e3:.4f} mm, static balance "
          f"{p_static*1e3:.4f} mm")
    expect(abs(e_hold / e_static - 1) < 0.02, f"held tracking error {e_hold*1e3:.4f} mm, static balance "
          f"{e_static*1e3:.4f} mm")
    if k_w > 0:
        f_e = median([r["peer_force_N_0"] for r in hold])
        expect(abs(f_e / (k_w * p_static) - 1) < 0.02, f"the master receives the slave's F_e {f_e:.4f} N "
              f"(k_w p = {k_w*p_static:.4f} N)")
    # The summaries: the maximum is the settled hold plus the overshoot when the ramp stops (measured +1.8 %) and
    # what a late sample adds while the contact still moves (≤ 3 mm/s × a 25 ms stall ≈ 6 % of e); below, at most
    # the 2 % settling tolerance. K_d deleted rings the contact mode: 3.4 mm instead of 0.35 mm.
    # A process that the machine deschedules for longer (a loaded CI host: 90 ms seen) sends nothing meanwhile, so
    # the other side's error grows by the speed at that moment times the stall. That allowance is measured from
    # the telemetry (gaps between consecutive records beyond 1.5 periods), not assumed.
    stall_allowance = 0.0
    for rows in (mt, st):
        for a, b in zip(rows, rows[1:]):
            gap = b["time_s"] - a["time_s"]
            if gap > 1.5 * period:
                speed = max(abs(a["velocity_m_per_s_0"]), abs(b["velocity_m_per_s_0"]),
                            abs(a["peer_velocity_m_per_s_0"]), abs(b["peer_velocity_m_per_s_0"]))
                stall_allowance = max(stall_allowance, speed * gap)
    for name, x in (("master", m), ("slave", s)):
        e_max = x["tracking_error_max_m"]
        expect(0.98 * e_static < e_max < 1.10 * e_static + stall_allowance,
               f"{name} max tracking error {e_max*1e3:.4f} mm, static balance {e_static*1e3:.4f} mm "
               f"(-2 %, +10 % + {stall_allowance*1e3:.4f} mm for the worst measured stall)")
    pen = s["fixture_max_penetration_m"]
    if k_vf > 0:
        expect(0.98 * p_static < pen < 1.10 * p_static, f"slave fixture max penetration {pen*1e3:.4f} mm, static "
              f"balance {p_static*1e3:.4f} mm (-2 %, +10 %)")
    else:
        expect(pen == 0, "no fixture, no fixture penetration")
    if failures:
        raise Failure(f"{len(failures)} physics check(s) failed: " + "; ".join(failures))


if __name__ == "__main__":
    try:
        main()
    except Failure as e:
        print(f"FAILED: {e}")
        sys.exit(1)
    print("PASSED")
