// Drives Debian's chromium with playwright-core for gateway/tests/edit.rs:
// the editor (`petrel edit`) used as a person does, with clicks and typing.
// Usage: node driver.js add|break URL OUT_DIR
//   add:   a transition added to COMMUNICATION (first without arcs: the
//          loader's problem shown on it), named, given its event and arcs;
//          its place dragged; wait for the check's verdict.
//   break: a place added and an output arc to it that makes the check fail;
//          its counterexample stepped through to the end.
// Prints one JSON object with what it saw; the Rust test judges it. The
// browser is closed on every path.
"use strict";
const path = require("path");
const { chromium } = require(process.env.PLAYWRIGHT_CORE || "playwright-core");

const [mode, url, out] = process.argv.slice(2);
const NET = "COMMUNICATION";
const FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
  "--disable-background-networking", "--disable-component-update", "--disable-sync"];
const CHECK_MS = 400000;

// A spot of the net's drawing at least 45 units from every node.
async function emptySpot(page) {
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
  }, NET);
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
  await page.click(el("place", "proceeding") + " circle", { force: true });
  await page.click(el("transition", "rc_back") + " rect", { force: true });
  await page.waitForFunction((s) => !!document.querySelector(s), svg + ' .arc[data-transition="rc_back"][data-input="true"]', { timeout: 20000 });
  await page.click(el("transition", "rc_back") + " rect", { force: true });
  await page.click(el("place", "proceeding") + " circle", { force: true });
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
  await page.click(el("transition", "rc_back") + " rect", { force: true });
  await page.screenshot({ path: path.join(out, "edit-added.png") });
}

async function breakIt(page, seen) {
  await page.goto(url);
  await page.waitForSelector(svg, { timeout: 30000 });
  await page.click("#tool-place");
  await page.click(svg, { position: await emptySpot(page) });
  await page.waitForSelector(el("place", "p1"), { timeout: 20000 });
  await page.click("#tool-arc");
  await page.click(el("transition", "rc_back") + " rect", { force: true });
  await page.click(el("place", "p1") + " circle", { force: true });
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
    if (mode === "add") await add(page, seen); else await breakIt(page, seen);
  } catch (e) {
    seen.failure = String(e && e.stack || e);
  } finally {
    await browser.close();
  }
  process.stdout.write(JSON.stringify(seen) + "\n");
})();
