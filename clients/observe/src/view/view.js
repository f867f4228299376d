// The page of `rome view`: the map from /map.json, the fleet from the
// server-sent events of /events (see view.rs for their kinds).
"use strict";

const COLORS = ["#1f6fd1", "#d1461f", "#2a9d4b", "#8e44ad", "#c99700", "#16a2a2", "#d12f7a", "#5d6d7e"];
const canvas = document.getElementById("map");
const ctx = canvas.getContext("2d");
const robots = new Map(); // name -> robot record
let map = null;
let view = null; // { cx, cy, scale } world centre (mm) and pixels per mm
let dirty = true;

function robot(name) {
  let r = robots.get(name);
  if (r) return r;
  r = {
    name, color: COLORS[robots.size % COLORS.length],
    truth: null, odo: null, trailTruth: [], trailOdo: [], scan: null,
    route: null, lights: [], plates: [], board: {}, card: null,
  };
  robots.set(name, r);
  makeCard(r);
  return r;
}

// ---- the stream -------------------------------------------------------

function connect() {
  const link = document.getElementById("link");
  const es = new EventSource("/events");
  es.onopen = () => { link.textContent = "live"; link.className = "link on"; };
  es.onerror = () => { link.textContent = "reconnecting…"; link.className = "link off"; };
  es.onmessage = (m) => {
    let e;
    try { e = JSON.parse(m.data); } catch (_) { return; }
    if (!e || typeof e.robot !== "string") return;
    apply(e);
    dirty = true;
  };
}

function addTrail(trail, x, y) {
  const last = trail[trail.length - 1];
  if (!last || Math.hypot(last[0] - x, last[1] - y) >= 100) {
    trail.push([x, y]);
    if (trail.length > 4000) trail.shift();
  }
}

function apply(e) {
  const r = robot(e.robot);
  switch (e.k) {
    case "state":
      r.odo = e; addTrail(r.trailOdo, e.x, e.y); updateCard(r); break;
    case "truth":
      r.truth = e; addTrail(r.trailTruth, e.x, e.y); updateCard(r); break;
    case "scan":
      r.scan = e; break;
    case "trail":
      r.trailTruth = e.truth || []; r.trailOdo = e.odometry || []; break;
    case "route":
      r.route = e.v; updateCard(r); break;
    case "light":
      r.lights.push(e); break;
    case "plate":
      r.plates.push(e); break;
    case "board":
      r.board[e.var] = e.v;
      // Who waits for whom changes on every robot's card.
      if (e.var === "Traffic") robots.forEach(updateCard); else updateCard(r);
      break;
  }
}

// ---- the side panel ---------------------------------------------------

function el(tag, attrs, text) {
  const n = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) n.setAttribute(k, v);
  if (text !== undefined) n.textContent = text;
  return n;
}

function makeCard(r) {
  document.getElementById("no-robots")?.remove();
  const card = el("section", { class: "robot", style: `--c:${r.color}`, "data-robot": r.name });
  const h = el("h2");
  h.append(el("span", {}, r.name), el("span", { class: "where" }, ""));
  card.append(h);
  const rows = el("div", { class: "rows" });
  card.append(rows);
  for (const cam of ["up", "side"]) {
    const b = el("button", { type: "button" }, `${cam} camera`);
    b.onclick = () => showCamera(r, cam);
    card.append(b);
  }
  const img = el("img", { class: "cam", alt: "", hidden: "" });
  const err = el("div", { class: "err" });
  const board = el("details");
  board.append(el("summary", {}, "blackboard"), el("table"));
  card.append(img, err, board);
  document.getElementById("robots").append(card);
  r.card = { card, rows, img, err, where: h.lastChild, table: board.lastChild };
  const cards = [...document.querySelectorAll(".robot")];
  cards.sort((a, b) => a.dataset.robot.localeCompare(b.dataset.robot, undefined, { numeric: true }));
  cards.forEach((c) => c.parentNode.append(c));
}

function showCamera(r, cam) {
  const { img, err } = r.card;
  err.textContent = "";
  fetch(`/camera/${encodeURIComponent(r.name)}/${encodeURIComponent(cam)}`)
    .then(async (res) => {
      if (!res.ok) throw new Error(await res.text());
      return res.blob();
    })
    .then((b) => { img.src = URL.createObjectURL(b); img.alt = `${r.name} ${cam} camera`; img.hidden = false; })
    .catch((e) => { err.textContent = String(e.message || e); });
}

function fmt(v) {
  if (typeof v === "number") return Number.isInteger(v) ? String(v) : v.toFixed(1);
  if (v === null || v === undefined) return "–";
  return typeof v === "string" ? v : JSON.stringify(v);
}

// A part of the building as people call it (rome_nav::traffic::describe).
function part(sem) {
  if (sem.startsWith("$passage/")) return `passage ${sem.slice(9)}`;
  if (sem.startsWith("$traffic/junction/")) return `junction ${sem.slice(18)}`;
  return sem;
}

// What a robot holds and waits for, and who holds what it waits for.
function traffic(r) {
  const t = r.board.Traffic;
  if (!t || typeof t !== "object") return null;
  const holds = Array.isArray(t.holds) ? t.holds.filter((s) => typeof s === "string") : [];
  let text = holds.length ? `holds ${holds.map(part).join(", ")}` : "holds nothing";
  if (typeof t.waits_for === "string") {
    const by = [...robots.values()].filter((o) => o !== r && Array.isArray(o.board.Traffic?.holds)
      && o.board.Traffic.holds.includes(t.waits_for)).map((o) => o.name);
    text += `; waits for ${part(t.waits_for)}${by.length ? " (held by " + by.join(", ") + ")" : ""}`;
  }
  return text;
}

function updateCard(r) {
  if (!r.card) return;
  const b = r.board;
  const rows = [];
  if (r.route) rows.push(["route", `${r.route.from} → ${r.route.to}, ${(r.route.length_mm / 1000).toFixed(1)} m`]);
  if (b.GoalType !== undefined) {
    const unit = b.GoalType === "L" ? " light(s)" : " mm";
    rows.push(["goal", `${fmt(b.GoalType)} ${fmt(b.GoalDistance)}${unit} heading ${fmt(b.GoalDirection)}°`]);
  }
  if (b.Status) rows.push(["navigator", `${b.Status.state} (goal ${b.Status.goal}, ${b.Status.goal_type})`]);
  if (b.Status && typeof b.Status.blocked === "string") rows.push(["blocked", b.Status.blocked]);
  if (b.CeilingLight !== undefined) rows.push(["lights counted", fmt(b.CeilingLight)]);
  const t = traffic(r);
  if (t) rows.push(["traffic", t]);
  if (r.odo) rows.push(["base", `${r.odo.mode}${r.odo.lock ? ", locked by " + r.odo.lock : ""}`]);
  if (r.truth) rows.push(["driven", `${(r.truth.travelled_mm / 1000).toFixed(2)} m`]);
  if (r.truth && r.odo) rows.push(["odometry off", `${(Math.hypot(r.truth.x - r.odo.x, r.truth.y - r.odo.y) / 1000).toFixed(2)} m`]);
  r.card.rows.replaceChildren(...rows.map(([k, v]) => {
    const d = el("div", { class: "row" });
    d.append(el("span", {}, k), el("span", {}, v));
    return d;
  }));
  const p = r.truth || r.odo;
  r.card.where.textContent = p ? `(${(p.x / 1000).toFixed(1)}, ${(p.y / 1000).toFixed(1)}) m ${Math.round(p.heading)}°` : "";
  r.card.table.replaceChildren(...Object.keys(b).sort().map((k) => {
    const tr = el("tr");
    tr.append(el("td", {}, k), el("td", {}, fmt(b[k])));
    return tr;
  }));
}

// ---- drawing ----------------------------------------------------------

function fit() {
  if (!map) return;
  const w = canvas.clientWidth, h = canvas.clientHeight;
  const mw = map.max[0] - map.min[0], mh = map.max[1] - map.min[1];
  view = {
    cx: (map.min[0] + map.max[0]) / 2,
    cy: (map.min[1] + map.max[1]) / 2,
    scale: 0.94 * Math.min(w / Math.max(mw, 1), h / Math.max(mh, 1)),
  };
  dirty = true;
}

function sx(x) { return canvas.clientWidth / 2 + (x - view.cx) * view.scale; }
function sy(y) { return canvas.clientHeight / 2 - (y - view.cy) * view.scale; }

function polyline(points, color, width, dash) {
  if (!points || points.length < 2) return;
  ctx.beginPath();
  ctx.moveTo(sx(points[0][0]), sy(points[0][1]));
  for (const p of points.slice(1)) ctx.lineTo(sx(p[0]), sy(p[1]));
  ctx.strokeStyle = color; ctx.lineWidth = width; ctx.setLineDash(dash || []);
  ctx.stroke(); ctx.setLineDash([]);
}

function triangle(p, color, filled) {
  const s = Math.max(7, 380 * view.scale); // about the robot's size, never a speck
  const [dx, dy] = p.dir; // world unit vector of the heading
  const fx = dx, fy = -dy; // on screen, y grows down
  const x = sx(p.x), y = sy(p.y);
  ctx.beginPath();
  ctx.moveTo(x + fx * s * 1.4, y + fy * s * 1.4);
  ctx.lineTo(x - fx * s - fy * s * 0.8, y - fy * s + fx * s * 0.8);
  ctx.lineTo(x - fx * s + fy * s * 0.8, y - fy * s - fx * s * 0.8);
  ctx.closePath();
  ctx.lineWidth = 2; ctx.strokeStyle = color;
  if (filled) { ctx.fillStyle = color; ctx.fill(); }
  ctx.stroke();
}

function draw() {
  const dpr = window.devicePixelRatio || 1;
  const w = canvas.clientWidth, h = canvas.clientHeight;
  if (canvas.width !== Math.round(w * dpr) || canvas.height !== Math.round(h * dpr)) {
    canvas.width = Math.round(w * dpr); canvas.height = Math.round(h * dpr);
  }
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  ctx.clearRect(0, 0, w, h);
  if (!map || !view) return;
  for (const [x1, y1, x2, y2, color, width, dashed] of map.lines) {
    ctx.beginPath(); ctx.moveTo(sx(x1), sy(y1)); ctx.lineTo(sx(x2), sy(y2));
    ctx.strokeStyle = color; ctx.lineWidth = width; ctx.setLineDash(dashed ? [5, 4] : []);
    ctx.stroke();
  }
  ctx.setLineDash([]);
  for (const [x, y, radius, color] of map.dots) {
    ctx.beginPath(); ctx.arc(sx(x), sy(y), radius, 0, 2 * Math.PI); ctx.fillStyle = color; ctx.fill();
  }
  const px = Math.max(9, Math.min(16, 600 * view.scale));
  ctx.font = `${px}px system-ui, sans-serif`;
  ctx.textBaseline = "top";
  for (const [x, y, text, color] of map.texts) {
    ctx.fillStyle = color; ctx.fillText(text, sx(x), sy(y));
  }
  for (const r of robots.values()) {
    if (r.route) polyline(r.route.points, r.color, 2, [8, 6]);
    polyline(r.trailOdo, r.color + "88", 1.5, [3, 3]);
    polyline(r.trailTruth, r.color, 2.5);
    if (r.scan) {
      const [fx, fy] = r.scan.from;
      for (const [x, y, echo] of r.scan.rays) {
        ctx.beginPath(); ctx.moveTo(sx(fx), sy(fy)); ctx.lineTo(sx(x), sy(y));
        ctx.strokeStyle = echo ? "rgba(230,120,0,0.45)" : "rgba(160,160,160,0.25)"; ctx.lineWidth = 1; ctx.stroke();
        if (echo) { ctx.beginPath(); ctx.arc(sx(x), sy(y), 2, 0, 2 * Math.PI); ctx.fillStyle = "rgba(230,120,0,0.9)"; ctx.fill(); }
      }
    }
    for (const l of r.lights) {
      ctx.beginPath(); ctx.arc(sx(l.x), sy(l.y), 7, 0, 2 * Math.PI);
      ctx.strokeStyle = "#e6b400"; ctx.lineWidth = 3; ctx.stroke();
    }
    for (const p of r.plates) {
      ctx.fillStyle = "#2a5"; ctx.fillRect(sx(p.x) - 5, sy(p.y) - 5, 10, 10);
      if (p.label) { ctx.fillStyle = "#174"; ctx.fillText(p.label, sx(p.x) + 7, sy(p.y) - 5); }
    }
    if (r.odo) triangle(r.odo, r.color, false);
    if (r.truth) triangle(r.truth, r.color, true);
    const p = r.truth || r.odo;
    if (p) {
      ctx.fillStyle = "#000"; ctx.font = `bold ${px + 1}px system-ui, sans-serif`;
      ctx.fillText(r.name, sx(p.x) + 12, sy(p.y) + 10);
      ctx.font = `${px}px system-ui, sans-serif`;
    }
  }
}

function frame() {
  if (dirty) { dirty = false; draw(); }
  requestAnimationFrame(frame);
}

// ---- pan and zoom -----------------------------------------------------

canvas.addEventListener("wheel", (ev) => {
  if (!view) return;
  ev.preventDefault();
  const k = Math.exp(-ev.deltaY * 0.0015);
  const rect = canvas.getBoundingClientRect();
  const mx = ev.clientX - rect.left, my = ev.clientY - rect.top;
  const wx = view.cx + (mx - canvas.clientWidth / 2) / view.scale;
  const wy = view.cy - (my - canvas.clientHeight / 2) / view.scale;
  view.scale *= k;
  view.cx = wx - (mx - canvas.clientWidth / 2) / view.scale;
  view.cy = wy + (my - canvas.clientHeight / 2) / view.scale;
  dirty = true;
}, { passive: false });
let drag = null;
canvas.addEventListener("mousedown", (ev) => { drag = [ev.clientX, ev.clientY]; });
window.addEventListener("mouseup", () => { drag = null; });
window.addEventListener("mousemove", (ev) => {
  if (!drag || !view) return;
  view.cx -= (ev.clientX - drag[0]) / view.scale;
  view.cy += (ev.clientY - drag[1]) / view.scale;
  drag = [ev.clientX, ev.clientY];
  dirty = true;
});
canvas.addEventListener("dblclick", fit);
window.addEventListener("resize", () => { dirty = true; });

fetch("/map.json")
  .then((r) => r.json())
  .then((m) => { map = m; document.getElementById("map-name").textContent = `· ${m.name}`; fit(); })
  .catch((e) => { document.getElementById("link").textContent = "no map: " + e; });
connect();
requestAnimationFrame(frame);
