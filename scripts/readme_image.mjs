// The README's image: the headline chart of a report (Speed vs accuracy over all scenes: every
// denoiser's overall error score, with its interval, against its time per frame), as a small PNG.
// Run after the default study (bash scripts/study.sh), from the repository root:
//   node scripts/readme_image.mjs report/index.html docs/images/report-headline.png
// Needs reports/node_modules (scripts/setup.sh) and Debian's Chromium (scripts/test.sh installs it).
import { createRequire } from 'node:module';
import path from 'node:path';
import { fileURLToPath, pathToFileURL } from 'node:url';

const repo = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..');
const require = createRequire(path.join(repo, 'reports', 'package.json'));
const { chromium } = require('playwright-core');

const [report, out] = process.argv.slice(2);
if (!report || !out) {
  console.error('usage: node scripts/readme_image.mjs REPORT/index.html OUT.png');
  process.exit(2);
}
const browser = await chromium.launch({ executablePath: process.env.CHROMIUM_PATH || '/usr/bin/chromium' });
try {
  const page = await browser.newPage({ viewport: { width: 1100, height: 900 }, deviceScaleFactor: 1 });
  await page.goto(pathToFileURL(path.resolve(report)).href);
  await page.waitForSelector('body[data-ready]', { timeout: 30000 });
  if ((await page.evaluate(() => document.body.dataset.ready)) !== 'true') throw new Error(`${report}: the report failed to load`);
  await page.waitForSelector('#speed-chart svg, #speed-chart canvas', { timeout: 30000 });
  await page.locator('#speed').screenshot({ path: out });
  console.log(`wrote ${out}`);
} finally {
  await browser.close();
}
