#!/usr/bin/env bash
# ctest deploy_bench_smoke: runs deploy/bench.sh --smoke into $1 and checks the JSON it writes is well-formed and
# holds every section (the figures themselves are not checked), and that the phase-locked pair's summaries carry the
# sync, round-trip and data-age fields with consistent counts.
set -euo pipefail
out="$1"
rm -rf "${out}"
"$(dirname "${BASH_SOURCE[0]}")/../bench.sh" --smoke --out "${out}"
/usr/bin/python3 - "${out}/performance.json" "${out}/performance.md" <<'PY'
import json, sys
data = json.load(open(sys.argv[1]))
required = ["machine", "master-1000-off", "slave-1000-off", "loop-1000-off", "loop-8000-off", "cyclictest-1000-off",
            "pingpong-64-off", "pingpong-184-off", "control_benchmark", "proto_codec_benchmark",
            "transport_link_benchmark", "analyze_limits", "analysis_reference", "master-1000-off-csv",
            "master-1000-off-triggered", "slave-1000-off-triggered"]
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
# The phase-locked pair (sync.mode triggered): counts add up; behaviour, not timing.
for role in ("master", "slave"):
    s = data[f"{role}-1000-off-triggered"]
    for key in ("sync", "triggered_cycles", "trigger_timeouts", "data_age_us", "data_age_sender_us",
                "data_age_cycles", "rtt_ms", "realtime_settings_applied"):
        if key not in s:
            sys.exit(f"{role} summary lacks {key}")
    if s["sync"] != "triggered":
        sys.exit(f"{role} ran {s['sync']!r}, not triggered")
    age = s["data_age_us"]
    if not s["cycles_with_peer"] > 0 or age["count"] != s["cycles_with_peer"]:
        sys.exit(f"{role}: {age['count']} data ages for {s['cycles_with_peer']} cycles with the peer")
    if sum(s["data_age_cycles"]) != age["count"]:
        sys.exit(f"{role}: data age in cycles {s['data_age_cycles']} does not add up to {age['count']}")
    if not age["p50"] <= age["p99"] <= age["max"]:
        sys.exit(f"{role}: data age percentiles out of order: {age}")
    if not s["rtt_ms"]["count"] > 0:
        sys.exit(f"{role}: no round trip measured")
    if s["realtime_settings_applied"]:
        sys.exit(f"{role}: the smoke run has no real-time settings, yet the summary says applied")
slave = data["slave-1000-off-triggered"]
if slave["triggered_cycles"] + slave["trigger_timeouts"] != slave["cycles"]:
    sys.exit("slave: triggered + timeouts != cycles")
if not slave["trigger_timeouts_coupled"] <= min(slave["trigger_timeouts"], slave["cycles_with_peer"]):
    sys.exit("slave: more timeouts while coupled than timeouts or coupled cycles")
if not slave["triggered_cycles"] > 0:
    sys.exit("slave: no cycle was triggered by the master's sample")
# Behaviour, not timing (on a loaded host the master itself stalls and the slave times out often): some of the
# slave's cycles used the master's sample of the same cycle, and the master, the clock, never does.
if not slave["data_age_cycles"][0] > 0:
    sys.exit(f"slave: no cycle used the sample that triggered it: {slave['data_age_cycles']}")
master = data["master-1000-off-triggered"]
if master["triggered_cycles"] != 0 or master["data_age_cycles"][0] != 0:
    sys.exit("master: the master is the clock, yet it counted triggered cycles")
md = open(sys.argv[2]).read()
for heading in ("## Loop timing beside cyclictest", "## Round trip and data age, free-running and phase-locked",
                "## Stability analysis: C++ beside NumPy/SciPy"):
    if heading not in md:
        sys.exit(f"performance.md lacks {heading!r}")
print("bench smoke: performance.json and performance.md well-formed")
PY
