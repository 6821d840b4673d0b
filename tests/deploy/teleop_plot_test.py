#!/usr/bin/env python3
"""deploy/teleop-plot on a real CSV and on a synthetic one with known content.

1. teleop-slave runs alone for a moment with --telemetry-csv: the real column layout. teleop-plot makes its seven
   PNGs from it (each a real PNG of plausible size) and reports no round trip (no peer answered).
2. A CSV with the real header and rows written here: 990 records of cycles 0..999 with cycles 500..509 missing, one
   5 ms period, a round trip of 2.5 ms measured every other cycle, a fixture penetration peaking at 3 mm, the peer lost
   in cycles 600..699. --list must report exactly those.
3. A file that is not telemetry is refused with the missing column names.
4. An arm's file (the real header plus 7 joints' joint_position_rad_i and joint_torque_Nm_i, known values): --list
   names the 7 joints and `--views joints` draws <stem>-joints.png (only); the real run's file (not an arm) has none.
5. deploy/teleop-session on a master without joints and an arm slave: one session file with every column of either,
   the master's joint cells empty and the slave's the values written; teleop-plot draws the session's joints. Files
   whose other columns differ are still refused.
"""
import json
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


def with_joints(header, src, dst, joints, position, torque):
    """`src` (a telemetry CSV whose header is `header`) with `joints` joint columns appended: position(c, i) and
    torque(c, i) for cycle c, joint i."""
    names = [f"joint_position_rad_{i}" for i in range(joints)] + [f"joint_torque_Nm_{i}" for i in range(joints)]
    lines = open(src).read().splitlines()
    out = [header + "," + ",".join(names)]
    for line in lines[1:]:
        c = int(line.split(",")[0])
        values = [position(c, i) for i in range(joints)] + [torque(c, i) for i in range(joints)]
        out.append(line + "," + ",".join(repr(v) for v in values))
    with open(dst, "w") as f:
        f.write("\n".join(out) + "\n")


def summary(path, role, csv_path, start_ns, offset_ns):
    with open(path, "w") as f:
        json.dump({"role": role, "telemetry_csv": csv_path, "software_version": "test",
                   "clock": {"start_monotonic_ns": start_ns, "peer_offset_ns": offset_ns,
                             "peer_offset_uncertainty_ns": 20000}}, f)


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

        # 4. An arm's file: the joints view, and none for a file without joints.
        check(not os.path.exists(os.path.join(tmp, "real-joints.png")), "no joints view for a device without joints")
        arm = os.path.join(tmp, "arm.csv")
        position = lambda c, i: 0.1 * i + 1e-4 * c  # noqa: E731
        with_joints(header, syn, arm, 7, position, lambda c, i: -2.0 * i)
        rc, out, err = plot(args.plot, [arm, "--out", tmp, "--views", "joints"])  # the others are drawn above
        print(out, err)
        check(rc == 0, "teleop-plot plots an arm's file")
        check("joint_position_rad_0..6, joint_torque_Nm_0..6 (7 joints)" in out, "the 7 joints are named")
        check(not os.path.exists(os.path.join(tmp, "arm-positions.png")), "--views joints draws only the joints")
        with open(os.path.join(tmp, "arm-joints.png"), "rb") as f:
            data = f.read()
        check(data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10000, f"arm-joints.png is a PNG ({len(data)} bytes)")

        # 5. A session of a master without joints and an arm slave.
        tool = os.path.join(os.path.dirname(os.path.abspath(args.plot)), "teleop-session")
        summary(os.path.join(tmp, "m.json"), "master", syn, 1_000_000_000, 500_000)
        summary(os.path.join(tmp, "s.json"), "slave", arm, 1_200_000_000, -500_000)
        session = os.path.join(tmp, "session.csv")
        rc, out, err = run([tool, os.path.join(tmp, "m.json"), os.path.join(tmp, "s.json"), "-o", session],
                           timeout_s=60)
        print(out, err)
        check(rc == 0, "teleop-session merges a master without joints and an arm slave")
        lines = open(session).read().splitlines()
        cols = lines[2].split(",")
        check(cols[1:len(header.split(",")) + 1] == header.split(",") and
              cols[-14:] == [f"joint_position_rad_{i}" for i in range(7)] + [f"joint_torque_Nm_{i}" for i in range(7)],
              "the session's columns: the shared ones, then the slave's 7 joints")
        master_rows = [r.split(",") for r in lines[3:] if r.startswith("master,")]
        slave_rows = [r.split(",") for r in lines[3:] if r.startswith("slave,")]
        check(len(master_rows) == 990 and len(slave_rows) == 990, "every row of both files")
        check(all(r[-14:] == [""] * 14 for r in master_rows), "the master's joint cells are empty")
        cycle = cols.index("cycle")
        check(all(float(r[cols.index("joint_position_rad_3")]) == position(int(r[cycle]), 3) and
                  float(r[cols.index("joint_torque_Nm_5")]) == -10.0 for r in slave_rows),
              "the slave's joint cells are the values written")
        rc, out, err = plot(args.plot, [session, "--out", tmp, "--views", "joints"])
        print(out, err)
        check(rc == 0 and os.path.exists(os.path.join(tmp, "session-joints.png")),
              "teleop-plot draws the session's joints")
        other = os.path.join(tmp, "other.csv")  # another dof: refused, naming the columns
        with open(other, "w") as f:
            f.write(header.replace("position_m_0", "position_m_0,position_m_1", 1) + "\n")
        summary(os.path.join(tmp, "s2.json"), "slave", other, 1_200_000_000, -500_000)
        rc, out, err = run([tool, os.path.join(tmp, "m.json"), os.path.join(tmp, "s2.json"), "-o", session],
                           timeout_s=60)
        check(rc == 1 and "different columns" in err and "position_m_1" in err,
              f"files whose other columns differ are refused: {err.strip()}")


if __name__ == "__main__":
    run_test(main)
