#!/usr/bin/env python3
"""deploy/figures.sh, the one command behind docs/figures.md: run into a scratch directory, every figure the gallery
shows must be produced and be a real plot, and the gallery must show every figure the command writes. A PNG is
"non-trivial" when it decodes (signature, IHDR, zlib-compressed IDAT), is at least 400 x 300 pixels and 5 KB, and its
pixel rows hold at least 4 distinct byte values with no one value over 99 % of them (a blank or one-colour image
fails both; a gnuplot palette image of a plot has about 10 values, an RGB one 256). Every gnuplot
figure must show all of its data and keep its key off them (figure_check.py: each panel's axis ranges against the
extent autoscaling finds; the pixels a key inside the axes covers against those the data draw) and its labels on the
canvas; every figure, matplotlib's too, must use most of the canvas and have nothing cut by its edge. The
committed docs/figures/ must hold the same names and stay under 2 MB.
"""
import os
import re
import struct
import subprocess
import sys
import zlib

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "test_utilities"))
from teleop_process import Failure, check, run_test  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import figure_check  # noqa: E402

ROOT = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))


def png_facts(path):
    data = open(path, "rb").read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise Failure(f"{path}: not a PNG")
    pos, idat, width, height = 8, b"", 0, 0
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            width, height = struct.unpack(">II", body[:8])
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    raw = zlib.decompress(idat)
    counts = {}
    for b in raw[::7]:  # a sample of the bytes is enough to tell a plot from a blank
        counts[b] = counts.get(b, 0) + 1
    top = max(counts.values()) / sum(counts.values())
    return width, height, len(set(raw)), top, len(data)


def main():
    build = os.environ.get("TELEOP_BUILD", os.path.join(ROOT, "build"))
    out = os.path.join(build, "tests", "deploy", "figures")
    r = subprocess.run([os.path.join(ROOT, "deploy", "figures.sh"), "--out", out], env=dict(os.environ,
                       TELEOP_BUILD=build), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=420)
    print(r.stdout[-1500:])
    check(r.returncode == 0, "deploy/figures.sh --out <scratch> exits 0")
    written = sorted(f for f in os.listdir(out) if f.endswith(".png"))
    gallery = open(os.path.join(ROOT, "docs", "figures.md")).read()
    shown = sorted(set(re.findall(r"\]\(figures/([A-Za-z0-9_.-]+\.png)\)", gallery)))
    check(shown == written, f"docs/figures.md shows exactly the {len(written)} figures the command writes "
          f"(missing from the gallery: {sorted(set(written) - set(shown))}, "
          f"not written: {sorted(set(shown) - set(written))})")
    for name in written:
        w, h, distinct, top, size = png_facts(os.path.join(out, name))
        check(w >= 400 and h >= 300 and distinct >= 4 and top < 0.99 and size > 5000,
              f"{name}: {w} x {h}, {distinct} distinct byte values (the commonest {100 * top:.0f} %), "
              f"{size // 1024} KiB")
    # Every gnuplot figure (all but deploy/teleop-plot's, which matplotlib autoscales and whose legends are placed
    # outside the axes) shows all of its data and keeps its key off the data and the labels (figure_check.py): each
    # panel's axis ranges hold the extent gnuplot finds with autoscaling, unless the script declares a clipped axis; a
    # key inside the axes has (almost) no data pixels under it; no key's text sits on an axis label, tick label or
    # title. The old figures failed all three: cobot-wall (x 0..250 mm of a 500 mm run, arrow tips above y = 30),
    # hybrid-friction (291 data pixels under the forces key), cobot-caster (its key box over 'x (mm)').
    manifest = [line.split() for line in open(os.path.join(build, "figures", "gnuplot-scripts.txt")) if line.strip()]
    drawn_by_gnuplot = sorted(n for n in written if not re.match(r"demo-(master|slave)-", n))
    check(sorted(n for n, _ in manifest) == drawn_by_gnuplot,
          f"deploy/figures.sh names the gnuplot script of each of the {len(drawn_by_gnuplot)} gnuplot figures")
    # Every PNG, matplotlib's too: its axes span at least half the canvas's width and height, and nothing is cut by
    # the canvas's edge (figure_check.canvas_check); a gnuplot figure's `set label`s are drawn and on the canvas
    # (figure_check.label_check).
    for name in written:
        _, msg, ok = figure_check.canvas_check(os.path.join(out, name))
        check(ok, f"{name}: {msg}")
    for name, script in manifest:
        _, msg, ok = figure_check.label_check(script)
        check(ok, f"{name}: {msg}")
    for name, script in manifest:
        panels = figure_check.check_script(script)
        for panel, msg, ok in panels:
            print(f"  {name} plot {panel}: {msg}")
        check(panels and all(ok for _, _, ok in panels),
              f"{name}: every panel shows all of its data, its key off them and off the labels")
    committed = os.path.join(ROOT, "docs", "figures")
    have = sorted(f for f in os.listdir(committed) if f.endswith(".png"))
    check(have == written, "docs/figures/ holds the same figures (rerun ./deploy/figures.sh after a change)")
    total = sum(os.path.getsize(os.path.join(committed, f)) for f in have)
    check(total < 2 * 1024 * 1024, f"docs/figures/ is {total // 1024} KiB (under 2 MB)")
    return 0


if __name__ == "__main__":
    run_test(main)
