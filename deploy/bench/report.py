#!/usr/bin/python3
"""Turns deploy/bench.sh's raw files into docs/performance.json (every raw figure) and docs/performance.md.

  report.py RAW_DIR OUT.json OUT.md
"""
import glob
import json
import os
import sys


def load(path, default=None):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError):
        return default


def fmt(value, digits=1):
    if value is None:
        return "–"
    if isinstance(value, float):
        return f"{value:.{digits}f}"
    return str(value)


def ratio(a, b):
    return None if a is None or b in (None, 0) else a / b


def main():
    raw, out_json, out_md = sys.argv[1:4]
    data = {"machine": load(os.path.join(raw, "machine.json"), {}),
            "machine_end": load(os.path.join(raw, "machine_end.json"), {})}
    for path in sorted(glob.glob(os.path.join(raw, "*.json"))):
        name = os.path.basename(path)[:-5]
        if name not in ("machine", "machine_end"):
            data[name] = load(path)
    for path in sorted(glob.glob(os.path.join(raw, "alloc-*.txt"))):
        with open(path) as f:
            data["count-" + os.path.basename(path)[:-4]] = int(f.read().strip() or 0)
    budget = os.path.join(raw, "can_budget.txt")
    if os.path.exists(budget):
        with open(budget) as f:
            data["can_budget_text"] = f.read()
    with open(out_json, "w") as f:
        json.dump(data, f, indent=1, sort_keys=True)
        f.write("\n")

    m = data["machine"]
    lines = []
    w = lines.append
    w("# Performance")
    w("")
    w(f"Every number on this page was written by `{m.get('command', 'deploy/bench.sh')}` in one run "
      "(raw figures: [performance.json](performance.json)). Regenerate with `deploy/bench.sh` (a few minutes, root "
      "for the real-time rows). The scale section (DOF, pairs per host, the 1 kHz jitter interleaved) is a run of "
      "its own: `deploy/bench.sh --scale` rewrites only it. Tests never assert timing; these are measurements.")
    w("")
    w("| machine | kernel | CPU | CPUs | PREEMPT_RT | root | load average (start → end) | date (UTC) | git |")
    w("|---|---|---|---|---|---|---|---|---|")
    w(f"| {m.get('host')} | {m.get('kernel')} | {m.get('cpu')} | {m.get('cpus')} | {m.get('preempt_rt')} | "
      f"{m.get('root')} | {m.get('loadavg_start')} → {data['machine_end'].get('loadavg_end')} | {m.get('date_utc')} | "
      f"{m.get('git')} |")
    w("")
    w("**Real-time settings** (`rt` rows): SCHED_FIFO 80, `mlockall`, master on CPU 0 and slave on CPU 1, and "
      "`/dev/cpu_dma_latency` held at 0 for the runs (`realtime.cpu_dma_latency_us: 0` in the processes' configs; "
      "the loop bench and cyclictest hold it themselves). `off` rows: normal scheduling, no pinning, no latency request (cyclictest "
      "`--laptop -p 0`).")
    # The machine's load when the run started (1-minute average beyond what the bench itself adds): above about one
    # busy CPU, other work competed with the processes and the timing rows say more about it than about the code.
    try:
        load_1min = float(str(m.get("loadavg_start", "")).split()[0])
    except (IndexError, ValueError):
        load_1min = None
    if load_1min is None:
        w("The load of the machine at the start was not recorded.")
    elif load_1min > 1.5:
        w(f"**This run was made on a busy machine** (1-minute load average {load_1min:.2f} at the start): the timing "
          "figures are noisy and pessimistic; the computed figures (limits, CAN bits, allocations) are not affected.")
    else:
        w(f"The machine was otherwise idle when the run started (1-minute load average {load_1min:.2f}); a VM's timing "
          "still moves with its host's load from run to run: compare ratios within one run.")
    loads = [f"`{mode}` runs {data[f'mode-{mode}']['loadavg']}" for mode in ("off", "rt")
             if (data.get(f"mode-{mode}") or {}).get("loadavg")]
    if loads:
        w("")
        w("Load average (1, 5, 15 min) when each set of process runs started: " + "; ".join(loads) + ".")
    if m.get("smoke"):
        w("")
        w("**Smoke run**: tiny durations, one rate; the figures only show that every step works.")
    w("")

    # Loop timing.
    w("## Loop timing beside cyclictest")
    w("")
    w("Wake-up jitter (wake time − scheduled time) in µs of the free-running processes; cyclictest at the same "
      "interval and priority in the same run. `loop alone` is `teleop-loop-bench` (runtime::PeriodicLoop with an "
      "empty body).")
    w("")
    w("| rate | mode | master p50 / p99 / max | slave p50 / p99 / max | loop alone p50 / p99 / max | cyclictest "
      "p50 / p99 / max | master p99 ÷ cyclictest p99 | loop alone overruns |")
    w("|---|---|---|---|---|---|---|---|")
    rows = []
    for rate in (1000, 2000, 4000, 8000):
        for mode in ("off", "rt"):
            tag = f"{rate}-{mode}"
            master = data.get(f"master-{tag}")
            slave = data.get(f"slave-{tag}")
            loop = data.get(f"loop-{tag}")
            cyc = data.get(f"cyclictest-{tag}")
            if not any((master, slave, loop, cyc)):
                continue

            def dist(summary):
                if not summary:
                    return "–"
                j = summary.get("jitter_us", {})
                return f"{fmt(j.get('p50'))} / {fmt(j.get('p99'))} / {fmt(j.get('max'))}"

            loop_text = "–"
            overrun_text = "–"
            if loop:
                j = loop["jitter"]
                loop_text = f"{fmt(j['p50_us'])} / {fmt(j['p99_us'])} / {fmt(j['max_us'])}"
                overrun_text = f"{100 * loop['overrun_fraction']:.2f} %"
            cyc_text = "–"
            cyc_p99 = None
            if cyc and not cyc.get("missing"):
                cyc_p99 = cyc.get("p99_us")
                cyc_text = f"{fmt(cyc.get('p50_us'))} / {fmt(cyc_p99)} / {fmt(cyc.get('max_us'))}"
            master_p99 = master.get("jitter_us", {}).get("p99") if master else None
            ref_p99 = master_p99 if master_p99 is not None else (loop["jitter"]["p99_us"] if loop else None)
            r = ratio(ref_p99, cyc_p99)
            rows.append((rate, mode, r, loop, master))
            w(f"| {rate} Hz | {mode} | {dist(master)} | {dist(slave)} | {loop_text} | {cyc_text} | "
              f"{fmt(r, 2) + '×' if r else '–'}{'' if master_p99 is not None else ' (loop alone)'} | {overrun_text} |")
    w("")
    for rate, mode, r, loop, master in rows:
        if rate == 8000 and mode == "rt" and (loop or master):
            if master and master.get("cycles"):
                frac = 100 * master["overruns"] / master["cycles"]
                who = "the master process"
            else:
                frac = 100 * loop["overrun_fraction"]
                who = "the loop alone"
            verdict = "met" if frac < 0.1 else f"missed by {frac - 0.1:.2f} points"
            jverdict = ("met" if r is not None and r <= 1.5 else
                        (f"missed: {r:.2f}× ({r - 1.5:.2f}× over)" if r is not None else "not measured"))
            w(f"Target 8 kHz with real-time settings: < 0.1 % overruns and jitter p99 ≤ 1.5× cyclictest. Measured "
              f"({who}): {frac:.2f} % overruns ({verdict}), p99 {fmt(r, 2)}× cyclictest ({jverdict}).")
            if frac >= 0.1 or r is None or r > 1.5:
                cyc = data.get("cyclictest-8000-rt") or {}
                comp = (master or {}).get("compute_us", {})
                w(f"Why: a period is 125 µs; the process's cycle takes {fmt(comp.get('p50'))} µs p50, "
                  f"{fmt(comp.get('p99'))} µs p99 (sense, receive, law, send: system calls that a VM makes dearer), "
                  f"so a wake-up the host delays by a few tens of µs more than cyclictest's (its max here: "
                  f"{fmt(cyc.get('max_us'))} µs) is already an overrun; cyclictest's empty cycle has no such budget to "
                  f"spend. On this shared VM the figure moves from run to run with the host's load; the loop alone "
                  f"(empty body) is the lower bound beside it.")
            w("")

    # Processes: compute, overruns.
    w("## The processes per rate")
    w("")
    w("| rate | mode | process | cycles | overruns | compute p50 / p99 / max (µs) | period p50 / p99 (µs) |")
    w("|---|---|---|---|---|---|---|")
    for rate in (1000, 2000, 4000, 8000):
        for mode in ("off", "off-triggered", "rt", "rt-triggered", "rt-triggered-spin", "off-csv"):
            for role in ("master", "slave"):
                s = data.get(f"{role}-{rate}-{mode}")
                if not s:
                    continue
                c, p = s.get("compute_us", {}), s.get("period_us", {})
                w(f"| {rate} Hz | {mode} | {role} | {s.get('cycles')} | {s.get('overruns')} | {fmt(c.get('p50'))} / "
                  f"{fmt(c.get('p99'))} / {fmt(c.get('max'))} | {fmt(p.get('p50'))} / {fmt(p.get('p99'))} |")
    w("")

    # Round trip and data age.
    w("## Round trip and data age, free-running and phase-locked")
    w("")
    w("**Round trip** (`rtt_ms` of the master's summary): from the master's send call to the slave's kernel receive "
      "timestamp and back, the slave's hold time removed (docs/protocol.md). Beside it `teleop-udp-pingpong` (plain "
      "C, two processes, blocking receive) of the same size (1-DOF sample: 64 bytes). **Data age** (`data_age_us`): "
      "how old the peer's sample is when the law uses it (law start − the kernel receive time of that sample); "
      "`free` runs each process on its own clock, `triggered` (`sync.mode: triggered`) starts the slave's cycle when "
      "the master's sample arrives (docs/configuration.md, `sync`); `triggered-spin` (real-time runs only) adds "
      "`sync.spin_us: 100`: the slave polls its socket without sleeping from 100 µs before the sample is due.")
    w("")
    w("| what | p50 (µs) | p99 (µs) | max (µs) |")
    w("|---|---|---|---|")
    floors = {}
    for b in (64, 184):
        for mode in ("off", "rt"):
            pp = data.get(f"pingpong-{b}-{mode}")
            if pp:
                if b == 64:
                    floors[mode] = pp["p50_us"]
                w(f"| ping-pong {b} B ({mode}) | {fmt(pp['p50_us'])} | {fmt(pp['p99_us'])} | {fmt(pp['max_us'])} |")
    w("")
    w("| rate | mode | sync | round trip p50 / p99 (µs) | p50 − ping-pong p50 (µs) | slave data age p50 / p99 / max "
      "(µs) | master data age p50 / p99 / max (µs) | slave age in cycles 0/1/2/3+ | slave trigger timeouts while coupled | "
      "overruns master / slave |")
    w("|---|---|---|---|---|---|---|---|---|---|")
    pairs_seen = []
    for rate in (1000, 2000, 4000, 8000):
        for mode in ("off", "rt"):
            for sync in ("free", "triggered", "triggered-spin"):
                tag = f"{rate}-{mode}" + ("" if sync == "free" else f"-{sync}")
                m, sl = data.get(f"master-{tag}"), data.get(f"slave-{tag}")
                if not m or not sl:
                    continue
                pairs_seen.append((rate, mode, sync, m, sl))
                r = m.get("rtt_ms", {})
                rtt_p50 = r["p50"] * 1e3 if r.get("count") else None
                gap = rtt_p50 - floors[mode] if rtt_p50 is not None and mode in floors else None

                def age(s):
                    a = s.get("data_age_us", {})
                    return f"{fmt(a.get('p50'))} / {fmt(a.get('p99'))} / {fmt(a.get('max'))}" if a.get("count") else "–"
                cyc = "/".join(str(x) for x in sl.get("data_age_cycles", [])) or "–"
                timeouts = (f"{sl.get('trigger_timeouts_coupled')} of {sl.get('cycles_with_peer')}"
                            if sync != "free" else "–")
                w(f"| {rate} Hz | {mode} | {sync} | {fmt(rtt_p50)} / {fmt(r['p99'] * 1e3 if r.get('count') else None)} | "
                  f"{fmt(gap)} | {age(sl)} | {age(m)} | {cyc} | {timeouts} | {m.get('overruns')} / {sl.get('overruns')} |")
    w("")
    # Targets.
    for mode in ("rt", "off"):
        rows = [p for p in pairs_seen if p[0] == 1000 and p[1] == mode]
        if not rows or mode not in floors:
            continue
        w(f"Targets at 1 kHz ({'with' if mode == 'rt' else 'without'} real-time settings), against the ping-pong "
          f"floor of this run ({fmt(floors[mode])} µs p50):")
        w("")
        for rate, _, sync, m, sl in rows:
            r = m.get("rtt_ms", {})
            if r.get("count"):
                gap = r["p50"] * 1e3 - floors[mode]
                w(f"- round trip ({sync}): p50 {fmt(r['p50'] * 1e3)} µs, {fmt(gap)} µs from the floor: "
                  + ("met (target ≤ 20 µs)." if gap <= 20 else f"missed by {gap - 20:.1f} µs (target ≤ 20 µs)."))
            a = sl.get("data_age_us", {})
            if sync != "free" and a.get("count"):
                w(f"- slave data age ({sync}): p50 {fmt(a['p50'])} µs: "
                  + ("met (target < 50 µs)." if a["p50"] < 50 else f"missed by {a['p50'] - 50:.1f} µs (target < 50 µs)."))
                ma = m.get("data_age_us", {})
                bound = 1e6 / rate - m.get("compute_us", {}).get("p50", 0.0)
                if ma.get("count"):
                    w(f"- master data age ({sync}): p50 {fmt(ma['p50'])} µs against one period minus the master's "
                      f"compute p50 ({fmt(bound)} µs): " + ("met." if ma["p50"] < bound else
                                                            f"missed by {ma['p50'] - bound:.1f} µs."))
        w("")
    w("Where the slave's data age misses its target in `triggered` and meets it in `triggered-spin`, the difference is "
      "the wake-up of the slave's thread sleeping in `ppoll`: on this VM a cross-CPU wake-up (an interrupt to a halted "
      "vCPU that the host must schedule) costs tens of µs, which `sync.spin_us` removes by polling instead of "
      "sleeping. The spin costs CPU: 100 µs of a 250 or 125 µs period (4 and 8 kHz) leaves the slave little else, and "
      "those rows show more timeouts and overruns; use a spin that is a small part of the period.")
    w("")
    w("Reading the table. The processes' round trip can be *below* the ping-pong's: the kernel stamps a datagram "
      "when it is queued on the receiving socket (on loopback, inside the sender's send call), before the reader "
      "wakes, so the processes' figure is send call → kernel → send call → kernel, while the ping-pong's includes "
      "two wake-ups of a blocked reader (pinned to different CPUs in the `rt` rows: a cross-CPU wake-up on this VM "
      "costs tens of µs). The wake-up is in the data age instead: a triggered slave's data age is the time from the "
      "master's sample reaching its socket to its law running (its wake-up from `ppoll`, then Sense). The master "
      "is the clock: it uses the slave's reply at its next cycle, so its data age stays near one period minus the "
      "slave's response time, whatever the mode. A triggered master's compute time includes the wake-up of the "
      "slave inside its send call (the slave waits on the socket), which free-running does not pay. Trigger "
      "timeouts are counted while the pair was coupled (before the master starts, the slave free-runs on timeouts "
      "by design).")
    w("")

    # Micro-benchmarks.
    w("## Compute: micro-benchmarks")
    w("")
    w("Google Benchmark (`build/bin/*_benchmark --benchmark_format=json`), CPU time per call.")
    w("")
    w("| benchmark | ns per call |")
    w("|---|---|")
    for b in ("control_benchmark", "proto_codec_benchmark", "transport_link_benchmark", "can_link_benchmark"):
        d = data.get(b)
        if not d:
            continue
        for bm in d.get("benchmarks", []):
            unit = bm.get("time_unit", "ns")
            scale = {"ns": 1, "us": 1e3, "ms": 1e6}.get(unit, 1)
            w(f"| {b}: {bm['name']} | {bm['cpu_time'] * scale:.0f} |")
    w("")
    w("`BM_LawStep` and `BM_CycleCompute` (one side's whole cycle without its system calls) run at 1, 2, 3, 6, 7 and 12 DOF; the scale section below fits them against DOF (`deploy/bench.sh --scale`).")
    w("")

    # Allocations.
    if all(k in data for k in ("count-alloc-master-1", "count-alloc-master-2")):
        w("## Allocations per cycle over a process run")
        w("")
        w("Every heap allocation of the whole process counted by an LD_PRELOAD shim "
          "(`build/lib/libteleop-alloc-count.so`) in a 1 s and a 2 s run at 1 kHz; start-up and shutdown cancel "
          "in the difference.")
        w("")
        w("| process | allocations (1 s run) | allocations (2 s run) | cycles difference | allocations per cycle |")
        w("|---|---|---|---|---|")
        for role in ("master", "slave"):
            a1, a2 = data.get(f"count-alloc-{role}-1"), data.get(f"count-alloc-{role}-2")
            c1 = (data.get(f"alloc-{role}-1") or {}).get("cycles")
            c2 = (data.get(f"alloc-{role}-2") or {}).get("cycles")
            dc = (c2 - c1) if c1 is not None and c2 is not None else None
            per = ratio((a2 - a1) if a1 is not None and a2 is not None else None, dc)
            w(f"| {role} | {a1} | {a2} | {fmt(dc)} | {fmt(per, 4)} |")
        w("")

    # CAN.
    if "can_budget_text" in data:
        w("## CAN bits per cycle and bus load")
        w("")
        w("From `can_link_benchmark` (computed, not timed); the second table is a triggered slave over CAN (sync.mode "
          "triggered; docs/can.md, \"Phase-locked cycles over CAN\"): the trigger is the master's last frame, so the bits "
          "are unchanged, beside a dedicated SYNC frame that was not built:")
        w("")
        w("```")
        w(data["can_budget_text"].strip())
        w("```")
        w("")

    # Analysis.
    w("## Stability analysis: C++ beside NumPy/SciPy")
    w("")
    ref = data.get("analysis_reference") or {}
    cpp = {bm["name"]: bm for bm in (data.get("analysis_benchmark") or {}).get("benchmarks", [])}
    limits = data.get("analyze_limits") or []
    w("Limits (`teleop-analyze max-stiffness --side S --kp 600 --kd 2 --rate 1000 --peer-delay-fraction F`, 512 "
      "operators) beside `deploy/bench/analysis_reference.py` (an independent NumPy/SciPy implementation, the same "
      "bracketing and bisection to 0.1 %):")
    w("")
    w("| side | velocity filter | peer delay | C++ limit (N/m) | NumPy/SciPy limit (N/m) | difference |")
    w("|---|---|---|---|---|---|")
    for lim in limits:
        delay = (f"{lim['peer_delay_samples']} sample" if lim["peer_delay_samples"]
                 else f"fraction {lim['peer_delay_fraction']:g}")
        if lim.get("slave_peer_delay_fraction") is not None:
            delay = (f"triggered: master 1 sample, slave fraction {lim['slave_peer_delay_fraction']:.3g}")
        match = None
        if lim.get("velocity_filter_hz", 0) == 0 and lim.get("slave_peer_delay_fraction") is None:
            for r in ref.get("limits", []):
                if (r["side"] == lim["side"] and r["peer_delay_samples"] == lim["peer_delay_samples"]
                        and abs(r["peer_delay_fraction"] - lim["peer_delay_fraction"]) < 1e-9):
                    match = r["limit_N_per_m"]
        c = lim["max_stable_stiffness_N_per_m"]
        diff = f"{100 * (c - match) / match:+.3f} %" if match else "–"
        w(f"| {lim['side']} | {lim.get('velocity_filter_hz', 0):g} Hz | {delay} | {c:.0f} | "
          f"{fmt(match, 0) if match else '–'} | {diff} |")
    w("")
    w("The triggered rows are what the start-up check of a `sync.mode: triggered` pair uses (docs/configuration.md, "
      "`stability.peer_delay_fraction`): 0.1 is its default at 1 kHz (an assumed 100 µs data age), the other the "
      "slave's data age p99 measured in this run, as a fraction of the period. The NumPy/SciPy reference does not "
      "implement the asymmetric delay; the fine-step simulation checks it instead (`config_stability_test`, "
      "`analysis_test` cases `*_triggered*`).")
    measured = [lim["slave_peer_delay_fraction"] for lim in limits
                if lim.get("slave_peer_delay_fraction") not in (None, 0.1)]
    if measured and measured[0] > 0.1:
        w("")
        w(f"In this run the measured p99 ({measured[0]:.3g} of a period) is above the default assumption (0.1): the "
          "default is optimistic for a loaded VM without `sync.spin_us`. On such a machine set "
          "`stability.peer_delay_fraction` from the slave's summary (or spin): the check then allows less, as the "
          "table shows, but still more than free-running (the `1 sample` row with the 200 Hz filter: fraction 1).")
    w("")
    w("Time per computation (C++: `analysis_benchmark`, one thread, real time; NumPy/SciPy: the same computation "
      "in the reference, wall and CPU time of the Python process):")
    w("")
    w("| computation | C++ (ms) | NumPy/SciPy wall (ms) | NumPy/SciPy CPU (ms) | CPU ratio |")
    w("|---|---|---|---|---|")
    pairs = [("slave limit, no delay", "BM_WorstCaseLimit512/slave:1/threads:1/delay:0/real_time", ("slave", 0)),
             ("master limit, no delay", "BM_WorstCaseLimit512/slave:0/threads:1/delay:0/real_time", ("master", 0)),
             ("slave limit, 1 sample (C++ on 2 threads)", "BM_WorstCaseLimit512/slave:1/threads:2/delay:1/real_time",
              ("slave", 1)),
             ("master limit, 1 sample (C++ on 2 threads)", "BM_WorstCaseLimit512/slave:0/threads:2/delay:1/real_time",
              ("master", 1))]
    for label, name, (side, samples) in pairs:
        bm = cpp.get(name)
        r = next((x for x in ref.get("limits", []) if x["side"] == side and x["peer_delay_samples"] == samples
                  and x["peer_delay_fraction"] == 0.0), None)
        if not bm and not r:
            continue
        c_ms = bm["real_time"] if bm else None
        w(f"| {label} | {fmt(c_ms, 2)} | {fmt(r['seconds'] * 1e3 if r else None, 0)} | "
          f"{fmt(r['cpu_seconds'] * 1e3 if r else None, 0)} | "
          f"{fmt(ratio(r['cpu_seconds'] * 1e3 if r else None, c_ms), 0)}× |")
    bm = cpp.get("BM_Fig7Curve10Rates/threads:1/real_time")
    curve = ref.get("fig7_curve")
    if bm or curve:
        w(f"| Fig. 7 curve (10 rates) | {fmt(bm['real_time'] if bm else None, 1)} | "
          f"{fmt(curve['seconds'] * 1e3 if curve else None, 0)} | {fmt(curve['cpu_seconds'] * 1e3 if curve else None, 0)} | "
          f"{fmt(ratio(curve['cpu_seconds'] * 1e3 if curve else None, bm['real_time'] if bm else None), 0)}× |")
    w("")
    w("The C++ figure is wall time of one thread on a loaded machine, so the CPU ratio understates the speed-up "
      "when the machine is busy; the Python wall time is inflated the same way.")
    w("")

    # CSV.
    base = data.get("master-1000-off")
    csv = data.get("master-1000-off-csv")
    if base and csv:
        w("## Cost of logging every cycle to CSV")
        w("")
        w("The master at 1 kHz without real-time settings, without and with `--telemetry-csv` (decimation 1): the "
          "cycle only pushes a record into a wait-free ring; a thread of its own writes the file.")
        w("")
        w("| run | compute p50 / p99 / max (µs) | overruns | telemetry records | dropped |")
        w("|---|---|---|---|---|")
        for label, s in (("no CSV", base), ("CSV every cycle", csv)):
            c = s.get("compute_us", {})
            w(f"| {label} | {fmt(c.get('p50'))} / {fmt(c.get('p99'))} / {fmt(c.get('max'))} | {s.get('overruns')} | "
              f"{s.get('telemetry_records')} | {s.get('telemetry_dropped')} |")
        w("")

    # The scale sections (deploy/bench.sh --scale, deploy/bench/scale_report.py) are a run of their own: carried over
    # from the page this run replaces.
    try:
        with open(out_md) as f:
            old = f.read()
        start, end = old.index("<!-- scale:begin"), old.index("<!-- scale:end -->") + len("<!-- scale:end -->")
        w(old[start:end])
        w("")
    except (OSError, ValueError):
        pass

    w("## Not measured or not done")
    w("")
    w("- A software PLL on the kernel receive timestamps (the alternative to the triggered cycle): not built; the "
      "triggered cycle already starts within the wake-up latency of the master's sample.")
    w("- `link.busy_poll_us` (`SO_BUSY_POLL`) is not measured: it pays only on a NIC with a NAPI queue, and these runs "
      "are on loopback. The spin receive that pays here is `sync.spin_us` (the `triggered-spin` rows).")
    w("")
    with open(out_md, "w") as f:
        f.write("\n".join(lines))


if __name__ == "__main__":
    main()
