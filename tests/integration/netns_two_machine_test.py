#!/usr/bin/env python3
"""Two machines on one host: teleop-slave and teleop-master in two network namespaces joined by a veth pair.

Each process has its own network stack and its own address (master 10.77.0.1, slave 10.77.0.2, a /30 that exists
only inside the two namespaces this test creates), so the samples cross a real (virtual) Ethernet link instead of
loopback. The test runs the shipped rig configs (deploy/configs/loopback/*.yaml) with only the real-time settings
relaxed for a shared test machine, and checks the run from both summaries: delivery, loss, round trip, tracking,
the fixture; and from the veth counters that the traffic really went over the link.

  --transport udp           the UDP rig configs, master-udp.yaml / slave-udp.yaml
  --transport emulated-can  the CAN rig configs with the SocketCAN interface swapped for the emulated bus daemon
                            (teleop-canbus) running in the slave's namespace: the master reaches the bus over the veth.
                            Real SocketCAN runs in the qemu guest (tests/qemu, docs/qemu-can.md).
  --units DIR               (udp) run each process as its systemd unit (DIR/teleop-<role>.service) ships: the unit's
                            own ExecStart arguments in a staged root (/etc/teleop/<role>.yaml, /var/lib/teleop as the
                            working and state directory), as an unprivileged user standing in for DynamicUser=yes
                            (nobody), with root's /etc/teleop/teleop.key (0600) present but unreadable to it and the
                            key handed over only as the unit's LoadCredential= names it: a copy in
                            $CREDENTIALS_DIRECTORY (run/credentials/teleop-<role>.service/, owned by that user, 0400:
                            systemd's layout where it cannot set an ACL). First the slave without the variable: it
                            must refuse to start (status 2, the key unreadable: the deployment's old defect).

Exit 77 (ctest: skipped) with a message only when network namespaces cannot be created here (not root, no
CAP_SYS_ADMIN, no iproute2). The namespaces are deleted on every exit path, failures included; their names carry the
process id so that parallel runs never collide.
"""
import argparse
import atexit
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "test_utilities"))
import teleop_keys  # noqa: E402  (tests/test_utilities)
from teleop_process import Failure, Output, check, parse_unit  # noqa: E402

SKIP = 77
MASTER_ADDR = "10.77.0.1"
SLAVE_ADDR = "10.77.0.2"


def run(cmd, check_rc=True):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if check_rc and r.returncode != 0:
        raise Failure(f"{' '.join(cmd)} failed ({r.returncode}): {r.stdout.strip()}")
    return r


class Namespaces:
    """Two namespaces and a veth pair; removed by close() whatever happened."""

    def __init__(self, tag):
        self.master = f"tlp{tag}m"
        self.slave = f"tlp{tag}s"
        self.veth_master = f"tv{tag}m"[:15]
        self.veth_slave = f"tv{tag}s"[:15]
        self.created = []

    def create(self):
        for ns in (self.master, self.slave):
            r = run(["ip", "netns", "add", ns], check_rc=False)
            if r.returncode != 0:
                return r.stdout.strip()
            self.created.append(ns)
        run(["ip", "link", "add", self.veth_master, "netns", self.master, "type", "veth", "peer", "name",
             self.veth_slave, "netns", self.slave])
        for ns, dev, addr in ((self.master, self.veth_master, MASTER_ADDR), (self.slave, self.veth_slave, SLAVE_ADDR)):
            run(["ip", "-n", ns, "link", "set", "lo", "up"])
            run(["ip", "-n", ns, "addr", "add", f"{addr}/30", "dev", dev])
            run(["ip", "-n", ns, "link", "set", dev, "up"])
        return None

    def exec(self, ns, cmd):
        return ["ip", "netns", "exec", ns] + cmd

    def tx_packets(self, ns, dev):
        out = run(["ip", "-n", ns, "-s", "-j", "link", "show", dev]).stdout
        return json.loads(out)[0]["stats64"]["tx"]["packets"]

    def close(self):
        for ns in self.created:
            # Deleting a namespace kills nothing by itself: the processes were waited for or killed before.
            subprocess.run(["ip", "netns", "del", ns], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        self.created = []


def relax_realtime(text):
    """The rig configs ask for SCHED_FIFO and locked memory (a deployed rig); a shared test machine gets neither."""
    text = re.sub(r"(?m)^(\s*fifo_priority:)\s*\d+", r"\1 0", text)
    text = re.sub(r"(?m)^(\s*lock_memory:)\s*\w+", r"\1 false", text)
    return re.sub(r"(?m)^(\s*cpu:)\s*-?\d+", r"\1 -1", text)


UNIT_USER = 65534  # nobody: stands in for the unit's transient DynamicUser= user


class AsShipped:
    """One process as its unit starts it, in a staged root (see --units)."""

    def __init__(self, units, role, stage, binary, config_text, key_text):
        self.role = role
        service = parse_unit(os.path.join(units, f"teleop-{role}.service"))["Service"]
        check(service.get("DynamicUser") == ["yes"], f"teleop-{role}.service: DynamicUser=yes")
        creds = [c.split(":", 1) for c in service.get("LoadCredential", [])]
        check(len(creds) == 1 and creds[0][1] == "/etc/teleop/teleop.key",
              f"teleop-{role}.service: LoadCredential=NAME:/etc/teleop/teleop.key ({service.get('LoadCredential')})")
        name = creds[0][0]
        check(service.get("WorkingDirectory") == ["/var/lib/teleop"] and service.get("StateDirectory") == ["teleop"],
              f"teleop-{role}.service: works in its state directory /var/lib/teleop")
        # The root is outside the build tree (which may sit in a private 0700 directory, as a mktemp clone does, that
        # the unit's user cannot enter), and the binary is copied into it as the package installs it.
        self.root = os.path.join(stage, f"root-{role}")
        etc, self.state = os.path.join(self.root, "etc/teleop"), os.path.join(self.root, "var/lib/teleop")
        self.creds = os.path.join(self.root, f"run/credentials/teleop-{role}.service")
        bindir = os.path.join(self.root, "usr/bin")
        for d in (etc, self.state, self.creds, bindir):
            os.makedirs(d)
        for d in (self.root, os.path.dirname(etc), etc, os.path.dirname(os.path.dirname(self.state)),
                  os.path.dirname(self.state), os.path.dirname(self.creds), os.path.join(self.root, "run"),
                  os.path.dirname(bindir), bindir):
            os.chmod(d, 0o755)
        self.binary = os.path.join(bindir, f"teleop-{role}")
        shutil.copy2(binary, self.binary)
        os.chmod(self.binary, 0o755)
        with open(os.path.join(etc, f"{role}.yaml"), "w") as f:
            f.write(config_text)
        os.chmod(os.path.join(etc, f"{role}.yaml"), 0o644)
        # root's key where docs/deployment.md puts it: private, so the service's user cannot open it.
        self.root_key = os.path.join(etc, "teleop.key")
        for path, owner in ((self.root_key, 0), (os.path.join(self.creds, name), UNIT_USER)):
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
            with os.fdopen(fd, "w") as f:
                f.write(key_text)
            os.chown(path, owner, owner)
        os.chmod(os.path.join(self.creds, name), 0o400)  # as systemd writes a credential
        os.chown(self.creds, UNIT_USER, UNIT_USER)
        os.chmod(self.creds, 0o500)
        os.chown(self.state, UNIT_USER, UNIT_USER)
        self.argv = [a.replace("/etc/teleop", etc).replace("/var/lib/teleop", self.state)
                     for a in service["ExecStart"][0].split()[1:]]
        self.summary = os.path.join(self.state, f"{role}-summary.json")
        check(f"--summary-json {self.summary}" in " ".join(self.argv),
              f"teleop-{role}.service writes its summary to /var/lib/teleop/{role}-summary.json")

    def command(self, ns, extra, with_credentials=True):
        env = ["env", "-u", "CREDENTIALS_DIRECTORY"] + ([f"CREDENTIALS_DIRECTORY={self.creds}"] if with_credentials
                                                        else [])
        drop = ["setpriv", f"--reuid={UNIT_USER}", f"--regid={UNIT_USER}", "--clear-groups", "--"]
        return ns.exec(ns.master if self.role == "master" else ns.slave, env + drop + [self.binary] + self.argv + extra)


def to_emulated_bus(text, bus):
    """SocketCAN interface -> the emulated bus daemon at `bus` (same frames, same budget, no AF_CAN needed)."""
    if not re.search(r"(?m)^\s*transport:\s*can\b", text):
        raise Failure("the CAN rig config does not say transport: can")
    text = re.sub(r"(?m)^(\s*)transport:\s*can\b", r"\1transport: emulated-can", text)
    return re.sub(r"(?m)^(\s*)interface:.*$", rf'\1bus: "{bus}"', text)


def load(path):
    with open(path) as f:
        return json.load(f)


def remove_stale_namespaces():
    """Namespaces a killed earlier run left behind (tlp<pid>..): removed when that process is gone."""
    listing = run(["ip", "netns", "list"], check_rc=False).stdout
    for name in re.findall(r"(?m)^(tlp(\d+)[uc][ms])\b", listing):
        ns, pid = name
        if not os.path.exists(f"/proc/{pid}"):
            subprocess.run(["ip", "netns", "del", ns], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            print(f"removed namespace {ns} left by an earlier run")


def stop_on_signal(signum, _frame):
    raise Failure(f"stopped by signal {signum} (ctest timeout?)")


def main():
    signal.signal(signal.SIGTERM, stop_on_signal)
    signal.signal(signal.SIGINT, stop_on_signal)
    ap = argparse.ArgumentParser()
    ap.add_argument("--master", required=True)
    ap.add_argument("--slave", required=True)
    ap.add_argument("--canbus", help="teleop-canbus (for --transport emulated-can)")
    ap.add_argument("--configs", required=True, help="deploy/configs/loopback")
    ap.add_argument("--transport", required=True, choices=["udp", "emulated-can"])
    ap.add_argument("--workdir", required=True)
    ap.add_argument("--units", help="deploy/systemd: run the UDP pair as the units ship (see the docstring)")
    args = ap.parse_args()

    if shutil.which("ip") is None:
        print("SKIPPED: iproute2 (ip) is not installed, so no network namespaces can be created")
        return SKIP
    os.makedirs(args.workdir, exist_ok=True)
    remove_stale_namespaces()
    ns = Namespaces(f"{os.getpid()}{'u' if args.transport == 'udp' else 'c'}")
    procs = []
    try:
        err = ns.create()
        if err is not None:
            print(f"SKIPPED: cannot create a network namespace here ({err}); this test needs root or CAP_SYS_ADMIN "
                  "(it runs in CI as root)")
            return SKIP
        print(f"namespaces {ns.master} ({MASTER_ADDR}) and {ns.slave} ({SLAVE_ADDR}) joined by veth "
              f"{ns.veth_master}/{ns.veth_slave}")
        return run_pair(args, ns, procs)
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
                p.wait()
        ns.close()
        leftover = run(["ip", "netns", "list"], check_rc=False).stdout
        if ns.master in leftover or ns.slave in leftover:
            print(f"FAILED: namespace {ns.master} or {ns.slave} was not removed")
            sys.exit(1)


def run_pair(args, ns, procs):
    suffix = "udp" if args.transport == "udp" else "can"
    cfgs = {}
    for role in ("master", "slave"):
        text = relax_realtime(open(os.path.join(args.configs, f"{role}-{suffix}.yaml")).read())
        if args.transport == "emulated-can":
            text = to_emulated_bus(text, f"{SLAVE_ADDR}:47300")
        else:
            check(f"{MASTER_ADDR}:" in text and f"{SLAVE_ADDR}:" in text,
                  f"{role}-udp.yaml binds/peers the two machines' addresses {MASTER_ADDR} and {SLAVE_ADDR}")
        cfgs[role] = os.path.join(args.workdir, f"{role}.yaml")
        with open(cfgs[role], "w") as f:
            f.write(text)
    key = teleop_keys.ensure_key(args.workdir)  # the UDP rig configs: key_file teleop.key beside the config
    mjson = os.path.join(args.workdir, "master.json")
    sjson = os.path.join(args.workdir, "slave.json")
    for p in (mjson, sjson):
        if os.path.exists(p):
            os.remove(p)
    shipped = None
    if args.units and args.transport == "udp":
        if shutil.which("setpriv") is None:
            raise Failure("setpriv (util-linux) is missing: it runs the processes as the units' unprivileged user")
        key_text = open(key).read()
        stage = tempfile.mkdtemp(prefix="teleop-units-", dir="/tmp")  # /tmp: every user may pass through it
        atexit.register(shutil.rmtree, stage, True)
        os.chmod(stage, 0o755)
        binaries = {"master": args.master, "slave": args.slave}
        shipped = {role: AsShipped(args.units, role, stage, binaries[role], open(cfgs[role]).read(), key_text)
                   for role in ("master", "slave")}
        for role in ("master", "slave"):
            st = os.stat(shipped[role].root_key)
            check(st.st_uid == 0 and (st.st_mode & 0o777) == 0o600,
                  f"{role}: root's /etc/teleop/teleop.key is there, 0600, the unit's user (uid {UNIT_USER}) cannot "
                  "read it")
        mjson, sjson = shipped["master"].summary, shipped["slave"].summary

    # The loopback master is unreachable from the slave's namespace and vice versa: only the veth joins them.
    r = run(ns.exec(ns.master, ["ip", "-4", "-o", "addr", "show"]))
    check(SLAVE_ADDR not in r.stdout, "the slave's address is not local to the master's namespace")

    if args.transport == "emulated-can":
        bus = subprocess.Popen(ns.exec(ns.slave, [args.canbus, "--bind", SLAVE_ADDR, "--port", "47300",
                                                   "--bitrate", "1000000", "--duration-s", "20",
                                                   "--stats-every-s", "0"]),
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        procs.append(bus)
        bus_out = Output(bus)
        if not bus_out.wait_for("listening", 10):
            raise Failure("teleop-canbus did not start:\n" + bus_out.text())

    if shipped is not None:
        # The deployment's old defect: the unit's user cannot open root's key. Without the credential the slave must
        # refuse to start, naming the key file (the check can fail: this is what the units did before).
        s = shipped["slave"]
        r = subprocess.run(s.command(ns, ["--duration", "0.2"], with_credentials=False),
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=60, cwd=s.state)
        check(r.returncode == 2 and "teleop.key" in r.stdout and "Permission denied" in r.stdout,
              f"as the unit's user without $CREDENTIALS_DIRECTORY the slave cannot open root's key and refuses to "
              f"start (status {r.returncode}): {r.stdout.strip().splitlines()[-1] if r.stdout.strip() else ''}")
        slave_cmd = s.command(ns, ["--duration", "10"])
        master_cmd = shipped["master"].command(ns, ["--duration", "3"])
        print(f"as shipped: {' '.join(slave_cmd)}")
    else:
        slave_cmd = ns.exec(ns.slave, [args.slave, "--config", cfgs["slave"], "--duration", "10",
                                       "--summary-json", sjson])
        master_cmd = ns.exec(ns.master, [args.master, "--config", cfgs["master"], "--duration", "3",
                                         "--summary-json", mjson])
    slave = subprocess.Popen(slave_cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                             cwd=shipped["slave"].state if shipped else None)
    procs.append(slave)
    slave_out = Output(slave)
    if not slave_out.wait_for("DOF at", 60):
        slave.kill()
        raise Failure("teleop-slave did not start its loop:\n" + slave_out.text())
    master = subprocess.Popen(master_cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                              cwd=shipped["master"].state if shipped else None)
    procs.append(master)
    master_out = Output(master)
    try:
        master.wait(timeout=90)
        slave.wait(timeout=30)
    except subprocess.TimeoutExpired:
        raise Failure("processes did not stop:\n" + master_out.text() + slave_out.text())
    print("---- master output ----\n" + master_out.text())
    print("---- slave output ----\n" + slave_out.text())

    check(master.returncode == 0, f"master exits 0 (got {master.returncode})")
    check(slave.returncode == 0, f"slave exits 0 (got {slave.returncode})")
    m, s = load(mjson), load(sjson)
    if shipped is not None:
        for name, x in (("master", m), ("slave", s)):
            mode = x.get("security", {}).get("mode")
            check(mode == "psk", f"{name}, as its unit starts it (uid {UNIT_USER}, the key only as the credential): "
                                 f"its summary in /var/lib/teleop, link authenticated (security mode {mode})")
    check(s["stop_reason"] == "peer shutdown", f"the slave stopped on the master's shutdown ({s['stop_reason']})")
    check(m["stop_reason"] == "duration", f"the master ran its 3 s ({m['stop_reason']})")
    for name, x in (("master", m), ("slave", s)):
        pk = x["packets"]
        check(x["cycles"] > 1000, f"{name} ran {x['cycles']} cycles ({x['achieved_rate_hz']:.0f} Hz achieved)")
        # An authenticated link (the UDP rig configs) sends nothing before its session: send_no_session.
        security = x.get("security", {})
        unsent = security.get("send_no_session", 0)
        check(pk["sent"] + unsent >= x["cycles"], f"{name} sent {pk['sent']} samples, one per cycle ({unsent} before "
                                                  "the session)")
        check(pk["send_errors"] == 0, f"{name} had no send errors")
        # A late welcome after a retried hello is refused (bad_handshake_tag / unexpected_handshake): a handshake
        # race on a slow start, harmless; anything else is not.
        reasons = security.get("rejected_by_reason", {})
        rejected = pk["rejected"] - reasons.get("bad_handshake_tag", 0) - reasons.get("unexpected_handshake", 0)
        check(rejected == 0, f"{name} rejected nothing ({pk['rejected']}, of which {pk['rejected'] - rejected} a "
                             "handshake race)")
        check(x["cycles_with_peer"] > 0.5 * x["cycles"] if name == "master" else x["cycles_with_peer"] > 1000,
              f"{name} was coupled for {x['cycles_with_peer']} cycles")
        check(pk["lost"] <= 0.01 * pk["accepted"] + 2, f"{name} lost {pk['lost']} of {pk['accepted']} (a veth: ~none)")
        check(x["nonfinite_inputs"] == 0 and x["device_fault_cycles"] == 0, f"{name} had no faults")
        check(x["tracking_error_rms_m"] < 0.005, f"{name} tracking error rms {x['tracking_error_rms_m'] * 1e3:.3f} mm")
    # Delivery: what one side sent, the other received (less what was still in flight at the end).
    check(s["packets"]["received"] >= 0.98 * m["packets"]["sent"],
          f"the slave received {s['packets']['received']} of the master's {m['packets']['sent']} samples")
    # The slave sent one sample per cycle while the master was there (its cycles with a fresh peer): the master must
    # have received them (not "one per master cycle": on a loaded machine the slave's loop can run slower).
    check(m["packets"]["received"] >= 0.98 * s["cycles_with_peer"] - 5,
          f"the master received {m['packets']['received']} samples; the slave ran {s['cycles_with_peer']} cycles "
          "coupled to it")
    if args.transport == "udp":
        for name, x in (("master", m), ("slave", s)):
            check(x["rtt_ms"]["count"] >= 0.9 * x["packets"]["accepted"],
                  f"{name} measured {x['rtt_ms']['count']} round trips")
            check(0 < x["rtt_ms"]["p50"] < 20, f"{name} round trip p50 {x['rtt_ms']['p50']:.3f} ms over the veth")
    else:
        check(m["rtt_ms"]["count"] == 0, "CAN frames carry no timestamps: no round trip claimed")
        check("bus" in m["link_detail"] or "frames" in m["link_detail"], f"CAN link detail: {m['link_detail']}")
    check(s["fixture_max_penetration_m"] > 0, "the operator pushed the slave into its fixture")
    check(s["fixture_max_penetration_m"] < 0.005,
          f"the fixture held the slave within 5 mm ({s['fixture_max_penetration_m'] * 1e3:.3f} mm)")
    # The samples went over the veth, not some loopback: its counters saw at least every sample the master sent.
    tx = ns.tx_packets(ns.master, ns.veth_master)
    check(tx >= m["packets"]["sent"], f"veth {ns.veth_master} sent {tx} packets >= the master's {m['packets']['sent']}")
    return 0


if __name__ == "__main__":
    try:
        rc = main()
    except Failure as e:
        print(f"FAILED: {e}")
        sys.exit(1)
    if rc == 0:
        print("PASSED")
    sys.exit(rc)
