// Drives Debian's chromium with playwright-core for gateway/tests/edit.rs:
// the editor (`petrel edit`) used as a person does, with clicks and typing.
// Usage: node driver.js add|break|net|undo|netops|netundo URL OUT_DIR
//   add:   a transition added to COMMUNICATION (first without arcs: the
//          loader's problem shown on it), named, given its event and arcs;
//          its place dragged; wait for the check's verdict.
//   break: a place added and an output arc to it that makes the check fail;
//          its counterexample stepped through to the end.
//   net:   a net added with the toolbar's form (first with a name taken:
//          refused, the reason shown), the check's verdict on it, then a
//          transition given to it with its event and arcs, the verdict,
//          its place made final, and the verdict.
//   undo:  Ctrl-Z once, then the Undo button until the added net is gone;
//          Redo (the net back), Ctrl-Z (gone again).
//   netops: COMMUNICATION's delete confirmed (refused: other nets name
//          it), OPERATIONS renamed FLIGHT (refused: taken) then OPS;
//          FLIGHT's "active at start" ticked then unticked; a net NEW
//          added, renamed SPARE, its delete cancelled then confirmed;
//          the check's verdict.
//   netundo: the Undo button until there is nothing to undo.
//   draws: page.json answered late (longer than the page's poll period);
//          three places of INIT dragged (a move: no check), then
//          a fourth moved by another client of the editor (POST /edit, as
//          another tab), then layout.toml changed on disk by another
//          program (PROJECT_DIR: read again at the page's poll), then a
//          Reload from another tab: the page's draws counted across each.
// Prints one JSON object with what it saw; the Rust test judges it. The
// browser is closed on every path.
"use strict";
const fs = require("fs");
const path = require("path");
const { chromium } = require(process.env.PLAYWRIGHT_CORE || "playwright-core");

const [mode, url, out] = process.argv.slice(2);
const NET = "COMMUNICATION";
const FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
  "--disable-background-networking", "--disable-component-update", "--disable-sync"];
const CHECK_MS = 400000;

// A spot of the net's drawing at least 45 units from every node.
// A click on a place or transition of a drawn net. The page draws its
// nets again after each edit and when its 500 ms poll sees a version it
// did not make (the check's verdict, another client's change), so the
// element found may be replaced before the click lands (Playwright
// then says "not visible" or "detached" and dispatches nothing): found
// again and clicked, a few times at most.
async function clickDrawn(page, selector) {
  for (let i = 0; ; i++) {
    try {
      return await page.click(selector, { force: true, timeout: 5000 });
    } catch (e) {
      if (i >= 4 || !/not visible|detached|not attached/.test(String(e))) throw e;
      await page.waitForTimeout(100);
    }
  }
}

async function emptySpot(page, net = NET) {
  return page.evaluate(async (net) => {
    const p = await (await fetch("page.json")).json();
    const n = p.nets.find((x) => x.name === net);
    const nodes = n.places.concat(n.transitions);
    for (let y = 50; y < n.height; y += 10) {
      for (let x = 40; x < n.width; x += 10) {
        if (nodes.every((m) => Math.hypot(m.x - x, m.y - y) > 45)) return { x, y };
      }
    }
    return { x: n.width - 10, y: n.height - 10 };
  }, net);
}

const svg = '#nets .net[data-net="' + NET + '"] svg';
const el = (kind, name) => "#" + (kind === "place" ? "p-" : "t-") + NET + "-" + name;

async function add(page, seen) {
  await page.goto(url);
  await page.waitForSelector(svg, { timeout: 30000 });
  seen.nets = await page.$$eval("#nets .net", (els) => els.map((e) => e.dataset.net));
  seen.ids = await page.$$eval("#nets g.place, #nets g.transition", (els) => els.map((e) => e.id));
  await page.screenshot({ path: path.join(out, "edit-start.png") });
  // A transition where the click falls.
  await page.click("#tool-transition");
  const spot = await emptySpot(page);
  await page.click(svg, { position: spot });
  await page.waitForSelector(el("transition", "t1") + ".problem", { timeout: 20000 });
  seen.error_rows = await page.$$eval("#problems .problem-row", (els) => els.map((e) => e.textContent));
  seen.error_title = await page.$eval(el("transition", "t1") + " title", (t) => t.textContent);
  seen.error_form = await page.$eval("#element-form", (f) => f.textContent);
  await page.screenshot({ path: path.join(out, "edit-error.png") });
  // Named, its event set, through the form.
  await page.fill("#f-name", "rc_back");
  await page.fill("#f-on", "link_degraded");
  await page.click("#f-apply");
  await page.waitForSelector(el("transition", "rc_back"), { timeout: 20000 });
  // Its arcs: place then transition (input), transition then place (output).
  await page.click("#tool-arc");
  await clickDrawn(page, el("place", "proceeding") + " circle");
  await clickDrawn(page, el("transition", "rc_back") + " rect");
  await page.waitForFunction((s) => !!document.querySelector(s), svg + ' .arc[data-transition="rc_back"][data-input="true"]', { timeout: 20000 });
  await clickDrawn(page, el("transition", "rc_back") + " rect");
  await clickDrawn(page, el("place", "proceeding") + " circle");
  await page.waitForFunction((s) => !!document.querySelector(s), svg + ' .arc[data-transition="rc_back"][data-input="false"]', { timeout: 20000 });
  // The place dragged 60 units down.
  await page.click("#tool-select");
  const box = await page.$eval(el("place", "proceeding") + " circle", (c) => { const r = c.getBoundingClientRect(); return { x: r.x + r.width / 2, y: r.y + r.height / 2 }; });
  await page.mouse.move(box.x, box.y);
  await page.mouse.down();
  for (let i = 1; i <= 6; i++) await page.mouse.move(box.x, box.y + 10 * i);
  await page.mouse.up();
  await page.waitForFunction(() => fetch("page.json").then((r) => r.json()).then((p) =>
    p.nets.find((n) => n.name === "COMMUNICATION").places.find((x) => x.name === "proceeding").pinned), null, { timeout: 20000 });
  seen.problems_after = await page.$$eval("#problems .problem-row", (els) => els.length);
  await page.waitForSelector('#check-state[data-state="holds"], #check-state[data-state="violated"], #check-state[data-state="failed"]', { timeout: CHECK_MS });
  seen.check = await page.$eval("#check-state", (e) => ({ state: e.dataset.state, text: e.textContent }));
  await clickDrawn(page, el("transition", "rc_back") + " rect");
  await page.screenshot({ path: path.join(out, "edit-added.png") });
}

async function breakIt(page, seen) {
  await page.goto(url);
  await page.waitForSelector(svg, { timeout: 30000 });
  await page.click("#tool-place");
  await page.click(svg, { position: await emptySpot(page) });
  await page.waitForSelector(el("place", "p1"), { timeout: 20000 });
  await page.click("#tool-arc");
  await clickDrawn(page, el("transition", "rc_back") + " rect");
  await clickDrawn(page, el("place", "p1") + " circle");
  await page.waitForFunction((s) => !!document.querySelector(s), svg + ' .arc[data-transition="rc_back"][data-place="p1"]', { timeout: 20000 });
  await page.waitForSelector('#check-state[data-state="holds"], #check-state[data-state="violated"], #check-state[data-state="failed"]', { timeout: CHECK_MS });
  seen.check = await page.$eval("#check-state", (e) => ({ state: e.dataset.state, text: e.textContent }));
  seen.title = await page.$eval("#cx-title", (e) => e.textContent);
  seen.steps = [];
  for (let i = 0; i < 50; i++) {
    seen.steps.push({
      pos: await page.$eval("#cx-pos", (e) => e.textContent),
      label: await page.$eval("#cx-label", (e) => e.textContent),
      marked: await page.$$eval("#nets g.place.marked", (els) => els.map((e) => e.id)),
      fired: await page.$$eval("#nets g.transition.fired", (els) => els.map((e) => e.id)),
      p1_fill: await page.$eval("#p-COMMUNICATION-p1 circle", (c) => getComputedStyle(c).fill),
    });
    if (await page.$eval("#cx-next", (b) => b.disabled)) break;
    await page.click("#cx-next");
  }
  await page.screenshot({ path: path.join(out, "edit-counterexample.png") });
  await page.click("#cx-prev");
  seen.back = await page.$eval("#cx-pos", (e) => e.textContent);
}

const VERDICT = '#check-state[data-state="holds"], #check-state[data-state="violated"], #check-state[data-state="failed"]';
const NEW = "NEW";
const newSvg = '#nets .net[data-net="' + NEW + '"] svg';

async function verdict(page) {
  await page.waitForSelector(VERDICT, { timeout: CHECK_MS });
  return page.$eval("#check-state", (e) => ({ state: e.dataset.state, text: e.textContent,
    title: document.getElementById("cx-title").textContent }));
}

async function addNet(page, seen) {
  await page.goto(url);
  await page.waitForSelector(svg, { timeout: 30000 });
  seen.undo_at_start = await page.$eval("#undo", (b) => b.disabled);
  await page.click("#net-add-open");
  // A name taken: refused, the reason shown.
  await page.fill("#net-name", NET);
  await page.click("#net-add-go");
  await page.waitForSelector("#edit-message:not([hidden])", { timeout: 20000 });
  seen.taken = await page.$eval("#edit-message", (e) => e.textContent);
  // NEW, active at start (ticked unless unticked).
  seen.active_ticked = await page.$eval("#net-active", (c) => c.checked);
  await page.fill("#net-name", NEW);
  await page.click("#net-add-go");
  await page.waitForSelector(newSvg, { timeout: 20000 });
  seen.message_after = await page.$eval("#edit-message", (e) => e.hidden);
  seen.nets = await page.$$eval("#nets .net", (els) => els.map((e) => e.dataset.net));
  seen.new_ids = await page.$$eval('#nets .net[data-net="NEW"] g.place, #nets .net[data-net="NEW"] g.transition', (els) => els.map((e) => e.id));
  seen.new_marked_at_start = await page.$$eval("#p-NEW-idle .start", (els) => els.length);
  seen.undo_title = await page.$eval("#undo", (b) => b.title);
  // The background check covers it: dead at the start.
  seen.first_check = await verdict(page);
  await page.screenshot({ path: path.join(out, "edit-net-added.png") });
  // A transition on link_lost, from idle back to idle.
  await page.click("#tool-transition");
  await page.click(newSvg, { position: await emptySpot(page, NEW) });
  await page.waitForSelector("#t-NEW-t1", { timeout: 20000 });
  await page.fill("#f-on", "link_lost");
  await page.click("#f-apply");
  await page.waitForFunction(() => fetch("page.json").then((r) => r.json()).then((p) =>
    p.nets.find((n) => n.name === "NEW").transitions.some((t) => t.on === "link_lost")), null, { timeout: 20000 });
  await page.click("#tool-arc");
  await clickDrawn(page, "#p-NEW-idle circle");
  await clickDrawn(page, "#t-NEW-t1 rect");
  await page.waitForFunction((s) => !!document.querySelector(s), newSvg + ' .arc[data-transition="t1"][data-input="true"]', { timeout: 20000 });
  await clickDrawn(page, "#t-NEW-t1 rect");
  await clickDrawn(page, "#p-NEW-idle circle");
  await page.waitForFunction((s) => !!document.querySelector(s), newSvg + ' .arc[data-transition="t1"][data-input="false"]', { timeout: 20000 });
  // The check after the arcs: dead when a catastrophe locks the
  // transition out (as any net without a final place). idle made final.
  seen.arcs_check = await verdict(page);
  await page.click("#tool-select");
  await clickDrawn(page, "#p-NEW-idle circle");
  await page.waitForSelector("#f-final", { timeout: 20000 });
  await page.check("#f-final");
  // Drawn final (the page redrawn after the edit: the verdict below is
  // the new check's).
  await page.waitForSelector('#p-NEW-idle circle[stroke-width="3"]', { timeout: 20000 });
  seen.problems_after = await page.$$eval("#problems .problem-row", (els) => els.length);
  seen.check = await verdict(page);
  await page.screenshot({ path: path.join(out, "edit-net-checked.png") });
}

async function undoIt(page, seen) {
  await page.goto(url);
  await page.waitForSelector(newSvg, { timeout: 30000 });
  seen.undone = [];
  // Ctrl-Z on the page (not in a field): the last edit undone.
  const what = async () => (await page.$eval("#undo", (b) => b.title)).replace(/^undo: /, "").replace(/ \(Ctrl-Z.*$/, "");
  const wait = (w) => page.waitForFunction((w) => document.getElementById("edit-message").textContent.startsWith("undone: " + w + " "),
    w, { timeout: 20000 });
  let w = await what();
  await page.keyboard.press("Control+z");
  await wait(w);
  seen.undone.push(w);
  seen.arcs_after_ctrl_z = await page.$$eval(newSvg + " .arc", (els) => els.map((e) => e.dataset.place + (e.dataset.input === "true" ? "->" : "<-") + e.dataset.transition));
  // Then the button, until the net is gone.
  for (let i = 0; i < 20 && await page.$(newSvg); i++) {
    w = await what();
    await page.click("#undo");
    await wait(w);
    seen.undone.push(w);
  }
  seen.nets = await page.$$eval("#nets .net", (els) => els.map((e) => e.dataset.net));
  seen.undo_disabled = await page.$eval("#undo", (b) => b.disabled);
  // Redo brings the net back; Ctrl-Z takes it away again.
  await page.click("#redo");
  await page.waitForFunction(() => document.getElementById("edit-message").textContent.startsWith("redone: add net NEW "), null, { timeout: 20000 });
  await page.waitForSelector(newSvg, { timeout: 20000 });
  seen.redo_title = await page.$eval("#redo", (b) => b.title);
  seen.nets_after_redo = await page.$$eval("#nets .net", (els) => els.map((e) => e.dataset.net));
  await page.keyboard.press("Control+z");
  await wait("add net NEW");
  seen.nets_at_end = await page.$$eval("#nets .net", (els) => els.map((e) => e.dataset.net));
  await page.screenshot({ path: path.join(out, "edit-undone.png") });
}

const head = (net) => '#nets .net[data-net="' + net + '"] .net-head';

async function message(page) {
  await page.waitForSelector("#edit-message:not([hidden])", { timeout: 20000 });
  return page.$eval("#edit-message", (e) => e.textContent);
}

async function netOps(page, seen) {
  await page.goto(url);
  await page.waitForSelector(svg, { timeout: 30000 });
  // Delete confirmed, refused: the reasons shown, the net still there.
  page.once("dialog", (d) => { seen.confirm = d.message(); d.accept(); });
  await page.click(head(NET) + " .net-delete");
  seen.in_use = await message(page);
  seen.still = await page.$$eval(svg, (els) => els.length);
  // Closed, so that the next message is the next refusal's.
  await page.click("#message-close");
  await page.waitForSelector("#edit-message", { state: "hidden", timeout: 20000 });
  // Renamed: a name taken refused (the form stays), then OPS.
  await page.click(head("OPERATIONS") + " .net-rename");
  await page.waitForSelector(head("OPERATIONS") + " .net-rename-to", { timeout: 20000 });
  seen.rename_value = await page.$eval(head("OPERATIONS") + " .net-rename-to", (i) => i.value);
  await page.fill(head("OPERATIONS") + " .net-rename-to", "FLIGHT");
  await page.press(head("OPERATIONS") + " .net-rename-to", "Enter");
  seen.taken = await message(page);
  seen.form_after_refusal = await page.$$eval(head("OPERATIONS") + " .net-rename-to", (els) => els.map((e) => e.value));
  // The refusal's own redraw done; then a redraw while the name is
  // selected to be typed over (a check's verdict arriving under a person's
  // hands, which once made "FLIGHTOPS"): what is typed replaces it.
  await page.waitForFunction(() => ED.posts === 0, null, { timeout: 20000 });
  const field = head("OPERATIONS") + " .net-rename-to";
  await page.focus(field);
  await page.$eval(field, (i) => i.select());
  await page.evaluate(() => draw());
  await page.keyboard.insertText("OPS");
  seen.typed_over = await page.$eval(field, (i) => i.value);
  await page.click(head("OPERATIONS") + " .net-rename-go");
  await page.waitForSelector(head("OPS") + " b", { timeout: 20000 });
  seen.message_after = await page.$eval("#edit-message", (e) => e.hidden);
  seen.nets_renamed = await page.$$eval("#nets .net", (els) => els.map((e) => e.dataset.net));
  // FLIGHT active at start, then not: the box shows what project.toml says.
  const box = head("FLIGHT") + " .net-active";
  const undoIs = (w) => page.waitForFunction((w) => document.getElementById("undo").title.startsWith("undo: " + w + " ("),
    w, { timeout: 20000 });
  seen.flight_active = [await page.$eval(box, (b) => b.checked)];
  await page.click(box);
  await undoIs("set net FLIGHT active at start");
  seen.flight_active.push(await page.$eval(box, (b) => b.checked));
  seen.actives = await page.$$eval("#nets .net", (els) => els.filter((e) => e.querySelector(".net-active").checked).map((e) => e.dataset.net));
  await page.click(box);
  await undoIs("set net FLIGHT not active at start");
  seen.flight_active.push(await page.$eval(box, (b) => b.checked));
  // A net added, renamed (its file with it), deleted.
  await page.click("#net-add-open");
  await page.fill("#net-name", "NEW");
  await page.click("#net-add-go");
  await page.waitForSelector(head("NEW"), { timeout: 20000 });
  await page.click(head("NEW") + " .net-rename");
  await page.waitForSelector(head("NEW") + " .net-rename-to", { timeout: 20000 });
  await page.fill(head("NEW") + " .net-rename-to", "SPARE");
  await page.press(head("NEW") + " .net-rename-to", "Enter");
  await page.waitForSelector(head("SPARE") + " b", { timeout: 20000 });
  seen.spare_file = await page.$eval(head("SPARE") + " .muted", (e) => e.textContent);
  await page.screenshot({ path: path.join(out, "edit-net-renamed.png") });
  page.once("dialog", (d) => d.dismiss());
  await page.click(head("SPARE") + " .net-delete");
  await page.waitForTimeout(500);
  seen.after_cancel = await page.$$eval("#nets .net", (els) => els.map((e) => e.dataset.net));
  page.once("dialog", (d) => d.accept());
  await page.click(head("SPARE") + " .net-delete");
  await page.waitForFunction(() => !document.querySelector('#nets .net[data-net="SPARE"]'), null, { timeout: 20000 });
  seen.nets = await page.$$eval("#nets .net", (els) => els.map((e) => e.dataset.net));
  seen.undo_title = await page.$eval("#undo", (b) => b.title);
  seen.check = await verdict(page);
  await page.screenshot({ path: path.join(out, "edit-net-deleted.png") });
}

async function netUndo(page, seen) {
  await page.goto(url);
  await page.waitForSelector(svg, { timeout: 30000 });
  seen.undone = [];
  for (let i = 0; i < 20 && !(await page.$eval("#undo", (b) => b.disabled)); i++) {
    const w = (await page.$eval("#undo", (b) => b.title)).replace(/^undo: /, "").replace(/ \(Ctrl-Z.*$/, "");
    await page.click("#undo");
    await page.waitForFunction((w) => document.getElementById("edit-message").textContent.startsWith("undone: " + w + " "),
      w, { timeout: 20000 });
    seen.undone.push(w);
  }
  seen.nets = await page.$$eval("#nets .net", (els) => els.map((e) => e.dataset.net));
}

// The page settled: it has drawn the editor's version, and neither has
// changed for longer than a poll period and a late page.json together.
async function settled(page) {
  let last = null;
  for (let i = 0; i < 60; i++) {
    const s = await page.evaluate(async () => ({ server: (await (await fetch("version")).json()).version,
      version: ED.version, draws: ED.draws }));
    if (last && s.server === s.version && s.version === last.version && s.draws === last.draws) return s;
    last = s;
    await page.waitForTimeout(1500);
  }
  throw new Error("the page never settled: " + JSON.stringify(last));
}

const LATE_MS = 700;

async function drawsPerEdit(page, seen) {
  // page.json answered 700 ms late: an edit's own refresh is still on its
  // way when the 500 ms poll next asks /version and finds the edit's
  // version (the race that drew the page twice, made certain).
  await page.route("**/page.json", async (route) => {
    await new Promise((r) => setTimeout(r, LATE_MS));
    await route.continue();
  });
  const net = "INIT";
  const circle = (name) => "#p-" + net + "-" + name + " circle";
  await page.goto(url);
  await page.waitForSelector(circle("start"), { timeout: 30000 });
  await verdict(page);
  let before = await settled(page);
  seen.edits = [];
  await page.click("#tool-select");
  const places = await page.evaluate((net) => page.nets.find((n) => n.name === net).places.map((p) => p.name), net);
  for (const name of places.slice(0, 3)) {
    await page.$eval(circle(name), (c) => c.scrollIntoView({ block: "center" }));
    const c = await page.$eval(circle(name), (c) => { const r = c.getBoundingClientRect(); return { x: r.x + r.width / 2, y: r.y + r.height / 2 }; });
    await page.mouse.move(c.x, c.y);
    await page.mouse.down();
    for (let i = 1; i <= 4; i++) await page.mouse.move(c.x + 5 * i, c.y + 5 * i);
    await page.mouse.up();
    await page.waitForFunction((v) => ED.version > v, before.version, { timeout: 20000 });
    const after = await settled(page);
    seen.edits.push({ place: name, draws: after.draws - before.draws, versions: after.version - before.version });
    before = after;
  }
  // Another client moves the fourth place (the layout file changes on
  // disk, not through this page): drawn once, soon.
  const fourth = places[3];
  const at = await page.evaluate((a) => {
    const p = page.nets.find((n) => n.name === a.net).places.find((x) => x.name === a.name);
    return [Math.round(p.x) + 30, Math.round(p.y) + 20];
  }, { net, name: fourth });
  const t0 = Date.now();
  const r = await fetch(new URL("edit", url), { method: "POST", headers: { "content-type": "application/json" },
    body: JSON.stringify({ op: "move", net, kind: "place", name: fourth, x: at[0], y: at[1] }) });
  seen.outside_answer = await r.json();
  await page.waitForFunction((a) => {
    const c = document.querySelector(a.sel);
    return !!c && Number(c.getAttribute("cx")) === a.at[0] && Number(c.getAttribute("cy")) === a.at[1];
  }, { sel: circle(fourth), at }, { timeout: 20000 });
  seen.outside_ms = Date.now() - t0;
  const after = await settled(page);
  seen.outside = { place: fourth, at, draws: after.draws - before.draws, versions: after.version - before.version };
  // layout.toml changed on disk by another program (the fourth place's
  // line, as a text editor saves: a whole new file renamed over it): the
  // page's poll reads it again, no Reload: drawn soon, then the new
  // check's verdict.
  const file = path.join(process.env.PROJECT_DIR || ".", "layout.toml");
  const text = fs.readFileSync(file, "utf8");
  const line = fourth + " = [" + at[0] + ".0, " + at[1] + ".0]";
  if (!text.includes(line)) throw new Error("layout.toml has no line " + line + ":\n" + text);
  const moved = [at[0] + 50, at[1] + 40];
  fs.writeFileSync(file + ".saving", text.replace(line, fourth + " = [" + moved[0] + ".0, " + moved[1] + ".0]"));
  fs.renameSync(file + ".saving", file);
  const t1 = Date.now();
  await page.waitForFunction((a) => {
    const c = document.querySelector(a.sel);
    return !!c && Number(c.getAttribute("cx")) === a.at[0] && Number(c.getAttribute("cy")) === a.at[1];
  }, { sel: circle(fourth), at: moved }, { timeout: 20000 });
  seen.disk_ms = Date.now() - t1;
  await page.waitForFunction(() => page.check.state === "done", null, { timeout: CHECK_MS });
  const read = await settled(page);
  seen.disk = { at: moved, draws: read.draws - after.draws, versions: read.version - after.version,
    check: await page.$eval("#check-state", (e) => e.dataset.state) };
  // Then Reload from another tab, nothing changed: the reload's version
  // and the new check's verdict.
  const t2 = Date.now();
  const r2 = await fetch(new URL("reload", url), { method: "POST", headers: { "content-type": "application/json" }, body: "{}" });
  seen.reload_answer = await r2.json();
  await page.waitForFunction((v) => ED.version > v, read.version, { timeout: 20000 });
  seen.reload_ms = Date.now() - t2;
  await page.waitForFunction((v) => ED.version >= v + 2, read.version, { timeout: CHECK_MS });
  const last = await settled(page);
  seen.reload = { draws: last.draws - read.draws, versions: last.version - read.version,
    check: await page.$eval("#check-state", (e) => e.dataset.state) };
}

(async () => {
  const seen = { errors: [] };
  const browser = await chromium.launch({
    executablePath: process.env.CHROMIUM || "/usr/bin/chromium",
    args: FLAGS,
    timeout: 60000,
  });
  try {
    const page = await browser.newPage({ viewport: { width: 1600, height: 1000 } });
    page.on("pageerror", (e) => seen.errors.push(String(e)));
    const modes = { add, break: breakIt, net: addNet, undo: undoIt, netops: netOps, netundo: netUndo, draws: drawsPerEdit };
    await modes[mode](page, seen);
  } catch (e) {
    seen.failure = String(e && e.stack || e);
  } finally {
    await browser.close();
  }
  process.stdout.write(JSON.stringify(seen) + "\n");
})();
