// Screenshot of a `lumo preview` page once its render is done (docs/preview.png):
//
//   lumo preview scenes/cornell.json --port 8123 &
//   node tests/browser/screenshot.mjs http://127.0.0.1:8123/ docs/preview.png
import { chromium } from "playwright-core";

const [url, out] = process.argv.slice(2);
const browser = await chromium.launch({
  executablePath: process.env.LUMO_CHROMIUM || "/usr/bin/chromium",
  args: ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync"],
});
try {
  const page = await browser.newPage({ viewport: { width: 760, height: 640 } });
  await page.goto(url);
  await page.waitForFunction(() => {
    const s = window.lumoStatus;
    return s && s.state === "done" && document.body.dataset.shownFrame === String(s.frame);
  }, null, { timeout: 300_000 });
  await page.screenshot({ path: out });
} finally {
  await browser.close();
}
