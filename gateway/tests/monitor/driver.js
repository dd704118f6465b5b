// Drives Debian's chromium with playwright-core for gateway/tests/monitor.rs.
// Usage: node driver.js live|view URL OUT_DIR [SECONDS_AT...]
// Prints one JSON object with what it saw; the Rust test judges it.
// The browser is closed on every path (and dies with this process: it is
// launched over a pipe).
"use strict";
const path = require("path");
const { chromium } = require(process.env.PLAYWRIGHT_CORE || "playwright-core");

const [mode, url, out, ...rest] = process.argv.slice(2);
const FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
  "--disable-background-networking", "--disable-component-update", "--disable-sync"];

async function live(page, seen) {
  await page.goto(url);
  await page.waitForFunction(() => document.querySelectorAll("#nets g.net").length > 0 &&
    document.querySelector("#connection").textContent === "connected" &&
    document.querySelectorAll("#nets g.place.marked").length > 0, null, { timeout: 30000 });
  // (The marking is painted every 250 ms: waiting for a first marked place
  // keeps the initial paint from passing for a place that turned red.)
  seen.ids = await page.$$eval("#nets g.place, #nets g.transition", (els) => els.map((e) => e.id));
  seen.nets = await page.$$eval("#nets g.net", (els) => els.map((e) => e.dataset.net));
  seen.globals = await page.$$eval("#globals .chip", (els) => els.map((e) => e.textContent));
  seen.marked_first = await page.$$eval("#nets g.place.marked", (els) => els.map((e) => e.id));
  seen.log_first = await page.$$eval("#log .row", (els) => els.length);
  await page.screenshot({ path: path.join(out, "monitor-live-start.png") });
  // The flight goes on: wait for a place not marked at first to turn red.
  // (Its colour read at once: a place may stay marked for a moment only.)
  const handle = await page.waitForFunction((first) => {
    const el = [...document.querySelectorAll("#nets g.place.marked")].find((e) => !first.includes(e.id));
    return el && { id: el.id, fill: getComputedStyle(el.querySelector("circle")).fill };
  }, seen.marked_first, { timeout: 120000 });
  const red = await handle.jsonValue();
  seen.turned_red = red.id;
  seen.fill = red.fill;
  seen.unmarked_fill = await page.$eval("#nets g.place:not(.marked) circle", (c) => getComputedStyle(c).fill);
  // The log is written when a frame arrives, the marking painted up to
  // 250 ms later: wait (bounded) for the log rather than reading it once.
  await page.waitForFunction((n) => document.querySelectorAll("#log .row").length > n, seen.log_first,
    { timeout: 30000 }).catch(() => {});
  seen.log_later = await page.$$eval("#log .row", (els) => els.length);
  seen.log_kinds = await page.$$eval("#log .row", (els) => [...new Set(els.map((e) => e.dataset.kind))]);
  seen.strip_mode = await page.$eval("#v-mode b", (b) => b.textContent);
  seen.enabled = await page.$$eval("#nets g.transition.enabled", (els) => els.length);
  await page.screenshot({ path: path.join(out, "monitor-live.png") });
  // Click a transition: its definition; open its net alone.
  const t = process.env.MONITOR_CLICK_TRANSITION;
  await page.click("#nets [id='" + t + "'] rect", { force: true });
  seen.definition = await page.$eval("#def-body", (d) => d.textContent);
  const net = process.env.MONITOR_ZOOM_NET;
  await page.click("#nets .net[data-net='" + net + "'] .net-head");
  await page.waitForSelector("#zoom:not([hidden]) svg");
  await page.mouse.move(500, 400);
  await page.mouse.wheel(0, -300);
  seen.zoom_ids = await page.$$eval("#zoom-view g.place, #zoom-view g.transition", (els) => els.length);
  seen.zoom_marked = await page.$$eval("#zoom-view g.place.marked", (els) => els.length);
  await page.screenshot({ path: path.join(out, "monitor-zoom.png") });
}

async function view(page, seen) {
  await page.goto(url);
  await page.waitForFunction(() => document.querySelector("#connection").textContent === "connected" &&
    !document.querySelector("#timeline").hidden, null, { timeout: 30000 });
  const info = await page.evaluate(() => fetch("page.json").then((r) => r.json()).then((p) => p.timeline));
  seen.timeline = { start_us: info.start_us, end_us: info.end_us, marks: info.marks.length,
    catastrophic: info.marks.filter((m) => m[1] === "catastrophic").length };
  seen.catastrophic_marks_drawn = await page.$$eval("#marks rect[fill='#f22']", (els) => els.length);
  seen.instants = [];
  for (const s of rest.map(Number)) {
    const at = s * 1e6;
    const v = ((at - info.start_us) / (info.end_us - info.start_us) * 1000).toFixed(6);
    const before = await page.$eval("#span", (e) => e.textContent);
    await page.$eval("#scrub", (el, v) => { el.value = v; el.dispatchEvent(new Event("input")); }, v);
    const want = (s - info.origin_us / 1e6).toFixed(1);
    await page.waitForFunction((w) => document.querySelector("#span").textContent.startsWith(w + " /"), want, { timeout: 10000 })
      .catch(() => {});
    const marked = await page.$$eval("#nets g.place.marked", (els) => els.map((e) => e.id));
    const span = await page.$eval("#span", (e) => e.textContent);
    const log = await page.$$eval("#log .row .t", (els) => els.map((e) => Number(e.textContent)));
    seen.instants.push({ at: s, span, before, marked, log_max: Math.max(...log, 0), log_rows: log.length });
    await page.screenshot({ path: path.join(out, "monitor-view-" + s.toFixed(1) + ".png") });
  }
  // Step forward and play a moment: the page moves on by itself.
  const t0 = await page.$eval("#step", (e) => e.textContent);
  await page.click("#next");
  await page.waitForFunction((t) => document.querySelector("#step").textContent !== t, t0, { timeout: 10000 });
  seen.stepped_from = t0;
  seen.stepped_to = await page.$eval("#step", (e) => e.textContent);
  await page.selectOption("#speed", "30");
  await page.click("#play");
  await page.waitForTimeout(1500);
  await page.click("#play");
  seen.played_to = await page.$eval("#step", (e) => e.textContent);
  await page.screenshot({ path: path.join(out, "monitor-view-played.png") });
}

(async () => {
  const seen = { errors: [] };
  const browser = await chromium.launch({
    executablePath: process.env.CHROMIUM || "/usr/bin/chromium",
    // Playwright gives each launch a fresh, empty --user-data-dir.
    args: FLAGS,
    timeout: 60000,
  });
  try {
    const page = await browser.newPage({ viewport: { width: 1600, height: 1000 } });
    page.on("pageerror", (e) => seen.errors.push(String(e)));
    if (mode === "live") await live(page, seen); else await view(page, seen);
  } catch (e) {
    seen.failure = String(e && e.stack || e);
  } finally {
    await browser.close();
  }
  process.stdout.write(JSON.stringify(seen) + "\n");
})();
