#!/usr/bin/env bash
# ctest deploy_bench_scale_smoke: runs deploy/bench.sh --scale --smoke into $1 (a few seconds: DOF 1 and 12 over UDP,
# classic CAN and CAN FD, two pairs at once, one interleaved jitter round) and checks what it writes is well-formed
# and holds every section (never the figures: tests do not assert timing). Behaviour it does check: 12 DOF runs over
# UDP and CAN FD and is refused over classic CAN (at most 6 DOF), and both pairs of the pairs run ran.
set -euo pipefail
out="$1"
rm -rf "${out}"
"$(dirname "${BASH_SOURCE[0]}")/../bench.sh" --scale --smoke --out "${out}"
/usr/bin/python3 - "${out}" <<'PY'
import json, os, sys
out = sys.argv[1]
data = json.load(open(os.path.join(out, "performance-scale.json")))
md = open(os.path.join(out, "performance.md")).read()
def need(key):
    if not data.get(key):
        sys.exit(f"performance-scale.json lacks {key}")
    return data[key]
for t in ("udp", "can-fd"):
    for d in (1, 12):
        for role in ("master", "slave"):
            s = need(f"dof-{t}-1000-{d}-0-{role}")
            if s.get("dof") not in (None, d) and s.get("cycles", 0) <= 0:
                sys.exit(f"{t} {d} DOF {role}: no cycle")
            if not s.get("cycles", 0) > 0:
                sys.exit(f"{t} {d} DOF {role} ran no cycle: {s}")
        run = need(f"dof-{t}-1000-{d}-0-run")
        if run["master_exit"] or run["slave_exit"]:
            sys.exit(f"{t} {d} DOF did not run: {run}")
classic12 = need("dof-can-1000-12-0-run")
if not (classic12["master_exit"] or classic12["slave_exit"]) or not classic12.get("refused"):
    sys.exit(f"classic CAN at 12 DOF was not refused: {classic12}")
if "1..6 (classic CAN)" not in classic12["refused"]:
    sys.exit(f"classic CAN at 12 DOF refused for another reason: {classic12['refused']}")
for t in ("udp", "can", "can-fd"):
    for i in range(2):
        for role in ("master", "slave"):
            if not need(f"pairs-{t}-1000-off-2-{i}-{role}").get("cycles", 0) > 0:
                sys.exit(f"pairs {t}: pair {i} {role} ran no cycle")
for item in ("loop", "loop-slack50", "pair"):
    need(f"jitter-1000-off-0-{item}")
if data["jitter-1000-off-0-loop"].get("timer_slack_ns") != 1:
    sys.exit(f"the loop did not run with 1 ns timer slack: {data['jitter-1000-off-0-loop']}")
if data["jitter-1000-off-0-loop-slack50"].get("timer_slack_ns") in (None, 1):
    sys.exit("the default-slack loop ran with the processes' slack")
names = {b["name"] for b in need("control_benchmark")["benchmarks"]}
if not {"BM_CycleCompute/1", "BM_CycleCompute/12"} <= names:
    sys.exit(f"BM_CycleCompute cases missing: {sorted(names)}")
for heading in ("<!-- scale:begin", "<!-- scale:end -->", "### DOF sweep: the processes", "### Pairs per host",
                "### The 1 kHz jitter, measured interleaved", "**Highest DOF meeting < 0.1 % overruns**",
                "**Highest pair count meeting < 0.1 % overruns**", "PROVISIONAL"):
    if heading not in md:
        sys.exit(f"performance.md lacks {heading!r}")
print("bench scale smoke: performance-scale.json and the scale region well-formed")
PY
