#!/usr/bin/env python3
"""The start-up stability check of the real teleop-slave / teleop-master (docs/stability.md, "In the processes").

Scenarios:
  refuse          slave fixture above the predicted limit: exit 2 before the link is opened (its UDP port is held
                  by this script meanwhile), one critical line naming the limit, the configured stiffness and
                  --allow-unstable; the limit is the one `teleop-analyze check --config` computes for the same file.
  override        the same config with --allow-unstable --duration 0.3: starts, runs (alone: exit 5), warns loudly.
  safe            the shipped slave (2000 N/m) and master with --duration 0.3: start, exit 5 (alone), one info line with the
                  limit and the margin.
  slow_coupling   no fixture at all, but 250 Hz: the coupling alone is predicted unstable: refused with its own
                  message.
"""
import argparse
import json
import os
import re
import socket
import subprocess
import sys
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "test_utilities"))
import teleop_keys  # noqa: E402  (tests/test_utilities)
from teleop_process import free_udp_port, set_ports  # noqa: E402


class Failure(Exception):
    pass


def check(cond, what):
    if not cond:
        raise Failure(what)
    print(f"  ok: {what}")


def write_config(src, dst, ports, replacements=()):
    text = open(src).read()
    text = set_ports(text, ports)
    for old, new in replacements:
        if old not in text:
            raise Failure(f"test bug: '{old}' not in {src}")
        text = text.replace(old, new, 1)
    text = re.sub(r"(?m)^(\s*csv:).*$", r'\1 ""', text)
    with open(dst, "w") as f:
        f.write(text)
    teleop_keys.ensure_key(os.path.dirname(dst))  # link.security key_file: teleop.key, beside the config


def run(cmd, timeout=30):
    print("$ " + " ".join(cmd))
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=timeout)
    print(p.stdout)
    return p.returncode, p.stdout


# A process run alone never connects: it exits kExitNeverConnected (teleop/node/exit_codes.hpp) after its run.
ALONE = 5

LIMIT = r"predicted stability limit (\d+) N/m"


def analyze_limit(analyze, config):
    code, out = run([analyze, "check", "--config", config, "--json"])
    result, _ = json.JSONDecoder().raw_decode(out)  # the first axis's object
    return code, result["limit"]["max_stable_stiffness_N_per_m"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--master", required=True)
    ap.add_argument("--slave", required=True)
    ap.add_argument("--analyze", required=True)
    ap.add_argument("--configs", required=True)
    ap.add_argument("--scenario", required=True, choices=["refuse", "override", "safe", "slow_coupling"])
    ap.add_argument("--workdir", required=True)
    args = ap.parse_args()
    os.makedirs(args.workdir, exist_ok=True)
    ports = (free_udp_port(), free_udp_port())
    slave_src = os.path.join(args.configs, "slave.yaml")
    master_src = os.path.join(args.configs, "master.yaml")
    cfg = os.path.join(args.workdir, "slave.yaml")

    if args.scenario in ("refuse", "override"):
        write_config(slave_src, cfg, ports, [("stiffness_N_per_m: 2000", "stiffness_N_per_m: 6000")])
        analyze_code, limit = analyze_limit(args.analyze, cfg)
        check(analyze_code == 1, f"teleop-analyze check calls 6000 N/m unstable (exit {analyze_code})")
        check(3000 < limit < 6000, f"predicted limit {limit:.1f} N/m")

    if args.scenario == "refuse":
        # Hold the slave's port: had the process opened its link before the check, it would fail on that instead.
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as held:
            held.bind(("127.0.0.1", ports[1]))
            code, out = run([args.slave, "--config", cfg, "--duration", "0.3"])
        check(code == 2, f"teleop-slave refuses with exit 2 (got {code})")
        lines = [l for l in out.splitlines() if "[critical]" in l]
        check(len(lines) == 1, "one critical line")
        line = lines[0]
        check("refusing to start" in line, "it says it refuses to start")
        check("slave fixture 6000 N/m" in line, "it names the configured stiffness")
        m = re.search(LIMIT, line)
        check(m is not None, "it names the predicted limit in N/m")
        check(abs(int(m.group(1)) - limit) <= 0.5, f"the limit {m.group(1)} N/m is teleop-analyze's {limit:.1f} N/m")
        check("--allow-unstable" in line, "it names the override")
        check("link udp" not in out and "summary" not in out, "nothing was opened or run")
    elif args.scenario == "override":
        code, out = run([args.slave, "--config", cfg, "--duration", "0.3", "--allow-unstable"])
        check(code == ALONE, f"teleop-slave --allow-unstable starts, runs alone and exits {ALONE} (got {code})")
        warnings = [l for l in out.splitlines() if "[warning]" in l and "--allow-unstable" in l]
        check(len(warnings) >= 1, "a warning names --allow-unstable")
        check("PREDICTED UNSTABLE" in warnings[0], "the warning is loud")
        m = re.search(LIMIT, warnings[0])
        check(m is not None and abs(int(m.group(1)) - limit) <= 0.5, "the warning names the predicted limit")
        check("slave fixture 6000 N/m" in warnings[0], "the warning names the configured stiffness")
        check("teleop-slave summary" in out, "the process ran its loop")
        check("[critical]" not in out, "no critical line")
    elif args.scenario == "safe":
        write_config(slave_src, cfg, ports)
        mcfg = os.path.join(args.workdir, "master.yaml")
        write_config(master_src, mcfg, ports)
        for name, binary, config, stiffness in (("slave", args.slave, cfg, "2000"), ("master", args.master, mcfg, "0")):
            code, out = run([binary, "--config", config, "--duration", "0.3"])
            check(code == ALONE, f"teleop-{name} starts, runs alone and exits {ALONE} (got {code})")
            passed = [l for l in out.splitlines() if "[info]" in l and "stability check passed" in l]
            check(len(passed) == 1, f"teleop-{name} logs one 'stability check passed' line")
            m = re.search(rf"{name} fixture {stiffness} N/m, predicted limit (\d+) N/m", passed[0])
            check(m is not None, f"it names the {stiffness} N/m fixture and the limit")
            _, limit = analyze_limit(args.analyze, config)
            check(abs(int(m.group(1)) - limit) <= 0.5, f"the limit {m.group(1)} N/m is teleop-analyze's {limit:.1f}")
            if name == "slave":
                margin = re.search(r"margin (\d+) %", passed[0])
                expected = 100.0 * (1.0 - 2000.0 / limit)
                check(margin is not None and abs(int(margin.group(1)) - expected) <= 0.5,
                      f"it names the margin ({expected:.1f} %)")
            check("[warning] --allow-unstable" not in out and "[critical]" not in out, "no warning, no refusal")
    elif args.scenario == "slow_coupling":
        text = open(slave_src).read()
        text = re.sub(r"(?ms)^fixture:.*?(?=^\S)", "", text)  # no fixture section at all
        text = text.replace("rate_hz: 1000", "rate_hz: 250", 1).replace("velocity_filter_hz: 200",
                                                                         "velocity_filter_hz: 100", 1)
        text = set_ports(text, ports)
        with open(cfg, "w") as f:
            f.write(text)
        teleop_keys.ensure_key(os.path.dirname(cfg))
        code, out = run([args.slave, "--config", cfg, "--duration", "0.3"])
        check(code == 2, f"teleop-slave refuses with exit 2 (got {code})")
        line = next((l for l in out.splitlines() if "[critical]" in l), "")
        check("UNSTABLE even without a fixture" in line, "it says the coupling alone is unstable")
        check("predicted limit 0 N/m, configured fixture 0 N/m" in line, "it names limit and stiffness")
        check("250 Hz" in line and "Raise rate_hz" in line, "it names the rate and what to change")
        check("--allow-unstable" in line, "it names the override")
        code, out = run([args.slave, "--config", cfg, "--duration", "0.3", "--allow-unstable"])
        check(code == ALONE, f"--allow-unstable starts it anyway (exit {ALONE}: alone; got {code})")


if __name__ == "__main__":
    try:
        main()
    except (Failure, subprocess.TimeoutExpired, ValueError, IndexError, StopIteration) as e:
        print(f"FAILED: {e}")
        sys.exit(1)
    print("PASSED")
