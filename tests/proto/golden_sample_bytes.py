#!/usr/bin/env python3
"""Independent generator of the UDP sample golden bytes (docs/protocol.md, version 1).

Written from the byte-layout table in docs/protocol.md with Python's `struct` and a bitwise CRC-32C, sharing no
code with the C++ encoder in proto/. It is the reference the golden arrays in tests/proto/codec_test.cpp and the
hex dump in docs/protocol.md are checked against:

  golden_sample_bytes.py                       print both messages (C++ initialisers and a hex dump)
  golden_sample_bytes.py --check-cpp FILE      FILE's kOneDofGolden / kSixDofGolden / kTwoDofEnergyGolden arrays
                                               are these bytes
  golden_sample_bytes.py --check-doc FILE      the hex dump in FILE's "Example: 1 DOF" section is the 1-DOF message

Exit 0 when every check given passes, 1 otherwise (each difference is printed).
"""
import argparse
import re
import struct
import sys

MAGIC = 0x504F4C54  # "TLOP"
VERSION = 1
TYPE_SAMPLE = 1
ROLE_MASTER, ROLE_SLAVE = 0, 1
FLAG_ENABLED, FLAG_IN_FIXTURE = 1 << 0, 1 << 4


def crc32c(data):
    """CRC-32C (Castagnoli), bit by bit: reflected polynomial 0x82F63B78 (= 0x1EDC6F41 reversed), initial value and
    final XOR 0xFFFFFFFF."""
    crc = 0xFFFFFFFF
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = (crc >> 1) ^ (0x82F63B78 if crc & 1 else 0)
    return crc ^ 0xFFFFFFFF


def sample(sender, flags, sequence, sender_time_ns, echo_time_ns, echo_age_ns, dofs, energies=None):
    """One sample datagram: the 36-byte header, 24 bytes per DOF (position, velocity, force as binary64), then
    when `energies` is given the energy block (16 bytes per DOF: input, output energy as binary64), CRC-32C of
    everything before it, all little-endian, no padding. payload_length says which: 24 or 40 bytes per DOF."""
    per_dof = 24 if energies is None else 40
    header = struct.pack("<IBBBBBBHIQQI", MAGIC, VERSION, TYPE_SAMPLE, sender, flags, len(dofs), 0,
                         per_dof * len(dofs), sequence, sender_time_ns, echo_time_ns, echo_age_ns)
    assert len(header) == 36
    body = header + b"".join(struct.pack("<ddd", *d) for d in dofs)
    if energies is not None:
        assert len(energies) == len(dofs)
        body += b"".join(struct.pack("<dd", *e) for e in energies)
    return body + struct.pack("<I", crc32c(body))


def one_dof():
    # docs/protocol.md, "Example: 1 DOF, hand-checked".
    return sample(ROLE_SLAVE, FLAG_ENABLED | FLAG_IN_FIXTURE, 0x01020304, 0x1122334455667788, 0x0102030405060708,
                  250000, [(0.25, -1.5, 2.0)])


def six_dof():
    # tests/proto/codec_test.cpp, SixDofGoldenMessage(): DOF i = 0..5 at 0.01 (i+1) m, -0.5 (i+1) m/s,
    # 10 (i+1) - 25 N; sequence at its wrap point.
    return sample(ROLE_MASTER, FLAG_ENABLED, 0xFFFFFFFF, 1000000000, 999000000, 123456,
                  [(0.01 * (i + 1), -0.5 * (i + 1), 10.0 * (i + 1) - 25.0) for i in range(6)])


def two_dof_energy():
    # tests/proto/codec_test.cpp, TwoDofEnergyGoldenMessage(): the energy block (time-domain passivity).
    return sample(ROLE_MASTER, FLAG_ENABLED, 7, 2000000000, 1999000000, 1000,
                  [(0.125, 0.5, -1.0), (-0.25, -0.75, 3.0)], energies=[(1.5, 0.25), (0.0, 2.0)])


def cpp_array(data):
    rows = [", ".join(f"0x{b:02X}" for b in data[i:i + 12]) for i in range(0, len(data), 12)]
    return "{\n    " + ",  //\n    ".join(rows) + ",\n}"


def parse_cpp_array(text, name):
    m = re.search(name + r"\s*=\s*\{(.*?)\};", text, re.S)
    if not m:
        return None
    return bytes(int(x, 16) for x in re.findall(r"0x([0-9A-Fa-f]{2})", m.group(1)))


def parse_doc_dump(text):
    """The bytes of the fenced block after the heading "### Example: 1 DOF": on each line, the leading run of
    two-digit hex tokens (what follows them is commentary)."""
    at = text.find("### Example: 1 DOF")
    if at < 0:
        return None
    m = re.search(r"```\n(.*?)```", text[at:], re.S)
    if not m:
        return None
    out = bytearray()
    for line in m.group(1).splitlines():
        for token in line.split():
            if not re.fullmatch(r"[0-9A-Fa-f]{2}", token):
                break
            out.append(int(token, 16))
    return bytes(out)


def compare(what, got, want):
    if got is None:
        print(f"FAILED: {what}: not found")
        return False
    if got == want:
        print(f"ok: {what} ({len(want)} bytes)")
        return True
    print(f"FAILED: {what}: {len(got)} bytes, expected {len(want)}")
    for i in range(max(len(got), len(want))):
        g = f"{got[i]:02X}" if i < len(got) else "--"
        w = f"{want[i]:02X}" if i < len(want) else "--"
        if g != w:
            print(f"  offset {i}: {g}, expected {w}")
    return False


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--check-cpp")
    ap.add_argument("--check-doc")
    args = ap.parse_args()
    ok = compare("CRC-32C check value of '123456789'", struct.pack("<I", crc32c(b"123456789")),
                 struct.pack("<I", 0xE3069283))
    if not args.check_cpp and not args.check_doc:
        for name, data in (("kOneDofGolden", one_dof()), ("kSixDofGolden", six_dof()),
                           ("kTwoDofEnergyGolden", two_dof_energy())):
            print(f"constexpr std::array<std::uint8_t, {len(data)}> {name} = {cpp_array(data)};")
        print(" ".join(f"{b:02X}" for b in one_dof()))
    if args.check_cpp:
        text = open(args.check_cpp).read()
        ok &= compare("kOneDofGolden in " + args.check_cpp, parse_cpp_array(text, "kOneDofGolden"), one_dof())
        ok &= compare("kSixDofGolden in " + args.check_cpp, parse_cpp_array(text, "kSixDofGolden"), six_dof())
        ok &= compare("kTwoDofEnergyGolden in " + args.check_cpp, parse_cpp_array(text, "kTwoDofEnergyGolden"),
                      two_dof_energy())
    if args.check_doc:
        ok &= compare("hex dump in " + args.check_doc, parse_doc_dump(open(args.check_doc).read()), one_dof())
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
