#!/usr/bin/env python3
"""Does a gnuplot figure show all of its data? For each plot of a script (each panel of a multiplot) the axis ranges
gnuplot drew (GPVAL_X_MIN ... GPVAL_Y_MAX) are compared with the extent of the data it was given: the same script is
run a second time with every `set xrange/yrange [...]` replaced by autoscaling, where GPVAL_DATA_X_MIN ...
GPVAL_DATA_Y_MAX are the extent of every curve, point and arrow tip. A panel whose data reach outside its axes is
clipped and fails, unless the script says so on the line before the plot: `# ranges: y clipped (reason)` (the figure
itself must tell the reader, for example in a key entry).

  figure_ranges.py SCRIPT.gp [...]    prints one line per panel and exits 1 when one is clipped

Both passes draw to /dev/null; a script runs in its own directory (the scenario scripts name their CSVs relatively).
"""
import os
import re
import subprocess
import sys

MARK = "FIGURE-RANGES"
RANGE_SET = re.compile(r"\bset\s+(x|y)range\s*\[[^\]]*\]")


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


def instrumented(stmts, autoscale):
    lines, clipped, pending = ["set print '-'"], [], ""
    for s in stmts:
        if s.startswith("#"):
            m = re.match(r"#\s*ranges:\s*([xy]+)\s+clipped", s)
            if m:
                pending = m.group(1)
            continue
        if re.match(r"set\s+(o|ou|out|outp|outpu|output)\b", s):
            s = "set output '/dev/null'"
        if autoscale:
            s = RANGE_SET.sub(lambda m: f"set autoscale {m.group(1)}", s)
        lines.append(s)
        if re.match(r"plot\b", s):
            lines.append(f'print sprintf("{MARK} %.9g %.9g %.9g %.9g %.9g %.9g %.9g %.9g", GPVAL_X_MIN, GPVAL_X_MAX, '
                         "GPVAL_Y_MIN, GPVAL_Y_MAX, GPVAL_DATA_X_MIN, GPVAL_DATA_X_MAX, GPVAL_DATA_Y_MIN, "
                         "GPVAL_DATA_Y_MAX)")
            clipped.append(pending)
            pending = ""
    return "\n".join(lines) + "\n", clipped


def run(script, text):
    r = subprocess.run(["gnuplot"], input=text, cwd=os.path.dirname(os.path.abspath(script)), text=True,
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=120)
    rows = [[float(v) for v in line.split()[1:]] for line in r.stdout.splitlines() if line.startswith(MARK)]
    if r.returncode != 0:
        raise RuntimeError(f"{script}: gnuplot exit {r.returncode}: {r.stderr[-500:]}")
    return rows


def check_script(script):
    """A list of (panel, message, ok) for each plot of the script."""
    stmts = statements(open(script).read())
    drawn_text, clipped = instrumented(stmts, autoscale=False)
    data_text, _ = instrumented(stmts, autoscale=True)
    drawn, data = run(script, drawn_text), run(script, data_text)
    if not drawn or len(drawn) != len(data):
        return [(0, f"{len(drawn)} plots drawn, {len(data)} with autoscaling: cannot compare", False)]
    results = []
    for i, (axes, extent, allowed) in enumerate(zip(drawn, data, clipped), start=1):
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
        results.append((i, "; ".join(msgs), ok))
    return results


def main(argv):
    bad = 0
    for script in argv:
        for panel, msg, ok in check_script(script):
            print(f"{'ok  ' if ok else 'FAIL'} {os.path.basename(script)} plot {panel}: {msg}")
            bad += not ok
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
