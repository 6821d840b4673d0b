#!/usr/bin/env python3
"""Two master/slave pairs of the real processes (loopback plant, UDP on 127.0.0.1) publish on DDS; teleop-supervise
records what it sees. Checks (docs/dds.md):

  - the supervisor lists all four processes, live and coupled, with the figures the processes report themselves:
    loop rate, loss and round trip against each process's --summary-json, and the run summary it received over DDS
    equal to that file;
  - killing one slave (SIGKILL: no goodbye on DDS) shows up within a bounded time: that slave goes stale, its master
    reports peer_lost (state and event), the other pair is untouched.

Cyclone DDS is confined to loopback unicast (CYCLONEDDS_URI) on a domain derived from the test's pid, so parallel
runs on one machine do not see each other. Every wait is bounded; nothing is timed.
"""
import argparse
import json
import os
import re
import signal
import sys
import time
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "test_utilities"))
import teleop_keys  # noqa: E402  (tests/test_utilities)

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "test_utilities"))
from teleop_process import Failure, Processes, check, free_udp_port, set_ports  # noqa: E402

CYCLONE_XML = """<CycloneDDS><Domain id="any">
  <General><Interfaces><NetworkInterface name="lo"/></Interfaces><AllowMulticast>false</AllowMulticast></General>
  <Discovery><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>20</MaxAutoParticipantIndex>
    <Peers><Peer address="127.0.0.1"/></Peers></Discovery>
</Domain></CycloneDDS>
"""

STALE_AFTER_S = 1.0
# A kill must show within this long: the stale limit plus generous slack for a loaded machine (refresh 0.2 s).
KILL_VISIBLE_WITHIN_S = STALE_AFTER_S + 4.0
MASTER_DURATION_S = 7.0


def write_config(src, dst, ports, domain, pair):
    text = open(src).read()
    text = set_ports(text, ports)
    text = re.sub(r"(?m)^(\s*csv:).*$", r'\1 ""', text)
    text += f"\ndds:\n  enabled: true\n  domain_id: {domain}\n  pair: {pair}\n  state_rate_hz: 20\n"
    with open(dst, "w") as f:
        f.write(text)
    teleop_keys.ensure_key(os.path.dirname(dst))  # link.security key_file: teleop.key, beside the config


def read_records(path):
    records = []
    if not os.path.exists(path):
        return records
    with open(path) as f:
        for line in f:
            if line.endswith("\n"):
                records.append(json.loads(line))
    return records


def wait_until(path, predicate, timeout_s, what):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        records = read_records(path)
        if predicate(records):
            return records
        time.sleep(0.1)
    raise Failure(f"timed out after {timeout_s} s waiting for: {what}")


def states(records, pair, role):
    return [r for r in records if r["type"] == "state" and r["pair"] == pair and r["role"] == role]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--master", required=True)
    ap.add_argument("--slave", required=True)
    ap.add_argument("--supervise", required=True)
    ap.add_argument("--configs", required=True)
    ap.add_argument("--workdir", required=True)
    args = ap.parse_args()
    os.makedirs(args.workdir, exist_ok=True)
    work = args.workdir
    for name in os.listdir(work):
        os.remove(os.path.join(work, name))

    xml = os.path.join(work, "cyclonedds.xml")
    with open(xml, "w") as f:
        f.write(CYCLONE_XML)
    env = dict(os.environ, CYCLONEDDS_URI="file://" + xml)
    domain = 10 + os.getpid() % 140
    pairs = [f"tp{os.getpid()}a", f"tp{os.getpid()}b"]
    record = os.path.join(work, "supervise.jsonl")
    procs = Processes(env=env)

    def spawn(key, cmd):
        procs.start(key, cmd, log_path=os.path.join(work, key + ".log"))

    try:
        spawn("supervise", [args.supervise, "--domain", str(domain), "--interval", "0.2", "--stale-after",
                            str(STALE_AFTER_S), "--duration", "60", "--record", record, "--quiet"])
        for pair in pairs:
            ports = (free_udp_port(), free_udp_port())
            for role in ("slave", "master"):
                cfg = os.path.join(work, f"{pair}_{role}.yaml")
                write_config(os.path.join(args.configs, f"{role}.yaml"), cfg, ports, domain, pair)
                cmd = [args.slave if role == "slave" else args.master, "--config", cfg, "--summary-json",
                       os.path.join(work, f"{pair}_{role}.json")]
                if role == "master":
                    cmd += ["--duration", str(MASTER_DURATION_S)]
                spawn(f"{pair}_{role}", cmd)

        print(f"domain {domain}, pairs {pairs}")
        procs_all = [(p, r) for p in pairs for r in ("master", "slave")]

        def all_coupled(records):
            return all(any(s["status"] == "live" and s["engagement"] == "coupled" for s in states(records, p, r))
                       for p, r in procs_all)

        # Start-up: the stability check, DDS discovery; a sanitizer build is slow here, hence the generous bound.
        wait_until(record, all_coupled, 60, "all four processes live and coupled")
        check(True, "the supervisor lists both pairs, all four processes live and coupled")
        time.sleep(1.0)  # a second of steady running for the figures

        victim = f"{pairs[1]}_slave"
        procs[victim].send_signal(signal.SIGKILL)
        procs[victim].wait(timeout=10)
        kill_t = None
        records = read_records(record)
        # The supervisor's clock: t_s of the newest record so far is no later than now.
        kill_t = max(r["t_s"] for r in records if r["type"] == "state")

        def kill_seen(records):
            stale = [s for s in states(records, pairs[1], "slave") if s["t_s"] > kill_t and s["status"] != "live"]
            lost = [s for s in states(records, pairs[1], "master")
                    if s["t_s"] > kill_t and s["engagement"] == "peer_lost"]
            return stale and lost

        records = wait_until(record, kill_seen, KILL_VISIBLE_WITHIN_S + 2, "the kill visible in the record")
        first_stale = min(s["t_s"] for s in states(records, pairs[1], "slave")
                          if s["t_s"] > kill_t and s["status"] != "live")
        first_lost = min(s["t_s"] for s in states(records, pairs[1], "master")
                         if s["t_s"] > kill_t and s["engagement"] == "peer_lost")
        print(f"  kill at supervisor t <= {kill_t:.2f} s: slave stale at {first_stale:.2f} s, "
              f"master peer_lost at {first_lost:.2f} s")
        check(first_stale - kill_t <= KILL_VISIBLE_WITHIN_S,
              f"the killed slave is shown stale within {KILL_VISIBLE_WITHIN_S} s ({first_stale - kill_t:.2f} s)")
        check(first_lost - kill_t <= KILL_VISIBLE_WITHIN_S,
              f"its master shows peer_lost within {KILL_VISIBLE_WITHIN_S} s ({first_lost - kill_t:.2f} s)")

        # The masters stop after their duration; slave A follows its master. All three publish a run summary.
        finished = [(pairs[0], "master"), (pairs[0], "slave"), (pairs[1], "master")]
        records = wait_until(
            record, lambda rs: all(any(r["type"] == "summary" and r["pair"] == p and r["role"] == role for r in rs)
                                   for p, role in finished),
            MASTER_DURATION_S + 30, "three run summaries")
        for key in (f"{pairs[0]}_master", f"{pairs[0]}_slave", f"{pairs[1]}_master"):
            check(procs[key].wait(timeout=30) == 0, f"{key} exits 0")
        time.sleep(0.5)  # one more refresh: "finished"
        procs["supervise"].send_signal(signal.SIGINT)
        check(procs["supervise"].wait(timeout=10) == 0, "teleop-supervise exits 0 on SIGINT")
        records = read_records(record)

        for pair, role in finished:
            own = json.load(open(os.path.join(work, f"{pair}_{role}.json")))
            summary = [r for r in records if r["type"] == "summary" and r["pair"] == pair and r["role"] == role][-1]
            name = f"{pair}/{role}"
            check(json.loads(summary["summary_json"]) == own, f"{name}: the DDS run summary equals --summary-json")
            check(summary["cycles"] == own["cycles"] and summary["stop_reason"] == own["stop_reason"],
                  f"{name}: cycles {summary['cycles']} and stop reason '{summary['stop_reason']}' as reported")
            live = [s for s in states(records, pair, role) if s["status"] == "live" and s["engagement"] == "coupled"]
            # The newest State's cycle over its loop time is the mean rate since the first cycle, as the summary's
            # (up to the last few cycles): the figure the supervisor shows against the one the process prints.
            last = max(states(records, pair, role), key=lambda s: s["cycle"])
            shown_rate = last["cycle"] / last["time_s"]
            check(abs(shown_rate - own["achieved_rate_hz"]) <= 0.05 * own["achieved_rate_hz"],
                  f"{name}: mean loop rate {shown_rate:.1f} Hz within 5 % of the process's own "
                  f"{own['achieved_rate_hz']:.1f} Hz")
            windows = [s["achieved_rate_hz"] for s in live if s["achieved_rate_hz"] is not None]
            check(windows and all(0 < r < 2 * own["rate_hz"] for r in windows),
                  f"{name}: {len(windows)} windowed rates shown, all in 0..2x the configured {own['rate_hz']} Hz")
            last_cycle = max(s["cycle"] for s in states(records, pair, role))
            check(0 <= own["cycles"] - last_cycle <= 100,
                  f"{name}: the last state shown is cycle {last_cycle}, within 100 cycles of the run's {own['cycles']}")
            rtts = [s["rtt_ms"] for s in live if s["rtt_ms"] is not None]
            check(rtts and all(0 < x <= own["rtt_ms"]["max"] + 1e-9 for x in rtts),
                  f"{name}: every round trip shown ({min(rtts):.3f}..{max(rtts):.3f} ms) is within the process's "
                  f"own distribution (max {own['rtt_ms']['max']:.3f} ms)")
            lost_shown = max(s["packets_lost"] for s in states(records, pair, role))
            check(lost_shown <= own["packets"]["lost"] and summary["packets_lost"] == own["packets"]["lost"],
                  f"{name}: packets lost shown {lost_shown} <= {own['packets']['lost']} at the end (summary equal)")
            check(all(s["device_faults"] == 0 for s in states(records, pair, role)), f"{name}: no device faults")
            check(states(records, pair, role)[-1]["status"] == "finished", f"{name}: shown as finished at the end")

        for role in ("master", "slave"):
            check(all(s["status"] in ("live", "finished") for s in states(records, pairs[0], role)),
                  f"{pairs[0]}/{role}: never stale while the other pair's slave died")
        own_a = json.load(open(os.path.join(work, f"{pairs[0]}_master.json")))
        own_b = json.load(open(os.path.join(work, f"{pairs[1]}_master.json")))
        check(own_a["watchdog_trips"] == 0 and own_b["watchdog_trips"] >= 1,
              "watchdog trips: 0 in the untouched pair, >= 1 where the slave was killed")
        check(any(r["type"] == "event" and r["pair"] == pairs[1] and r["role"] == "master" and r["kind"] == "peer_lost"
                  for r in records), f"{pairs[1]}/master: the peer_lost event arrived over DDS")
        check(states(records, pairs[1], "slave")[-1]["status"] in ("stale", "gone"),
              f"{pairs[1]}/slave: still shown stale (or gone) at the end")
        print("PASS")
        return 0
    except Failure as e:
        print(f"FAIL: {e}")
        for log in procs.logs:
            log.flush()
            print(f"--- {log.name}")
            print(open(log.name).read()[-3000:])
        return 1
    finally:
        procs.stop_all()


if __name__ == "__main__":
    sys.exit(main())
