#!/usr/bin/env python3
"""Both real processes and the loopback plant over an emulated bad network (`link.emulate`, docs/link-emulation.md).

Each scenario runs teleop-slave and teleop-master (2.5 s of master time, the shipped demo configs) with the same
impairments in both processes' configs: each process impairs what it receives, so both directions are impaired.
The scenarios run a few at a time in parallel. For every scenario the test checks:
  - no crash: both exit 0, the master stops at its duration, the slave on the master's shutdown;
  - no torn sample: every peer sample a process used (its telemetry's peer_* columns) is, field for field, one
    sample the peer sent (the peer's own telemetry of that cycle: position, velocity, force sensor);
  - the counters: the loop's link counters balance (received == accepted + superseded + reordered + duplicates +
    rejected + handshake messages); the emulation's counters balance and were fed exactly what the wrapped link accepted; each
    configured probability is met within 4.5 binomial standard deviations of the number of samples offered (the
    streams are seeded, so a run cannot flake on it); what the loop counts as lost, rejected, duplicated and
    reordered is what the emulation did, give or take the samples still in flight at the end;
  - delay: the round trip is at least both configured delays (a lower bound only: the tests never assert wall time);
  - an outage trips the master's watchdog.
It prints a table (scenario, loss measured in each direction, round trip p50, the slave's tracking error rms/max,
fixture penetration, saturated cycles, watchdog trips): docs/link-emulation.md shows it with this command.

  tests/integration/link_emulation_test.py --master build/bin/teleop-master --slave build/bin/teleop-slave \\
      --canbus build/bin/teleop-canbus --configs deploy/configs --workdir /tmp/link-emulation [--only NAME]
"""
import argparse
import concurrent.futures
import math
import os
import re
import signal
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import two_process_test as tp  # noqa: E402  (the two-process helpers: configs, ports, output, telemetry)

MASTER_DURATION_S = 2.5
# At 100 ms the plain law's oscillation grows slowly: a longer run shows where it goes.
LONGER_S = {"delay 100 ms": 4.5, "WAN 100 ms, loss 5%": 4.5, "WAN 100 ms, loss 5%, passivity": 4.5}

# name, link.emulate as a YAML flow mapping (None: no emulation), transport ("udp" or "can" = the teleop-canbus bus).
SCENARIOS = [
    ("clean", None, "udp"),
    ("loss 1%", "{loss_probability: 0.01}", "udp"),
    ("loss 5%", "{loss_probability: 0.05}", "udp"),
    ("loss 20%", "{loss_probability: 0.20}", "udp"),
    ("bursts", "{burst: {enter_probability: 0.01, exit_probability: 0.2}}", "udp"),
    ("delay 5 ms", "{delay_ms: 5, jitter_ms: 1}", "udp"),
    ("delay 20 ms", "{delay_ms: 20, jitter_ms: 5}", "udp"),
    ("delay 100 ms", "{delay_ms: 100, jitter_ms: 10}", "udp"),
    ("reorder 10%", "{delay_ms: 3, reorder_probability: 0.1}", "udp"),
    ("duplicate 10%", "{duplicate_probability: 0.1}", "udp"),
    ("corrupt 5%", "{corrupt_probability: 0.05}", "udp"),
    ("outage 200 ms", "{outages: [[1.2, 0.2]]}", "udp"),
    ("can: loss 5%, delay 5 ms", "{loss_probability: 0.05, delay_ms: 5, jitter_ms: 1}", "can"),
    ("delay 20 ms, passivity", "{delay_ms: 20, jitter_ms: 5}", "udp"),
    ("loss 5%, passivity", "{loss_probability: 0.05}", "udp"),
    # Across sites (issue 32.4): 50 and 100 ms with jitter and 5 % loss, the plain law and with passivity on.
    ("WAN 50 ms, loss 5%", "{delay_ms: 50, jitter_ms: 5, loss_probability: 0.05}", "udp"),
    ("WAN 100 ms, loss 5%", "{delay_ms: 100, jitter_ms: 10, loss_probability: 0.05}", "udp"),
    ("WAN 50 ms, loss 5%, passivity", "{delay_ms: 50, jitter_ms: 5, loss_probability: 0.05}", "udp"),
    ("WAN 100 ms, loss 5%, passivity", "{delay_ms: 100, jitter_ms: 10, loss_probability: 0.05}", "udp"),
]
# Scenarios run with time-domain passivity on both sides (docs/stability.md): the energy exchange over the link.
PASSIVITY = "passivity: {mode: energy_exchange, max_damping_Ns_per_m: 100}\n"


def slug(name):
    return re.sub(r"[^a-z0-9]+", "_", name.lower()).strip("_")


def flow_value(flow, key):
    """A number from the scenario's flow mapping ("{delay_ms: 5, ...}" -> 5.0), 0 when absent."""
    m = re.search(r"\b" + key + r":\s*([0-9.eE+-]+)", flow or "")
    return float(m.group(1)) if m else 0.0


def add_emulation(path, flow, seed):
    """Inserts `emulate: FLOW` (with its seed) as the first key of the config's link: section."""
    text = open(path).read()
    body = flow.strip()[1:-1]
    # The start-up check would assume the emulated delay (link.expected_delay_ms absent) and refuse the shipped gains
    # beyond a few ms (docs/stability.md, "Delay"); these scenarios show what the plain law does over the delay.
    line = f"  emulate: {{seed: {seed}, {body}}}\n  expected_delay_ms: 0\n"
    text, n = re.subn(r"(?m)^link:\n", "link:\n" + line, text, count=1)
    if n != 1:
        raise tp.Failure(f"test bug: no 'link:' section in {path}")
    if 2 * flow_value(flow, "delay_ms") >= 50.0 and "\nengagement:" not in text:
        # The latency gate (engagement.max_rtt_ms, 100 ms by default) would keep a pair with a round trip this long
        # from ever coupling; these scenarios are about what the plain law does over the delay, so it is off here.
        text += "\nengagement: {max_rtt_ms: 0}\n"
    open(path, "w").write(text)


def wrapped_counters(link_detail):
    """The wrapped link's own counters from the summary's link_detail ("wrapped link: received N, ...")."""
    m = re.search(r"wrapped link: received (\d+), accepted (\d+), lost (\d+), superseded (\d+), rejected (\d+)",
                  link_detail)
    if not m:
        raise tp.Failure(f"no wrapped-link counters in link_detail '{link_detail}'")
    return dict(zip(("received", "accepted", "lost", "superseded", "rejected"), map(int, m.groups())))


# CAN carries position, velocity and force as 14/11/12-bit codes of 20 µm, 2 mm/s, 10 mN, saturated (docs/can.md).
CAN_FIELDS = ((20e-6, 14), (2e-3, 11), (10e-3, 12))


# node::EngagementState: waiting for a session's first sample (or the peer after an outage).
HANDSHAKING = 1


def can_code(value, lsb, bits):
    limit = 2 ** (bits - 1) - 1
    return max(-limit, min(limit, math.floor(value / lsb + 0.5)))


def torn_samples(sender_rows, receiver_rows, dof, can=False):
    """Receiver rows whose peer sample is not, field for field, one sample the sender recorded sending (UDP: the
    exact doubles; CAN: the codes the sender's values round to)."""
    def fields(r, keys):
        values = [r[f"{k}_{i}"] for k in keys for i in range(dof)]
        if can:
            values = [can_code(v, *CAN_FIELDS[j // dof]) for j, v in enumerate(values)]
        return tuple(values)

    def sent(r):
        # A sender in its safe state after a fault (flag bit 1, kFlagFault) sends zeros with the flag, not its
        # readings (teleop_node.cpp, Transmit).
        if int(r.get("flags", 0)) & 0x2:
            return tuple(0 if can else 0.0 for _ in range(3 * dof))
        return fields(r, ("position_m", "velocity_m_per_s", "force_sensor_N"))

    def used(r):
        return fields(r, ("peer_position_m", "peer_velocity_m_per_s", "peer_force_N"))
    sent_set = {sent(r) for r in sender_rows}
    zero = tuple(0 if can else 0.0 for _ in range(3 * dof))
    bad = []
    for r in receiver_rows:
        u = used(r)
        if u == zero and int(r.get("engagement", HANDSHAKING)) == HANDSHAKING:
            continue  # no peer sample held: before a session's first sample (the telemetry records zeros)
        if u not in sent_set:
            bad.append(r)
    return bad, sum(1 for r in receiver_rows if used(r) != zero)


def self_check():
    """The torn-sample check can fail: a sample mixing two sent samples' fields is found, over UDP and CAN."""
    def rec(x, v, f, px, pv, pf):
        return {"position_m_0": x, "velocity_m_per_s_0": v, "force_sensor_N_0": f,
                "peer_position_m_0": px, "peer_velocity_m_per_s_0": pv, "peer_force_N_0": pf}
    sent = [rec(0.001, 0.01, 1.0, 0, 0, 0), rec(0.002, 0.02, 2.0, 0, 0, 0)]
    whole = rec(0, 0, 0, 0.002, 0.02, 2.0)
    torn = rec(0, 0, 0, 0.002, 0.02, 1.0)  # force from the first sample, the rest from the second
    for can in (False, True):
        bad, used = torn_samples(sent, [rec(0, 0, 0, 0, 0, 0), whole, torn], 1, can)
        if bad != [torn] or used != 2:
            raise tp.Failure(f"test bug: the torn-sample check missed a torn sample (can={can})")
    # A zero peer sample is "none held" only while handshaking; engaged, it is a sample nobody sent.
    engaged_zero = dict(rec(0, 0, 0, 0, 0, 0), engagement=3)
    if torn_samples(sent, [whole, engaged_zero], 1)[0] != [engaged_zero]:
        raise tp.Failure("test bug: an engaged cycle's zero peer sample was not found")
    # Ports: a kernel-chosen port equal to a template port must not be replaced again (bind == peer).
    if tp.set_ports('bind: "h:47001"\npeer: "h:47002"', (47002, 50000)) != 'bind: "h:47002"\npeer: "h:50000"':
        raise tp.Failure("test bug: set_ports replaced a replaced port")
    # Over CAN the codes compare: 0.002005 m rounds to the same 20 µm code as 0.002 m, 0.00203 m does not.
    if torn_samples(sent, [rec(0, 0, 0, 0.002005, 0.02, 2.0)], 1, True)[0] or \
            not torn_samples(sent, [rec(0, 0, 0, 0.00203, 0.02, 2.0)], 1, True)[0]:
        raise tp.Failure("test bug: CAN codes compared wrongly")


def run_scenario(args, name, flow, transport, log):
    work = os.path.join(args.workdir, slug(name))
    os.makedirs(work, exist_ok=True)
    ports = (tp.free_udp_port(), tp.free_udp_port())
    suffix = "-can" if transport == "can" else ""
    paths = {k: os.path.join(work, k) for k in ("master.yaml", "slave.yaml", "master.json", "slave.json",
                                                 "master.csv", "slave.csv")}
    for p in paths.values():
        if os.path.exists(p):
            os.remove(p)
    bus = None
    for role, seed in (("master", 2), ("slave", 1)):
        tp.write_config(os.path.join(args.configs, f"{role}{suffix}.yaml"), paths[f"{role}.yaml"], ports,
                        paths[f"{role}.csv"])
        if transport == "can":
            text = open(paths[f"{role}.yaml"]).read().replace("47300", str(ports[0]))
            open(paths[f"{role}.yaml"], "w").write(text)
        if flow:
            add_emulation(paths[f"{role}.yaml"], flow, seed)
        if name.endswith("passivity"):
            with open(paths[f"{role}.yaml"], "a") as f:
                f.write("\n" + PASSIVITY)
    procs = []
    try:
        if transport == "can":
            bus = subprocess.Popen([args.canbus, "--port", str(ports[0]), "--bitrate", "1000000", "--duration-s",
                                    "60"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
            procs.append(bus)
            time.sleep(0.2)
        slave = subprocess.Popen([args.slave, "--config", paths["slave.yaml"], "--duration", "60", "--summary-json",
                                  paths["slave.json"]], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        procs.append(slave)
        slave_out = tp.Output(slave)
        slave_out.wait_for("teleop-slave:", 60)  # its loop is about to start: the master's first samples land
        master = subprocess.Popen([args.master, "--config", paths["master.yaml"], "--duration",
                                   str(LONGER_S.get(name, MASTER_DURATION_S)), "--summary-json", paths["master.json"]],
                                  stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        procs.append(master)
        master_out = tp.Output(master)
        try:
            master.wait(timeout=90)
            try:
                slave.wait(timeout=2)
            except subprocess.TimeoutExpired:
                # Every sample carrying the master's shutdown flag was lost (it sends two): stop the slave.
                slave.send_signal(signal.SIGTERM)
                slave.wait(timeout=30)
        except subprocess.TimeoutExpired:
            raise tp.Failure("processes did not stop")
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
                p.wait()
    out = f"---- {name}: master output ----\n{master_out.text()}---- {name}: slave output ----\n{slave_out.text()}"
    log.append(out)
    checks = []

    def check(cond, what):
        checks.append(("ok" if cond else "FAILED", what))
        return cond

    check(master.returncode == 0 and slave.returncode == 0,
          f"both exit 0 (master {master.returncode}, slave {slave.returncode})")
    if not (os.path.exists(paths["master.json"]) and os.path.exists(paths["slave.json"])):
        check(False, "both wrote their summaries")
        return {"name": name, "checks": checks}
    m, s = tp.load(paths["master.json"]), tp.load(paths["slave.json"])
    check(m["stop_reason"] == "duration", f"master stopped at its duration ({m['stop_reason']})")
    check(s["stop_reason"] == "peer shutdown" or (s["stop_reason"] == "signal" and s["watchdog_trips"] >= 1),
          f"the slave stopped on the master's shutdown, or its watchdog tripped when the master went silent "
          f"(every shutdown sample lost) and the test stopped it ({s['stop_reason']})")
    check(m["nonfinite_inputs"] == 0 and s["nonfinite_inputs"] == 0 and m["device_fault_cycles"] == 0 and
          s["device_fault_cycles"] == 0, "no non-finite input, no device fault")
    mt, st = tp.read_telemetry(paths["master.csv"]), tp.read_telemetry(paths["slave.csv"])
    check(m["telemetry_dropped"] == 0 and s["telemetry_dropped"] == 0, "every cycle in the telemetry")
    row = {"name": name, "checks": checks, "m": m, "s": s, "slave_stop": s["stop_reason"]}
    for sender, receiver, srows, rrows in (("master", "slave", mt, st), ("slave", "master", st, mt)):
        bad, used = torn_samples(srows, rrows, 1, can=transport == "can")
        check(not bad and used > 0.5 * len(rrows),
              f"{receiver}: all {used} peer samples used are samples the {sender} sent ({len(bad)} torn)")
    for side, x in (("master", m), ("slave", s)):
        pk = x["packets"]
        # Handshake datagrams of the authenticated session (link.security psk) are the one other outcome.
        hs = x.get("security", {}).get("handshake_messages", 0)
        check(pk["received"] == pk["accepted"] + pk["superseded"] + pk["reordered"] + pk["duplicates"] +
              pk["rejected"] + hs, f"{side}: link counters balance ({pk['received']} received, {hs} handshake)")
        row[f"gaps_{side}"] = pk["lost"] / max(1, pk["lost"] + pk["accepted"] + pk["superseded"])
        e = x["link_emulation"]
        if flow is None:
            check(e is None, f"{side}: no emulation, link_emulation null")
            continue
        if not check(e is not None, f"{side}: link_emulation in the summary"):
            continue
        inner = wrapped_counters(x["link_detail"])
        dropped = e["dropped_loss"] + e["dropped_burst"] + e["dropped_outage"] + e["dropped_bandwidth"] + \
            e["dropped_overflow"]
        in_flight = e["offered"] + e["duplicated"] - e["delivered"] - dropped
        check(in_flight >= 0 and e["offered"] == inner["accepted"],
              f"{side}: the emulation got every sample the wrapped link accepted ({e['offered']}), "
              f"{in_flight} in flight at the end")
        n = e["offered"]
        row[f"dropped_{side}"] = dropped / max(1, n)
        for key, count in (("loss_probability", e["dropped_loss"]), ("duplicate_probability", e["duplicated"]),
                           ("corrupt_probability", e["corrupted"]), ("reorder_probability", e["reordered"])):
            p = flow_value(flow, key)
            if key == "corrupt_probability":
                n_k = n + e["duplicated"]  # copies can be corrupted too
            else:
                n_k = n
            sigma = math.sqrt(max(p * (1 - p), 1e-12) / max(n_k, 1))
            check(abs(count / max(n_k, 1) - p) <= 4.5 * sigma + 1e-9,
                  f"{side}: {key} measured {count / max(n_k, 1):.4f} of {n_k}, configured {p} (±{4.5 * sigma:.4f})")
        enter, leave = flow_value(flow, "enter_probability"), flow_value(flow, "exit_probability")
        if enter > 0:
            expected = enter / (enter + leave)
            # Bursts are correlated: a short run holds a few dozen, so the band is wide (unit tests pin the rate).
            check(0.3 * expected <= e["dropped_burst"] / n <= 2.5 * expected,
                  f"{side}: burst loss {e['dropped_burst'] / n:.4f}, stationary rate {expected:.4f} (0.3x..2.5x)")
        # What the loop lost: at least the emulation's drops (but those before the first and after the last sample
        # that got through, at most a few), at most those plus the corrupted, the wrapped link's own gaps and the
        # samples it superseded (after a stall; not gaps when in its first drain, before anything was accepted).
        floor = dropped - in_flight - 5
        ceiling = dropped + e["corrupted"] + inner["lost"] + inner["superseded"] + 3
        check(floor <= pk["lost"] <= ceiling, f"{side}: loop lost {pk['lost']}, emulation dropped {dropped}, "
              f"corrupted {e['corrupted']}, wrapped link lost {inner['lost']} superseded {inner['superseded']}")
        check(e["corrupted"] - in_flight <= pk["rejected"] - inner["rejected"] <= e["corrupted"],
              f"{side}: rejected {pk['rejected'] - inner['rejected']} of {e['corrupted']} corrupted")
        check(e["duplicated"] - e["corrupted"] - in_flight <= pk["duplicates"] <= e["duplicated"] + 2,
              f"{side}: duplicates {pk['duplicates']} of {e['duplicated']} copies")
        check(e["reordered"] - in_flight <= pk["reordered"] <= e["reordered"] + 2,
              f"{side}: reordered {pk['reordered']} of {e['reordered']} overtakes")
        delay = flow_value(flow, "delay_ms")
        if delay > 0 and x["rtt_ms"]["count"] > 0:
            check(x["rtt_ms"]["p50"] >= 2 * delay, f"{side}: round trip p50 {x['rtt_ms']['p50']:.1f} ms >= both "
                  f"delays {2 * delay:.0f} ms")
        if name.endswith("passivity"):
            # Energy bounded: the observed energy at the port never goes below a few microjoules (a negative W is
            # energy the coupling generated; the controller dissipates it within the cycle after), the energy block
            # arrived with every sample, and the pair tracks without saturating. Without passivity the same 20 ms
            # delay oscillates into saturation (the "delay 20 ms" row: hundreds of saturated cycles, tens of mm).
            pv = x["passivity"]
            check(pv["mode"] == "energy_exchange" and pv["peer_without_energy"] == 0,
                  f"{side}: energy exchange on, every peer sample carried its energies")
            check(pv["min_observed_J"] > -1e-3, f"{side}: observed energy bounded below (min {pv['min_observed_J']:.2e} J, "
                  f"dissipated {pv['dissipated_J']:.2e} J in {pv['cycles']} cycles)")
            check(x["saturated_cycles"] == 0 and x["tracking_error_max_m"] < 5e-3,
                  f"{side}: no saturation ({x['saturated_cycles']}), tracking max "
                  f"{x['tracking_error_max_m'] * 1e3:.2f} mm < 5 mm")
        if "outages" in flow and side == "master":
            check(e["dropped_outage"] > 0 and x["watchdog_trips"] >= 1,
                  f"master: outage dropped {e['dropped_outage']} samples, watchdog trips {x['watchdog_trips']}")
    return row


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--master", required=True)
    ap.add_argument("--slave", required=True)
    ap.add_argument("--canbus", required=True)
    ap.add_argument("--configs", required=True)
    ap.add_argument("--workdir", required=True)
    ap.add_argument("--jobs", type=int, default=4, help="scenarios run at the same time")
    ap.add_argument("--only", default="", help="run only the scenarios whose name contains this")
    args = ap.parse_args()
    self_check()
    os.makedirs(args.workdir, exist_ok=True)
    chosen = [sc for sc in SCENARIOS if args.only in sc[0]]
    logs = {sc[0]: [] for sc in chosen}
    started = time.monotonic()
    with concurrent.futures.ThreadPoolExecutor(max_workers=args.jobs) as pool:
        futures = {sc[0]: pool.submit(run_scenario, args, sc[0], sc[1], sc[2], logs[sc[0]]) for sc in chosen}
        rows = []
        for name, f in futures.items():
            try:
                rows.append(f.result())
            except tp.Failure as e:
                rows.append({"name": name, "checks": [("FAILED", str(e))]})
    failed = []
    for row in rows:
        bad = [w for v, w in row["checks"] if v != "ok"]
        print(f"== {row['name']}: {'FAILED' if bad else 'ok'}")
        for verdict, what in row["checks"]:
            print(f"  {verdict}: {what}")
        if bad:
            failed.append(row["name"])
            print("".join(logs[row["name"]]))
    print(f"\n{len(rows)} scenarios in {time.monotonic() - started:.1f} s of wall time\n")
    print("| scenario | dropped m→s / s→m | gaps seen m→s / s→m | rtt p50 ms | slave tracking rms / max mm | "
          "penetration mm | saturated cycles m/s | watchdog trips m/s | slave stop |")
    print("|---|---|---|---|---|---|---|---|---|")
    for row in rows:
        if "m" not in row:
            print(f"| {row['name']} | failed | | | | | | | |")
            continue
        m, s = row["m"], row["s"]
        rtt = f"{m['rtt_ms']['p50']:.1f}" if m["rtt_ms"]["count"] else "n/a"
        dropped = (f"{100 * row['dropped_slave']:.1f} / {100 * row['dropped_master']:.1f} %"
                   if "dropped_slave" in row and "dropped_master" in row else "–")
        print(f"| {row['name']} | {dropped} | {100 * row['gaps_slave']:.1f} / {100 * row['gaps_master']:.1f} % | {rtt} | "
              f"{s['tracking_error_rms_m'] * 1e3:.3f} / {s['tracking_error_max_m'] * 1e3:.3f} | "
              f"{s['fixture_max_penetration_m'] * 1e3:.3f} | {m['saturated_cycles']}/{s['saturated_cycles']} | "
              f"{m['watchdog_trips']}/{s['watchdog_trips']} | {row['slave_stop']} |")
    if failed:
        # Last, so a log shown by its tail says why: each failed check of each failed scenario.
        for row in rows:
            for verdict, what in row["checks"]:
                if verdict != "ok":
                    print(f"FAILED check: {row['name']}: {what}")
        print(f"FAILED: {', '.join(failed)}")
        sys.exit(1)
    print("PASSED")


if __name__ == "__main__":
    main()
