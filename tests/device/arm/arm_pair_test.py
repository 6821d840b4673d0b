#!/usr/bin/env python3
"""The arm rigs as two real processes over UDP (deploy/configs/arm, docs/arms.md): a simulated stylus master (or a
7-joint leader; or, --rig emulated with --configs deploy/configs/arm-mit, the 7-joint leader on simulated MIT motors) pushed down by its simulated operator, a simulated 7-joint slave with a plane fixture 3 cm below its
working point. --rig daemon (deploy/configs/arm-mit): the same MIT pair on one machine over two CAN buses, each
arm's seven simulated motors another process (teleop-arm simulate-motors) on its own teleop-canbus daemon, every
command and reply crossing the daemon. Through a UDP relay that cuts both directions for 0.5 s once the slave rests on the plane. Checks
from the telemetry and prints:

  follows      while engaged and before contact, the slave's z within 10 mm of the master's (the largest gap; the first
               run measured 6.5 mm on the stylus rig: the 3 kg slave lags during the descent);
  stops        the slave's deepest penetration of the fixture plane, at most 5 mm (first run: 2.1 mm, the
               underdamped 3 kg slave overshoots; the static estimate is 0.3 mm);
  link cut     the slave leaves `engaged`, has no device fault, and its tool moves at most 3 mm while the link is
               down: the arm holds its own weight (gravity compensation stays on).
"""
import argparse
import os
import re
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "test_utilities"))
sys.path.insert(0, os.path.join(HERE, "..", "..", "integration"))
from two_process_test import Output, free_udp_port, read_telemetry  # noqa: E402
from udp_relay import UdpRelay  # noqa: E402
import teleop_keys  # noqa: E402

ENGAGED = 3
PLANE_Z = -0.03


class Failure(Exception):
    pass


def write_config(src, dst, bind_port, peer_port, csv, robots, can_bus_port=None):
    text = open(src).read()
    if can_bus_port is not None:  # the arm's motors on a teleop-canbus daemon: its port
        text = re.sub(r'(?m)^(\s*can:\s*\{medium: emulated, bus:\s*)"127\.0\.0\.1:\d+"',
                      lambda m: f'{m.group(1)}"127.0.0.1:{can_bus_port}"', text)
        # Six processes on a CI machine shared with builds (load average 8 on 2 cores) get descheduled for up to
        # ~0.1 s: a host whose loop stalls that long has its motors disabled by their own CAN timeout, a motor
        # process that stalls is "stopped answering" after missing_limit exchanges. Both are right on a real bus;
        # this test is of the pair through the daemons, so they are relaxed here (the timeout's and the missing
        # replies' own behaviour are device_arm_mit_test's).
        text = re.sub(r"(?m)^(\s*motor_timeout_ms:)\s*\d+", lambda m: f"{m.group(1)} 1000", text)
        text = re.sub(r"(?m)^(\s*missing_limit:)\s*\d+", lambda m: f"{m.group(1)} 500", text)
    text = re.sub(r'(?m)^(\s*bind:\s*)"127\.0\.0\.1:\d+"', lambda m: f'{m.group(1)}"127.0.0.1:{bind_port}"', text)
    text = re.sub(r'(?m)^(\s*peer:\s*)"127\.0\.0\.1:\d+"', lambda m: f'{m.group(1)}"127.0.0.1:{peer_port}"', text)
    text = re.sub(r"(?m)^(\s*csv:).*$", lambda m: f'{m.group(1)} "{csv}"', text)
    text = re.sub(r"(?m)^(\s*urdf:\s*)\.\./\.\./robots/", lambda m: f"{m.group(1)}{robots}/", text)
    text = re.sub(r"(?m)^(\s*fifo_priority:).*$", lambda m: f"{m.group(1)} 0", text)
    text = re.sub(r"(?m)^(\s*lock_memory:).*$", lambda m: f"{m.group(1)} false", text)
    with open(dst, "w") as f:
        f.write(text)
    teleop_keys.ensure_key(os.path.dirname(dst))


def run(args):
    work = args.workdir
    os.makedirs(work, exist_ok=True)
    ports = {"master": free_udp_port(), "slave": free_udp_port()}
    relay = UdpRelay(("127.0.0.1", ports["master"]), ("127.0.0.1", ports["slave"]))
    relay.start()
    mcfg, scfg = os.path.join(work, "master.yaml"), os.path.join(work, "slave.yaml")
    mcsv, scsv = os.path.join(work, "master.csv"), os.path.join(work, "slave.csv")
    daemon = args.rig == "daemon"
    bus_ports = {"master": free_udp_port(), "slave": free_udp_port()} if daemon else {"master": None, "slave": None}
    write_config(os.path.join(args.configs, f"master-{args.rig}.yaml"), mcfg, ports["master"], relay.master_side[1],
                 mcsv, args.robots, bus_ports["master"])
    write_config(os.path.join(args.configs, f"slave-{args.rig}.yaml"), scfg, ports["slave"], relay.slave_side[1],
                 scsv, args.robots, bus_ports["slave"])
    helpers = []  # the daemons and the motor processes (--rig daemon)
    try:
        if daemon:
            start_buses_and_motors(args, bus_ports, {"master": mcfg, "slave": scfg}, helpers)
        run_pair(args, relay, mcfg, scfg, mcsv, scsv)
    finally:
        for p in reversed(helpers):
            if p.poll() is None:
                p.terminate()
                try:
                    p.wait(timeout=5)
                except subprocess.TimeoutExpired:
                    p.kill()
                    p.wait()
        relay.stop()


def start_buses_and_motors(args, bus_ports, configs, helpers):
    """Per arm: a teleop-canbus daemon (CAN FD, 1 Mbit/s arbitration, 5 Mbit/s data) and the arm's seven simulated
    motors on it (teleop-arm simulate-motors with the arm's own config), before the host processes start."""
    for role in ("slave", "master"):
        bus = subprocess.Popen([args.canbus, "--port", str(bus_ports[role]), "--bitrate", "1000000", "--data-bitrate",
                                "5000000", "--stats-every-s", "0"], stdout=subprocess.PIPE,
                               stderr=subprocess.STDOUT, text=True)
        helpers.append(bus)
        bus_out = Output(bus)
        if not bus_out.wait_for("listening", 10):
            raise Failure(f"the {role}'s teleop-canbus did not start:\n" + bus_out.text()[-2000:])
        motors = subprocess.Popen([args.teleop_arm, "simulate-motors", "--config", configs[role]],
                                  stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        helpers.append(motors)
        motors_out = Output(motors)
        if not motors_out.wait_for("ready", 10):
            raise Failure(f"the {role}'s simulated motors did not start:\n" + motors_out.text()[-2000:])


def run_pair(args, relay, mcfg, scfg, mcsv, scsv):
    slave = subprocess.Popen([args.slave, "--config", scfg, "--duration", "5"], stdout=subprocess.PIPE,
                             stderr=subprocess.STDOUT, text=True)
    slave_out = Output(slave)
    # The slave's start-up check sweeps the arm's configurations near the plane (about 2 s, docs/arms.md,
    # "Stability"): the master starts once it is done, so that the pair engages before the operator's push.
    if not slave_out.wait_for("stability check", 30):
        slave.kill()
        raise Failure("the slave did not finish its start-up check:\n" + slave_out.text()[-2000:])
    master = subprocess.Popen([args.master, "--config", mcfg, "--duration", "4"], stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, text=True)
    master_out = Output(master)
    try:
        if not (master_out.wait_for("engaged", 20) and slave_out.wait_for("engaged", 10)):
            raise Failure("the two processes never engaged:\n" + master_out.text()[-2000:] + slave_out.text()[-2000:])
        time.sleep(2.2)  # the push starts at 0.5 s; the slave rests on the plane well before 2 s
        cut = relay.cut(0.5)
        master.wait(timeout=60)
        slave.wait(timeout=60)
    finally:
        for p in (master, slave):
            if p.poll() is None:
                p.kill()
    if master.returncode != 0 or slave.returncode != 0:
        raise Failure(f"exit codes master {master.returncode}, slave {slave.returncode}:\n" + master_out.text()[-2000:]
                      + slave_out.text()[-2000:])
    s = read_telemetry(scsv)
    engaged = [r for r in s if r["engagement"] == ENGAGED]
    if not engaged:
        raise Failure("the slave never engaged in its telemetry")
    # follows: engaged rows before the slave reaches within 5 mm of the plane
    free = [r for r in engaged if r["position_m_2"] > PLANE_Z + 0.005]
    gap = max(abs(r["position_m_2"] - r["peer_position_m_2"]) for r in free)
    # stops
    penetration = max(PLANE_Z - r["position_m_2"] for r in s)
    # link cut: from the first non-engaged row after the first engagement
    first_engaged = s.index(engaged[0])
    after = [r for r in s[first_engaged:] if r["engagement"] != ENGAGED]
    if not after:
        raise Failure("the slave never left `engaged` during the link cut")
    z0 = after[0]["position_m_2"]
    cut_rows = [r for r in after if r["time_s"] <= after[0]["time_s"] + 0.4]
    drift = max(abs(r["position_m_2"] - z0) for r in cut_rows)
    reached = min(r["position_m_2"] for r in engaged)
    print(f"rig {args.rig}: follows: largest |z_s - z_m| before contact {gap * 1000:.2f} mm over {len(free)} cycles; "
          f"stops: deepest z {reached * 1000:.2f} mm, penetration of the plane at {PLANE_Z * 1000:.0f} mm: "
          f"{max(0.0, penetration) * 1000:.3f} mm; link cut: slave tool moved {drift * 1000:.3f} mm in 0.4 s "
          f"without a peer")
    if reached > PLANE_Z + 0.01:
        raise Failure(f"the slave never came near the plane (deepest z {reached} m)")
    if gap > 0.010:
        raise Failure(f"the slave did not follow: gap {gap} m")
    if penetration > 0.005:
        raise Failure(f"the slave went {penetration} m through the plane")
    if drift > 0.003:
        raise Failure(f"the slave did not hold its weight without a peer: moved {drift} m")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--master", required=True)
    ap.add_argument("--slave", required=True)
    ap.add_argument("--configs", required=True)
    ap.add_argument("--robots", required=True)
    # emulated, daemon: deploy/configs/arm-mit (daemon: also --canbus and --teleop-arm)
    ap.add_argument("--rig", required=True, choices=["stylus", "twin", "emulated", "daemon"])
    ap.add_argument("--canbus", help="teleop-canbus (--rig daemon)")
    ap.add_argument("--teleop-arm", help="teleop-arm (--rig daemon: simulate-motors)")
    ap.add_argument("--workdir", required=True)
    args = ap.parse_args()
    if args.rig == "daemon" and not (args.canbus and args.teleop_arm):
        ap.error("--rig daemon needs --canbus and --teleop-arm")
    try:
        run(args)
    except Failure as e:
        print(f"FAIL: {e}")
        return 1
    print("PASS")
    return 0


if __name__ == "__main__":
    sys.exit(main())
