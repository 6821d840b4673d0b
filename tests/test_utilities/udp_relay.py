"""A UDP relay between two processes for process-level tests: it forwards datagrams both ways unchanged and drops
everything in scheduled windows (link cuts). Standard library only.

Each process's config points its `link.peer` at the relay: the master's peer is `relay.master_side` (the relay
forwards what arrives there to the slave from `relay.slave_side`) and the slave's peer is `relay.slave_side`. So
each process sees datagrams from exactly the address it expects (`link.accept_only_peer_address`).

    relay = UdpRelay(master_addr, slave_addr)   # binds two free ports on 127.0.0.1
    relay.start()
    relay.cut(0.1)                              # drop both directions for 100 ms, from now
    relay.stop()
"""
import select
import socket
import threading
import time


class UdpRelay:
    def __init__(self, master_addr, slave_addr, host="127.0.0.1"):
        self.master_addr = master_addr
        self.slave_addr = slave_addr
        self._from_master = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)  # the master sends here
        self._from_master.bind((host, 0))
        self._from_slave = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)  # the slave sends here
        self._from_slave.bind((host, 0))
        self.master_side = self._from_master.getsockname()  # the master's link.peer
        self.slave_side = self._from_slave.getsockname()  # the slave's link.peer
        self._lock = threading.Lock()
        self._windows = []  # (start, end) in time.monotonic()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self.forwarded = {"master": 0, "slave": 0}
        self.dropped = {"master": 0, "slave": 0}
        # time.monotonic() of the last datagram forwarded before, and the first after, each window (per direction).
        self.last_before = {}
        self.first_after = {}

    def start(self):
        self._thread.start()

    def stop(self):
        self._stop.set()
        self._thread.join(timeout=5)
        self._from_master.close()
        self._from_slave.close()

    def cut(self, duration_s, start_in_s=0.0):
        """Drops both directions for duration_s, starting start_in_s from now. Returns the (start, end) window."""
        start = time.monotonic() + start_in_s
        window = (start, start + duration_s)
        with self._lock:
            self._windows.append(window)
        return window

    def _in_cut(self, now):
        with self._lock:
            return any(a <= now < b for a, b in self._windows)

    def _run(self):
        socks = [self._from_master, self._from_slave]
        while not self._stop.is_set():
            ready, _, _ = select.select(socks, [], [], 0.005)
            for s in ready:
                try:
                    data, _ = s.recvfrom(2048)
                except OSError:
                    continue
                now = time.monotonic()
                sender = "master" if s is self._from_master else "slave"
                if self._in_cut(now):
                    self.dropped[sender] += 1
                    continue
                self.forwarded[sender] += 1
                with self._lock:
                    for w in self._windows:
                        if now < w[0]:
                            self.last_before[(w, sender)] = now
                        elif now >= w[1] and (w, sender) not in self.first_after:
                            self.first_after[(w, sender)] = now
                try:
                    if sender == "master":
                        self._from_slave.sendto(data, self.slave_addr)
                    else:
                        self._from_master.sendto(data, self.master_addr)
                except OSError:
                    pass  # the receiver is not up yet or gone: like a lost datagram
