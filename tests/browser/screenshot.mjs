// Screenshot of a `lumo preview` page once its render is done, the cursor on the image so that
// the readout shows its values (docs/preview.png):
//
//   lumo preview scenes/cornell.json --aov albedo,normal,depth,object_id --port 8123 &
//   node tests/browser/screenshot.mjs http://127.0.0.1:8123/ docs/preview.png
import { chromium } from "playwright-core";

const [url, out] = process.argv.slice(2);
const browser = await chromium.launch({
  executablePath: process.env.LUMO_CHROMIUM || "/usr/bin/chromium",
  args: ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--force-color-profile=srgb"],
});
try {
  const page = await browser.newPage({ viewport: { width: 1040, height: 620 } });
  await page.goto(url);
  await page.waitForFunction(() => {
    const s = window.lumoStatus;
    return s && s.state === "done" && document.body.dataset.shownFrame === String(s.frame);
  }, null, { timeout: 300_000 });
  const box = await page.locator("#view").boundingBox();
  await page.mouse.move(box.x + box.width * 0.3, box.y + box.height * 0.55);
  await page.waitForFunction(() => [...document.querySelectorAll("#readout-body tr")]
    .every((tr) => tr.querySelector("td[data-channel]")), null, { timeout: 60_000 });
  await page.screenshot({ path: out });
} finally {
  await browser.close();
}
