#!/usr/bin/env bash
# ctest deploy_bench_smoke: runs deploy/bench.sh --smoke into $1 and checks the JSON it writes is well-formed and
# holds every section (the figures themselves are not checked).
set -euo pipefail
out="$1"
rm -rf "${out}"
"$(dirname "${BASH_SOURCE[0]}")/../bench.sh" --smoke --out "${out}"
/usr/bin/python3 - "${out}/performance.json" "${out}/performance.md" <<'PY'
import json, sys
data = json.load(open(sys.argv[1]))
required = ["machine", "master-1000-off", "slave-1000-off", "loop-1000-off", "loop-8000-off", "cyclictest-1000-off",
            "pingpong-64-off", "pingpong-184-off", "control_benchmark", "proto_codec_benchmark",
            "transport_link_benchmark", "analyze_limits", "analysis_reference", "master-1000-off-csv"]
missing = [k for k in required if not data.get(k)]
if missing:
    sys.exit(f"performance.json lacks {missing}")
for key in ("kernel", "date_utc", "command"):
    if not data["machine"].get(key):
        sys.exit(f"machine.{key} missing")
if data["pingpong-64-off"]["bytes"] != 64 or not data["pingpong-64-off"]["p50_us"] > 0:
    sys.exit("ping-pong figures malformed")
if not data["loop-8000-off"]["cycles"] > 0:
    sys.exit("the 8 kHz loop ran no cycle")
md = open(sys.argv[2]).read()
for heading in ("## Loop timing beside cyclictest", "## Round trip beside the UDP ping-pong floor",
                "## Stability analysis: C++ beside NumPy/SciPy"):
    if heading not in md:
        sys.exit(f"performance.md lacks {heading!r}")
print("bench smoke: performance.json and performance.md well-formed")
PY
