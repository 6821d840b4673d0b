#!/usr/bin/env python3
"""deploy/teleop-plot on a real CSV and on a synthetic one with known content.

1. teleop-slave runs alone for a moment with --telemetry-csv: the real column layout. teleop-plot makes its seven
   PNGs from it (each a real PNG of plausible size) and reports no round trip (no peer answered).
2. A CSV with the real header and rows written here: 990 records of cycles 0..999 with cycles 500..509 missing, one
   5 ms period, a round trip of 2.5 ms measured every other cycle, a fixture penetration peaking at 3 mm, the peer lost
   in cycles 600..699. --list must report exactly those.
3. A file that is not telemetry is refused with the missing column names.
"""
import argparse
import os
import re
import subprocess
import sys
import tempfile
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "test_utilities"))
import teleop_keys  # noqa: E402  (tests/test_utilities)

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "test_utilities"))
from teleop_process import check, free_udp_port, run, run_test  # noqa: E402

VIEWS = ["positions", "forces", "fixture", "period", "rtt", "loss", "engagement"]


def plot(tool, args):
    return run([tool] + args, timeout_s=120)


def check_pngs(out_dir, stem):
    for view in VIEWS:
        path = os.path.join(out_dir, f"{stem}-{view}.png")
        check(os.path.exists(path), f"{stem}-{view}.png written")
        with open(path, "rb") as f:
            data = f.read()
        check(data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10000, f"{stem}-{view}.png is a PNG ({len(data)} bytes)")


def synthetic(header, path):
    cols = header.split(",")
    rows = []
    for c in range(1000):
        if 500 <= c < 510:
            continue
        t = c * 0.001 + (0.004 if c >= 300 else 0.0)  # cycle 300 came 5 ms after cycle 299
        v = dict.fromkeys(cols, 0.0)
        v["cycle"], v["time_s"], v["dof"] = c, t, 1
        v["position_m_0"] = 0.01 * c / 1000
        v["peer_position_m_0"] = 0.01 * (c // 2) * 2 / 1000  # a new peer sample every other cycle
        pen = max(0.0, 0.003 - abs(c - 800) * 0.0001)
        v["fixture_penetration_m"] = pen
        v["fixture_force_N_0"] = -2000 * pen
        v["rtt_s"] = 0.0025 + 1e-6 * (c // 2)  # one new measurement per new sample
        v["flags"] = 1 | (4 if 600 <= c < 700 else 0) | (16 if pen > 0 else 0)
        v["law_status"] = 2 if 600 <= c < 700 else 0
        v["compute_s"] = 2e-5
        if "engagement" in v:  # engaged except cycles 600..699 (aligning) and the first 50 (handshaking)
            v["engagement"] = 1 if c < 50 else 2 if 600 <= c < 700 else 3
        rows.append(",".join(repr(v[k]) if isinstance(v[k], float) else str(v[k]) for k in cols))
    with open(path, "w") as f:
        f.write(header + "\n" + "\n".join(rows) + "\n")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--plot", required=True)
    ap.add_argument("--slave", required=True)
    ap.add_argument("--configs", required=True)
    args = ap.parse_args()
    # --version on the python tools: the package version, the one CMakeLists.txt's project() names.
    root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
    version = re.search(r"project\(teleop VERSION (\S+)", open(os.path.join(root, "CMakeLists.txt")).read()).group(1)
    for tool in (args.plot, os.path.join(os.path.dirname(args.plot), "teleop-canlog")):
        r = subprocess.run([tool, "--version"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        name = os.path.basename(tool)
        check(r.returncode == 0 and r.stdout.strip() == f"{name} {version}", f"{name} --version: {r.stdout.strip()}")
        r = subprocess.run([tool, "--help"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        first = r.stdout.split("\n\n")[1].strip()  # the description, after the usage
        check(r.stdout.count(first) == 1, f"{name} --help prints its description once")
    with tempfile.TemporaryDirectory(prefix="teleop-plot-") as tmp:
        # 1. A real run's file.
        cfg = os.path.join(tmp, "slave.yaml")
        text = open(os.path.join(args.configs, "slave.yaml")).read()
        with open(cfg, "w") as f:
            f.write(text.replace("127.0.0.1:47002", f"127.0.0.1:{free_udp_port()}").replace("127.0.0.1:47001",
                                                                                           "127.0.0.1:9"))
        teleop_keys.ensure_key(tmp)  # link.security key_file: teleop.key, beside the config
        real = os.path.join(tmp, "real.csv")
        r = subprocess.run([args.slave, "--config", cfg, "--duration", "0.4", "--telemetry-csv", real],
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=60)
        # Alone, it never connects: exit 5 (kExitNeverConnected), its telemetry written all the same.
        check(r.returncode == 5 and os.path.exists(real), f"teleop-slave wrote a telemetry CSV ({r.returncode})")
        rc, out, err = plot(args.plot, [real, "--out", tmp, "--title", "test"])
        print(out, err)
        check(rc == 0, "teleop-plot plots a real run")
        check("rtt_s (0 measurements)" in out, "no round trip without a peer")
        check_pngs(tmp, "real")

        # 2. Known content.
        header = open(real).readline().strip()
        syn = os.path.join(tmp, "syn.csv")
        synthetic(header, syn)
        rc, out, err = plot(args.plot, ["--list", syn])
        print(out, err)
        check(rc == 0, "teleop-plot --list reads the synthetic run")
        check("990 records, 1 DOF" in out, "990 records of 1 DOF")
        check("cycles 0..999 (decimation 1)" in out, "cycles 0..999, decimation 1")
        check("(10 missing)" in out, "the 10 missing records are counted")
        check("max 3.000 mm" in out, "the peak penetration is 3 mm")
        check("rtt_s (495 measurements, p50 2.7" in out, "495 round-trip measurements around 2.7 ms")
        check("time_s differences (989)" in out, "989 periods")
        # 990 records: 50 handshaking, 100 aligning, 840 engaged, entered twice (at 50 and at 700).
        check("engagement (2 engagements, engaged in 84.8 % of records)" in out, "two engagements, 840 of 990 engaged")

        # 3. Not telemetry.
        bad = os.path.join(tmp, "bad.csv")
        with open(bad, "w") as f:
            f.write("time_s,x\n0,1\n")
        rc, out, err = plot(args.plot, [bad])
        check(rc == 1 and "missing columns: cycle" in err and "flags" in err, f"a foreign CSV is refused: {err.strip()}")


if __name__ == "__main__":
    run_test(main)
