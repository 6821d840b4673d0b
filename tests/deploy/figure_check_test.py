#!/usr/bin/env python3
"""figure_check.py (deploy.figures' readability check) on small gnuplot scripts whose verdict is known by construction:
a y range cut below the data's maximum, a key placed on a curve, the same key moved to an empty corner, a key outside
the axes, a declared clip, a key below the axes over the x label and then clear of it, axes in a corner of the
canvas, a label beyond the canvas and one cut by its edge. Each must get the verdict
its construction gives; about 2 s.
"""
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "test_utilities"))
sys.path.insert(0, HERE)
from teleop_process import check, run_test  # noqa: E402
import figure_check  # noqa: E402

HEAD = "set terminal png size 600,400\nset output 'x.png'\nset grid\n"
# A curve from (0, 0) to (10, 50) along the diagonal of the axes, and a second one flat at y = 45 across the top.
DATA = "0 0 45\n10 50 45\n"
PLOT = "plot 'd.dat' using 1:2 w l lw 3 t 'rising', '' using 1:3 w l lw 3 t 'flat at 45'\n"


def write(directory, name, body):
    path = os.path.join(directory, name)
    with open(path, "w") as f:
        f.write(HEAD + body)
    return path


def verdict(directory, name, body, text=False):
    """The verdict on the script's one plot, or with text=True the one on its key and label text."""
    path = write(directory, name, body)
    panels = figure_check.check_script(path)
    for panel, msg, ok in panels:
        print(f"  {name} {panel}: {'ok' if ok else 'FAIL'}: {msg}")
    check(len(panels) == 2 and panels[0][0] == "text", f"{name}: the text check and one plot ({len(panels)})")
    return panels[0] if text else panels[1]


def main():
    with tempfile.TemporaryDirectory() as tmp:
        with open(os.path.join(tmp, "d.dat"), "w") as f:
            f.write(DATA)
        _, msg, ok = verdict(tmp, "clipped.gp", "set xrange [0:10]\nset yrange [0:30]\nset key bottom right\n" + PLOT)
        check(not ok and "CLIPPED" in msg, "y range [0:30] of data reaching 50 fails as clipped")
        _, msg, ok = verdict(tmp, "declared.gp", "set yrange [0:30]\nset key bottom right\n"
                             "# ranges: y clipped (test)\n" + PLOT)
        check(ok and "declared clipped" in msg, "the same clip declared in the script passes")
        # The key's top right corner at (8, 47): its two entries reach down across the flat curve at y = 45.
        _, msg, ok = verdict(tmp, "covering.gp", "set yrange [0:50]\nset key at first 8, first 47\n" + PLOT)
        check(not ok and "COVERS DATA" in msg, "a key over the curve at y = 45 fails")
        # The lower-right corner is empty: the rising curve runs from the lower-left corner to the upper-right one.
        _, msg, ok = verdict(tmp, "corner.gp", "set yrange [0:50]\nset key bottom right\n" + PLOT)
        check(ok and "key inside: 0 of" in msg, "the key in the empty lower-right corner passes with no data under it")
        _, msg, ok = verdict(tmp, "outside.gp", "set yrange [0:50]\nset key outside right\n" + PLOT)
        check(ok and "key outside the axes" in msg, "a key outside the axes passes")
        # gnuplot's key below the axes lands on the x label unless the bottom margin leaves room for both.
        below = "set yrange [0:50]\nset xlabel 'x (mm)'\nset key below box opaque\n"
        text = verdict(tmp, "below.gp", below + PLOT, text=True)
        check(not text[2] and "KEY ON A LABEL" in text[1], "a key below drawn over the x label fails")
        text = verdict(tmp, "below_margin.gp", below + "set bmargin 6\n" + PLOT, text=True)
        check(text[2], "the same key with a bottom margin of 6 lines passes")
        # The canvas: axes in a corner of it, and labels placed beyond its edge.
        for name, body, fails in (("full.gp", "", False), ("squeezed.gp", "set size 0.45,0.45\n", True)):
            path = write(tmp, name, body + "set yrange [0:50]\nset key bottom right\n" + PLOT)
            subprocess.run(["gnuplot", name], cwd=tmp, check=True)
            _, msg, ok = figure_check.canvas_check(os.path.join(tmp, "x.png"))
            print(f"  {name}: {msg}")
            check(ok != fails and (("SQUEEZED" in msg) == fails),
                  f"{name}: the canvas check {'fails' if fails else 'passes'}")
        for name, label, fails in (("label_in.gp", "at first 2, first 40", False),
                                   ("label_beyond.gp", "at screen 0.5, screen 1.2", True),
                                   ("label_cut.gp", "at screen 0.97, screen 0.5", True)):
            path = write(tmp, name, f"set yrange [0:50]\nset label 'a wall at x = 5' {label}\n" + PLOT)
            _, msg, ok = figure_check.label_check(path)
            print(f"  {name}: {msg}")
            check(ok != fails, f"a label {label}: the label check {'fails' if fails else 'passes'}")
    return 0


if __name__ == "__main__":
    run_test(main)
