#!/usr/bin/env python3
"""Can a reader read a gnuplot figure? Three checks per plot of a script (each panel of a multiplot):

- Ranges: the axis ranges gnuplot drew (GPVAL_X_MIN ... GPVAL_Y_MAX) must hold the extent of the data it was given.
  The script is run a second time with every `set xrange/yrange [...]` replaced by autoscaling, where
  GPVAL_DATA_X_MIN ... GPVAL_DATA_Y_MAX are the extent of every curve, point and arrow tip. A panel whose data reach
  outside its axes is clipped and fails, unless the script says so on a line before the plot:
  `# ranges: y clipped (reason)` (the figure itself must tell the reader, for example in a key entry).
- Key: the key must not cover the data. The panel is drawn three times with the same axes and without the grid: as
  the script draws it (A), with `unset key` (B) and with its ranges fixed to A's and nothing plotted (C). A key
  outside the axes moves them (A's plot area differs from B's): it covers nothing. A key inside them is where A and B
  differ; the data are where B and C differ; the key fails when more than 0.2 % of its box (at least 20 pixels) is
  data.
- Text: a key must not sit on an axis label, a tick label or a title (gnuplot draws a key below the axes over the x
  label unless the bottom margin leaves room): the figure is drawn again with the keys' text white, then with the
  labels white (one result, "text", for the whole figure).

  figure_check.py SCRIPT.gp [...]    prints one line per panel and exits 1 when one fails

The passes draw into a temporary directory; a script runs in its own directory (the scenario scripts name their CSVs
relatively). Images are compared with Pillow and NumPy (python3-pil comes with python3-matplotlib).
"""
import os
import re
import subprocess
import sys
import tempfile

MARK = "FIGURE-CHECK"
RANGE_SET = re.compile(r"\bset\s+(x|y)range\s*\[[^\]]*\]")
OUTPUT_SET = re.compile(r"set\s+(o|ou|out|outp|outpu|output)\b")
REPORT = (f'print sprintf("{MARK} %.9g %.9g %.9g %.9g %.9g %.9g %.9g %.9g %d %d %d %d", GPVAL_X_MIN, GPVAL_X_MAX, '
          "GPVAL_Y_MIN, GPVAL_Y_MAX, GPVAL_DATA_X_MIN, GPVAL_DATA_X_MAX, GPVAL_DATA_Y_MIN, GPVAL_DATA_Y_MAX, "
          "GPVAL_TERM_XMIN, GPVAL_TERM_XMAX, GPVAL_TERM_YMIN, GPVAL_TERM_YMAX)")
KEY_SHARE = 0.002  # of the key's box that may be data: a stray pixel of a thick line at its edge is not a cover
KEY_MIN_PIXELS = 20


def statements(text):
    """The script's statements: continuation lines joined, `;`-separated commands split outside quotes."""
    text = re.sub(r"\\\n", " ", text)
    out = []
    for line in text.split("\n"):
        if line.lstrip().startswith("#"):
            out.append(line.strip())
            continue
        cur, quote = "", None
        for ch in line:
            if quote:
                quote = None if ch == quote else quote
            elif ch in "'\"":
                quote = ch
            elif ch == "#":
                break
            elif ch == ";":
                out.append(cur.strip())
                cur = ""
                continue
            cur += ch
        out.append(cur.strip())
    return [s for s in out if s]


def instrumented(stmts, output, mode, fixed=None):
    """The script for one pass. mode: 'drawn' as is, 'autoscale' with its ranges autoscaled, 'nokey' with every key
    off, 'empty' with each plot replaced by nothing on the axes in fixed (the ranges pass 'drawn' reported),
    'keytext' with the keys' text white, 'labeltext' with the axis labels, tick labels and titles white."""
    lines, clipped, pending, n = ["set print '-'"], [], "", 0
    for s in stmts:
        if s.startswith("#"):
            m = re.match(r"#\s*ranges:\s*([xy]+)\s+clipped", s)
            if m:
                pending = m.group(1)
            continue
        if OUTPUT_SET.match(s):
            s = f"set output '{output}'"
        if mode == "autoscale":
            s = RANGE_SET.sub(lambda m: f"set autoscale {m.group(1)}", s)
        if re.match(r"plot\b", s):
            lines.append("unset grid")  # where a key sits, gnuplot leaves out the grid: that is neither key nor data
            if mode in ("nokey", "empty"):
                lines.append("unset key")
            if mode == "keytext":
                lines.append("set key textcolor rgb 'white'")
            if mode == "labeltext":
                lines.append("set xlabel textcolor rgb 'white'; set ylabel textcolor rgb 'white'; "
                             "set tics textcolor rgb 'white'; set title textcolor rgb 'white'")
            if mode == "empty":
                x0, x1, y0, y1 = fixed[n][:4]
                lines.append(f"set xrange [{x0!r}:{x1!r}]; set yrange [{y0!r}:{y1!r}]")
                s = "plot NaN notitle"
            lines.append(s)
            lines.append(REPORT)
            clipped.append(pending)
            pending, n = "", n + 1
            continue
        lines.append(s)
    return "\n".join(lines) + "\n", clipped


def run(script, text):
    r = subprocess.run(["gnuplot"], input=text, cwd=os.path.dirname(os.path.abspath(script)), text=True,
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=120)
    if r.returncode != 0:
        raise RuntimeError(f"{script}: gnuplot exit {r.returncode}: {r.stderr[-500:]}")
    return [[float(v) for v in line.split()[1:]] for line in r.stdout.splitlines() if line.startswith(MARK)]


def pixels(path):
    import numpy
    from PIL import Image
    return numpy.asarray(Image.open(path).convert("RGB"), dtype=numpy.int16)


def key_cover(a, b, c, area):
    """(key box pixels, data pixels under it) in the plot area (x0, x1, y0, y1 in gnuplot's terminal pixels, y up)."""
    import numpy
    height = a.shape[0]
    x0, x1, y0, y1 = (int(v) for v in area)
    # Two pixels in from the border: the border itself and the tick marks on it are not data.
    rows = slice(max(0, height - y1 + 2), max(0, height - y0 - 2))
    cols = slice(max(0, x0 + 2), max(0, x1 - 2))
    key = numpy.any(a[rows, cols] != b[rows, cols], axis=2)
    if not key.any():
        return 0, 0
    ys, xs = numpy.nonzero(key)
    box = (slice(ys.min(), ys.max() + 1), slice(xs.min(), xs.max() + 1))
    data = numpy.any(b[rows, cols][box] != c[rows, cols][box], axis=2)
    return int(data.size), int(data.sum())


def text_clash(a, k, t, drawn, keytext, labeltext):
    """('text', message, ok): does a key sit on an axis label, a tick label or a title? Whitening text keeps the layout,
    so the key's text is where a and k differ, the labels where a and t differ. Each line of key text (a band of rows)
    spans the columns from its first to its last entry; a label within 4 pixels above or below that band and inside
    those columns is under or against the key (an opaque key box hides it, or the key's line runs into it)."""
    import numpy
    same = [r[8:12] for r in drawn]
    if [r[8:12] for r in keytext] != same or [r[8:12] for r in labeltext] != same:
        return ("text", "key and label text not checked: whitening the text moved the axes", False)
    key = numpy.any(a != k, axis=2)
    label = numpy.any(a != t, axis=2)
    rows = numpy.nonzero(key.any(axis=1))[0]
    bands, clash = [], 0
    for r in rows:
        if bands and r - bands[-1][1] <= 2:
            bands[-1][1] = r
        else:
            bands.append([r, r])
    for r0, r1 in bands:
        cols = numpy.nonzero(key[r0:r1 + 1].any(axis=0))[0]
        clash += int(label[max(0, r0 - 4):r1 + 5, cols.min():cols.max() + 1].sum())
    ok = clash == 0
    return ("text", f"key text in {len(bands)} bands of rows, {clash} label pixels against them"
            + ("" if ok else " KEY ON A LABEL"), ok)


def check_script(script):
    """A list of (panel, message, ok) for each plot of the script."""
    stmts = statements(open(script).read())
    with tempfile.TemporaryDirectory() as tmp:
        png = {m: os.path.join(tmp, f"{m}.png") for m in ("drawn", "autoscale", "nokey", "empty", "keytext",
                                                           "labeltext")}
        drawn_text, clipped = instrumented(stmts, png["drawn"], "drawn")
        drawn = run(script, drawn_text)
        data = run(script, instrumented(stmts, png["autoscale"], "autoscale")[0])
        nokey = run(script, instrumented(stmts, png["nokey"], "nokey")[0])
        empty = run(script, instrumented(stmts, png["empty"], "empty", fixed=drawn)[0]) if drawn else []
        if not drawn or not len(drawn) == len(data) == len(nokey) == len(empty):
            return [(0, f"plots: {len(drawn)} drawn, {len(data)} autoscaled, {len(nokey)} without keys, "
                        f"{len(empty)} empty: cannot compare", False)]
        keytext = run(script, instrumented(stmts, png["keytext"], "keytext")[0])
        labeltext = run(script, instrumented(stmts, png["labeltext"], "labeltext")[0])
        a, b, c = pixels(png["drawn"]), pixels(png["nokey"]), pixels(png["empty"])
        results = [text_clash(a, pixels(png["keytext"]), pixels(png["labeltext"]), drawn, keytext, labeltext)]
        for i, (axes, extent, bare, blank, allowed) in enumerate(zip(drawn, data, nokey, empty, clipped), start=1):
            msgs, ok = [], True
            for k, axis in enumerate("xy"):
                lo, hi = axes[2 * k], axes[2 * k + 1]
                dlo, dhi = extent[4 + 2 * k], extent[4 + 2 * k + 1]
                # Half a thousandth of the span: a point drawn on the border (data max = axis max) is shown.
                tol = 5e-4 * abs(hi - lo)
                inside = dlo >= lo - tol and dhi <= hi + tol
                msgs.append(f"{axis} axis [{lo:g}, {hi:g}], data [{dlo:g}, {dhi:g}]"
                            + ("" if inside else (" declared clipped" if axis in allowed else " CLIPPED")))
                ok = ok and (inside or axis in allowed)
            area = axes[8:12]
            if area != bare[8:12]:
                msgs.append("key outside the axes")
            else:
                box, covered = key_cover(a, b, c, area)
                if box == 0:
                    msgs.append("no key inside the axes")
                elif area != blank[8:12]:
                    msgs.append("a key inside the axes, not checked: the empty panel's axes moved")
                    ok = False
                else:
                    bad = covered > max(KEY_MIN_PIXELS, KEY_SHARE * box)
                    msgs.append(f"key inside: {covered} of its {box} pixels over data"
                                + (" COVERS DATA" if bad else ""))
                    ok = ok and not bad
            results.append((i, "; ".join(msgs), ok))
        return results


# The canvas check (any PNG, gnuplot's or matplotlib's): what is drawn must use the canvas and stay on it.
PLOT_AREA_MIN = 0.5  # of the canvas's width and of its height, the plot area (the axes' frames) must span
EDGE_PX = 2  # nothing but the background within this many pixels of the canvas's edge


def canvas_check(png):
    """('canvas', message, ok) for a PNG. The plot area is the box around the axes' frames: the rows and columns
    with a dark straight run (every channel below 128) over at least a quarter of the canvas, which frames, axes and
    panel borders are and text, grid lines and curves are not. It must span PLOT_AREA_MIN of the canvas's width and
    of its height (demo-cobot.png once drew its axes in the middle third). Text or a line cut by the canvas's edge
    leaves pixels other than the background (the corner pixel's colour) in the outermost EDGE_PX pixels: a label
    placed beyond the canvas fails. A label placed entirely beyond it draws nothing; check_script's passes are where
    a gnuplot figure is checked for that."""
    import numpy
    img = pixels(png)
    height, width = img.shape[:2]
    dark = numpy.all(img < 128, axis=2)

    def longest_runs(mask):  # per row: the longest run of True
        best = numpy.zeros(mask.shape[0], dtype=int)
        cur = numpy.zeros(mask.shape[0], dtype=int)
        for col in range(mask.shape[1]):
            cur = numpy.where(mask[:, col], cur + 1, 0)
            best = numpy.maximum(best, cur)
        return best

    rows = numpy.nonzero(longest_runs(dark) >= width // 4)[0]
    cols = numpy.nonzero(longest_runs(dark.T) >= height // 4)[0]
    msgs, ok = [], True
    if len(rows) < 2 or len(cols) < 2:
        msgs.append("no axes frame found")
        ok = False
    else:
        fw = (cols.max() - cols.min()) / width
        fh = (rows.max() - rows.min()) / height
        small = fw < PLOT_AREA_MIN or fh < PLOT_AREA_MIN
        msgs.append(f"plot area {100 * fw:.0f} % of the width, {100 * fh:.0f} % of the height"
                    + (" SQUEEZED" if small else ""))
        ok = not small
    background = img[0, 0]
    edge = numpy.ones((height, width), dtype=bool)
    edge[EDGE_PX:height - EDGE_PX, EDGE_PX:width - EDGE_PX] = False
    cut = int((numpy.any(img != background, axis=2) & edge).sum())
    msgs.append(f"{cut} drawn pixels at the canvas's edge" + (" CUT BY THE EDGE" if cut else ""))
    return ("canvas", "; ".join(msgs), ok and cut == 0)


LABEL_COLOUR = re.compile(r"\b(?:tc|textcolor)\s+(?:rgb\s+(?:\"[^\"]*\"|'[^']*')|(?:lt|ls)\s+\S+|default)")


def label_check(script):
    """('labels', message, ok): each `set label` of a gnuplot script is drawn, and inside the canvas. The figure is
    drawn again with every label white: a label whose text changes no pixel is placed off the canvas; one whose
    pixels reach the canvas's edge is cut by it."""
    import numpy
    stmts = statements(open(script).read())
    labels = [s for s in stmts if re.match(r"set\s+label\b", s)]
    if not labels:
        return ("labels", "no set label", True)
    with tempfile.TemporaryDirectory() as tmp:
        a_png, w_png = os.path.join(tmp, "a.png"), os.path.join(tmp, "w.png")
        run(script, instrumented(stmts, a_png, "drawn")[0])
        white = [LABEL_COLOUR.sub("", s) + " textcolor rgb 'white'" if re.match(r"set\s+label\b", s) else s
                 for s in stmts]
        run(script, instrumented(white, w_png, "drawn")[0])
        a, w = pixels(a_png), pixels(w_png)
    text = numpy.any(a != w, axis=2)
    height, width = text.shape
    edge = numpy.ones((height, width), dtype=bool)
    edge[EDGE_PX:height - EDGE_PX, EDGE_PX:width - EDGE_PX] = False
    drawn, cut = int(text.sum()), int((text & edge).sum())
    ok = drawn > 0 and cut == 0
    return ("labels", f"{len(labels)} labels, {drawn} pixels of their text, {cut} at the canvas's edge"
            + ("" if ok else " LABEL OFF THE CANVAS"), ok)


def main(argv):
    bad = 0
    for script in argv:
        for panel, msg, ok in check_script(script):
            print(f"{'ok  ' if ok else 'FAIL'} {os.path.basename(script)} plot {panel}: {msg}")
            bad += not ok
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
