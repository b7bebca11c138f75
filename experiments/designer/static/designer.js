// pdmkit designer: the page. Every computation happens on the server; this draws.
"use strict";

const TOKEN = document.querySelector('meta[name="designer-token"]').content;
const PALETTE = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b",
  "#e377c2", "#7f7f7f", "#bcbd22", "#17becf", "#393b79", "#e7969c", "#637939",
  "#ad494a", "#6b6ecf", "#8ca252", "#bd9e39", "#a55194", "#31a354", "#de9ed6"];
const PAGE = 100;
const $ = (id) => document.getElementById(id);
const state = { info: null, offset: 0, filter: {}, picked: new Set(), features: [],
  ranking: null, colours: {} };

// ------------------------------------------------------------------ talking to the server
function say(text, kind) {
  const el = $("status");
  el.textContent = text || "";
  el.className = kind || "";
}

async function api(path, body, raw) {
  const opts = { method: body === undefined ? "GET" : "POST",
    headers: { "x-designer-token": TOKEN } };
  if (body !== undefined) {
    opts.headers["content-type"] = "application/json";
    opts.body = typeof body === "string" ? body : JSON.stringify(body);
  }
  const res = await fetch(path, opts);
  if (!res.ok) {
    let msg = res.statusText;
    try { msg = (await res.json()).error || msg; } catch (e) { /* not JSON */ }
    throw new Error(msg);
  }
  return raw ? res : res.json();
}

function guarded(fn) {
  return async (...args) => {
    try { await fn(...args); } catch (err) { say("error: " + err.message, "error"); }
  };
}

async function runJob(kind, body, bar, message) {
  say(`${kind}: running…`, "busy");
  let job = await api(`/api/run/${kind}`, body);
  while (job.state === "running") {
    await new Promise((r) => setTimeout(r, 200));
    job = await api(`/api/job/${job.id}`);
    if (bar) bar.value = job.fraction || 0;
    if (message) message.textContent = job.message || "";
  }
  if (job.state === "failed") throw new Error(job.error);
  if (bar) bar.value = 1;
  say(`${kind}: done in ${job.seconds.toFixed(1)} s`);
  return job.result;
}

function colour(name) {
  if (!(name in state.colours)) {
    state.colours[name] = PALETTE[Object.keys(state.colours).length % PALETTE.length];
  }
  return state.colours[name];
}

function fillSelect(el, values, chosen) {
  el.innerHTML = "";
  for (const v of values) {
    const o = document.createElement("option");
    o.value = v; o.textContent = v;
    if (v === chosen) o.selected = true;
    el.appendChild(o);
  }
}

const layoutBase = { margin: { l: 60, r: 20, t: 36, b: 45 }, legend: { orientation: "v" },
  font: { size: 12 }, title: { x: 0, xanchor: "left" } };
const plotConfig = { responsive: true, displaylogo: false, displayModeBar: "hover" };
const titled = (text) => ({ text, font: { size: 13 }, x: 0.01, xanchor: "left" });

// ------------------------------------------------------------------ step 1: data
function buildFilters() {
  const box = $("filters");
  box.innerHTML = "";
  for (const c of state.info.conditions) {
    if (!c.levels || c.levels.length < 2 || (c.numeric && c.levels.length > 12)) continue;
    const label = document.createElement("label");
    label.textContent = c.name;
    const sel = document.createElement("select");
    sel.multiple = true; sel.size = Math.min(4, c.levels.length); sel.dataset.column = c.name;
    fillSelect(sel, c.levels);
    for (const o of sel.options) o.selected = (state.filter[c.name] || []).includes(o.value);
    label.appendChild(sel);
    box.appendChild(label);
  }
}

function readFilter() {
  const filter = {};
  for (const sel of document.querySelectorAll("#filters select")) {
    const picked = [...sel.selectedOptions].map((o) => o.value);
    if (picked.length) filter[sel.dataset.column] = picked;
  }
  return filter;
}

async function loadMembers() {
  const res = await api("/api/members", { filter: state.filter, offset: state.offset, limit: PAGE });
  const cols = ["member", ...state.info.conditions.map((c) => c.name)];
  const thead = $("members").tHead, tbody = $("members").tBodies[0];
  thead.innerHTML = "<tr><th></th>" + cols.map((c) => `<th>${escapeHtml(c)}</th>`).join("") + "</tr>";
  tbody.innerHTML = "";
  for (const row of res.rows) {
    const tr = document.createElement("tr");
    const box = document.createElement("input");
    box.type = "checkbox"; box.checked = state.picked.has(row.member);
    box.addEventListener("change", () => {
      if (box.checked) state.picked.add(row.member); else state.picked.delete(row.member);
      tr.classList.toggle("picked", box.checked);
    });
    const td = document.createElement("td"); td.appendChild(box); tr.appendChild(td);
    tr.classList.toggle("picked", box.checked);
    for (const c of cols) {
      const cell = document.createElement("td");
      const v = row[c];
      cell.textContent = typeof v === "number" && !Number.isInteger(v) ? v.toPrecision(4) : v;
      tr.appendChild(cell);
    }
    tbody.appendChild(tr);
  }
  $("member-count").textContent = `${res.total} of ${state.info.n_members} members`;
  const last = Math.min(res.total, state.offset + PAGE);
  $("page-info").textContent = res.total ? `${state.offset + 1}–${last}` : "none";
  $("prev-page").disabled = state.offset === 0;
  $("next-page").disabled = last >= res.total;
}

function escapeHtml(s) {
  return String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" }[c]));
}

async function plotSignals(members) {
  const body = { signal: $("plot-signal").value, by: $("plot-by").value || null,
    kind: $("plot-kind").value, filter: state.filter, members: members || [],
    per_class: Number($("per-class").value) || 1 };
  const res = await api("/api/plot", body);
  const seen = new Set();
  const traces = res.traces.map((t) => {
    const group = t.group === null ? t.member : t.group;
    const first = !seen.has(group); seen.add(group);
    return { x: t.x, y: t.y, type: "scattergl", mode: "lines", name: group,
      legendgroup: group, showlegend: first, line: { width: 1, color: colour(group) },
      hovertemplate: `${escapeHtml(t.member)}<br>%{x:.4g}, %{y:.4g}<extra>${escapeHtml(group)}</extra>` };
  });
  const layout = { ...layoutBase, xaxis: { title: { text: res.x_label } },
    yaxis: { title: { text: res.y_label }, type: body.kind === "spectrum" ? "log" : "linear" },
    title: titled(`${res.signal} of ${res.traces.length} members, coloured by ${body.by || "member"}`) };
  await Plotly.react("plot-signals", traces, layout, plotConfig);
  $("plot-note").textContent = res.decimated
    ? "Long traces are drawn decimated (min/max of each bucket, about 2000 points per trace); the samples stay on the server."
    : "";
  if (!window.designerFirstPlotMs) {
    window.designerFirstPlotMs = performance.now();
    document.body.dataset.firstPlot = String(window.designerFirstPlotMs);
  }
}

// ------------------------------------------------------------------ step 2: indicators
function buildIndicatorForm() {
  const info = state.info;
  const conds = info.conditions.map((c) => c.name);
  fillSelect($("label"), conds, info.label);
  const boxes = (el, names, chosen, cls) => {
    el.innerHTML = "";
    for (const n of names) {
      const l = document.createElement("label");
      l.innerHTML = `<input type="checkbox" class="${cls}" value="${escapeHtml(n)}"${chosen.includes(n) ? " checked" : ""}> ${escapeHtml(n)}`;
      el.appendChild(l);
    }
  };
  const ind = info.steps.indicators;
  boxes($("signal-boxes"), info.signals.map((s) => s.name), ind ? ind.signals : info.defaults.signals, "sig");
  boxes($("group-boxes"), info.groups, ind ? ind.groups : info.defaults.groups, "grp");
  $("options").value = ind ? ind.options : info.defaults.options;
  if (ind) document.querySelector(`input[name=scope][value=${ind.scope}]`).checked = true;
}

async function compute() {
  const body = {
    signals: [...document.querySelectorAll(".sig:checked")].map((b) => b.value),
    groups: [...document.querySelectorAll(".grp:checked")].map((b) => b.value),
    options: $("options").value,
    scope: document.querySelector("input[name=scope]:checked").value,
    filter: state.filter,
  };
  $("compute").disabled = true;
  try {
    const res = await runJob("features", body, $("features-progress"), $("features-message"));
    $("features-message").textContent = `${res.n_members} members × ${res.n_features} indicators`;
    setFeatures(res.features);
    await drawHistogram(); await drawScatter();
  } finally { $("compute").disabled = false; }
}

function setFeatures(features) {
  state.features = features;
  fillSelect($("hist-feature"), features, features[0]);
  fillSelect($("scatter-x"), features, features[0]);
  fillSelect($("scatter-y"), features, features[1] || features[0]);
  fillSelect($("hand-features"), features);
}

async function drawHistogram() {
  const col = $("hist-feature").value;
  if (!col) return;
  const res = await api("/api/values", { columns: [col], by: $("label").value });
  const violin = $("hist-kind").value === "violin";
  const traces = res.groups.map((g) => violin
    ? { type: "violin", y: g.values[0], name: g.name, box: { visible: true }, meanline: { visible: true },
        line: { color: colour(g.name) }, points: false }
    : { type: "histogram", x: g.values[0], name: `${g.name} (${g.n})`, opacity: 0.6,
        marker: { color: colour(g.name) }, nbinsx: 40 });
  const layout = { ...layoutBase, barmode: "overlay", title: titled(`${col} by ${res.by}`),
    xaxis: { title: { text: violin ? res.by : col } }, yaxis: { title: { text: violin ? col : "members" } } };
  await Plotly.react("plot-hist", traces, layout, plotConfig);
}

async function drawScatter() {
  const x = $("scatter-x").value, y = $("scatter-y").value;
  if (!x || !y) return;
  const res = await api("/api/values", { columns: [x, y], by: $("label").value });
  const traces = res.groups.map((g) => ({ type: "scattergl", mode: "markers", x: g.values[0], y: g.values[1],
    name: g.name, text: g.members, marker: { color: colour(g.name), size: 6, opacity: 0.75 } }));
  const layout = { ...layoutBase, xaxis: { title: { text: x } }, yaxis: { title: { text: y } },
    title: titled(`scatter by ${res.by}`) };
  await Plotly.react("plot-scatter", traces, layout, plotConfig);
}

// ------------------------------------------------------------------ step 3: rank and train
async function rank() {
  const body = { method: $("rank-method").value, unit: $("rank-unit").value || null,
    order: $("rank-order").value || null };
  const res = await runJob("rank", body);
  drawRanking(res.ranking, res.method);
}

function drawRanking(rows, method) {
  state.ranking = rows;
  const top = rows.slice(0, 20).reverse();
  const trace = { type: "bar", orientation: "h", x: top.map((r) => r.score), y: top.map((r) => r.feature),
    marker: { color: "#2a6fdb" } };
  const layout = { ...layoutBase, margin: { l: 260, r: 20, t: 30, b: 40 },
    title: titled(`top ${top.length} indicators by ${method || rows[0].method}`),
    xaxis: { title: { text: "score" } } };
  Plotly.react("plot-rank", [trace], layout, plotConfig);
  fillSelect($("hand-features"), rows.map((r) => r.feature));
}

async function train() {
  const body = { selection: $("selection").value, top_k: Number($("top-k").value),
    features: [...$("hand-features").selectedOptions].map((o) => o.value),
    model: $("model").value, test_size: Number($("test-size").value), seed: Number($("seed").value) };
  $("train").disabled = true;
  try {
    const res = await runJob("train", body, $("train-progress"));
    showTraining(res);
  } finally { $("train").disabled = false; }
}

function pct(v) { return v === null || v === undefined ? "–" : (100 * v).toFixed(2) + " %"; }

function showTraining(res) {
  const cv = res.cv_accuracy === null ? "" : ` · cross-validated ${pct(res.cv_accuracy)} ± ${pct(res.cv_accuracy_std)}`;
  $("train-result").innerHTML = `${escapeHtml(res.model)}: held-out accuracy <b id="accuracy" data-accuracy="${res.accuracy}">${pct(res.accuracy)}</b>`
    + ` on ${res.n_test} members (trained on ${res.n_train})${cv}`
    + (res.split ? `<br><span id="split-kind">${escapeHtml(res.split.kind)} split: it measures ${escapeHtml(res.split.measures)}</span>` : "")
    + `<br><span class="muted">indicators: ${res.features.map(escapeHtml).join(", ")}</span>`
    + (res.notes.length ? `<br><span class="muted">${res.notes.map(escapeHtml).join("; ")}</span>` : "");
  const counts = res.confusion;
  const z = counts.map((row) => { const n = row.reduce((a, b) => a + b, 0) || 1; return row.map((v) => v / n); });
  const text = counts.map((row) => row.map(String));
  const trace = { type: "heatmap", z, x: res.labels, y: res.labels, text, texttemplate: "%{text}",
    zmin: 0, zmax: 1, colorscale: [[0, "#f7fbff"], [0.5, "#9ecae1"], [1, "#4292c6"]], showscale: false,
    hovertemplate: "true %{y}<br>predicted %{x}<br>%{text} members<extra></extra>" };
  const longest = Math.max(...res.labels.map((l) => String(l).length));
  const plot = $("plot-confusion");
  plot.style.height = `${Math.max(420, 26 * res.labels.length + 40 + 7 * longest)}px`;
  const layout = { ...layoutBase, margin: { l: 20 + 7 * longest, r: 20, t: 30, b: 20 + 7 * longest },
    title: titled("confusion matrix (held-out members; shade: share of the true class)"),
    xaxis: { title: { text: "predicted" } }, yaxis: { title: { text: "true" }, autorange: "reversed" } };
  Plotly.react("plot-confusion", [trace], layout, plotConfig);
}

async function compareSensors() {
  const body = { model: $("model").value, top_k: Number($("top-k").value), costs: $("costs").value };
  const res = await runJob("sensors", body);
  showSensors(res.sensors);
}

function showSensors(rows) {
  const cols = ["sensor", "accuracy", "accuracy_std", "cost", "n_members", "pareto", "note"];
  $("sensor-table").tHead.innerHTML = "<tr>" + cols.map((c) => `<th>${c}</th>`).join("") + "</tr>";
  $("sensor-table").tBodies[0].innerHTML = rows.map((r) => "<tr>" + cols.map((c) => {
    const v = r[c];
    return `<td>${typeof v === "number" && !Number.isInteger(v) ? v.toFixed(4) : escapeHtml(v ?? "")}</td>`;
  }).join("") + "</tr>").join("");
  const priced = rows.filter((r) => r.cost !== null);
  const trace = { type: "scatter", mode: "markers+text", x: priced.map((r) => r.cost),
    y: priced.map((r) => r.accuracy), text: priced.map((r) => r.sensor), textposition: "top center",
    marker: { size: 10, color: priced.map((r) => (r.pareto ? "#d62728" : "#1f77b4")) } };
  const layout = { ...layoutBase, xaxis: { title: { text: "cost" } }, yaxis: { title: { text: "accuracy (CV)" } },
    title: titled(priced.length ? "accuracy against cost (red: Pareto front)" : "no costs given: see the table") };
  Plotly.react("plot-sensors", [trace], layout, plotConfig);
}

// ------------------------------------------------------------------ step 4: export
async function loadExport() {
  const res = await api("/api/export");
  $("commands").textContent = res.commands.length ? res.commands.join("\n\n") : "(nothing yet)";
  $("export-notes").innerHTML = res.notes.map((n) => `<li>${escapeHtml(n)}</li>`).join("");
  $("script").textContent = res.script;
}

async function download(path, name) {
  const res = await api(path, undefined, true);
  const blob = await res.blob();
  const a = document.createElement("a");
  a.href = URL.createObjectURL(blob); a.download = name;
  document.body.appendChild(a); a.click(); a.remove();
}

async function openProject(file) {
  if (file.size > 1 << 20) throw new Error(`${file.name} is larger than 1 MiB; not a designer project`);
  const text = await file.text();
  say("opening project…", "busy");
  let job = await api("/api/project", text);
  while (job.state === "running") {
    await new Promise((r) => setTimeout(r, 250));
    job = await api(`/api/job/${job.id}`);
    say(`opening project: ${job.message || "…"}`, "busy");
  }
  if (job.state === "failed") throw new Error(job.error);
  await refresh();
  say(`project opened: ${job.result.replayed.join(", ") || "no steps"} repeated`);
}

// ------------------------------------------------------------------ history (pdmkit monitor)
const HISTORY_PAGE = 50;
const HISTORY_COLUMNS = [["unit", "unit"], ["rows", "rows"], ["first_alarm", "first alarm"],
  ["health_index_at_alarm", "HI at alarm"], ["drivers_at_alarm", "drivers at alarm"],
  ["last_health_index", "last HI"]];
const monitor = { offset: 0, unit: null, timer: null, busy: false };

function cellText(v) {
  if (v === null || v === undefined) return "";
  return typeof v === "number" && !Number.isInteger(v) ? String(Number(v.toPrecision(3))) : String(v);
}

function boundText(v) { return v === null ? "open" : String(Number(v.toPrecision(4))); }

async function loadHistory() {
  if (monitor.busy) return;
  monitor.busy = true;
  try {
    const q = new URLSearchParams({ offset: monitor.offset, limit: HISTORY_PAGE,
      alarmed: $("history-alarmed").checked ? "1" : "", contains: $("history-filter").value });
    const res = await api(`/api/history?${q}`);
    const withRul = Object.keys(res.last_rul).length > 0;
    $("history-units").tHead.innerHTML = "<tr>" + HISTORY_COLUMNS.map((c) => `<th>${c[1]}</th>`).join("")
      + (withRul ? "<th>last RUL [interval]</th>" : "") + "</tr>";
    const tbody = $("history-units").tBodies[0];
    tbody.innerHTML = "";
    for (const row of res.rows) {
      const tr = document.createElement("tr");
      tr.dataset.unit = row.unit;
      tr.classList.toggle("alarmed", row.first_alarm !== "");
      tr.classList.toggle("picked", row.unit === monitor.unit);
      for (const [key] of HISTORY_COLUMNS) {
        const td = document.createElement("td"); td.textContent = cellText(row[key]); tr.appendChild(td);
      }
      if (withRul) {
        const r = res.last_rul[row.unit], td = document.createElement("td");
        td.textContent = r ? `${cellText(r.rul)} [${r.lower === null ? "open" : cellText(r.lower)}, ${r.upper === null ? "open" : cellText(r.upper)}]` : "";
        tr.appendChild(td);
      }
      tr.addEventListener("click", guarded(() => drawUnit(row.unit)));
      tbody.appendChild(tr);
    }
    $("history-count").textContent = `${res.n_alarmed} of ${res.n_units} units alarmed · ${res.history} read at ${new Date().toLocaleTimeString()}`;
    const last = Math.min(res.total, monitor.offset + HISTORY_PAGE);
    $("history-page").textContent = res.total ? `${monitor.offset + 1}–${last} of ${res.total}` : "none";
    $("history-prev").disabled = monitor.offset === 0;
    $("history-next").disabled = last >= res.total;
    if (!monitor.unit && res.rows.length) monitor.unit = res.rows[0].unit;  // the first alarm
    if (monitor.unit) await drawUnit(monitor.unit);
  } finally { monitor.busy = false; }
}

async function drawUnit(unit) {
  const s = await api(`/api/history/unit?unit=${encodeURIComponent(unit)}`);
  monitor.unit = unit;
  for (const tr of $("history-units").tBodies[0].rows) tr.classList.toggle("picked", tr.dataset.unit === unit);
  const fa = s.first_alarm;
  const custom = s.time_text.map((t, i) => [t, s.score[i] === null ? "–" : s.score[i].toPrecision(4), s.drivers[i] || "–"]);
  const traces = [{ x: s.x, y: s.health_index, type: "scatter", mode: "lines", name: "health index",
    line: { width: 1.2, color: "#1f77b4" }, customdata: custom,
    hovertemplate: "%{customdata[0]}<br>health index %{y:.3f}<br>score %{customdata[1]}<br>drivers: %{customdata[2]}<extra></extra>" }];
  const shapes = [{ type: "line", xref: "paper", x0: 0, x1: 1, y0: s.threshold, y1: s.threshold,
    line: { color: "#333", width: 1, dash: "dash" } }];
  if (fa) {
    shapes.push({ type: "rect", xref: "x", yref: "paper", x0: fa.x, x1: s.x_end, y0: 0, y1: 1,
      fillcolor: "#d62728", opacity: 0.12, line: { width: 0 }, layer: "below" });
    traces.push({ x: [fa.x], y: [fa.health_index], type: "scatter", mode: "markers", name: "first alarm",
      marker: { color: "#d62728", size: 9, symbol: "diamond" },
      hovertemplate: `first alarm ${escapeHtml(fa.time_text)}<br>health index %{y:.3f}<br>drivers: ${escapeHtml(fa.drivers || "–")}<extra></extra>` });
  }
  const date = s.x_kind === "date";
  const layout = { ...layoutBase, shapes, showlegend: false,
    title: titled(`${unit}: health index` + (fa ? `, alarm since ${fa.time_text}` : ", no alarm")),
    xaxis: { type: date ? "date" : "linear", title: { text: s.x_label }, range: [s.x[0], s.x_end] },
    yaxis: { title: { text: "health index (1 = healthy)" }, range: [-0.02, 1.05] },
    annotations: [{ xref: "paper", x: 1, y: s.threshold, yanchor: "bottom", xanchor: "right",
      text: "alarm threshold (0.5)", showarrow: false, font: { size: 11, color: "#333" } }] };
  await Plotly.react("plot-health", traces, layout, plotConfig);
  $("plot-health").dataset.unit = unit;
  $("health-note").textContent = `${s.n_rows} rows` + (s.decimated
    ? `, ${s.n_points} drawn (min/max of each bucket, every alarm change kept)` : "")
    + (fa ? `; shaded: in alarm from the first alarm on` : "");
  await drawRul(unit, s.rul, date, [s.x[0], s.x_end], fa);
}

async function drawRul(unit, r, date, range, fa) {
  $("plot-rul").hidden = !r;
  if (!r) {
    Plotly.purge("plot-rul");
    $("rul-note").textContent = "No RUL estimates for this unit (no RUL model attached to the history).";
    return;
  }
  const finite = [...r.rul, ...r.lower, ...r.upper].filter((v) => v !== null);
  const top = 1.15 * Math.max(0, ...finite) || 1, bottom = Math.min(0, ...finite);
  const level = r.level.find((v) => v !== null);
  const band = level ? `${Math.round(100 * level)} % interval` : "interval";
  const custom = r.time_text.map((t, i) => [t, boundText(r.lower[i]), boundText(r.upper[i]), r.note[i]]);
  const traces = [
    { x: r.x, y: r.lower.map((v) => (v === null ? bottom : v)), type: "scatter", mode: "lines",
      line: { width: 0 }, showlegend: false, hoverinfo: "skip" },
    { x: r.x, y: r.upper.map((v) => (v === null ? top : v)), type: "scatter", mode: "lines",
      fill: "tonexty", fillcolor: "rgba(42,111,219,0.18)", line: { width: 0 }, name: band, hoverinfo: "skip" },
    { x: r.x, y: r.rul, type: "scatter", mode: "lines+markers", name: "RUL", line: { color: "#2a6fdb" },
      cliponaxis: false,
      customdata: custom, hovertemplate: "%{customdata[0]}<br>RUL %{y:.4g}<br>interval %{customdata[1]} … %{customdata[2]}<br>%{customdata[3]}<extra></extra>" }];
  const shapes = fa ? [{ type: "line", xref: "x", yref: "paper", x0: fa.x, x1: fa.x, y0: 0, y1: 1,
    line: { color: "#d62728", width: 1 } }] : [];
  const layout = { ...layoutBase, shapes, showlegend: false,
    title: titled(`${unit}: remaining useful life (line) and its ${band} (shaded)`),
    xaxis: { type: date ? "date" : "linear", title: { text: r.x_label }, range },
    yaxis: { title: { text: "RUL (the RUL model's time unit)" }, range: [bottom, top] } };
  await Plotly.react("plot-rul", traces, layout, plotConfig);
  $("rul-note").textContent = `${r.n_rows} estimates, one after each scored file`
    + (fa ? "; red line: the first alarm" : "") + ". An open bound (none computed) is drawn to the chart's edge.";
}

function showHistoryOnly(info) {
  for (const tab of ["data", "indicators", "train", "export"]) $(`tab-${tab}`).hidden = true;
  $("save-project").hidden = true;
  $("open-project").parentElement.hidden = true;
  $("source").textContent = `monitoring history ${info.history} (read-only)`;
  say("Units by alarm, the earliest first; click a unit to draw its health index over time.");
  switchTab("history");
}

function wireHistory() {
  const reload = guarded(async () => { monitor.offset = 0; await loadHistory(); });
  $("history-refresh").addEventListener("click", guarded(loadHistory));
  $("history-alarmed").addEventListener("change", reload);
  $("history-filter").addEventListener("change", reload);
  $("history-prev").addEventListener("click", guarded(async () => { monitor.offset = Math.max(0, monitor.offset - HISTORY_PAGE); await loadHistory(); }));
  $("history-next").addEventListener("click", guarded(async () => { monitor.offset += HISTORY_PAGE; await loadHistory(); }));
  $("history-auto").addEventListener("change", () => {
    clearInterval(monitor.timer);
    monitor.timer = $("history-auto").checked ? setInterval(() => {
      if ($("pane-history").classList.contains("active")) guarded(loadHistory)();
    }, 10000) : null;
  });
}

// ------------------------------------------------------------------ start
async function refresh() {
  const info = await api("/api/state");
  state.info = info;
  $("tab-history").hidden = !info.history;
  if (info.kind === null) return info;  // --history alone: no ensemble
  state.filter = info.data.filter || {};
  $("source").textContent = info.source;
  const signals = info.signals.map((s) => s.name);
  fillSelect($("plot-signal"), signals, info.data.signal || signals[0]);
  const levelled = info.conditions.filter((c) => c.levels).map((c) => c.name);
  fillSelect($("plot-by"), levelled, info.data.by || info.label);
  if (info.data.kind) $("plot-kind").value = info.data.kind;
  buildFilters();
  buildIndicatorForm();
  if (info.features.n_features) setFeatures(info.features.features);
  if (info.ranking) drawRanking(info.ranking);
  if (info.train) showTraining(info.train);
  if (info.sensors) showSensors(info.sensors);
  const t = info.steps.train;
  if (t) {
    $("selection").value = t.selection; $("top-k").value = t.top_k; $("model").value = t.model;
    $("test-size").value = t.test_size; $("seed").value = t.seed;
  }
  if (info.kind === "features") {
    $("tab-data").disabled = true; $("compute").disabled = true;
    switchTab("indicators");
    if (info.features.n_features) { await drawHistogram(); await drawScatter(); }
  }
  return info;
}

function switchTab(name) {
  for (const b of document.querySelectorAll(".tab")) b.classList.toggle("active", b.dataset.tab === name);
  for (const p of document.querySelectorAll(".pane")) p.classList.toggle("active", p.id === `pane-${name}`);
  if (name === "export") guarded(loadExport)();
  if (name === "history") guarded(loadHistory)();
  window.dispatchEvent(new Event("resize"));
}

function wire() {
  for (const b of document.querySelectorAll(".tab")) b.addEventListener("click", () => switchTab(b.dataset.tab));
  $("apply-filter").addEventListener("click", guarded(async () => { state.filter = readFilter(); state.offset = 0; await loadMembers(); }));
  $("clear-filter").addEventListener("click", guarded(async () => { state.filter = {}; state.offset = 0; buildFilters(); await loadMembers(); }));
  $("prev-page").addEventListener("click", guarded(async () => { state.offset = Math.max(0, state.offset - PAGE); await loadMembers(); }));
  $("next-page").addEventListener("click", guarded(async () => { state.offset += PAGE; await loadMembers(); }));
  $("plot-classes").addEventListener("click", guarded(() => plotSignals([])));
  $("plot-selected").addEventListener("click", guarded(async () => {
    if (!state.picked.size) throw new Error("tick some members in the table first");
    await plotSignals([...state.picked]);
  }));
  for (const id of ["plot-signal", "plot-by", "plot-kind"]) $(id).addEventListener("change", guarded(() => plotSignals(state.picked.size ? [...state.picked] : [])));
  $("label").addEventListener("change", guarded(async () => { await api("/api/label", { label: $("label").value }); await drawHistogram(); await drawScatter(); }));
  $("compute").addEventListener("click", guarded(compute));
  for (const id of ["hist-feature", "hist-kind"]) $(id).addEventListener("change", guarded(drawHistogram));
  for (const id of ["scatter-x", "scatter-y"]) $(id).addEventListener("change", guarded(drawScatter));
  $("rank-method").addEventListener("change", () => {
    const prog = !["kruskal", "anova"].includes($("rank-method").value);
    for (const el of document.querySelectorAll(".prognostic")) el.classList.toggle("show", prog);
  });
  $("selection").addEventListener("change", () => {
    for (const el of document.querySelectorAll(".hand")) el.classList.toggle("show", $("selection").value === "hand");
  });
  $("rank").addEventListener("click", guarded(rank));
  $("train").addEventListener("click", guarded(train));
  $("sensors").addEventListener("click", guarded(compareSensors));
  $("download-script").addEventListener("click", guarded(async () => {
    const res = await api("/api/export");
    const a = document.createElement("a");
    a.href = URL.createObjectURL(new Blob([res.script], { type: "text/x-python" }));
    a.download = "designer_pipeline.py"; document.body.appendChild(a); a.click(); a.remove();
  }));
  $("download-model").addEventListener("click", guarded(() => download("/api/export/model.pdmkit", "model.pdmkit")));
  const saveProject = guarded(() => download("/api/project", "designer_project.json"));
  $("download-project").addEventListener("click", saveProject);
  $("save-project").addEventListener("click", saveProject);
  $("open-project").addEventListener("change", guarded(async (e) => { if (e.target.files[0]) await openProject(e.target.files[0]); e.target.value = ""; }));
}

wire();
wireHistory();
guarded(async () => {
  const info = await refresh();
  if (info.kind === null) { showHistoryOnly(info); return; }
  if (info.kind !== "features") {
    await Promise.all([loadMembers(), plotSignals([])]);
  }
  if (info.jobs.length) {
    say("repeating the project's steps…", "busy");
    while ((await api("/api/state")).jobs.length) await new Promise((r) => setTimeout(r, 300));
    await refresh();
    say("project re-opened");
  } else if (!$("status").className) {
    say(`${info.source}. Plot signals by condition, then compute indicators (step 2).`);
  }
})();
