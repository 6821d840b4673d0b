#!/usr/bin/env python3
"""teleop-scenario cobot-wall --vehicle {unicycle,bicycle} --overlay {on,off} --json: each run prints one JSON object
with max_penetration_mm; the overlay must reduce the penetration (Fig. 9) for both vehicles, and stay bounded."""
import json
import subprocess
import sys
import tempfile

scenario = sys.argv[1]
with tempfile.TemporaryDirectory() as out:
    result = {}
    for vehicle in ("unicycle", "bicycle"):
        for overlay in ("on", "off"):
            run = subprocess.run([scenario, "cobot-wall", "--vehicle", vehicle, "--overlay", overlay, "--json",
                                  "--no-plot", "--output", f"{out}/{vehicle}_{overlay}"],
                                 capture_output=True, text=True, timeout=300, check=False)
            if run.returncode != 0:
                sys.exit(f"{vehicle} overlay {overlay}: exit {run.returncode}\n{run.stderr}")
            metrics = json.loads(run.stdout.strip().splitlines()[-1])
            assert metrics["vehicle"] == vehicle, metrics
            result[(vehicle, overlay)] = metrics["max_penetration_mm"]
            print(vehicle, overlay, metrics)
    for vehicle in ("unicycle", "bicycle"):
        on, off = result[(vehicle, "on")], result[(vehicle, "off")]
        if not on < off:
            sys.exit(f"{vehicle}: the overlay did not reduce the penetration ({on} mm on, {off} mm off)")
        if not (on < 6.0 and off < 30.0):
            sys.exit(f"{vehicle}: penetration out of bounds ({on} mm on, {off} mm off)")
    bad = subprocess.run([scenario, "cobot-wall", "--vehicle", "tricycle", "--no-plot", "--output", f"{out}/bad"],
                         capture_output=True, text=True, timeout=60, check=False)
    if bad.returncode == 0 or "--vehicle" not in bad.stderr + bad.stdout:
        sys.exit("an unknown vehicle was not refused with a message naming --vehicle")
print("ok")
