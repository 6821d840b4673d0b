#!/usr/bin/env python3
"""The Wireshark dissector (deploy/wireshark/teleop.lua) against a real run captured on loopback with tshark.

teleop-slave and teleop-master run for about 1.5 s on 127.0.0.1 with telemetry CSVs while tshark captures their
ports; one datagram with a broken CRC and one foreign datagram are sent to the slave's port during the run. Then
tshark decodes the capture with the dissector, and the test checks, field by field, that every sample the dissector
decodes matches what the sending process itself recorded for that cycle in its telemetry CSV (the sequence number is
the cycle number; position, velocity, force sensor and flags are what it sent), that every slave echo is a master
timestamp, that the shutdown sample at the end is flagged, that the CRC of every real sample verifies and the broken
one is flagged bad, and that the foreign datagram is not taken for teleop. That run uses link.security.mode insecure
(version 1 on the wire); a second run with the shipped configs as they are (psk, version 2) checks the decoded
handshake (hello, welcome, one confirm) and frame headers: one session id, frame sequences 0, 1, 2, ... per sender,
as many frames as each process's summary says it sent, and the 1-DOF sizes. Exit 77 (skip) only when capturing is not
permitted here (no root / CAP_NET_RAW).
"""
import argparse
import csv
import json
import math
import os
import re
import socket
import struct
import subprocess
import sys
import tempfile
import time
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "test_utilities"))
import teleop_keys  # noqa: E402  (tests/test_utilities)

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "test_utilities"))
from teleop_process import (Failure, SKIP, check, free_udp_port, set_ports,  # noqa: E402
                            run_test, start_capture, stop_capture)

def write_config(src, dst, ports, csv_path):
    text = set_ports(open(src).read(), ports)
    text = re.sub(r"(?m)^(\s*csv:).*$", rf'\1 "{csv_path}"', text)
    # The dissector decodes version-1 samples: this run needs them on the wire (the shipped configs say psk).
    text = teleop_keys.make_insecure(text)
    with open(dst, "w") as f:
        f.write(text)


def read_csv(path):
    with open(path, newline="") as f:
        return {int(r["cycle"]): r for r in csv.DictReader(f)}


def broken_sample():
    """A well-formed 1-DOF master sample whose CRC is off by one (the receiver rejects it as bad_crc)."""
    head = struct.pack("<IBBBBBBHIQQI", 0x504F4C54, 1, 1, 0, 0x01, 1, 0, 24, 12345, 1, 0, 0)
    body = struct.pack("<ddd", 0.25, -1.5, 2.0)
    return head + body + struct.pack("<I", 0xDEADBEEF)


# docs/protocol.md, "Example: 1 DOF, hand-checked" (also the golden bytes of tests/proto/codec_test.cpp).
GOLDEN = bytes.fromhex(
    "544C4F50 01 01 01 11 01 00 1800 04030201"
    "8877665544332211 0807060504030201 90D00300"
    "000000000000D03F 000000000000F8BF 0000000000000040"
    "EE516B95".replace(" ", ""))


# tests/proto/codec_test.cpp kTwoDofEnergyGolden (golden_sample_bytes.py two_dof_energy()): a 2-DOF master sample
# with the energy block (docs/protocol.md, "Energy block"): in/out energies 1.5/0.25 J and 0/2 J.
ENERGY_GOLDEN = bytes.fromhex("544C4F500101000102005000070000000094357700000000C051267700000000E8030000000000000000C03F000000000000E03F000000000000F0BF000000000000D0BF000000000000E8BF0000000000000840000000000000F83F000000000000D03F00000000000000000000000000000040FC370378")


def golden_energy(tshark, dissector, tmp):
    """The energy-block golden sample, through text2pcap and the dissector."""
    dump = os.path.join(tmp, "energy.txt")
    with open(dump, "w") as f:
        f.write("000000 " + " ".join(f"{b:02x}" for b in ENERGY_GOLDEN) + "\n")
    pcap = os.path.join(tmp, "energy.pcap")
    r = subprocess.run(["text2pcap", "-q", "-u", "47002,47001", dump, pcap], stdout=subprocess.PIPE,
                       stderr=subprocess.STDOUT, text=True)
    check(r.returncode == 0, "text2pcap wrapped the energy sample in a UDP datagram" + (r.stdout if r.returncode else ""))
    fields = ["teleop.dof", "teleop.payload_length", "teleop.force", "teleop.input_energy", "teleop.output_energy",
              "teleop.crc.status", "teleop.status"]
    cmd = [tshark, "-r", pcap, "-X", f"lua_script:{dissector}", "-T", "fields", "-E", "separator=\t",
           "-E", "aggregator=;"]
    for name in fields:
        cmd += ["-e", name]
    out = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True).stdout.strip()
    got = dict(zip(fields, out.split("\t")))
    want = {"teleop.dof": "2", "teleop.payload_length": "80", "teleop.force": "-1;3",
            "teleop.input_energy": "1.5;0", "teleop.output_energy": "0.25;2", "teleop.crc.status": "1",
            "teleop.status": "ok"}
    wrong = [f"{k} is {got.get(k)!r}, expected {v}" for k, v in want.items() if got.get(k, "") != v]
    check(not wrong, "the energy-block golden sample decodes (payload 80, energies 1.5/0.25 J and 0/2 J, CRC good)"
          + (f": {wrong}" if wrong else ""))


def golden(tshark, dissector, tmp):
    """The protocol page's hand-checked sample, through text2pcap and the dissector."""
    dump = os.path.join(tmp, "golden.txt")
    with open(dump, "w") as f:
        f.write("000000 " + " ".join(f"{b:02x}" for b in GOLDEN) + "\n")
    pcap = os.path.join(tmp, "golden.pcap")
    r = subprocess.run(["text2pcap", "-q", "-u", "47002,47001", dump, pcap], stdout=subprocess.PIPE,
                       stderr=subprocess.STDOUT, text=True)
    check(r.returncode == 0, "text2pcap wrapped the golden sample in a UDP datagram" + (r.stdout if r.returncode else ""))
    fields = ["teleop.role", "teleop.flags", "teleop.dof", "teleop.payload_length", "teleop.seq",
              "teleop.sender_time_ns", "teleop.echo_time_ns", "teleop.echo_age_ns", "teleop.position",
              "teleop.velocity", "teleop.force", "teleop.crc", "teleop.crc.status", "teleop.status",
              "teleop.flags.enabled", "teleop.flags.in_fixture", "teleop.flags.fault"]
    cmd = [tshark, "-r", pcap, "-X", f"lua_script:{dissector}", "-T", "fields", "-E", "separator=\t"]
    for name in fields:
        cmd += ["-e", name]
    out = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True).stdout.strip()
    got = dict(zip(fields, out.split("\t")))
    want = {"teleop.role": "1", "teleop.flags": "0x11", "teleop.dof": "1", "teleop.payload_length": "24",
            "teleop.seq": str(0x01020304), "teleop.sender_time_ns": str(0x1122334455667788),
            "teleop.echo_time_ns": str(0x0102030405060708), "teleop.echo_age_ns": "250000",
            "teleop.position": "0.25", "teleop.velocity": "-1.5", "teleop.force": "2", "teleop.crc": "0x956b51ee",
            "teleop.crc.status": "1", "teleop.status": "ok"}
    wrong = [f"{k} is {got.get(k)!r}, docs/protocol.md says {v}" for k, v in want.items()
             if got.get(k, "").lower() != v.lower()]
    check(got.get("teleop.flags.enabled") in ("1", "True") and got.get("teleop.flags.in_fixture") in ("1", "True")
          and got.get("teleop.flags.fault") in ("0", "False"), "golden sample flags: enabled, in fixture, no fault")
    check(not wrong, "the golden sample of docs/protocol.md decodes field by field (seq, times, echo age 250 us, "
                "x 0.25 m, v -1.5 m/s, F 2 N, CRC 0x956B51EE good)" + (f": {wrong}" if wrong else ""))


def secure_run(tshark, args, tmp):
    """A run with the shipped configs as they are (link.security.mode psk): the dissector decodes the version-2
    handshake and frame headers, and what it shows agrees with the processes' own summaries."""
    work = os.path.join(tmp, "secure")
    os.makedirs(work)
    ports = (free_udp_port(), free_udp_port())
    mcfg, scfg = os.path.join(work, "master.yaml"), os.path.join(work, "slave.yaml")
    for src, dst in ((os.path.join(args.configs, "master.yaml"), mcfg), (os.path.join(args.configs, "slave.yaml"),
                                                                         scfg)):
        text = set_ports(open(src).read(), ports)
        text = re.sub(r"(?m)^(\s*csv:).*$", r'\1 ""', text)
        check("mode: psk" in text, f"{os.path.basename(src)} authenticates its link (mode psk)")
        with open(dst, "w") as f:
            f.write(text)
    teleop_keys.ensure_key(work)
    pcap = os.path.join(work, "secure.pcapng")
    cap = start_capture(pcap, f"udp port {ports[0]} or udp port {ports[1]}")
    if cap is None:
        return SKIP
    mjson, sjson = os.path.join(work, "master.json"), os.path.join(work, "slave.json")
    try:
        slave = subprocess.Popen([args.slave, "--config", scfg, "--duration", "6", "--summary-json", sjson],
                                 stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        time.sleep(0.3)
        master = subprocess.run([args.master, "--config", mcfg, "--duration", "1.5", "--summary-json", mjson],
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=60)
        slave.communicate(timeout=60)
        time.sleep(0.3)
    finally:
        stop_capture(cap)
    check(master.returncode == 0 and slave.returncode == 0, "secure run: both processes ran and exited 0")
    summaries = {"master": json.load(open(mjson)), "slave": json.load(open(sjson))}
    fields = ["frame.number", "udp.srcport", "teleop.version", "teleop.type", "teleop.role", "teleop.session_id",
              "teleop.frame_seq", "teleop.ciphertext_length", "teleop.status", "udp.length", "teleop.hello_timestamp"]
    # The ports of the run as teleop ports (the preference): random ciphertext can satisfy another protocol's
    # heuristic, and a port registration is tried before any heuristic.
    cmd = [tshark, "-r", pcap, "-X", f"lua_script:{args.dissector}", "-o", f"teleop.ports:{ports[0]},{ports[1]}",
           "-T", "fields", "-E", "separator=\t", "-e", "_ws.col.Protocol"]
    for name in fields:
        cmd += ["-e", name]
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=120)
    errors = [ln for ln in r.stderr.splitlines() if "Running as user" not in ln and ln.strip()]
    check(r.returncode == 0 and not errors, f"secure run: tshark reads the capture {errors[:3]}")
    rows = [dict(zip(["protocol"] + fields, ln.split("\t"))) for ln in r.stdout.splitlines()]
    odd = [x for x in rows if x["teleop.version"] != "2"]
    check(len(rows) > 1000 and not odd, f"secure run: all {len(rows)} datagrams are version 2 {odd[:2]}")
    bad = [x for x in rows if x["teleop.status"] != "ok"]
    check(not bad, f"every version-2 message decodes as ok {bad[:2]}")
    by_type = {}
    for x in rows:
        by_type.setdefault(x["teleop.type"], []).append(x)
    hellos, welcomes, confirms, frames = (by_type.get(t, []) for t in ("6", "3", "4", "5"))
    check(len(hellos) >= 1 and all(x["teleop.role"] == "0" for x in hellos), f"{len(hellos)} hello from the master")
    stamps = [int(x["teleop.hello_timestamp"]) for x in hellos]
    check(all(b > a for a, b in zip(stamps, stamps[1:])) and all(x["udp.length"] == str(8 + 80) for x in hellos),
          f"hellos are 80 bytes with strictly increasing timestamps {stamps[:3]}")
    check(len(welcomes) >= 1 and all(x["teleop.role"] == "1" for x in welcomes),
          f"{len(welcomes)} welcome from the slave")
    check(len(confirms) == 1 and confirms[0]["teleop.role"] == "0", "one confirm from the master")
    session = confirms[0]["teleop.session_id"]
    check(all(x["teleop.session_id"] == session for x in frames),
          f"every frame carries the confirmed session id {session}")
    for role, code, port in (("master", "0", ports[0]), ("slave", "1", ports[1])):
        mine = [x for x in frames if x["teleop.role"] == code]
        check(all(int(x["udp.srcport"]) == port for x in mine), f"{role} frames come from its port")
        seqs = [int(x["teleop.frame_seq"]) for x in mine]
        check(seqs == list(range(len(seqs))), f"{role}: frame sequences 0..{len(seqs) - 1}, one per frame, in order")
        sent = summaries[role]["packets"]["sent"]
        check(len(mine) == sent, f"{role}: {len(mine)} frames captured = {sent} sent (its summary)")
        check(all(x["teleop.ciphertext_length"] == "64" and x["udp.length"] == str(8 + 28 + 64 + 16) for x in mine),
              f"{role}: 1-DOF frames, 64 bytes of ciphertext, 108 bytes in all")
    return 0


def same(a, b):
    return math.isclose(a, b, rel_tol=1e-13, abs_tol=1e-300)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--master", required=True)
    ap.add_argument("--slave", required=True)
    ap.add_argument("--configs", required=True)
    ap.add_argument("--dissector", required=True)
    args = ap.parse_args()
    tshark = "/usr/bin/tshark"
    if not os.path.exists(tshark):
        raise Failure("tshark is not installed: apt-get install tshark (it is in TELEOP_PACKAGES)")

    with tempfile.TemporaryDirectory(prefix="teleop-tshark-") as tmp:
        golden(tshark, args.dissector, tmp)
        golden_energy(tshark, args.dissector, tmp)
        if secure_run(tshark, args, tmp) == SKIP:
            return SKIP
        ports = (free_udp_port(), free_udp_port())
        mcsv, scsv = os.path.join(tmp, "master.csv"), os.path.join(tmp, "slave.csv")
        mcfg, scfg = os.path.join(tmp, "master.yaml"), os.path.join(tmp, "slave.yaml")
        write_config(os.path.join(args.configs, "master.yaml"), mcfg, ports, mcsv)
        write_config(os.path.join(args.configs, "slave.yaml"), scfg, ports, scsv)
        pcap = os.path.join(tmp, "run.pcapng")
        cap = start_capture(pcap, f"udp port {ports[0]} or udp port {ports[1]}")
        if cap is None:
            return SKIP
        try:
            slave = subprocess.Popen([args.slave, "--config", scfg, "--duration", "6"],
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
            time.sleep(0.3)
            master = subprocess.Popen([args.master, "--config", mcfg, "--duration", "1.5"],
                                      stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
            time.sleep(0.8)
            with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
                s.sendto(broken_sample(), ("127.0.0.1", ports[1]))
                s.sendto(b"GET / HTTP/1.0\r\n\r\n" * 3, ("127.0.0.1", ports[1]))
            mout, _ = master.communicate(timeout=60)
            sout, _ = slave.communicate(timeout=60)
            time.sleep(0.3)
        finally:
            stop_capture(cap)
        print(mout, sout)
        check(master.returncode == 0 and slave.returncode == 0, "both processes ran and exited 0")
        # They come from another port: the slave's socket is connect()ed to the master, so the kernel drops them
        # (docs/security.md); the capture below still shows them on the wire.
        check("rejected 0" in sout, "the two datagrams the test sent from another port never reached the slave")

        fields = ["frame.number", "udp.srcport", "teleop.role", "teleop.seq", "teleop.flags", "teleop.dof",
                  "teleop.position", "teleop.velocity", "teleop.force", "teleop.sender_time_ns",
                  "teleop.echo_time_ns", "teleop.crc.status", "teleop.status", "teleop.flags.shutdown"]
        cmd = [tshark, "-r", pcap, "-X", f"lua_script:{args.dissector}", "-T", "fields", "-E", "separator=\t",
               "-E", "occurrence=a"]
        for name in fields:
            cmd += ["-e", name]
        r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=120)
        errors = [ln for ln in r.stderr.splitlines() if "Running as user" not in ln and ln.strip()]
        check(r.returncode == 0 and not errors, f"tshark loads the dissector and reads the capture {errors[:3]}")
        rows = [dict(zip(fields, ln.split("\t"))) for ln in r.stdout.splitlines()]
        frames = len(rows)
        teleop_rows = [x for x in rows if x["teleop.seq"] != ""]
        other = [x for x in rows if x["teleop.seq"] == ""]
        # The run is 1.5 s at 1 kHz, but a loaded machine achieves less: ask for a real run, not a rate.
        check(frames > 200, f"{frames} frames captured")
        check(len(other) == 1, f"exactly one frame (the foreign datagram) is not teleop ({len(other)})")

        mrows, srows = read_csv(mcsv), read_csv(scsv)
        bad = [x for x in teleop_rows if x["teleop.crc.status"] != "1"]
        check(len(bad) == 1 and bad[0]["teleop.seq"] == "12345" and bad[0]["teleop.status"] == "bad_crc",
              "the one forged sample is flagged: CRC status bad, decode status bad_crc")
        real = [x for x in teleop_rows if x not in bad]
        check(all(x["teleop.status"] == "ok" for x in real), "every real sample decodes as ok with a good CRC")

        master_times = set()
        matched = {"master": 0, "slave": 0}
        sent = {"master": 0, "slave": 0}
        shutdown = {"master": 0, "slave": 0}
        for x in real:
            role = "master" if x["teleop.role"] == "0" else "slave"
            src = int(x["udp.srcport"])
            if src != ports[0 if role == "master" else 1]:
                raise Failure(f"frame {x['frame.number']}: role {role} from port {src}")
            sent[role] += 1
            if role == "master":
                master_times.add(int(x["teleop.sender_time_ns"]))
            if x["teleop.flags.shutdown"] in ("1", "True"):
                shutdown[role] += 1
                continue
            table = mrows if role == "master" else srows
            row = table.get(int(x["teleop.seq"]))
            if row is None:
                continue
            checks = [("position", "position_m_0"), ("velocity", "velocity_m_per_s_0"),
                      ("force", "force_sensor_N_0")]
            for field, col in checks:
                if not same(float(x[f"teleop.{field}"]), float(row[col])):
                    raise Failure(f"frame {x['frame.number']} {role} seq {x['teleop.seq']}: {field} "
                                  f"{x[f'teleop.{field}']} but the CSV says {row[col]}")
            if int(x["teleop.flags"], 16) != int(row["flags"]) or x["teleop.dof"] != row["dof"]:
                raise Failure(f"frame {x['frame.number']}: flags {x['teleop.flags']} dof {x['teleop.dof']}, CSV "
                              f"{row['flags']} {row['dof']}")
            matched[role] += 1
        for role, table in (("master", mrows), ("slave", srows)):
            check(matched[role] >= 0.99 * len(table),
                  f"{role}: {matched[role]} of its {len(table)} CSV cycles found in the capture, every field equal "
                  f"(position, velocity, force, flags, dof)")
            check(shutdown[role] >= 1, f"{role}: its shutdown sample is flagged")
        echoes = [int(x["teleop.echo_time_ns"]) for x in real if x["teleop.role"] == "1"]
        echoes = [e for e in echoes if e != 0]
        hits = sum(1 for e in echoes if e in master_times)
        check(echoes and hits >= 0.99 * len(echoes),
              f"{hits} of {len(echoes)} slave echoes are master sender times from the capture")
    return 0


if __name__ == "__main__":
    run_test(main)
