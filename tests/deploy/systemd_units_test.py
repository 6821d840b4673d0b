#!/usr/bin/env python3
"""The systemd units of deploy/systemd/ parse and say what docs/deployment.md promises.

systemd-analyze verify needs no running systemd: it loads the units into a throw-away manager under --root, a staged
file system with the units, the binaries at their packaged paths (/usr/bin, /usr/share/teleop) and the host's own
system units (for network-online.target and friends). Any message it prints fails the test (it reports unknown keys
only as warnings). A deliberately broken copy must be caught, so the check itself can fail.

Then the restart policy against the processes' exit statuses (common/include/teleop/node/exit_codes.hpp) and the
real-time limits against the rig configs.

The key as shipped: the units pass /etc/teleop/teleop.key as the systemd credential teleop.key (LoadCredential=),
the config the .deb installs as /etc/teleop/<role>.yaml names that file, and the real process, started with the
unit's own ExecStart arguments and CREDENTIALS_DIRECTORY set as systemd sets it, reads the credential where the
key beside the config does not exist (the transient user could not read root's file); without the variable it
refuses to start with a message naming the key.
"""
import argparse
import glob
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "test_utilities"))
from teleop_keys import write_key  # noqa: E402
from teleop_process import (Failure, check, free_udp_port, parse_unit, relax_realtime, run, run_test,  # noqa: E402
                            set_ports)


def exit_codes(header):
    text = open(header).read()
    return {name: int(value) for name, value in re.findall(r"constexpr int (kExit\w+) = (\d+);", text)}


def stage(root, units_dir, binaries):
    sysdir = os.path.join(root, "usr/lib/systemd/system")
    shutil.copytree("/usr/lib/systemd/system", sysdir, symlinks=True)
    for unit in glob.glob(os.path.join(units_dir, "*.service")):
        shutil.copy(unit, sysdir)
    for src, dst in binaries:
        os.makedirs(os.path.dirname(root + dst), exist_ok=True)
        shutil.copy(src, root + dst)
    return sysdir


def verify(root, names):
    r = subprocess.run(["systemd-analyze", "verify", "--man=no", f"--root={root}"] + names,
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    return r.returncode, r.stdout.strip()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--units", required=True)
    ap.add_argument("--master", required=True)
    ap.add_argument("--slave", required=True)
    ap.add_argument("--can-up", required=True)
    ap.add_argument("--exit-codes", required=True)
    ap.add_argument("--configs", required=True)
    args = ap.parse_args()
    if shutil.which("systemd-analyze") is None or not os.path.isdir("/usr/lib/systemd/system"):
        raise Failure("systemd-analyze is missing: apt-get install systemd (it is in TELEOP_PACKAGES)")

    names = ["teleop-master.service", "teleop-slave.service", "teleop-can-up@can0.service"]
    with tempfile.TemporaryDirectory(prefix="teleop-units-") as root:
        sysdir = stage(root, args.units, [(args.master, "/usr/bin/teleop-master"),
                                          (args.slave, "/usr/bin/teleop-slave"),
                                          (args.can_up, "/usr/share/teleop/can-up.sh"),
                                          (shutil.which("ip") or "/usr/sbin/ip", "/usr/sbin/ip")])
        rc, out = verify(root, names)
        print(out)
        check(rc == 0 and out == "", "systemd-analyze verify: the three units load with no message")

        broken = os.path.join(sysdir, "teleop-master.service")
        text = open(broken).read()
        with open(broken, "w") as f:
            f.write(text.replace("LimitRTPRIO=", "LimitRTPRIOO=", 1))
        rc, out = verify(root, ["teleop-master.service"])
        check("LimitRTPRIOO" in out, f"a misspelt key is reported ({out.splitlines()[0] if out else 'nothing'})")
        with open(broken, "w") as f:
            f.write(text.replace("ExecStart=/usr/bin/teleop-master", "ExecStart=/usr/bin/teleop-mastr", 1))
        rc, out = verify(root, ["teleop-master.service"])
        check(rc != 0 and "teleop-mastr" in out, "a wrong binary path is reported")

    codes = exit_codes(args.exit_codes)
    check({"kExitOk", "kExitConfigError", "kExitUnexpectedError", "kExitFaulted",
           "kExitNeverConnected"} <= codes.keys(),
          f"exit statuses read from exit_codes.hpp: {codes}")
    never = {codes["kExitConfigError"], codes["kExitUnexpectedError"], codes["kExitFaulted"]}
    fifo = [int(p) for c in glob.glob(os.path.join(args.configs, "**/*.yaml"), recursive=True)
            for p in re.findall(r"(?m)^\s*fifo_priority:\s*(\d+)", open(c).read())]
    for role in ("master", "slave"):
        u = parse_unit(os.path.join(args.units, f"teleop-{role}.service"))
        s = u["Service"]
        exec_start = s["ExecStart"][0]
        check(exec_start.startswith(f"/usr/bin/teleop-{role} ") and f"/etc/teleop/{role}.yaml" in exec_start,
              f"{role}: ExecStart runs /usr/bin/teleop-{role} on /etc/teleop/{role}.yaml")
        check(s["Restart"] == ["always"], f"{role}: Restart=always (a clean stop comes back to wait for the peer)")
        prevent = " ".join(s["RestartPreventExitStatus"]).split()
        numbers = {int(x) for x in prevent if x.isdigit() and int(x) < 100}
        cli = {int(x) for x in prevent if x.isdigit() and int(x) >= 100}
        check(cli == {105, 106, 109}, f"{role}: a bad command line (CLI11 105, 106, 109) is not restarted")
        check(numbers == never, f"{role}: never restarted after statuses {sorted(never)} (set-up error, unexpected, "
              f"latched fault), got {sorted(numbers)}")
        check(codes["kExitOk"] not in numbers, f"{role}: a clean stop (status 0) is restarted")
        check({"SIGSEGV", "SIGABRT"} <= set(prevent), f"{role}: never restarted after a crash")
        check(s["CPUSchedulingPolicy"] == ["fifo"], f"{role}: CPUSchedulingPolicy=fifo")
        rtprio = int(s["LimitRTPRIO"][0])
        check(fifo and rtprio >= max(fifo), f"{role}: LimitRTPRIO={rtprio} admits every rig's fifo_priority "
              f"(max {max(fifo) if fifo else '?'})")
        check(int(s["CPUSchedulingPriority"][0]) < min(p for p in fifo if p > 0),
              f"{role}: the process's base priority is below its loop's")
        check(s["LimitMEMLOCK"] == ["infinity"], f"{role}: LimitMEMLOCK=infinity (realtime.lock_memory)")
        check(s.get("StartLimitBurst") is None and "StartLimitBurst" in u["Unit"],
              f"{role}: restarts are rate-limited ([Unit] StartLimitBurst)")
    check_credentials(args)


def check_credentials(args):
    """The units' LoadCredential= against the installed configs, and the process finding the credential."""
    for role in ("master", "slave"):
        s = parse_unit(os.path.join(args.units, f"teleop-{role}.service"))["Service"]
        check(s.get("DynamicUser") == ["yes"], f"{role}: DynamicUser=yes (the case a root-owned key file fails)")
        creds = [c.split(":", 1) for c in s.get("LoadCredential", [])]
        check(creds == [["teleop.key", "/etc/teleop/teleop.key"]],
              f"{role}: LoadCredential=teleop.key:/etc/teleop/teleop.key ({s.get('LoadCredential')})")
        # The .deb installs configs/loopback/<role>-udp.yaml as /etc/teleop/<role>.yaml
        # (deploy/cmake/teleop_package.cmake).
        shipped = open(os.path.join(args.configs, "loopback", f"{role}-udp.yaml")).read()
        key = re.search(r"(?m)^\s*key_file:\s*(\S+)", shipped)
        named = key and (key.group(1) if key.group(1).startswith(("/", "credential:"))
                         else os.path.join("/etc/teleop", key.group(1)))
        check(named in ("/etc/teleop/teleop.key", "credential:teleop.key"),
              f"{role}: the installed config's key_file ({key and key.group(1)}) is the unit's credential")

    # The slave as the unit starts it (its own ExecStart arguments, paths under a staged root), alone for 0.3 s.
    s = parse_unit(os.path.join(args.units, "teleop-slave.service"))["Service"]
    argv = s["ExecStart"][0].split()
    with tempfile.TemporaryDirectory(prefix="teleop-creds-") as root:
        etc, state = os.path.join(root, "etc/teleop"), os.path.join(root, "var/lib/teleop")
        creds = os.path.join(root, "run/credentials/teleop-slave.service")
        for d in (etc, state, creds):
            os.makedirs(d)
        text = open(os.path.join(args.configs, "loopback", "slave-udp.yaml")).read()
        text = set_ports(re.sub(r"10\.77\.0\.\d", "127.0.0.1", relax_realtime(text)),
                         (free_udp_port(), free_udp_port()))
        with open(os.path.join(etc, "slave.yaml"), "w") as f:
            f.write(text)
        write_key(os.path.join(creds, "teleop.key"))
        os.chmod(os.path.join(creds, "teleop.key"), 0o400)  # as systemd writes it
        os.chmod(creds, 0o500)
        cmd = [args.slave] + [a.replace("/etc/teleop", etc).replace("/var/lib/teleop", state) for a in argv[1:]]
        cmd += ["--duration", "0.3"]
        env = dict(os.environ, CREDENTIALS_DIRECTORY=creds)
        check(not os.path.exists(os.path.join(etc, "teleop.key")), "no key beside the config (only the credential)")
        rc, out, err = run(cmd, timeout_s=60, env=env)
        summary = os.path.join(state, "slave-summary.json")
        alone = exit_codes(args.exit_codes)["kExitNeverConnected"]  # alone: it never connects
        ok = rc == alone and os.path.exists(summary)
        check(ok, f"with CREDENTIALS_DIRECTORY the slave starts on the unit's arguments and reads the credential "
                  f"(status {rc}) {'' if ok else (out + err)[-600:]}")
        mode = json.load(open(summary)).get("security", {}).get("mode")
        check(mode == "psk", f"its link is authenticated with that key (security mode {mode})")
        env.pop("CREDENTIALS_DIRECTORY")
        rc, out, err = run(cmd, timeout_s=60, env=env)
        check(rc == 2 and "teleop.key" in out + err,
              f"without it the slave refuses to start (status {rc}, set-up error) naming the key file")


if __name__ == "__main__":
    run_test(main)
