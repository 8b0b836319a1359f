// flexhrc operator panel: renders the state pushed over the websocket, posts the operator's
// inputs. No framework, no network beyond this server. Every name from the server is set as
// text (never as HTML).
"use strict";

const TOKEN = new URLSearchParams(location.search).get("token");
const SVGNS = "http://www.w3.org/2000/svg";
const openInstances = new Set([""]);  // instance paths unfolded by the operator
// what the tests and the latency benchmark read: the last state drawn, and when
window.__panel = { version: -1, messages: 0, renderedAt: 0, state: null, log: [] };

function el(tag, attrs, ...children) {
  const e = tag.startsWith("svg:") ? document.createElementNS(SVGNS, tag.slice(4))
                                   : document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) {
    if (v === null || v === undefined || v === false) continue;
    if (k === "onclick") e.addEventListener("click", v);
    else if (k === "text") e.textContent = v;
    else e.setAttribute(k, v === true ? "" : String(v));
  }
  for (const c of children) {
    if (c === null || c === undefined) continue;
    e.append(c instanceof Node ? c : document.createTextNode(String(c)));
  }
  return e;
}

function fmtCost(c) { return c === null || c === undefined ? "–" : (+c).toFixed(Number.isInteger(+c) ? 0 : 2); }

// -- talking to the server --------------------------------------------------------------
async function post(path, body) {
  const headers = { "Content-Type": "application/json" };
  if (TOKEN) headers["Authorization"] = "Bearer " + TOKEN;
  let text = "";
  try {
    const r = await fetch(path, { method: "POST", headers, body: JSON.stringify(body) });
    const data = await r.json().catch(() => ({}));
    if (!r.ok) { say(data.error || ("HTTP " + r.status), true); return null; }
    text = data.already_done ? "already done: " + data.action
         : data.action ? "done: " + data.action : data.take ? "you take " + data.take
         : data.reply ? "you said " + REPLY_TEXT[data.reply]
         : data.stopped ? "stopped " + data.stopped : data.resumed ? "resumed " + data.resumed : "ok";
    say(text, false);
    return data;
  } catch (err) { say("cannot reach the panel: " + err, true); return null; }
}

function say(text, error) {
  const m = document.getElementById("message");
  m.textContent = text; m.hidden = false;
  m.className = "message" + (error ? " error" : "");
}

function connect(delay) {
  const proto = location.protocol === "https:" ? "wss:" : "ws:";
  const url = proto + "//" + location.host + "/ws" + (TOKEN ? "?token=" + encodeURIComponent(TOKEN) : "");
  const ws = new WebSocket(url);
  const link = document.getElementById("link");
  ws.onopen = () => { link.textContent = "live"; link.className = "badge link-up"; delay = 250; };
  ws.onmessage = (ev) => {
    const received = Date.now();
    const t0 = performance.now();
    const state = JSON.parse(ev.data);
    window.__panel.messages += 1;
    render(state);
    const cost = performance.now() - t0;
    window.__panel.version = state.version === undefined ? window.__panel.messages : state.version;
    window.__panel.events = state.events;
    window.__panel.renderedAt = Date.now();
    window.__panel.state = state;
    window.dispatchEvent(new CustomEvent("panel-state", { detail: state }));  // the 3D view
    window.__panel.log.push([state.events, window.__panel.renderedAt, received, cost]);
    if (window.__panel.log.length > 2000) window.__panel.log.shift();
  };
  ws.onclose = () => {
    link.textContent = "offline"; link.className = "badge link-down";
    setTimeout(() => connect(Math.min(delay * 2, 5000)), delay);
  };
}

// -- the two views -----------------------------------------------------------------------
// The operator's view (default) speaks plain words with big buttons; the engineer's view is the
// graph, the knowledge base and the events. `?view=engineer` opens the latter first.
function setView(view) {
  for (const tab of document.querySelectorAll(".tab")) {
    const on = tab.dataset.view === view;
    tab.setAttribute("aria-selected", on ? "true" : "false");
    tab.tabIndex = on ? 0 : -1;
    document.getElementById(tab.getAttribute("aria-controls")).hidden = !on;
  }
  window.__panel.view = view;
}
for (const tab of document.querySelectorAll(".tab")) {
  tab.addEventListener("click", () => setView(tab.dataset.view));
  tab.addEventListener("keydown", (ev) => {  // arrow keys move between tabs (WAI-ARIA tabs)
    if (ev.key !== "ArrowRight" && ev.key !== "ArrowLeft") return;
    const other = document.querySelector(`.tab:not([data-view="${tab.dataset.view}"])`);
    setView(other.dataset.view); other.focus();
  });
}
setView(new URLSearchParams(location.search).get("view") === "engineer" ? "engineer" : "operator");

// The clock runs between events: the cell's time at the last state, advanced by the wall clock
// at the cell's pace (`clock_rate`: simulated seconds per second; 0 when time only jumps).
const clock = { t: 0, at: 0, rate: 0, running: false };
function fmtClock(t) {
  const m = Math.floor(t / 60), sec = Math.floor(t % 60);
  return `${m}:${String(sec).padStart(2, "0")}`;
}
function tickClock() {
  const t = clock.t + (clock.running ? (performance.now() - clock.at) / 1000 * clock.rate : 0);
  document.getElementById("op-clock").textContent = fmtClock(t);
  document.getElementById("clock").textContent = "t = " + t.toFixed(1) + " s";
  window.__panel.clock = t;
}
setInterval(tickClock, 200);

// "your turn": a cue when a step is put to the person (a short tone if they asked for sound)
let turnWas = null;
function cue() {
  if (new URLSearchParams(location.search).get("sound") !== "1") return;
  try {
    const ctx = new AudioContext(), osc = ctx.createOscillator(), gain = ctx.createGain();
    osc.frequency.value = 880; gain.gain.value = 0.1;
    osc.connect(gain).connect(ctx.destination); osc.start(); osc.stop(ctx.currentTime + 0.2);
  } catch (err) { /* no audio here: the visual cue stays */ }
}

function myStep(s) {
  return (s.suggestions || []).find((g) => g.owner === "human" && g.next) || null;
}

function renderOperator(s) {
  const running = s.outcome === "running";
  const step = running ? myStep(s) : null;
  const turn = document.getElementById("turn");
  const key = step ? step.element + "|" + step.next : null;
  turn.dataset.turn = step ? "yours" : "none";
  document.getElementById("turn-title").textContent = step ? "Your turn"
    : running ? "Nothing for you right now" : s.outcome === "solved" ? "All done" : "Stopped";
  document.getElementById("step-text").textContent = step ? (step.next_text || step.next) : "";
  document.getElementById("step-action").textContent = step ? step.next : "";
  const buttons = { "op-done": step ? { action: step.next } : null,
                    "op-start": step ? { reply: "start" } : null,
                    "op-decline": step ? { reply: "decline" } : null,
                    "op-cannot": step ? { reply: "cannot", reason: "said at the panel" } : null,
                    "op-give-back": step ? { reply: "give_back" } : null };
  for (const [id, body] of Object.entries(buttons)) {
    const b = document.getElementById(id);
    b.disabled = !body;
    b.onclick = body ? () => post("/api/human", body) : null;
  }
  if (key && key !== turnWas) cue();
  turnWas = key;
  changed("offers", [running, s.offers], () => {
    const offers = running ? (s.offers || []) : [];
    document.getElementById("op-take").replaceChildren(...offers.map((o) =>
      el("button", { class: "take-big", "data-take": o.element,
        onclick: () => post("/api/human", { take: o.element }) }, "I'll do this: " + o.text)));
  });
  const p = s.progress || { done: 0, todo: 0 };
  const total = p.done + p.todo;
  const bar = document.getElementById("op-progress");
  bar.max = Math.max(total, 1); bar.value = running ? p.done : bar.max;
  document.getElementById("op-progress-text").textContent = running
    ? `${p.done} of ${total} steps done` : `${p.done} steps done`;
  changed("robots", [s.agents, running], () => renderRobots(s, running));
}

function renderRobots(s, running) {
  const robots = (s.agents || []).filter((a) => a.kind === "robot");
  document.getElementById("op-robots").replaceChildren(...robots.map((a) => {
    const now = !a.alive ? "lost" : a.status === "stopped" ? "stopped by you"
      : a.text ? a.text : "waiting";
    let button = null;
    if (a.status === "stopped") {
      button = el("button", { class: "resume", "data-robot": a.name, disabled: !running,
        onclick: () => post("/api/resume", { robot: a.name }) }, "resume");
    } else {
      button = el("button", { class: "stop", "data-robot": a.name, disabled: !running,
        onclick: () => post("/api/stop", { robot: a.name }) }, "stop robot");
    }
    return el("li", { "data-robot": a.name, "data-status": a.status },
      el("span", { class: "robot-name", text: a.name }),
      el("span", { class: "now", text: "now: " + now }),
      a.next_text ? el("span", { class: "next", text: "next: " + a.next_text }) : null,
      button);
  }));
}

// -- rendering ----------------------------------------------------------------------------
function render(s) {
  document.getElementById("cell-name").textContent = s.cell || "";
  const out = document.getElementById("outcome");
  out.textContent = s.outcome; out.dataset.outcome = s.outcome;
  Object.assign(clock, { t: s.time ?? 0, at: performance.now(), rate: +s.clock_rate || 0,
                         running: s.outcome === "running" });
  tickClock();
  document.getElementById("events").textContent = s.events + " events";
  const banner = document.getElementById("banner");
  const why = s.outcome === "failed" ? "failed: " + (s.reason || "no reason given")
            : s.outcome === "solved" ? "solved: the task is complete" : s.waiting;
  banner.hidden = !why; banner.textContent = why || "";
  banner.className = "banner" + (s.outcome === "failed" ? " failed"
                                 : s.outcome === "solved" ? " solved" : "");
  // only the parts whose data changed are drawn again: with many pages open on one machine
  // the browser's work per event stays small
  changed("suggestions", [s.suggestions, s.takeable], () => renderSuggestions(s));
  changed("agents", s.agents, () => renderAgents(s));
  changed("graph", s.graph, () => renderGraph(s));
  changed("timeline", [s.timeline, (s.agents || []).map((a) => a.name)], () => renderTimeline(s));
  changed("kb", [s.objects, s.facts], () => renderKB(s));
  renderOperator(s);
  // the run has ended: nothing the person can press would do anything any more
  if (s.outcome !== "running") {
    for (const b of document.querySelectorAll("main button, .operator button")) b.disabled = true;
  }
}

const drawn = {};
function changed(part, data, draw) {
  const key = JSON.stringify(data);
  if (drawn[part] === key) return;
  drawn[part] = key;
  draw();
}

// the person's answers beyond "done" (docs/protocol.md, "Operator answers")
const REPLY_TEXT = { start: "I'm starting", decline: "not now", cannot: "I can't do this",
                     give_back: "I give it back" };
function replyButtons() {
  return ["start", "decline", "cannot", "give_back"].map((r) =>
    el("button", { class: "reply " + r, "data-reply": r,
      onclick: () => post("/api/human", r === "cannot" ? { reply: r, reason: "said at the panel" }
                                                        : { reply: r }) },
      { start: "start", decline: "not now", cannot: "can't", give_back: "give back" }[r]));
}

function renderSuggestions(s) {
  const body = document.querySelector("#suggestions tbody");
  const takeable = new Set(s.takeable || []);
  const rows = (s.suggestions || []).map((g) => {
    const mine = g.owner === "human";
    let button = null;
    if (mine && g.next) {
      button = el("span", { class: "answers" },
        el("button", { class: "done", "data-action": g.next,
          onclick: () => post("/api/human", { action: g.next }) }, "done"),
        ...replyButtons());
    } else if (takeable.has(g.element)) {
      button = el("button", { class: "take", "data-take": g.element,
        onclick: () => post("/api/human", { take: g.element }) }, "I'll do this");
    }
    const to = g.to && g.to.length ? g.to.join(" + ") : "–";
    return el("tr", { class: mine ? "suggestion mine" : "suggestion", "data-element": g.element,
                       "data-owner": g.owner || "" },
      el("td", {}, el("code", { text: g.element })),
      el("td", { text: fmtCost(g.cost) }),
      el("td", { text: g.graph_name || g.graph || "top" }),
      el("td", { class: "to", text: to }),
      el("td", {}, g.next ? el("code", { text: g.next }) : ""),
      el("td", {}, button));
  });
  if (!rows.length) rows.push(el("tr", {}, el("td", { colspan: 6, class: "muted",
    text: s.outcome === "running" ? "no feasible element" : "nothing left to do" })));
  body.replaceChildren(...rows);
}

function renderAgents(s) {
  const box = document.getElementById("agents");
  box.replaceChildren(...(s.agents || []).map((a) => {
    let button = null;
    if (a.kind === "robot" && a.status === "stopped") {
      button = el("button", { class: "resume", "data-robot": a.name,
        onclick: () => post("/api/resume", { robot: a.name }) }, "resume");
    } else if (a.kind === "robot") {
      button = el("button", { class: "stop", "data-robot": a.name,
        onclick: () => post("/api/stop", { robot: a.name }) }, "stop robot");
    }
    return el("div", { class: "agent", "data-agent": a.name, "data-status": a.status,
                        "data-alive": a.alive ? "true" : "false" },
      el("span", { class: a.alive ? "dot" : "dot dead", title: a.alive ? "alive" : "lost" }),
      el("span", { class: "name", text: a.name }),
      el("span", { class: "muted", text: a.kind }),
      el("span", { class: "status " + a.status, text: a.alive ? a.status : "lost" }),
      el("span", { class: "action" }, a.action ? el("code", { text: a.action }) : ""),
      button);
  }));
}

// A layered drawing: leaves at the bottom, the root at the top; a hyper-arc is a box between
// its children and its parent (AND: all child edges enter the same box; OR: several boxes).
function layout(inst) {
  const level = new Map(inst.nodes.map((n) => [n.id, 0]));
  for (let pass = 0; pass < inst.nodes.length + 1; pass++) {
    let changed = false;
    for (const h of inst.hyperarcs) {
      const l = Math.max(0, ...h.children.map((c) => level.get(c) ?? 0)) + 1;
      if ((level.get(h.parent) ?? 0) < l) { level.set(h.parent, l); changed = true; }
    }
    if (!changed) break;
  }
  // a leaf used late (a leg for the k-th bolt) sits beside the other children of its first
  // hyper-arc instead of at the bottom, so its edges stay short
  const produced = new Set(inst.hyperarcs.map((h) => h.parent));
  for (const n of inst.nodes) {
    if (produced.has(n.id)) continue;
    const uses = inst.hyperarcs.filter((h) => h.children.includes(n.id));
    const others = uses.map((h) => Math.max(0, ...h.children.filter((c) => produced.has(c))
                                                          .map((c) => level.get(c) ?? 0)));
    if (others.length) level.set(n.id, Math.min(...others));
  }
  const rows = new Map();
  const put = (key, item) => { if (!rows.has(key)) rows.set(key, []); rows.get(key).push(item); };
  inst.nodes.forEach((n) => put(2 * level.get(n.id), { kind: "node", d: n }));
  inst.hyperarcs.forEach((h) => put(2 * Math.max(0, ...h.children.map((c) => level.get(c) ?? 0)) + 1,
                                    { kind: "arc", d: h }));
  const keys = [...rows.keys()].sort((a, b) => a - b);
  const pos = new Map();
  const W = 150, H = 56;
  const width = Math.max(...keys.map((k) => rows.get(k).length)) * W + 20;
  keys.forEach((k) => {
    const row = rows.get(k);
    const anchor = (it) => {
      const ids = it.kind === "arc" ? it.d.children
        : inst.hyperarcs.filter((h) => h.parent === it.d.id).map((h) => h.id);
      const xs = ids.map((i) => pos.get(i)).filter(Boolean).map((p) => p.x);
      return xs.length ? xs.reduce((a, b) => a + b, 0) / xs.length : Infinity;
    };
    row.sort((a, b) => anchor(a) - anchor(b));
    const off = (width - row.length * W) / 2;
    row.forEach((it, i) => pos.set(it.d.id, { x: off + i * W + W / 2,
                                              y: (keys[keys.length - 1] - k) * H + 24 }));
  });
  return { pos, width, height: (keys[keys.length - 1] + 1) * H + 10 };
}

const graphIndex = new Map();  // element id -> its drawn parts, to update statuses in place
let graphShape = null;         // the structure drawn; redrawn only when it changes
let graphState = [];           // the latest instances (a folded one is drawn when unfolded)

function arcTitle(h) {
  return `${h.id}: ${h.status}` + (h.cost !== null ? `, cost ${fmtCost(h.cost)}` : "")
    + (h.running ? `, being done by the ${h.running}` : "")
    + (h.actions.length ? "\n" + h.actions.join("\n") : "");
}
function nodeTitle(n) {
  return `${n.id}: ${n.status}` + (n.cost !== null ? `, cost ${fmtCost(n.cost)}` : "");
}
function instanceSummary(inst) {
  const done = inst.nodes.filter((n) => n.status === "met").length;
  return (inst.upper ? inst.upper + " → " : "") + `${inst.name} — ${done}/${inst.nodes.length} nodes met`;
}

function drawInstance(inst) {
  const { pos, width, height } = layout(inst);
  const svg = el("svg:svg", { width, height, viewBox: `0 0 ${width} ${height}`,
                              "data-graph": inst.path || "top" });
  const edges = new Map();
  for (const h of inst.hyperarcs) {
    const p = pos.get(h.id), done = h.status === "solved";
    const mine = [];
    for (const c of h.children) {
      const q = pos.get(c);
      mine.push(el("svg:path", { class: done ? "edge done" : "edge",
        d: `M${q.x},${q.y - 12} C${q.x},${(q.y + p.y) / 2} ${p.x},${(q.y + p.y) / 2} ${p.x},${p.y + 10}` }));
    }
    const r = pos.get(h.parent);
    mine.push(el("svg:path", { class: done ? "edge done" : "edge",
      d: `M${p.x},${p.y - 10} L${r.x},${r.y + 12}` }));
    svg.append(...mine);
    edges.set(h.id, mine);
  }
  for (const h of inst.hyperarcs) {
    const p = pos.get(h.id);
    const label = h.name.length > 20 ? h.name.slice(0, 19) + "…" : h.name;
    const title = el("svg:title", { text: arcTitle(h) });
    const g = el("svg:g", { class: "arc" + (h.running ? " running" : ""), "data-id": h.id,
                            "data-status": h.status, "data-running": h.running || "" },
      title,
      el("svg:rect", { x: p.x - 66, y: p.y - 10, width: 132, height: 20, rx: 4 }),
      el("svg:text", { x: p.x, y: p.y + 4, "text-anchor": "middle", text: label }));
    svg.append(g);
    graphIndex.set(h.id, { g, title, edges: edges.get(h.id) });
  }
  for (const n of inst.nodes) {
    const p = pos.get(n.id);
    const title = el("svg:title", { text: nodeTitle(n) });
    const g = el("svg:g", { class: "node", "data-id": n.id, "data-status": n.status },
      title,
      el("svg:ellipse", { cx: p.x, cy: p.y, rx: 58, ry: 12 }),
      el("svg:text", { x: p.x, y: p.y + 4, "text-anchor": "middle", text: n.name }));
    svg.append(g);
    graphIndex.set(n.id, { g, title, edges: [] });
  }
  return el("div", { class: "graph-scroll" }, svg);
}

function renderGraph(s) {
  const insts = s.graph || [];
  graphState = insts;
  const shape = JSON.stringify(insts.map((i) => [i.path, i.nodes.map((n) => n.id),
    i.hyperarcs.map((h) => [h.id, h.children, h.parent])]));
  if (shape === graphShape) { updateGraph(insts); return; }
  graphShape = shape;
  graphIndex.clear();
  const box = document.getElementById("graph");
  box.replaceChildren(...insts.map((inst) => {
    const open = openInstances.has(inst.path);
    const d = el("details", { class: "instance" + (inst.depth ? " sub" : ""),
                              "data-path": inst.path || "top", open },
      el("summary", { text: instanceSummary(inst) }), open ? drawInstance(inst) : null);
    d.addEventListener("toggle", () => {
      if (!d.open) { openInstances.delete(inst.path); return; }
      openInstances.add(inst.path);
      if (d.querySelector("svg")) return;
      const now = graphState.find((i) => i.path === inst.path);  // drawn when first unfolded
      if (now) d.append(drawInstance(now));
    });
    return d;
  }));
}

function updateGraph(insts) {
  const summaries = document.querySelectorAll("#graph details.instance > summary");
  insts.forEach((inst, k) => {
    if (summaries[k]) summaries[k].textContent = instanceSummary(inst);
    for (const n of inst.nodes) {
      const e = graphIndex.get(n.id);
      if (!e) continue;  // folded, not drawn yet
      e.g.setAttribute("data-status", n.status);
      e.title.textContent = nodeTitle(n);
    }
    for (const h of inst.hyperarcs) {
      const e = graphIndex.get(h.id);
      if (!e) continue;
      e.g.setAttribute("data-status", h.status);
      e.g.setAttribute("data-running", h.running || "");
      e.g.setAttribute("class", "arc" + (h.running ? " running" : ""));
      e.title.textContent = arcTitle(h);
      for (const p of e.edges) p.setAttribute("class", h.status === "solved" ? "edge done" : "edge");
    }
  });
}

// The timeline grows at its end: new entries are appended and only the time scale (one
// transform) changes; it is drawn again only when its start moved (it keeps the latest 300).
const tl = { lanes: null, first: null, last: null, count: 0, end: 1, group: null, label: null,
             list: null, k: 1, W: 600 };
const TL_COLOUR = { done: "#2e9d5b", failed: "#c2410c", timed_out: "#c2410c", stopped: "#f59e0b" };
const tlKey = (it) => `${it.start}|${it.end}|${it.action}|${it.status}|${it.agents.join("+")}`;

function renderTimeline(s) {
  const box = document.getElementById("timeline");
  const items = s.timeline || [];
  const lanes = (s.agents || []).map((a) => a.name);
  const L = 70, H = 22;
  // the width is read once per full drawing: reading it each time would force a layout
  const grows = tl.group && tl.lanes === lanes.join(",") && tl.count > 0
    && items.length >= tl.count && tlKey(items[0]) === tl.first
    && tlKey(items[tl.count - 1]) === tl.last;
  if (!grows) {
    tl.W = Math.max(600, box.clientWidth - 10);
    const W = tl.W;
    const svg = el("svg:svg", { width: W, height: lanes.length * H + 22, id: "timeline-svg" });
    lanes.forEach((name, i) => {
      svg.append(el("svg:text", { x: 4, y: i * H + 15, class: "lane-label", text: name }));
      svg.append(el("svg:line", { x1: L, x2: W - 10, y1: i * H + 20, y2: i * H + 20, stroke: "#e5e7eb" }));
    });
    tl.group = el("svg:g", {});
    tl.label = el("svg:text", { x: W - 10, y: lanes.length * H + 18, "text-anchor": "end",
                                class: "muted" });
    svg.append(tl.group, tl.label);
    tl.list = el("ol", { id: "timeline-list", reversed: true });
    box.replaceChildren(svg, tl.list);
    Object.assign(tl, { lanes: lanes.join(","), count: 0, end: 1 });
  }
  const fresh = items.slice(tl.count);
  tl.end = Math.max(tl.end, ...fresh.map((i) => i.end));
  tl.k = (tl.W - L - 10) / tl.end;
  for (const it of fresh) {
    for (const a of it.agents) {
      const i = lanes.indexOf(a);
      if (i < 0) continue;
      tl.group.append(el("svg:rect", { x: it.start, y: i * H + 4, height: 14,
          width: Math.max(it.end - it.start, 3 / tl.k), fill: TL_COLOUR[it.status] || "#9aa3af" },
        el("svg:title", { text: `${it.action} ${it.status} ${it.start}–${it.end} s`
                               + (it.reason ? " (" + it.reason + ")" : "") })));
    }
    tl.list.prepend(el("li", { "data-status": it.status },
      `${it.start.toFixed(1)} s `, el("code", { text: it.action }),
      ` — ${it.agents.join(" + ")}, ${it.status}` + (it.reason ? ` (${it.reason})` : "")));
  }
  while (tl.list.children.length > 40) tl.list.lastChild.remove();
  tl.list.setAttribute("start", items.length);
  tl.group.setAttribute("transform", `translate(${L},0) scale(${tl.k},1)`);
  tl.label.textContent = tl.end.toFixed(1) + " s";
  tl.count = items.length;
  if (items.length) { tl.first = tlKey(items[0]); tl.last = tlKey(items[items.length - 1]); }
}

// The objects table is updated cell by cell while the same objects are listed.
let kbShape = null;
function renderKB(s) {
  const body = document.querySelector("#objects tbody");
  const objects = s.objects || [];
  const pos = (o) => (o.position || []).map((v) => (+v).toFixed(2)).join(", ");
  const shape = objects.map((o) => o.id + ":" + o.type).join(",");
  if (shape === kbShape) {
    objects.forEach((o, k) => {
      const cells = body.rows[k].cells;
      if (cells[2].textContent !== pos(o)) cells[2].textContent = pos(o);
      const fixed = o.fixed ? "yes" : "";
      if (cells[3].textContent !== fixed) cells[3].textContent = fixed;
    });
  } else {
    kbShape = shape;
    body.replaceChildren(...objects.map((o) => el("tr", { "data-object": o.id },
      el("td", {}, el("code", { text: o.id })), el("td", { text: o.type }),
      el("td", { text: pos(o) }), el("td", { text: o.fixed ? "yes" : "" }))));
  }
  renderFacts(s);
}

function renderFacts(s) {
  const facts = document.getElementById("facts");
  facts.replaceChildren(...(s.facts || []).map((f) =>
    el("li", {}, el("code", { text: `${f[0]}(${f.slice(1).join(", ")})` }))));
}

connect(250);
