#!/usr/bin/env python3
"""Checks a candump -L capture of a teleop CAN run against proto/teleop.dbc and the processes' JSON summaries.

    can_capture_check.py --dbc proto/teleop.dbc --log candump.log --dof 3 [--fd] --rate-hz 500
                         [--master-summary master.json] [--slave-summary slave.json] [--injected injected.txt]
                         [--min-rate-fraction 0.8] [--report report.json]

Independent of the C++ code: the frame layout is derived from the DBC alone (signals whose name ends in a DOF index
>= --dof are not sent; a classic frame is as long as its last used signal; an FD frame is rounded up to an FD length
and zero-padded). Every captured frame must be one of the configured identifiers, have the expected length and frame
format, carry 0 in every bit no used signal covers, decode to values inside the DBC ranges and never the "NaN" code;
the slots of a cycle carry one counter, and consecutive cycles count up by one (mod 16): a gap is a lost cycle.

--injected lists the frames a test put on the bus on purpose, one per line: `<process> <reason> <candump frame>`,
e.g. `master bad_length 184##0112233`. Each must appear exactly once in the capture (it is then exempt from the
checks), and `<process>`'s summary must count it under packets.rejected_by_reason.<reason> (`-` as reason: the
kernel's receive filter drops it, so no process may count it). Nothing else may be rejected, no sample lost, no
watchdog trip: the injections did not disturb the loop.

With --master-config and --slave-config (the YAML files the processes ran) the motion is checked as well, from the
positions the captured frames carry: on every axis whose operator force (device.loopback.operator.script) has been
constant for a while at the end of the run, the slave and master must rest where the static balance of the law
(eqs. 8-9), the finger spring and the slave's fixture (eq. 7) put them (see check_motion).

Exit status 0 when everything holds, 1 with one line per violation otherwise. Python 3 standard library only.
"""

import argparse
import copy
import json
import math
import re
import sys
from collections import Counter, defaultdict

FD_LENGTHS = [0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64]
COUNTER_MODULO = 16


class Signal:
    def __init__(self, name, start, length, little_endian, signed, factor, offset, minimum, maximum, unit):
        self.name, self.start, self.length = name, start, length
        self.little_endian, self.signed = little_endian, signed
        self.factor, self.offset, self.minimum, self.maximum, self.unit = factor, offset, minimum, maximum, unit
        self.nan_code = None
        match = re.search(r"(\d+)$", name)
        self.dof = int(match.group(1)) if match and not name.startswith("Counter") else None
        match = re.match(r"Counter_S(\d+)$", name)
        self.slot = int(match.group(1)) if match else (0 if name == "Counter" else None)

    def raw(self, data):
        word = int.from_bytes(data, "little")
        value = (word >> self.start) & ((1 << self.length) - 1)
        if self.signed and value & (1 << (self.length - 1)):
            value -= 1 << self.length
        return value


class Message:
    def __init__(self, frame_id, name, dlc, sender):
        self.id, self.name, self.dlc, self.sender = frame_id, name, dlc, sender
        self.signals = []
        self.fd = False


def parse_dbc(path):
    """The subset of DBC that teleop.dbc uses: BO_, SG_ (Intel order), VAL_ NaN codes, BA_ VFrameFormat."""
    messages = {}
    current = None
    bo = re.compile(r"^BO_ (\d+) (\w+) *: *(\d+) (\w+)")
    sg = re.compile(r"^\s*SG_ (\w+) *: *(\d+)\|(\d+)@([01])([+-]) \(([^,]+),([^)]+)\) \[([^|]+)\|([^\]]+)\] \"([^\"]*)\"")
    val = re.compile(r"^VAL_ (\d+) (\w+) (.*);")
    frame_format = re.compile(r'^BA_ "VFrameFormat" BO_ (\d+) (\d+);')
    with open(path, encoding="utf-8") as f:
        for line in f:
            if m := bo.match(line):
                current = Message(int(m.group(1)), m.group(2), int(m.group(3)), m.group(4))
                messages[current.id] = current
            elif (m := sg.match(line)) and current is not None:
                if m.group(4) != "1":
                    raise ValueError(f"{path}: signal {m.group(1)} is Motorola order; teleop uses Intel only")
                current.signals.append(Signal(m.group(1), int(m.group(2)), int(m.group(3)), True, m.group(5) == "-",
                                              float(m.group(6)), float(m.group(7)), float(m.group(8)),
                                              float(m.group(9)), m.group(10)))
            elif m := val.match(line):
                for code, label in re.findall(r"(-?\d+) \"([^\"]*)\"", m.group(3)):
                    if label == "NaN":
                        for s in messages[int(m.group(1))].signals:
                            if s.name == m.group(2):
                                s.nan_code = int(code)
            elif m := frame_format.match(line):
                messages[int(m.group(1))].fd = int(m.group(2)) in (14, 15)
    return messages


def used_signals(message, dof, slots):
    """Signals sent for `dof` DOF: per-DOF signals below dof, counters of the slots in use, the flags."""
    out = []
    for s in message.signals:
        if s.dof is not None and s.dof >= dof:
            continue
        if s.slot is not None and s.slot >= slots:
            continue
        out.append(s)
    return out


def place_layout_marker(signals):
    """The DBC describes 6 DOF, where the layout marker (signal Layout, CAN layout 2) sits at bit 62 of slot 0; for
    fewer DOF it follows slot 0's last used signal (docs/can.md, "Layout version"): move it there."""
    out = [s for s in signals if s.name != "Layout"]
    for marker in (s for s in signals if s.name == "Layout"):
        slot_base = 64 * (marker.start // 64)
        end = max(s.start + s.length for s in out if slot_base <= s.start < slot_base + 64)
        moved = copy.copy(marker)
        moved.start = end
        out.append(moved)
    return out


class Layout:
    """What one direction sends per cycle, derived from the DBC for a DOF count and frame format."""

    def __init__(self, messages, sender, dof, fd):
        mine = sorted((m for m in messages.values() if m.sender == sender and m.fd == fd), key=lambda m: m.id)
        self.fd = fd
        self.frames = {}  # id -> (slot index, used signals, expected length)
        for slot, message in enumerate(mine):
            signals = place_layout_marker(used_signals(message, dof, slots=99))
            if not fd and not any(s.dof is not None for s in signals):
                continue  # a classic slot with no DOF of ours is not sent
            if fd:
                slots = 1 + max(s.start // 64 for s in signals if s.dof is not None)
                signals = place_layout_marker(used_signals(message, dof, slots))
                end = (max(s.start + s.length for s in signals) + 7) // 8
                length = next(n for n in FD_LENGTHS if n >= end)
            else:
                length = (max(s.start + s.length for s in signals) + 7) // 8
            self.frames[message.id] = (slot, signals, length)
        self.slot_count = len(self.frames)


def normalize(text):
    """A frame's text as cansend takes it, for matching: upper case; for FD frames, the FDF flag (0x4) that kernels
    since 6.0 set on every received FD frame dropped (BRS 0x1 and ESI 0x2 kept)."""
    text = text.upper()
    if "##" in text:
        head, tail = text.split("##", 1)
        if tail:
            text = f"{head}##{int(tail[0], 16) & ~0x4:X}{tail[1:]}"
    return text


def parse_candump(path):
    """candump -L lines: (time) iface ID#DATA, ID##<flags>DATA (FD), ID#R (remote); error frames have the ERR flag."""
    line_re = re.compile(r"^\((\d+\.\d+)\) (\S+) ([0-9A-Fa-f]{3}|[0-9A-Fa-f]{8})(##?)(.*)$")
    frames, malformed = [], []
    with open(path, encoding="utf-8", errors="replace") as f:
        for number, line in enumerate(f, 1):
            line = line.rstrip("\n")
            m = line_re.match(line)
            if not m:
                malformed.append((number, line))
                continue
            fd = m.group(4) == "##"
            body = m.group(5)
            if fd:
                body = body[1:]
            remote = body.startswith("R")
            if remote or len(body) % 2 or not re.fullmatch(r"[0-9A-Fa-f]*", body):
                frames.append(dict(t=float(m.group(1)), text=f"{m.group(3)}{m.group(4)}{m.group(5)}", id=None,
                                   fd=fd, data=b"", line=number, bad=("remote frame" if remote else "bad data")))
                continue
            raw_id = int(m.group(3), 16)
            frames.append(dict(t=float(m.group(1)), text=normalize(f"{m.group(3)}{m.group(4)}{m.group(5)}"),
                               id=raw_id & 0x1FFFFFFF, extended=len(m.group(3)) == 8, error=bool(raw_id & 0x20000000),
                               fd=fd, data=bytes.fromhex(body), line=number, bad=None))
    return frames, malformed


def check_frame(frame, layout, violations):
    """Returns the counter of a valid frame's slots (one value), or None after recording the violation."""
    where = f"line {frame['line']} {frame['text']}"
    entry = layout.frames.get(frame["id"])
    if frame["bad"] or frame.get("error") or entry is None:
        violations.append(f"{where}: {frame['bad'] or ('error frame' if frame.get('error') else 'unexpected id')}")
        return None
    slot, signals, length = entry
    if frame["fd"] != layout.fd or frame.get("extended"):
        violations.append(f"{where}: {'FD' if frame['fd'] else 'classic'}{' 29-bit' if frame.get('extended') else ''}"
                          f" frame, the layout is {'FD' if layout.fd else 'classic'} 11-bit")
        return None
    if len(frame["data"]) != length:
        violations.append(f"{where}: length {len(frame['data'])}, the DBC layout needs {length}")
        return None
    data = frame["data"]
    covered = 0
    for s in signals:
        covered |= ((1 << s.length) - 1) << s.start
    word = int.from_bytes(data, "little")
    if word & ~covered & ((1 << (8 * len(data))) - 1):
        violations.append(f"{where}: reserved bits set (0x{word & ~covered:x})")
        return None
    counters = set()
    for s in signals:
        raw = s.raw(data)
        if s.name.startswith("Counter"):
            counters.add(raw)
            continue
        if s.name == "Layout" and raw != 1:
            violations.append(f"{where}: layout marker 0 (a frame of CAN layout 1, an older build)")
            return None
        if s.nan_code is not None and raw == s.nan_code:
            violations.append(f"{where}: {s.name} carries the NaN code")
            continue
        value = raw * s.factor + s.offset
        if not s.minimum - 1e-9 <= value <= s.maximum + 1e-9:
            violations.append(f"{where}: {s.name} = {value:g} {s.unit} outside [{s.minimum:g}, {s.maximum:g}]")
    if len(counters) != 1:
        violations.append(f"{where}: slots carry different counters {sorted(counters)}")
        return None
    return counters.pop()


def check_direction(name, frames, layout, rate_hz, min_rate_fraction, violations, report, positions=None):
    """Groups a direction's frames into cycles (one counter, every slot once) and checks their sequence. Appends
    (bus time, {dof: position_m}) per complete cycle to `positions` when given."""
    cycles, open_cycle, open_counter = [], {}, None
    for frame in frames:
        counter = check_frame(frame, layout, violations)
        if counter is None:
            continue
        slot = layout.frames[frame["id"]][0]
        if open_cycle and (counter != open_counter or slot in open_cycle):
            violations.append(f"{name}: cycle {open_counter} incomplete before line {frame['line']}")
            open_cycle = {}
        open_cycle[slot], open_counter = frame, counter
        if len(open_cycle) == layout.slot_count:
            cycles.append((counter, min(f["t"] for f in open_cycle.values())))
            if positions is not None:
                values = {}
                for f in open_cycle.values():
                    for sig in layout.frames[f["id"]][1]:
                        if sig.name.startswith("Position") and sig.dof is not None:
                            values[sig.dof] = sig.raw(f["data"]) * sig.factor + sig.offset
                positions.append((cycles[-1][1], values))
            open_cycle = {}
    if open_cycle:
        violations.append(f"{name}: the last cycle is incomplete")
    gaps = 0
    for (previous, _), (counter, t) in zip(cycles, cycles[1:]):
        step = (counter - previous) % COUNTER_MODULO
        if step != 1:
            gaps += 1
            violations.append(f"{name}: counter {previous} -> {counter} at t={t:.6f}: {(step - 1) % 16} cycle(s) lost")
    rate = 0.0
    if len(cycles) >= 2:
        rate = (len(cycles) - 1) / (cycles[-1][1] - cycles[0][1])
    if rate < min_rate_fraction * rate_hz:
        violations.append(f"{name}: {rate:.1f} cycles/s on the bus, below {min_rate_fraction:.2f} x {rate_hz:g} Hz")
    report[name] = dict(frames=len(frames), cycles=len(cycles), counter_gaps=gaps, rate_hz=round(rate, 2))
    return len(cycles)


def check_summary(role, summary, injected, captured_sent_cycles, bus_rate_hz, violations, report):
    packets = summary.get("packets", {})
    achieved = summary.get("achieved_rate_hz") or 0.0
    if abs(bus_rate_hz - achieved) > 0.1 * max(achieved, 1e-9):
        violations.append(f"{role}: reports {achieved} Hz achieved, its frames came at {bus_rate_hz} cycles/s")
    expected = Counter(reason for process, reason, _ in injected if process == role and reason != "-")
    counted = {k: v for k, v in packets.get("rejected_by_reason", {}).items() if v}
    for reason in sorted(set(expected) | set(counted)):
        if counted.get(reason, 0) != expected.get(reason, 0):
            violations.append(f"{role}: rejected_by_reason.{reason} = {counted.get(reason, 0)}, "
                              f"expected {expected.get(reason, 0)} (injected)")
    if packets.get("rejected", 0) != sum(expected.values()):
        violations.append(f"{role}: {packets.get('rejected')} rejected, {sum(expected.values())} injected")
    for key in ("lost", "send_errors", "bus_errors", "wrong_sender"):
        if packets.get(key, 0) != 0:
            violations.append(f"{role}: packets.{key} = {packets.get(key)}, expected 0")
    for key in ("watchdog_trips", "nonfinite_inputs", "dof_mismatches", "device_fault_cycles"):
        if summary.get(key, 0) != 0:
            violations.append(f"{role}: {key} = {summary.get(key)}, expected 0")
    if packets.get("sent") != captured_sent_cycles:
        violations.append(f"{role}: sent {packets.get('sent')} samples, the capture holds {captured_sent_cycles} cycles")
    report[role] = dict(cycles=summary.get("cycles"), achieved_rate_hz=summary.get("achieved_rate_hz"),
                        sent=packets.get("sent"), accepted=packets.get("accepted"), lost=packets.get("lost"),
                        rejected=packets.get("rejected"), rejected_by_reason=counted,
                        watchdog_trips=summary.get("watchdog_trips"), stop_reason=summary.get("stop_reason"))


def read_config(path):
    """The scalar keys of a process config as dotted paths ("law.kp_N_per_m" -> 600.0) and the operator script as
    a list of dicts, read with the standard library: block mappings, one-line flow mappings and the script's
    one-line "- {...}" items, which is all the test configs use for the keys read here."""
    values, script, stack = {}, [], []

    def scalar(text):
        text = text.strip()
        try:
            return float(text)
        except ValueError:
            return text.strip('"')

    def flow(text):
        return {k.strip(): scalar(v) for k, v in (item.split(":", 1) for item in text.strip()[1:-1].split(","))}

    for raw in open(path, encoding="utf-8"):
        line = raw.split("#", 1)[0].rstrip()
        item = re.match(r"^\s*- (\{.*\})$", line)
        if item:
            if [k for _, k in stack][-1:] == ["script"]:
                script.append(flow(item.group(1)))
            continue
        m = re.match(r"^(\s*)([A-Za-z_][A-Za-z0-9_]*):\s*(.*)$", line)
        if not m:
            continue
        indent, key, value = len(m.group(1)), m.group(2), m.group(3).strip()
        while stack and stack[-1][0] >= indent:
            stack.pop()
        dotted = ".".join([k for _, k in stack] + [key])
        if value == "":
            stack.append((indent, key))
        elif value.startswith("{") and value.endswith("}"):
            values.update({f"{dotted}.{k}": v for k, v in flow(value).items()})
        else:
            values[dotted] = scalar(value)
    return values, script


def script_force(script, axis, t):
    """F_h*(t) on `axis` (docs/configuration.md, device.loopback.operator.script): the sum of the segments active
    at t (start <= t < start + duration, duration 0 = to the end); a hold keeps the level just before its start."""
    total = 0.0
    for seg in script:
        if int(seg.get("axis", 0)) != axis:
            continue
        start, duration = seg["start_s"], seg.get("duration_s", 0.0)
        if t < start or (duration > 0 and t >= start + duration):
            continue
        kind = seg["type"]
        if kind == "ramp":
            total += seg["from_N"] + (seg["to_N"] - seg["from_N"]) * (t - start) / duration
        elif kind == "step":
            total += seg["to_N"]
        elif kind == "sine":
            total += seg.get("offset_N", 0.0) + seg["amplitude_N"] * math.sin(2 * math.pi * seg["frequency_hz"] *
                                                                               (t - start))
        elif kind == "hold":
            total += script_force([x for x in script if x is not seg], axis, start - 1e-9)
    return total


def last_change_s(script, axis):
    """When F_h* on `axis` last changes: the end of its last ramp, the start or end of any segment; inf if a sine
    drives it to the end."""
    t = 0.0
    for seg in script:
        if int(seg.get("axis", 0)) != axis:
            continue
        duration = seg.get("duration_s", 0.0)
        if seg["type"] == "sine" and duration == 0:
            return math.inf
        t = max(t, seg["start_s"] + duration)
    return t


def median(xs):
    xs = sorted(xs)
    return xs[len(xs) // 2] if len(xs) % 2 else 0.5 * (xs[len(xs) // 2 - 1] + xs[len(xs) // 2])


def check_motion(master_cfg, slave_cfg, dof, master_positions, slave_positions, position_lsb_m, violations, report):
    """Static balance on every axis whose operator force is constant at the end of the run.

    Each master frame is one master cycle, so the n-th carries the master's simulated time n / rate (the loopback
    plant advances one period per cycle and the script runs on that time). On an axis whose force F_h* has not
    changed for `settle` seconds before the last master frame, over the rest of the run:
      free space:  x_m = x_s = F_h* / k_h                        (the finger spring, eq. 2, holds the force alone)
      in contact with the slave's fixture x > x_c (eq. 7, stiffness K), p = x_s - x_c:
        slave (eq. 9):  K_p (x_m - x_s) = K p
        master (eq. 8): F_h* - k_h x_m = K_p (x_m - x_s)
        => p = (F_h* - k_h x_c) / (k_h (1 + K / K_p) + K),   x_m - x_s = K p / K_p
    The slave's positions are taken over the bus-time span of the master's window."""
    mc, mscript = master_cfg
    sc, _ = slave_cfg
    rate = mc["rate_hz"]
    kp = mc["law.kp_N_per_m"]
    k_h = mc.get("device.loopback.operator.stiffness_N_per_m", 0.0)
    k_vf = sc.get("fixture.stiffness_N_per_m", 0.0)
    fixture_axis = int(sc.get("fixture.half_space.axis", -1)) if k_vf > 0 else -1
    x_c = sc.get("fixture.half_space.offset_m", 0.0)
    if k_vf > 0 and sc.get("fixture.half_space.direction", 1.0) != 1.0:
        violations.append("motion: only a +1 fixture direction is predicted here")
        return
    if kp != sc["law.kp_N_per_m"] or k_h <= 0:
        violations.append("motion: the prediction needs equal K_p on both sides and a finger spring k_h > 0")
        return
    # 0.25 s: the slowest mode here, the slave's contact mode, decays with 2 m_s / b_s ≈ 0.15 s (0.036 kg,
    # 0.49 N·s/m): after 0.25 s the transient left from the force change is below 20 % of its (few per cent) size.
    settle = 0.25
    t_last = (len(master_positions) - 1) / rate
    report["motion"] = {}
    for axis in range(dof):
        changed = last_change_s(mscript, axis)
        if math.isinf(changed):
            report["motion"][axis] = "driven to the end of the run (not checked)"
            continue
        if changed + settle > t_last - 0.2:
            violations.append(f"motion axis {axis}: the master's simulated time reached {t_last:.3f} s, too short "
                              f"for a static window after the force's last change at {changed:g} s + {settle} s")
            continue
        window_from = changed + settle
        master = [(t, v[axis]) for n, (t, v) in enumerate(master_positions) if n / rate >= window_from]
        t0, t1 = master[0][0], master[-1][0]
        slave = [v[axis] for t, v in slave_positions if t0 <= t <= t1]
        if len(slave) < 50:
            violations.append(f"motion axis {axis}: {len(slave)} slave cycles in the static window")
            continue
        force = script_force(mscript, axis, t_last)
        x_m, x_s = median([x for _, x in master]), median(slave)
        spread = max(slave) - min(slave)
        free = force / k_h
        if axis == fixture_axis and free > x_c:
            p = (force - k_h * x_c) / (k_h * (1 + k_vf / kp) + k_vf)
            want_s, want_m = x_c + p, x_c + p + k_vf * p / kp
            scale = p
        else:
            want_s = want_m = free
            scale = abs(free)
        # 3 % of the static displacement: settled (above) and still, so the link delay adds nothing; K_p halved
        # moves the contact balance by 18 %, the fixture force halved by 76 %. Plus the DBC's position step
        # (2e-5 m), by which every captured position is rounded, once per position in the difference.
        tol = 0.03 * scale + position_lsb_m
        report["motion"][axis] = dict(force_N=force, slave_m=x_s, slave_predicted_m=want_s, master_m=x_m,
                                      master_predicted_m=want_m, slave_spread_m=spread, window_from_s=window_from)
        if abs(x_s - want_s) > tol:
            violations.append(f"motion axis {axis}: slave rests at {x_s*1e3:.4f} mm, the static balance at "
                              f"F_h* = {force:g} N is {want_s*1e3:.4f} mm (± {tol*1e3:.4f})")
        if abs((x_m - x_s) - (want_m - want_s)) > tol + position_lsb_m:
            violations.append(f"motion axis {axis}: tracking error {(x_m - x_s)*1e3:.4f} mm, the static balance "
                              f"gives {(want_m - want_s)*1e3:.4f} mm (± {(tol + position_lsb_m)*1e3:.4f})")
        # Still: a sustained vibration (a broken K_d, an unstable fixture) shows as a spread over the window.
        if spread > 0.05 * scale + 2 * position_lsb_m:
            violations.append(f"motion axis {axis}: the slave moves over {spread*1e3:.4f} mm in the static window")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--dbc", required=True)
    parser.add_argument("--log", required=True, help="candump -L capture")
    parser.add_argument("--dof", type=int, required=True)
    parser.add_argument("--fd", action="store_true", help="one CAN FD frame per cycle (default: classic)")
    parser.add_argument("--rate-hz", type=float, required=True)
    parser.add_argument("--min-rate-fraction", type=float, default=0.8,
                        help="cycles/s on the bus must reach this fraction of --rate-hz (default 0.8)")
    parser.add_argument("--master-summary")
    parser.add_argument("--slave-summary")
    parser.add_argument("--injected", help="frames injected on purpose: '<process> <reason> <frame>' per line")
    parser.add_argument("--report", help="write what was measured as JSON")
    parser.add_argument("--master-config", help="the master's YAML config: check the motion (with --slave-config)")
    parser.add_argument("--slave-config", help="the slave's YAML config")
    args = parser.parse_args(argv)

    violations, report = [], {}
    messages = parse_dbc(args.dbc)
    layouts = {role: Layout(messages, sender, args.dof, args.fd) for role, sender in
               (("master_to_slave", "MASTER"), ("slave_to_master", "SLAVE"))}
    for role, layout in layouts.items():
        if not layout.frames:
            violations.append(f"{args.dbc}: no {role} frames for dof {args.dof}, fd {args.fd}")
    frames, malformed = parse_candump(args.log)
    for number, line in malformed:
        violations.append(f"line {number}: not a candump -L frame: {line[:80]}")

    injected = []
    if args.injected:
        with open(args.injected, encoding="utf-8") as f:
            for line in f:
                if line.strip() and not line.startswith("#"):
                    process, reason, text = line.split()
                    injected.append((process, reason, normalize(text)))
    by_text = defaultdict(list)
    for index, frame in enumerate(frames):
        by_text[frame["text"]].append(index)
    exempt = set()
    for process, reason, text in injected:
        hits = by_text.get(text, [])
        if len(hits) != 1:
            violations.append(f"injected {text} ({process} {reason}) appears {len(hits)} times in the capture")
        exempt.update(hits)
    report["injected"] = len(injected)

    owner = {}
    for role, layout in layouts.items():
        for frame_id in layout.frames:
            owner[frame_id] = role
    streams = defaultdict(list)
    for index, frame in enumerate(frames):
        if index in exempt:
            continue
        role = owner.get(frame["id"])
        if role is None:
            violations.append(f"line {frame['line']} {frame['text']}: not a configured identifier")
            continue
        streams[role].append(frame)
    cycles = {}
    positions = {role: [] for role in layouts}
    for role, layout in layouts.items():
        cycles[role] = check_direction(role, streams[role], layout, args.rate_hz, args.min_rate_fraction, violations,
                                       report, positions[role])
    if args.master_config and args.slave_config:
        lsb = min((s.factor for m in messages.values() for s in m.signals if s.name.startswith("Position")),
                  default=0.0)
        check_motion(read_config(args.master_config), read_config(args.slave_config), args.dof,
                     positions["master_to_slave"], positions["slave_to_master"], lsb, violations, report)

    for role, path, direction in (("master", args.master_summary, "master_to_slave"),
                                  ("slave", args.slave_summary, "slave_to_master")):
        if path:
            with open(path, encoding="utf-8") as f:
                check_summary(role, json.load(f), injected, cycles[direction], report[direction]["rate_hz"],
                              violations, report)

    if args.report:
        with open(args.report, "w", encoding="utf-8") as f:
            json.dump(dict(report, violations=violations), f, indent=2)
    print(json.dumps(report, sort_keys=True))
    for v in violations[:50]:
        print("VIOLATION", v)
    if len(violations) > 50:
        print(f"... and {len(violations) - 50} more violations")
    return 1 if violations else 0


if __name__ == "__main__":
    sys.exit(main())
