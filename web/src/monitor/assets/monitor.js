// Petrel monitor: draws the page from /page.json and keeps it up to date
// from the frames of /ws (live: pushed; a recording: asked for an instant).
// Plain JavaScript, no library, no build step.
"use strict";

const $ = (id) => document.getElementById(id);
const FLASH_MS = 1500;
let page = null;
let byId = {};             // element id -> {kind: "place"|"transition", flat, def, net}
let frame = null;          // the last frame applied
let firedAt = {};          // flat transition -> when it last fired (performance.now())
let vehicles = [];         // a team's vehicles: [{name, system, colour}]; [] without a team
let tracks = {};           // vehicle name ("" without a team) -> track points
let lastEvents = {};       // vehicle name -> its last events, newest first
const LAST_EVENTS = 5;
let selected = null;
let socket = null;
let logRows = 0;

function text(s) { return s === null || s === undefined ? "" : String(s); }
function esc(s) {
  return text(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" }[c]));
}
function params(p) {
  if (!p || typeof p !== "object") return "";
  const keys = Object.keys(p);
  if (!keys.length) return "";
  return " {" + keys.map((k) => {
    let v = JSON.stringify(p[k]);
    if (v && v.length > 40) v = "…";
    return k + ": " + v;
  }).join(", ") + "}";
}
function seconds(t) { return (t === null || t === undefined) ? "–" : t.toFixed(1) + " s"; }

// ---- the fixed part ----------------------------------------------------

function build() {
  $("project").textContent = page.name;
  document.title = page.name + " — Petrel monitor";
  const live = page.mode === "live";
  $("mode").textContent = page.mirror ? "MIRROR" : (live ? "LIVE" : "RECORDING");
  $("mode").className = "badge" + (live ? "" : " view");
  const globals = $("globals");
  globals.innerHTML = page.globals.length ? '<span class="muted">global places:</span>' : "";
  for (const g of page.globals) {
    const chip = document.createElement("span");
    chip.className = "chip";
    chip.id = "g-" + g.flat;
    chip.textContent = "@" + g.name;
    chip.title = "used by " + g.nets.join(", ");
    chip.onmouseenter = () => linkGlobal(g.name, true);
    chip.onmouseleave = () => linkGlobal(g.name, false);
    chip.onclick = () => define({ kind: "global", def: g });
    globals.appendChild(chip);
  }
  // A team: one group per vehicle (its nets, strip and last events), then
  // the team nets' group. Without a team the nets alone, as ever.
  vehicles = teamOf(page);
  const nets = $("nets");
  const all = page.nets.map((n, i) => i);
  // The nets in the order shown: by group, each by level.
  const order = [];
  const shown = (indices) => { const l = byLevel(indices); for (const k of [...l.keys()].sort((a, b) => a - b)) order.push(...l.get(k)); };
  if (vehicles.length) {
    $("strip").hidden = true;
    vehicles.forEach((v, k) => {
      const mine = all.filter((i) => page.nets[i].vehicle === v.name);
      nets.appendChild(group(v, k, mine));
      shown(mine);
    });
    const team = all.filter((i) => !page.nets[i].vehicle);
    if (team.length) nets.appendChild(group(null, null, team));
    shown(team);
  } else {
    levelRows(nets, all);
    shown(all);
  }
  // The mission at a glance: each net and its marked places, in that order.
  const summary = $("summary");
  for (const i of order) {
    const s = document.createElement("div");
    s.className = "sum";
    s.id = "sum-" + i;
    s.innerHTML = "<small>" + esc(page.nets[i].name) + "</small><b>–</b>";
    const v = vehicleOf(page.nets[i]);
    if (v) s.style.borderLeftColor = v.colour;
    s.onclick = () => $("net-" + i).scrollIntoView({ behavior: "smooth" });
    summary.appendChild(s);
  }
  for (const [i, n] of page.nets.entries()) {
    for (const p of n.places) byId[p.id] = { kind: "place", flat: p.flat, def: p, net: i };
    for (const t of n.transitions) byId[t.id] = { kind: "transition", flat: t.flat, def: t, net: i };
  }
  if (!live) timeline();
  if (page.mirror) mirrorBuild();
}

// The team: the page's vehicles, or else the vehicles its nets name
// (whatever page served the JSON), in order; each its colour.
const COLOURS = ["#06c", "#d60", "#393", "#a3c", "#c03", "#088", "#875", "#d4a"];
function colour(k) { return k < COLOURS.length ? COLOURS[k] : "hsl(" + ((k * 137.5) % 360).toFixed(0) + ", 70%, 40%)"; }
function teamOf(p) {
  const named = (p.vehicles || []).map((v) => ({ name: v.name, system: v.system }));
  for (const n of p.nets) {
    if (n.vehicle && !named.some((v) => v.name === n.vehicle)) named.push({ name: n.vehicle, system: null });
  }
  return named.map((v, k) => ({ name: v.name, system: v.system, colour: colour(k) }));
}
function vehicleOf(n) { return n.vehicle ? vehicles.find((v) => v.name === n.vehicle) : null; }
function groupId(name) { return name === null ? "group-team" : "group-" + vehicles.findIndex((v) => v.name === name); }

// Net indices by level: the hierarchy reads top to bottom.
function byLevel(indices) {
  const levels = new Map();
  for (const i of indices) {
    const l = page.nets[i].level === null ? 99 : page.nets[i].level;
    if (!levels.has(l)) levels.set(l, []);
    levels.get(l).push(i);
  }
  return levels;
}
function levelRows(box, indices) {
  const levels = byLevel(indices);
  for (const l of [...levels.keys()].sort((a, b) => a - b)) {
    const title = document.createElement("div");
    title.className = "level-title";
    title.textContent = l === 0 ? "level 0 — activated by no other net" : (l === 99 ? "not activated" : "level " + l);
    box.appendChild(title);
    const row = document.createElement("div");
    row.className = "level";
    for (const i of levels.get(l)) row.appendChild(card(i));
    box.appendChild(row);
  }
}

// A vehicle's group (v null: the team nets'): its head — name, system,
// lockout, mode, armed, position, heartbeat — its last events, its nets.
function group(v, k, indices) {
  const g = document.createElement("section");
  g.className = "group" + (v ? "" : " team");
  g.id = groupId(v ? v.name : null);
  if (v) {
    g.dataset.vehicle = v.name;
    g.style.borderLeftColor = v.colour;
    const tile = (c, label) => '<div class="g-tile ' + c + '"><label>' + label + "</label><b>–</b></div>";
    g.innerHTML = '<div class="group-head"><span class="swatch" style="background:' + v.colour + '"></span><b class="g-name">' +
      esc(v.name) + '</b><span class="g-system muted">' + (v.system === null ? "" : "system " + v.system) + "</span>" +
      '<span class="g-lock" hidden>LOCKED OUT</span>' + tile("g-mode", "mode") + tile("g-armed", "armed") +
      tile("g-position", "position") + tile("g-battery", "battery") + tile("g-hb", "last heartbeat") + "</div>" +
      '<div class="g-events"><span class="muted">no event yet</span></div>';
  } else {
    g.innerHTML = '<div class="group-head"><b class="g-name">team</b><span class="muted">the nets of no one vehicle</span>' +
      '<span class="g-lock" hidden>LOCKED OUT</span></div>';
  }
  const box = document.createElement("div");
  box.className = "group-nets";
  levelRows(box, indices);
  g.appendChild(box);
  return g;
}

function card(i) {
  const n = page.nets[i];
  const div = document.createElement("div");
  div.className = "net";
  div.id = "net-" + i;
  div.dataset.net = n.name;
  if (n.vehicle) div.dataset.vehicle = n.vehicle;
  const by = page.nets.filter((m) => m.activates.includes(n.name)).map((m) => m.name);
  div.innerHTML = '<div class="net-head" title="open alone"><b>' + esc(n.name) + '</b><span class="state"></span>' +
    '<span class="now"></span><span class="activates">' + (n.activates.length ? "activates " + esc(n.activates.join(", ")) : "") +
    (by.length ? (n.activates.length ? " · " : "") + "activated by " + esc(by.join(", ")) : "") + "</span></div>" + n.svg;
  div.querySelector(".net-head").onclick = () => zoom(i);
  // Drawn at most 300 px high and as wide as the page allows, but never
  // below a scale its labels can be read at: a longer net scrolls in its
  // card, which follows its marked places (`follow`).
  const svg = div.querySelector("svg");
  const w = +svg.getAttribute("width"), h = +svg.getAttribute("height");
  const room = Math.max(($("left").clientWidth || 1000) - 30, 300);
  const k = Math.max(READABLE, Math.min(1, room / w, 300 / h));
  svg.setAttribute("width", (w * k).toFixed(0));
  svg.setAttribute("height", (h * k).toFixed(0));
  const body = document.createElement("div");
  body.className = "net-body";
  svg.replaceWith(body);
  body.appendChild(svg);
  // A person scrolling a net is left alone for a while.
  for (const ev of ["wheel", "pointerdown", "touchstart", "keydown"]) {
    body.addEventListener(ev, () => { body.dataset.touched = performance.now(); }, { passive: true });
  }
  div.addEventListener("click", pick);
  return div;
}

// The smallest scale a net is drawn at in its card: its 10-unit labels
// at 8.5 px or more.
const READABLE = 0.85;
// How long a net a person scrolled is not scrolled for them (ms).
const LEFT_ALONE_MS = 10000;

// Scrolls each net's card to its marked places when they leave its view
// (a long net is wider than the page at a readable scale).
function follow() {
  const now = performance.now();
  for (const body of document.querySelectorAll("#nets .net-body")) {
    if (body.scrollWidth <= body.clientWidth + 1 && body.scrollHeight <= body.clientHeight + 1) continue;
    if (now - (+body.dataset.touched || -1e9) < LEFT_ALONE_MS) continue;
    const marked = [...body.querySelectorAll("g.place.marked")];
    if (!marked.length) continue;
    const box = body.getBoundingClientRect();
    const rects = marked.map((m) => m.getBoundingClientRect());
    const left = Math.min(...rects.map((r) => r.left)), right = Math.max(...rects.map((r) => r.right));
    const top = Math.min(...rects.map((r) => r.top)), bottom = Math.max(...rects.map((r) => r.bottom));
    const inView = left >= box.left && right <= box.right && top >= box.top && bottom <= box.bottom;
    if (inView) continue;
    // The marked places' middle in the middle of the card.
    body.scrollLeft += (left + right) / 2 - (box.left + box.right) / 2;
    body.scrollTop += (top + bottom) / 2 - (box.top + box.bottom) / 2;
  }
}

function linkGlobal(name, on) {
  const id = "@" + name;
  for (const [eid, e] of Object.entries(byId)) {
    if (e.kind === "place" && e.def.name === id) {
      document.querySelectorAll('[id="' + eid + '"]').forEach((el) => el.classList.toggle("linked", on));
    }
  }
}

function pick(ev) {
  const el = ev.target.closest("g.place, g.transition");
  if (!el || !byId[el.id]) return;
  ev.stopPropagation();
  document.querySelectorAll(".selected").forEach((x) => x.classList.remove("selected"));
  document.querySelectorAll('[id="' + el.id + '"]').forEach((x) => x.classList.add("selected"));
  selected = el.id;
  define(byId[el.id]);
}

function define(e) {
  const d = e.def;
  const where = d.file ? "<code>" + esc(d.file) + (d.line ? ":" + d.line : "") + "</code>" : "";
  let h = "";
  if (e.kind === "transition") {
    const net = page.nets[e.net].name;
    const fired = frame ? frame.fired[d.flat] : 0;
    const enabled = frame && frame.enabled.includes(d.flat);
    h = "<b>transition " + esc(net) + "." + esc(d.name) + "</b> " + where +
      "<br>on <code>" + esc(d.event || "(immediate)") + "</code>" +
      (d.guard ? " when <code>" + esc(d.guard) + "</code>" : "") +
      "<br>from " + esc(d.inputs.join(", ")) + " → to " + esc(d.outputs.join(", ")) +
      (d.actions.length ? "<br>do:<br>" + d.actions.map((a) => "&nbsp;&nbsp;<code>" + esc(a) + "</code>").join("<br>") : "<br>no actions") +
      "<br><span class=muted>" + (enabled ? "enabled (waiting for its event)" : "not enabled") + "; fired " + fired + " times</span>";
  } else if (e.kind === "place") {
    const net = page.nets[e.net].name;
    const on = frame && frame.marked.includes(d.flat);
    h = "<b>place " + esc(net) + "." + esc(d.name) + "</b> " + where +
      (d.global ? "<br>a global place, shared by every net that names it" : "") +
      (d.initial ? "<br>initially marked" : "") + (d.final ? "<br>final" : "") +
      "<br><span class=muted>" + (on ? "MARKED" : "not marked") + "</span>";
  } else {
    h = "<b>global place @" + esc(d.name) + "</b> " + where + "<br>used by " + esc(d.nets.join(", "));
  }
  $("def-body").innerHTML = h;
}

// ---- the live part -----------------------------------------------------

function paint(root) {
  const marked = new Set(frame.marked);
  const enabled = new Set(frame.enabled);
  const now = performance.now();
  root.querySelectorAll("g.place, g.transition").forEach((el) => {
    const e = byId[el.id];
    if (!e) return;
    if (e.kind === "place") {
      el.classList.toggle("marked", marked.has(e.flat));
    } else {
      el.classList.toggle("enabled", enabled.has(e.flat));
      el.classList.toggle("fired", now - (firedAt[e.flat] || -1e9) < FLASH_MS);
    }
  });
}

function apply(f) {
  // Over a recording, a jump (scrubbing) flashes nothing: only playing
  // and stepping show what just fired.
  const near = page.mode === "live" || (frame && Math.abs(f.time_us - frame.time_us) <= 2e6);
  if (frame && f.fired && near) {
    const now = performance.now();
    f.fired.forEach((c, i) => { if (c > (frame.fired[i] || 0)) firedAt[i] = now; });
  }
  frame = f;
  $("clock").textContent = "t = " + seconds(f.t);
  $("step").textContent = "step " + f.seq;
  // The team's lockout, or some vehicles' own (a team project's).
  const lockedVehicles = f.locked || [];
  const banner = $("lockout");
  banner.hidden = !f.lockout && lockedVehicles.length === 0;
  banner.textContent = f.lockout || lockedVehicles.length === 0
    ? "CATASTROPHIC LOCKOUT: only catastrophic events are handled"
    : "CATASTROPHIC LOCKOUT @" + lockedVehicles.join(", @") + ": only catastrophic events of " + lockedVehicles.join(", ") + " are handled";
  page.nets.forEach((n, i) => {
    const div = $("net-" + i);
    const on = !!f.active[i];
    div.classList.toggle("inactive", !on);
    div.classList.toggle("locked", on && (f.lockout || (!!n.vehicle && lockedVehicles.includes(n.vehicle))));
    div.querySelector(".state").textContent = on ? "ACTIVE" : "inactive";
    // The marked places' names, large: the net's state read from afar.
    const names = n.places.filter((p) => !p.global && f.marked.includes(p.flat)).map((p) => p.name);
    div.querySelector(".now").textContent = on ? (names.join(", ") || "(no token)") : "";
    const sum = $("sum-" + i);
    sum.classList.toggle("inactive", !on);
    sum.querySelector("b").textContent = on ? (names.join(", ") || "(no token)") : "inactive";
  });
  for (const g of page.globals) $("g-" + g.flat).classList.toggle("marked", f.marked.includes(g.flat));
  paint(document);
  follow();
  const vs = f.vehicles || [];
  for (const v of vs) {
    const key = v.name || "";
    if (v.track_reset || !tracks[key]) tracks[key] = [];
    tracks[key] = tracks[key].concat(v.track || []);
  }
  if (vehicles.length) {
    for (const g of document.querySelectorAll(".group")) {
      const name = g.dataset.vehicle || null;
      const locked = f.lockout || (name !== null && lockedVehicles.includes(name));
      g.classList.toggle("locked", locked);
      g.querySelector(".g-lock").hidden = !locked;
    }
    for (const v of vs) groupStrip(v);
  } else {
    strip(vs[0]);
  }
  map(vs);
  log(f.log || [], f.log_reset, f.log_gap);
  if (f.mirror) mirror(f.mirror);
  if (page.mode !== "live") position(f.time_us);
}

function tile(id, value, cls) {
  const t = $(id);
  t.querySelector("b").textContent = value;
  t.className = "tile" + (cls ? " " + cls : "");
}

function strip(v) {
  if (!v) return;
  const n = (x, d, u) => (x === null || x === undefined) ? "–" : x.toFixed(d) + u;
  tile("v-mode", text(v.mode) || "–");
  tile("v-armed", v.armed === null ? "–" : (v.armed ? "ARMED" : "disarmed"), v.armed ? "warn" : "");
  tile("v-alt", n(v.alt, 1, " m"));
  tile("v-gs", n(v.ground_speed, 1, " m/s"));
  const b = v.battery_pct;
  tile("v-battery", (b === null ? "" : b + "% ") + n(v.battery_v, 1, " V"), b === null ? "" : (b < 20 ? "bad" : (b < 35 ? "warn" : "")));
  tile("v-gps", (text(v.gps_fix) || "–") + (v.satellites === null ? "" : " · " + v.satellites + " sats"),
    v.gps_fix && !/3D|RTK|DGPS/i.test(v.gps_fix) ? "bad" : "");
  tile("v-link", text(v.link).replace(" received", "") || "–");
  const age = v.heartbeat_age;
  tile("v-hb", age === null ? "never" : age.toFixed(1) + " s ago", age === null || age > 3 ? "bad" : (age > 1.5 ? "warn" : "good"));
}

// A vehicle's tiles in its group's head.
function groupStrip(v) {
  const k = vehicles.findIndex((x) => x.name === v.name);
  const g = k < 0 ? null : $("group-" + k);
  if (!g) return;
  const set = (c, value, cls) => {
    const t = g.querySelector("." + c);
    t.querySelector("b").textContent = value;
    t.className = "g-tile " + c + (cls ? " " + cls : "");
  };
  set("g-mode", text(v.mode) || "–");
  set("g-armed", v.armed === null ? "–" : (v.armed ? "ARMED" : "disarmed"), v.armed ? "warn" : "");
  set("g-position", v.position ? v.position[0].toFixed(5) + ", " + v.position[1].toFixed(5) : "–");
  const b = v.battery_pct;
  set("g-battery", b === null ? "–" : b + "%", b === null ? "" : (b < 20 ? "bad" : (b < 35 ? "warn" : "")));
  const age = v.heartbeat_age;
  set("g-hb", age === null ? "never" : age.toFixed(1) + " s ago", age === null || age > 3 ? "bad" : (age > 1.5 ? "warn" : "good"));
}

// Each vehicle's last events in its group's head, newest first.
function vehicleEvents(entries, reset) {
  if (!vehicles.length) return;
  if (reset) lastEvents = {};
  let touched = reset;
  for (const e of entries) {
    if (e.kind !== "event" || !e.vehicle) continue;
    const list = (lastEvents[e.vehicle] = lastEvents[e.vehicle] || []);
    list.unshift(e);
    if (list.length > LAST_EVENTS) list.pop();
    touched = true;
  }
  if (!touched) return;
  vehicles.forEach((v, k) => {
    const box = document.querySelector("#group-" + k + " .g-events");
    if (!box) return;
    const list = lastEvents[v.name] || [];
    box.innerHTML = list.length ? list.map((e) => '<span class="g-event ' + esc(e.category) + '">' +
      '<span class="t">' + e.t.toFixed(1) + "</span> " + esc(e.name) + "</span>").join("") : '<span class="muted">no event yet</span>';
  });
}

// Every vehicle on one map: each its track, marker, heading and (in a
// team) label, in its colour; home, waypoints, targets and sites too.
function map(vs) {
  const svg = $("map");
  const team = vehicles.length > 0;
  const shown = vs.map((v) => {
    const k = team ? vehicles.findIndex((x) => x.name === v.name) : 0;
    return { v, k, colour: team ? (k < 0 ? "#555" : vehicles[k].colour) : "#06c", track: tracks[v.name || ""] || [] };
  });
  const pts = [];
  const add = (p) => { if (p) pts.push(p); };
  for (const { v, track } of shown) {
    track.forEach(add);
    add(v.position); add(v.home);
    (v.waypoints || []).forEach(add); (v.sites || []).forEach(add); (v.targets || []).forEach(add);
  }
  if (!pts.length) { svg.innerHTML = '<text x="200" y="130" text-anchor="middle" fill="#777">no position yet</text>'; return; }
  let [la0, la1, lo0, lo1] = [90, -90, 180, -180];
  for (const p of pts) { la0 = Math.min(la0, p[0]); la1 = Math.max(la1, p[0]); lo0 = Math.min(lo0, p[1]); lo1 = Math.max(lo1, p[1]); }
  const k = Math.cos((la0 + la1) / 2 * Math.PI / 180);
  const w = Math.max((lo1 - lo0) * k, 1e-4), h = Math.max(la1 - la0, 1e-4);
  const s = Math.min(360 / w, 220 / h);
  const cx = (lo0 + lo1) / 2, cy = (la0 + la1) / 2;
  const X = (p) => (200 + (p[1] - cx) * k * s).toFixed(1);
  const Y = (p) => (130 - (p[0] - cy) * s).toFixed(1);
  let o = "";
  // A scale bar: a round number of metres.
  const mPerUnit = 111320 / s;
  let bar = Math.pow(10, Math.floor(Math.log10(mPerUnit * 100)));
  if (bar / mPerUnit < 40) bar *= 5;
  o += '<line x1="10" y1="250" x2="' + (10 + bar / mPerUnit).toFixed(1) + '" y2="250" stroke="#333" stroke-width="3"/>' +
    '<text x="12" y="245" font-size="11">' + (bar >= 1000 ? bar / 1000 + " km" : bar + " m") + "</text>";
  for (const { v, colour: c } of shown) {
    if (v.waypoints && v.waypoints.length) {
      o += '<polyline fill="none" stroke="' + (team ? c : "#777") + '" stroke-dasharray="4 3" points="' + v.waypoints.map((p) => X(p) + "," + Y(p)).join(" ") + '"/>';
      v.waypoints.forEach((p, i) => {
        o += '<circle cx="' + X(p) + '" cy="' + Y(p) + '" r="5" fill="#fff" stroke="#333"><title>' + esc(p[2]) + "</title></circle>" +
          '<text x="' + (+X(p) + 6) + '" y="' + (+Y(p) - 5) + '" font-size="10" fill="#333">' + (i + 1) + "</text>";
      });
    }
  }
  for (const { v, colour: c, track } of shown) {
    if (track.length > 1) o += '<polyline class="track" data-vehicle="' + esc(v.name || "") + '" fill="none" stroke="' + c + '" stroke-width="2.5" points="' + track.map((p) => X(p) + "," + Y(p)).join(" ") + '"/>';
    if (v.home) o += '<rect x="' + (X(v.home) - 6) + '" y="' + (Y(v.home) - 6) + '" width="12" height="12" fill="' + (team ? c : "#2a2") + '"/><text x="' + (+X(v.home) + 8) + '" y="' + (+Y(v.home) + 4) + '" font-size="11" font-weight="bold">H</text>';
    // A team's sites are many (a planner's every answer): named on hover.
    for (const p of v.sites || []) {
      o += '<path d="M ' + X(p) + " " + (Y(p) - 8) + " l 7 12 l -14 0 z\" fill=\"" + (team ? c : "#d00") + "\"><title>" + esc(p[2]) + "</title></path>" +
        (team ? "" : '<text x="' + (+X(p) + 8) + '" y="' + (+Y(p) + 4) + '" font-size="10" fill="#a00">' + esc(p[2]) + "</text>");
    }
    for (const p of v.targets || []) o += '<circle cx="' + X(p) + '" cy="' + Y(p) + '" r="7" fill="none" stroke="' + (team ? c : "#c0c") + '" stroke-width="2"><title>' + esc(p[2]) + "</title></circle>";
  }
  for (const { v, colour: c } of shown) {
    if (!v.position) continue;
    const hd = (v.heading || 0) * Math.PI / 180;
    const x = +X(v.position), y = +Y(v.position);
    o += '<g class="marker" data-vehicle="' + esc(v.name || "") + '" data-lat="' + v.position[0] + '" data-lon="' + v.position[1] + '">' +
      '<circle cx="' + x + '" cy="' + y + '" r="7" fill="' + c + '" stroke="#fff" stroke-width="2"/>' +
      '<line x1="' + x + '" y1="' + y + '" x2="' + (x + 16 * Math.sin(hd)).toFixed(1) + '" y2="' + (y - 16 * Math.cos(hd)).toFixed(1) + '" stroke="' + c + '" stroke-width="3"/>' +
      (team && v.name ? '<text x="' + (x + 9) + '" y="' + (y - 9) + '" font-size="12" font-weight="bold" fill="' + c + '">' + esc(v.name) + "</text>" : "") + "</g>";
  }
  svg.innerHTML = o;
}

function row(e) {
  const div = document.createElement("div");
  let cls = "row", what = "";
  const kind = (k) => '<span class="kind">' + k + "</span>";
  switch (e.kind) {
    case "event": {
      cls += " " + e.category;
      what = '<span class="cat ' + e.category + '">' + esc(e.category) + "</span><b>" + esc(e.name) + "</b>" + esc(params(e.params));
      if (e.fired && e.fired.length) what += ' <span class="out">→ fired ' + esc(e.fired.join(", ")) + "</span>";
      else if (e.dropped) what += ' <span class="drop">→ dropped: ' + esc(e.dropped) + "</span>";
      else what += ' <span class="muted">→ nothing waiting</span>';
      break;
    }
    case "command": what = kind("command") + "<b>" + esc(e.name) + "</b>" + esc(params(e.params)) + ' <span class="muted">(' + esc(e.net) + ", #" + e.id + ")</span>"; break;
    case "call": what = kind("call") + "<b>" + esc(e.name) + "</b>" + esc(params(e.params)) + ' <span class="muted">(' + esc(e.net) + ", #" + e.id + ")</span>"; break;
    case "result":
      what = kind("result") + "<b>" + esc(e.of || "#" + e.id) + "</b> " +
        (e.ok ? '<span class="out">done' + esc(params(e.detail)) + "</span>" : '<span class="fail">failed: ' + esc(e.detail) + "</span>") +
        (e.fired && e.fired.length ? ' <span class="out">→ fired ' + esc(e.fired.join(", ")) + "</span>" : "");
      break;
    case "answer":
      what = kind("answer") + "<b>#" + esc(e.id) + "</b> " + esc(e.choice) +
        (e.fired && e.fired.length ? ' <span class="out">→ fired ' + esc(e.fired.join(", ")) + "</span>" : "");
      break;
    case "question": what = kind("question") + "<b>" + esc(e.name) + "</b> " + esc(e.question) + ' <span class="muted">(' + esc((e.choices || []).join(" / ")) + ", #" + e.id + ")</span>"; break;
    case "timer": what = kind("timer") + esc(e.name) + " expired"; break;
    case "net": what = kind("net") + esc(e.name) + " " + esc(e.what); break;
    case "fired": what = kind("fired") + esc(e.name); break;
    // A new version of the project took over; a version sent up (mirror).
    case "version": case "push": what = kind(e.kind) + esc(e.text); break;
    default: cls += " fault"; what = kind(e.kind) + esc(e.text || JSON.stringify(e));
  }
  div.className = cls;
  div.dataset.kind = e.kind;
  div.innerHTML = '<span class="t">' + e.t.toFixed(1) + '</span><span class="what">' + what + "</span>";
  return div;
}

function log(entries, reset, gap) {
  const box = $("log");
  if (reset) { box.innerHTML = ""; logRows = 0; }
  if (gap) {
    const g = document.createElement("div");
    g.className = "row muted";
    g.innerHTML = '<span class="t"></span><span class="what">… entries skipped (the page fell behind)</span>';
    box.prepend(g);
  }
  for (const e of entries) { box.prepend(row(e)); logRows++; }
  vehicleEvents(entries, reset);
  while (box.childElementCount > 500) box.lastElementChild.remove();
  $("log-count").textContent = "(" + logRows + ")";
}

// ---- the mirror: agreement, questions, the independent check ---------

let answering = { can: false, why: null };   // from GET /answer
const asking = {};         // question id -> an answer in flight (its status text)

function mirrorBuild() {
  $("mirror").hidden = false;
  $("disagreements-panel").hidden = false;
  fetch("answer").then((r) => r.json()).then((a) => { answering = a; })
    .catch(() => { answering = { can: false, why: "cannot ask the mirror whether answers are taken" }; });
}

function mirror(m) {
  // The banner: the replica against the vehicle, readable across a room.
  const a = $("agreement");
  a.className = m.agreement;
  let state = "", detail = "";
  const agreed = m.agreed === null ? "none yet" : "step " + m.agreed + (m.digest ? " · digest " + m.digest : "");
  switch (m.agreement) {
    case "exact":
      state = "REPLICA EXACT";
      detail = "agrees with the vehicle · last agreed " + agreed +
        (m.resynced && m.resynced.how !== "start" ? " · resynced by " + m.resynced.how + " after " + m.resynced.after_s.toFixed(1) + " s" : "");
      break;
    case "provisional":
      state = "PROVISIONAL";
      detail = (!m.gap ? "records" : m.gap.to - m.gap.from > 1 ? "records " + m.gap.from + "–" + (m.gap.to - 1) : "record " + m.gap.from) + " lost on the radio: advanced by the ground's own telemetry until repaired · last agreed " + agreed;
      break;
    case "diverged":
      state = "DIVERGED";
      detail = (m.diverged ? "at step " + m.diverged.step + ": " + m.diverged.reason : "") + " · last agreed " + agreed + " · resyncing";
      break;
    default:
      state = "WAITING";
      detail = "for the vehicle's gateway (petrel run --downlink)";
  }
  // Nothing heard for a while: what is shown is as of the last record.
  if (m.silent_s !== null && m.silent_s > 3 && m.agreement !== "waiting") {
    a.className = m.agreement === "exact" ? "silent" : m.agreement;
    const silent = "nothing heard from the vehicle for " + m.silent_s.toFixed(0) + " s · shown as of step " + (m.step === null ? "–" : m.step);
    if (m.agreement === "exact") { state = "NO DOWNLINK"; detail = silent + " · last agreed " + agreed; } else detail = silent + " · " + detail;
  }
  // A signed downlink: what was refused (forged, replayed) is said.
  const signed = !m.signatures ? "" : " · downlink signed: " + (m.signatures.unsigned + m.signatures.bad_signature + m.signatures.replayed + m.signatures.stale === 0 ? "none refused" :
    [["unsigned", m.signatures.unsigned], ["bad signature", m.signatures.bad_signature], ["replayed", m.signatures.replayed], ["stale", m.signatures.stale]]
      .filter((r) => r[1] > 0).map((r) => r[1] + " " + r[0]).join(", ") + " refused");
  $("agreement-state").textContent = state;
  $("agreement-detail").textContent = detail + (m.vehicle_t === null ? "" : " · vehicle t = " + m.vehicle_t.toFixed(1) + " s") + signed;
  questions(m);
  const box = $("disagreements");
  const key = JSON.stringify(m.disagreements);
  if (box.dataset.key !== key) {
    box.dataset.key = key;
    box.innerHTML = m.disagreements.length ? m.disagreements.map((d) =>
      '<div class="disagreement"><b>' + esc(d.event) + "</b> seen by the " + esc(d.seen_by) + " only at " + d.t.toFixed(1) +
      " s (window ±" + d.window_s + " s)" +
      '<div class="side"><span>' + esc(d.seen_by) + "</span><code>" + esc(d.t.toFixed(2) + " s" + params(d.params)) + "</code></div>" +
      '<div class="side"><span>' + esc(d.other) + "</span><code>" + (d.other_t === null ? "none within the window" :
        "nearest at " + esc(d.other_t.toFixed(2) + " s" + params(d.other_params))) + "</code></div></div>").join("")
      : '<span class="muted">the ground\'s telemetry agrees with the vehicle\'s events</span>';
  }
  $("disagreement-count").textContent = "(" + m.disagreements_total + " disagreements)";
}

function questions(m) {
  const box = $("questions");
  const open = new Set(m.questions.map((q) => "q-" + q.id));
  for (const el of [...box.querySelectorAll(".question.open")]) if (!open.has(el.id)) el.remove();
  for (const q of m.questions) {
    let el = $("q-" + q.id);
    if (!el) {
      el = document.createElement("div");
      el.className = "question open";
      el.id = "q-" + q.id;
      el.dataset.id = q.id;
      el.innerHTML = '<div class="ask"><small></small><b></b></div><div class="left"></div><div class="choices"></div><div class="status"></div>';
      el.querySelector("small").textContent = "question #" + q.id + " from " + q.net + " · deadline t = " + q.deadline.toFixed(1) + " s (vehicle)";
      el.querySelector("b").textContent = q.question;
      const choices = el.querySelector(".choices");
      for (const c of q.choices) {
        const b = document.createElement("button");
        b.textContent = c;
        b.dataset.choice = c;
        b.onclick = () => answer(q.id, c);
        choices.appendChild(b);
      }
      box.prepend(el);
    }
    const left = el.querySelector(".left");
    left.textContent = q.left === null ? "–" : Math.ceil(q.left) + " s";
    left.classList.toggle("urgent", q.left !== null && q.left <= 10);
    const can = answering.can && q.fate === "pending" && !asking[q.id];
    el.querySelectorAll("button").forEach((b) => { b.hidden = !answering.can; b.disabled = !can; });
    const status = el.querySelector(".status");
    let said = "", bad = false;
    if (!answering.can) said = answering.why ? "read-only: " + answering.why : "";
    else if (asking[q.id]) { said = asking[q.id].text; bad = asking[q.id].bad; }
    else if (q.fate === "sent") said = "“" + q.choice + "” sent, signed — waiting for the vehicle";
    if (q.not_sent && !asking[q.id]) { said = q.not_sent; bad = true; }
    status.textContent = said;
    status.classList.toggle("bad", bad);
    el.dataset.fate = q.fate;
  }
  // The last questions closed, and what became of them.
  const closed = m.closed.map((q) => {
    const what = { answered: "ANSWERED “" + q.choice + "”", timed_out: "TIMED OUT", closed: "closed",
      refused: "refused on board: “" + q.choice + "” " + q.reason }[q.fate] || q.fate;
    return '<div class="question closed ' + q.fate + '" id="done-' + q.id + '" data-id="' + q.id + '" data-fate="' + q.fate + '">' +
      '<div class="ask"><small>question #' + q.id + " from " + esc(q.net) + "</small><b>" + esc(q.question) + '</b></div><div class="status">' + esc(what) + "</div></div>";
  }).join("");
  let done = $("closed-questions");
  if (!done) { done = document.createElement("div"); done.id = "closed-questions"; box.appendChild(done); }
  if (done.dataset.key !== closed) { done.dataset.key = closed; done.innerHTML = closed; }
}

// The answer goes to the mirror, which sends it as one typed on its stdin.
function answer(id, choice) {
  // The desk's verdict is shown at once, not at the next frame: with the
  // vehicle silent, that may be a while.
  const repaint = () => { if (frame && frame.mirror) questions(frame.mirror); };
  asking[id] = { text: "sending “" + choice + "”…", bad: false };
  repaint();
  fetch("answer", {
    method: "POST",
    headers: { "Content-Type": "application/json", "X-Petrel-Answer": "1" },
    body: JSON.stringify({ id: id, choice: choice }),
  }).then((r) => r.json()).then((r) => {
    delete asking[id];
    if (!r.sent) asking[id] = { text: r.error, bad: true };
    setTimeout(() => { if (asking[id] && asking[id].bad) { delete asking[id]; repaint(); } }, 5000);
    repaint();
  }).catch((e) => { asking[id] = { text: "not sent: " + e, bad: true }; repaint(); });
}

// ---- one net alone, zoomable and pannable -------------------------------

function zoom(i) {
  const view = $("zoom-view");
  view.innerHTML = page.nets[i].svg;
  $("zoom-title").textContent = page.nets[i].name;
  $("zoom").hidden = false;
  const svg = view.querySelector("svg");
  svg.removeAttribute("width"); svg.removeAttribute("height");
  let vb = svg.getAttribute("viewBox").split(" ").map(Number);
  const set = () => svg.setAttribute("viewBox", vb.map((x) => x.toFixed(1)).join(" "));
  svg.addEventListener("wheel", (ev) => {
    ev.preventDefault();
    const r = svg.getBoundingClientRect();
    const f = ev.deltaY > 0 ? 1.15 : 1 / 1.15;
    const px = vb[0] + (ev.clientX - r.left) / r.width * vb[2], py = vb[1] + (ev.clientY - r.top) / r.height * vb[3];
    vb = [px - (px - vb[0]) * f, py - (py - vb[1]) * f, vb[2] * f, vb[3] * f];
    set();
  }, { passive: false });
  let drag = null;
  svg.addEventListener("mousedown", (ev) => { drag = [ev.clientX, ev.clientY, vb[0], vb[1]]; });
  window.onmouseup = () => { drag = null; };
  svg.addEventListener("mousemove", (ev) => {
    if (!drag) return;
    const r = svg.getBoundingClientRect();
    const k = Math.max(vb[2] / r.width, vb[3] / r.height);
    vb[0] = drag[2] - (ev.clientX - drag[0]) * k; vb[1] = drag[3] - (ev.clientY - drag[1]) * k;
    set();
  });
  view.onclick = pick;
  if (frame) paint(view);
}
function unzoom() { $("zoom").hidden = true; $("zoom-view").innerHTML = ""; }

// ---- a recording: the timeline -----------------------------------------

let playing = false, at = 0, asked = false, wanted = null, lastTick = 0;

function timeline() {
  const tl = page.timeline;
  $("timeline").hidden = false;
  const span = Math.max(tl.end - tl.start, 1e-6);
  const marks = $("marks");
  marks.setAttribute("viewBox", "0 0 1000 26");
  let o = "";
  const colour = { catastrophic: "#f22", safety: "#f90", communication: "#b8f", mission: "#6af", nominal: "#9a9", fault: "#fff", lockout: "#f22" };
  for (const [t, cat, name] of tl.marks) {
    const x = ((t - tl.start) / span * 1000).toFixed(2);
    const big = cat === "catastrophic" || cat === "lockout" || cat === "fault";
    o += '<rect x="' + x + '" y="' + (big ? 0 : 12) + '" width="' + (big ? 3 : 1) + '" height="' + (big ? 26 : 14) +
      '" fill="' + (colour[cat] || "#ccc") + '"><title>' + t.toFixed(1) + " s " + esc(name) + " [" + cat + "]</title></rect>";
  }
  marks.innerHTML = o;
  at = tl.start_us;
  const scrub = $("scrub");
  scrub.oninput = () => { playing = false; $("play").textContent = "▶"; ask(tl.start_us + (tl.end_us - tl.start_us) * scrub.value / 1000); };
  $("play").onclick = () => { playing = !playing; $("play").textContent = playing ? "⏸" : "▶"; lastTick = performance.now(); if (playing && at >= tl.end_us) ask(tl.start_us); };
  $("prev").onclick = () => step(-1);
  $("next").onclick = () => step(1);
  document.addEventListener("keydown", (ev) => {
    if (ev.key === " ") { ev.preventDefault(); $("play").click(); }
    if (ev.key === "ArrowLeft") step(-1);
    if (ev.key === "ArrowRight") step(1);
    if (ev.key === "Escape") unzoom();
  });
  requestAnimationFrame(tick);
}

function position(t) {
  const tl = page.timeline;
  at = t;
  $("scrub").value = ((t - tl.start_us) / Math.max(tl.end_us - tl.start_us, 1) * 1000).toFixed(2);
  $("span").textContent = ((t - tl.origin_us) / 1e6).toFixed(1) + " / " + tl.end.toFixed(1) + " s";
}

function send(m) { if (socket && socket.readyState === 1) { socket.send(JSON.stringify(m)); asked = true; } }
// One question at a time: the latest wins (coalesced).
function ask(t) { wanted = Math.round(t); if (!asked) { send({ at: wanted }); wanted = null; } }
function step(dir) { playing = false; $("play").textContent = "▶"; send({ at: Math.round(at), step: dir }); }

function tick(now) {
  const tl = page.timeline;
  if (playing) {
    const dt = (now - lastTick) * 1000 * Number($("speed").value);
    const t = Math.min((wanted === null ? at : wanted) + dt, tl.end_us);
    ask(t);
    if (t >= tl.end_us) { playing = false; $("play").textContent = "▶"; }
  }
  lastTick = now;
  requestAnimationFrame(tick);
}

// ---- the connection ----------------------------------------------------

function connect() {
  socket = new WebSocket((location.protocol === "https:" ? "wss://" : "ws://") + location.host + "/ws");
  socket.onopen = () => { $("connection").textContent = "connected"; $("connection").className = "badge"; };
  socket.onmessage = (m) => {
    asked = false;
    const f = JSON.parse(m.data);
    // A recording's page loaded again at an instant: the first frame is
    // the start's; the instant is asked for, and drawn when it comes.
    if (startAt !== null) {
      const t = startAt;
      startAt = null;
      ask(t);
      if (f.page !== undefined && f.page !== drawnPage) return;
    }
    // Another version of the project's nets (one took over in flight):
    // the page loads again with it — a recording's at the same instant.
    if (f.page !== undefined && drawnPage !== null && f.page !== drawnPage) {
      if (page.mode !== "live") location.hash = "v=" + f.page + "&at=" + f.time_us;
      location.reload();
      return;
    }
    if (f.page !== undefined) drawnPage = f.page;
    apply(f);
    if (wanted !== null) { send({ at: wanted }); wanted = null; }
  };
  socket.onclose = () => {
    $("connection").textContent = page.mode === "live" ? "disconnected (the gateway stopped?)" : "disconnected";
    $("connection").className = "badge off";
    setTimeout(connect, 2000);
  };
}

$("zoom-close").onclick = unzoom;
document.addEventListener("keydown", (ev) => { if (ev.key === "Escape") unzoom(); });
setInterval(() => { if (frame) { paint(document); if (!$("zoom").hidden) paint($("zoom-view")); } }, 250);
// The page number drawn (`page` of the frames): another means a new
// version of the project replaced the nets. A recording's page loaded
// again for another version says which, and the instant, in its hash.
const hash = new URLSearchParams(location.hash.slice(1));
let drawnPage = Number.isInteger(Number(hash.get("v"))) && hash.has("v") ? Number(hash.get("v")) : null;
let startAt = Number.isFinite(Number(hash.get("at"))) && hash.has("at") ? Number(hash.get("at")) : null;
const version = hash.has("v") ? "?v=" + encodeURIComponent(hash.get("v")) : "";
fetch("page.json" + version).then((r) => r.json()).then((p) => {
  page = p;
  // `petrel edit`: the editor (edit.js, fetched only then) draws the page.
  if (p.mode === "edit") { const s = document.createElement("script"); s.src = "edit.js"; document.head.appendChild(s); return; }
  build(); connect();
})
  .catch((e) => { document.body.innerHTML = "<p>cannot load the page: " + esc(e) + "</p>"; });
