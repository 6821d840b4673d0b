#!/usr/bin/env python3
"""docs/troubleshooting.md lists the processes' actual messages: each "### `text`" heading must occur verbatim in the
sources that print it (common/, proto/, master/, slave/, deploy/ scripts), so a reworded message fails the suite until
the page follows. Also: the page covers the messages the processes print when they refuse to start for the reasons
the deployment docs discuss."""
import os
import re
import sys

root = sys.argv[1]
page = open(os.path.join(root, "docs/troubleshooting.md")).read()
headings = re.findall(r"(?m)^### `([^`]+)`\s*$", page)
sources = []
for top in ("common", "proto", "master", "slave", "deploy"):
    for dirpath, _, files in os.walk(os.path.join(root, top)):
        for name in files:
            if name.endswith((".cpp", ".hpp", ".sh")) or name == "teleop-plot":
                with open(os.path.join(dirpath, name), encoding="utf-8") as f:
                    sources.append((os.path.relpath(os.path.join(dirpath, name), root), f.read()))
missing, found = [], {}
for h in headings:
    where = [path for path, text in sources if h in text]
    if where:
        found[h] = where[0]
    else:
        missing.append(h)
for h, where in found.items():
    print(f"  ok: `{h}` ({where})")
required = ["UDP link: cannot bind to ", "refusing to start: ", "periodic loop: cannot switch to SCHED_FIFO priority ",
            "periodic loop: mlockall failed: ", "AF_CAN not supported by this kernel", "CAN bus load too high: ",
            "emulated-can: no teleop-canbus answered at ", "cycle {}: peer lost (watchdog), coupling off"]
absent = [r for r in required if r not in headings]
if len(headings) < 25:
    print(f"FAILED: only {len(headings)} messages on the page")
    sys.exit(1)
if missing or absent:
    for h in missing:
        print(f"FAILED: `{h}` is on docs/troubleshooting.md but in no source file")
    for r in absent:
        print(f"FAILED: the page does not list `{r}`")
    sys.exit(1)
print(f"PASSED: {len(headings)} messages, each found in the sources")
