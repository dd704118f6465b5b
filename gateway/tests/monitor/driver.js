// Drives Debian's chromium with playwright-core for gateway/tests/monitor.rs.
// Usage: node driver.js live|view|view-versions URL OUT_DIR [SECONDS_AT...]
//        node driver.js mirror|mirror-read-only URL OUT_DIR [CHOICE]
//        (gateway/tests/monitor_mirror.rs: the mirror's page)
//        node driver.js team URL OUT_DIR
//        (gateway/tests/monitor_team.rs: a team's live page; MONITOR_SIGNALS)
// Prints one JSON object with what it saw; the Rust test judges it.
// The browser is closed on every path (and dies with this process: it is
// launched over a pipe).
"use strict";
const path = require("path");
const { chromium } = require(process.env.PLAYWRIGHT_CORE || "playwright-core");

const [mode, url, out, ...rest] = process.argv.slice(2);
const FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
  "--disable-background-networking", "--disable-component-update", "--disable-sync"];

// Every net's labels as rendered (10 drawing units: px on the page) and
// the marked places of each active net outside its card's view.
function readability() {
  return [...document.querySelectorAll("#nets div.net")].map((n) => {
    const svg = n.querySelector("svg");
    if (!svg) return { net: n.dataset.net, px: 0, out: ["no drawing"] };
    const body = svg.parentElement;
    const px = svg.getBoundingClientRect().width / svg.viewBox.baseVal.width * 10;
    const box = body.getBoundingClientRect();
    const out = n.classList.contains("inactive") ? [] : [...body.querySelectorAll("g.place.marked")]
      .filter((m) => {
        const r = m.getBoundingClientRect();
        return r.left < box.left - 1 || r.right > box.right + 1 || r.top < box.top - 1 || r.bottom > box.bottom + 1;
      }).map((m) => m.id);
    return { net: n.dataset.net, px, out };
  });
}

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
  // Legible at the page's size, the marking in view as the flight goes on
  // (read after the next frames: the page follows on each frame).
  await page.waitForTimeout(600);
  seen.readable = await page.evaluate(readability);
  // Click a transition: its definition; open its net alone.
  const t = process.env.MONITOR_CLICK_TRANSITION;
  // The click is dispatched on the bar itself: a click at its position
  // could land elsewhere when the nets' headers (the marked places' names,
  // changing as the flight goes on) move the drawing meanwhile.
  await page.dispatchEvent("#nets [id='" + t + "'] rect", "click");
  await page.waitForFunction((t) => document.querySelector("#nets [id='" + t + "']").classList.contains("selected"),
    t, { timeout: 10000 }).catch(() => {});
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

// A recording whose project took a new version in flight: at each
// instant (seconds), the transitions drawn and the places marked, after
// the page loaded again for another version if the scrub crossed a swap.
async function viewVersions(page, seen) {
  await page.goto(url);
  const ready = (want) => page.waitForFunction((w) => document.querySelector("#connection").textContent === "connected" &&
    !document.querySelector("#timeline").hidden && (w === null || document.querySelector("#span").textContent.startsWith(w + " /")),
    want, { timeout: 15000 });
  await ready(null);
  const info = await page.evaluate(() => fetch("page.json").then((r) => r.json()).then((p) => p.timeline));
  seen.instants = [];
  for (const s of rest.map(Number)) {
    const v = ((s * 1e6 - info.start_us) / (info.end_us - info.start_us) * 1000).toFixed(6);
    await page.$eval("#scrub", (el, v) => { el.value = v; el.dispatchEvent(new Event("input")); }, v);
    const want = (s - info.origin_us / 1e6).toFixed(1);
    // Crossing a swap loads the page again (its hash says the version and
    // the instant): wait for it connected and at the instant.
    await page.waitForTimeout(500);
    await ready(want).catch(() => {});
    await page.waitForTimeout(400);
    seen.instants.push({
      at: s,
      hash: await page.evaluate(() => location.hash),
      span: await page.$eval("#span", (e) => e.textContent),
      transitions: await page.$$eval("#nets g.transition", (els) => els.map((e) => e.id)),
      marked: await page.$$eval("#nets g.place.marked", (els) => els.map((e) => e.id)),
    });
    await page.screenshot({ path: path.join(out, "monitor-view-version-" + s.toFixed(1) + ".png") });
  }
}

// The mirror's page: the replica agreeing, a question counting down; with
// a CHOICE, its button clicked and the question seen answered.
async function mirror(page, seen, readOnly) {
  const name = readOnly ? "monitor-mirror-read-only" : "monitor-mirror";
  // The radio's state is the test's, changed when told (files in
  // MONITOR_SIGNALS); the page must show each stage.
  const signals = process.env.MONITOR_SIGNALS;
  const tell = (what) => require("fs").writeFileSync(path.join(signals, what), what);
  // The banner in a state, read in the same instant (it may change the
  // next: a loaded machine's mirror hears nothing for a moment).
  const banner = async (state, timeout, also) => {
    const h = await page.waitForFunction(([s, re]) => {
      const e = document.querySelector("#agreement");
      return e.className === s && (!re || new RegExp(re).test(e.textContent)) && { state: e.className, text: e.textContent };
    }, [state, also || null], { timeout });
    return h.jsonValue();
  };
  const until = async (state, timeout) => {
    seen[state] = await banner(state, timeout);
    await page.screenshot({ path: path.join(out, name + "-" + state + ".png") });
  };
  await page.goto(url);
  await page.waitForFunction(() => document.querySelector("#connection").textContent === "connected" &&
    !document.querySelector("#mirror").hidden, null, { timeout: 30000 });
  seen.mode = await page.$eval("#mode", (e) => e.textContent);
  seen.agreement = await banner("exact", 60000, "last agreed step \\d+");
  // Read-only, on a project whose ask differs from the vehicle's: the
  // uplink lost before the question, the replica diverges when it asks
  // and cannot ask for a snapshot (the periodic one repairs it).
  if (readOnly && signals) tell("uplink-lost");
  const q = await page.waitForSelector(".question.open", { timeout: 90000 });
  seen.question_id = Number(await q.getAttribute("data-id"));
  // The answer desk's verdict comes apart from the frames: wait for it.
  await page.waitForFunction(() => {
    const el = document.querySelector(".question.open");
    const b = el && el.querySelector("button");
    return el && b && (!b.hidden || el.querySelector(".status").textContent !== "");
  }, null, { timeout: 10000 });
  const read = () => page.$eval(".question.open", (el) => ({
    text: el.querySelector(".ask b").textContent,
    head: el.querySelector(".ask small").textContent,
    left: el.querySelector(".left").textContent,
    buttons: [...el.querySelectorAll("button")].filter((b) => !b.hidden && b.offsetParent !== null).map((b) => b.textContent),
    status: el.querySelector(".status").textContent,
  }));
  seen.question = await read();
  await page.screenshot({ path: path.join(out, name + ".png") });
  // The countdown runs on the vehicle's time: a moment later, less left.
  await page.waitForFunction((l) => document.querySelector(".question.open .left").textContent !== l,
    seen.question.left, { timeout: 15000 }).catch(() => {});
  seen.question_later = await read();
  seen.disagreements = await page.$eval("#disagreements", (e) => e.textContent);
  if (readOnly && signals) {
    await until("diverged", 30000);
    tell("uplink");
    seen.repaired = await banner("exact", 60000);
  }
  const choice = rest[0];
  if (readOnly || !choice) return;
  // Requests the page would never make are refused: a simple POST (what
  // any site's form can send), one from another origin (localhost is not
  // 127.0.0.1), and a choice the question does not offer.
  seen.forged = await page.evaluate(async (id) => {
    const json = { "Content-Type": "application/json", "X-Petrel-Answer": "1" };
    const body = JSON.stringify({ id: id, choice: "no" });
    const other = location.href.replace("127.0.0.1", "localhost") + "answer";
    const out = {};
    out.simple = await fetch("answer", { method: "POST", body }).then((r) => r.status).catch((e) => String(e));
    out.cross_origin = await fetch(other, { method: "POST", headers: json, body }).then((r) => r.status).catch((e) => "blocked: " + e.name);
    out.no_cors = await fetch(other, { method: "POST", mode: "no-cors", body }).then((r) => r.type).catch((e) => "blocked: " + e.name);
    out.not_offered = await fetch("answer", { method: "POST", headers: json, body: JSON.stringify({ id: id, choice: "maybe" }) })
      .then((r) => r.json());
    return out;
  }, seen.question_id);
  await page.click(".question.open button[data-choice='" + choice + "']");
  const id = seen.question_id;
  await page.waitForSelector("#done-" + id, { timeout: 60000 });
  seen.closed = await page.$eval("#done-" + id, (el) => ({ fate: el.dataset.fate, status: el.querySelector(".status").textContent }));
  seen.log_answer = await page.$$eval("#log .row[data-kind='answer']", (els) => els.map((e) => e.textContent));
  await page.screenshot({ path: path.join(out, name + "-answered.png") });
  // The radio fades, as the test makes it when told (files in
  // MONITOR_SIGNALS): the downlink lost (the page says the vehicle is
  // silent) while the next question is answered; then the downlink back
  // and the uplink lost (the answer's record missing, not asked again:
  // provisional); then both back (exact again).
  if (!signals) return;
  const next = await page.waitForSelector(".question.open", { timeout: 90000 });
  const second = Number(await next.getAttribute("data-id"));
  seen.second_id = second;
  tell("fade");
  await until("silent", 30000);
  await page.click("#q-" + second + " button[data-choice='no']");
  // Sent: the mirror's frame says so, and the page has heard the desk's
  // verdict (the two come apart; either may be first).
  await page.waitForFunction((id) => {
    const q = document.querySelector("#q-" + id);
    return q && q.dataset.fate === "sent" && !q.querySelector(".status").textContent.startsWith("sending");
  }, second, { timeout: 10000 }).catch(() => {});
  seen.second_sent = await page.$eval("#q-" + second + " .status", (e) => e.textContent);
  await page.waitForTimeout(1000);
  tell("downlink");
  await until("provisional", 30000);
  tell("uplink");
  seen.repaired = await banner("exact", 60000);
  seen.second_closed = await page.$eval("#done-" + second, (el) => el.dataset.fate).catch(() => null);
}

// A team's live page: one group per vehicle and the team's, every vehicle
// on the map moving; told when the test has failed R1's engine
// ("moved" written to MONITOR_SIGNALS, then the page watched), R1's group
// must show locked out, the others not.
async function team(page, seen) {
  const tell = (what) => require("fs").writeFileSync(path.join(process.env.MONITOR_SIGNALS, what), what);
  await page.goto(url);
  await page.waitForFunction(() => document.querySelector("#connection").textContent === "connected" &&
    document.querySelectorAll("#nets .group").length > 0, null, { timeout: 30000 });
  seen.groups = await page.$$eval("#nets > .group", (els) => els.map((g) => ({
    id: g.id, vehicle: g.dataset.vehicle || null,
    nets: [...g.querySelectorAll("div.net")].map((n) => n.dataset.net),
    head: g.querySelector(".group-head").textContent,
  })));
  seen.strip_hidden = await page.$eval("#strip", (e) => e.hidden);
  const markers = () => [...document.querySelectorAll("#map g.marker")].map((g) => ({
    vehicle: g.dataset.vehicle, lat: +g.dataset.lat, lon: +g.dataset.lon,
    fill: g.querySelector("circle").getAttribute("fill"), label: (g.querySelector("text") || {}).textContent || null }));
  const first = await page.waitForFunction((f) => {
    const m = eval(f)();
    return m.length >= 2 && m;
  }, "(" + markers.toString() + ")", { timeout: 60000 });
  seen.markers_first = await first.jsonValue();
  // Every marker moves (more than about 2 m).
  const moved = await page.waitForFunction(([f, first]) => {
    const m = eval(f)();
    return first.every((a) => m.some((b) => b.vehicle === a.vehicle &&
      (Math.abs(b.lat - a.lat) > 2e-5 || Math.abs(b.lon - a.lon) > 2e-5))) && m;
  }, ["(" + markers.toString() + ")", seen.markers_first], { timeout: 120000 });
  seen.markers_moved = await moved.jsonValue();
  seen.tracks = await page.$$eval("#map polyline.track", (els) => els.map((e) => ({
    vehicle: e.dataset.vehicle, stroke: e.getAttribute("stroke"), points: e.getAttribute("points").split(" ").length })));
  seen.modes = await page.$$eval("#nets > .group[data-vehicle]", (els) => els.map((g) => g.querySelector(".g-mode b").textContent));
  await page.screenshot({ path: path.join(out, "monitor-team.png") });
  seen.readable = await page.evaluate(readability);
  tell("moved");
  await page.waitForFunction(() => {
    const g = document.querySelector("#nets > .group[data-vehicle='R1']");
    return g && g.classList.contains("locked");
  }, null, { timeout: 60000 });
  seen.locked = await page.$$eval("#nets > .group", (els) => els.map((g) => ({
    vehicle: g.dataset.vehicle || null, locked: g.classList.contains("locked"),
    badge: !g.querySelector(".g-lock").hidden, events: (g.querySelector(".g-events") || {}).textContent || "" })));
  seen.banner = await page.$eval("#lockout", (e) => ({ hidden: e.hidden, text: e.textContent }));
  await page.screenshot({ path: path.join(out, "monitor-team-locked.png") });
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
    if (mode === "live") await live(page, seen);
    else if (mode.startsWith("mirror")) await mirror(page, seen, mode === "mirror-read-only");
    else if (mode === "team") await team(page, seen);
    else if (mode === "view-versions") await viewVersions(page, seen);
    else await view(page, seen);
  } catch (e) {
    seen.failure = String(e && e.stack || e);
  } finally {
    await browser.close();
  }
  process.stdout.write(JSON.stringify(seen) + "\n");
})();
