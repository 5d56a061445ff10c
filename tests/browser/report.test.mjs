// Browser test of `arena report`: headless Chromium (Debian's, /usr/bin/chromium) driven by
// playwright-core opens the generated report from disk (file://, no server) and checks what a
// person would: the charts drew the expected marks, the image viewer loads, zooms every panel and
// follows the frame selector, a failed pair is shown, and nothing logs an error. Run with
// `node --test` (ctest: browser_report); needs ARENA_BINARY (the built `arena`) and reports/node_modules.
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import { createRequire } from 'node:module';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath, pathToFileURL } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const repo = path.resolve(here, '..', '..');
// playwright-core lives in reports/node_modules (installed by scripts/setup.sh); resolving from
// reports/package.json finds it whatever the working directory or NODE_PATH.
const require = createRequire(path.join(repo, 'reports', 'package.json'));
const { chromium } = require('playwright-core');

const ARENA = process.env.ARENA_BINARY;
const CHROMIUM = process.env.CHROMIUM_PATH || '/usr/bin/chromium';
const ARTIFACTS = path.join(repo, 'tests', 'artifacts');
const FRAMES = 16;  // light_switch's light goes off at frame 12: the ghosting panel has an event

let work, context;

function arena(...args) {
  return execFileSync(ARENA, args, { encoding: 'utf8', stdio: ['ignore', 'pipe', 'pipe'] });
}

function tinyRun(out, extra = []) {
  arena('run', '--scenes', 'cornell_static,light_switch', '--resolution', '48x27', '--frames', String(FRAMES),
    '--ref-spp', '16', '--flip', 'ldr', '--warmup', '4', '--cache', path.join(work, 'cache'), '--out', out, ...extra);
}

// A run with a failed pair, as the run matrix records one (status, error, no results).
function failOnePair(runDir, scene, label) {
  const file = path.join(runDir, 'results.json');
  const results = JSON.parse(fs.readFileSync(file, 'utf8'));
  const i = results.pairs.findIndex((p) => p.scene === scene && p.label === label);
  assert.ok(i >= 0, `fixture: no pair ${label} on ${scene}`);
  const p = results.pairs[i];
  results.pairs[i] = { scene: p.scene, denoiser: p.denoiser, label: p.label, params: {}, status: 'failed',
                       error: 'eaw: injected failure for the browser test' };
  fs.writeFileSync(file, JSON.stringify(results));
  return results;
}

async function openReport(dir) {
  const page = await context.newPage();
  const problems = [];
  page.on('console', (m) => { if (m.type() === 'error') problems.push(`console error: ${m.text()}`); });
  page.on('pageerror', (e) => problems.push(`page error: ${e.message}`));
  // Opens from disk with no network: anything but file: and data: URLs is a bug.
  page.on('request', (r) => { if (!/^(file|data|blob):/.test(r.url())) problems.push(`network request: ${r.url()}`); });
  await page.goto(pathToFileURL(path.join(dir, 'index.html')).href);
  await page.waitForSelector('body[data-ready]', { timeout: 30000 });
  assert.equal(await page.evaluate(() => document.body.dataset.ready), 'true', problems.join('\n'));
  return { page, problems };
}

// Points of the speed-vs-accuracy chart: the symbols of its 'points' layer (legend symbols excluded).
const speedPoints = (page) => page.locator('#speed-chart g.mark-symbol.role-mark.points_marks path').count();

before(async () => {
  assert.ok(ARENA && fs.existsSync(ARENA), 'set ARENA_BINARY to the built arena executable');
  assert.ok(fs.existsSync(CHROMIUM), `${CHROMIUM} is missing: apt-get install chromium (scripts/test.sh does)`);
  work = fs.mkdtempSync(path.join(os.tmpdir(), 'arena-browser-'));
  const userData = fs.mkdtempSync(path.join(os.tmpdir(), 'arena-chromium-'));
  context = await chromium.launchPersistentContext(userData, {
    executablePath: CHROMIUM,
    headless: true,
    args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
           '--disable-background-networking', '--disable-component-update', '--disable-sync'],
    viewport: { width: 1400, height: 1000 },
  });
});

after(async () => {
  if (context) await context.close();
  if (work) fs.rmSync(work, { recursive: true, force: true });
});

test('report of a real tiny run: charts, image viewer, failure, regression, no errors', async () => {
  const run = path.join(work, 'run');
  const base = path.join(work, 'base');
  tinyRun(run);
  tinyRun(base, ['--denoisers', 'passthrough,temporal,eaw,svgf', '--param', 'svgf.sigmaL=8']);
  const results = failOnePair(run, 'light_switch', 'eaw');
  const out = path.join(work, 'report');
  const said = arena('report', run, '--baseline', base, '--out', out);
  assert.match(said, /1 failed/);

  const { page, problems } = await openReport(out);
  for (const id of ['speed', 'over-time', 'ghosting', 'tables', 'images', 'regression'])
    assert.equal(await page.locator(`section#${id}`).count(), 1, `section ${id}`);

  // (1) All scenes: one point per label that has a result somewhere.
  const labels = [...new Set(results.pairs.filter((p) => p.status === 'ok').map((p) => p.label))];
  assert.equal(await speedPoints(page), labels.length);
  // One scene: one point per successful pair there (eaw failed on light_switch).
  const okHere = results.pairs.filter((p) => p.scene === 'light_switch' && p.status === 'ok').length;
  await page.selectOption('#speed-scene', 'light_switch');
  await page.waitForFunction((k) => document.querySelector('#speed-chart g.points_marks')?.querySelectorAll('path').length === k, okHere);
  assert.equal(await speedPoints(page), okHere);
  assert.ok((await page.locator('#speed-front b').count()) >= 1, 'the Pareto front names its members');

  // (2) Over time on light_switch: one line per successful pair, and the event is marked.
  await page.selectOption('#scene-select', 'light_switch');
  await page.waitForFunction((n) => document.querySelectorAll('#time-error-chart g.mark-line.role-mark path').length === n, okHere);
  assert.ok((await page.locator('#time-error-chart g.mark-rule.role-mark line').count()) >= 1, 'event rule drawn');
  assert.ok((await page.locator('#ghosting-body table tbody tr').count()) === okHere, 'ghosting table: one row per pair');

  // (3) The failed pair is shown (banner and table row), the others are reported.
  assert.match(await page.locator('#failures').innerText(), /injected failure/);
  assert.equal(await page.locator('#summary-table tr.failed').count(), 1);
  assert.equal(await page.locator('#summary-table tbody tr:not(.failed):not(.reference-row)').count(), okHere);

  // (4) Image viewer: every panel's image loads (lazy: bring each into view first).
  await page.selectOption('#scene-select', 'cornell_static');
  const imgs = page.locator('#viewer .viewport img');
  const n = await imgs.count();
  assert.ok(n >= 2 + 3 * 4 - 4, `expected reference, noisy and 3 panels per label, got ${n}`);  // ldr FLIP only
  for (let i = 0; i < n; ++i) {
    await imgs.nth(i).scrollIntoViewIfNeeded();
    await page.waitForFunction((k) => {
      const img = document.querySelectorAll('#viewer .viewport img')[k];
      return img.complete && img.naturalWidth > 0;
    }, i);
  }
  const transforms = () => page.$$eval('#viewer .viewport img', (list) => list.map((img) => img.style.transform));
  const before0 = await transforms();
  await page.locator('#viewer .viewport').first().scrollIntoViewIfNeeded();
  const box = await page.locator('#viewer .viewport').first().boundingBox();
  await page.mouse.move(box.x + box.width * 0.3, box.y + box.height * 0.4);
  await page.mouse.wheel(0, -400);
  await page.waitForFunction(() => /scale\((?!1\.0000\))/.test(document.querySelector('#viewer .viewport img').style.transform));
  const after0 = await transforms();
  after0.forEach((t, i) => assert.notEqual(t, before0[i], `panel ${i} did not zoom`));
  assert.equal(new Set(after0).size, 1, 'every panel shows the same zoom');

  // Frame selector: a different frame changes every image's source, and the new images load.
  const srcBefore = await page.locator('#viewer .viewport img').first().getAttribute('src');
  const frames = await page.$$eval('#frame-select option', (o) => o.map((x) => x.value));
  assert.ok(frames.length >= 2, 'chosen frames to select');
  await page.selectOption('#frame-select', frames[frames.length - 1]);
  const srcAfter = await page.locator('#viewer .viewport img').first().getAttribute('src');
  assert.notEqual(srcAfter, srcBefore);
  assert.match(srcAfter, new RegExp(`_${String(frames[frames.length - 1]).padStart(4, '0')}\\.png$`));
  await page.locator('#viewer .viewport img').first().scrollIntoViewIfNeeded();
  await page.waitForFunction(() => document.querySelector('#viewer .viewport img').naturalWidth > 0);

  // (5) Regression view from the baseline: svgf's sigmaL differs, so rows exist with verdicts.
  assert.ok((await page.locator('#regression-body table tbody tr').count()) >= 1, 'regression rows');

  fs.mkdirSync(ARTIFACTS, { recursive: true });
  await page.evaluate(() => window.scrollTo(0, 0));
  await page.screenshot({ path: path.join(ARTIFACTS, 'report.png'), fullPage: true });
  assert.deepEqual(problems, []);
  await page.close();
});

// 10 denoisers x 10 scenes x 100 frames, synthetic (no images): the page must build quickly and
// keep a small DOM, because only the selected scene's series are drawn.
function syntheticRun(nScenes, nLabels, nFrames) {
  const scenes = {};
  const pairs = [];
  for (let s = 0; s < nScenes; ++s) {
    const name = `scene_${s}`;
    scenes[name] = { purpose: 'synthetic', width: 64, height: 36, frames: nFrames, events: [{ frame: 50, kind: 'light_off', what: 'lamp' }],
                     chosenFrames: [8, 50, 99], images: `images/${name}`, referenceRelMse: Array(nFrames).fill(0.001),
                     noisyRelMse: Array(nFrames).fill(0.5) };
    for (let l = 0; l < nLabels; ++l) {
      const frames = [];
      for (let t = 0; t < nFrames; ++t)
        frames.push({ frame: t, relMse: 0.01 * (l + 1) * (1 + 0.1 * Math.sin(t)), ldrFlip: 0.05 + 0.01 * l, ssim: 0.9 - 0.01 * l, tRmae: 0.1 * (l + 1), ms: 1 + l });
      const st = (v) => ({ mean: v, median: v, p5: v * 0.8, p95: v * 1.2, frames: nFrames - 8 });
      pairs.push({ scene: name, denoiser: `d${l}`, label: `denoiser_${l}`, params: {}, status: 'ok', frames,
                   summary: { relMse: st(0.01 * (l + 1)), ldrFlip: st(0.05 + 0.01 * l), ssim: st(0.9 - 0.01 * l), tRmae: st(0.1 * (l + 1)), ms: st(1 + l) },
                   timing: { msMedian: 1 + l + 0.1 * s, msP95: 2 + l, msPerMegapixel: 100, tapsPerPixel: 25, passes: [] },
                   ghosting: [{ eventFrame: 50, kind: 'light_off', what: 'lamp', windowBegin: 45, windowEnd: 99,
                                curve: Array.from({ length: 55 }, (_, i) => 0.01 + 0.5 * Math.exp(-i / (l + 1))),
                                steadyState: 0.01, peakExcess: 0.5, responseFrames: l + 1, ghostEnergy: 0.3 * l, signedBias: 0.1, maskFraction: 0.4 }],
                   warnings: [], images: { dir: `images/${name}/denoiser_${l}`, all: false } });
    }
  }
  return { schema: 2, kind: 'arena-run', name: 'synthetic', created: '2025-01-01T00:00:00Z', environment: {},
           settings: { warmup: 8, flip: 'ldr', relMseEpsilon: 0.01 }, scenes, pairs };
}

test('10 denoisers x 10 scenes x 100 frames stays light', async () => {
  const run = path.join(work, 'synthetic');
  fs.mkdirSync(run, { recursive: true });
  fs.writeFileSync(path.join(run, 'results.json'), JSON.stringify(syntheticRun(10, 10, 100)));
  const out = path.join(work, 'synthetic-report');
  arena('report', run, '--out', out);
  const { page, problems } = await openReport(out);
  assert.equal(await speedPoints(page), 10);
  // Only the selected scene's lines: 10, not 100.
  assert.equal(await page.locator('#time-error-chart g.mark-line.role-mark path').count(), 10);
  const domSize = await page.evaluate(() => document.getElementsByTagName('*').length);
  assert.ok(domSize < 6000, `DOM has ${domSize} elements`);
  await page.selectOption('#scene-select', 'scene_7');
  await page.waitForFunction(() => document.getElementById('scene-purpose').textContent.startsWith('scene_7'));
  assert.equal(await page.locator('#time-error-chart g.mark-line.role-mark path').count(), 10);
  assert.deepEqual(problems, []);
  await page.close();
});
