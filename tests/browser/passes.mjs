// The preview page as an image viewer, in a real browser (Debian's Chromium, driven by
// playwright-core; no browser download). Run by tests/preview.rs:
//
//   node tests/browser/passes.mjs URL OUT_DIR
//
// URL serves a finished render with render passes. The script checks in the page what only the
// page knows (the selector, the view fitting the window, zoom about the cursor, dragging, the
// keys, refitting on resize), and writes what the test compares with the server's floats and
// lumo's own colour mapping to OUT_DIR: report.json (the canvas's pixels in every view, the
// readout under the cursor at a few pixels) and zoom.png (a screenshot of the magnified image,
// for the nearest-neighbour check). Every wait is for a state of the page, bounded by a
// timeout; there are no fixed sleeps. Exit code 0 on success.

import { writeFileSync } from "node:fs";
import { join } from "node:path";
import { chromium } from "playwright-core";

const [url, outDir] = process.argv.slice(2);
if (!url || !outDir) {
  console.error("usage: node passes.mjs URL OUT_DIR");
  process.exit(64);
}
const WAIT = { timeout: 60_000, polling: "raf" };

function step(text) {
  console.log(`[passes.mjs] ${text}`);
}
function check(ok, message) {
  if (!ok) throw new Error(message);
}
const near = (a, b, tolerance) => Math.abs(a - b) <= tolerance;

const browser = await chromium.launch({
  executablePath: process.env.LUMO_CHROMIUM || "/usr/bin/chromium",
  args: [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
    "--force-color-profile=srgb",
  ],
});
try {
  const page = await browser.newPage({ viewport: { width: 1000, height: 600 } });
  page.on("pageerror", (e) => { console.error(`page error: ${e}`); process.exitCode = 1; });
  const report = { views: {}, readouts: [] };

  // The canvas's box and the viewport's, in page coordinates.
  const boxes = () => page.evaluate(() => {
    const box = (el) => { const r = el.getBoundingClientRect(); return { x: r.left, y: r.top, w: r.width, h: r.height }; };
    return { canvas: box(document.getElementById("view")), viewport: box(document.getElementById("viewport")) };
  });
  // Whether the canvas is the whole image fitted to the viewport, centred.
  const fitted = (b, [w, h]) => {
    const z = Math.min(b.viewport.w / w, b.viewport.h / h);
    return near(b.canvas.w, w * z, 0.5) && near(b.canvas.h, h * z, 0.5)
      && near(b.canvas.x - b.viewport.x, (b.viewport.w - w * z) / 2, 0.5)
      && near(b.canvas.y - b.viewport.y, (b.viewport.h - h * z) / 2, 0.5);
  };
  // The page position of the centre of image pixel (x, y).
  const at = (b, [w, h], x, y) => ({
    x: b.canvas.x + (x + 0.5) * b.canvas.w / w,
    y: b.canvas.y + (y + 0.5) * b.canvas.h / h,
  });
  const waitFor = (f, arg) => page.waitForFunction(f, arg, WAIT);

  step(`open ${url}`);
  await page.goto(url);
  await waitFor(() => {
    const s = window.lumoStatus;
    return s && s.state === "done" && !s.quick && s.denoiser !== "loading"
      && document.body.dataset.shownFrame === String(s.frame);
  });
  const status = await page.evaluate(() => window.lumoStatus);
  const size = [status.image_width, status.image_height];
  report.status = status;

  step("the selector");
  report.options = await page.$$eval("#kind option", (os) => os.map((o) => ({ value: o.value, disabled: o.disabled, text: o.textContent })));
  report.denoise_note = await page.textContent("#denoise-note");
  step(`options: ${report.options.map((o) => o.value + (o.disabled ? " (disabled)" : "")).join(", ")}`);

  step("fit to the window");
  const first = await boxes();
  check(fitted(first, size), `the image is not fitted to the window: ${JSON.stringify(first)}`);

  // Each view, once the page shows it for the latest frame: the canvas's pixels.
  const denoise = report.options.some((o) => o.value === "denoised" && !o.disabled);
  const kinds = ["normal", "depth", "position", "uv", "object_id", "material_id", "albedo", "error", "image"];
  if (denoise) kinds.splice(kinds.length - 1, 0, "denoised");
  for (const kind of kinds) {
    await page.selectOption("#kind", kind);
    await waitFor((k) => document.body.dataset.shownKind === k
      && document.body.dataset.shownFrame === String(window.lumoStatus.frame), kind);
    report.views[kind] = await page.evaluate(() => {
      const c = document.getElementById("view");
      const px = c.getContext("2d").getImageData(0, 0, c.width, c.height).data;
      return { frame: Number(document.body.dataset.shownFrame), width: c.width, height: c.height, rgba: Array.from(px) };
    });
    step(`${kind} shown`);
  }

  step("the readout under the cursor");
  const readAt = async (x, y) => {
    const p = at(await boxes(), size, x, y);
    await page.mouse.move(p.x, p.y);
    // Every row filled in for this pixel (the passes are fetched once the cursor is on the image).
    await waitFor(([x, y]) => {
      const rx = document.getElementById("readout-x");
      const ry = document.getElementById("readout-y");
      return rx && rx.textContent === String(x) && ry.textContent === String(y)
        && [...document.querySelectorAll("#readout-body tr")].every((tr) => tr.querySelector("td[data-channel]"));
    }, [x, y]);
    return page.$$eval("#readout-body tr", (rows) => rows.map((tr) => ({
      kind: tr.dataset.kind,
      values: Object.fromEntries([...tr.querySelectorAll("td[data-channel]")].map((td) => [td.dataset.channel, td.querySelector(".v").textContent])),
    })));
  };
  for (const [x, y] of [[3, 20], [Math.floor(size[0] / 2), Math.floor(size[1] / 3)], [size[0] - 5, size[1] - 4]]) {
    report.readouts.push({ x, y, rows: await readAt(x, y) });
  }

  step("wheel zoom about the cursor");
  const target = [Math.floor(size[0] * 0.3), Math.floor(size[1] * 0.6)];
  const before = await boxes();
  // Mouse events carry whole CSS pixels: put the cursor on one, inside the target pixel.
  const centre = at(before, size, ...target);
  const p = { x: Math.round(centre.x), y: Math.round(centre.y) };
  await page.mouse.move(p.x, p.y);
  for (let i = 0; i < 3; i++) await page.mouse.wheel(0, -300);
  await waitFor((w) => document.getElementById("view").getBoundingClientRect().width > 7 * w, before.canvas.w);
  const zoomed = await boxes();
  const factor = zoomed.canvas.w / before.canvas.w;
  step(`zoomed ×${factor.toFixed(3)}`);
  check(near(factor, 8, 0.01), `three wheel notches of 300 did not zoom ×8: ×${factor}`);
  // The image point under the cursor stayed there.
  const under = (b) => [(p.x - b.canvas.x) * size[0] / b.canvas.w, (p.y - b.canvas.y) * size[1] / b.canvas.h];
  const [u0, v0] = under(before);
  const [u1, v1] = under(zoomed);
  check(near(u0, u1, 0.01) && near(v0, v1, 0.01), `the point under the cursor moved: (${u0}, ${v0}) → (${u1}, ${v1})`);
  const rx = await page.textContent("#readout-x");
  const ry = await page.textContent("#readout-y");
  check(rx === String(target[0]) && ry === String(target[1]), `the readout left the pixel under the cursor: ${rx}, ${ry}`);
  // Magnified pixels are drawn nearest-neighbour: the test compares this screenshot with the
  // canvas (report.zoom), pixel by pixel.
  const clip = { x: zoomed.viewport.x, y: zoomed.viewport.y, width: Math.floor(zoomed.viewport.w), height: Math.floor(zoomed.viewport.h) };
  await page.mouse.move(clip.x + clip.width + 5, clip.y + 5); // the cursor off the image
  await page.screenshot({ path: join(outDir, "zoom.png"), clip });
  report.zoom = {
    canvas: { x: zoomed.canvas.x - clip.x, y: zoomed.canvas.y - clip.y, w: zoomed.canvas.w, h: zoomed.canvas.h },
    rendering: await page.$eval("#view", (c) => getComputedStyle(c).imageRendering),
  };

  step("drag to pan");
  const start = { x: clip.x + clip.width / 2, y: clip.y + clip.height / 2 };
  await page.mouse.move(start.x, start.y);
  await page.mouse.down();
  await page.mouse.move(start.x + 60, start.y + 40, { steps: 4 });
  await page.mouse.up();
  const dragged = await boxes();
  check(near(dragged.canvas.x - zoomed.canvas.x, 60, 0.5) && near(dragged.canvas.y - zoomed.canvas.y, 40, 0.5),
    `dragging by (60, 40) moved the image by (${dragged.canvas.x - zoomed.canvas.x}, ${dragged.canvas.y - zoomed.canvas.y})`);

  step("keys: 1 for 100 %, F to fit");
  await page.keyboard.press("1");
  await waitFor((w) => Math.abs(document.getElementById("view").getBoundingClientRect().width - w) < 0.01, size[0]);
  await page.keyboard.press("f");
  await waitFor(() => document.getElementById("zoom").textContent.includes("fit"));
  check(fitted(await boxes(), size), "F did not fit the image to the window");

  step("a smaller window refits");
  await page.setViewportSize({ width: 640, height: 420 });
  // The page refits on the window's resize event: wait until the canvas fits the new viewport.
  await waitFor(([w, h]) => {
    const c = document.getElementById("view").getBoundingClientRect();
    const v = document.getElementById("viewport").getBoundingClientRect();
    const z = Math.min(v.width / w, v.height / h);
    return v.width < 640 && Math.abs(c.width - w * z) < 0.5 && Math.abs(c.height - h * z) < 0.5;
  }, size);
  const resized = await boxes();
  check(resized.viewport.w < first.viewport.w && fitted(resized, size),
    `the image was not refitted to the smaller window: ${JSON.stringify(resized)}`);

  writeFileSync(join(outDir, "report.json"), JSON.stringify(report));
  step("ok");
} finally {
  await browser.close();
}
