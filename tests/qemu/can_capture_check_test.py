#!/usr/bin/env python3
"""Self-test of can_capture_check.py (ctest qemu_can_capture_check_selftest; no qemu needed).

Synthetic candump -L captures are encoded from proto/teleop.dbc, then spoiled one way at a time; the checker must
accept the clean ones and name every spoilage. Run: python3 tests/qemu/can_capture_check_test.py [path/to/teleop.dbc]
"""

import io
import json
import os
import sys
import tempfile
import unittest
from contextlib import redirect_stdout

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import can_capture_check as checker  # noqa: E402

DBC = os.environ.get("TELEOP_DBC") or os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "proto",
                                                   "teleop.dbc")
RATE_HZ = 500.0


def encode(layout, frame_id, counter, values, flags=1):
    """Bytes of one frame: every used signal set from `values(signal)` (physical units), counters, flags."""
    _, signals, length = layout.frames[frame_id]
    word = 0
    for s in signals:
        if s.name.startswith("Counter"):
            raw = counter
        elif s.name == "Flags":
            raw = flags
        elif s.name == "Layout":
            raw = 1
        else:
            raw = round((values(s) - s.offset) / s.factor)
        word |= (raw & ((1 << s.length) - 1)) << s.start
    return word.to_bytes(length, "little")


def frame_text(frame_id, data, fd):
    # Flags 5 = BRS | FDF: kernels since 6.0 mark every received FD frame with FDF, and candump prints it.
    return f"{frame_id:03X}##5{data.hex().upper()}" if fd else f"{frame_id:03X}#{data.hex().upper()}"


def capture(dof, fd, cycles=100, rate_hz=RATE_HZ, skip_cycle=None, spoil=None):
    """Lines of a clean capture: both directions, `cycles` cycles. spoil(direction, cycle, frame_id, data) may
    return replacement bytes."""
    messages = checker.parse_dbc(DBC)
    layouts = {"MASTER": checker.Layout(messages, "MASTER", dof, fd), "SLAVE": checker.Layout(messages, "SLAVE", dof, fd)}
    lines = []
    t0 = 1700000000.0
    for n in range(cycles):
        if n == skip_cycle:
            continue
        for sender, layout in layouts.items():
            for frame_id in sorted(layout.frames):
                data = encode(layout, frame_id, n % 16, lambda s: 0.001 * (n % 50) * (1 if sender == "MASTER" else -1))
                if spoil:
                    data = spoil(sender, n, frame_id, data) or data
                lines.append(f"({t0 + n / rate_hz:.6f}) vcan0 {frame_text(frame_id, data, fd)}")
    return lines


def summary(sent, rejected_by_reason=None, **overrides):
    reasons = rejected_by_reason or {}
    s = {"role": "x", "stop_reason": "duration", "cycles": sent, "achieved_rate_hz": RATE_HZ, "watchdog_trips": 0,
         "nonfinite_inputs": 0, "dof_mismatches": 0, "device_fault_cycles": 0,
         "packets": {"sent": sent, "send_errors": 0, "received": sent, "accepted": sent, "lost": 0, "reordered": 0,
                     "duplicates": 0, "rejected": sum(reasons.values()), "wrong_sender": 0, "superseded": 0,
                     "bus_errors": 0, "rejected_by_reason": reasons}}
    s.update(overrides)
    return s


class CaptureCheckTest(unittest.TestCase):
    def run_checker(self, lines, dof, fd, injected=None, master=None, slave=None, rate_hz=RATE_HZ):
        with tempfile.TemporaryDirectory() as tmp:
            log = os.path.join(tmp, "candump.log")
            with open(log, "w", encoding="utf-8") as f:
                f.write("\n".join(lines) + "\n")
            args = ["--dbc", DBC, "--log", log, "--dof", str(dof), "--rate-hz", str(rate_hz),
                    "--report", os.path.join(tmp, "report.json")]
            if fd:
                args.append("--fd")
            if injected is not None:
                path = os.path.join(tmp, "injected.txt")
                with open(path, "w", encoding="utf-8") as f:
                    f.write("\n".join(injected) + "\n")
                args += ["--injected", path]
            for name, content in (("master", master), ("slave", slave)):
                if content is not None:
                    path = os.path.join(tmp, name + ".json")
                    with open(path, "w", encoding="utf-8") as f:
                        json.dump(content, f)
                    args += [f"--{name}-summary", path]
            out = io.StringIO()
            with redirect_stdout(out):
                status = checker.main(args)
            with open(os.path.join(tmp, "report.json"), encoding="utf-8") as f:
                report = json.load(f)
        return status, report

    def assert_violation(self, report, text):
        self.assertTrue(any(text in v for v in report["violations"]),
                        f"expected a violation containing '{text}', got {report['violations'][:5]}")

    def test_layout_lengths_follow_the_dbc(self):
        messages = checker.parse_dbc(DBC)
        # (dof, fd) -> frame lengths of one direction: the table of tests/can/can_codec_test.cpp (SlotLength,
        # FdDataBytes rounded to an FD length), here derived from the DBC alone.
        classic = [[7], [8, 4], [8, 8], [8, 8, 6], [8, 8, 8, 4], [8, 8, 8, 8]]
        fd_lengths = [7, 12, 16, 24, 32, 32, 48, 48, 48, 64, 64, 64]  # classic CAN stops at 6 DOF, FD at 12
        expected = {}
        for dof in range(1, 13):
            if dof <= 6:
                expected[(dof, False)] = classic[dof - 1]
            expected[(dof, True)] = [fd_lengths[dof - 1]]
        for (dof, fd), lengths in expected.items():
            layout = checker.Layout(messages, "SLAVE", dof, fd)
            self.assertEqual([layout.frames[i][2] for i in sorted(layout.frames)], lengths, f"dof {dof} fd {fd}")

    def test_golden_frames_of_the_cpp_codec_decode_to_their_sample(self):
        # Bytes from tests/can/can_codec_test.cpp (GoldenClassicFramesThreeDof, GoldenFdFrameIsTheSlotsConcatenated).
        messages = checker.parse_dbc(DBC)
        slot0 = bytes([0x15, 0x91, 0x01, 0xFC, 0x6F, 0x09, 0xFF, 0x7F])
        slot1 = bytes([0x15, 0x80, 0x00, 0xFC, 0xFF, 0x00, 0x10, 0x00])
        expected = {"Counter": 5, "Counter_S0": 5, "Counter_S1": 5, "Flags": 0x11, "Position0": 0.001,
                    "Position1": -0.00002, "Position2": 0.16382, "Velocity0": -0.004, "Velocity1": 0.002,
                    "Velocity2": 0.0, "Force0": 1.5, "Force1": -20.47, "Force2": 0.01, "Layout": 1}
        cases = [(checker.Layout(messages, "MASTER", 3, False), 0x100, slot0, False),
                 (checker.Layout(messages, "MASTER", 3, False), 0x101, slot1, False),
                 (checker.Layout(messages, "SLAVE", 3, True), 0x184, slot0 + slot1, True)]
        for layout, frame_id, data, fd in cases:
            violations = []
            frame = dict(id=frame_id, fd=fd, extended=False, data=data, line=1, text="golden", bad=None)
            self.assertEqual(checker.check_frame(frame, layout, violations), 5)
            self.assertEqual(violations, [])
            for s in layout.frames[frame_id][1]:
                value = s.raw(data) * s.factor + s.offset
                self.assertAlmostEqual(value, expected[s.name], delta=1e-9, msg=f"{frame_id:x} {s.name}")

    def test_clean_captures_pass(self):
        for dof in (1, 3, 6):
            for fd in (False, True):
                status, report = self.run_checker(capture(dof, fd), dof, fd)
                self.assertEqual(report["violations"], [], f"dof {dof} fd {fd}")
                self.assertEqual(status, 0)
                self.assertEqual(report["master_to_slave"]["cycles"], 100)
                self.assertEqual(report["slave_to_master"]["cycles"], 100)
                self.assertAlmostEqual(report["slave_to_master"]["rate_hz"], RATE_HZ, delta=0.5)

    def test_wrong_length_is_named(self):
        lines = capture(3, False, spoil=lambda d, n, i, data: data[:7] if (d, n, i) == ("SLAVE", 40, 0x181) else None)
        status, report = self.run_checker(lines, 3, False)
        self.assertEqual(status, 1)
        self.assert_violation(report, "length 7, the DBC layout needs 8")

    def test_reserved_bit_is_named(self):
        # 1 DOF: bits 49..55 after the layout marker (bit 48) are reserved.
        lines = capture(1, False, spoil=lambda d, n, i, data: data[:6] + bytes([data[6] | 0x80]) if n == 7 else None)
        status, report = self.run_checker(lines, 1, False)
        self.assertEqual(status, 1)
        self.assert_violation(report, "reserved bits set")

    def test_a_layout_1_frame_is_named(self):
        # Slot 0 without the layout marker (bit 62 for 3 DOF): what a build of CAN layout 1 sends there.
        def unmark(direction, n, frame_id, data):
            return data[:7] + bytes([data[7] & ~0x40]) if (direction, n, frame_id) == ("MASTER", 20, 0x100) else None
        status, report = self.run_checker(capture(3, False, spoil=unmark), 3, False)
        self.assertEqual(status, 1)
        self.assert_violation(report, "layout marker 0")

    def test_lost_cycle_is_counted(self):
        status, report = self.run_checker(capture(3, True, skip_cycle=30), 3, True)
        self.assertEqual(status, 1)
        self.assertEqual(report["master_to_slave"]["counter_gaps"], 1)
        self.assert_violation(report, "1 cycle(s) lost")

    def test_nan_code_is_named(self):
        def nan_position0(direction, n, frame_id, data):
            if direction == "MASTER" and n == 12:
                word = int.from_bytes(data, "little") & ~(0x3FFF << 11) | (0x2000 << 11)  # -8192 = NaN
                return word.to_bytes(len(data), "little")
            return None
        status, report = self.run_checker(capture(1, False, spoil=nan_position0), 1, False)
        self.assertEqual(status, 1)
        self.assert_violation(report, "Position0 carries the NaN code")

    def test_mixed_counters_in_one_fd_frame_are_named(self):
        def mix(direction, n, frame_id, data):
            if direction == "SLAVE" and n == 50:
                return data[:8] + bytes([(data[8] & 0xF0) | ((n + 3) % 16)]) + data[9:]
            return None
        status, report = self.run_checker(capture(3, True, spoil=mix), 3, True)
        self.assertEqual(status, 1)
        self.assert_violation(report, "slots carry different counters")

    def test_slow_bus_is_named(self):
        status, report = self.run_checker(capture(1, False, rate_hz=300.0), 1, False)
        self.assertEqual(status, 1)
        self.assert_violation(report, "cycles/s on the bus, below 0.80 x 500 Hz")

    def test_foreign_frame_is_named_unless_injected(self):
        lines = capture(1, False)
        lines.insert(20, "(1700000000.020100) vcan0 555#01")
        status, report = self.run_checker(lines, 1, False)
        self.assertEqual(status, 1)
        self.assert_violation(report, "555#01: not a configured identifier")
        status, report = self.run_checker(lines, 1, False, injected=["slave - 555#01"])
        self.assertEqual(report["violations"], [])

    def test_injections_must_be_counted_by_the_right_process(self):
        lines = capture(3, True)
        injected_frames = {"bad_length": "184##10102030405060708090A0B", "bad_crc": "184##1" + "01" + "00" * 7 + "02" +
                           "00" * 7, "bad_magic": "180##1" + "00" * 16}
        for k, text in enumerate(injected_frames.values()):
            # As captured: the kernel adds FDF (##1 sent with cansend is logged as ##5).
            lines.insert(30 + 10 * k, f"(1700000000.{100000 + k:06d}) vcan0 {text.replace('##1', '##5')}")
        injected = [f"master {reason} {text}" for reason, text in injected_frames.items()] + ["master - 555#01"]
        lines.insert(70, "(1700000000.200000) vcan0 555#01")
        counted = {"bad_length": 1, "bad_crc": 1, "bad_magic": 1}
        status, report = self.run_checker(lines, 3, True, injected, master=summary(100, counted), slave=summary(100))
        self.assertEqual(report["violations"], [])
        self.assertEqual(status, 0)
        self.assertEqual(report["master"]["rejected_by_reason"], counted)

        status, report = self.run_checker(lines, 3, True, injected, master=summary(100, dict(counted, bad_crc=0)),
                                          slave=summary(100))
        self.assertEqual(status, 1)
        self.assert_violation(report, "master: rejected_by_reason.bad_crc = 0, expected 1")

        status, report = self.run_checker(lines, 3, True, injected + ["slave bad_length 184##1FFFF"],
                                          master=summary(100, counted), slave=summary(100))
        self.assertEqual(status, 1)
        self.assert_violation(report, "injected 184##1FFFF (slave bad_length) appears 0 times")

    def test_disturbed_loop_is_named(self):
        lines = capture(1, False)
        status, report = self.run_checker(lines, 1, False, master=summary(100, watchdog_trips=2),
                                          slave=summary(99))
        self.assertEqual(status, 1)
        self.assert_violation(report, "master: watchdog_trips = 2, expected 0")
        self.assert_violation(report, "slave: sent 99 samples, the capture holds 100 cycles")

    def test_summary_rate_must_match_the_bus(self):
        status, report = self.run_checker(capture(1, False), 1, False, master=summary(100, achieved_rate_hz=400.0),
                                          slave=summary(100))
        self.assertEqual(status, 1)
        self.assert_violation(report, "master: reports 400.0 Hz achieved, its frames came at 500.0 cycles/s")

    def motion_capture(self, contact_scale=1.0, ring_m=0.0):
        """A 3-DOF FD capture of the qemu run's configs (tests/qemu/configs), 2 s at 500 Hz, whose positions rest
        at the static balance from 0.6 s on: axis 0 in the fixture (p = 1 N / (200·(1 + 1000/600) + 1000) N/m,
        times contact_scale), axis 2 free at -1 N / 200 N/m. ring_m adds a vibration to the slave."""
        p = contact_scale * 1.0 / (200.0 * (1.0 + 1000.0 / 600.0) + 1000.0)
        rest = {"MASTER": {0: 0.01 + p + 1000.0 * p / 600.0, 1: 0.0, 2: -0.005},
                "SLAVE": {0: 0.01 + p, 1: 0.0, 2: -0.005}}
        messages = checker.parse_dbc(DBC)
        layouts = {k: checker.Layout(messages, k, 3, True) for k in ("MASTER", "SLAVE")}
        lines = []
        for n in range(1000):
            for sender, layout in layouts.items():
                def value(s):
                    if not s.name.startswith("Position") or n < 300:
                        return 0.0
                    ring = ring_m * (1 if n % 2 else -1) if sender == "SLAVE" and s.dof == 0 else 0.0
                    return rest[sender][s.dof] + ring
                for frame_id in sorted(layout.frames):
                    data = encode(layout, frame_id, n % 16, value)
                    lines.append(f"({1700000000.0 + n / RATE_HZ:.6f}) vcan0 {frame_text(frame_id, data, True)}")
        return lines

    def run_motion(self, lines):
        here = os.path.dirname(os.path.abspath(__file__))
        with tempfile.TemporaryDirectory() as tmp:
            log = os.path.join(tmp, "candump.log")
            with open(log, "w", encoding="utf-8") as f:
                f.write("\n".join(lines) + "\n")
            report_path = os.path.join(tmp, "report.json")
            args = ["--dbc", DBC, "--log", log, "--dof", "3", "--fd", "--rate-hz", str(RATE_HZ), "--report",
                    report_path, "--master-config", os.path.join(here, "configs", "master_can.yaml"),
                    "--slave-config", os.path.join(here, "configs", "slave_can.yaml")]
            with redirect_stdout(io.StringIO()):
                status = checker.main(args)
            with open(report_path, encoding="utf-8") as f:
                return status, json.load(f)

    def test_motion_at_the_static_balance_passes(self):
        status, report = self.run_motion(self.motion_capture())
        self.assertEqual(report["violations"], [])
        self.assertEqual(status, 0)
        self.assertAlmostEqual(report["motion"]["0"]["slave_predicted_m"] - 0.01, 1.0 / 1533.333, delta=1e-9)
        self.assertAlmostEqual(report["motion"]["2"]["master_predicted_m"], -0.005, delta=1e-12)
        self.assertIn("not checked", report["motion"]["1"])  # the sine axis is never static

    def test_motion_needs_a_long_enough_run(self):
        status, report = self.run_motion(self.motion_capture()[:2 * 400])  # 0.8 s: axis 0 holds from 0.6 s only
        self.assertEqual(status, 1)
        self.assert_violation(report, "motion axis 0: the master's simulated time reached 0.798 s, too short")

    def test_motion_off_the_balance_is_named(self):
        # K_p halved puts the contact balance 18 % shallower; the fixture force halved 76 % deeper.
        for scale in (0.82, 1.76):
            status, report = self.run_motion(self.motion_capture(contact_scale=scale))
            self.assertEqual(status, 1)
            self.assert_violation(report, "motion axis 0: slave rests at")
        status, report = self.run_motion(self.motion_capture(ring_m=0.0002))
        self.assertEqual(status, 1)
        self.assert_violation(report, "motion axis 0: the slave moves over")


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1].endswith(".dbc"):
        DBC = sys.argv.pop(1)
    unittest.main(verbosity=1)
