#!/usr/bin/env python3
"""teleop-supervise's live dashboard in a real browser (docs/dds.md, "The dashboard"): one master/slave pair of the
real processes (loopback plant, UDP on 127.0.0.1, the master's operator pushing a 1 Hz sine) publishes on DDS,
`teleop-supervise --http 127.0.0.1:<port>` serves the page, and headless Chromium (python3-selenium,
chromium-driver) opens it. Checks:

  - the page, its script and dygraphs are served; the page lists the pair's two processes, live and coupled;
  - the traces advance: every plot (position, force, fixture penetration, fixture stiffness, data age, round trip)
    is drawn by dygraphs and its x range moves on with the supervisor's clock, new State samples keep arriving, and
    the master's position trace moves (the sine);
  - only true states: the fixture plot draws the stiffness in use (the slave's 2000 N/m, the master's 0) and no
    limit line for a process that computes none (the loopback plant), and a Cartesian pair has no joint plots; an
    arm's states (fed to the page) show the joint plots, the joint choice, and the limit only from its first value;
  - the clutch: `teleop-ctl clutch on` on the master's command socket shows both sides clutched (the master by its
    command, the slave by the peer's flag) and the pair no longer coupled; `clutch off` shows both released and
    coupled again (the State's `clutch` field, docs/dds.md);
    while clutched both sides show the state "clutched" (not "aligning"), in the badges and the table;
  - the master's tracking error after the re-index excludes the index offset (the `reindexed` event's value);
  - the history: the page reloaded mid-run shows the last seconds of every trace at once;
  - cutting the pair (SIGKILL of the slave, no goodbye on DDS) changes the state shown within a bound: the master's
    engagement becomes peer_lost, the slave's status stale and its engagement "unknown" (not its last "coupled"),
    the slave's data-age trace grows past the stale limit, and the master's round-trip trace has a gap from the cut
    on (no frozen last value) while its position trace goes on;
  - events fold: a storm of 40 `overrun` events is one line with its count;
  - the series of every plot keep distinct colours for colour-blind readers (protan, deutan, tritan simulation,
    Machado et al. 2009, CIE76 distance at least COLOUR_DELTA_E), sensor traces dashed;
  - the browser logged no script error.
Screenshots (coupled, clutched, reloaded, after the cut, an arm's states) are written to the work directory (paths printed).

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
MASTER_DURATION_S = 60.0  # longer than the test needs (on a loaded machine too); the master is stopped at the end
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
  const columns = {}, gaps = {}, lastFiniteX = {}, lastX = {}, dashed = {};
  series.forEach((label, i) => {
    const values = [];
    gaps[label] = 0;
    for (let r = 0; r < g.numRows(); r++) {
      const v = g.getValue(r, i + 1);
      if (v === null) continue;
      lastX[label] = g.getValue(r, 0);
      if (Number.isNaN(v)) { gaps[label]++; continue; }
      values.push(v);
      lastFiniteX[label] = g.getValue(r, 0);
    }
    columns[label] = values;
    dashed[label] = Boolean(g.getOption('strokePattern', label));
  });
  const visibility = g.visibility();
  const visible = Object.fromEntries(series.map((label, i) => [label, Boolean(visibility[i])]));
  graphs[name] = {x: g.xAxisRange(), rows: g.numRows(), columns: columns, gaps: gaps, lastFiniteX: lastFiniteX,
                  lastX: lastX, colors: g.getColors(), labels: series, dashed: dashed, visible: visible,
                  canvas: g.graphDiv.querySelectorAll('canvas').length};
}
const badge = (role) => { const b = document.getElementById('badge-' + role);
  return {engagement: b.dataset.engagement, status: b.dataset.status, clutch: b.dataset.clutch || '',
          text: b.textContent.replace(/\\s+/g, ' ')}; };
const rows = [...document.querySelectorAll('#processes tbody tr')].map(
  (tr) => [...tr.querySelectorAll('td')].map((td) => td.textContent));
return {pair: d.pair, states: d.statesReceived, processes: d.processesReceived, graphs: graphs, events: d.eventList(),
        master: badge('master'), slave: badge('slave'), table: rows, tNow: d.tNow,
        connection: document.getElementById('connection').textContent,
        shown: Object.fromEntries(['joint-position', 'joint-torque', 'stiffness'].map((p) => [p, d.panelShown(p)])),
        jointChoice: document.getElementById('joint-label').hidden ? null
          : [...document.querySelectorAll('#joint option')].map((o) => o.textContent)};
"""

PLOTS = ("position", "force", "penetration", "stiffness", "tracking", "age", "rtt")
SLAVE_FIXTURE_N_PER_M = 2000.0  # deploy/configs/slave.yaml fixture.stiffness_N_per_m; the master has none
FOLD_S = 10.0  # dashboard.js: events of one kind from one side within this long are one line
COLOUR_DELTA_E = 12.0  # CIE76 distance two series' colours keep under each simulated colour-vision deficiency
# Machado, Oliveira & Fernandes (2009), severity 1.0, on linear RGB.
CVD = {
    "protan": ((0.152286, 1.052583, -0.204868), (0.114503, 0.786281, 0.099216), (-0.003882, -0.048116, 1.051998)),
    "deutan": ((0.367322, 0.860646, -0.227968), (0.280085, 0.672501, 0.047413), (-0.011820, 0.042940, 0.968881)),
    "tritan": ((1.255528, -0.076749, -0.178779), (-0.078411, 0.930809, 0.147602), (0.004733, 0.691367, 0.303900)),
}


def lab(rgb_hex, matrix=None):
    """CIE L*a*b* (D65) of an sRGB colour '#rrggbb' (or 'rgb(r,g,b)'), seen through a CVD matrix if given."""
    if rgb_hex.startswith("rgb"):
        c = [int(v) / 255 for v in re.findall(r"\d+", rgb_hex)[:3]]
    else:
        c = [int(rgb_hex[i:i + 2], 16) / 255 for i in (1, 3, 5)]
    lin = [v / 12.92 if v <= 0.04045 else ((v + 0.055) / 1.055) ** 2.4 for v in c]
    if matrix:
        lin = [min(1.0, max(0.0, sum(m * v for m, v in zip(row, lin)))) for row in matrix]
    x = (0.4124 * lin[0] + 0.3576 * lin[1] + 0.1805 * lin[2]) / 0.95047
    y = 0.2126 * lin[0] + 0.7152 * lin[1] + 0.0722 * lin[2]
    z = (0.0193 * lin[0] + 0.1192 * lin[1] + 0.9505 * lin[2]) / 1.08883
    f = [t ** (1 / 3) if t > 0.008856 else 7.787 * t + 16 / 116 for t in (x, y, z)]
    return (116 * f[1] - 16, 500 * (f[0] - f[1]), 200 * (f[1] - f[2]))


def require(cond, what):
    """check() without the "ok" line, for checks made many times over."""
    if not cond:
        raise Failure(what)


def delta_e(a, b):
    return sum((p - q) ** 2 for p, q in zip(a, b)) ** 0.5


def check_colours(name, g):
    """The series a plot draws (dygraphs gives the colours of the visible ones) stay apart for colour-blind readers."""
    labels = [label for label in g["labels"] if g["visible"][label]]
    require(len(labels) == len(g["colors"]), f"{name}: a colour per visible series ({labels}, {g['colors']})")
    colours = dict(zip(labels, g["colors"]))
    for kind, matrix in CVD.items():
        for i, a in enumerate(labels):
            for b in labels[i + 1:]:
                d = delta_e(lab(colours[a], matrix), lab(colours[b], matrix))
                require(d >= COLOUR_DELTA_E, f"{name}: '{a}' {colours[a]} and '{b}' {colours[b]} stay apart "
                        f"for {kind} readers (CIE76 {d:.1f} >= {COLOUR_DELTA_E})")


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
    stiffness = second["graphs"]["stiffness"]
    cols = stiffness["columns"]
    check(cols["slave stiffness"] and set(cols["slave stiffness"]) == {SLAVE_FIXTURE_N_PER_M}
          and cols["master stiffness"] and set(cols["master stiffness"]) == {0.0},
          f"the fixture plot draws the stiffness in use: slave {sorted(set(cols['slave stiffness']))} N/m, master "
          f"{sorted(set(cols['master stiffness']))} N/m ({len(cols['slave stiffness'])} points)")
    check(not cols["master limit"] and not cols["slave limit"]
          and not stiffness["visible"]["master limit"] and not stiffness["visible"]["slave limit"],
          "no limit line and no limit in the legend: the loopback plant computes no run-time limit")
    check(not second["shown"]["joint-position"] and not second["shown"]["joint-torque"]
          and "joint-position" not in second["graphs"] and second["jointChoice"] is None,
          "a Cartesian pair shows no joint plots and no joint choice")

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
        ok = all(s[r]["clutch"] == "clutched" and s[r]["engagement"] == "clutched" for r in ("master", "slave"))
        clutch_column = {r: rows.get((pair, r), [""] * 5)[4] for r in ("master", "slave")}
        engagement_column = {r: rows.get((pair, r), [""] * 5)[3] for r in ("master", "slave")}
        ok = ok and clutch_column == {"master": "command", "slave": "peer"}
        ok = ok and engagement_column == {"master": "clutched", "slave": "clutched"}
        return s if ok else None
    on = wait_until(clutched, 5, "both sides shown in the state 'clutched' (badges and table, not 'aligning'); the "
                    "table's clutch column: master 'command', slave 'peer'", interval_s=0.1)
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
    time.sleep(1.0)  # a second of coupled motion at the new index
    second = state()
    reindex = [e for e in second["events"] if e["role"] == "master" and e["kind"] == "reindexed"]
    check(reindex, "the master's reindexed event is listed")
    offset_mm = abs(reindex[0]["value"]) * 1e3
    t_coupled = second["tNow"] - 1.0
    master_track = [v for v in second["graphs"]["tracking"]["columns"]["master"]][-15:]
    check(master_track and max(master_track) < max(0.5 * offset_mm, 0.3) and max(master_track) < 2.0,
          f"the master's tracking error after the re-index excludes the index offset ({offset_mm:.2f} mm): at most "
          f"{max(master_track):.3f} mm over its last {len(master_track)} samples (t > {t_coupled:.1f} s)")

    # The history: the page reloaded mid-run shows the last seconds at once (not empty plots).
    reloaded_at = time.monotonic()
    driver.get(f"{base}/?pair={pair}")

    def history_shown():
        s = state()
        if not s or not all(p in s["graphs"] for p in PLOTS if p != "age"):
            return None
        span = s["graphs"]["position"]["x"][1] - s["graphs"]["position"]["x"][0]
        return s if span >= 8.0 else None
    hist = wait_until(history_shown, 5, "the reloaded page showing at least 8 s of traces", interval_s=0.1)
    span = hist["graphs"]["position"]["x"][1] - hist["graphs"]["position"]["x"][0]
    check(time.monotonic() - reloaded_at < 5.0,
          f"the reloaded page shows {span:.1f} s of history {time.monotonic() - reloaded_at:.2f} s after loading")
    shot = os.path.join(work, "dashboard_reloaded.png")
    driver.save_screenshot(shot)
    print(f"  screenshot (reloaded, with history): {shot}")

    # Colours: every plot's series distinguishable for colour-blind readers; sensor traces dashed.
    for name in PLOTS:
        check_colours(name, hist["graphs"][name])
    check(all(hist["graphs"]["force"]["dashed"][f"{r} sensor"] for r in ("master", "slave"))
          and not any(hist["graphs"]["force"]["dashed"][f"{r} command"] for r in ("master", "slave")),
          "every plot's series keep distinct colours under protan, deutan and tritan simulation; sensor traces dashed")
    second = state()

    t_cut = second["tNow"]
    procs["slave"].send_signal(signal.SIGKILL)
    procs["slave"].wait(timeout=10)
    cut_wall = time.monotonic()

    def cut_shown():
        s = state()
        return s if (s["master"]["engagement"] == "peer_lost" and s["slave"]["status"] == "stale"
                     and s["slave"]["engagement"] == "unknown") else None
    after = wait_until(cut_shown, CUT_VISIBLE_WITHIN_S + 2,
                       "the cut shown (master peer_lost, slave stale with engagement unknown)", interval_s=0.1)
    rows = {(row[0], row[1]): row for row in after["table"]}
    check(rows[(pair, "slave")][3] == "unknown",
          f"the table shows the stale slave's engagement as unknown, not its last value ({rows[(pair, 'slave')][3]})")
    shown_after = time.monotonic() - cut_wall
    check(shown_after <= CUT_VISIBLE_WITHIN_S,
          f"the cut is shown {shown_after:.2f} s after the kill (bound {CUT_VISIBLE_WITHIN_S} s): master "
          f"'{after['master']['text'].strip()}', slave '{after['slave']['text'].strip()}'")

    def age_grown():
        s = state()
        ages = s["graphs"]["age"]["columns"]["slave"]
        return s if ages and ages[-1] > STALE_AFTER_S else None
    aged = wait_until(age_grown, 5, "the slave's data age past the stale limit", interval_s=0.1)
    rtt = aged["graphs"]["rtt"]
    position = aged["graphs"]["position"]
    check(rtt["gaps"]["master"] > 0 and rtt["lastFiniteX"]["master"] <= t_cut + 0.5
          and position["lastX"]["master x"] > t_cut + 1.0,
          f"the master's round-trip trace has a gap from the cut (last value at t = {rtt['lastFiniteX']['master']:.2f}"
          f" s, cut at {t_cut:.2f} s) while its position trace goes on (t = {position['lastX']['master x']:.2f} s)")

    # Events fold: a storm of one kind from one side is one line with its count.
    driver.execute_script("""
const d = window.teleopDashboard;
for (let i = 0; i < 40; i++)
  d.dispatch({type: 'event', t_s: d.tNow + 0.001 * i, pair: d.pair, role: 'master', kind: 'overrun', cycle: i,
              value: 0});""")
    events = state()["events"]
    storm = [e for e in events if e["role"] == "master" and e["kind"] == "overrun"]
    check(len(storm) == 1 and storm[0]["count"] >= 40,
          f"40 overrun events are one line ({len(storm)} lines, count {storm[0]['count'] if storm else 0})")
    for i, a in enumerate(events):
        for b in events[i + 1:]:
            require(not (a["role"] == b["role"] and a["kind"] == b["kind"] and abs(a["last"] - b["first"]) <= FOLD_S
                         and abs(b["last"] - a["first"]) <= FOLD_S),
                    f"no two lines of {a['role']} {a['kind']} within {FOLD_S} s")
    ages = aged["graphs"]["age"]["columns"]["slave"]
    check(ages[-1] > STALE_AFTER_S, f"the slave's data-age trace grows after the cut (now {ages[-1]:.2f} s; "
          f"cut at supervisor t = {t_cut:.1f} s)")
    shot = os.path.join(work, "dashboard_cut.png")
    driver.save_screenshot(shot)
    print(f"  screenshot (after the cut): {shot}")

    # An arm's states, fed to the page as teleop-supervise sends them (the message is dds_dashboard_test's): 7
    # joints, the fixture lowered to 1400 N/m under its run-time limit, which the first 5 states do not have yet.
    # The master stops first, so that they come after every real State on the page's time axis.
    procs["master"].send_signal(signal.SIGINT)
    procs["master"].wait(timeout=10)
    wait_until(lambda: state()["master"]["status"] == "finished" or None, 5, "the master shown finished",
               interval_s=0.1)
    time.sleep(0.3)  # the supervisor's clock past the master's last State
    driver.execute_script("""
const d = window.teleopDashboard;
const t0 = d.tNow + 0.05;
for (let i = 0; i < 20; i++)
  d.dispatch({type: 'state', t_s: t0 + 0.05 * i, pair: d.pair, role: 'slave', cycle: 1000 + 50 * i, time_s: i,
              engagement: 'coupled', device_faults: 0, dof: 3, position_m: [0, 0, 0], peer_position_m: [0, 0, 0],
              force_sensor_N: [0, 0, 0], command_N: [0, 0, 0], fixture_penetration_m: 0, tracking_error_m: 0,
              rtt_ms: 1, fixture_stiffness_N_per_m: 1400, fixture_limit_N_per_m: i < 5 ? null : 14000, joints: 7,
              joint_position_rad: [0.01 * i, 0.6, 0, -1.4, 0, 0.9, 0], joint_torque_Nm: [2.5, -38, 0, 5, 0, 1, 0]});
""")

    def arm_shown():
        s = state()
        ok = s["shown"]["joint-position"] and s["shown"]["joint-torque"] and "joint-torque" in s["graphs"]
        return s if ok and len(s["graphs"]["stiffness"]["columns"]["slave limit"]) >= 15 else None
    arm = wait_until(arm_shown, 5, "the joint plots shown for the arm's states", interval_s=0.1)
    q = arm["graphs"]["joint-position"]
    tau = arm["graphs"]["joint-torque"]
    check(arm["jointChoice"] == [str(j) for j in range(1, 8)] and q["visible"]["slave q"]
          and not q["visible"]["master q"] and not tau["visible"]["master torque"]
          and q["columns"]["slave q"][-20:] == [0.01 * i for i in range(20)]
          and set(tau["columns"]["slave torque"]) == {2.5},
          f"the joint plots: joints 1..7 to choose, joint 1's position {q['columns']['slave q'][-3:]} rad and torque "
          f"{sorted(set(tau['columns']['slave torque']))} N·m for the slave only (the loopback master has no joints)")
    limit = arm["graphs"]["stiffness"]
    check(limit["visible"]["slave limit"] and limit["columns"]["slave limit"] == [14000.0] * 15
          and not limit["visible"]["master limit"] and limit["columns"]["slave stiffness"][-20:] == [1400.0] * 20,
          "the slave's limit is drawn from its first value on (15 of 20 states), the master's (none) is not")
    for name in ("stiffness", "joint-position", "joint-torque"):
        check_colours(name, arm["graphs"][name])
    check(arm["graphs"]["stiffness"]["dashed"]["slave limit"]
          and not arm["graphs"]["stiffness"]["dashed"]["slave stiffness"],
          "the stiffness, limit and joint plots keep distinct colours for colour-blind readers; the limit dashed")
    driver.execute_script("document.querySelector('figure[data-panel=\"stiffness\"]').scrollIntoView();")
    shot = os.path.join(work, "dashboard_arm.png")
    driver.save_screenshot(shot)
    print(f"  screenshot (an arm's states): {shot}")

    errors = [e for e in driver.get_log("browser") if e.get("level") == "SEVERE"]
    check(not errors, f"the browser logged no error ({errors[:3]})")

    procs["supervise"].send_signal(signal.SIGINT)
    check(procs["supervise"].wait(timeout=10) == 0, "teleop-supervise (with the dashboard) exits 0 on SIGINT")
    return 0


if __name__ == "__main__":
    run_test(main)
