#!/usr/bin/env python3
"""teleop-supervise's live dashboard in a real browser (docs/dds.md, "The dashboard"): one master/slave pair of the
real processes (loopback plant, UDP on 127.0.0.1, the master's operator pushing a 1 Hz sine) publishes on DDS,
`teleop-supervise --http 127.0.0.1:<port>` serves the page, and headless Chromium (python3-selenium,
chromium-driver) opens it. Checks:

  - the page, its script and dygraphs are served; the page lists the pair's two processes, live and coupled;
  - the traces advance: every plot (position, force, fixture penetration, data age, round trip) is drawn by dygraphs
    and its x range moves on with the supervisor's clock, new State samples keep arriving, and the master's position
    trace moves (the sine);
  - the clutch: `teleop-ctl clutch on` on the master's command socket shows both sides clutched (the master by its
    command, the slave by the peer's flag) and the pair no longer coupled; `clutch off` shows both released and
    coupled again (the State's `clutch` field, docs/dds.md);
  - cutting the pair (SIGKILL of the slave, no goodbye on DDS) changes the state shown within a bound: the master's
    engagement becomes peer_lost, the slave's status stale, and the slave's data-age trace grows past the stale limit;
  - the browser logged no script error.
Screenshots before and after the cut are written to the work directory (paths printed).

Skips (77, with the reason) only when the browser cannot be started: python3-selenium, chromium or chromium-driver
missing or failing. Cyclone DDS is confined to loopback unicast on a domain derived from the test's pid.
"""
import argparse
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "test_utilities"))
import teleop_keys  # noqa: E402
from teleop_process import SKIP, Failure, Processes, check, free_udp_port, run_test, set_ports, wait_until  # noqa

CYCLONE_XML = """<CycloneDDS><Domain id="any">
  <General><Interfaces><NetworkInterface name="lo"/></Interfaces><AllowMulticast>false</AllowMulticast></General>
  <Discovery><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>20</MaxAutoParticipantIndex>
    <Peers><Peer address="127.0.0.1"/></Peers></Discovery>
</Domain></CycloneDDS>
"""
CHROMIUM = "/usr/bin/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync",
                  "--window-size=1400,1300"]
STALE_AFTER_S = 1.0
# The cut must show within this long: the stale limit, the master's 50 ms watchdog, one 0.1 s dashboard refresh
# and one 0.25 s redraw, with slack for a loaded 2-core machine.
CUT_VISIBLE_WITHIN_S = STALE_AFTER_S + 4.0
MASTER_DURATION_S = 25.0  # longer than the test needs; the master is stopped at the end
SINE = ("      script:\n"
        "        - {type: sine, axis: 0, start_s: 0.0, amplitude_N: 1.0, frequency_hz: 1.0}\n")


def write_config(src, dst, ports, domain, pair, role):
    text = set_ports(open(src).read(), ports)
    text = re.sub(r"(?m)^(\s*csv:).*$", r'\1 ""', text)
    if role == "master":
        # The shipped script ramps and then holds: a sine keeps the position trace moving for the whole test.
        text, n = re.subn(r"(?m)^      script:.*\n(^        - .*\n)+", SINE, text)
        if n != 1:
            raise Failure("master.yaml: the operator script block was not found to replace")
    text += f"\ndds:\n  enabled: true\n  domain_id: {domain}\n  pair: {pair}\n  state_rate_hz: 20\n"
    with open(dst, "w") as f:
        f.write(text)
    teleop_keys.ensure_key(os.path.dirname(dst))


def http_get(url, timeout_s=2.0):
    with urllib.request.urlopen(url, timeout=timeout_s) as r:
        return r.status, r.read()


def start_browser(profile):
    """The Selenium driver of a headless Chromium, or (None, why) when it cannot start here."""
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.options import Options
        from selenium.webdriver.chrome.service import Service
    except ImportError as e:
        return None, f"python3-selenium is not installed ({e}); apt-get install python3-selenium"
    for path, package in ((CHROMIUM, "chromium"), (CHROMEDRIVER, "chromium-driver")):
        if not os.path.exists(path):
            return None, f"{path} is missing; apt-get install {package}"
    options = Options()
    options.binary_location = CHROMIUM
    for flag in CHROMIUM_FLAGS + [f"--user-data-dir={profile}"]:
        options.add_argument(flag)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    try:
        return webdriver.Chrome(service=Service(CHROMEDRIVER), options=options), None
    except Exception as e:  # selenium's WebDriverException and whatever the driver's start raises
        return None, f"headless Chromium did not start: {str(e).strip()[:400]}"


# What the page shows, read from its own state object (window.teleopDashboard) and its dygraphs.
PAGE_STATE = """
const d = window.teleopDashboard;
if (!d) return null;
const graphs = {};
for (const [name, g] of Object.entries(d.graphs)) {
  const series = g.getLabels().slice(1);
  const columns = {};
  series.forEach((label, i) => {
    const values = [];
    for (let r = 0; r < g.numRows(); r++) { const v = g.getValue(r, i + 1); if (v !== null) values.push(v); }
    columns[label] = values;
  });
  graphs[name] = {x: g.xAxisRange(), rows: g.numRows(), columns: columns,
                  canvas: g.graphDiv.querySelectorAll('canvas').length};
}
const badge = (role) => { const b = document.getElementById('badge-' + role);
  return {engagement: b.dataset.engagement, status: b.dataset.status, clutch: b.dataset.clutch || '',
          text: b.textContent.replace(/\\s+/g, ' ')}; };
const rows = [...document.querySelectorAll('#processes tbody tr')].map(
  (tr) => [...tr.querySelectorAll('td')].map((td) => td.textContent));
return {pair: d.pair, states: d.statesReceived, processes: d.processesReceived, graphs: graphs,
        master: badge('master'), slave: badge('slave'), table: rows, tNow: d.tNow,
        connection: document.getElementById('connection').textContent};
"""

PLOTS = ("position", "force", "penetration", "age", "rtt")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--master", required=True)
    ap.add_argument("--slave", required=True)
    ap.add_argument("--supervise", required=True)
    ap.add_argument("--ctl", required=True)
    ap.add_argument("--configs", required=True)
    ap.add_argument("--workdir", required=True)
    args = ap.parse_args()
    work = args.workdir
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)

    xml = os.path.join(work, "cyclonedds.xml")
    with open(xml, "w") as f:
        f.write(CYCLONE_XML)
    env = dict(os.environ, CYCLONEDDS_URI="file://" + xml)
    domain = 150 + os.getpid() % 80
    pair = f"dash{os.getpid()}"
    http_port = free_udp_port(kind=socket.SOCK_STREAM)
    base = f"http://127.0.0.1:{http_port}"

    with Processes(env=env) as procs:
        def spawn(key, cmd):
            procs.start(key, cmd, log_path=os.path.join(work, key + ".log"))

        spawn("supervise", [args.supervise, "--domain", str(domain), "--interval", "0.2", "--stale-after",
                            str(STALE_AFTER_S), "--duration", "120", "--quiet", "--http", f"127.0.0.1:{http_port}"])
        ports = (free_udp_port(), free_udp_port())
        for role in ("slave", "master"):
            cfg = os.path.join(work, f"{role}.yaml")
            write_config(os.path.join(args.configs, f"{role}.yaml"), cfg, ports, domain, pair, role)
            cmd = [args.slave if role == "slave" else args.master, "--config", cfg]
            if role == "master":
                cmd += ["--duration", str(MASTER_DURATION_S), "--command-socket", os.path.join(work, "master.sock")]
            spawn(role, cmd)
        print(f"domain {domain}, pair {pair}, dashboard {base}/")

        def served():
            try:
                return http_get(base + "/")
            except OSError:
                return None
        status, page = wait_until(served, 10, "teleop-supervise serving the dashboard")
        check(status == 200 and b"/dashboard.js" in page and b"/dygraph.min.js" in page,
              "GET / serves the page (it loads dashboard.js and dygraph.min.js)")
        status, script = http_get(base + "/dygraph.min.js")
        check(status == 200 and b"Dygraph" in script,
              f"GET /dygraph.min.js serves dygraphs from its installed path ({len(script)} bytes)")

        profile = tempfile.mkdtemp(prefix="chromium-profile-", dir=work)
        driver, why = start_browser(profile)
        if driver is None:
            print(f"SKIPPED: {why}")
            return SKIP
        try:
            return browse(driver, procs, base, pair, work, args.ctl)
        except Failure:
            for log in procs.logs:
                log.flush()
                print(f"--- {log.name}")
                print(open(log.name).read()[-2000:])
            raise
        finally:
            driver.quit()


def browse(driver, procs, base, pair, work, ctl):
    driver.set_page_load_timeout(15)
    driver.get(f"{base}/?pair={pair}")

    def state():
        return driver.execute_script(PAGE_STATE)

    def coupled():
        s = state()
        ok = s and all(s[r]["engagement"] == "coupled" and s[r]["status"] == "live" for r in ("master", "slave"))
        return s if ok and all(p in s["graphs"] for p in PLOTS) else None
    # Start-up: the stability check and DDS discovery, then two redraws.
    first = wait_until(coupled, 40, "the page showing master and slave live and coupled, with every plot drawn",
                       interval_s=0.2)
    check(first["pair"] == pair and first["connection"] == "live",
          f"the page chose pair {pair} (?pair=) and its WebSocket is live")
    table = {(row[0], row[1]): row for row in first["table"]}
    check(all((pair, r) in table and table[(pair, r)][2] == "live" and table[(pair, r)][3] == "coupled"
              and table[(pair, r)][4] == "-" for r in ("master", "slave")),
          "the process table lists master and slave, live, coupled and not clutched")
    for name in PLOTS:
        check(first["graphs"][name]["canvas"] > 0, f"the {name} plot is a dygraphs canvas")
    shot = os.path.join(work, "dashboard_coupled.png")
    driver.save_screenshot(shot)
    print(f"  screenshot (coupled): {shot}")

    time.sleep(2.0)  # two seconds of traces; every later wait polls with a deadline
    second = state()
    for name in PLOTS:
        x0, x1 = first["graphs"][name]["x"], second["graphs"][name]["x"]
        check(x1[1] - x0[1] >= 1.0, f"the {name} trace advances: x range end {x0[1]:.2f} -> {x1[1]:.2f} s")
    check(second["states"] - first["states"] >= 20,
          f"State samples keep arriving ({second['states'] - first['states']} in about 2 s, 2 processes x 20 Hz)")
    xs = second["graphs"]["position"]["columns"]["master x"]
    check(len(xs) >= 20 and max(xs) - min(xs) > 0.05,
          f"the master's position trace moves with the operator's sine ({min(xs):.3f}..{max(xs):.3f} mm, "
          f"{len(xs)} points)")
    rtts = second["graphs"]["rtt"]["columns"]["master"]
    check(rtts and all(0 < v < 50 for v in rtts), f"round trips plotted ({min(rtts):.3f}..{max(rtts):.3f} ms)")

    def command(line):
        out = subprocess.run([ctl, "--socket", os.path.join(work, "master.sock")] + line.split(),
                             capture_output=True, text=True, timeout=10)
        check(out.returncode == 0 and out.stdout.startswith("ok"),
              f"teleop-ctl {line}: exit {out.returncode}, {out.stdout.strip()} {out.stderr.strip()}")

    check(second["master"]["clutch"] == "released" and second["slave"]["clutch"] == "released",
          f"both badges show the clutch released ({second['master']['clutch']!r}, {second['slave']['clutch']!r})")
    command("clutch on")

    def clutched():
        s = state()
        rows = {(row[0], row[1]): row for row in s["table"]}
        ok = all(s[r]["clutch"] == "clutched" and s[r]["engagement"] != "coupled" for r in ("master", "slave"))
        clutch_column = {r: rows.get((pair, r), [""] * 5)[4] for r in ("master", "slave")}
        ok = ok and clutch_column == {"master": "command", "slave": "peer"}
        return s if ok else None
    on = wait_until(clutched, 5, "both sides shown clutched and not coupled; the table's clutch column: master "
                    "'command', slave 'peer'", interval_s=0.1)
    print(f"  clutch on shown: master '{on['master']['text'].strip()}', slave '{on['slave']['text'].strip()}'")
    shot = os.path.join(work, "dashboard_clutched.png")
    driver.save_screenshot(shot)
    print(f"  screenshot (clutched): {shot}")
    command("clutch off")

    def released():
        s = state()
        ok = all(s[r]["clutch"] == "released" and s[r]["engagement"] == "coupled" for r in ("master", "slave"))
        return s if ok else None
    wait_until(released, 10, "both sides shown released and coupled again (re-indexed through aligning)",
               interval_s=0.1)
    second = state()

    t_cut = second["tNow"]
    procs["slave"].send_signal(signal.SIGKILL)
    procs["slave"].wait(timeout=10)
    cut_wall = time.monotonic()

    def cut_shown():
        s = state()
        return s if s["master"]["engagement"] == "peer_lost" and s["slave"]["status"] == "stale" else None
    after = wait_until(cut_shown, CUT_VISIBLE_WITHIN_S + 2, "the cut shown (master peer_lost, slave stale)",
                       interval_s=0.1)
    shown_after = time.monotonic() - cut_wall
    check(shown_after <= CUT_VISIBLE_WITHIN_S,
          f"the cut is shown {shown_after:.2f} s after the kill (bound {CUT_VISIBLE_WITHIN_S} s): master "
          f"'{after['master']['text'].strip()}', slave '{after['slave']['text'].strip()}'")

    def age_grown():
        s = state()
        ages = s["graphs"]["age"]["columns"]["slave"]
        return s if ages and ages[-1] > STALE_AFTER_S else None
    aged = wait_until(age_grown, 5, "the slave's data age past the stale limit", interval_s=0.1)
    ages = aged["graphs"]["age"]["columns"]["slave"]
    check(ages[-1] > STALE_AFTER_S, f"the slave's data-age trace grows after the cut (now {ages[-1]:.2f} s; "
          f"cut at supervisor t = {t_cut:.1f} s)")
    shot = os.path.join(work, "dashboard_cut.png")
    driver.save_screenshot(shot)
    print(f"  screenshot (after the cut): {shot}")

    errors = [e for e in driver.get_log("browser") if e.get("level") == "SEVERE"]
    check(not errors, f"the browser logged no error ({errors[:3]})")

    procs["master"].send_signal(signal.SIGINT)
    procs["master"].wait(timeout=10)
    procs["supervise"].send_signal(signal.SIGINT)
    check(procs["supervise"].wait(timeout=10) == 0, "teleop-supervise (with the dashboard) exits 0 on SIGINT")
    return 0


if __name__ == "__main__":
    run_test(main)
