#!/usr/bin/python3
"""The out-of-tree rig of deploy/examples/custom_backend as a process pair: its spring-master (teleop-master's
ProcessMain with the example-spring backend compiled in) against an unmodified teleop-slave on the loopback plant,
both on the example's configs (ports made free). Checks: both exit 0, the master ran its own backend, the two
exchanged samples and engaged.
    custom_rig_pair.py --master SPRING_MASTER --slave TELEOP_SLAVE --configs EXAMPLE_DIR --workdir DIR
"""
import argparse
import json
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "test_utilities"))
from teleop_process import Processes, check, free_udp_port, run_test, set_ports, wait_for_udp_port, write_text  # noqa


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--master", required=True)
    ap.add_argument("--slave", required=True)
    ap.add_argument("--configs", required=True)
    ap.add_argument("--workdir", required=True)
    a = ap.parse_args()
    os.makedirs(a.workdir, exist_ok=True)
    ports = (free_udp_port(), free_udp_port())
    configs = {}
    for role in ("master", "slave"):
        text = set_ports(open(os.path.join(a.configs, f"{role}.yaml")).read(), ports)
        configs[role] = write_text(os.path.join(a.workdir, f"{role}.yaml"), text)
    summaries = {role: os.path.join(a.workdir, f"{role}.json") for role in configs}
    with Processes() as procs:
        slave = procs.start("slave", [a.slave, "--config", configs["slave"], "--summary-json", summaries["slave"]],
                            log_path=os.path.join(a.workdir, "slave.log"))
        wait_for_udp_port(ports[1], 10)
        master = procs.start("master", [a.master, "--config", configs["master"], "--duration", "1.5",
                                        "--summary-json", summaries["master"]],
                             log_path=os.path.join(a.workdir, "master.log"))
        master_rc = master.wait(timeout=30)
        slave_rc = slave.wait(timeout=10)  # the master's shutdown sample stops it
    log = open(os.path.join(a.workdir, "master.log")).read()
    check(master_rc == 0, f"spring-master exited 0 (got {master_rc}; {a.workdir}/master.log)")
    check(slave_rc == 0, f"teleop-slave stopped with the master and exited 0 (got {slave_rc})")
    check("device 'example-spring'" in log, "spring-master ran the out-of-tree backend")
    m = json.load(open(summaries["master"]))
    s = json.load(open(summaries["slave"]))
    check(m["packets"]["accepted"] > 1000 and s["packets"]["accepted"] > 1000,
          f"samples exchanged both ways (master accepted {m['packets']['accepted']}, "
          f"slave {s['packets']['accepted']})")
    check(m["engagement"]["times_engaged"] >= 1 and s["engagement"]["times_engaged"] >= 1, "both sides engaged")
    check(s["stop_reason"] == "peer shutdown", "the slave stopped on the master's shutdown")


if __name__ == "__main__":
    run_test(main)
