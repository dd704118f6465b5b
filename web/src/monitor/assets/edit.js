// Petrel editor (`petrel edit`): the monitor's page in editing mode. Loaded
// by monitor.js when /page.json says mode "edit"; draws each net from the
// draft (positions from the server: stored or laid out), sends each edit
// to POST /edit and redraws once it is answered, and redraws from
// /page.json when /version changes otherwise (the background check's
// verdict, another client's edit or reload).
// Plain JavaScript, no library, no build step.
"use strict";

const ED = {
  tool: "select",
  sel: null,            // {net, kind, name}
  arcFrom: null,        // {net, kind, name}: the first end of an arc being drawn
  drag: null,
  version: -1,
  step: 0,              // the counterexample's moment shown
  checkKey: "",
  busy: false,
  renaming: null,       // {net, to}: a net's rename form, open
  draws: 0,             // times the nets were drawn (the browser test counts them)
  posts: 0,             // requests of this page in flight: each draws what it did
  loads: 0,             // page.json fetches started (the last one's wins)
};
const RADIUS = 14, BAR_W = 8, BAR_H = 34;

function idPart(s) { return String(s).replace(/[^A-Za-z0-9-]/g, "_"); }
function elementId(net, kind, name) { return (kind === "place" ? "p-" : "t-") + idPart(net) + "-" + idPart(name); }
function attr(s) { return esc(s); }

// ---- the page's frame ---------------------------------------------------

function editorFrame() {
  document.body.classList.add("editing");
  const link = document.createElement("link");
  link.rel = "stylesheet"; link.href = "edit.css";
  document.head.appendChild(link);
  $("mode").textContent = "EDIT";
  $("mode").className = "badge edit";
  $("connection").hidden = true;
  $("clock").textContent = "";
  $("step").textContent = "";
  const bar = document.createElement("div");
  bar.id = "toolbar";
  bar.innerHTML =
    '<span class="group">' +
    ["select:Select / move", "place:Place", "transition:Transition", "arc:Arc", "delete:Delete"].map((x) => {
      const [k, label] = x.split(":");
      return '<button id="tool-' + k + '" data-tool="' + k + '">' + label + "</button>";
    }).join("") + "</span>" +
    '<button id="undo" title="nothing to undo" disabled>Undo</button>' +
    '<button id="redo" title="nothing to redo" disabled>Redo</button>' +
    '<span id="hint" class="muted"></span>' +
    '<button id="net-add-open" title="add a net to the project: a new file NAME.toml">+ net</button>' +
    '<span id="net-add" hidden><input id="net-name" placeholder="NAME" size="14" spellcheck="false"> ' +
    '<label><input type="checkbox" id="net-active" checked> active at start</label> ' +
    '<button id="net-add-go">add</button><button id="net-add-close" title="cancel">×</button></span>' +
    '<button id="reload" title="read every file again from disk">Reload</button>';
  $("left").prepend(bar);
  bar.querySelectorAll("[data-tool]").forEach((b) => { b.onclick = () => setTool(b.dataset.tool); });
  $("reload").onclick = () => post("reload", {});
  $("undo").onclick = undo;
  $("redo").onclick = redo;
  $("net-add-open").onclick = () => { $("net-add").hidden = false; $("net-add-open").hidden = true; $("net-name").focus(); };
  $("net-add-close").onclick = () => { $("net-add").hidden = true; $("net-add-open").hidden = false; };
  $("net-add-go").onclick = addNet;
  $("net-name").onkeydown = (ev) => { if (ev.key === "Enter") addNet(); if (ev.key === "Escape") $("net-add-close").onclick(); };
  const msg = document.createElement("div");
  msg.id = "edit-message"; msg.hidden = true;
  $("left").prepend(msg);
  const aside = document.querySelector("aside");
  aside.innerHTML =
    '<div class="panel" id="check-panel"><h2>Check</h2><div id="check-state" data-state="none">–</div>' +
    '<div id="cx" hidden><div id="cx-title"></div><div class="cx-bar"><button id="cx-prev">◀ step</button>' +
    '<span id="cx-pos"></span><button id="cx-next">step ▶</button></div><div id="cx-label"></div></div></div>' +
    '<div class="panel" id="element-panel"><h2>Element</h2><div id="element-form" class="muted">Click a place or a transition; pick a tool above to add.</div></div>' +
    '<div class="panel grow"><h2>Problems <span id="problem-count" class="muted"></span></h2><div id="problems"></div></div>' +
    '<div class="panel" id="stubs-panel"><h2>Program stubs</h2>' +
    '<select id="stubs-lang"><option value="python">Python</option><option value="rust">Rust</option></select> ' +
    'into <input id="stubs-out" value="stubs" size="10"> <label><input type="checkbox" id="stubs-force"> overwrite</label> ' +
    '<button id="stubs-go">Generate</button><div id="stubs-result" class="muted"></div></div>';
  $("cx-prev").onclick = () => { showStep(ED.step - 1); reveal(); };
  $("cx-next").onclick = () => { showStep(ED.step + 1); reveal(); };
  $("stubs-go").onclick = stubs;
  document.addEventListener("keydown", (ev) => {
    // In a field, Ctrl-Z is the field's own.
    if (ev.target.closest("input, textarea, select")) return;
    if ((ev.ctrlKey || ev.metaKey) && !ev.altKey) {
      const k = ev.key.toLowerCase();
      if (k === "z" && !ev.shiftKey) { ev.preventDefault(); undo(); return; }
      if ((k === "z" && ev.shiftKey) || k === "y") { ev.preventDefault(); redo(); return; }
    }
    if ((ev.key === "Delete" || ev.key === "Backspace") && ED.sel) remove(ED.sel);
    if (ev.key === "Escape") { ED.arcFrom = null; select(null); }
  });
  window.addEventListener("mousemove", dragMove);
  window.addEventListener("mouseup", dragEnd);
  setTool("select");
}

function setTool(t) {
  ED.tool = t;
  ED.arcFrom = null;
  document.querySelectorAll("#toolbar [data-tool]").forEach((b) => b.classList.toggle("on", b.dataset.tool === t));
  const hints = {
    select: "drag a node to move it; click it to edit it",
    place: "click an empty spot of a net to add a place there",
    transition: "click an empty spot of a net to add a transition there",
    arc: "click a place then a transition (an input), or a transition then a place (an output)",
    delete: "click a place, a transition or an arc to delete it",
  };
  $("hint").textContent = hints[t];
  document.body.dataset.tool = t;
  markArcFrom();
}

function say(text, conflict) {
  const m = $("edit-message");
  if (!text) { m.hidden = true; return; }
  m.hidden = false;
  m.className = conflict ? "conflict" : "";
  m.innerHTML = esc(text) + (conflict ? ' <button id="conflict-reload">Reload from disk</button>' : "") +
    ' <button id="message-close">×</button>';
  if (conflict) $("conflict-reload").onclick = () => post("reload", {});
  $("message-close").onclick = () => say(null);
}

// ---- talking to the server ----------------------------------------------

// A request of the page's own, then one redraw (also after a refusal: a
// node dragged goes back). `answered(a)`, if given, runs before it. While
// it is in flight the poll draws nothing: the version it would see is
// this request's.
async function post(path, body, answered) {
  ED.posts++;
  try {
    let r;
    try {
      r = await fetch(path, { method: "POST", headers: { "content-type": "application/json" }, body: JSON.stringify(body) });
    } catch (e) { say("the editor is not answering: " + e); return false; }
    const a = await r.json().catch(() => ({ ok: false, error: "HTTP " + r.status }));
    if (a.ok) say(null); else say(a.error, a.conflict);
    if (answered) answered(a);
    await refresh(true);
    return a;
  } finally {
    ED.posts--;
  }
}
function edit(op, answered) { return post("edit", op, answered); }

// The session's last edit undone: its files back to their bytes before it.
async function undo() {
  if (!page.undo) return;
  const a = await post("undo", {});
  if (a.ok) say("undone: " + a.undone);
}

async function redo() {
  if (!page.redo) return;
  const a = await post("redo", {});
  if (a.ok) say("redone: " + a.redone);
}

async function addNet() {
  const name = $("net-name").value.trim();
  const a = await edit({ op: "add_net", name, active: $("net-active").checked });
  if (!a.ok) return;
  $("net-name").value = "";
  $("net-add-close").onclick();
  const div = document.querySelector('#nets .net[data-net="' + CSS.escape(name) + '"]');
  if (div) div.scrollIntoView({ block: "nearest" });
}

// A net renamed: its file's `name`, the actions naming it, its file if
// named after it (the server's rules; a refusal says why, the form stays).
async function renameNet(net) {
  const to = ED.renaming ? ED.renaming.to.trim() : "";
  // Closed before the edit's redraw (one draw, without the form).
  await edit({ op: "rename_net", name: net, to }, (a) => { if (a.ok) ED.renaming = null; });
}

// A net deleted, once confirmed: its [[net]] table and its file (Undo
// brings both back). Refused by the server while other nets name it.
async function deleteNet(n) {
  const sure = window.confirm("Delete net " + n.name + "? Its [[net]] table leaves project.toml and " + n.file +
    " is removed (Undo brings both back).");
  if (!sure) return;
  await edit({ op: "delete_net", name: n.name });
}

// A net active at start or not: its [[net]] table's `active` in
// project.toml (a refusal says why; the redraw shows the value on disk).
async function setActive(net, active) {
  await edit({ op: "set_active", name: net, active });
}

// The page drawn again from /page.json: always for the page's own request
// (`own`); for the poll's, not when a request of the page's is in flight
// or has fetched since (it draws what it did, a newer page), nor for the
// version drawn already, nor under a node being dragged.
async function refresh(own) {
  const load = ++ED.loads;
  const p = await (await fetch("page.json")).json();
  if (!own && (ED.posts || load !== ED.loads || p.version === ED.version || ED.drag)) return;
  page = p;
  ED.version = p.version;
  draw();
}

async function poll() {
  try {
    const v = await (await fetch("version")).json();
    if (v.version !== ED.version && !ED.drag && !ED.posts) await refresh(false);
  } catch (e) { /* the editor stopped: keep trying */ }
  setTimeout(poll, 500);
}

// ---- drawing --------------------------------------------------------------

function netOf(name) { return page.nets.find((n) => n.name === name); }
function nodeOf(net, kind, name) {
  const n = netOf(net);
  if (!n) return null;
  return (kind === "place" ? n.places : n.transitions).find((x) => x.name === name) || null;
}
function problemsOf(net, kind, name) {
  return page.problems.filter((p) => p.net === net && (kind === undefined ? !p.kind : p.kind === kind && p.name === name));
}

function trim(from, to, r) {
  const dx = to[0] - from[0], dy = to[1] - from[1];
  const len = Math.max(Math.hypot(dx, dy), 1e-9);
  return [to[0] - dx / len * r, to[1] - dy / len * r];
}

function netSvg(n) {
  const pos = {};
  for (const p of n.places) pos["place:" + p.name] = [p.x, p.y];
  for (const t of n.transitions) pos["transition:" + t.name] = [t.x, t.y];
  if (ED.drag && ED.drag.net === n.name && ED.drag.moved) pos[ED.drag.kind + ":" + ED.drag.name] = ED.drag.at;
  let w = n.width, h = n.height;
  for (const k in pos) { w = Math.max(w, pos[k][0] + 40); h = Math.max(h, pos[k][1] + 40); }
  let o = '<svg xmlns="http://www.w3.org/2000/svg" class="edit-net" data-net="' + attr(n.name) + '" width="' + w.toFixed(0) + '" height="' + h.toFixed(0) +
    '" viewBox="0 0 ' + w.toFixed(0) + " " + h.toFixed(0) + '" font-family="Helvetica, Arial, sans-serif" font-size="10">' +
    '<defs><marker id="arrow-' + idPart(n.name) + '" viewBox="0 0 10 10" refX="10" refY="5" markerWidth="7" markerHeight="7" orient="auto-start-reverse"><path d="M 0 0 L 10 5 L 0 10 z" fill="#444"/></marker></defs>';
  o += '<rect class="canvas" x="0" y="0" width="' + w.toFixed(0) + '" height="' + h.toFixed(0) + '" fill="transparent"/>';
  for (const a of n.arcs) {
    const pk = "place:" + a.place, tk = "transition:" + a.transition;
    const moved = ED.drag && ED.drag.net === n.name && ED.drag.moved && (ED.drag.kind + ":" + ED.drag.name === pk || ED.drag.kind + ":" + ED.drag.name === tk);
    let pts = moved ? (a.input ? [pos[pk], pos[tk]] : [pos[tk], pos[pk]]) : a.points.map((p) => p.slice());
    // A straight arc with one back the other way (a place tested and
    // kept): each drawn a little to its side, not on top of the other.
    if (pts.length === 2 && n.arcs.some((b) => b.place === a.place && b.transition === a.transition && b.input !== a.input)) {
      const dx = pts[1][0] - pts[0][0], dy = pts[1][1] - pts[0][1], len = Math.max(Math.hypot(dx, dy), 1e-9);
      const ox = -dy / len * 5, oy = dx / len * 5;
      pts = pts.map((p) => [p[0] + ox, p[1] + oy]);
    }
    if (pts.length >= 2) {
      const rFrom = a.input ? RADIUS + 1 : BAR_W / 2 + 1, rTo = a.input ? BAR_W / 2 + 1 : RADIUS + 1;
      pts[pts.length - 1] = trim(pts[pts.length - 2], pts[pts.length - 1], rTo);
      pts[0] = trim(pts[1], pts[0], rFrom);
    }
    const d = pts.map((p) => p[0].toFixed(1) + "," + p[1].toFixed(1)).join(" ");
    const data = ' data-transition="' + attr(a.transition) + '" data-place="' + attr(a.place) + '" data-input="' + a.input + '"';
    o += '<polyline class="arc"' + data + ' points="' + d + '" fill="none" stroke="#444" marker-end="url(#arrow-' + idPart(n.name) + ')"/>' +
      '<polyline class="arc-hit"' + data + ' points="' + d + '" fill="none" stroke="transparent" stroke-width="9"><title>' +
      esc(a.input ? a.place + " → " + a.transition : a.transition + " → " + a.place) + "</title></polyline>";
  }
  for (const p of n.places) {
    const [x, y] = pos["place:" + p.name];
    const probs = problemsOf(n.name, "place", p.name);
    o += '<g class="place' + (probs.length ? " problem" : "") + '" id="' + elementId(n.name, "place", p.name) + '" data-kind="place" data-name="' + attr(p.name) + '">' +
      "<title>" + esc(p.name + (probs.length ? "\n" + probs.map((x) => x.message).join("\n") : "")) + "</title>" +
      '<circle cx="' + x.toFixed(1) + '" cy="' + y.toFixed(1) + '" r="' + RADIUS + '" fill="#fff" stroke="#222" stroke-width="' + (p.final ? 3 : 1) + '"/>' +
      (p.global ? '<circle cx="' + x.toFixed(1) + '" cy="' + y.toFixed(1) + '" r="' + (RADIUS - 3) + '" fill="none" stroke="#222"/>' : "") +
      (p.initial ? '<circle class="start" cx="' + x.toFixed(1) + '" cy="' + y.toFixed(1) + '" r="3.5" fill="#222"/>' : "") +
      '<text x="' + x.toFixed(1) + '" y="' + (y + RADIUS + 12).toFixed(1) + '" text-anchor="middle">' + esc(p.name) + "</text>" +
      (probs.length ? '<text class="warn" x="' + (x + RADIUS).toFixed(1) + '" y="' + (y - RADIUS + 2).toFixed(1) + '">⚠</text>' : "") + "</g>";
  }
  for (const t of n.transitions) {
    const [x, y] = pos["transition:" + t.name];
    const probs = problemsOf(n.name, "transition", t.name);
    let label = t.on || "(immediate)";
    if (t.when) label += " [" + t.when + "]";
    const short = label.length > 40 ? label.slice(0, 39) + "…" : label;
    o += '<g class="transition' + (probs.length ? " problem" : "") + '" id="' + elementId(n.name, "transition", t.name) + '" data-kind="transition" data-name="' + attr(t.name) + '">' +
      "<title>" + esc(n.name + "." + t.name + ": " + label + (probs.length ? "\n" + probs.map((x) => x.message).join("\n") : "")) + "</title>" +
      '<rect x="' + (x - BAR_W / 2).toFixed(1) + '" y="' + (y - BAR_H / 2).toFixed(1) + '" width="' + BAR_W + '" height="' + BAR_H + '" fill="#222"/>' +
      '<text x="' + x.toFixed(1) + '" y="' + (y - BAR_H / 2 - 4).toFixed(1) + '" text-anchor="middle">' + esc(short) + "</text>" +
      '<text class="tname" x="' + x.toFixed(1) + '" y="' + (y + BAR_H / 2 + 11).toFixed(1) + '" text-anchor="middle">' + esc(t.name) + "</text>" +
      (probs.length ? '<text class="warn" x="' + (x + 6).toFixed(1) + '" y="' + (y - BAR_H / 2 + 2).toFixed(1) + '">⚠</text>' : "") + "</g>";
  }
  return o + "</svg>";
}

function drawNet(n) {
  const div = document.querySelector('#nets .net[data-net="' + CSS.escape(n.name) + '"]');
  if (!div) return;
  const probs = problemsOf(n.name);
  div.querySelector(".net-problems").textContent = probs.map((p) => "⚠ " + p.file + ":" + p.line + ":" + p.col + ": " + p.message).join("\n");
  div.classList.toggle("problem", probs.length > 0);
  div.querySelector(".drawing").innerHTML = netSvg(n);
  const svg = div.querySelector("svg");
  svg.addEventListener("mousedown", (ev) => pointerDown(ev, n.name, svg));
}

function draw() {
  ED.draws++;
  // A redraw (an edit, the check's verdict) keeps the rename field's focus
  // and its selection: text selected to be typed over stays selected.
  const active = document.activeElement;
  const typing = active && active.classList.contains("net-rename-to")
    ? [active.selectionStart, active.selectionEnd, active.selectionDirection] : null;
  $("project").textContent = page.name;
  document.title = page.name + " — Petrel editor";
  const nets = $("nets");
  nets.innerHTML = "";
  $("globals").innerHTML = page.globals.length ? '<span class="muted">global places:</span>' + page.globals.map((g) => '<span class="chip">@' + esc(g) + "</span>").join("") : "";
  if (page.broken) say(page.broken + " — fix it and reload", true);
  $("undo").disabled = !page.undo;
  $("undo").title = page.undo ? "undo: " + page.undo + " (Ctrl-Z; " + page.undo_depth + " in all)" : "nothing to undo";
  $("redo").disabled = !page.redo;
  $("redo").title = page.redo ? "redo: " + page.redo + " (Ctrl-Shift-Z or Ctrl-Y)" : "nothing to redo";
  for (const n of page.nets) {
    const div = document.createElement("div");
    div.className = "net";
    div.dataset.net = n.name;
    const renaming = ED.renaming && ED.renaming.net === n.name;
    div.innerHTML = '<div class="net-head">' +
      (renaming
        ? '<span class="net-rename-form"><input class="net-rename-to" size="14" spellcheck="false" value="' + attr(ED.renaming.to) + '">' +
          '<button class="net-rename-go">rename</button><button class="net-rename-close" title="cancel">×</button></span>'
        : "<b>" + esc(n.name) + "</b>" +
          '<button class="net-rename" title="rename this net: every action naming it, and its file if named after it, with it">rename</button>' +
          '<button class="net-delete danger" title="delete this net: its [[net]] table in project.toml and its file">delete</button>' +
          '<label class="net-active-at-start" title="active at start: the `active` key of this net\'s [[net]] table in project.toml">' +
          '<input type="checkbox" class="net-active"' + (n.active ? " checked" : "") + "> active at start</label>") +
      '<span class="muted">' + esc(n.file) + "</span>" +
      '<button class="relayout" title="forget the positions given by hand: lay the whole net out automatically">re-layout</button></div>' +
      '<pre class="net-problems"></pre><div class="drawing"></div>';
    div.querySelector(".relayout").onclick = () => edit({ op: "relayout", net: n.name });
    if (renaming) {
      const input = div.querySelector(".net-rename-to");
      input.oninput = () => { ED.renaming.to = input.value; };
      input.onkeydown = (ev) => { if (ev.key === "Enter") renameNet(n.name); if (ev.key === "Escape") { ED.renaming = null; draw(); } };
      div.querySelector(".net-rename-go").onclick = () => renameNet(n.name);
      div.querySelector(".net-rename-close").onclick = () => { ED.renaming = null; draw(); };
    } else {
      div.querySelector(".net-rename").onclick = () => {
        ED.renaming = { net: n.name, to: n.name };
        draw();
        const input = document.querySelector('#nets .net[data-net="' + CSS.escape(n.name) + '"] .net-rename-to');
        if (input) { input.focus(); input.select(); }
      };
      div.querySelector(".net-delete").onclick = () => deleteNet(n);
      div.querySelector(".net-active").onchange = (ev) => setActive(n.name, ev.target.checked);
    }
    nets.appendChild(div);
    drawNet(n);
  }
  if (typing) {
    const input = document.querySelector("#nets .net-rename-to");
    if (input) { input.focus(); input.setSelectionRange(typing[0], typing[1], typing[2]); }
  }
  problems();
  check();
  if (ED.sel && !nodeOf(ED.sel.net, ED.sel.kind, ED.sel.name)) ED.sel = null;
  select(ED.sel);
  markArcFrom();
}

function problems() {
  const box = $("problems");
  $("problem-count").textContent = page.loads ? "(the project loads)" : "(" + page.problems.length + ")";
  box.innerHTML = "";
  for (const p of page.problems) {
    const d = document.createElement("div");
    d.className = "problem-row";
    const where = p.net ? p.net + (p.name ? "." + p.name : "") : "project";
    d.innerHTML = "<code>" + esc(p.file + ":" + p.line + ":" + p.col) + "</code> <b>" + esc(where) + "</b> " + esc(p.message);
    if (p.kind) d.onclick = () => select({ net: p.net, kind: p.kind, name: p.name });
    box.appendChild(d);
  }
}

// ---- the check and its counterexample ------------------------------------

function check() {
  const c = page.check, s = $("check-state");
  s.dataset.state = c.state === "done" ? (c.holds ? "holds" : "violated") : c.state;
  const key = JSON.stringify([c.state, c.title, c.moments && c.moments.length, c.states]);
  if (key !== ED.checkKey) { ED.checkKey = key; ED.step = 0; }
  $("cx").hidden = true;
  if (c.state === "none") s.textContent = page.loads ? "–" : "not checked: the project does not load";
  else if (c.state === "running") s.innerHTML = '<span class="spin">⟳</span> petrel check is running…';
  else if (c.state === "failed") s.textContent = "the check failed: " + c.why;
  else {
    s.innerHTML = (c.holds ? "✔ every property holds" : "✘ a property is violated") +
      ' <span class="muted">(' + c.states + " states, " + Number(c.seconds).toFixed(1) + " s)</span>";
    if (c.moments && c.moments.length) {
      $("cx").hidden = false;
      $("cx-title").textContent = c.title;
      showStep(ED.step);
      return;
    }
  }
  paintMoment(null);
}

function showStep(i) {
  const m = page.check.moments;
  if (!m || !m.length) return;
  ED.step = Math.max(0, Math.min(i, m.length - 1));
  $("cx-pos").textContent = "step " + ED.step + " / " + (m.length - 1);
  $("cx-label").textContent = m[ED.step].label;
  $("cx-prev").disabled = ED.step === 0;
  $("cx-next").disabled = ED.step === m.length - 1;
  paintMoment(m[ED.step]);
}

// The step's first fired transition brought into view (on a click only:
// a redraw never scrolls the page under a person's hands).
function reveal() {
  const el = document.querySelector("#nets g.transition.fired");
  if (el) el.scrollIntoView({ block: "nearest", inline: "nearest" });
}

function paintMoment(m) {
  const marked = new Set(m ? m.marked : []), fired = new Set(m ? m.fired : []), active = new Set(m ? m.active : []);
  for (const n of page.nets) {
    const div = document.querySelector('#nets .net[data-net="' + CSS.escape(n.name) + '"]');
    if (!div) continue;
    div.classList.toggle("inactive", !!m && !active.has(n.name));
    for (const p of n.places) {
      const el = document.getElementById(elementId(n.name, "place", p.name));
      if (el) el.classList.toggle("marked", marked.has(p.global ? p.name : n.name + "." + p.name));
    }
    for (const t of n.transitions) {
      const el = document.getElementById(elementId(n.name, "transition", t.name));
      if (el) el.classList.toggle("fired", fired.has(n.name + "." + t.name));
    }
  }
}

// ---- pointing ------------------------------------------------------------

function svgPoint(svg, ev) {
  const pt = svg.createSVGPoint();
  pt.x = ev.clientX; pt.y = ev.clientY;
  const p = pt.matrixTransform(svg.getScreenCTM().inverse());
  return [Math.round(p.x), Math.round(p.y)];
}

function fresh(net, kind, stem) {
  const n = netOf(net);
  const taken = new Set((kind === "place" ? n.places : n.transitions).map((x) => x.name));
  for (let i = 1; ; i++) if (!taken.has(stem + i)) return stem + i;
}

async function pointerDown(ev, net, svg) {
  if (ev.button !== 0) return;
  const g = ev.target.closest("g.place, g.transition");
  const arc = ev.target.closest(".arc-hit");
  const xy = svgPoint(svg, ev);
  // Not under the net's edge: room for a node's label above it.
  const at = [Math.max(24, xy[0]), Math.max(40, xy[1])];
  ev.preventDefault();
  const node = g ? { net, kind: g.dataset.kind, name: g.dataset.name } : null;
  switch (ED.tool) {
    case "select":
      if (node) {
        const n = nodeOf(net, node.kind, node.name);
        ED.drag = { ...node, svg, start: at, from: [n.x, n.y], at: [n.x, n.y], moved: false };
      } else select(null);
      break;
    case "place":
    case "transition":
      if (!node && !arc) {
        const name = fresh(net, ED.tool, ED.tool === "place" ? "p" : "t");
        const a = await edit({ op: "add_" + ED.tool, net, name, at });
        if (a.ok) select({ net, kind: ED.tool, name });
      } else if (node) select(node);
      break;
    case "arc":
      if (!node) { ED.arcFrom = null; markArcFrom(); break; }
      if (!ED.arcFrom || ED.arcFrom.net !== net || ED.arcFrom.kind === node.kind) {
        ED.arcFrom = node; markArcFrom();
        $("hint").textContent = "now click a " + (node.kind === "place" ? "transition" : "place") + " of " + net;
        break;
      }
      {
        const input = ED.arcFrom.kind === "place";
        const place = input ? ED.arcFrom.name : node.name, transition = input ? node.name : ED.arcFrom.name;
        ED.arcFrom = null;
        setTool("arc");
        await edit({ op: "add_arc", net, transition, place, input });
      }
      break;
    case "delete":
      if (node) await remove(node);
      else if (arc) await edit({ op: "delete_arc", net, transition: arc.dataset.transition, place: arc.dataset.place, input: arc.dataset.input === "true" });
      break;
  }
}

function dragMove(ev) {
  const d = ED.drag;
  if (!d) return;
  const at = svgPoint(d.svg, ev);
  const dx = at[0] - d.start[0], dy = at[1] - d.start[1];
  if (!d.moved && Math.hypot(dx, dy) < 4) return;
  d.moved = true;
  d.at = [Math.max(24, d.from[0] + dx), Math.max(40, d.from[1] + dy)];
  const n = netOf(d.net);
  const div = document.querySelector('#nets .net[data-net="' + CSS.escape(d.net) + '"] .drawing');
  div.innerHTML = netSvg(n);
  d.svg = div.querySelector("svg");
  d.svg.addEventListener("mousedown", (e) => pointerDown(e, n.name, d.svg));
  select(ED.sel);
}

async function dragEnd() {
  const d = ED.drag;
  if (!d) return;
  ED.drag = null;
  if (d.moved) await edit({ op: "move", net: d.net, kind: d.kind, name: d.name, x: d.at[0], y: d.at[1] });
  select({ net: d.net, kind: d.kind, name: d.name });
}

function markArcFrom() {
  document.querySelectorAll(".arc-from").forEach((x) => x.classList.remove("arc-from"));
  if (ED.arcFrom) {
    const el = document.getElementById(elementId(ED.arcFrom.net, ED.arcFrom.kind, ED.arcFrom.name));
    if (el) el.classList.add("arc-from");
  }
}

async function remove(e) {
  const op = e.kind === "place" ? "delete_place" : "delete_transition";
  const a = await edit({ op, net: e.net, name: e.name });
  if (a.ok && ED.sel && ED.sel.name === e.name && ED.sel.kind === e.kind) select(null);
}

// ---- the element's form --------------------------------------------------

function select(e) {
  ED.sel = e;
  document.querySelectorAll("#nets .selected").forEach((x) => x.classList.remove("selected"));
  const form = $("element-form");
  if (!e) { form.className = "muted"; form.textContent = "Click a place or a transition; pick a tool above to add."; return; }
  const el = document.getElementById(elementId(e.net, e.kind, e.name));
  if (el) el.classList.add("selected");
  // Not rebuilt under a person typing in it (a check's verdict redraws).
  if (form.dataset.key === JSON.stringify(e) && form.contains(document.activeElement)) return;
  form.dataset.key = JSON.stringify(e);
  form.className = "";
  const n = nodeOf(e.net, e.kind, e.name);
  if (!n) return;
  const probs = problemsOf(e.net, e.kind, e.name);
  const problemsHtml = probs.map((p) => '<div class="problem-row"><code>' + esc(p.file + ":" + p.line + ":" + p.col) + "</code> " + esc(p.message) + "</div>").join("");
  const file = netOf(e.net).file;
  if (e.kind === "place") {
    if (n.global) {
      form.innerHTML = "<b>global place " + esc(n.name) + "</b> <span class=muted>(in " + esc(e.net) + ")</span>" +
        "<p class=muted>Declared in project.toml's [globals]" + (n.declared ? "" : " — NOT declared there") + ".</p>" + problemsHtml;
      return;
    }
    form.innerHTML = "<b>place</b> <span class=muted>" + esc(e.net) + " · " + esc(file) + "</span>" +
      '<div class="row2"><label>name</label><input id="f-name" value="' + attr(n.name) + '"><button id="f-rename">rename</button></div>' +
      '<div class="row2"><label></label><label><input type="checkbox" id="f-initial"' + (n.initial ? " checked" : "") + "> initially marked</label>" +
      '<label><input type="checkbox" id="f-final"' + (n.final ? " checked" : "") + "> final</label></div>" +
      problemsHtml + '<div class="row2"><label></label><button id="f-delete" class="danger">delete place</button></div>';
    const rename = async () => {
      const to = $("f-name").value.trim();
      if (to === n.name) return;
      const a = await edit({ op: "rename_place", net: e.net, name: n.name, to });
      if (a.ok) select({ ...e, name: to });
    };
    $("f-rename").onclick = rename;
    $("f-name").onkeydown = (ev) => { if (ev.key === "Enter") rename(); };
    $("f-initial").onchange = () => edit({ op: "set_place", net: e.net, name: n.name, initial: $("f-initial").checked });
    $("f-final").onchange = () => edit({ op: "set_place", net: e.net, name: n.name, final: $("f-final").checked });
    $("f-delete").onclick = () => remove(e);
    return;
  }
  const chips = (list, input) => list.map((p) => '<span class="chip">' + esc(p) +
    ' <a href="#" data-place="' + attr(p) + '" data-input="' + input + '" title="delete this arc">×</a></span>').join(" ") || '<span class="muted">none</span>';
  form.innerHTML = "<b>transition</b> <span class=muted>" + esc(e.net) + " · " + esc(file) + "</span>" +
    '<div class="row2"><label>name</label><input id="f-name" value="' + attr(n.name) + '"></div>' +
    '<div class="row2"><label>on</label><input id="f-on" list="f-events" placeholder="(immediate)" value="' + attr(n.on) + '"></div>' +
    '<datalist id="f-events">' + page.events.map((x) => '<option value="' + attr(x) + '">').join("") + "</datalist>" +
    '<div class="row2"><label>when</label><input id="f-when" placeholder="(no guard)" value="' + attr(n.when) + '"></div>' +
    '<div class="row2"><label>do</label><textarea id="f-do" rows="3" placeholder="one action a line">' + esc(n.do.join("\n")) + "</textarea></div>" +
    '<div class="row2"><label></label><button id="f-apply">apply</button> <button id="f-delete" class="danger">delete transition</button></div>' +
    '<div class="row2"><label>from</label><span id="f-from">' + chips(n.from, true) + "</span></div>" +
    '<div class="row2"><label>to</label><span id="f-to">' + chips(n.to, false) + "</span></div>" +
    '<div class="row2"><label>arc</label><select id="f-arc-place">' +
    netOf(e.net).places.filter((p) => !p.global).map((p) => p.name).concat(page.globals.map((g) => "@" + g))
      .map((p) => '<option value="' + attr(p) + '">' + esc(p) + "</option>").join("") +
    '</select><span><button id="f-arc-from" title="an input arc from this place">+ from</button>' +
    '<button id="f-arc-to" title="an output arc to this place">+ to</button></span></div>' + problemsHtml;
  $("f-apply").onclick = async () => {
    // Read at once: the form is drawn again after each edit.
    let name = n.name;
    const to = $("f-name").value.trim();
    const actions = $("f-do").value.split("\n").map((x) => x.trim()).filter((x) => x);
    const on = $("f-on").value, when = $("f-when").value;
    if (to !== name) {
      ED.sel = { ...e, name: to };
      const a = await edit({ op: "rename_transition", net: e.net, name, to });
      if (!a.ok) { ED.sel = e; return; }
      name = to;
    }
    const a = await edit({ op: "set_transition", net: e.net, name, on, when, do: actions });
    if (a.ok) { $("element-form").dataset.key = ""; select({ ...e, name }); }
  };
  $("f-delete").onclick = () => remove(e);
  // Arcs to any place, global ones the net does not use yet included.
  const arc = (input) => edit({ op: "add_arc", net: e.net, transition: n.name, place: $("f-arc-place").value, input });
  $("f-arc-from").onclick = () => arc(true);
  $("f-arc-to").onclick = () => arc(false);
  form.querySelectorAll("a[data-place]").forEach((x) => {
    x.onclick = (ev) => { ev.preventDefault(); edit({ op: "delete_arc", net: e.net, transition: n.name, place: x.dataset.place, input: x.dataset.input === "true" }); };
  });
}

// ---- program stubs -------------------------------------------------------

async function stubs() {
  const a = await post("stubs", { lang: $("stubs-lang").value, out: $("stubs-out").value, force: $("stubs-force").checked });
  $("stubs-result").textContent = a.ok ? (a.files.length ? "written: " + a.files.join(", ") : "the nets call no program: nothing to write") : "";
}

editorFrame();
ED.version = page.version;
draw();
poll();
