#!/usr/bin/env python3
"""A pair that never connects says why (docs/troubleshooting.md, "The pair does not connect"): the real processes
on loopback UDP with the shipped configs (psk), --connect-timeout 1 and a status line every 0.3 s.

Cases, each a few seconds:
  no_peer        the master alone: status lines "waiting for the slave at 127.0.0.1:P: N hellos sent, ...", exit 5,
                 stop reason "connect timeout", the summary's connection line and a UDP round-trip line that does
                 not blame CAN.
  wrong_address  the slave runs, the master's peer port is one where nothing listens: the master names the port
                 unreachable, the slave says no hello came; both exit 5.
  wrong_key      both run with different keys: the slave says the peer's key differs (handshakes refused: bad
                 tag), the master that its hellos get no answer; both exit 5.
  wrong_version  a fake slave sends datagrams of wire protocol version 9 from the slave's port: the master names
                 version 9 and its own versions, exits 5.
"""
import argparse
import json
import os
import re
import socket
import struct
import sys
import threading

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "test_utilities"))
import teleop_keys  # noqa: E402  (tests/test_utilities)
from teleop_process import (Failure, Processes, check, free_udp_port, relax_realtime, run_test,  # noqa: E402
                            set_key, set_ports, wait_for_udp_port, write_text)

NEVER_CONNECTED = 5  # teleop/node/exit_codes.hpp, kExitNeverConnected
OPTIONS = ["--duration", "20", "--connect-timeout", "1", "--status-interval", "0.3"]


def configs(args, ports, master_peer_port=None, master_key="teleop.key"):
    out = {}
    for role in ("master", "slave"):
        text = relax_realtime(set_ports(open(os.path.join(args.configs, f"{role}.yaml")).read(), ports))
        text = re.sub(r"(?m)^(\s*csv:).*$", r'\1 ""', text)
        if role == "master":
            if master_peer_port is not None:
                text = set_key(text, "peer", f'"127.0.0.1:{master_peer_port}" ')  # the space: before a comment
            text = set_key(text, "key_file", master_key + " ")
        out[role] = write_text(os.path.join(args.workdir, f"{role}.yaml"), text)
    teleop_keys.ensure_key(args.workdir)
    teleop_keys.ensure_key(args.workdir, "other.key")
    return out


def start(procs, args, role, config):
    summary = os.path.join(args.workdir, f"{role}.json")
    if os.path.exists(summary):
        os.remove(summary)
    binary = args.master if role == "master" else args.slave
    return procs.start(role, [binary, "--config", config, "--summary-json", summary] + OPTIONS), summary


def finish(proc, summary, role):
    out, _ = proc.communicate(timeout=30)
    print(f"---- {role} ----\n{out}")
    check(proc.returncode == NEVER_CONNECTED, f"{role} exits {NEVER_CONNECTED} (got {proc.returncode})")
    s = json.load(open(summary))
    check(s["connected"] is False and s["connection"].startswith("NEVER CONNECTED"),
          f"{role}'s summary: {s['connection']}")
    check(s["stop_reason"] == "connect timeout", f"{role} gave up at --connect-timeout ({s['stop_reason']})")
    check(s["software_version"] != "" and s["protocol_version"] == 2, f"{role}'s summary names its versions")
    status = [line for line in out.splitlines() if "[warning]" in line and "waiting for the" in line]
    check(len(status) >= 1, f"{role} printed {len(status)} status lines while waiting")
    return out, s, status


def no_peer(args, ports):
    cfg = configs(args, ports)
    with Processes() as procs:
        proc, summary = start(procs, args, "master", cfg["master"])
        out, s, status = finish(proc, summary, "master")
    check(f"waiting for the slave at 127.0.0.1:{ports[1]}" in status[-1], "the status names the slave's address")
    check("hellos sent" in status[-1], "it counts the hellos")
    check("round trip        not measured (the peer never answered)" in out, "the round-trip line says why, not CAN")
    check("giving up after --connect-timeout 1 s" in out, "it says it gives up")


def wrong_address(args, ports):
    cfg = configs(args, ports, master_peer_port=free_udp_port())
    with Processes() as procs:
        slave, slave_summary = start(procs, args, "slave", cfg["slave"])
        master, master_summary = start(procs, args, "master", cfg["master"])
        _, _, status = finish(master, master_summary, "master")
        check("port unreachable" in status[-1] or "no answer" in status[-1], f"master: {status[-1]}")
        _, _, status = finish(slave, slave_summary, "slave")
        check(f"waiting for the master at 127.0.0.1:{ports[0]}" in status[-1] and "no hello received" in status[-1],
              "the slave says no hello came from the master's address")


def wrong_key(args, ports):
    cfg = configs(args, ports, master_key="other.key")
    with Processes() as procs:
        slave, slave_summary = start(procs, args, "slave", cfg["slave"])
        # The master gives up after 1 s: on a loaded machine a slave not yet bound answers 'port unreachable', and
        # the master rightly says nothing listens instead of asking for the key.
        wait_for_udp_port(ports[1], 10)
        master, master_summary = start(procs, args, "master", cfg["master"])
        _, _, status = finish(master, master_summary, "master")
        check("hellos sent, no answer" in status[-1] and "the same key?" in status[-1], "the master asks for the key")
        _, s, status = finish(slave, slave_summary, "slave")
        check("the peer answers but its key differs" in status[-1] and "bad tag" in status[-1],
              "the slave says the key differs")
        check("key differs" in s["connection"], "so does its summary")


def wrong_version(args, ports):
    cfg = configs(args, ports)
    stop = threading.Event()
    # Magic "TLOP", version 9, then enough bytes to look like a datagram.
    datagram = struct.pack("<IBBBB", 0x504F4C54, 9, 1, 2, 0) + bytes(60)

    def fake_slave(sock):
        while not stop.wait(0.05):
            try:
                sock.sendto(datagram, ("127.0.0.1", ports[0]))
            except OSError:
                pass  # the master is not up yet (port unreachable)

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock, Processes() as procs:
        sock.bind(("127.0.0.1", ports[1]))
        thread = threading.Thread(target=fake_slave, args=(sock,), daemon=True)
        thread.start()
        try:
            master, master_summary = start(procs, args, "master", cfg["master"])
            _, s, status = finish(master, master_summary, "master")
        finally:
            stop.set()
            thread.join()
    check("the peer runs wire protocol version 9" in status[-1], "the master names the peer's version")
    check(f"this process runs {s['software_version']} (wire protocol 1, authenticated 2)" in status[-1],
          "and its own")
    check("version 9" in s["connection"], "so does its summary")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--master", required=True)
    ap.add_argument("--slave", required=True)
    ap.add_argument("--configs", required=True)
    ap.add_argument("--workdir", required=True)
    ap.add_argument("--scenario", required=True, choices=["no_peer", "wrong_address", "wrong_key", "wrong_version"])
    args = ap.parse_args()
    os.makedirs(args.workdir, exist_ok=True)
    ports = (free_udp_port(), free_udp_port())
    {"no_peer": no_peer, "wrong_address": wrong_address, "wrong_key": wrong_key,
     "wrong_version": wrong_version}[args.scenario](args, ports)


if __name__ == "__main__":
    run_test(main)
