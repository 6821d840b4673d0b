#!/usr/bin/env python3
"""Attacks on the authenticated link (docs/security.md): teleop-slave and teleop-master as real processes on
127.0.0.1 with the shipped configs (link.security.mode psk, loopback plant), attacked from this script.

During start-up (raw sockets; the slave is up, then the master starts):
  stub flood           hello stubs (6 bytes, "v2 hello") and forged hellos (the layout, a tag without the key), 4 per
                       ms from the master's port, until the pair has coupled: none may spend the handshake budget
  duplicated hello     every hello the master sends, captured on lo and sent twice more at once
  replayed hello       with each, a hello captured from an earlier master process (older timestamp)
While the pair is coupled (master alive):
  spoofed v1 sample    raw socket, source = the master's address and port, a valid version-1 sample (CRC right,
                       sequence a little ahead) commanding -0.5 m
  spoofed v2 frame     raw socket, same source: a captured frame's header (session id, sequence ahead), forged
                       ciphertext and tag
  spoofed shutdown     raw socket: version-1 samples with the shutdown flag, and captured frames whose encrypted
                       shutdown bit is flipped (a stream cipher lets anyone flip it; the tag does not)
  replay (live)        raw socket: captured genuine frames sent again, a second later
  huge sequence jump   raw socket: a genuine frame with its sequence raised by 2^40 (the header is authenticated
                       data), and a version-1 sample 2^31 ahead
  datagram flood       raw socket: 30 000 forged frames of the running session (fresh sequences, so each costs the
                       slave a full AEAD) as fast as this process sends, above the rejection bucket (20 000/s):
                       beyond it they are counted rate_limited, real frames never
  other-port flood     no privileges: 3000 forged frames from another port; the slave's socket is connect()ed to the
                       master, so the kernel drops them: nothing is counted at all
  re-handshake         the slave is stopped (SIGSTOP) for 0.2 s, so the master re-handshakes; its new hellos are
                       duplicated and the start-up's first hello replayed, and the stub flood runs, as at start-up
On the emulated CAN bus (teleop-canbus, --canbus):
  unprivileged attach  a process running as nobody says hello to the daemon and sends it a bus-off command: it must
                       get no welcome, the command must not act, and the daemon counts both refusals
  ... Unix socket      the same against `teleop-canbus --bind unix:PATH`: with the default mode 0600 the kernel
                       refuses nobody's connect (EACCES: nothing reaches the daemon); with 0666 the daemon reads
                       nobody's uid from SO_PEERCRED and refuses the hellos and the bus-off (counted)
Then the master is killed (SIGKILL), and:
  foreign stream       no privileges: a process binds the master's freed port and streams version-1 samples from
                       sequence 0 (commanding 0.25 m), plus hellos with a wrong key
  replay (master dead) from the master's port: the last captured frames, cyclically, for a second

Each row: what was sent, the slave's cycles in the window and how many of them coupled (engaged), its motion, the
counters. Each rejected attack: 100 % rejected and counted by reason (the slave's summary; the reason totals must
balance exactly), no forged value ever reaches the slave's law (its telemetry), the slave's motion is what it is
without the attack (excursion of the slave at rest, against a quiet window of the same phase), the pair stays
engaged through the floods and re-couples after the re-handshake, and after the master died the slave's watchdog is
never fed: every cycle from the timeout on has the peer-lost flag and a frozen peer input. Prints the table
docs/security.md shows.

Raw sockets (spoofing and capture) need root or CAP_NET_RAW; without them those rows are skipped with a message and
only the unprivileged attack runs.
"""
import argparse
import csv
import datetime
import json
import os
import random
import re
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time

sys.dont_write_bytecode = True  # imports from the source tree: leave no __pycache__ there
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "test_utilities"))
import teleop_keys  # noqa: E402  (tests/test_utilities)
from two_process_test import Failure, Output, check, free_udp_port, load, write_config  # noqa: E402

FLAG_ENABLED, FLAG_PEER_LOST, FLAG_SHUTDOWN = 1, 4, 32
FORGED_POSITIONS = (-0.5, 0.25)  # what the forgeries command; genuine positions stay within ±0.1 m here
START, LIVE, DEAD = "start", "live", "dead"


# ---- wire formats (docs/protocol.md), written out here rather than taken from the library -----------------------

def _crc32c_table():
    table = []
    for i in range(256):
        c = i
        for _ in range(8):
            c = (c >> 1) ^ 0x82F63B78 if c & 1 else c >> 1
        table.append(c)
    return table


CRC_TABLE = _crc32c_table()


def crc32c(data):
    c = 0xFFFFFFFF
    for b in data:
        c = CRC_TABLE[(c ^ b) & 0xFF] ^ (c >> 8)
    return c ^ 0xFFFFFFFF


def v1_sample(sequence, position, flags=FLAG_ENABLED, velocity=-12.0, force=-10.0, sender_time_ns=0):
    """A version-1 sample from the master, 1 DOF, CRC-32C right: exactly what the version-1 receiver accepted."""
    header = struct.pack("<IBBBBBBHIQQI", 0x504F4C54, 1, 1, 0, flags, 1, 0, 24, sequence & 0xFFFFFFFF,
                         sender_time_ns, 0, 0)
    body = header + struct.pack("<ddd", position, velocity, force)
    return body + struct.pack("<I", crc32c(body))


FRAME_SEQUENCE = slice(16, 24)


def frame_sequence(frame):
    return struct.unpack("<Q", frame[FRAME_SEQUENCE])[0]


def with_sequence(frame, sequence):
    return frame[:16] + struct.pack("<Q", sequence) + frame[24:]


def forged_frame(frame, sequence, rng):
    """The captured header (session id, length) with a new sequence; ciphertext and tag random."""
    return with_sequence(frame, sequence)[:28] + bytes(rng.getrandbits(8) for _ in range(len(frame) - 28))


def flipped_shutdown(frame, sequence):
    """The genuine ciphertext with the plaintext's shutdown flag bit flipped (flags at offset 7 of the sample)."""
    b = bytearray(with_sequence(frame, sequence))
    b[28 + 7] ^= FLAG_SHUTDOWN
    return bytes(b)


HELLO_TYPE, FRAME_TYPE = 6, 5


def bad_hello(rng):
    """A version-2 hello from "the master": random ephemeral key and timestamp, a MAC made without the PSK."""
    return struct.pack("<IBBBB", 0x504F4C54, 2, HELLO_TYPE, 0, 0) + bytes(rng.getrandbits(8) for _ in range(72))


HELLO_STUB = struct.pack("<IBB", 0x504F4C54, 2, HELLO_TYPE)  # 6 bytes that say "version 2 hello", nothing else


# ---- raw sockets: spoof the master's source port, capture its frames --------------------------------------------

class Raw:
    """IPv4 raw socket writing UDP datagrams with any source (root or CAP_NET_RAW)."""

    def __init__(self):
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_RAW, socket.IPPROTO_RAW)

    @staticmethod
    def packet(payload, src_port, dst_port):
        udp = struct.pack("!HHHH", src_port, dst_port, 8 + len(payload), 0)  # checksum 0: none (IPv4)
        ip = struct.pack("!BBHHHBBH4s4s", 0x45, 0, 20 + 8 + len(payload), 0, 0, 64, socket.IPPROTO_UDP, 0,
                         socket.inet_aton("127.0.0.1"), socket.inet_aton("127.0.0.1"))
        return ip + udp + payload

    def send(self, payload, src_port, dst_port):
        self.sock.sendto(self.packet(payload, src_port, dst_port), ("127.0.0.1", 0))


def capture(src_port, dst_port, seconds, message_type=FRAME_TYPE):
    """Genuine version-2 frames (or messages of `message_type`) from src_port to dst_port on lo, for `seconds`
    (AF_PACKET, root)."""
    s = socket.socket(socket.AF_PACKET, socket.SOCK_DGRAM, socket.htons(0x0800))
    s.bind(("lo", 0x0800))
    s.settimeout(0.05)
    frames = []
    end = time.monotonic() + seconds
    try:
        while time.monotonic() < end:
            try:
                data, addr = s.recvfrom(2048)
            except socket.timeout:
                continue
            if addr[2] == socket.PACKET_OUTGOING or len(data) < 28 or data[9] != socket.IPPROTO_UDP:
                continue
            ihl = (data[0] & 0x0F) * 4
            sport, dport = struct.unpack("!HH", data[ihl:ihl + 4])
            payload = data[ihl + 8:]
            if sport == src_port and dport == dst_port and len(payload) > 28 and payload[4] == 2 and \
                    payload[5] == message_type:
                frames.append(bytes(payload))
    finally:
        s.close()
    return frames


def raw_sockets_available():
    try:
        Raw().sock.close()
        socket.socket(socket.AF_PACKET, socket.SOCK_DGRAM, socket.htons(0x0800)).close()
        return True, ""
    except (PermissionError, OSError) as e:
        return False, str(e)


class HelloEcho(threading.Thread):
    """Watches lo for the master's hellos; each new one is sent twice more at once (duplicated) and followed by a
    replay of `old_hello` (an older, genuine hello), from the master's port, counted into the Attack objects
    `self.dup` and `self.replay` (None: not now)."""

    def __init__(self, raw, master_port, slave_port, old_hello):
        super().__init__(daemon=True)
        self.raw, self.master_port, self.slave_port, self.old_hello = raw, master_port, slave_port, old_hello
        self.dup = self.replay = None
        self.seen = {old_hello}
        self.stop = threading.Event()
        self.lock = threading.Lock()

    def run(self):
        s = socket.socket(socket.AF_PACKET, socket.SOCK_DGRAM, socket.htons(0x0800))
        s.bind(("lo", 0x0800))
        s.settimeout(0.02)
        try:
            while not self.stop.is_set():
                try:
                    data, addr = s.recvfrom(2048)
                except socket.timeout:
                    continue
                if addr[2] == socket.PACKET_OUTGOING or len(data) < 28 or data[9] != socket.IPPROTO_UDP:
                    continue
                ihl = (data[0] & 0x0F) * 4
                sport, dport = struct.unpack("!HH", data[ihl:ihl + 4])
                payload = bytes(data[ihl + 8:])
                if sport != self.master_port or dport != self.slave_port or len(payload) != 80 or \
                        payload[5] != HELLO_TYPE or payload in self.seen:
                    continue
                self.seen.add(payload)  # our own copies come by here too: each hello is echoed once
                with self.lock:
                    dup, replay = self.dup, self.replay
                if dup is not None:
                    for _ in range(2):
                        self.raw.send(payload, self.master_port, self.slave_port)
                        dup.sent += 1
                if replay is not None:
                    self.raw.send(self.old_hello, self.master_port, self.slave_port)
                    replay.sent += 1
        finally:
            s.close()

    def attach(self, dup, replay):
        with self.lock:
            self.dup, self.replay = dup, replay


def flood_until(send, make, per_ms, stop):
    """Sends make(i) per_ms times per millisecond until `stop` is set; returns the count."""
    n = 0
    while not stop.is_set():
        for _ in range(per_ms):
            send(make(n))
            n += 1
        time.sleep(0.001)
    return n


BUS_MAGIC = 0x31424354  # "TCB1", common/include/teleop/transport/can_bus_datagram.hpp


def _as_nobody():
    os.setgid(65534)
    os.setuid(65534)


CAN_ATTACKER = r"""
import socket, struct, sys, time
port = int(sys.argv[1])
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
s.connect(("127.0.0.1", port))
s.settimeout(0.02)
hellos = welcomes = 0
end = time.monotonic() + 0.5
while time.monotonic() < end:
    s.send(struct.pack("<IB", 0x31424354, 1))
    hellos += 1
    try:
        data = s.recv(64)
        if len(data) >= 6 and data[4] == 2:
            welcomes += 1
    except (socket.timeout, ConnectionRefusedError):
        pass
s.send(struct.pack("<IBBI", 0x31424354, 4, 2, 0))  # bus-off node 0
print(hellos, welcomes)
"""


CAN_UNIX_ATTACKER = r"""
import socket, struct, sys, time
path = sys.argv[1]
hellos = welcomes = denied = 0
s = socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET)
s.settimeout(0.02)
try:
    s.connect(path)
except PermissionError:
    denied += 1
    s = None
end = time.monotonic() + 0.3
while s is not None and time.monotonic() < end:
    hellos += 1
    s.send(struct.pack("<IB", 0x31424354, 1))
    try:
        data = s.recv(64)
        if len(data) >= 6 and data[4] == 2:
            welcomes += 1
    except socket.timeout:
        pass
if s is not None:
    s.send(struct.pack("<IBBI", 0x31424354, 4, 2, 0))  # bus-off node 0
    time.sleep(0.05)
print(hellos, welcomes, denied)
"""


def can_unix_attach_attack(canbus):
    """The unprivileged attach against a Unix-socket daemon, once with the default mode (0600: the kernel refuses)
    and once with 0666 (the daemon refuses by its SO_PEERCRED uid). Returns [(label, sent, rejected, reason)]."""
    rows = []
    for mode in ("0600", "0666"):
        # A short path nobody may traverse to (only the socket file's own mode decides), whatever the build dir is.
        d = tempfile.mkdtemp(prefix=f"teleop-canbus-{mode}-")
        os.chmod(d, 0o755)
        path = os.path.join(d, "canbus.sock")
        bus = subprocess.Popen([canbus, "--bind", "unix:" + path, "--socket-mode", mode, "--stats-every-s", "0"],
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        bus_out = Output(bus)
        try:
            for _ in range(100):
                if os.path.exists(path):
                    break
                time.sleep(0.01)
            r = subprocess.run([sys.executable, "-c", CAN_UNIX_ATTACKER, path], stdout=subprocess.PIPE,
                               stderr=subprocess.STDOUT, text=True, timeout=30, preexec_fn=_as_nobody)
            hellos, welcomes, denied = (int(x) for x in r.stdout.split()[:3])
            time.sleep(0.1)
        finally:
            bus.send_signal(signal.SIGTERM)
            bus.wait(timeout=30)
        m = re.search(r"(\d+) hellos and (\d+) control commands refused", bus_out.text())
        check(m is not None, "teleop-canbus (unix) printed its refusals")
        refused_hellos, refused_controls = int(m.group(1)), int(m.group(2))
        check(welcomes == 0, f"unix {mode}: the unprivileged process got no welcome ({welcomes} of {hellos})")
        check(re.search(r": 0 node\(s\)", bus_out.text()) is not None, f"unix {mode}: no node attached")
        check(not os.path.exists(path), f"unix {mode}: the daemon removed its socket file")
        os.rmdir(d)
        if mode == "0600":
            check(denied == 1 and hellos == 0 and refused_hellos == 0 and refused_controls == 0,
                  f"unix 0600: the kernel refused the connect ({denied}), nothing reached the daemon "
                  f"({refused_hellos} hellos, {refused_controls} commands)")
            rows.append(("... over a Unix socket, mode 0600 (connect refused: EACCES)", 1, denied,
                         "(kernel: EACCES, none counted)"))
        else:
            check(denied == 0 and refused_hellos == hellos and refused_controls == 1,
                  f"unix 0666: the daemon refused all {hellos} hellos ({refused_hellos}) and the bus-off "
                  f"({refused_controls}) by its SO_PEERCRED uid")
            rows.append(("... over a Unix socket, mode 0666 (SO_PEERCRED)", hellos + 1,
                         refused_hellos + refused_controls, "refused_hellos+refused_controls"))
    return rows


def can_attach_attack(canbus):
    """An unprivileged process attaching to teleop-canbus (run as root: the daemon as root, the attacker as nobody).
    Returns the row's figures."""
    port = free_udp_port()
    bus = subprocess.Popen([canbus, "--port", str(port), "--bitrate", "1000000", "--stats-every-s", "0"],
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    bus_out = Output(bus)
    try:
        time.sleep(0.3)
        r = subprocess.run([sys.executable, "-c", CAN_ATTACKER, str(port)], stdout=subprocess.PIPE,
                           stderr=subprocess.STDOUT, text=True, timeout=30, preexec_fn=_as_nobody)
        hellos, welcomes = (int(x) for x in r.stdout.split()[:2])
        time.sleep(0.1)
    finally:
        bus.send_signal(signal.SIGTERM)
        bus.wait(timeout=30)
    m = re.search(r"(\d+) hellos and (\d+) control commands refused", bus_out.text())
    check(m is not None, "teleop-canbus printed its refusals")
    refused_hellos, refused_controls = int(m.group(1)), int(m.group(2))
    check(welcomes == 0, f"the unprivileged process got no welcome ({welcomes} of {hellos} hellos answered)")
    check(refused_hellos == hellos and refused_controls == 1,
          f"the daemon refused all {hellos} hellos ({refused_hellos}) and the bus-off command ({refused_controls})")
    check(re.search(r": 0 node\(s\)", bus_out.text()) is not None, "no node attached")
    return hellos, refused_hellos + refused_controls


CAN_HEIR = r"""
import socket, struct, sys, time
bus_port, port, seconds, position = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4])
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
end = time.monotonic() + 2.0
while True:  # the port is free once the killed master's socket is closed
    try:
        s.bind(("127.0.0.1", port))
        break
    except OSError:
        if time.monotonic() > end:
            print("0 0 0 nobind")
            sys.exit(3)
        time.sleep(0.0005)
s.connect(("127.0.0.1", bus_port))
s.setblocking(False)
def frame(counter):
    # The master's 1-DOF classic frame (docs/can.md): counter, flags (enabled), position (14 bits, 20 um), layout bit.
    counts = int(round(position / 20e-6)) & 0x3FFF
    value = (counter & 0xF) | (1 << 4) | (counts << 11) | (1 << 48)
    return struct.pack("<IBBIB", 0x31424354, 3, 0, 0x100, 7) + value.to_bytes(7, "little")
frames = hellos = 0
t0 = time.monotonic()
s.send(struct.pack("<IB", 0x31424354, 1))  # a hello as the master's node would (refused: not the daemon's user)
hellos += 1
while time.monotonic() - t0 < seconds:
    try:
        s.send(frame(frames))
        frames += 1
    except (BlockingIOError, ConnectionRefusedError):
        pass
    time.sleep(0.001)
s.send(struct.pack("<IBBI", 0x31424354, 4, 2, 0))  # bus-off node 0 (the master's node), with its controller rights
print(frames, hellos, 1)
"""


def udp_port_of(pid, bus_port):
    """The local port of process `pid`'s UDP socket connected to 127.0.0.1:bus_port (from /proc: its fds' inodes)."""
    inodes = set()
    for fd in os.listdir(f"/proc/{pid}/fd"):
        try:
            link = os.readlink(f"/proc/{pid}/fd/{fd}")
        except OSError:
            continue
        m = re.match(r"socket:\[(\d+)\]", link)
        if m:
            inodes.add(m.group(1))
    with open("/proc/net/udp") as f:
        next(f)
        for line in f:
            fields = line.split()
            local, remote, inode = fields[1], fields[2], fields[9]
            if inode in inodes and int(remote.split(":")[1], 16) == bus_port:
                return int(local.split(":")[1], 16)
    raise Failure(f"no UDP socket of process {pid} connected to the bus port {bus_port}")


def can_inherit_attack(canbus, master, slave, configs, workdir):
    """Issue 31 item 14: the pair over teleop-canbus (UDP); the master is SIGKILLed (no bye) and a process running as
    nobody binds its freed port at once, says hello, sends the master's frames commanding 144 mm for 0.5 s and a
    bus-off for node 0. Returns the row's figures and the slave's coupled fraction and motion."""
    bus_port = free_udp_port()
    files = {n: os.path.join(workdir, n) for n in ("master-can.yaml", "slave-can.yaml", "slave-can.csv")}
    for name in ("master-can.yaml", "slave-can.yaml"):
        text = open(os.path.join(configs, name)).read().replace('"127.0.0.1:47300"', f'"127.0.0.1:{bus_port}"')
        # The start-up stability check (512 operators, seconds on a loaded CI machine) is not what this row tests.
        text = re.sub(r"(?m)^(\s*check:) true", r"\1 false", text)
        csv_path = files["slave-can.csv"] if name.startswith("slave") else ""
        text = re.sub(r"(?m)^(\s*csv:).*$", lambda m: f'{m.group(1)} "{csv_path}"', text)
        if not re.search(r"(?m)^safety:", text):
            text += f'\nsafety: {{fault_record_dir: "{workdir}"}}\n'
        with open(files[name], "w") as f:
            f.write(text)
    if os.path.exists(files["slave-can.csv"]):
        os.remove(files["slave-can.csv"])
    bus = subprocess.Popen([canbus, "--port", str(bus_port), "--stats-every-s", "0"], stdout=subprocess.PIPE,
                           stderr=subprocess.STDOUT, text=True)
    bus_out = Output(bus)
    time.sleep(0.2)
    sl = subprocess.Popen([slave, "--config", files["slave-can.yaml"], "--duration", "0"], stdout=subprocess.PIPE,
                          stderr=subprocess.STDOUT, text=True)
    sl_out = Output(sl)
    ma = subprocess.Popen([master, "--config", files["master-can.yaml"], "--duration", "0"],
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    ma_out = Output(ma)
    position = 0.144
    try:
        for _ in range(2000):  # both attached (their logs reach the pipe only when a buffer fills)
            try:
                udp_port_of(ma.pid, bus_port)
                udp_port_of(sl.pid, bus_port)
                break
            except (Failure, OSError):
                time.sleep(0.01)
        time.sleep(1.5)  # aligned and coupled (about 0.5 s after both attached, more under load)
        check(ma.poll() is None and sl.poll() is None, "the pair runs over teleop-canbus")
        port = udp_port_of(ma.pid, bus_port)
        coupled_t0 = wall_now() - 0.5
        coupled_t1 = wall_now()
        ma.kill()
        ma.wait(timeout=30)
        t0 = wall_now()
        r = subprocess.run([sys.executable, "-c", CAN_HEIR, str(bus_port), str(port), "0.5", str(position)],
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=30,
                           preexec_fn=_as_nobody)
        t1 = wall_now()
        fields = r.stdout.split()
        check(len(fields) == 3, f"the heir bound the master's freed port {port} ({r.stdout.strip()})")
        frames, hellos, controls = (int(x) for x in fields)
        time.sleep(0.2)
    finally:
        for p in (ma, sl, bus):
            if p.poll() is None:
                p.send_signal(signal.SIGTERM)
        for p in (ma, sl, bus):
            p.wait(timeout=30)
    text = bus_out.text()
    m = re.search(r"(\d+) malformed datagrams, (\d+) hellos and (\d+) control commands refused \(not allowed\), "
                  r"(\d+) nodes detached as silent and (\d+) as orphaned", text)
    check(m is not None, f"teleop-canbus printed its statistics line ({text.strip()[-300:]})")
    malformed, refused_hellos, refused_controls, silent, orphaned = (int(x) for x in m.groups())
    rows = read_telemetry(files["slave-can.csv"], start_wall_time(sl_out.text(), "teleop-slave"))
    window = between(rows, t0, t1 + 0.1)
    check(len(window) > 300, f"slave telemetry over the heir's window ({len(window)} cycles)")
    forged = sum(1 for r in window if abs(r["peer_position_m_0"] - position) < 1e-3)
    excursion = max(abs(r["position_m_0"] - window[0]["position_m_0"]) for r in window)
    before = between(rows, coupled_t0, coupled_t1)
    coupled_before = sum(1 for r in before if int(r["engagement"]) == 3)
    coupled = sum(1 for r in window if int(r["engagement"]) == 3)
    check(coupled_before == len(before) and len(before) > 300,
          f"the pair was coupled over the bus before the kill ({coupled_before} of {len(before)} cycles)")
    check(orphaned == 1, f"the daemon detached the dead master's node ({orphaned} orphaned)")
    check(refused_hellos == hellos and refused_controls == controls,
          f"the heir's hello ({refused_hellos} of {hellos}) and bus-off ({refused_controls} of {controls}) refused")
    # Frames sent before the daemon's next look-up of its nodes' sockets (every 10 ms) are still the dead node's:
    # at most ~10 at 1 kHz. Every later one comes from no node (malformed) and never reaches the bus.
    check(frames - malformed <= 15 and malformed >= frames - 15,
          f"the heir's frames came from no node: {malformed} of {frames} counted malformed")
    check(forged <= 15, f"the forged position reached the slave's law in {forged} cycles (at most the 10 ms window)")
    check(excursion < 1e-3, f"the slave did not follow the heir ({excursion*1e3:.3f} mm)")
    print(f"emulated CAN, master killed, nobody on its port: {frames} frames + {hellos} hello + {controls} bus-off; "
          f"daemon: {orphaned} orphaned, {malformed} malformed, {refused_hellos}+{refused_controls} refused; slave "
          f"coupled {coupled_before}/{len(before)} before, {coupled}/{len(window)} after; forged position in {forged} "
          f"cycles; excursion {excursion*1e3:.3f} mm")
    return (frames + hellos + controls, malformed + refused_hellos + refused_controls, f"{coupled}/{len(window)}",
            excursion)


# ---- telemetry on the wall clock ----------------------------------------------------------------------------------

def start_wall_time(output_text, program):
    """Wall time (seconds of the day) at which the loop started: the node's start-up line, logged just before it."""
    for line in output_text.splitlines():
        m = re.match(r"^\[(\d\d):(\d\d):(\d\d)\.(\d\d\d)\] \[" + program + r"\] \[info\] " + program + r": \d+ DOF",
                     line)
        if m:
            h, mi, s, ms = (int(x) for x in m.groups())
            return h * 3600 + mi * 60 + s + ms / 1000.0
    raise Failure(f"no start-up line from {program} (the test reads its time to align telemetry)")


def wall_now():
    now = datetime.datetime.now()
    return now.hour * 3600 + now.minute * 60 + now.second + now.microsecond / 1e6


def read_telemetry(path, start_wall):
    with open(path) as f:
        rows = [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]
    for r in rows:
        r["wall"] = start_wall + r["time_s"]
    return rows


def between(rows, t0, t1):
    return [r for r in rows if t0 <= r["wall"] <= t1]


# ---- the run ------------------------------------------------------------------------------------------------------

class Attack:
    """One row. `reasons`: the rejection reasons its datagrams are counted under (each one rejected). rejects=False:
    datagrams the slave accepts as handshake messages (duplicates: the cached welcome) or never sees (dropped by
    the kernel); they add nothing to `rejected`."""

    def __init__(self, name, phase, reasons, rejects=True):
        self.name, self.phase, self.reasons, self.rejects = name, phase, reasons, rejects
        self.sent = 0
        self.t0 = self.t1 = None

    def __enter__(self):
        self.t0 = wall_now()
        return self

    def __exit__(self, *exc):
        self.t1 = wall_now()


def paced(send, items, per_ms=2):
    """Sends `items` at about per_ms per millisecond: under the slave's datagram bucket (20000/s), so every one is
    judged rather than rate limited, and well inside its socket buffer."""
    n = 0
    for i, item in enumerate(items):
        send(item)
        n += 1
        if i % per_ms == per_ms - 1:
            time.sleep(0.001)
    return n


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--master", required=True)
    ap.add_argument("--slave", required=True)
    ap.add_argument("--configs", required=True)
    ap.add_argument("--workdir", required=True)
    ap.add_argument("--canbus", help="teleop-canbus, for the emulated-CAN row")
    args = ap.parse_args()
    os.makedirs(args.workdir, exist_ok=True)
    rng = random.Random(10)
    ports = (free_udp_port(), free_udp_port())
    master_port, slave_port = ports
    files = {n: os.path.join(args.workdir, n) for n in ("master.yaml", "slave.yaml", "master.csv", "slave.csv",
                                                        "slave.json")}
    for p in files.values():
        if os.path.exists(p):
            os.remove(p)
    write_config(os.path.join(args.configs, "master.yaml"), files["master.yaml"], ports, files["master.csv"])
    write_config(os.path.join(args.configs, "slave.yaml"), files["slave.yaml"], ports, files["slave.csv"])
    timeout_s = 0.050  # link.timeout_ms of the shipped configs
    check("mode: psk" in open(files["slave.yaml"]).read(), "the shipped slave config authenticates (mode psk)")

    privileged, why = raw_sockets_available()
    if not privileged:
        print(f"SKIPPED (no raw sockets: {why}): the spoofed-source, capture and replay attacks need root or "
              "CAP_NET_RAW; only the unprivileged foreign stream runs")

    attacks = []
    start_rows = []
    can_row = None
    can_unix_rows = []
    can_heir_row = None
    if args.canbus and os.geteuid() == 0:
        can_row = can_attach_attack(args.canbus)
        can_unix_rows = can_unix_attach_attack(args.canbus)
        can_heir_row = can_inherit_attack(args.canbus, args.master, args.slave, args.configs, args.workdir)
    elif args.canbus:
        print("SKIPPED the emulated-CAN row: it runs the attacker as another user (needs root)")
    echo = None
    old_hellos = []
    if privileged:
        # An earlier master process, alone (no slave yet): its hellos are the "older" ones replayed below.
        early = subprocess.Popen([args.master, "--config", files["master.yaml"], "--duration", "0"],
                                 stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        old_hellos = capture(master_port, slave_port, 1.0, HELLO_TYPE)
        early.kill()
        early.wait(timeout=30)
        check(len(old_hellos) >= 1, f"captured {len(old_hellos)} hello(s) of an earlier master process")
        raw = Raw()
        to_slave = lambda payload: raw.send(payload, master_port, slave_port)  # noqa: E731
        echo = HelloEcho(raw, master_port, slave_port, old_hellos[0])
        echo.start()
    slave = subprocess.Popen([args.slave, "--config", files["slave.yaml"], "--duration", "0", "--summary-json",
                              files["slave.json"]], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    slave_out = Output(slave)
    master = None
    try:
        if privileged:
            time.sleep(0.3)  # the slave is listening
            stub = Attack("stub flood of the handshake limiter (start-up)", START,
                          ("malformed", "bad_handshake_tag"))
            dup = Attack("duplicated hello (start-up)", START, (), rejects=False)
            replay = Attack("replayed older hello (start-up)", START, ("stale_handshake",))
            echo.attach(dup, replay)
            stop_flood = threading.Event()
            result = {}
            def flood_item(i):
                if i % 2 == 0:
                    return HELLO_STUB
                forged = bad_hello(rng)
                echo.seen.add(forged)  # not the master's: the echo must not answer it
                return forged

            flooder = threading.Thread(target=lambda: result.update(n=flood_until(to_slave, flood_item, 4, stop_flood)))
            for a in (stub, dup, replay):
                a.__enter__()
            flooder.start()
        master = subprocess.Popen([args.master, "--config", files["master.yaml"], "--duration", "0"],
                                  stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        master_out = Output(master)
        coupled = master_out.wait_for("peer connected", 120) and slave_out.wait_for("peer connected", 20)
        if privileged:
            time.sleep(0.5)
            stop_flood.set()
            flooder.join()
            echo.attach(None, None)
            stub.sent = result["n"]
            for a in (stub, dup, replay):
                a.__exit__()
            attacks += [stub, dup, replay]
            start_rows = [stub, dup, replay]
        if not coupled:
            raise Failure("the two processes never coupled")
        # The master's scripted operator ramps, holds and pulls back until 4 s, then holds (deploy/configs/master.yaml):
        # attack a pair at rest, so that any motion during an attack is the attack's.
        time.sleep(5.5)
        quiet_live = Attack("(none: coupled, quiet)", LIVE, ())
        with quiet_live:
            frames = capture(master_port, slave_port, 1.0) if privileged else []
            if not privileged:
                time.sleep(1.0)
        if privileged:
            check(len(frames) > 100, f"captured {len(frames)} genuine master frames")
            raw = Raw()
            to_slave = lambda payload: raw.send(payload, master_port, slave_port)  # noqa: E731
            ahead = frame_sequence(frames[-1]) + 5000  # ahead of anything the master sent so far
            newest_v1 = 0
            with Attack("spoofed source, v1 sample", LIVE, ("insecure",)) as a:
                a.sent = paced(to_slave, [v1_sample(newest_v1 + 1 + i, FORGED_POSITIONS[0]) for i in range(300)])
            attacks.append(a)
            time.sleep(0.2)
            with Attack("spoofed source, v2 frame", LIVE, ("bad_tag",)) as a:
                a.sent = paced(to_slave, [forged_frame(frames[-1], ahead + i, rng) for i in range(300)])
            attacks.append(a)
            time.sleep(0.2)
            with Attack("spoofed shutdown (v1 flag, v2 bit flip)", LIVE, ("insecure", "bad_tag")) as a:
                items = [v1_sample(10 + i, 0.0, FLAG_ENABLED | FLAG_SHUTDOWN, 0.0, 0.0) for i in range(100)]
                items += [flipped_shutdown(frames[-1 - i], ahead + 1000 + i) for i in range(100)]
                a.sent = paced(to_slave, items)
            attacks.append(a)
            time.sleep(0.2)
            with Attack("replay of captured traffic (live)", LIVE, ("replayed", "too_old")) as a:
                a.sent = paced(to_slave, frames)
            attacks.append(a)
            time.sleep(0.2)
            with Attack("huge sequence jump (v2 +2^40, v1 +2^31)", LIVE, ("bad_tag", "insecure")) as a:
                items = [with_sequence(frames[-1 - i], frame_sequence(frames[-1 - i]) + (1 << 40)) for i in range(100)]
                items += [v1_sample((1 << 31) + i, FORGED_POSITIONS[0]) for i in range(100)]
                a.sent = paced(to_slave, items)
            attacks.append(a)
            time.sleep(0.2)
            # As fast as this process can send (whole IP packets built beforehand): above the rejection bucket
            # (20 000/s) on any machine that can, and each one costs the slave a full AEAD.
            base = ahead + 100000
            packets = [raw.packet(with_sequence(frames[-1], base + i), master_port, slave_port) for i in range(30000)]
            with Attack("datagram flood", LIVE, ("bad_tag", "rate_limited")) as a:
                t0 = time.monotonic()
                for pkt in packets:
                    raw.sock.sendto(pkt, ("127.0.0.1", 0))
                a.sent = len(packets)
                rate = a.sent / max(time.monotonic() - t0, 1e-6)
                shown = f"{rate:,.0f}".replace(",", " ")
                a.name = f"datagram flood, forged frames at {shown}/s (rejection bucket 20 000/s)"
            attacks.append(a)
            time.sleep(0.3)
        other = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        other.bind(("127.0.0.1", 0))
        with Attack("flood from another port (dropped by the kernel: connect())", LIVE, (), rejects=False) as a:
            fake = frames[-1] if privileged else v1_sample(1, FORGED_POSITIONS[0])
            a.sent = paced(lambda p: other.sendto(p, ("127.0.0.1", slave_port)), [fake] * 3000, per_ms=6)
        attacks.append(a)
        other.close()
        time.sleep(0.2)
        if privileged:
            # A re-handshake: the slave stalls past the master's timeout; the master's new hellos are duplicated and
            # an older one replayed while the slave is stopped and as it resumes.
            # Throughout, the start-up's stubs and forged hellos again from the master's port, 1 per ms (50 times the
            # handshake bucket's 20/s that the old code charged them to): they must not keep the pair from setting the
            # session up again. Not 4 per ms here: the stopped slave's queue holds them, and a backlog beyond the
            # rejection bucket's burst (512) would be drained partly as rate_limited (the replayed hello among them),
            # harmless to the pair but no longer countable by reason.
            stub = Attack("stub flood of the handshake limiter (re-handshake)", LIVE,
                          ("malformed", "bad_handshake_tag"))
            dup = Attack("duplicated hello (re-handshake)", LIVE, (), rejects=False)
            replay = Attack("replayed older hello (re-handshake)", LIVE, ("stale_handshake",))
            stop_flood = threading.Event()
            result = {}
            flooder = threading.Thread(target=lambda: result.update(n=flood_until(to_slave, flood_item, 1, stop_flood)))
            with stub, dup, replay:
                echo.attach(dup, replay)
                flooder.start()
                slave.send_signal(signal.SIGSTOP)
                time.sleep(0.2)
                slave.send_signal(signal.SIGCONT)
                time.sleep(0.8)
                stop_flood.set()
                flooder.join()
                echo.attach(None, None)
            stub.sent = result["n"]
            attacks += [stub, dup, replay]
            rehandshake = (stub, dup, replay)
            time.sleep(0.2)
            last_frames = capture(master_port, slave_port, 0.3)
            check(len(last_frames) > 30, f"captured the master's last {len(last_frames)} frames before it dies")
        if master.poll() is not None:
            raise Failure(f"the master stopped during the live attacks (exit {master.returncode})")
        kill_wall = wall_now()
        master.send_signal(signal.SIGKILL)
        master.wait(timeout=30)
        time.sleep(0.1)
        quiet_dead = Attack("(none: master dead, quiet)", DEAD, ())
        with quiet_dead:
            time.sleep(0.4)
        # The master's port is free now: any local user can bind it.
        foreign = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        foreign.bind(("127.0.0.1", master_port))
        to_slave_unprivileged = lambda payload: foreign.sendto(payload, ("127.0.0.1", slave_port))  # noqa: E731
        with Attack("foreign stream after the master died (port reused)", DEAD,
                    ("insecure", "bad_handshake_tag")) as a:
            a.sent = paced(to_slave_unprivileged, [bad_hello(rng) for _ in range(10)], per_ms=1)  # none spends a token
            a.sent += paced(to_slave_unprivileged,
                            [v1_sample(i, FORGED_POSITIONS[1], velocity=12.0, force=10.0) for i in range(1000)],
                            per_ms=1)
        attacks.append(a)
        if privileged:
            # The frames captured before the re-handshake belong to the old session: wrong_session now.
            with Attack("replay with the master dead", DEAD, ("replayed", "too_old", "wrong_session")) as a:
                replay = last_frames[-300:] + frames[-300:]
                a.sent = paced(to_slave_unprivileged, (replay * 4)[:2000], per_ms=2)
            attacks.append(a)
        foreign.close()
        time.sleep(0.3)
        if echo is not None:
            echo.stop.set()
            echo.join(timeout=5)
        end_wall = wall_now()
        slave.send_signal(signal.SIGTERM)
        slave.wait(timeout=60)
    finally:
        for p in (master, slave):
            if p is not None and p.poll() is None:
                p.send_signal(signal.SIGCONT)
                p.kill()
    slave_text = slave_out.text()
    master_out.text()
    print("---- slave output ----\n" + slave_text)

    check(slave.returncode == 0, f"slave exits 0 after SIGTERM (got {slave.returncode})")
    s = load(files["slave.json"])
    pk = s["packets"]
    sec = s["security"]
    check(sec["mode"] == "psk", "the slave's summary says security mode psk")
    check(s["stop_reason"] == "signal", f"the slave ran until stopped (stop reason '{s['stop_reason']}': no spoofed "
                                        "shutdown stopped it)")
    counted = sec["rejected_by_reason"]
    total_sent = sum(a.sent for a in attacks if a.rejects)
    check(pk["wrong_sender"] == 0, "no datagram from another source reached the link (the kernel drops them)")
    check(pk["rejected"] == total_sent, f"slave rejected {pk['rejected']} datagrams: all {total_sent} rejected "
                                        "attacks, nothing else")
    dups = sum(a.sent for a in attacks if a.name.startswith("duplicated hello"))
    check(not privileged or dups >= 4, f"{dups} duplicated hellos sent (at start-up and in the re-handshake)")
    check(sec["handshake_messages"] >= dups + 2 * sec["sessions"],
          f"every duplicated hello was taken as a handshake message (answered from the cache): "
          f"{sec['handshake_messages']} >= {dups} + 2 x {sec['sessions']} sessions")
    check(not privileged or sec["sessions"] >= 2,
          f"the slave re-handshook with the master ({sec['sessions']} sessions)")
    reasons = sorted({r for a in attacks for r in a.reasons})
    # Reason groups: each group's counters must add up to what the attacks of that group sent.
    groups = {}
    for a in attacks:
        if not a.rejects:
            continue
        groups.setdefault(frozenset(a.reasons), []).append(a)
    merged = []  # union-find-free merge of overlapping reason sets
    for g in groups:
        hit = [m for m in merged if m[0] & g]
        for m in hit:
            merged.remove(m)
        reasons_union = frozenset(g).union(*[m[0] for m in hit])
        members = sum((m[1] for m in hit), []) + groups[g]
        merged.append((reasons_union, members))
    for reasons_set, members in merged:
        expected = sum(a.sent for a in members)
        got = sum(counted.get(r, 0) for r in reasons_set)
        check(got == expected, f"reasons {'+'.join(sorted(reasons_set))}: {got} counted = {expected} sent by "
                               f"{', '.join(a.name for a in members)}")
    unexpected = {r: n for r, n in counted.items() if n and r not in reasons}
    check(not unexpected, f"no rejection for any other reason ({unexpected or 'none'})")

    slave_rows = read_telemetry(files["slave.csv"], start_wall_time(slave_text, "teleop-slave"))
    check(len(slave_rows) > 1000, f"telemetry: slave {len(slave_rows)} records")
    worst_peer = max(abs(r["peer_position_m_0"]) for r in slave_rows)
    check(worst_peer < 0.1 and not any(r["peer_position_m_0"] in FORGED_POSITIONS for r in slave_rows),
          f"no forged position ever reached the slave's law (largest peer input {worst_peer*1e3:.2f} mm)")

    # Excursion: how far the slave moved during the window (and 0.1 s after it) from where it was when the window
    # began. The pair is at rest, so a quiet window of the same phase shows what "no effect" looks like.
    def excursion(a):
        rows = between(slave_rows, a.t0, a.t1 + 0.1)
        if not rows:
            raise Failure(f"no slave telemetry in the window of '{a.name}'")
        return max(abs(r["position_m_0"] - rows[0]["position_m_0"]) for r in rows)

    def coupled(a):
        rows = between(slave_rows, a.t0, a.t1)
        return len(rows), sum(1 for r in rows if int(r["engagement"]) == 3)

    table = [a for a in attacks if a.phase == START] + [quiet_live] + [a for a in attacks if a.phase == LIVE] + \
        [quiet_dead] + [a for a in attacks if a.phase == DEAD]
    rows_out = []
    for a in table:
        ex = excursion(a) if a.phase != START else max(abs(r["position_m_0"]) for r in between(slave_rows, a.t0, a.t1))
        cycles, engaged = coupled(a)
        quiet = not a.reasons and a.rejects
        rows_out.append((a.name, "-" if quiet else a.sent, "-" if quiet else (a.sent if a.rejects else 0),
                         "+".join(a.reasons) if a.reasons else ("-" if quiet else "(none: not a rejection)"),
                         f"{engaged}/{cycles}", ex * 1e3))
    base_live = excursion(quiet_live)
    base_dead = excursion(quiet_dead)
    for a in attacks:
        if a.phase == START:
            continue
        ex = excursion(a)
        base = base_live if a.phase == LIVE else base_dead
        check(ex <= base + 0.1e-3, f"{a.name}: slave excursion {ex*1e3:.4f} mm, quiet window {base*1e3:.4f} mm")
    for a in [quiet_live] + [a for a in attacks if a.phase == LIVE and a.name.startswith(("datagram", "flood"))]:
        cycles, engaged = coupled(a)
        check(cycles > 0 and engaged == cycles, f"{a.name}: coupled in {engaged} of {cycles} slave cycles")
    for a in start_rows:
        cycles, engaged = coupled(a)
        check(engaged > 0, f"{a.name}: the pair coupled during it ({engaged} of {cycles} slave cycles engaged)")
        rows = between(slave_rows, a.t0, a.t1)
        first = next(i for i, r in enumerate(rows) if int(r["engagement"]) == 3)
        check(engaged == len(rows) - first and rows[-1]["wall"] - rows[first]["wall"] > 0.3,
              f"{a.name}: once coupled, engaged in every later cycle of the attack ({engaged} of {len(rows) - first}, "
              f"{rows[-1]['wall'] - rows[first]['wall']:.2f} s)")
        check(max(abs(r["position_m_0"]) for r in rows) < 0.1, f"{a.name}: the slave stayed within its rest range")
    if privileged:
        for a in rehandshake:
            rows = between(slave_rows, a.t1 - 0.3, a.t1)
            check(rows and all(int(r["engagement"]) == 3 for r in rows),
                  f"{a.name}: the pair recoupled after the re-handshake (engaged in the last 0.3 s of the window)")

    # The watchdog is never fed after the master died: from the kill + timeout (+ alignment margin) to the end,
    # every slave cycle says peer lost and its peer input is frozen.
    after = between(slave_rows, kill_wall + timeout_s + 0.05, end_wall)
    check(len(after) > 500, f"{len(after)} slave cycles after the master died")
    lost = sum(1 for r in after if int(r["flags"]) & FLAG_PEER_LOST)
    check(lost == len(after), f"peer lost in {lost} of {len(after)} cycles after the master died (replays and the "
                              "foreign stream never fed the watchdog)")
    frozen = {r["peer_position_m_0"] for r in after}
    check(len(frozen) == 1, f"the slave's peer input stayed frozen after the master died ({len(frozen)} values)")
    check(s["watchdog_trips"] >= 1, f"slave watchdog tripped ({s['watchdog_trips']})")

    print("\nattack table (slave side). rejected: the slave's rejected total equals the datagrams sent and each datagram"
          " has exactly one outcome, so every one was rejected; the reason totals balance per group (checked above)")
    print(f"| {'attack':<66} | {'sent':>6} | {'rejected':>8} | {'counted reason':<34} | {'coupled cycles':>14} | "
          "slave excursion |")
    print(f"| {'-'*66} | {'-'*5}: | {'-'*7}: | {'-'*34} | {'-'*13}: | {'-'*14}: |")
    for name, sent, rejected, reason, cyc, ex_mm in rows_out:
        print(f"| {name:<66} | {sent!s:>6} | {rejected!s:>8} | {reason:<34} | {cyc:>14} | {ex_mm*1e3:12.1f} µm |")
    if can_row is not None:
        print(f"| {'unprivileged process attaching to the emulated CAN bus (+ bus-off)':<66} | {can_row[0] + 1:>6} | "
              f"{can_row[1]:>8} | {'refused_hellos+refused_controls':<34} | {'n/a (bus)':>14} | {'n/a':>15} |")
    for label, sent, rejected, reason in can_unix_rows:
        print(f"| {label:<66} | {sent:>6} | {rejected:>8} | {reason:<34} | {'n/a (bus)':>14} | {'n/a':>15} |")
    if can_heir_row is not None:
        sent, rejected, cyc, ex = can_heir_row
        label = "nobody on the killed master's emulated-CAN port (frames, bus-off)"
        print(f"| {label:<66} | {sent:>6} | "
              f"{rejected:>8} | {'malformed+refused (orphaned node)':<34} | {cyc:>14} | {ex*1e6:12.1f} µm |")
    print("(start-up rows: the excursion column is the slave's largest |position| in the window, from rest at 0)")
    print("\nslave counters: " + json.dumps({k: v for k, v in counted.items() if v}) +
          f"; sessions {sec['sessions']}; watchdog trips {s['watchdog_trips']}")


if __name__ == "__main__":
    try:
        main()
    except Failure as e:
        print(f"FAILED: {e}")
        sys.exit(1)
    print("PASSED")
