// drempower dashboard page: one WebSocket, five views, an always-visible ESTOP.
"use strict";
(function () {
  const $ = (s) => document.querySelector(s);
  const $$ = (s) => Array.from(document.querySelectorAll(s));
  const KEEP_S = 60; // seconds of samples kept per motor (the largest window)
  const CH = { angle: 2, speed: 3, torque: 4 };
  const TGT = { angle: 6, speed: 7, torque: 8 };
  const PLOT_UNIT = { angle: "deg", speed: "rpm", torque: "Nm", T: "flag", E: "flag" };
  const UNIT_LABEL = { deg: "angle / deg", rpm: "speed / r/min", Nm: "torque / Nm", flag: "T, E flags", value: "parameter" };
  const DASH = { angle: undefined, speed: [8, 4], torque: [3, 3], T: [12, 3, 2, 3], E: [2, 6] };
  const COLORS = ["#1e88e5", "#e53935", "#43a047", "#fb8c00", "#8e24aa", "#00897b", "#6d4c41", "#3949ab",
    "#c0ca33", "#d81b60", "#5e35b1", "#00acc1"];

  // ------------------------------------------------------------ state
  const S = {
    ws: null, req: 0, pending: new Map(), params: [], motors: [], cards: {}, readOnly: false,
    data: new Map(), // id -> {t:[], rows:[]} raw samples, oldest first
    lastT: 0, paused: false, frozen: null, xRange: null, dirty: true,
    received: 0, frames: 0, rateWin: [], paramValues: {}, changed: new Set(), runs: [],
    names: {}, watched: [], gainsSeq: 0, paramsSeq: 0, twin: new Map(), pdata: new Map(), // "id:name" -> {t:[], v:[]} polled parameter values
  };
  window.dashParams = (key) => S.pdata.get(key);
  window.dashListeners = window.dashListeners || []; // other views' handlers of every server message
  window.dashStats = { received: 0, firstTotal: 0, serverTotal: 0, batches: 0, frames: 0, fps: 0, rate: 0, connected: false };

  function say(text, info) {
    const m = $("#msg");
    m.textContent = text || "";
    m.className = info ? "info" : "";
  }

  // ------------------------------------------------------------ connection
  function connect() {
    const proto = location.protocol === "https:" ? "wss:" : "ws:";
    const ws = new WebSocket(proto + "//" + location.host + "/ws" + location.search);
    S.ws = ws;
    ws.onopen = () => { setConn(true); };
    ws.onclose = () => {
      setConn(false);
      for (const p of S.pending.values()) p.reject(new Error("connection lost"));
      S.pending.clear();
      setTimeout(connect, 1000);
    };
    ws.onmessage = (ev) => onMessage(JSON.parse(ev.data));
  }
  function setConn(ok) {
    const c = $("#conn");
    c.textContent = ok ? "connected" : "disconnected";
    c.className = ok ? "ok" : "bad";
    window.dashStats.connected = ok;
  }
  // The heartbeat (every 100 ms; the server idles this page's motors after 0.5 s without one) is ticked
  // by a worker: browsers slow the timers of a hidden tab down to once a second, not those of workers.
  const beat = () => { if (S.ws && S.ws.readyState === 1) S.ws.send('{"op":"hb"}'); };
  try {
    const w = new Worker(URL.createObjectURL(new Blob(["setInterval(() => postMessage(0), 100);"], { type: "text/javascript" })));
    w.onmessage = beat;
  } catch (e) {
    setInterval(beat, 100);
  }

  function call(op, args) {
    return new Promise((resolve, reject) => {
      if (!S.ws || S.ws.readyState !== 1) { reject(new Error("not connected")); return; }
      const req = ++S.req;
      S.pending.set(req, { resolve, reject });
      S.ws.send(JSON.stringify(Object.assign({ op, req }, args || {})));
    });
  }
  window.dashCall = call;
  window.dashSay = say;
  async function act(op, args, okText) {
    try {
      const r = await call(op, args);
      if (okText) say(okText, true);
      return r;
    } catch (e) {
      say(String(e.message || e));
      throw e;
    }
  }

  // click handlers: a refused input or a failed request is shown in #msg, never thrown
  function on(sel, fn, ev) {
    $(sel).addEventListener(ev || "click", (e) => {
      try {
        const r = fn(e);
        if (r && r.catch) r.catch(() => {});
      } catch (err) {
        if (err.message !== "invalid") say(String(err.message || err));
      }
    });
  }

  function onMessage(m) {
    for (const f of window.dashListeners) f(m);
    switch (m.t) {
      case "hello":
        S.params = m.params; S.readOnly = m.read_only; S.bandwidth = m.bandwidth;
        S.paramByName = Object.fromEntries(m.params.map((p) => [p.name, p]));
        S.names = m.names || {};
        S.columns = m.columns;
        $("#ro").hidden = !m.read_only;
        lockReadOnly();
        $("#busname").textContent = m.bus;
        // the load is reckoned against the CAN bit rate; a serial link's baud rate is not it
        $("#load-of").textContent = m.bitrate ? `of CAN ${m.bitrate / 1e6} Mbit/s` : "of 1 Mbit/s (assumed)";
        $("#load-of").title = (m.bitrate ? "" : "the CAN bit rate is unknown to this connection; ") + `polling budget: ${m.budget}`;
        $("#plot-rate").value = m.heartbeat_ms ? String(Math.round(1000 / m.heartbeat_ms)) : "0";
        if (m.motors.length) setMotors(m.motors);
        buildParamTable();
        $("#pw-names").innerHTML = m.params.map((p) => `<option value="${p.name}">`).join("");
        setWatched(m.watched);
        if (m.scanning) $("#scan-text").textContent = "scanning...";
        else if (!m.motors.length) scanBus().catch(() => {}); // what is on the bus, at once
        break;
      case "scanned":
        $("#scan-text").textContent = `done: ${m.found.length} motor(s): ${m.found.map((f) => shortName(f.id)).join(", ")}`;
        break;
      case "samples": onSamples(m); break;
      case "shadow": onShadow(m); break;
      case "divergence": { // the shadow twin flagged a joint: said, and kept on the page
        say(m.text);
        const n = $("#shadow-note");
        n.hidden = false;
        n.textContent = n.textContent ? n.textContent + "\n" + m.text : m.text;
        break;
      }
      case "watched": setWatched(m.watched); break;
      case "names": { S.names = m.names || {}; const ms = S.motors; S.motors = []; setMotors(ms); break; }
      case "params":
        for (const [id, name, t, v] of m.s) {
          const k = `${id}:${name}`;
          let d = S.pdata.get(k);
          if (!d) { d = { t: [], v: [] }; S.pdata.set(k, d); }
          d.t.push(t); d.v.push(v);
          if (d.t.length > 4000) { d.t = d.t.slice(-3000); d.v = d.v.slice(-3000); }
        }
        S.dirty = true;
        break;
      case "status":
        $("#load").textContent = (100 * m.load).toFixed(1) + " %";
        window.dashStats.serverTotal = m.sent_total;
        window.dashStats.commanded = m.commanded;
        break;
      case "scan":
        $("#scan-progress").max = m.of;
        $("#scan-progress").value = m.done;
        $("#scan-text").textContent = `${m.done}/${m.of}, found ${m.found.map((f) => shortName(f.id)).join(", ") || "none"}`;
        break;
      case "cards":
        for (const c of m.cards) S.cards[c.id] = c;
        setMotors(m.cards.map((c) => c.id));
        renderCards();
        applyLimits();
        break;
      case "reply": {
        const p = S.pending.get(m.req);
        if (p) { S.pending.delete(m.req); m.ok ? p.resolve(m.result) : p.reject(new Error(m.error)); }
        break;
      }
    }
  }

  // ------------------------------------------------------------ samples
  function onSamples(m) {
    const s = m.s;
    if (window.dashStats.batches++ === 0) window.dashStats.firstTotal = m.total - s.length;
    S.received += s.length;
    window.dashStats.received = S.received;
    window.dashStats.serverTotal = Math.max(window.dashStats.serverTotal, m.total);
    const now = performance.now();
    S.rateWin.push([now, s.length]);
    let newTarget = false;
    for (const row of s) {
      let d = S.data.get(row[0]);
      if (!d) { d = { t: [], rows: [], targets: new Set() }; S.data.set(row[0], d); if (!S.motors.includes(row[0])) setMotors([...S.motors, row[0]]); }
      d.t.push(row[1]); d.rows.push(row);
      if (row[1] > S.lastT) S.lastT = row[1];
      for (const [ch, col] of Object.entries(TGT)) {
        if (row[col] !== null && row[col] !== undefined && !d.targets.has(ch)) { d.targets.add(ch); newTarget = true; }
      }
    }
    // a target drawn for the first time joins the legend (only series that are drawn are listed)
    if (newTarget && !$("#view-plots").hidden) rebuildPlot();
    for (const d of S.data.values()) {
      if (d.t.length > 1000 && d.t[0] < S.lastT - KEEP_S * 1.2) {
        const k = lowerBound(d.t, S.lastT - KEEP_S);
        d.t = d.t.slice(k); d.rows = d.rows.slice(k);
      }
    }
    S.dirty = true;
  }
  setInterval(() => {
    const now = performance.now();
    S.rateWin = S.rateWin.filter((r) => now - r[0] < 1000);
    const rate = S.rateWin.reduce((a, r) => a + r[1], 0);
    window.dashStats.rate = rate;
    $("#rate").textContent = rate;
    $("#plot-count").textContent = S.received;
    const per = [];
    for (const [id, d] of S.data) {
      const k = lowerBound(d.t, S.lastT - 1);
      per.push(`${motorName(id)}: ${d.t.length - k}/s`);
    }
    $("#plot-per-motor").textContent = per.join(", ");
    window.dashStats.fps = S.frames; $("#plot-fps").textContent = S.frames; S.frames = 0;
  }, 1000);

  // the shadow twin's angle at each motor (deg): a series beside the motor's own angle
  function onShadow(m) {
    let added = false;
    for (const [key, v] of Object.entries(m.a || {})) {
      const id = Number(key);
      let d = S.twin.get(id);
      if (!d) { d = { t: [], v: [] }; S.twin.set(id, d); added = true; }
      d.t.push(m.at); d.v.push(v);
      if (d.t.length > 1000 && d.t[0] < m.at - KEEP_S * 1.2) {
        const k = lowerBound(d.t, m.at - KEEP_S);
        d.t = d.t.slice(k); d.v = d.v.slice(k);
      }
    }
    if (added && !$("#view-plots").hidden) rebuildPlot();
    S.dirty = true;
  }

  function lowerBound(a, x) {
    let lo = 0, hi = a.length;
    while (lo < hi) { const mid = (lo + hi) >> 1; if (a[mid] < x) lo = mid + 1; else hi = mid; }
    return lo;
  }

  // ------------------------------------------------------------ motors and views
  // watching only: every control disabled (the server refuses them anyway), ESTOP stays
  function lockReadOnly() {
    for (const e of $$("#view-control button, #view-control input, #view-control select, #par-save, #par-restore, #tun-run, #tun-gains input, #tun-gains button, #prop-run, #plot-rate")) {
      e.disabled = S.readOnly;
    }
  }
  // how the page names a motor: as the server names it (drempower.naming: motor_<id>, a robot file's joint,
  // <bus>/motor_<id> where buses collide); one name in every label, list, legend, message and CSV row
  function motorName(id) {
    const n = S.names && S.names[id];
    return n && n.name ? n.name : `motor_${id}`;
  }
  const legendName = motorName;
  // the units the page takes and shows for a motor: at the joint (gear and offset applied) for a joint of
  // a robot file, the motor's own for a bare motor (the server's names say which)
  function atJoint(id) { const n = S.names && S.names[id]; return !!(n && n.units === "joint"); }
  const unitsWord = (id) => (atJoint(id) ? " at the joint" : "");
  function unitsText(id) {
    const n = S.names && S.names[id];
    if (!n) return "";
    return n.units === "joint"
      ? `${motorName(id)}: deg, r/min and Nm at the joint (gear ${fmtL(n.gear)}, offset ${fmtL(n.offset_deg)} deg: motor angle = (joint angle - offset) x gear)`
      : `${motorName(id)}: the motor's deg, r/min and Nm`;
  }
  const shortName = motorName;
  function setMotors(ids) {
    ids = Array.from(new Set(ids)).sort((a, b) => a - b);
    if (ids.join() === S.motors.join()) return;
    S.motors = ids;
    for (const sel of $$(".motor-select")) {
      const v = sel.value;
      sel.innerHTML = ids.map((i) => `<option value="${i}">${shortName(i)}</option>`).join("");
      if (ids.includes(Number(v))) sel.value = v;
    }
    const unchecked = new Set($$("#plot-motors input:not(:checked)").map((e) => Number(e.value)));
    $("#plot-motors").innerHTML = "motors " + ids.map((i) =>
      `<label><input type="checkbox" value="${i}" ${unchecked.has(i) ? "" : "checked"}> ${shortName(i)}</label>`).join(" ");
    $("#sync-rows").innerHTML = ids.map((i) =>
      `<label><span><input type="checkbox" class="sync-on" value="${i}" checked> ${motorName(i)}</span>
       <input type="number" step="any" class="sync-angle" data-id="${i}" value="0"></label>`).join("");
    lockReadOnly();
    rebuildPlot();
  }

  for (const b of $$("nav button")) {
    b.addEventListener("click", () => {
      for (const o of $$("nav button")) o.setAttribute("aria-selected", String(o === b));
      for (const v of $$(".view")) v.hidden = v.id !== "view-" + b.dataset.view;
      say(""); // a message belongs to the view it came from
      if (b.dataset.view === "plots") rebuildPlot();
      if (b.dataset.view === "params" && S.motors.length && !Object.keys(S.paramValues).length) readParams();
      if (b.dataset.view === "tuning") { loadGains(); drawRuns(); }
    });
  }

  // ------------------------------------------------------------ ESTOP
  function estop() {
    if (S.ws && S.ws.readyState === 1) S.ws.send(JSON.stringify({ op: "estop", req: ++S.req }));
    say("ESTOP sent: every motor stopped; clear errors and enable to go on", false);
  }
  on("#estop", estop);
  document.addEventListener("keydown", (e) => {
    if (e.key !== " " && e.key !== "Escape") return;
    const t = e.target;
    const typing = t && (t.isContentEditable || ["INPUT", "TEXTAREA", "SELECT"].includes(t.tagName));
    if (typing) return;
    e.preventDefault();
    estop();
  });

  // ------------------------------------------------------------ bus view
  function scanBus() {
    $("#scan-progress").value = 0;
    $("#scan-text").textContent = "scanning...";
    return act("scan", {});
  }
  on("#scan", scanBus);
  const esc = (t) => String(t).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" }[c]));
  function fmt(v, d) { return v === null || v === undefined ? "-" : Number(v).toFixed(d); }
  function latest(id) {
    const d = S.data.get(id);
    return d && d.rows.length ? d.rows[d.rows.length - 1] : null;
  }
  function renderCards() {
    const html = S.motors.map((id) => {
      const c = S.cards[id] || { id };
      const r = latest(id);
      const errs = (c.errors || []).map((e) => `<div class="err"><b>${e.word}: ${e.flag}</b> ${e.meaning} <i>${e.advice}</i></div>`).join("");
      const ro = S.readOnly ? "disabled" : "";
      const n = S.names[id];
      const title = motorName(id) + (n && n.bus ? ` <span class="dim">bus ${n.bus}, id ${n.id}</span>` : "");
      return `<div class="card" data-id="${id}"><h3>${title}</h3>
        <table><tr><td>state</td><td>${c.state_name || "-"}</td></tr>
        <tr><td>angle</td><td>${r ? fmt(r[2], 2) : "-"} deg</td></tr>
        <tr><td>speed</td><td>${r ? fmt(r[3], 2) : "-"} r/min</td></tr>
        <tr><td>torque</td><td>${r ? fmt(r[4], 2) : "-"} Nm</td></tr>
        <tr><td>supply</td><td>${fmt(c.vbus, 1)} V</td></tr>
        <tr><td>temps</td><td>FET ${fmt(c.fet_temp, 1)} / motor ${fmt(c.motor_temp, 1)} &deg;C</td></tr>
        <tr><td>current</td><td class="derating">limit ${fmt(c.current_limit, 2)} A, derating ${c.derating == null ? "-" : fmt(c.derating * 100, 0)} %</td></tr>
        <tr><td>fw/hw</td><td>${c.fw ?? "-"}/${c.hw ?? "-"}</td></tr></table>
        ${r && r[5] & 2 ? errs || '<div class="err">error flag set</div>' : ""}
        <button data-card="clear_errors" ${ro}>Clear errors</button>
        <button data-card="enable" ${ro}>Enable</button><button data-card="idle" ${ro}>Idle</button></div>`;
    }).join("");
    $("#cards").innerHTML = html;
  }
  on("#cards", (e) => {
    const b = e.target.closest("button[data-card]");
    if (!b) return;
    const id = Number(b.closest(".card").dataset.id);
    return act("control", { action: b.dataset.card, id }, `${motorName(id)}: ${b.dataset.card}`);
  });
  setInterval(() => { if (!$("#view-bus").hidden) renderCards(); }, 500);

  // ------------------------------------------------------------------ health: temperatures, derating, faults
  const HEALTH = { lo: 20, hi: 110, w: 360, h: 90 };
  function trendSvg(trend) {
    if (!trend || trend.length < 2) return '<svg class="trend"></svg>';
    const t0 = trend[0][0], t1 = Math.max(trend[trend.length - 1][0], t0 + 1);
    const x = (t) => ((t - t0) / (t1 - t0)) * HEALTH.w;
    const y = (v) => HEALTH.h - ((Math.min(Math.max(v, HEALTH.lo), HEALTH.hi) - HEALTH.lo) / (HEALTH.hi - HEALTH.lo)) * HEALTH.h;
    const line = (k, cls) => `<polyline class="${cls}" points="${trend.map((p) => `${x(p[0]).toFixed(1)},${y(p[k]).toFixed(1)}`).join(" ")}"/>`;
    const mark = (v, cls) => `<line class="${cls}" x1="0" x2="${HEALTH.w}" y1="${y(v).toFixed(1)}" y2="${y(v).toFixed(1)}"/>`;
    return `<svg class="trend" viewBox="0 0 ${HEALTH.w} ${HEALTH.h}" width="${HEALTH.w}" height="${HEALTH.h}">` +
      mark(95, "derate") + mark(100, "trip") + line(2, "board") + line(1, "winding") + "</svg>";
  }
  function renderHealth() {
    const rows = S.motors.map((id) => {
      const c = S.cards[id] || { id };
      // the robot file's supervisor (its [health]) decides the level when it runs; else the reading does
      const level = c.level || ((c.errors || []).length ? "error" : c.derating > 0 || c.motor_temp >= 80 || c.fet_temp >= 80 ? "warn" : "ok");
      const faults = (c.errors || []).map((e) => `<div class="err"><b>${e.word} ${e.flag}</b>: ${e.meaning} <i>Fix: ${e.advice}</i></div>`).join("") +
        (c.events || []).map((e) => `<div class="event event-${e.level}" data-kind="${e.kind}" data-action="${e.action}">${fmt(e.t, 1)} s: ${esc(e.text)}</div>`).join("");
      return `<tr class="health-${level}" data-id="${id}"><td>${motorName(id)}</td><td>${level}</td>
        <td>${fmt(c.motor_temp, 1)}</td><td>${fmt(c.fet_temp, 1)}</td><td>${fmt(c.current_limit, 2)}</td>
        <td>${c.derating == null ? "-" : fmt(c.derating * 100, 0)} %</td><td>${trendSvg(c.trend)}${faults}</td></tr>`;
    }).join("");
    $("#health-table tbody").innerHTML = rows;
  }
  setInterval(() => { if (!$("#view-health").hidden) renderHealth(); }, 500);

  // ------------------------------------------------------------ plots
  let plot = null;
  let series = []; // [{id, ch, target}]
  function selectedMotors() { return $$("#plot-motors input:checked").map((e) => Number(e.value)); }
  function selectedChannels() { return $$("#plot-channels input[value]:checked").map((e) => e.value); }
  function windowS() { return Number($("#plot-window").value); }

  function rebuildPlot() {
    const el = $("#plot");
    if (plot) { plot.destroy(); plot = null; }
    if ($("#view-plots").hidden) return;
    const ids = selectedMotors(), chs = selectedChannels(), tg = $("#plot-targets").checked;
    series = [];
    // one colour per joint (motor), the channel by its dash; targets only once there are any to draw
    ids.forEach((id, k) => {
      const color = COLORS[k % COLORS.length], d = S.data.get(id);
      for (const ch of chs) {
        series.push({ id, ch, target: false, color, unit: PLOT_UNIT[ch] });
        if (tg && TGT[ch] !== undefined && d && d.targets && d.targets.has(ch)) series.push({ id, ch, target: true, color, unit: PLOT_UNIT[ch] });
        if (ch === "angle" && S.twin.has(id)) series.push({ id, ch, twin: true, color, unit: PLOT_UNIT[ch] });
      }
    });
    S.watched.forEach(([id, name], k) => {
      series.push({ id, ch: name, param: `${id}:${name}`, color: COLORS[(ids.length + k) % COLORS.length], unit: "value" });
    });
    // one y axis per unit drawn: the first on the left, the next on the right, and so on
    const units = [...new Set(series.map((x) => x.unit))];
    const scales = { x: { time: false } };
    for (const u of units) scales[u] = {};
    const axes = [{ label: "t / s" }].concat(units.map((u, i) => ({
      scale: u, side: i % 2 ? 1 : 3, label: UNIT_LABEL[u] || u, grid: { show: i === 0 },
    })));
    const opts = {
      width: Math.max(400, el.clientWidth || window.innerWidth - 30), height: 380,
      scales,
      axes: units.length ? axes : [{ label: "t / s" }, {}],
      cursor: { drag: { x: true, y: false } },
      hooks: { setSelect: [(u) => {
        if (u.select.width > 5) {
          S.xRange = [u.posToVal(u.select.left, "x"), u.posToVal(u.select.left + u.select.width, "x")];
          pause(true);
        }
      }] },
      series: [{ label: "t" }].concat(series.map((s) => ({
        label: `${legendName(s.id)} ${s.param ? s.ch.split(".").slice(-2).join(".") : s.ch + (s.target ? " target" : s.twin ? " twin" : "")}`,
        stroke: s.color, width: s.target || s.twin ? 1 : 1.5, scale: s.unit,
        dash: s.target ? [1, 3] : s.twin ? [8, 4] : DASH[s.ch], spanGaps: true,
        points: { show: false },
      }))),
    };
    plot = new uPlot(opts, [[]].concat(series.map(() => [])), el);
    window.dashPlot = plot; // what is drawn: axes and series (for tests and the curious)
    S.dirty = true;
  }

  // min/max decimation of every series onto one grid of ~width buckets (display only)
  function decimated(x0, x1, width) {
    const n = Math.max(10, Math.floor(width / 2));
    const dt = (x1 - x0) / n;
    const xs = new Array(2 * n);
    for (let b = 0; b < n; b++) { xs[2 * b] = x0 + b * dt; xs[2 * b + 1] = x0 + (b + 0.5) * dt; }
    const out = [xs];
    const src = S.paused && S.frozen ? S.frozen : S.data;
    for (const s of series) {
      const ys = new Array(2 * n).fill(null);
      if (s.param || s.twin) {
        const p = s.twin ? S.twin.get(s.id) : S.pdata.get(s.param);
        if (p) {
          for (let i = lowerBound(p.t, x0); i < p.t.length && p.t[i] < x1; i++) {
            const b = Math.min(n - 1, Math.floor((p.t[i] - x0) / dt));
            ys[2 * b] = p.v[i];
          }
        }
        out.push(ys);
        continue;
      }
      const d = src.get(s.id);
      if (d) {
        const col = s.target ? TGT[s.ch] : CH[s.ch];
        let i = lowerBound(d.t, x0);
        const end = lowerBound(d.t, x1);
        for (let b = 0; b < n && i < end; b++) {
          const lim = x0 + (b + 1) * dt;
          let lo = Infinity, hi = -Infinity;
          for (; i < end && d.t[i] < lim; i++) {
            const r = d.rows[i];
            const v = col !== undefined ? r[col] : (s.ch === "T" ? r[5] & 1 : (r[5] >> 1) & 1);
            if (v === null) continue;
            if (v < lo) lo = v;
            if (v > hi) hi = v;
          }
          if (lo !== Infinity) { ys[2 * b] = lo; ys[2 * b + 1] = hi; }
        }
      }
      out.push(ys);
    }
    return out;
  }
  function frame() {
    requestAnimationFrame(frame);
    if (!plot || $("#view-plots").hidden || !S.dirty) return;
    S.dirty = false;
    let x0, x1;
    if (S.xRange) [x0, x1] = S.xRange;
    else { x1 = S.paused && S.frozenT ? S.frozenT : S.lastT; x0 = x1 - windowS(); }
    plot.batch(() => {
      plot.setData(decimated(x0, x1, plot.width), false);
      plot.setScale("x", { min: x0, max: x1 });
    });
    S.frames++; window.dashStats.frames++;
  }
  requestAnimationFrame(frame);
  function pause(on) {
    S.paused = on;
    $("#plot-pause").textContent = on ? "Resume" : "Pause";
    if (on && !S.frozen) {
      S.frozen = new Map(Array.from(S.data, ([k, d]) => [k, { t: d.t.slice(), rows: d.rows.slice() }]));
      S.frozenT = S.lastT;
    }
    if (!on) { S.frozen = null; S.xRange = null; }
    S.dirty = true;
  }
  on("#plot-pause", () => pause(!S.paused));
  on("#plot-reset", () => pause(false));
  function pan(dir) {
    if (!S.paused) pause(true);
    const x1 = S.xRange ? S.xRange[1] : S.frozenT, x0 = S.xRange ? S.xRange[0] : x1 - windowS();
    const w = x1 - x0;
    S.xRange = [x0 + dir * w / 2, x1 + dir * w / 2];
    S.dirty = true;
  }
  on("#plot-left", () => pan(-1));
  on("#plot-right", () => pan(1));
  on("#plot-window", () => { S.xRange = null; S.dirty = true; }, "change");
  on("#plot-channels", rebuildPlot, "change");
  on("#plot-motors", rebuildPlot, "change");
  on("#plot-rate", (e) =>
    act("rate", { hz: Number(e.target.value) }, `sample rate ${e.target.value === "0" ? "poll" : e.target.value + "/s"}`), "change");
  on("#plot-csv", () => {
    const src = S.paused && S.frozen ? S.frozen : S.data;
    let x0, x1;
    if (S.xRange) [x0, x1] = S.xRange; else { x1 = S.paused ? S.frozenT : S.lastT; x0 = x1 - windowS(); }
    // the columns of monitor --csv and state --json (names with units, from the server), one row per sample
    const C = S.columns;
    const lines = [[C.time, C.id, C.name, C.position, C.speed, C.torque, C.done, C.error,
      "target_" + C.position, "target_" + C.speed, "target_" + C.torque, "units"].join(",")];
    for (const id of selectedMotors()) {
      const d = src.get(id);
      if (!d) continue;
      const n = S.names[id], name = motorName(id);
      const quoted = /[",\n]/.test(name) ? `"${name.replace(/"/g, '""')}"` : name;
      for (let i = lowerBound(d.t, x0); i < d.t.length && d.t[i] <= x1; i++) {
        const r = d.rows[i];
        lines.push([r[1].toFixed(4), n ? n.id : id, quoted, r[2], r[3], r[4], r[5] & 1, (r[5] >> 1) & 1,
          r[6] ?? "", r[7] ?? "", r[8] ?? "", atJoint(id) ? "joint" : "motor"].join(","));
      }
    }
    download("drempower-plot.csv", lines.join("\n") + "\n", "text/csv");
  });
  function download(name, text, type) {
    const a = document.createElement("a");
    a.href = URL.createObjectURL(new Blob([text], { type }));
    a.download = name;
    document.body.appendChild(a); a.click(); a.remove();
  }
  window.addEventListener("resize", rebuildPlot);
  function setWatched(w) {
    S.watched = w || [];
    $("#pw-list").innerHTML = S.watched.map(([id, name, hz]) =>
      `<span>${motorName(id)} ${name} ${hz}/s <button data-unwatch="${id}|${name}" aria-label="stop plotting ${name}">&times;</button></span>`).join(" ");
    rebuildPlot();
  }
  on("#pw-add", () => act("watch", { id: Number($("#pw-motor").value), name: $("#pw-name").value.trim(),
    hz: Number($("#pw-rate").value) }));
  on("#pw-list", (e) => {
    const b = e.target.closest("button[data-unwatch]");
    if (!b) return null;
    const [id, name] = b.dataset.unwatch.split("|");
    return act("watch", { id: Number(id), name, hz: 0 });
  });

  // ------------------------------------------------------------ control
  const ctlId = () => Number($("#ctl-motor").value);
  // an input as the page labels it: "Position: speed r/min", "jog deg", "duration s"
  function fieldName(el) {
    const lab = el.closest("label");
    let name = el.getAttribute("aria-label") || (lab ? lab.textContent.trim() : el.id);
    const fs = el.closest("fieldset");
    if (fs) name = `${fs.querySelector("legend").textContent}: ${name}`;
    return name;
  }
  const num = (sel) => {
    const el = $(sel);
    if (!el.checkValidity() || el.value === "") { say(`${fieldName(el)} ${el.value || "(empty)"} is outside ${el.min}..${el.max}`); throw new Error("invalid"); }
    return Number(el.value);
  };
  function control(args, text) {
    try { return act("control", Object.assign({ id: ctlId() }, args), text); } catch (e) { return null; }
  }
  $$("#view-control button[data-act]").forEach((b) => b.addEventListener("click", () => {
    const r = control({ action: b.dataset.act }, `${motorName(ctlId())}: ${b.dataset.act}`);
    if (r) r.catch(() => {}); // a refusal is shown in #msg
  }));
  on("#pos-go", () => control({ action: $("#pos-mode").value, angle: num("#pos-angle"),
    speed: num("#pos-speed"), param: num("#pos-param") }, `${motorName(ctlId())}: move to ${$("#pos-angle").value} deg`));
  on("#jog-plus", () => control({ action: "jog", delta: num("#jog-delta"), speed: num("#pos-speed"), param: num("#pos-param") }));
  on("#jog-minus", () => control({ action: "jog", delta: -num("#jog-delta"), speed: num("#pos-speed"), param: num("#pos-param") }));
  on("#step-go", () => control({ action: "step", delta: num("#step-delta") })); // T, the motor's own bandwidth
  on("#vel-go", () => control({ action: "V", speed: num("#vel-speed"), mode: Number($("#vel-mode").value), param: num("#vel-param") }));
  on("#tq-go", () => control({ action: "C", torque: num("#tq-torque"), mode: Number($("#tq-mode").value), param: num("#tq-param") }));
  on("#imp-go", () => control({ action: "impedance", angle: num("#imp-angle"), speed: num("#imp-speed"),
    torque: num("#imp-torque"), kp: num("#imp-kp"), kd: num("#imp-kd") }));
  on("#sync-go", () => {
    const ids = $$(".sync-on:checked").map((e) => Number(e.value));
    const angles = ids.map((i) => Number($(`.sync-angle[data-id="${i}"]`).value));
    return act("control", { action: "sync_move", ids, angles, speed: num("#sync-speed"), accel: num("#sync-accel") },
      `synchronised move of ${ids.join(",")}`);
  });
  // the Control inputs bounded by the limits the selected motor holds (read by the server) and by the
  // T-mode bandwidth's parameter domain; the server checks the same bounds again
  const WIRE = 327.67;
  // a value the user typed is never changed by the page (a limit arriving later only makes it refused)
  $$("#view-control input[type=number]").forEach((el) => el.addEventListener("input", () => { el.dataset.typed = "1"; }));
  function setRange(id, lo, hi) {
    const el = $("#" + id); el.min = String(lo); el.max = String(hi);
    // a default beyond a limit (a robot file's speed limit) would be refused: bring it within
    const v = Number(el.value);
    if (!el.dataset.typed && el.value !== "" && Number.isFinite(v) && (v < lo || v > hi)) {
      el.value = String(Math.trunc(Math.min(hi, Math.max(lo, v)) * 1e4) / 1e4); // toward 0: still within
    }
  }
  function applyLimits() {
    const c = S.cards[ctlId()], L = (c && c.limits) || {};
    const sp = Math.min(WIRE, L.speed ?? WIRE), tq = Math.min(WIRE, L.torque ?? WIRE);
    const bw = L.bandwidth || S.bandwidth || [0, 300];
    for (const id of ["pos-speed", "vel-speed", "imp-speed"]) setRange(id, -sp, sp);
    for (const id of ["tq-torque", "imp-torque"]) setRange(id, -tq, tq);
    const all = S.motors.map((i) => (S.cards[i] && S.cards[i].limits && S.cards[i].limits.speed) ?? WIRE);
    setRange("sync-speed", 0.01, Math.min(WIRE, ...all));
    const pm = $("#pos-mode").value;
    if (pm === "T") setRange("pos-param", bw[0], bw[1]);
    else if (pm === "P") setRange("pos-param", -tq, tq);
    else setRange("pos-param", -WIRE, WIRE);
    if ($("#vel-mode").value === "1") setRange("vel-param", -tq, tq); else setRange("vel-param", -WIRE, WIRE);
    const pos = L.position;
    for (const id of ["pos-angle", "imp-angle"]) {
      if (pos) setRange(id, pos[0], pos[1]); else setRange(id, -36000, 36000);
    }
    const by = L.set_by ? ` (set by ${[...new Set(Object.values(L.set_by))].join("; ")})` : "";
    $("#ctl-limits").textContent = c && c.limits
      ? `limits of ${motorName(ctlId())}${unitsWord(ctlId())}: ${pos ? `position ${fmtL(pos[0])}..${fmtL(pos[1])} deg, ` : ""}speed ±${fmtL(L.speed)} r/min, torque ±${fmtL(L.torque)} Nm, current ${fmtL(L.current)} A; T bandwidth ${bw[0]}..${bw[1]} 1/s${by}`
      : `T bandwidth ${bw[0]}..${bw[1]} 1/s (scan to read the motor's limits)`;
    $("#ctl-units").textContent = unitsText(ctlId()) ? "units: " + unitsText(ctlId()) : "";
  }
  const fmtL = (v) => (v === null || v === undefined ? "?" : String(+Number(v).toPrecision(6)));
  for (const sel of ["#ctl-motor", "#pos-mode", "#vel-mode"]) on(sel, applyLimits, "change");
  // the live plot of the selected motor: angle (deg, left) and speed (r/min, right), targets dashed
  let ctlPlot = null, ctlPlotId = null;
  function drawControlPlot() {
    const el = $("#ctl-plot");
    if ($("#view-control").hidden) return;
    const id = ctlId();
    if (!ctlPlot || ctlPlotId !== id) {
      if (ctlPlot) ctlPlot.destroy();
      ctlPlotId = id;
      ctlPlot = new uPlot({
        width: Math.max(400, el.clientWidth || window.innerWidth - 30), height: 200, scales: { x: { time: false } },
        axes: [{ label: "t / s" }, { scale: "deg", label: `angle / deg${atJoint(id) ? " (joint)" : ""}` }, { scale: "rpm", side: 1, label: `speed / r/min${atJoint(id) ? " (joint)" : ""}`, grid: { show: false } }],
        series: [{ label: "t" },
          { label: `${legendName(id)} angle`, scale: "deg", stroke: COLORS[0], points: { show: false }, spanGaps: true },
          { label: `${legendName(id)} angle target`, scale: "deg", stroke: COLORS[0], dash: [6, 4], points: { show: false }, spanGaps: true },
          { label: `${legendName(id)} speed`, scale: "rpm", stroke: COLORS[1], points: { show: false }, spanGaps: true },
          { label: `${legendName(id)} speed target`, scale: "rpm", stroke: COLORS[1], dash: [6, 4], points: { show: false }, spanGaps: true }],
      }, [[], [], [], [], []], el);
    }
    const d = S.data.get(id), cols = [[], [], [], [], []];
    if (d) {
      const step = Math.max(1, Math.floor((d.t.length - lowerBound(d.t, S.lastT - 10)) / 800));
      for (let i = lowerBound(d.t, S.lastT - 10); i < d.t.length; i += step) {
        const r = d.rows[i];
        cols[0].push(r[1]); cols[1].push(r[2]); cols[2].push(r[6]); cols[3].push(r[3]); cols[4].push(r[7]);
      }
    }
    ctlPlot.setData(cols);
    window.dashStats.controlPoints = cols[0].length;
    window.dashStats.controlMotor = id;
  }
  setInterval(drawControlPlot, 100);
  on("#ctl-motor", drawControlPlot, "change");
  setInterval(() => {
    const r = latest(ctlId());
    $("#ctl-state").textContent = r ? `${atJoint(ctlId()) ? "at the joint: " : ""}angle ${fmt(r[2], 2)} deg, speed ${fmt(r[3], 2)} r/min, torque ${fmt(r[4], 2)} Nm${r[5] & 1 ? ", done" : ""}${r[5] & 2 ? ", ERROR" : ""}` : "";
  }, 250);

  // ------------------------------------------------------------ parameters
  function buildParamTable() {
    let html = "", group = null;
    for (const p of S.params) {
      if (p.group !== group) { group = p.group; html += `<tr class="group"><td colspan="6">${group}</td></tr>`; }
      // a hard range bounds the input itself; a soft one is checked on Set (crossable with "force")
      const hardRange = p.hard && !p.allowed.length
        ? `${p.min !== null ? `min="${p.min}"` : ""} ${p.max !== null ? `max="${p.max}"` : ""}` : "";
      const force = p.domain && !p.hard
        ? ` <label class="force" title="write a value outside the soft domain"><input type="checkbox" data-force="${p.name}" aria-label="force ${p.name}">force</label>` : "";
      const edit = p.access === "rw" && !S.readOnly
        ? `<input data-name="${p.name}" type="number" step="${p.type === "f32" ? "any" : "1"}" ${hardRange} aria-label="${p.name}"> <button data-set="${p.name}">Set</button>${force}` : "";
      html += `<tr data-name="${p.name}"><td title="address ${p.address}, ${p.type}">${p.name}</td>
        <td><span class="val" data-val="${p.name}">-</span> ${edit}</td><td>${p.unit}</td><td>${p.access}</td>
        <td class="domain">${p.domain}</td><td>${p.description}</td></tr>`;
    }
    $("#par-table tbody").innerHTML = html;
  }
  const parId = () => Number($("#par-motor").value);
  function inDomain(p, v) {
    if (p.allowed.length) return p.allowed.includes(v);
    if (p.min !== null && !(v >= p.min)) return false;
    return p.max === null || v <= p.max;
  }
  // a parameter value as the motor holds it: f32 values to their 7 significant digits
  const shown = (v) => (Number.isInteger(v) ? String(v) : String(+Number(v).toPrecision(7)));
  // the motor cannot say what its flash holds: the baseline is the first read of this session, or Save to flash
  const CHANGED_TIP = "* changed this session: differs from the value first read by this dashboard, or since Save to flash";
  function markChanged(tr, on) { tr.classList.toggle("changed", on); tr.title = on ? CHANGED_TIP : ""; }
  async function readParams() {
    if (!S.motors.length) return;
    const id = parId(), seq = ++S.paramsSeq;
    const r = await act("params", { id });
    if (seq !== S.paramsSeq) return; // a later read (another motor) owns the table
    S.paramValues = r.values; S.changed = new Set(r.changed);
    for (const el of $$("#par-table span.val")) {
      const v = r.values[el.dataset.val];
      el.textContent = v === undefined ? "-" : shown(v);
    }
    for (const tr of $$("#par-table tr[data-name]")) markChanged(tr, S.changed.has(tr.dataset.name));
    $("#par-status").textContent = `${motorName(id)}: ${Object.keys(r.values).length} values read ${new Date().toLocaleTimeString()}; ${S.changed.size} changed this session`;
    $("#par-status").title = CHANGED_TIP;
  }
  on("#par-read", readParams);
  on("#par-motor", readParams, "change");
  setInterval(() => { if ($("#par-live").checked && !$("#view-params").hidden) readParams().catch(() => {}); }, 2000);
  on("#par-table", async (e) => {
    const b = e.target.closest("button[data-set]");
    if (!b) return;
    const name = b.dataset.set, input = $(`#par-table input[data-name="${name}"]`);
    const p = S.paramByName[name], v = Number(input.value);
    const forceBox = $(`#par-table input[data-force="${name}"]`), force = Boolean(forceBox && forceBox.checked);
    if (input.value === "" || !Number.isFinite(v)) { say(`${name}: ${input.value || "(empty)"} is not a valid value`); return; }
    if (p.domain && !inDomain(p, v) && (p.hard || !force)) {
      say(`${name}=${input.value} is outside its domain: ${p.domain}${p.hard ? "" : "; tick force to write it anyway"}`);
      return;
    }
    const r = await act("write", { id: parId(), name, value: v, force });
    if (forceBox) forceBox.checked = false;
    if (r.limits) { S.cards[r.id] = Object.assign(S.cards[r.id] || { id: r.id }, { limits: r.limits }); applyLimits(); }
    $(`#par-table span[data-val="${name}"]`).textContent = shown(r.value);
    say(`${motorName(r.id)}: ${name} = ${shown(r.value)} (read back)`, true);
    if (r.changed) S.changed.add(name); else S.changed.delete(name);
    markChanged($(`#par-table tr[data-name="${name}"]`), r.changed);
    $("#par-status").textContent = `${motorName(r.id)}: ${name} written; ${S.changed.size} changed this session`;
  });
  $("#par-filter").addEventListener("input", (e) => {
    const f = e.target.value.toLowerCase();
    let group = null, any = false;
    for (const tr of $$("#par-table tbody tr")) {
      if (tr.classList.contains("group")) {
        if (group) group.hidden = !any;
        group = tr; any = false;
      } else {
        tr.hidden = Boolean(f) && !tr.dataset.name.toLowerCase().includes(f);
        any = any || !tr.hidden;
      }
    }
    if (group) group.hidden = !any;
  });
  on("#par-save", async () => { await act("save", { id: parId() }, `${motorName(parId())}: saved to flash`); readParams(); });
  on("#par-backup", async () => {
    const doc = await act("backup", { id: parId() });
    download(`drempower-motor${parId()}-backup.json`, JSON.stringify(doc, null, 1) + "\n", "application/json");
  });
  on("#par-restore", async (e) => {
    const f = e.target.files[0];
    if (!f) return;
    let doc;
    try { doc = JSON.parse(await f.text()); } catch (err) { say(`${f.name}: not JSON (${err.message})`); return; }
    e.target.value = "";
    const id = parId();
    const r = await act("restore", { id, doc, dry_run: true });
    const box = $("#par-diff");
    box.hidden = false;
    if (!r.diff.length) { box.innerHTML = `${f.name}: ${motorName(id)} already holds these values. <button id="diff-close">Close</button>`; }
    else {
      box.innerHTML = `<b>${f.name}: ${r.diff.length} parameter(s) of ${motorName(id)} would change</b>
        <table><tr><th>name</th><th>now</th><th>backup</th></tr>${r.diff.map((d) => `<tr><td>${d[0]}</td><td>${shown(d[1])}</td><td>${shown(d[2])}</td></tr>`).join("")}</table>
        <button id="diff-write">Write them</button> <button id="diff-close">Cancel</button>`;
      on("#diff-write", async () => {
        const w = await act("restore", { id, doc, dry_run: false });
        box.hidden = true;
        say(`${motorName(id)}: ${w.diff.length} parameter(s) written${w.failed.length ? ", failed: " + w.failed.map((x) => x[0]).join(", ") : ""}`, !w.failed.length);
        readParams();
      });
    }
    on("#diff-close", () => { box.hidden = true; });
  }, "change");

  // ------------------------------------------------------------ tuning
  const GAINS = {
    position: ["axis0.controller.config.pos_gain", "axis0.controller.config.vel_gain",
      "axis0.controller.config.vel_integrator_gain", "axis0.controller.config.input_filter_bandwidth"],
    velocity: ["axis0.controller.config.vel_gain", "axis0.controller.config.vel_integrator_gain"],
  };
  let tunPlot = null;
  async function loadGains() {
    if (!S.motors.length) return;
    const mode = $("#tun-mode").value, id = Number($("#tun-motor").value), seq = ++S.gainsSeq;
    const r = await act("params", { id });
    if (seq !== S.gainsSeq) return; // a later load (another motor or mode) owns the box
    $("#tun-gains").dataset.motor = String(id);
    $("#tun-gains").innerHTML = GAINS[mode].map((n) =>
      `<label>${n.split(".").pop()} <input type="number" step="any" data-gain="${n}" value="${+Number(r.values[n]).toPrecision(6)}" size="8"></label>`).join("") +
      ' <button id="tun-apply">Write gains</button>';
    lockReadOnly();
    on("#tun-apply", async () => {
      for (const el of $$("#tun-gains input[data-gain]")) {
        const w = await act("write", { id, name: el.dataset.gain, value: Number(el.value) });
        el.value = w.value;
      }
      say(`${motorName(id)}: gains written and read back`, true);
    });
  }
  const UNIT = { position: "deg", velocity: "r/min" };
  function tunUnits() {
    const id = Number($("#tun-motor").value);
    $("#tun-amp-label").textContent = `amplitude ${UNIT[$("#tun-mode").value]}${unitsWord(id)}`;
    $("#tun-units").textContent = unitsText(id) ? ` (units: ${unitsText(id)})` : "";
  }
  setInterval(tunUnits, 500);  // the names (and so the units) may arrive after the motor is chosen
  on("#tun-mode", () => { tunUnits(); return loadGains(); }, "change");
  on("#tun-motor", () => { tunUnits(); return loadGains(); }, "change");
  on("#tun-run", async () => {
    const gains = $$("#tun-gains input[data-gain]").map((e) => `${e.dataset.gain.split(".").pop()}=${e.value}`).join(" ");
    say("running step...", true);
    const args = { id: Number($("#tun-motor").value), mode: $("#tun-mode").value,
      amplitude: num("#tun-amp"), duration: num("#tun-dur") };
    // the position step runs with the filter bandwidth the gains box shows
    const bw = $('#tun-gains input[data-gain$="input_filter_bandwidth"]');
    if (args.mode === "position" && bw) args.bandwidth = Number(bw.value);
    const r = await act("step", args);
    r.gains = gains; r.n = S.runs.length + 1;
    S.runs.push(r);
    const f = r.figures;
    $("#tun-runs tbody").insertAdjacentHTML("beforeend", `<tr><td>${r.n}</td><td>${r.mode}</td>
      <td>${fmt(r.base, 2)} &rarr; ${fmt(r.target, 2)} ${UNIT[r.mode]}${r.units === "joint" ? " at the joint" : ""}</td><td>${fmt(f.rise_s, 3)}</td><td>${fmt(f.overshoot_pct, 1)}</td>
      <td>${fmt(f.settling_s, 3)}</td><td>${fmt(f.steady_error, 3)}</td><td>${gains}</td></tr>`);
    say(`step run ${r.n}: rise ${fmt(f.rise_s, 3)} s, overshoot ${fmt(f.overshoot_pct, 1)} %`, true);
    drawRuns();
  });
  on("#tun-clear", () => { S.runs = []; $("#tun-runs tbody").innerHTML = ""; drawRuns(); });
  setupPropose();
  // "Propose gains": identify the joint and step it (asked first: it moves), show the proposal beside the
  // step with the present gains; the gains are written only when the user confirms, then a step after
  function setupPropose() {
    let proposal = null;
    function row(what, g, st) {
      const cells = [what].concat(g ? [fmt(g.pos_gain, 4), fmt(g.vel_gain, 4), fmt(g.vel_integrator_gain, 4), fmt(g.bandwidth, 1)] : ["", "", "", ""])
        .concat(st ? [fmt(st.rise, 3), fmt(st.overshoot === null ? null : st.overshoot * 100, 1), st.settling === null ? "never" : fmt(st.settling, 3)] : ["", "", ""]);
      const tr = document.createElement("tr");
      for (const c of cells) { const td = document.createElement("td"); td.textContent = c; tr.appendChild(td); }
      $("#prop-table tbody").appendChild(tr);
    }
    on("#prop-run", async () => {
      const id = Number($("#tun-motor").value), bandwidth = num("#prop-bw");
      if (!window.confirm(`Propose gains for ${motorName(id)}: it is excited around where it is (about 0.3 rad either way for 6 s) and stepped by 0.15 rad. Continue?`)) return;
      $("#prop-write").disabled = true;
      say("identifying and stepping...", true);
      proposal = await act("propose", { id, bandwidth });
      const p = proposal, k = p.identified;
      $("#prop-what").textContent = `${p.joint} at ${p.bandwidth} Hz: inertia ${fmt(k.inertia, 5)} kg m^2, viscous ${fmt(k.viscous, 4)} Nm s/rad, Coulomb ${fmt(k.coulomb, 4)} Nm, fit R^2 ${fmt(k.fit, 4)}`;
      $("#prop-table tbody").replaceChildren();
      row("present gains (step)", null, p.before);
      row("proposed", p.gains, null);
      $("#prop-table").hidden = false;
      $("#prop-write").disabled = S.readOnly;
      say("gains proposed; nothing written", true);
    });
    on("#prop-write", async () => {
      if (!proposal) return;
      if (!window.confirm(`Write the proposed gains to ${motorName(proposal.id)} (in RAM) and step it again?`)) return;
      const r = await act("apply_gains", { id: proposal.id, bandwidth: proposal.bandwidth });
      proposal = null;
      $("#prop-write").disabled = true;
      $("#prop-table tbody").lastChild.remove();
      row("written (step after)", r.gains, r.after);
      say("proposed gains written; Save stores them in flash", true);
      await loadGains();
    });
  }
  // where the runs of a mode are at a joint, the axis says so
  function unitsNote(m) {
    const u = new Set(S.runs.filter((r) => r.mode === m).map((r) => r.units));
    if (!u.has("joint")) return ""; // bare motors: the motor's own units, as ever
    return u.size === 1 ? " at the joint" : " (joints at the joint, motors at the motor)";
  }
  function drawRuns() {
    const el = $("#tun-plot");
    if (tunPlot) { tunPlot.destroy(); tunPlot = null; }
    if (!S.runs.length || $("#view-tuning").hidden) return;
    // each run relative to its start: position runs in deg (left axis), velocity runs in r/min (right)
    const tables = S.runs.map((r) => [r.t, r.y.map((v) => v - r.base), r.t.map(() => r.target - r.base)]);
    const data = uPlot.join(tables);
    const ser = [{ label: "t / s" }];
    S.runs.forEach((r, k) => {
      const scale = UNIT[r.mode];
      ser.push({ label: `run ${r.n} actual`, scale, stroke: COLORS[k % COLORS.length], spanGaps: true, points: { show: false } });
      ser.push({ label: `run ${r.n} target`, scale, stroke: COLORS[k % COLORS.length], dash: [6, 4], spanGaps: true, points: { show: false } });
    });
    const modes = ["position", "velocity"].filter((m) => S.runs.some((r) => r.mode === m));
    const axes = [{ label: "t / s" }].concat(modes.map((m, k) => ({ scale: UNIT[m], side: k ? 1 : 3,
      label: (m === "position" ? "angle change from start / deg" : "speed change from start / r/min") + unitsNote(m), grid: { show: k === 0 } })));
    tunPlot = new uPlot({ width: Math.max(400, el.clientWidth || 800), height: 320, scales: { x: { time: false } },
      axes, series: ser }, data, el);
    window.dashStats.tuningAxes = axes.slice(1).map((a) => a.label);
  }

  connect();
})();
