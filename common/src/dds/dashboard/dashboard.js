// teleop-supervise's live dashboard (docs/dds.md, "The dashboard"). Messages from /ws, one JSON object each:
//   hello      {version, t_s, history_s}
//   processes  {t_s, total, offset, processes: [{pair, role, status, engagement, age_s, ...}], chosen: [...]}
//              every refresh: the rows of the table from `offset` ("table <offset>") and those of this page's pair
//   state      {t_s, pair, role, engagement, dof, position_m[], command_N[], force_sensor_N[], ..., clutch?,
//              fixture_stiffness_N_per_m, fixture_limit_N_per_m (null: no limit computed), joints,
//              joint_position_rad[joints], joint_torque_Nm[joints]}
//   event      {t_s, pair, role, kind, cycle, value}
// state and event only for the pair this page subscribed to ("subscribe <pair>"); on subscribing, the server first sends
// the pair's history (its last seconds of states and events), so a page opened mid-run shows it at once. The page
// repeats its subscription every KEEPALIVE_MS: the server drops a page that says nothing for two minutes.
//
// What is shown is what is so: a process that is not live (stale, gone, finished) has engagement "unknown", never
// its last value; a held clutch is its own state "clutched"; a trace has a gap (NaN: dygraphs breaks the line) where
// no sample came for GAP_PERIODS sample periods, and the round trip is a gap while the peer does not answer; events
// of one kind from one side within FOLD_S fold into one line with a count. An optional series (the fixture's
// predicted limit, a joint) is drawn and listed only while it has a value in the window, and a panel of optional
// series only (the joints) is shown only then: a Cartesian pair has no joint plots, a process that computes no limit
// no limit line. The plots are built from PANELS (add a panel there, nothing else); colours are Okabe and Ito's
// (distinguishable with the common colour-vision deficiencies), a sensor trace dashed beside its command. Text from
// DDS is only ever set with textContent; class names come from the fixed tables below, never from a message.
'use strict';
(function () {
  let WINDOW_S = 30;          // seconds shown per plot: the server's history (hello.history_s), at least 30
  const MAX_ROWS = 20000;     // rows per plot at most (20 Hz x 2 processes x 30 s = 1200)
  const MAX_EVENTS = 50;
  const MAX_JOINTS = 12;      // the State's joint sequences' bound (teleop::kMaxDof)
  const FOLD_S = 10;          // events of one kind from one side within this long: one line with a count
  const GAP_PERIODS = 4;      // no sample for this many sample periods (at least GAP_MIN_S): a gap in the trace
  const GAP_MIN_S = 0.3;
  const REDRAW_MS = 250;
  const KEEPALIVE_MS = 15000;
  const ROLES = ['master', 'slave'];
  const KNOWN_STATUS = ['discovered', 'live', 'stale', 'gone', 'finished'];
  const KNOWN_ENGAGEMENT = ['waiting', 'coupled', 'peer_lost', 'peer_shutdown', 'fault', 'stopping', 'aligning',
    'clutched', 'unknown'];
  const LIVE_STATUS = ['live'];
  // Okabe & Ito, "Color Universal Design" (2008): master blue, slave vermillion; their sensors sky blue, orange.
  const COLOR = {master: '#0072B2', slave: '#D55E00', masterSensor: '#56B4E9', slaveSensor: '#E69F00'};
  const DASHED = [6, 3];
  const PAIR_NAME = /^[A-Za-z][A-Za-z0-9_]{0,63}$/;
  const KNOWN_KIND = /^[a-z_]{1,40}$/;

  // One panel per plot: its id, title, y unit, the message it is fed from, and its series (label, role, colour,
  // dashed or not, optional or not, value of a state or process entry at the chosen axis a and joint j; NaN for
  // "no value": a gap).
  const PANELS = [
    {id: 'position', title: 'Position (mm)', y: 'mm', from: 'state', series: [
      {label: 'master x', role: 'master', color: COLOR.master, value: (s, a) => mm(s.position_m[a])},
      {label: 'slave x', role: 'slave', color: COLOR.slave, value: (s, a) => mm(s.position_m[a])}]},
    {id: 'force', title: 'Force (N)', y: 'N', from: 'state', series: [
      {label: 'master command', role: 'master', color: COLOR.master, value: (s, a) => s.command_N[a]},
      {label: 'slave command', role: 'slave', color: COLOR.slave, value: (s, a) => s.command_N[a]},
      {label: 'master sensor', role: 'master', color: COLOR.masterSensor, dashed: true,
        value: (s, a) => s.force_sensor_N[a]},
      {label: 'slave sensor', role: 'slave', color: COLOR.slaveSensor, dashed: true,
        value: (s, a) => s.force_sensor_N[a]}]},
    {id: 'penetration', title: 'Fixture penetration (mm)', y: 'mm', from: 'state', includeZero: true, series: [
      {label: 'master', role: 'master', color: COLOR.master, value: (s) => mm(s.fixture_penetration_m)},
      {label: 'slave', role: 'slave', color: COLOR.slave, value: (s) => mm(s.fixture_penetration_m)}]},
    {id: 'stiffness', title: 'Fixture stiffness and predicted limit (N/m)', y: 'N/m', from: 'state', includeZero: true,
      series: [
        {label: 'master stiffness', role: 'master', color: COLOR.master, value: (s) => s.fixture_stiffness_N_per_m},
        {label: 'slave stiffness', role: 'slave', color: COLOR.slave, value: (s) => s.fixture_stiffness_N_per_m},
        {label: 'master limit', role: 'master', color: COLOR.masterSensor, dashed: true, optional: true,
          value: (s) => s.fixture_limit_N_per_m},
        {label: 'slave limit', role: 'slave', color: COLOR.slaveSensor, dashed: true, optional: true,
          value: (s) => s.fixture_limit_N_per_m}]},
    {id: 'tracking', title: 'Tracking error (mm)', y: 'mm', from: 'state', includeZero: true, series: [
      {label: 'master', role: 'master', color: COLOR.master, value: (s) => mm(s.tracking_error_m)},
      {label: 'slave', role: 'slave', color: COLOR.slave, value: (s) => mm(s.tracking_error_m)}]},
    {id: 'age', title: 'Data age at the supervisor (s)', y: 's', from: 'processes', includeZero: true, series: [
      {label: 'master', role: 'master', color: COLOR.master, value: (p) => p.age_s},
      {label: 'slave', role: 'slave', color: COLOR.slave, value: (p) => p.age_s}]},
    {id: 'rtt', title: 'Round trip (ms)', y: 'ms', from: 'state', series: [
      {label: 'master', role: 'master', color: COLOR.master, value: (s) => peerAnswers(s) ? s.rtt_ms : NaN},
      {label: 'slave', role: 'slave', color: COLOR.slave, value: (s) => peerAnswers(s) ? s.rtt_ms : NaN}]},
    {id: 'joint-position', title: 'Joint position (rad)', y: 'rad', from: 'state', series: [
      {label: 'master q', role: 'master', color: COLOR.master, optional: true,
        value: (s, a, j) => joint(s, s.joint_position_rad, j)},
      {label: 'slave q', role: 'slave', color: COLOR.slave, optional: true,
        value: (s, a, j) => joint(s, s.joint_position_rad, j)}]},
    {id: 'joint-torque', title: 'Joint torque (N\u00b7m)', y: 'N\u00b7m', from: 'state', includeZero: true, series: [
      {label: 'master torque', role: 'master', color: COLOR.master, optional: true,
        value: (s, a, j) => joint(s, s.joint_torque_Nm, j)},
      {label: 'slave torque', role: 'slave', color: COLOR.slave, optional: true,
        value: (s, a, j) => joint(s, s.joint_torque_Nm, j)}]},
  ];
  const PLOTS = Object.fromEntries(PANELS.map((p) => [p.id, p]));
  // A panel whose series are all optional is shown only while one of them has a value.
  function panelOptional(plot) { return plot.series.every((x) => x.optional); }

  // Joint j of a state (NaN when the process has no such joint: a Cartesian device, or fewer joints).
  function joint(s, values, j) {
    return (Array.isArray(values) && Number.isInteger(s.joints) && j < s.joints && j < values.length) ? values[j]
                                                                                                     : NaN;
  }

  // The round trip is measured only while the peer answers; otherwise the State holds its last value.
  function peerAnswers(s) { return s.engagement === 'coupled' || s.engagement === 'aligning'; }

  function buildPanels() {
    const plots = document.getElementById('plots');
    for (const panel of PANELS) {
      const figure = document.createElement('figure');
      figure.className = 'plot';
      figure.dataset.panel = panel.id;
      figure.hidden = panelOptional(panel);
      const caption = document.createElement('figcaption');
      caption.textContent = panel.title;
      const graph = document.createElement('div');
      graph.className = 'graph';
      graph.id = 'graph-' + panel.id;
      const legend = document.createElement('div');
      legend.className = 'legend';
      legend.id = 'legend-' + panel.id;
      figure.append(caption, graph, legend);
      plots.appendChild(figure);
    }
    const events = document.createElement('figure');
    events.className = 'plot events';
    const caption = document.createElement('figcaption');
    caption.textContent = 'Events';
    const list = document.createElement('ol');
    list.id = 'events';
    events.append(caption, list);
    plots.appendChild(events);
  }
  buildPanels();

  const ui = {
    connection: document.getElementById('connection'),
    clock: document.getElementById('clock'),
    table: document.querySelector('#processes tbody'),
    noProcesses: document.getElementById('no-processes'),
    pair: document.getElementById('pair'),
    axis: document.getElementById('axis'),
    joint: document.getElementById('joint'),
    jointLabel: document.getElementById('joint-label'),
    events: document.getElementById('events'),
    noDygraphs: document.getElementById('no-dygraphs'),
    tableRange: document.getElementById('table-range'),
    tablePrev: document.getElementById('table-prev'),
    tableNext: document.getElementById('table-next'),
  };
  document.getElementById('window-s').textContent = String(WINDOW_S);
  const haveDygraphs = typeof window.Dygraph === 'function';
  ui.noDygraphs.hidden = haveDygraphs;

  // What the page shows, also read by the browser test (tests/dds/dashboard_browser_test.py).
  const dash = {
    pair: '', axis: 0, dof: 1, joint: 0, joints: 0, tNow: 0, tableOffset: 0, tableTotal: 0, tableRows: 0,
    rows: {}, graphs: {}, dirty: {},
    statesReceived: 0, processesReceived: 0, eventsReceived: 0,
    latest: {master: null, slave: null},   // newest state of the chosen pair
    view: {master: null, slave: null},     // newest process entry of the chosen pair
    lastT: {}, period: {},                 // by panel and role: the newest sample's time, the sample period
    folded: new Map(),                     // "role kind" -> {li, count, first, last, cycle}
    eventLines: 0, gaps: 0,
  };
  window.teleopDashboard = dash;
  // Whether a panel is shown (a panel of optional series is hidden while none has a value), for the browser test.
  dash.panelShown = (name) => !figureOf(name).hidden;
  function figureOf(name) { return document.querySelector('figure[data-panel="' + name + '"]'); }
  // The events as folded, for the browser test: one entry per line shown.
  dash.eventList = () => [...dash.folded.values()].filter((f) => f.li.parentNode === ui.events)
    .map((f) => ({role: f.role, kind: f.kind, count: f.count, first: f.first, last: f.last, value: f.value}));
  let socket = null;

  function mm(m) { return (m === null || m === undefined) ? null : m * 1e3; }
  function fixed(v, digits) { return (v === null || v === undefined) ? '-' : Number(v).toFixed(digits); }

  function resetTraces() {
    for (const name of Object.keys(PLOTS)) {
      dash.rows[name] = [];
      dash.dirty[name] = true;
      dash.lastT[name] = {};
      dash.period[name] = {};
      if (dash.graphs[name]) { dash.graphs[name].destroy(); delete dash.graphs[name]; }
      figureOf(name).hidden = panelOptional(PLOTS[name]);
    }
    setJoints(0);
    dash.latest = {master: null, slave: null};
    dash.view = {master: null, slave: null};
    dash.folded = new Map();
    ui.events.replaceChildren();
    renderBadges();
  }

  // A row of `role`'s values (the other role's columns null: dygraphs connects across those). When no sample of
  // this role came for GAP_PERIODS periods, a NaN row first: the line breaks there.
  function addRow(name, t, role, values) {
    const plot = PLOTS[name];
    const rows = dash.rows[name];
    const last = dash.lastT[name][role];
    if (last !== undefined) {
      const dt = t - last;
      const period = dash.period[name][role];
      if (period !== undefined && dt > Math.max(GAP_MIN_S, GAP_PERIODS * period)) {
        rows.push(rowOf(plot, last + 1e-3, role, values.map(() => NaN)));
        dash.gaps++;
      } else if (dt > 0) {
        dash.period[name][role] = period === undefined ? dt : 0.9 * period + 0.1 * Math.min(dt, 1);
      }
    }
    dash.lastT[name][role] = t;
    const row = rowOf(plot, t, role, values);
    rows.push(row);
    while (rows.length > MAX_ROWS || (rows.length > 1 && rows[0][0] < t - WINDOW_S)) rows.shift();
    dash.dirty[name] = true;
  }

  function rowOf(plot, t, role, values) {
    const row = [t];
    let v = 0;
    for (const s of plot.series) row.push(s.role === role ? values[v++] : null);
    return row;
  }

  function onState(s) {
    if (s.pair !== dash.pair || ROLES.indexOf(s.role) < 0) return;
    dash.statesReceived++;
    dash.latest[s.role] = s;
    if (s.dof !== dash.dof) setDof(s.dof);
    const joints = Math.max(...ROLES.map((r) => (dash.latest[r] && Number.isInteger(dash.latest[r].joints))
      ? Math.min(dash.latest[r].joints, MAX_JOINTS) : 0));
    if (joints !== dash.joints) setJoints(joints);
    const a = Math.min(dash.axis, Math.max(0, s.dof - 1));
    for (const [name, plot] of Object.entries(PLOTS)) {
      if (plot.from !== 'state') continue;
      const values = plot.series.filter((x) => x.role === s.role)
        .map((x) => finiteOrGap(x.value(s, a, dash.joint)));
      addRow(name, s.t_s, s.role, values);
    }
    renderBadges();
  }

  // A y tick: at most 4 significant digits, never an exponent wider than the axis.
  function tick(v) {
    if (v === 0) return '0';
    const a = Math.abs(v);
    if (a < 1e-3 || a >= 1e5) return v.toExponential(1);
    return String(Number(v.toPrecision(4)));
  }

  function finiteOrGap(v) { return (typeof v === 'number' && isFinite(v)) ? v : NaN; }
  function hasValue(v) { return typeof v === 'number' && isFinite(v); }

  function setDof(dof) {
    dash.dof = dof;
    const keep = Math.min(dash.axis, dof - 1);
    ui.axis.replaceChildren();
    for (let i = 0; i < dof; i++) {
      const o = document.createElement('option');
      o.value = String(i);
      o.textContent = String(i);
      ui.axis.appendChild(o);
    }
    ui.axis.value = String(Math.max(0, keep));
  }

  // The joint chosen for the joint plots; the choice is shown only when a side of the pair has joints (an arm).
  function setJoints(joints) {
    dash.joints = joints;
    ui.jointLabel.hidden = joints === 0;
    const keep = Math.min(dash.joint, Math.max(0, joints - 1));
    ui.joint.replaceChildren();
    for (let i = 0; i < joints; i++) {
      const o = document.createElement('option');
      o.value = String(i);
      o.textContent = String(i + 1);  // joints are named from 1, as in the URDFs and the arm's messages
      ui.joint.appendChild(o);
    }
    dash.joint = keep;
    if (joints > 0) ui.joint.value = String(keep);
  }

  // Commands (teleop-supervise --allow-commands): the token comes in the address's fragment (#token=..., never sent
  // to a server or logged); the server checks it, forwards the command to the process's command channel (its
  // stability gate and bounded rates) and sends the reply, with who sent it, to every page of the pair.
  const TOKEN = /^[0-9a-f]{64}$/;
  const commandToken = new URLSearchParams(window.location.hash.slice(1)).get('token') || '';
  function sendCommand(line) {
    const reply = document.getElementById('command-reply');
    if (!TOKEN.test(commandToken)) { reply.textContent = 'no token: open the address teleop-supervise printed'; return; }
    if (!socket || socket.readyState !== WebSocket.OPEN || !dash.pair) return;
    const role = document.getElementById('command-role').value;
    socket.send('command ' + commandToken + ' ' + role + ' ' + line.trim());
  }
  function onCommand(m) {
    if (m.pair !== dash.pair) return;
    document.getElementById('command-reply').textContent = m.role + ' ' + m.text + ': ' + m.reply;
    onEvent({pair: m.pair, role: m.role, kind: 'command ' + m.text + ' from ' + m.from + ': ' + m.reply,
             t_s: m.t_s, cycle: '-', value: 0});
  }
  for (const b of document.querySelectorAll('#commands button[data-command]'))
    b.addEventListener('click', () => sendCommand(b.dataset.command));
  document.getElementById('command-send').addEventListener('click',
    () => sendCommand(document.getElementById('command-line').value));

  function onHello(m) {
    document.getElementById('commands').hidden = m.commands !== true;
    if (typeof m.history_s === 'number' && isFinite(m.history_s) && m.history_s > WINDOW_S) {
      WINDOW_S = Math.min(m.history_s, 3600);
      document.getElementById('window-s').textContent = String(WINDOW_S);
    }
  }

  function onProcesses(m) {
    dash.processesReceived++;
    dash.tNow = m.t_s;
    ui.clock.textContent = 't = ' + fixed(m.t_s, 1) + ' s';
    renderTable(m.processes);
    renderTableRange(m);
    const chosen = Array.isArray(m.chosen) ? m.chosen : [];
    const names = m.processes.map((p) => p.pair).concat(dash.pair ? [dash.pair] : []);
    const pairs = [...new Set(names)].filter((p) => PAIR_NAME.test(p)).sort();
    renderPairChoice(pairs);
    const mine = chosen.concat(m.processes).filter((p) => p.pair === dash.pair);
    for (const p of mine) if (ROLES.indexOf(p.role) >= 0) dash.view[p.role] = p;
    for (const role of ROLES) {
      const p = mine.find((x) => x.role === role);
      if (p) addRow('age', m.t_s, role, [finiteOrGap(PLOTS.age.series.find((x) => x.role === role).value(p))]);
    }
    renderBadges();
  }

  // The table comes a page of rows at a time (the server's bound): "rows a-b of N" and the buttons to turn pages.
  function renderTableRange(m) {
    dash.tableTotal = Number(m.total) || m.processes.length;
    dash.tableRows = Math.max(dash.tableRows, m.processes.length);
    const first = Number(m.offset) || 0;
    const paged = dash.tableTotal > m.processes.length || first > 0;
    ui.tableRange.hidden = !paged;
    ui.tablePrev.hidden = !paged;
    ui.tableNext.hidden = !paged;
    ui.tableRange.textContent = 'rows ' + (m.processes.length ? first + 1 : 0) + '-' + (first + m.processes.length) +
        ' of ' + dash.tableTotal;
    ui.tablePrev.disabled = first === 0;
    ui.tableNext.disabled = first + m.processes.length >= dash.tableTotal;
  }

  function turnTable(direction) {
    const step = dash.tableRows || 50;
    dash.tableOffset = Math.max(0, Math.min(dash.tableOffset + direction * step, dash.tableTotal - 1));
    if (socket && socket.readyState === WebSocket.OPEN) socket.send('table ' + dash.tableOffset);
  }

  function renderPairChoice(pairs) {
    const have = [...ui.pair.options].map((o) => o.value);
    if (have.join('\n') !== pairs.join('\n')) {
      ui.pair.replaceChildren();
      for (const p of pairs) {
        const o = document.createElement('option');
        o.value = p;
        o.textContent = p;
        ui.pair.appendChild(o);
      }
    }
    if (!dash.pair && pairs.length > 0) {
      const wanted = new URLSearchParams(window.location.search).get('pair');
      choosePair(wanted && pairs.indexOf(wanted) >= 0 ? wanted : pairs[0]);
    }
    if (dash.pair) ui.pair.value = dash.pair;
  }

  function choosePair(pair) {
    if (!PAIR_NAME.test(pair) || pair === dash.pair) return;
    dash.pair = pair;
    resetTraces();
    subscribe();
  }

  function subscribe() {
    if (socket && socket.readyState === WebSocket.OPEN) socket.send(dash.pair ? 'subscribe ' + dash.pair : 'subscribe');
  }

  function cell(tr, text, cls) {
    const td = document.createElement('td');
    td.textContent = text;
    if (cls) td.className = cls;
    tr.appendChild(td);
  }

  // The engagement as it is known: "unknown" for a process that is not live (its last State is not what it does
  // now), "clutched" while a clutch is held (the node aligns while clutched; that is not a failure to couple).
  function shownEngagement(status, engagement, clutched) {
    if (status !== undefined && LIVE_STATUS.indexOf(status) < 0) return status === 'discovered' ? '-' : 'unknown';
    if (engagement === null || engagement === undefined) return '-';
    if (clutched && (engagement === 'aligning' || engagement === 'coupled')) return 'clutched';
    return engagement;
  }
  function tableClutched(p) { return typeof p.clutch === 'string' && p.clutch !== '-' && p.clutch !== ''; }

  function statusClass(status) { return KNOWN_STATUS.indexOf(status) >= 0 ? 'status-' + status : 'status-unknown'; }
  function engagementClass(e) { return KNOWN_ENGAGEMENT.indexOf(e) >= 0 ? 'engagement-' + e : 'engagement-none'; }

  function renderTable(processes) {
    ui.noProcesses.hidden = processes.length > 0;
    const body = document.createDocumentFragment();
    for (const p of processes) {
      const tr = document.createElement('tr');
      tr.dataset.pair = p.pair;
      tr.dataset.role = p.role;
      if (p.pair === dash.pair) tr.className = 'chosen';
      tr.addEventListener('click', () => { choosePair(p.pair); ui.pair.value = p.pair; });
      cell(tr, p.pair);
      cell(tr, p.role);
      cell(tr, p.status, statusClass(p.status));
      const shown = shownEngagement(p.status, p.engagement, tableClutched(p));
      cell(tr, shown, engagementClass(shown));
      cell(tr, typeof p.clutch === 'string' ? p.clutch : '-');  // "-" or the sources held ("device+command")
      cell(tr, fixed(p.age_s, 1), 'num');
      cell(tr, fixed(p.achieved_rate_hz, 0), 'num');
      cell(tr, p.loss_fraction === null ? '-' : (100 * p.loss_fraction).toFixed(2), 'num');
      cell(tr, String(p.packets_lost), 'num');
      cell(tr, fixed(p.rtt_ms, 3), 'num');
      cell(tr, p.tracking_error_m === null ? '-' : (1e3 * p.tracking_error_m).toFixed(3), 'num');
      cell(tr, p.device_faults ? '0x' + p.device_faults.toString(16) : '-');
      cell(tr, String(p.watchdog_trips), 'num');
      cell(tr, p.last_event || '-');
      body.appendChild(tr);
    }
    ui.table.replaceChildren(body);
  }

  function renderBadges() {
    for (const role of ROLES) {
      const badge = document.getElementById('badge-' + role);
      const s = dash.latest[role];
      const p = dash.view[role];
      const status = p ? p.status : '-';
      const clutched = s ? s.clutch === 'clutched' : (p ? tableClutched(p) : false);
      const engagement = shownEngagement(p ? p.status : undefined, s ? s.engagement : (p && p.engagement),
                                         clutched);
      const e = badge.querySelector('.engagement');
      e.textContent = engagement;
      e.className = 'engagement ' + engagementClass(engagement);
      const st = badge.querySelector('.status');
      st.textContent = status;
      st.className = 'status ' + statusClass(status);
      badge.dataset.engagement = KNOWN_ENGAGEMENT.indexOf(engagement) >= 0 ? engagement : '';
      badge.dataset.status = KNOWN_STATUS.indexOf(status) >= 0 ? status : '';
      const clutch = badge.querySelector('.clutch');
      // The State's clutch ("clutched" / "released"; teleop-supervise sends it for every State it has).
      clutch.hidden = !(s && typeof s.clutch === 'string');
      if (!clutch.hidden) clutch.querySelector('.clutch-state').textContent = s.clutch;
      badge.dataset.clutch = clutch.hidden ? '' : s.clutch;
    }
  }

  function onEvent(m) {
    if (m.pair !== dash.pair) return;
    dash.eventsReceived++;
    const key = m.role + ' ' + m.kind;
    let f = dash.folded.get(key);
    if (f && m.t_s - f.last <= FOLD_S && f.li.parentNode === ui.events) {
      f.count++;
      f.last = m.t_s;
      f.cycle = m.cycle;
      f.value = m.value;
    } else {
      f = {li: document.createElement('li'), count: 1, first: m.t_s, last: m.t_s, cycle: m.cycle, role: m.role,
           kind: m.kind, value: m.value};
      f.li.dataset.kind = KNOWN_KIND.test(m.kind) ? m.kind : '';
      dash.folded.set(key, f);
    }
    f.li.dataset.count = String(f.count);
    f.li.textContent = 't = ' + fixed(f.last, 2) + ' s  ' + f.role + '  ' + f.kind + '  (cycle ' + f.cycle + ')' +
        (f.count > 1 ? '  x' + f.count + ' since t = ' + fixed(f.first, 2) + ' s' : '');
    ui.events.insertBefore(f.li, ui.events.firstChild);
    while (ui.events.childNodes.length > MAX_EVENTS) ui.events.removeChild(ui.events.lastChild);
    dash.eventLines = ui.events.childNodes.length;
  }

  function redraw() {
    if (!haveDygraphs) return;
    for (const [name, plot] of Object.entries(PLOTS)) {
      if (!dash.dirty[name]) continue;
      const rows = dash.rows[name];
      if (!rows || rows.length < 2) continue;
      dash.dirty[name] = false;
      const t1 = rows[rows.length - 1][0];
      const xRange = [Math.max(rows[0][0], t1 - WINDOW_S), t1];
      // An optional series is drawn and listed only while it has a value in the window.
      const visibility = plot.series.map((x, i) => !x.optional || rows.some((r) => hasValue(r[i + 1])));
      const shown = !panelOptional(plot) || visibility.some((v) => v);
      figureOf(name).hidden = !shown;
      if (!shown) {
        if (dash.graphs[name]) { dash.graphs[name].destroy(); delete dash.graphs[name]; }
        continue;
      }
      if (!dash.graphs[name]) {
        dash.graphs[name] = new window.Dygraph(document.getElementById('graph-' + name), rows, {
          labels: ['t (s)'].concat(plot.series.map((s) => s.label)),
          colors: plot.series.map((s) => s.color),
          series: Object.fromEntries(plot.series.filter((s) => s.dashed).map((s) => [s.label, {strokePattern: DASHED}])),
          labelsDiv: document.getElementById('legend-' + name),  // beside the plot, never over the data
          legend: 'always',
          labelsSeparateLines: true,
          xlabel: 'supervisor time (s)',
          ylabel: plot.y,
          connectSeparatedPoints: true,
          strokeWidth: 1.5,
          dateWindow: xRange,
          axisLabelFontSize: 13,
          xLabelHeight: 16,
          yLabelWidth: 16,
          includeZero: Boolean(plot.includeZero),
          visibility: visibility,
          axes: {y: {axisLabelWidth: 64, axisLabelFormatter: tick}},
        });
      } else {
        dash.graphs[name].updateOptions({file: rows, dateWindow: xRange, visibility: visibility});
      }
    }
  }

  function dispatch(m) {
    if (m.type === 'state') onState(m);
    else if (m.type === 'hello') onHello(m);
    else if (m.type === 'processes') onProcesses(m);
    else if (m.type === 'event') onEvent(m);
    else if (m.type === 'command') onCommand(m);
  }
  dash.dispatch = dispatch;  // the browser test feeds a synthetic event storm through it

  function connect() {
    const url = (window.location.protocol === 'https:' ? 'wss://' : 'ws://') + window.location.host + '/ws';
    socket = new WebSocket(url);
    socket.onopen = () => {
      resetTraces();  // the server sends the pair's history again on subscribing
      ui.connection.textContent = 'live';
      ui.connection.className = 'connection live';
      subscribe();
      if (dash.tableOffset > 0) socket.send('table ' + dash.tableOffset);
    };
    socket.onclose = () => {
      ui.connection.textContent = 'disconnected, retrying';
      ui.connection.className = 'connection lost';
      setTimeout(connect, 1000);
    };
    socket.onmessage = (e) => {
      let m;
      try { m = JSON.parse(e.data); } catch (err) { return; }
      dispatch(m);
    };
  }

  ui.pair.addEventListener('change', () => choosePair(ui.pair.value));
  ui.axis.addEventListener('change', () => {
    dash.axis = Number(ui.axis.value) || 0;
    for (const name of ['position', 'force']) {
      dash.rows[name] = [];
      if (dash.graphs[name]) { dash.graphs[name].destroy(); delete dash.graphs[name]; }
    }
  });
  ui.joint.addEventListener('change', () => {
    dash.joint = Number(ui.joint.value) || 0;
    for (const name of ['joint-position', 'joint-torque']) {
      dash.rows[name] = [];
      if (dash.graphs[name]) { dash.graphs[name].destroy(); delete dash.graphs[name]; }
    }
  });
  ui.tablePrev.addEventListener('click', () => turnTable(-1));
  ui.tableNext.addEventListener('click', () => turnTable(1));
  resetTraces();
  setInterval(redraw, REDRAW_MS);
  setInterval(subscribe, KEEPALIVE_MS);
  connect();
})();
