// teleop-supervise's live dashboard (docs/dds.md, "The dashboard"). Messages from /ws, one JSON object each:
//   hello      {version, t_s}
//   processes  {t_s, total, offset, processes: [{pair, role, status, engagement, age_s, ...}], chosen: [...]}
//              every refresh: the rows of the table from `offset` ("table <offset>") and those of this page's pair
//   state      {t_s, pair, role, engagement, dof, position_m[], command_N[], force_sensor_N[], ..., clutch?}
//   event      {t_s, pair, role, kind, cycle, value}
// state and event only for the pair this page subscribed to ("subscribe <pair>"). The page repeats its subscription
// every KEEPALIVE_MS: the server drops a page that says nothing for two minutes. Text from DDS is only ever set
// with textContent; class names come from the fixed tables below, never from a message.
'use strict';
(function () {
  const WINDOW_S = 30;        // seconds of history per plot
  const MAX_ROWS = 4000;      // rows per plot at most (20 Hz x 2 processes x 30 s = 1200)
  const MAX_EVENTS = 50;
  const REDRAW_MS = 250;
  const KEEPALIVE_MS = 15000;
  const ROLES = ['master', 'slave'];
  const KNOWN_STATUS = ['discovered', 'live', 'stale', 'gone', 'finished'];
  const KNOWN_ENGAGEMENT = ['waiting', 'coupled', 'peer_lost', 'peer_shutdown', 'fault', 'stopping', 'aligning'];
  const PAIR_NAME = /^[A-Za-z][A-Za-z0-9_]{0,63}$/;

  // One plot per trace: its series (label, role, value of a state or process entry) and its y unit.
  const PLOTS = {
    position: {
      y: 'mm', from: 'state',
      series: [['master x', 'master', (s, a) => mm(s.position_m[a])],
               ['slave x', 'slave', (s, a) => mm(s.position_m[a])]],
    },
    force: {
      y: 'N', from: 'state',
      series: [['master command', 'master', (s, a) => s.command_N[a]],
               ['slave command', 'slave', (s, a) => s.command_N[a]],
               ['master sensor', 'master', (s, a) => s.force_sensor_N[a]],
               ['slave sensor', 'slave', (s, a) => s.force_sensor_N[a]]],
    },
    penetration: {
      y: 'mm', from: 'state',
      series: [['master', 'master', (s) => mm(s.fixture_penetration_m)],
               ['slave', 'slave', (s) => mm(s.fixture_penetration_m)]],
    },
    age: {
      y: 's', from: 'processes',
      series: [['master', 'master', (p) => p.age_s], ['slave', 'slave', (p) => p.age_s]],
    },
    rtt: {
      y: 'ms', from: 'state',
      series: [['master', 'master', (s) => s.rtt_ms], ['slave', 'slave', (s) => s.rtt_ms]],
    },
  };

  const ui = {
    connection: document.getElementById('connection'),
    clock: document.getElementById('clock'),
    table: document.querySelector('#processes tbody'),
    noProcesses: document.getElementById('no-processes'),
    pair: document.getElementById('pair'),
    axis: document.getElementById('axis'),
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
    pair: '', axis: 0, dof: 1, tNow: 0, tableOffset: 0, tableTotal: 0, tableRows: 0,
    rows: {}, graphs: {}, dirty: {},
    statesReceived: 0, processesReceived: 0, eventsReceived: 0,
    latest: {master: null, slave: null},   // newest state of the chosen pair
    view: {master: null, slave: null},     // newest process entry of the chosen pair
  };
  window.teleopDashboard = dash;
  let socket = null;

  function mm(m) { return (m === null || m === undefined) ? null : m * 1e3; }
  function fixed(v, digits) { return (v === null || v === undefined) ? '-' : Number(v).toFixed(digits); }

  function resetTraces() {
    for (const name of Object.keys(PLOTS)) {
      dash.rows[name] = [];
      dash.dirty[name] = true;
      if (dash.graphs[name]) { dash.graphs[name].destroy(); delete dash.graphs[name]; }
    }
    dash.latest = {master: null, slave: null};
    dash.view = {master: null, slave: null};
    ui.events.replaceChildren();
    renderBadges();
  }

  function addRow(name, t, role, values) {
    const plot = PLOTS[name];
    const row = [t];
    let v = 0;
    for (const s of plot.series) row.push(s[1] === role ? values[v++] : null);
    const rows = dash.rows[name];
    rows.push(row);
    while (rows.length > MAX_ROWS || (rows.length > 1 && rows[0][0] < t - WINDOW_S)) rows.shift();
    dash.dirty[name] = true;
  }

  function onState(s) {
    if (s.pair !== dash.pair || ROLES.indexOf(s.role) < 0) return;
    dash.statesReceived++;
    dash.latest[s.role] = s;
    if (s.dof !== dash.dof) setDof(s.dof);
    const a = Math.min(dash.axis, Math.max(0, s.dof - 1));
    for (const [name, plot] of Object.entries(PLOTS)) {
      if (plot.from !== 'state') continue;
      const values = plot.series.filter((x) => x[1] === s.role).map((x) => finiteOrNull(x[2](s, a)));
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

  function finiteOrNull(v) { return (typeof v === 'number' && isFinite(v)) ? v : null; }

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
      if (p) addRow('age', m.t_s, role, [finiteOrNull(PLOTS.age.series.find((x) => x[1] === role)[2](p))]);
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
      cell(tr, p.engagement === null ? '-' : p.engagement, engagementClass(p.engagement));
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
      const engagement = s ? s.engagement : (p && p.engagement) || '-';
      const status = p ? p.status : '-';
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
    const li = document.createElement('li');
    li.textContent = 't = ' + fixed(m.t_s, 2) + ' s  ' + m.role + '  ' + m.kind + '  (cycle ' + m.cycle + ')';
    ui.events.insertBefore(li, ui.events.firstChild);
    while (ui.events.childNodes.length > MAX_EVENTS) ui.events.removeChild(ui.events.lastChild);
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
      if (!dash.graphs[name]) {
        dash.graphs[name] = new window.Dygraph(document.getElementById('graph-' + name), rows, {
          labels: ['t (s)'].concat(plot.series.map((s) => s[0])),
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
          includeZero: name === 'age' || name === 'penetration',
          axes: {y: {axisLabelWidth: 64, axisLabelFormatter: tick}},
        });
      } else {
        dash.graphs[name].updateOptions({file: rows, dateWindow: xRange});
      }
    }
  }

  function connect() {
    const url = (window.location.protocol === 'https:' ? 'wss://' : 'ws://') + window.location.host + '/ws';
    socket = new WebSocket(url);
    socket.onopen = () => {
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
      if (m.type === 'state') onState(m);
      else if (m.type === 'processes') onProcesses(m);
      else if (m.type === 'event') onEvent(m);
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
  ui.tablePrev.addEventListener('click', () => turnTable(-1));
  ui.tableNext.addEventListener('click', () => turnTable(1));
  resetTraces();
  setInterval(redraw, REDRAW_MS);
  setInterval(subscribe, KEEPALIVE_MS);
  connect();
})();
