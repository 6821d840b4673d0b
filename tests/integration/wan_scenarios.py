#!/usr/bin/env python3
"""The WAN scenario table of docs/link-emulation.md (issue 32.5): the shipped loopback pair brought to a link of 0,
10, 40 and 100 ms each way (10 % of it as jitter, 5 % loss both ways; none at 0 ms) WITHOUT telling the start-up
check (link.expected_delay_ms: 0, so the check passes as on a lab network), with the run-time delay re-check on: what
the analysis predicts at that delay, what the pair does, and what the re-check did.

Two gain sets: the shipped K_p 600 / K_d 2 (the coupling alone is unstable from 5 ms on; on_unstable: passivity, so
the re-check switches the passivity controllers on) and the softer K_p 50 / K_d 1 (stable alone to 100 ms; the
re-check lowers the slave's fixture to 0.9 x the limit at the measured delay). The master's finger pushes the slave
8 N into its 2000 N/m fixture from 1 s, holds, and pulls it back into free space from 4 s. A hand-run for the docs,
not a ctest (about 8 s per row):

  /usr/bin/python3 tests/integration/wan_scenarios.py --master build/bin/teleop-master --slave build/bin/teleop-slave \\
      --analyze build/bin/teleop-analyze --configs deploy/configs --workdir /tmp/wan-table [--delays 0,10,40,100]

Columns: the predicted slave fixture limit at the delay (teleop-analyze max-stiffness, the processes' 8 operators),
what the re-check did (its log), the slave's fixture stiffness at the end of the slow period, the slave's tracking
error as it sees the master (RMS of x_s - the newest master sample; a delayed link adds the lag of its delay to it)
in the hold, the peak-to-peak motion in free space over the last second (growing oscillation or rest), saturated
cycles and the passivity controllers' acting cycles (master/slave).
"""
import argparse
import json
import os
import re
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import two_process_test as tp  # noqa: E402  (configs, ports, telemetry)

GAINS = {"shipped": (600.0, 2.0, 2000.0), "soft": (50.0, 1.0, 2800.0)}  # K_p, K_d, the slave's fixture
MASTER_S = 7.0
HOLD = (2.5, 4.0)   # the hold in the fixture (s since the slave's start, about the master's)
FREE = (5.5, 6.5)   # free space after the pull
SCRIPT = ("      script:\n"
          "        - {type: ramp, axis: 0, start_s: 1.0, duration_s: 1.0, from_N: 0, to_N: 8}\n"
          "        - {type: hold, axis: 0, start_s: 2.0, duration_s: 2.0}\n"
          "        - {type: ramp, axis: 0, start_s: 4.0, duration_s: 1.0, from_N: 8, to_N: -1}\n"
          "        - {type: hold, axis: 0, start_s: 5.0}\n")


def configure(path, role, kp, kd, fixture, delay_ms, seed, on_unstable):
    text = open(path).read()
    text = re.sub(r"(?m)^(\s*(?:fixture_)?stiffness_N_per_m:) 2000\b", lambda m: f"{m.group(1)} {fixture:g}", text)
    text = re.sub(r"(?m)^(\s*kp_N_per_m:).*$", lambda m: f"{m.group(1)} {kp:g}", text)
    text = re.sub(r"(?m)^(\s*kd_Ns_per_m:).*$", lambda m: f"{m.group(1)} {kd:g}", text)
    text = re.sub(r"(?m)^(\s*human_grid_steps:).*$", r"\1 1", text)
    text += "\nengagement: {max_rtt_ms: 0}\n"  # the latency gate off: the re-check decides
    if on_unstable == "passivity":  # the bound of the controller the re-check switches on
        text += "passivity: {mode: off, max_damping_Ns_per_m: 100}\n"
    text = re.sub(r"(?m)^(\s*timeout_ms:).*\n", "", text)
    link_end = text.index("  security:")
    link = "  timeout_ms: 500\n  expected_delay_ms: 0\n"
    if delay_ms > 0:
        link += (f"  emulate: {{seed: {seed}, delay_ms: {delay_ms:g}, jitter_ms: {delay_ms / 10:g}, "
                 "loss_probability: 0.05}\n")
    link += ("  delay_recheck: {enabled: true, window_s: 0.5, percentile: 0.5, trigger_ratio: 3, recover_ratio: 2, "
             f"recover_hold_s: 1.0, on_unstable: {on_unstable}}}\n")
    text = text[:link_end] + link + text[link_end:]
    if role == "master":
        text = re.sub(r"(?ms)^      script:.*?(?=^\S|^\s{0,4}\S)", SCRIPT, text)
    with open(path, "w") as f:
        f.write(text)


def predicted(analyze, kp, kd, delay_ms):
    out = subprocess.run([analyze, "max-stiffness", "--side", "slave", "--kp", f"{kp:g}", "--kd", f"{kd:g}",
                          "--human-steps", "1", "--link-delay-ms", f"{delay_ms:g}", "--json"],
                         capture_output=True, text=True)
    if "predicted UNSTABLE" in out.stderr:
        return "none (coupling unstable)"
    try:
        j = json.loads(out.stdout)
    except json.JSONDecodeError:
        return "?"
    if j.get("unstable_without_fixture"):
        return "none (coupling unstable)"
    return f"{j.get('max_stable_stiffness_N_per_m', float('nan')):.0f} N/m"


def action(log):
    """What one side's re-check did, from its log."""
    if "passivity controller on: observer" in log:
        did = "coupling unstable: passivity on"
        if "passivity back to off" in log:
            did += ", back off"
        return did
    m = re.findall(r"predicted limit ([0-9]+) N/m; fixture [0-9]+ N/m -> ([0-9]+) N/m", log)
    if m:
        return f"limit {m[-1][0]}: fixture to {m[-1][1]} N/m"
    if "no fixture is stable" in log or "coupling itself is unstable" in log:
        return "coupling unstable: event only"
    return "nothing"


def oscillation(t, x, lo, hi):
    """Peak-to-peak of x minus its 0.1 s centred moving average over [lo, hi): the oscillating part of the motion
    (a slow creep or a rest reads about 0)."""
    idx = [i for i, ti in enumerate(t) if lo <= ti < hi]
    if len(idx) < 200:
        return float("nan")
    resid = []
    for i in idx:
        w = [x[j] for j in range(max(0, i - 50), min(len(x), i + 51))]
        resid.append(x[i] - sum(w) / len(w))
    return max(resid) - min(resid)


def run(args, name, kp, kd, fixture, delay_ms):
    work = os.path.join(args.workdir, f"{name}-{delay_ms:g}ms")
    os.makedirs(work, exist_ok=True)
    ports = (tp.free_udp_port(), tp.free_udp_port())
    p = {k: os.path.join(work, k) for k in ("master.yaml", "slave.yaml", "master.csv", "slave.csv", "master.json",
                                             "slave.json", "master.log", "slave.log")}
    for role, seed in (("master", 2), ("slave", 1)):
        tp.write_config(os.path.join(args.configs, f"{role}.yaml"), p[f"{role}.yaml"], ports, p[f"{role}.csv"])
        configure(p[f"{role}.yaml"], role, kp, kd, fixture, delay_ms, seed,
                  "passivity" if name == "shipped" else "event")
    with open(p["slave.log"], "w") as slog, open(p["master.log"], "w") as mlog:
        slave = subprocess.Popen([args.slave, "--config", p["slave.yaml"], "--duration", "60", "--summary-json",
                                  p["slave.json"]], stdout=slog, stderr=subprocess.STDOUT)
        master = subprocess.Popen([args.master, "--config", p["master.yaml"], "--duration", str(MASTER_S),
                                   "--summary-json", p["master.json"]], stdout=mlog, stderr=subprocess.STDOUT)
        master.wait(timeout=90)
        try:
            slave.wait(timeout=10)
        except subprocess.TimeoutExpired:
            slave.kill()
            slave.wait()
    rows = tp.read_telemetry(p["slave.csv"])
    t = [r["time_s"] for r in rows]
    x = [r["position_m_0"] for r in rows]
    hold = oscillation(t, x, *HOLD)
    free = oscillation(t, x, *FREE)
    k_min = min(r["fixture_stiffness_N_per_m"] for r in rows) if rows else float("nan")
    did = "slave: " + action(open(p["slave.log"]).read()) + "; master: " + action(open(p["master.log"]).read())
    summaries = [json.load(open(p[f"{s}.json"])) for s in ("master", "slave")]
    sat = "/".join(str(s.get("saturated_cycles", "?")) for s in summaries)
    pc = "/".join(str(s.get("passivity", {}).get("cycles", "?")) for s in summaries)
    return did, k_min, hold, free, sat, pc, (t, x)


def main():
    ap = argparse.ArgumentParser()
    for a in ("--master", "--slave", "--analyze", "--configs", "--workdir"):
        ap.add_argument(a, required=True)
    ap.add_argument("--delays", default="0,10,40,100")
    ap.add_argument("--png", default="", help="also plot the slave's position against time, one panel per gain set")
    args = ap.parse_args()
    traces = {}
    print("| gains, slave fixture | one-way delay | predicted slave limit | what the re-check did | lowest fixture "
          "applied | oscillation in contact / in free space (mm p-p) | saturated cycles m/s | passivity cycles m/s |")
    print("|---|---|---|---|---|---|---|---|")
    for name, (kp, kd, fixture) in GAINS.items():
        for d in (float(x) for x in args.delays.split(",")):
            limit = predicted(args.analyze, kp, kd, d)
            did, k_min, hold, free, sat, pc, traces[(name, d)] = run(args, name, kp, kd, fixture, d)
            print(f"| K_p {kp:g} / K_d {kd:g}, {fixture:g} N/m | {d:g} ms | {limit} | {did} | {k_min:.0f} N/m | "
                  f"{hold * 1e3:.3f} / {free * 1e3:.3f} | {sat} | {pc} |", flush=True)
    if args.png:
        plot(args.png, traces)
    return 0


def plot(png, traces):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharey=True)
    for ax, (name, (kp, kd, fixture)) in zip(axes, GAINS.items()):
        for (n, d), (t, x) in sorted(traces.items()):
            if n == name:
                ax.plot(t, [xi * 1e3 for xi in x], label=f"{d:g} ms", linewidth=1.2)
        ax.axvspan(*HOLD, color="0.92", zorder=0)
        ax.set_title(f"K_p {kp:g} N/m, K_d {kd:g} N·s/m, slave fixture {fixture:g} N/m", fontsize=10)
        ax.set_xlabel("slave time (s)")
        ax.legend(title="one-way delay", fontsize=8, title_fontsize=8, loc="lower left")
        ax.grid(True, linewidth=0.3)
    axes[0].set_ylabel("slave position (mm)")
    fig.suptitle("The pair over a WAN link (10 % jitter, 5 % loss), the re-check on; grey: the push into the fixture",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(png, dpi=90)


if __name__ == "__main__":
    sys.exit(main())
