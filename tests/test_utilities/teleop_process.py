"""Helpers the Python process tests share (tests/deploy/*_test.py, tests/dds/two_pairs_test.py): the failure and
check protocol, free ports, config rewriting for a test machine, starting and always stopping processes, waiting for
output or a condition with a deadline, a tshark capture on lo, and the PASSED/FAILED/SKIPPED ending ctest reads.

Import from a test script with
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "test_utilities"))
    from teleop_process import Failure, check, ...

Debian python3 only. Nothing here sleeps a fixed time to wait for a condition: every wait polls with a deadline.
"""
import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time

SKIP = 77  # ctest SKIP_RETURN_CODE of these tests


class Failure(Exception):
    """A check that did not hold: the test prints FAILED with the message and exits 1."""


def check(cond, what):
    """Raises Failure(what) unless `cond`; prints "  ok: what" otherwise."""
    if not cond:
        raise Failure(what)
    print(f"  ok: {what}")


def run_test(main):
    """Runs main() and ends the process as ctest expects: 0 and PASSED when main returns 0 or None, its status when
    it returns another (SKIP prints nothing more: main says why), 1 and FAILED on Failure."""
    try:
        rc = main()
    except Failure as e:
        print(f"FAILED: {e}")
        sys.exit(1)
    rc = 0 if rc is None else rc
    if rc == 0:
        print("PASSED")
    sys.exit(rc)


_HANDED_OUT = set()
_HANDED_OUT_LOCK = threading.Lock()  # link_emulation_test asks from several threads at once
# The shipped configs' ports, which set_ports replaces: never handed out, so a replaced port is never read again as one.
TEMPLATE_PORTS = ("47001", "47002")


def free_udp_port(host="127.0.0.1", kind=socket.SOCK_DGRAM):
    """A port nobody uses on `host` right now (the kernel's choice), never one this process was given before (the
    kernel may offer a just-closed port again) and never a template port of the shipped configs: two processes told
    to bind and peer on the same port refuse to start."""
    for _ in range(1000):
        with socket.socket(socket.AF_INET, kind) as s:
            s.bind((host, 0))
            port = s.getsockname()[1]
        with _HANDED_OUT_LOCK:
            if port not in _HANDED_OUT and str(port) not in TEMPLATE_PORTS:
                _HANDED_OUT.add(port)
                return port
    raise RuntimeError("no fresh port after 1000 tries")


def set_ports(text, ports):
    """The shipped configs' ports 47001 and 47002 replaced by ports[0] and ports[1], in one pass. (Two replace()
    calls in a row gave bind == peer whenever ports[0] was 47002: integration.link_emulation failed on it.)"""
    return re.sub(r"\b4700([12])\b", lambda m: str(ports[int(m.group(1)) - 1]), text)


def run(cmd, timeout_s=60, **kwargs):
    """Runs `cmd` to completion: (status, stdout, stderr) as text."""
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=timeout_s, **kwargs)
    return r.returncode, r.stdout, r.stderr


# ---- configs ---------------------------------------------------------------------------------------------------

def relax_realtime(text):
    """The rig configs ask for SCHED_FIFO and locked memory (a deployed rig); a shared test machine gets neither."""
    text = re.sub(r"(?m)^(\s*fifo_priority:)\s*\d+", r"\1 0", text)
    text = re.sub(r"(?m)^(\s*lock_memory:)\s*\w+", r"\1 false", text)
    return re.sub(r"(?m)^(\s*cpu:)\s*-?\d+", r"\1 -1", text)


def to_emulated_bus(text, bus):
    """SocketCAN interface -> the emulated bus daemon at `bus` ("HOST:PORT"): same frames, same budget, no AF_CAN."""
    if not re.search(r"(?m)^\s*transport:\s*can\b", text):
        raise Failure("the CAN rig config does not say transport: can")
    text = re.sub(r"(?m)^(\s*)transport:\s*can\b", r"\1transport: emulated-can", text)
    return re.sub(r"(?m)^(\s*)interface:.*$", rf'\1bus: "{bus}"', text)


def set_key(text, key, value):
    """Sets the first `key:` line (any indentation) to `value` (YAML text); Failure when there is none."""
    new, n = re.subn(rf"(?m)^(\s*{re.escape(key)}:)[^\n#]*", rf"\g<1> {value}", text, count=1)
    if n != 1:
        raise Failure(f"test bug: no '{key}:' in the config")
    return new


def write_text(path, text):
    with open(path, "w") as f:
        f.write(text)
    return path


# ---- processes -------------------------------------------------------------------------------------------------

class Output:
    """A process's merged stdout/stderr collected on a thread, so the test can wait for a line."""

    def __init__(self, proc):
        self.lines = []
        self.cond = threading.Condition()
        self.thread = threading.Thread(target=self._read, args=(proc,), daemon=True)
        self.thread.start()

    def _read(self, proc):
        for line in proc.stdout:
            with self.cond:
                self.lines.append(line)
                self.cond.notify_all()

    def wait_for(self, text, timeout_s):
        """True once a line contains `text`; False after `timeout_s`."""
        deadline = time.monotonic() + timeout_s
        with self.cond:
            while not any(text in line for line in self.lines):
                left = deadline - time.monotonic()
                if left <= 0:
                    return False
                self.cond.wait(left)
        return True

    def text(self):
        self.thread.join(timeout=5)
        return "".join(self.lines)


class Processes:
    """The processes a test starts; `with Processes() as procs:` kills (SIGKILL) and reaps every one still running
    when the block ends, failures included, and closes their log files."""

    def __init__(self, env=None):
        self.env = env
        self.procs = {}
        self.logs = []

    def start(self, key, cmd, log_path=None, **kwargs):
        """Starts `cmd`. With `log_path` its output goes to that file; otherwise to a pipe (proc.stdout, text)."""
        kwargs.setdefault("env", self.env)
        if log_path is not None:
            log = open(log_path, "w")
            self.logs.append(log)
            proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, **kwargs)
        else:
            proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, **kwargs)
        self.procs[key] = proc
        return proc

    def __getitem__(self, key):
        return self.procs[key]

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.stop_all()
        return False

    def stop_all(self):
        """Kills (SIGKILL) and reaps every process still running; closes the log files."""
        for p in self.procs.values():
            if p.poll() is None:
                p.kill()
                p.wait()
        for log in self.logs:
            log.close()


def wait_until(predicate, timeout_s, what, interval_s=0.05):
    """Polls predicate() until it returns something true (returned) or `timeout_s` passes (Failure naming `what`)."""
    deadline = time.monotonic() + timeout_s
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() >= deadline:
            raise Failure(f"{what}: not within {timeout_s} s")
        time.sleep(interval_s)


def wait_for_udp_port(port, timeout_s, host="127.0.0.1"):
    """Waits until something has bound UDP `port` on `host` (a process listening), by trying to bind it."""
    def bound():
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            try:
                s.bind((host, port))
            except OSError:
                return True
            return False
    return wait_until(bound, timeout_s, f"a process bound UDP port {port}")


# ---- capture ---------------------------------------------------------------------------------------------------

TSHARK = "/usr/bin/tshark"


def start_capture(pcap, capture_filter, interface="lo", timeout_s=30):
    """Starts tshark writing `pcap` and waits until it captures. Returns the Popen, or None when capturing is not
    permitted here (the caller skips). Failure when tshark is missing or fails otherwise."""
    if not os.path.exists(TSHARK):
        raise Failure("tshark is not installed: apt-get install tshark (it is in TELEOP_PACKAGES)")
    cap = subprocess.Popen([TSHARK, "-i", interface, "-q", "-w", pcap, "-f", capture_filter],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    # tshark says "Capturing on 'Loopback: lo'" once the capture runs.
    line, deadline = "", time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        line = cap.stderr.readline()
        if "Capturing on" in line or not line:
            break
    if "Capturing on" in line:
        return cap
    cap.kill()
    rest = line + cap.stderr.read()
    if "permission" in rest.lower() or "not permitted" in rest.lower():
        print(f"SKIPPED: capturing on {interface} is not permitted here: {rest.strip()}")
        return None
    raise Failure(f"tshark did not start capturing: {rest.strip()}")


def stop_capture(cap, timeout_s=20):
    """Stops tshark the way it finishes its file (SIGINT), killing it if it does not."""
    cap.send_signal(signal.SIGINT)
    try:
        cap.wait(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        cap.kill()
        cap.wait()


def parse_unit(path):
    """[Section] -> {key: [values]} of a systemd unit file (comments and blank lines skipped)."""
    sections, current = {}, None
    for raw in open(path):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        m = re.match(r"\[(\w+)\]$", line)
        if m:
            current = sections.setdefault(m.group(1), {})
            continue
        key, _, value = line.partition("=")
        current.setdefault(key.strip(), []).append(value.strip())
    return sections
