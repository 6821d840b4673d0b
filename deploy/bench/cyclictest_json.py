#!/usr/bin/env python3
"""cyclictest's histogram (-h) as JSON: count, p50/p99 (the first bin whose cumulative count reaches it) and the
maximum. Usage: cyclictest_json.py FILE INTERVAL_US MODE (deploy/bench.sh and deploy/bench/scale.sh)."""
import json, sys
hist, total, maximum = {}, 0, None
for line in open(sys.argv[1]):
    parts = line.split()
    if len(parts) == 2 and parts[0].isdigit() and parts[1].isdigit():
        hist[int(parts[0])] = int(parts[1]); total += int(parts[1])
    elif line.startswith("# Max Latencies"):
        maximum = int(line.split(":")[1].split()[0])
def pct(p):
    need, seen = p * total, 0
    for us in sorted(hist):
        seen += hist[us]
        if seen >= need and hist[us]:
            return us
    return None
print(json.dumps({"interval_us": int(sys.argv[2]), "mode": sys.argv[3], "count": total, "p50_us": pct(0.5),
                  "p99_us": pct(0.99), "max_us": maximum}))
