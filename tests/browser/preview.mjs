// End-to-end test of `lumo preview` in a real browser (Debian's Chromium, driven by
// playwright-core; no browser download). Run by tests/preview.rs:
//
//   node tests/browser/preview.mjs URL SCENE.json [SCREENSHOT.png]
//
// SCENE.json is a copy of scenes/cornell.json that the preview is serving. The script opens the
// page, checks the image is not blank, recolours the left wall in the file and waits for the
// page to show it, breaks the file and waits for the located error (the last image staying
// visible), fixes it and waits for rendering to resume. Every wait is for an event on the page,
// bounded by a timeout; there are no fixed sleeps. Exit code 0 on success.

import { readFileSync, writeFileSync, renameSync } from "node:fs";
import { chromium } from "playwright-core";

const [url, scenePath, screenshot] = process.argv.slice(2);
if (!url || !scenePath) {
  console.error("usage: node preview.mjs URL SCENE.json [SCREENSHOT.png]");
  process.exit(64);
}
const WAIT = { timeout: 60_000, polling: "raf" };
const RED = '"red": {"base_color": [0.570068, 0.0430135, 0.0443706]';
const BLUE = '"red": {"base_color": [0.05, 0.1, 0.6]';
const BROKEN = '"red": {"base_color": [0.05, 0.1]';

function step(text) {
  console.log(`[preview.mjs] ${text}`);
}

// Editors save by writing a temporary file and renaming it over the scene; do the same.
function save(text) {
  const tmp = scenePath + ".tmp-edit";
  writeFileSync(tmp, text);
  renameSync(tmp, scenePath);
}

const original = readFileSync(scenePath, "utf8");
if (!original.includes(RED)) throw new Error(`${scenePath} does not hold the red wall material`);

const browser = await chromium.launch({
  executablePath: process.env.LUMO_CHROMIUM || "/usr/bin/chromium",
  args: [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
  ],
});
try {
  const page = await browser.newPage({ viewport: { width: 1100, height: 560 } });
  page.on("pageerror", (e) => { console.error(`page error: ${e}`); process.exitCode = 1; });

  // Waits until the page shows a finished path-traced frame of render number `renders` or later.
  const shownDone = (renders) => page.waitForFunction((n) => {
    const s = window.lumoStatus;
    return s && s.renders >= n && s.state === "done" && !s.quick
      && document.body.dataset.shownFrame === String(s.frame);
  }, renders, WAIT);

  // Mean sRGB colour of the canvas's left and right eighths (the walls), and the overall spread.
  const measure = () => page.evaluate(() => {
    const c = document.getElementById("view");
    const px = c.getContext("2d").getImageData(0, 0, c.width, c.height).data;
    const band = (x0, x1) => {
      const sum = [0, 0, 0];
      let n = 0;
      for (let y = Math.floor(c.height * 0.3); y < c.height * 0.7; y++) {
        for (let x = Math.floor(c.width * x0); x < c.width * x1; x++) {
          const i = 4 * (y * c.width + x);
          sum[0] += px[i]; sum[1] += px[i + 1]; sum[2] += px[i + 2]; n++;
        }
      }
      return sum.map((v) => v / n);
    };
    let max = 0;
    let lit = 0;
    for (let i = 0; i < px.length; i += 4) {
      const v = Math.max(px[i], px[i + 1], px[i + 2]);
      max = Math.max(max, v);
      if (v > 8) lit++;
    }
    return { left: band(0.02, 0.12), right: band(0.88, 0.98), max, lit: lit / (px.length / 4),
             width: c.width, height: c.height };
  });

  step(`open ${url}`);
  await page.goto(url);
  await shownDone(1);
  const first = await measure();
  step(`first image ${first.width}×${first.height}: max ${first.max}, lit ${(100 * first.lit).toFixed(0)} %, left wall ${first.left.map(Math.round)}`);
  if (first.max < 100 || first.lit < 0.5) throw new Error("the first image is blank");
  if (!(first.left[0] > 2 * first.left[2])) throw new Error("the left wall is not red");
  const stats = await page.textContent("#stats");
  if (!/spp/.test(stats) || !/samples\/s/.test(stats) || !/error/.test(stats)) {
    throw new Error(`the stats line lacks spp, samples/s or error: ${stats}`);
  }

  step("exposure and the error view");
  const mean = (m) => (m.left[0] + m.left[1] + m.left[2] + m.right[0] + m.right[1] + m.right[2]) / 6;
  await page.locator("#exposure").fill("-2");
  const darker = await measure();
  if (!(mean(darker) < 0.8 * mean(first))) throw new Error(`exposure −2 did not darken: ${mean(first)} → ${mean(darker)}`);
  await page.locator("#exposure").fill("0");
  await page.selectOption("#kind", "error");
  await page.waitForFunction(() => document.body.dataset.shownKind === "error", null, WAIT);
  const error = await measure();
  step(`walls ${mean(first).toFixed(0)} in the image, ${mean(error).toFixed(0)} in the error view`);
  if (!(mean(error) < 0.7 * mean(first)) || error.max === 0) throw new Error("the error view does not show the standard error");
  await page.selectOption("#kind", "image");
  await page.waitForFunction(() => document.body.dataset.shownKind === "image", null, WAIT);

  step("recolour the left wall blue in the scene file");
  save(original.replace(RED, BLUE));
  await shownDone(2);
  const blue = await measure();
  step(`left wall now ${blue.left.map(Math.round)}`);
  if (!(blue.left[2] > 2 * blue.left[0])) throw new Error("the left wall did not turn blue");
  if (Math.abs(blue.right[1] - first.right[1]) > 30) throw new Error("the right wall changed too");
  if (screenshot) {
    await page.screenshot({ path: screenshot });
    step(`screenshot ${screenshot}`);
  }

  step("break the scene file");
  save(original.replace(RED, BROKEN));
  await page.waitForFunction(() => {
    const e = document.getElementById("error");
    return e.offsetParent !== null && /:\d+:\d+/.test(e.textContent);
  }, null, WAIT);
  const report = await page.textContent("#error");
  step(`error shown: ${report.trim().split("\n").pop().trim()}`);
  if (!report.includes("materials.red.base_color") || !/\.json:25:\d+/.test(report)) {
    throw new Error(`the report does not locate the problem: ${report}`);
  }
  const kept = await measure();
  if (Math.abs(kept.left[2] - blue.left[2]) > 1 || kept.max < 100) {
    throw new Error("the last good image did not stay visible");
  }

  step("fix the scene file");
  const before = await page.evaluate(() => window.lumoStatus.renders);
  save(original);
  await shownDone(before + 1);
  const fixed = await measure();
  const hidden = await page.evaluate(() => document.getElementById("error").offsetParent === null);
  if (!hidden) throw new Error("the error is still shown after the fix");
  if (!(fixed.left[0] > 2 * fixed.left[2])) throw new Error("rendering did not resume with the fixed scene");
  step(`rendering resumed: left wall ${fixed.left.map(Math.round)}`);
  step("ok");
} finally {
  await browser.close();
}
