// Two browsers on the web monitor for gateway/benches/monitor_load.rs.
// Usage: node browsers.js URL
// Launches two Debian chromium processes (headless), opens the page in each
// — the second with its CPU throttled 20 times (a slow browser) — prints
// "ready" once both are connected, keeps them open until its stdin closes,
// then prints one JSON line (WebSocket frames and bytes each received, the
// step each shows) and closes both. The browsers die with this process
// (launched over a pipe).
"use strict";
const { chromium } = require(process.env.PLAYWRIGHT_CORE || "playwright-core");

const FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
  "--disable-background-networking", "--disable-component-update", "--disable-sync"];

async function main() {
  const url = process.argv[2];
  const launch = () => chromium.launch({ executablePath: process.env.CHROMIUM || "/usr/bin/chromium", args: FLAGS });
  const browsers = [await launch(), await launch()];
  const pages = [];
  const seen = { frames: [0, 0], bytes: [0, 0] };
  for (const [i, b] of browsers.entries()) {
    const page = await b.newPage();
    page.on("websocket", (ws) => ws.on("framereceived", (f) => {
      seen.frames[i] += 1;
      seen.bytes[i] += f.payload.length;
    }));
    pages.push(page);
  }
  const cdp = await pages[1].context().newCDPSession(pages[1]);
  await cdp.send("Emulation.setCPUThrottlingRate", { rate: 20 });
  const connected = () => document.querySelector("#connection") &&
    document.querySelector("#connection").textContent === "connected";
  await Promise.all(pages.map((p) => p.goto(url, { timeout: 120000 })));
  await Promise.all(pages.map((p) => p.waitForFunction(connected, null, { timeout: 120000 })));
  console.log("ready");
  await new Promise((done) => {
    process.stdin.on("end", done);
    process.stdin.on("error", done);
    process.stdin.resume();
  });
  seen.steps = await Promise.all(pages.map((p) => p.$eval("#step", (e) => e.textContent).catch(() => null)));
  console.log(JSON.stringify(seen));
  await Promise.all(browsers.map((b) => b.close()));
}

main().catch((e) => {
  console.error(String(e));
  process.exit(1);
});
