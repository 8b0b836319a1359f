// flexhrc operator panel: renders the state pushed over the websocket, posts the operator's
// inputs. No framework, no network beyond this server. Every name from the server is set as
// text (never as HTML).
"use strict";

const TOKEN = new URLSearchParams(location.search).get("token");
const SVGNS = "http://www.w3.org/2000/svg";
const openInstances = new Set([""]);  // instance paths unfolded by the operator
window.__panel = { version: -1, messages: 0, renderedAt: 0, state: null };

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
    text = data.action ? "done: " + data.action : data.take ? "you take " + data.take
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
    const state = JSON.parse(ev.data);
    window.__panel.messages += 1;
    render(state);
    window.__panel.version = state.version === undefined ? window.__panel.messages : state.version;
    window.__panel.events = state.events;
    window.__panel.renderedAt = Date.now();
    window.__panel.state = state;
  };
  ws.onclose = () => {
    link.textContent = "offline"; link.className = "badge link-down";
    setTimeout(() => connect(Math.min(delay * 2, 5000)), delay);
  };
}

// -- rendering ----------------------------------------------------------------------------
function render(s) {
  document.getElementById("cell-name").textContent = s.cell || "";
  const out = document.getElementById("outcome");
  out.textContent = s.outcome; out.dataset.outcome = s.outcome;
  document.getElementById("clock").textContent = "t = " + (s.time ?? 0).toFixed(1) + " s";
  document.getElementById("events").textContent = s.events + " events";
  const banner = document.getElementById("banner");
  const why = s.outcome === "failed" ? "failed: " + (s.reason || "no reason given")
            : s.outcome === "solved" ? "solved: the task is complete" : s.waiting;
  banner.hidden = !why; banner.textContent = why || "";
  banner.className = "banner" + (s.outcome === "failed" ? " failed" : "");
  // only the parts whose data changed are drawn again: with many pages open on one machine
  // the browser's work per event stays small
  changed("suggestions", [s.suggestions, s.takeable], () => renderSuggestions(s));
  changed("agents", s.agents, () => renderAgents(s));
  changed("graph", s.graph, () => renderGraph(s));
  changed("timeline", [s.timeline, (s.agents || []).map((a) => a.name)], () => renderTimeline(s));
  changed("kb", [s.objects, s.facts], () => renderKB(s));
}

const drawn = {};
function changed(part, data, draw) {
  const key = JSON.stringify(data);
  if (drawn[part] === key) return;
  drawn[part] = key;
  draw();
}

function renderSuggestions(s) {
  const body = document.querySelector("#suggestions tbody");
  const takeable = new Set(s.takeable || []);
  const rows = (s.suggestions || []).map((g) => {
    const mine = g.owner === "human";
    let button = null;
    if (mine && g.next) {
      button = el("button", { class: "done", "data-action": g.next,
        onclick: () => post("/api/human", { action: g.next }) }, "done");
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

function drawInstance(inst) {
  const { pos, width, height } = layout(inst);
  const svg = el("svg:svg", { width, height, viewBox: `0 0 ${width} ${height}`,
                              "data-graph": inst.path || "top" });
  for (const h of inst.hyperarcs) {
    const p = pos.get(h.id), done = h.status === "solved";
    for (const c of h.children) {
      const q = pos.get(c);
      svg.append(el("svg:path", { class: done ? "edge done" : "edge",
        d: `M${q.x},${q.y - 12} C${q.x},${(q.y + p.y) / 2} ${p.x},${(q.y + p.y) / 2} ${p.x},${p.y + 10}` }));
    }
    const r = pos.get(h.parent);
    svg.append(el("svg:path", { class: done ? "edge done" : "edge",
      d: `M${p.x},${p.y - 10} L${r.x},${r.y + 12}` }));
  }
  for (const h of inst.hyperarcs) {
    const p = pos.get(h.id);
    const label = h.name.length > 20 ? h.name.slice(0, 19) + "…" : h.name;
    const g = el("svg:g", { class: "arc" + (h.running ? " running" : ""), "data-id": h.id,
                            "data-status": h.status, "data-running": h.running || "" },
      el("svg:title", { text: `${h.id}: ${h.status}` + (h.cost !== null ? `, cost ${fmtCost(h.cost)}` : "")
                             + (h.running ? `, being done by the ${h.running}` : "")
                             + (h.actions.length ? "\n" + h.actions.join("\n") : "") }),
      el("svg:rect", { x: p.x - 66, y: p.y - 10, width: 132, height: 20, rx: 4 }),
      el("svg:text", { x: p.x, y: p.y + 4, "text-anchor": "middle", text: label }));
    svg.append(g);
  }
  for (const n of inst.nodes) {
    const p = pos.get(n.id);
    svg.append(el("svg:g", { class: "node", "data-id": n.id, "data-status": n.status },
      el("svg:title", { text: `${n.id}: ${n.status}` + (n.cost !== null ? `, cost ${fmtCost(n.cost)}` : "") }),
      el("svg:ellipse", { cx: p.x, cy: p.y, rx: 58, ry: 12 }),
      el("svg:text", { x: p.x, y: p.y + 4, "text-anchor": "middle", text: n.name })));
  }
  return el("div", { class: "graph-scroll" }, svg);
}

function renderGraph(s) {
  const box = document.getElementById("graph");
  const insts = s.graph || [];
  const counts = (inst) => {
    const done = inst.nodes.filter((n) => n.status === "met").length;
    return `${inst.name} — ${done}/${inst.nodes.length} nodes met`;
  };
  const blocks = insts.map((inst) => {
    const d = el("details", { class: "instance" + (inst.depth ? " sub" : ""),
                              "data-path": inst.path || "top",
                              open: openInstances.has(inst.path) },
      el("summary", { text: (inst.upper ? inst.upper + " → " : "") + counts(inst) }),
      drawInstance(inst));
    d.addEventListener("toggle", () => {
      if (d.open) openInstances.add(inst.path); else openInstances.delete(inst.path);
    });
    return d;
  });
  box.replaceChildren(...blocks);
}

function renderTimeline(s) {
  const box = document.getElementById("timeline");
  const items = s.timeline || [];
  const lanes = (s.agents || []).map((a) => a.name);
  const end = Math.max(1, ...items.map((i) => i.end));
  const W = Math.max(600, box.clientWidth - 10), L = 70, H = 22;
  const svg = el("svg:svg", { width: W, height: lanes.length * H + 22, id: "timeline-svg" });
  const x = (t) => L + (W - L - 10) * (t / end);
  lanes.forEach((name, i) => {
    svg.append(el("svg:text", { x: 4, y: i * H + 15, class: "lane-label", text: name }));
    svg.append(el("svg:line", { x1: L, x2: W - 10, y1: i * H + 20, y2: i * H + 20, stroke: "#e5e7eb" }));
  });
  const colour = { done: "#2e9d5b", failed: "#c2410c", timed_out: "#c2410c", stopped: "#f59e0b" };
  for (const it of items) {
    for (const a of it.agents) {
      const i = lanes.indexOf(a);
      if (i < 0) continue;
      const w = Math.max(3, x(it.end) - x(it.start));
      svg.append(el("svg:rect", { x: x(it.start), y: i * H + 4, width: w, height: 14, rx: 2,
                                  fill: colour[it.status] || "#9aa3af" },
        el("svg:title", { text: `${it.action} ${it.status} ${it.start}–${it.end} s`
                               + (it.reason ? " (" + it.reason + ")" : "") })));
    }
  }
  svg.append(el("svg:text", { x: W - 10, y: lanes.length * H + 18, "text-anchor": "end",
                              class: "muted", text: end.toFixed(1) + " s" }));
  const list = el("ol", { id: "timeline-list", reversed: true, start: items.length },
    ...items.slice(-40).reverse().map((it) => el("li", { "data-status": it.status },
      `${it.start.toFixed(1)} s `, el("code", { text: it.action }),
      ` — ${it.agents.join(" + ")}, ${it.status}` + (it.reason ? ` (${it.reason})` : ""))));
  box.replaceChildren(svg, list);
}

function renderKB(s) {
  const body = document.querySelector("#objects tbody");
  body.replaceChildren(...(s.objects || []).map((o) => el("tr", { "data-object": o.id },
    el("td", {}, el("code", { text: o.id })), el("td", { text: o.type }),
    el("td", { text: (o.position || []).map((v) => (+v).toFixed(2)).join(", ") }),
    el("td", { text: o.fixed ? "yes" : "" }))));
  const facts = document.getElementById("facts");
  facts.replaceChildren(...(s.facts || []).map((f) =>
    el("li", {}, el("code", { text: `${f[0]}(${f.slice(1).join(", ")})` }))));
}

connect(250);
