// Browser test of `arena report` and `arena history`: headless Chromium (Debian's,
// /usr/bin/chromium) driven by playwright-core opens the generated pages from disk (file://, no
// server) and checks what a person would: the charts drew the expected marks (log axis, error and
// time bars, small multiples, the named all-scenes aggregate), hover and click on a point work,
// the rankings mark ties, the summary table fits 1400 px, the A/B viewer splits and flips, a marked
// region is measured, every kept frame is offered with its events marked, the history dashboard
// marks the regressing run, and nothing logs an error. Screenshots go to tests/artifacts/. Run
// with `node --test` (ctest: browser_report); needs ARENA_BINARY (the built `arena`) and
// reports/node_modules.
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { execFileSync, spawnSync } from 'node:child_process';
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

let work, userData, context;

function arena(...args) {
  return execFileSync(ARENA, args, { encoding: 'utf8', stdio: ['ignore', 'pipe', 'pipe'] });
}

function tinyRun(out, extra = []) {
  return arena('run', '--scenes', 'cornell_static,light_switch', '--resolution', '48x27', '--frames', String(FRAMES),
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
  // A failed pair has no statistics: drop it from the scene's ranking, as a real run would.
  const st = results.statistics && results.statistics.scenes && results.statistics.scenes[scene];
  const drop = (r) => {
    r.ranking = r.ranking.filter((m) => m.label !== label);
    for (const m of r.ranking) m.tiedWith = m.tiedWith.filter((t) => t !== label);
    r.pairs = r.pairs.filter((x) => x.a !== label && x.b !== label);
    r.resolvedPairs = r.pairs.filter((x) => x.resolved).length;
    r.totalPairs = r.pairs.length;
  };
  if (st) {
    drop(st);
    for (const r of Object.values(st.byMetric || {})) drop(r);
    for (const e of [...(st.events || []), ...(st.cuts || [])])
      for (const r of Object.values(e.byFigure)) drop(r);
  }
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
  userData = fs.mkdtempSync(path.join(os.tmpdir(), 'arena-chromium-'));
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
  if (userData) fs.rmSync(userData, { recursive: true, force: true });
});

// PNG colour type (byte 25 of the file): 0 grey, 2 RGB. OpenCV writes a 3-channel image as RGB.
const pngColorType = (file) => fs.readFileSync(file)[25];

// The tiny runs every test can use: `run` keeps every frame's images, `base` differs in svgf.
let tiny;
function tinyRuns() {
  if (tiny) return tiny;
  const run = path.join(work, 'run');
  const base = path.join(work, 'base');
  const printed = tinyRun(run, ['--keep-frames', 'all', '--lowres-factor', '4']);  // reengine's disocclusion rays
  tinyRun(base, ['--denoisers', 'passthrough,temporal,eaw,svgf', '--param', 'svgf.sigmaL=8']);
  const schema = JSON.parse(fs.readFileSync(path.join(run, 'results.json'), 'utf8')).schema;
  tiny = { run, base, schema, printed };
  return tiny;
}

const shot = async (target, name) => {
  fs.mkdirSync(ARTIFACTS, { recursive: true });
  await target.screenshot({ path: path.join(ARTIFACTS, name) });
};

test('report of a real tiny run: charts, selection, tables, A/B viewer, crops, failure, regression', async () => {
  const { run, base } = tinyRuns();
  const results = failOnePair(run, 'light_switch', 'eaw');
  const out = path.join(work, 'report');
  const said = arena('report', run, '--baseline', base, '--out', out);
  assert.match(said, /1 failed/);
  // FLIP maps are written in colour (magma), not grey.
  const flipPng = path.join(run, 'images', 'cornell_static', 'svgf', 'flip_0008.png');
  assert.ok(fs.existsSync(flipPng), flipPng);
  assert.equal(pngColorType(flipPng), 2, 'FLIP map is an RGB (colour-mapped) PNG');

  const { page, problems } = await openReport(out);
  for (const id of ['speed', 'over-time', 'ghosting', 'tables', 'images', 'regression'])
    assert.equal(await page.locator(`section#${id}`).count(), 1, `section ${id}`);

  // (1) All scenes: one point per label that has a result somewhere, on a log error axis, each
  // with an error bar; the aggregate is named on the chart.
  const labels = [...new Set(results.pairs.filter((p) => p.status === 'ok').map((p) => p.label))];
  assert.equal(await speedPoints(page), labels.length);
  assert.equal(await page.evaluate(() => window.arenaReport.arena.views.speed.scale('y').type), 'log');
  assert.equal(await page.locator('#speed-chart g.errorbars_marks line').count(), labels.length, 'one error bar per point');
  const withP5 = results.pairs.filter((p) => p.status === 'ok' && p.timing && Number.isFinite(p.timing.msP5)).length;
  if (withP5) assert.ok((await page.locator('#speed-chart g.timebars_marks line').count()) >= 1, 'time bars drawn (msP5 recorded)');
  // reengine's disocclusion rays: its equivalent tracing time is a separate, labelled bar.
  assert.ok(results.pairs.some((p) => p.status === 'ok' && p.summary && p.summary.tracingMs), 'fixture: a pair charged for extra rays (reengine)');
  assert.ok((await page.locator('#speed-chart g.tracing_marks line').count()) >= 1, 'tracing-cost bar drawn');
  assert.ok((await page.locator('#speed-chart svg.marks').textContent()).includes('+ extra rays (tracing)'), 'tracing bar labelled');
  const named = (results.statistics && results.statistics.overall && results.statistics.overall.normalisation) ||
    'geometric mean over scenes of relMSE ÷ passthrough\'s relMSE';
  assert.ok((await page.locator('#speed-chart svg.marks').textContent()).includes(`All scenes: ${named}`), `the chart names its aggregate: ${named}`);
  await page.uncheck('#speed-log');
  await page.waitForFunction(() => window.arenaReport.arena.views.speed && window.arenaReport.arena.views.speed.scale('y').type === 'linear');
  await page.check('#speed-log');
  await page.waitForFunction(() => window.arenaReport.arena.views.speed && window.arenaReport.arena.views.speed.scale('y').type === 'log');

  // Hover shows the point's parameters.
  await page.locator('#speed-chart g.points_marks path').first().hover({ force: true });
  await page.waitForSelector('#vg-tooltip-element.visible', { timeout: 5000 });
  assert.match(await page.locator('#vg-tooltip-element').innerText(), /parameters/);

  // One scene: one point per successful pair there (eaw failed on light_switch).
  const okHere = results.pairs.filter((p) => p.scene === 'light_switch' && p.status === 'ok').length;
  await page.selectOption('#speed-scene', 'light_switch');
  await page.waitForFunction((k) => document.querySelector('#speed-chart g.points_marks')?.querySelectorAll('path').length === k, okHere);
  assert.equal(await speedPoints(page), okHere);
  assert.ok((await page.locator('#speed-front b').count()) >= 1, 'the Pareto front names its members');
  // Each method has a shape as well as a colour (a cluster is told apart without hovering).
  const shapes = new Set(await page.$$eval('#speed-chart g.points_marks path', (ps) => ps.map((p) => p.getAttribute('d'))));
  assert.ok(shapes.size >= Math.min(okHere, 4), `point shapes: ${shapes.size} for ${okHere} points`);

  // Small multiples: one panel per scene, each with its points.
  await page.selectOption('#speed-layout', 'multiples');
  await page.waitForFunction(() => document.querySelectorAll('#speed-chart .multiple g.points_marks').length === 2);
  assert.equal(await page.locator('#speed-chart .multiple').count(), 2);
  assert.equal(await page.locator('#speed-chart .multiple[data-scene="light_switch"] g.points_marks path').count(), okHere);
  // The run has intervals: the note says the bars are them (it said "no intervals" before).
  assert.match(await page.locator('#speed-note').innerText(), /Error bars: 95% interval of the mean/);
  await shot(page.locator('#speed'), 'speed-multiples.png');
  await page.selectOption('#speed-layout', 'single');
  await page.waitForFunction((k) => document.querySelector('#speed-chart g.points_marks')?.querySelectorAll('path').length === k, okHere);
  await shot(page.locator('#speed'), 'speed.png');

  // The time axis (issue 31): the GPU ms the model predicts at 1080p. A point per pair whose passes
  // counted traffic (passthrough has none: named under the chart, not drawn), labelled a model,
  // with the order by time on that axis.
  const clocks = await page.$$eval('#speed-clock option', (o) => o.map((x) => x.value));
  assert.deepEqual(clocks.slice(0, 2), ['cpu', 'gpu:TITAN RTX']);
  // Flicker is an error axis too (its overall score on the all-scenes chart, as the others').
  const errorAxes = await page.$$eval('#speed-metric option', (o) => o.map((x) => x.value));
  assert.ok(errorAxes.includes('tRmae'), errorAxes.join(', '));
  const predicted = results.pairs.filter((p) => p.scene === 'light_switch' && p.status === 'ok' && p.timing &&
    p.timing.gpuPredicted && p.timing.gpuPredicted.devices.find((d) => d.device === 'TITAN RTX').msMedian > 0).length;
  assert.ok(predicted >= 3, `pairs with a predicted GPU time: ${predicted}`);
  await page.selectOption('#speed-clock', 'gpu:TITAN RTX');
  await page.waitForFunction((k) => document.querySelector('#speed-chart g.points_marks')?.querySelectorAll('path').length === k, predicted);
  assert.match(await page.locator('#speed-note').innerText(), /a prediction, not a measurement/);
  // The model does not order a time less than 10% above the first of its group (≈), as the run's
  // predictions say: the order printed is the one the drawn points' medians give by that rule.
  const expectedOrder = await page.evaluate(() => {
    const points = window.ARENA_DATA.speed.views['gpu:TITAN RTX'].scenes.light_switch.relMse.points
      .filter((p) => p.ms > 0 && p.error > 0).sort((a, b) => a.ms - b.ms);
    let start = 0;
    return points.map((p, i) => {
      const joins = i > 0 && p.ms < start * 1.1;
      if (!joins) start = p.ms;
      return (i === 0 ? '' : joins ? ' ≈ ' : ' < ') + p.label;
    }).join('');
  });
  assert.ok(expectedOrder.includes(' < '), expectedOrder);
  assert.ok((await page.locator('#speed-front').innerText()).includes(
    `by time on this axis (medians, no interval; ≈: less than 10% above the first of its group, which the model does not order): ${expectedOrder}`),
    expectedOrder);
  assert.match(await page.locator('#speed-front').innerText(), /passthrough: .*no GPU traffic counted/);
  assert.ok((await page.locator('#speed-chart svg.marks').textContent()).includes('predicted GPU ms'), 'the time axis says it is predicted');
  await shot(page.locator('#speed'), 'speed-gpu.png');
  // All scenes: passthrough, unpriced on both scenes, is named once with its count.
  await page.selectOption('#speed-scene', '__all__');
  await page.waitForFunction(() => /passthrough on 2 scenes: /.test(document.getElementById('speed-front').innerText));
  assert.doesNotMatch(await page.locator('#speed-front').innerText(), /passthrough on light_switch/);
  await page.selectOption('#speed-scene', 'light_switch');
  await page.selectOption('#speed-clock', 'cpu');
  await page.waitForFunction((k) => document.querySelector('#speed-chart g.points_marks')?.querySelectorAll('path').length === k, okHere);
  assert.match(await page.locator('#speed-front').innerText(), /by time on this axis \(medians, no interval\): [^≈]* < /);

  // Clicking a point selects that denoiser (and the point's scene) in the viewer and over time.
  // The symbols are drawn in the order of the scope's points (those a log axis can show).
  const svgfPoint = await page.evaluate(() => window.ARENA_DATA.speed.views.cpu.scenes.light_switch.relMse.points
    .filter((p) => p.ms > 0 && p.error > 0).findIndex((p) => p.label === 'svgf'));
  assert.ok(svgfPoint >= 0, 'svgf has a point on light_switch');
  await page.locator('#speed-chart g.points_marks path').nth(svgfPoint).click({ force: true });
  await page.waitForFunction(() => window.arenaReport.arena.state.selected === 'svgf');
  assert.equal(await page.evaluate(() => window.arenaReport.arena.state.scene), 'light_switch');
  await page.waitForFunction(() => /svgf/.test(document.getElementById('ab-tag-a').textContent));
  // Over time: the other lines fade.
  await page.waitForFunction(() => [...document.querySelectorAll('#time-error-chart g.mark-line.role-mark path')].some((p) => Number(p.getAttribute('opacity') ?? p.getAttribute('stroke-opacity') ?? 1) < 0.5));
  assert.match(await page.locator('#selection').innerText(), /svgf/);

  // (2) Over time on light_switch: one line per successful pair, and the event is marked.
  await page.waitForFunction((n) => document.querySelectorAll('#time-error-chart g.mark-line.role-mark path').length === n, okHere);
  assert.ok((await page.locator('#time-error-chart g.mark-rule.role-mark line').count()) >= 1, 'event rule drawn');
  // The charts' metric menus come from the registry's catalogue (field `chart`), with its titles.
  const menu = (id) => page.$$eval(`#${id} option`, (o) => o.map((x) => `${x.value}=${x.textContent}`));
  const catalogue = (chart) => page.evaluate((c) => window.ARENA_DATA.metrics
    .filter((m) => m.chart === c && window.ARENA_DATA.pairs.some((p) => p.series && p.series[m.name]))
    .map((m) => `${m.name}=${m.title}`), chart);
  assert.deepEqual(await menu('time-error-metric'), await catalogue('error'));
  assert.deepEqual(await menu('time-flicker-metric'), await catalogue('temporal'));
  assert.ok((await menu('time-error-metric')).includes('dssim=1 − SSIM'), (await menu('time-error-metric')).join(', '));
  assert.ok((await menu('time-flicker-metric')).includes('tRmae=tRMAE'), (await menu('time-flicker-metric')).join(', '));
  assert.ok((await page.locator('#ghosting-body table tbody tr').count()) === okHere, 'ghosting table: one row per pair');
  // Four frames from the event on: the lag figures, and no steady state (said under the table).
  assert.match(await page.locator('#ghosting-body p.steady-absent').innerText(), /No E_ss, peak excess or ghost energy: the window holds 4 frame\(s\)/);
  // Every lag energy with its 95% interval (or why it has none); "best" = ranked first, ties included.
  const lagCells = await page.$$eval('#ghosting-body table.ghost-table tbody tr', (rows) => rows.map((r) => r.cells[1].textContent));
  assert.ok(lagCells.every((t) => /\[.+, .+\]|no interval/.test(t)), `lag energy cells: ${lagCells.join(' | ')}`);
  const firstOnLag = results.statistics.scenes.light_switch.events[0].byFigure.lagEnergy.ranking
    .filter((m) => m.rank === 1).map((m) => m.label).sort();
  const markedOnLag = await page.$$eval('#ghosting-body table.ghost-table tbody tr', (rows) => rows.filter((r) => r.cells[1].classList.contains('best')).map((r) => r.dataset.label).sort());
  assert.ok(firstOnLag.length >= 1);
  // ... except a method that keeps no history (the noisy input; eaw, spatial only), which has no lag
  // by construction: unmarked, and said so where first.
  const stateless = results.pairs.filter((p) => p.scene === 'light_switch' && p.keepsHistory === false).map((p) => p.label);
  assert.ok(stateless.includes('passthrough'), `results record passthrough's lack of history: ${stateless}`);
  assert.deepEqual(markedOnLag, firstOnLag.filter((l) => !stateless.includes(l)));
  assert.equal(await page.locator('#ghosting-body tr[data-label="passthrough"] td.best').count(), 0);
  assert.ok(firstOnLag.includes('passthrough'), `passthrough has no lag: ${firstOnLag.join(', ')}`);
  assert.match(await page.locator('#ghosting-body p.input-unmarked').first().innerText(), /Not marked, though ranked first: .*passthrough on lag energy/);
  // The chromaticity lag (the warm ceiling light goes, the cool lamp stays) with its interval too.
  const chromaColumn = await page.$$eval('#ghosting-body table.ghost-table thead th', (th) => th.map((h) => h.textContent).indexOf('chroma lag energy'));
  assert.ok(chromaColumn > 0, 'chroma lag energy column');
  const chromaCells = await page.$$eval('#ghosting-body table.ghost-table tbody tr', (rows, c) => rows.map((r) => r.cells[c].textContent), chromaColumn);
  assert.ok(chromaCells.every((t) => /\[.+, .+\]/.test(t)), `chroma lag energy cells: ${chromaCells.join(' | ')}`);

  // (3) Tables: rankings (scene and overall), the failed pair, intervals, and a table that fits.
  assert.equal(await page.locator('#rankings > .ranking table.ranking-table').count(), 2, 'scene and overall rankings');
  // The overall ranking is statistics' one score: the page shows exactly what `arena run` printed
  // (rank with ties, label, score, interval), digit for digit.
  const pageOverall = await page.locator('#rankings table.ranking-table').nth(1).locator('tbody tr').evaluateAll(
    (rows) => rows.map((r) => [...r.querySelectorAll('td')].slice(0, 4).map((td) => td.textContent).join(' | ')));
  // The overall block ends at the first blank line (the event tables follow).
  const printedOverall = tinyRuns().printed.split('\n\noverall: ')[1].split('\n\n')[0].split('\n').slice(1)
    .filter((l) => /^\s+\d/.test(l))
    .map((l) => { const m = l.trim().match(/^(\d+=?)\s+(\S+(?: \(\+paths\))?)\s+(\S+)\s+(\[[^\]]*\]|–|\(1 by definition\))/); return m.slice(1, 5).join(' | '); });
  assert.ok(printedOverall.length >= 3, `the run printed its overall ranking: ${tinyRuns().printed.slice(-800)}`);
  assert.deepEqual(pageOverall, printedOverall, 'report and printout show the same overall ranking');
  // A method that read extra paths is marked "(+paths)" on both.
  assert.deepEqual(pageOverall.map((r) => r.split(' | ')[1]),
    results.statistics.overall.ranking.map((m) => m.label + (m.extraPathsPerPixel > 0 ? ' (+paths)' : '')));
  assert.equal(await page.locator('#rankings table.ranking-table').first().locator('tbody tr').count(), okHere);
  // The overall rankings on the other metrics (1 − SSIM, LDR-FLIP), folded under it, are the
  // printout's table of them: rank with ties and score, method by method.
  const others = Object.keys(results.statistics.overallByMetric)
    .filter((m) => results.statistics.overallByMetric[m].ranking.length > 0);
  assert.ok(others.includes('dssim') && others.includes('ldrFlip') && others.includes('tRmae'), others.join(', '));
  // The fold's title names each one's rank 1 (a different winner on flicker shows unopened).
  const firstOn = (m) => results.statistics.overallByMetric[m].ranking.filter((r) => r.rank === 1).map((r) => r.label).join(', ');
  assert.match(await page.locator('#rankings details.other-overall summary').innerText(),
               new RegExp(`tRMAE ${firstOn('tRmae').replace(/[[\]()+]/g, '\\$&')}`));
  const otherTables = page.locator('#rankings details.other-overall table.ranking-table');
  assert.equal(await otherTables.count(), others.length);
  const printedOther = {};
  for (const line of tinyRuns().printed.split('\noverall on the other metrics ')[1].split('\n').slice(2)) {
    if (!/^  [^ (]/.test(line)) break;
    const [, label, cells] = line.match(/^  (\S+)\s+(.*)$/);
    printedOther[label] = [...cells.matchAll(/(\d+=?)\s+(\S+)|-/g)].map((c) => (c[1] ? `${c[1]} ${c[2]}` : '-'));
  }
  for (let k = 0; k < others.length; ++k) {
    const rows = await otherTables.nth(k).locator('tbody tr').evaluateAll(
      (trs) => trs.map((r) => [...r.querySelectorAll('td')].slice(0, 3).map((td) => td.textContent)));
    assert.equal(rows.length, results.statistics.overallByMetric[others[k]].ranking.length);
    for (const [rank, shown, score] of rows) {
      const label = shown.replace(/ \(\+paths\)$/, '');
      assert.equal(printedOther[label] && printedOther[label][k], `${rank} ${score}`, `${others[k]}, ${label}: ${JSON.stringify(printedOther)}`);
    }
  }
  assert.match(await page.locator('#failures').innerText(), /injected failure/);
  assert.equal(await page.locator('#summary-table tr.failed').count(), 1);
  assert.equal(await page.locator('#summary-table tbody tr[data-label]').count(), okHere);
  // The floors row is named apart from the verdict's "reference noise floor" (another estimate).
  assert.equal(await page.locator('#summary-table tr.reference-row td.first').first().textContent(), 'floor: a perfect method');
  const fits = () => page.$eval('#summary-wrap', (w) => ({ scroll: w.scrollWidth, client: w.clientWidth }));
  let f = await fits();
  assert.ok(f.scroll <= f.client, `summary table fits 1400 px: ${f.scroll} > ${f.client}`);
  // Column picker: a metric's columns go and come back; p95 columns appear.
  const groups = () => page.$$eval('#summary-table th.group', (t) => t.map((x) => x.textContent));
  assert.ok((await groups()).some((g) => g.startsWith('ssim')));
  await page.click('details.column-picker summary');
  await page.locator('#column-picker input[data-column="ssim"]').uncheck();
  assert.ok(!(await groups()).some((g) => g.startsWith('ssim')), 'ssim column removed');
  await page.locator('#column-picker input[data-column="ssim"]').check();
  assert.ok((await groups()).some((g) => g.startsWith('ssim')));
  const headers = () => page.$$eval('#summary-table thead tr:nth-child(2) th', (t) => t.map((x) => x.textContent));
  const before = (await headers()).filter((h) => h === 'p95').length;
  await page.locator('#column-picker input[data-column="p95"]').check();
  assert.ok((await headers()).filter((h) => h === 'p95').length > before, 'p95 columns added');
  await page.locator('#column-picker input[data-column="p95"]').uncheck();
  // The cost model's columns (docs/gpu-cost.md): predicted GPU ms and GPU memory at 1080p, under
  // one group; svgf's row has all three, passthrough's none (it counts no traffic).
  for (const c of ['gpuMs', 'gpuPersistentMiB', 'gpuWorkingSetMiB']) await page.locator(`#column-picker input[data-column="${c}"]`).check();
  assert.ok((await groups()).some((g) => g.startsWith('GPU, 1080p (model), ')), 'the GPU group is shown, with its device');
  assert.ok((await groups()).includes('CPU time here, 48×27'), 'the times say whose clock and what size');
  const cells = (label) => page.$$eval(`#summary-table tbody tr[data-label="${label}"] td`, (t) => t.slice(-3).map((x) => x.textContent));
  for (const v of await cells('svgf')) assert.ok(Number(v) > 0, `svgf's GPU cells: ${await cells('svgf')}`);
  for (const v of await cells('passthrough')) assert.ok(!(Number(v) > 0), `passthrough's GPU cells: ${await cells('passthrough')}`);
  for (const c of ['gpuMs', 'gpuPersistentMiB', 'gpuWorkingSetMiB']) await page.locator(`#column-picker input[data-column="${c}"]`).uncheck();
  await shot(page.locator('#tables'), 'tables.png');

  // (4) Images on light_switch: every kept frame is offered, the event frame is marked.
  const frameOptions = await page.$$eval('#frame-select option', (o) => o.map((x) => ({ v: x.value, event: x.dataset.event === 'true', text: x.textContent })));
  assert.equal(frameOptions.length, FRAMES, 'every kept frame (--keep-frames all)');
  const events = results.scenes.light_switch.events.map((e) => String(e.frame));
  assert.ok(events.length >= 1);
  for (const o of frameOptions) assert.equal(o.event, events.includes(o.v), `frame ${o.v} event mark`);
  await page.selectOption('#frame-select', events[0]);

  // A/B: noisy input vs reference; both load; the split slider moves the split; F flips.
  const optionIndex = (sel, text) => page.$eval(sel, (s, t) => [...s.options].find((o) => o.text === t).value, text);
  await page.selectOption('#ab-a', await optionIndex('#ab-a', 'noisy input'));
  await page.selectOption('#ab-b', await optionIndex('#ab-b', 'reference'));
  await page.locator('#ab-view').scrollIntoViewIfNeeded();
  for (const side of ['a', 'b'])
    await page.waitForFunction((s) => { const i = document.getElementById(`ab-img-${s}`); return i.complete && i.naturalWidth > 0; }, side);
  await page.locator('#ab-split').fill('30');
  assert.equal(await page.$eval('#ab-view', (v) => v.style.getPropertyValue('--split')), '30%');
  await shot(page.locator('#ab-section'), 'ab-split.png');
  await page.selectOption('#ab-mode', 'flip');
  await page.locator('#ab-view').click();
  await page.keyboard.press('f');
  assert.ok(await page.$eval('#ab-view', (v) => v.classList.contains('show-b')), 'F shows B');
  assert.equal(await page.$eval('#ab-tag-b', (t) => getComputedStyle(t).display !== 'none'), true);
  await page.keyboard.press('f');
  assert.ok(!(await page.$eval('#ab-view', (v) => v.classList.contains('show-b'))), 'F again shows A');
  // A FLIP map on A, with the magma legend.
  await page.selectOption('#ab-a', await optionIndex('#ab-a', 'svgf · LDR-FLIP'));
  await page.waitForFunction(() => { const i = document.getElementById('ab-img-a'); return /flip_\d{4}\.png$/.test(i.src) && i.complete && i.naturalWidth > 0; });
  assert.match(await page.$eval('.legend[data-map="flip"] .legend-bar', (b) => b.style.background), /rgb\(0, 0, 4\)/);
  assert.equal(await page.locator('.legend[data-map="relerr"] .legend-ticks span').count(), 6, 'relative-error legend: 1e-4 .. 1e1');
  await shot(page.locator('#ab-section'), 'ab-flip-magma.png');
  await page.selectOption('#ab-mode', 'split');

  // Crop: mark the whole frame; its FLIP equals the frame's LDR-FLIP (from the 8-bit map).
  await page.click('#crop-mode');
  const box = await page.locator('#ab-view').boundingBox();
  await page.mouse.move(box.x + 1, box.y + 1);
  await page.mouse.down();
  await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2, { steps: 3 });
  await page.mouse.move(box.x + box.width - 1, box.y + box.height - 1, { steps: 3 });
  await page.mouse.up();
  await page.waitForSelector('#crop-result table tbody tr');
  const cropRows = await page.$$eval('#crop-result table tbody tr', (rows) => rows.map((r) => [r.dataset.label, ...[...r.cells].slice(1).map((c) => Number(c.textContent))]));
  const svgfRow = cropRows.find((r) => r[0] === 'svgf');
  const svgfPair = results.pairs.find((p) => p.scene === 'light_switch' && p.label === 'svgf');
  const frameIndex = svgfPair.frames.findIndex((x) => x.frame === Number(events[0]));
  const ldr = svgfPair.frames[frameIndex].ldrFlip;
  assert.ok(Math.abs(svgfRow[2] - ldr) < 0.01, `crop of the whole frame: FLIP ${svgfRow[2]} vs the frame's ${ldr}`);
  const noisyRow = cropRows.find((r) => r[0] === 'noisy');
  assert.ok(noisyRow && cropRows.some((r) => r[0] !== 'noisy' && r[1] > noisyRow[1]), 'some denoiser beats the noisy input on PSNR in the crop');
  // A smaller region: fewer pixels, a drawn rectangle.
  await page.mouse.move(box.x + box.width * 0.2, box.y + box.height * 0.2);
  await page.mouse.down();
  await page.mouse.move(box.x + box.width * 0.5, box.y + box.height * 0.6, { steps: 3 });
  await page.mouse.up();
  await page.waitForFunction(() => /Region x 0–48, y 0–27/.test(document.getElementById('crop-result').textContent) === false);
  assert.ok(await page.$eval('#crop-rect', (r) => !r.hidden && parseFloat(r.style.width) < 60));
  await shot(page.locator('#ab-section'), 'crop.png');
  await page.click('#crop-mode');

  // The grid on cornell_static: every panel's image loads (lazy: bring each into view first).
  await page.selectOption('#scene-select', 'cornell_static');
  const imgs = page.locator('#viewer .viewport img');
  const n = await imgs.count();
  assert.ok(n >= 2 + 3 * 4 - 4, `expected reference, noisy and 3 panels per label, got ${n}`);  // ldr FLIP only
  for (let i = 0; i < n; ++i) {
    if (!(await imgs.nth(i).isVisible())) continue;  // a hidden panel (e.g. a map the run did not keep)
    await imgs.nth(i).scrollIntoViewIfNeeded();
    await page.waitForFunction((k) => {
      const img = document.querySelectorAll('#viewer .viewport img')[k];
      return img.complete && img.naturalWidth > 0;
    }, i);
  }
  // Synchronised zoom: every panel and the A/B view follow one wheel.
  const transforms = () => page.$$eval('#images [data-zoom]', (list) => list.map((e) => e.style.transform));
  const before0 = await transforms();
  await page.locator('#viewer .viewport').first().scrollIntoViewIfNeeded();
  const vbox = await page.locator('#viewer .viewport').first().boundingBox();
  await page.mouse.move(vbox.x + vbox.width * 0.3, vbox.y + vbox.height * 0.4);
  await page.mouse.wheel(0, -400);
  await page.waitForFunction(() => /scale\((?!1\.0000\))/.test(document.querySelector('#viewer .viewport img').style.transform));
  const after0 = await transforms();
  after0.forEach((t, i) => assert.notEqual(t, before0[i], `image ${i} did not zoom`));
  assert.equal(new Set(after0).size, 1, 'every image shows the same zoom');

  // Frame selector: a different frame changes every image's source, and the new images load.
  const srcBefore = await page.locator('#viewer .viewport img').first().getAttribute('src');
  const frames = await page.$$eval('#frame-select option', (o) => o.map((x) => x.value));
  assert.equal(frames.length, FRAMES);
  await page.selectOption('#frame-select', frames[frames.length - 1]);
  const srcAfter = await page.locator('#viewer .viewport img').first().getAttribute('src');
  assert.notEqual(srcAfter, srcBefore);
  assert.match(srcAfter, new RegExp(`_${String(frames[frames.length - 1]).padStart(4, '0')}\\.png$`));
  await page.locator('#viewer .viewport img').first().scrollIntoViewIfNeeded();
  await page.waitForFunction(() => document.querySelector('#viewer .viewport img').naturalWidth > 0);

  // (5) Regression view from the baseline: svgf's sigmaL differs, so rows exist with verdicts.
  assert.ok((await page.locator('#regression-body table tbody tr').count()) >= 1, 'regression rows');
  // "What fails the gate" shows the rows whose `fails` (compare's own rule) is true, and only those.
  const gate = await page.evaluate(() => {
    const rows = window.Arena.D.regression.rows;
    return { failing: rows.filter((r) => r.fails === true).length, typed: rows.every((r) => typeof r.fails === 'boolean') };
  });
  assert.ok(gate.typed, 'every regression row says whether it fails the gate');
  await page.selectOption('#regression-filter', 'regressed');
  assert.equal(await page.locator('#regression-body table tbody tr').count(), gate.failing);
  // Every row both runs measured shows its change, whatever its note says.
  await page.selectOption('#regression-filter', 'all');
  const changes = await page.evaluate(() => ({
    measured: window.Arena.D.regression.rows.filter((r) => r.change != null).length,
    shown: [...document.querySelectorAll('#regression-body table tbody tr td:nth-child(6)')]
               .filter((td) => !td.textContent.startsWith('–')).length
  }));
  assert.equal(changes.shown, changes.measured, 'a measured change is shown');
  await page.selectOption('#regression-filter', 'moved');
  // The rule as the gate applies it: its confidence, and Holm's correction over the rows judged together.
  const judged = await page.evaluate(() => window.Arena.D.regression.rowsJudgedTogether);
  assert.match(await page.locator('#regression-body').innerText(),
               new RegExp(`paired 95% interval of that change excludes zero, and it stays resolved among the ${judged} rows judged together \\(Holm`));

  await page.evaluate(() => window.scrollTo(0, 0));
  await shot(page, 'report-top.png');
  await page.screenshot({ path: path.join(ARTIFACTS, 'report.png'), fullPage: true });
  assert.deepEqual(problems, []);
  await page.close();

  // (6) A baseline measured under another warm-up: `arena compare` refuses it (exit 2), and so
  // does the view, with its sentence; given --allow-settings-mismatch, both judge and warn.
  const otherBase = path.join(work, 'base-other-warmup');
  fs.cpSync(base, otherBase, { recursive: true });
  const baseFile = path.join(otherBase, 'results.json');
  const edited = JSON.parse(fs.readFileSync(baseFile, 'utf8'));
  edited.settings.warmup = 3;
  fs.writeFileSync(baseFile, JSON.stringify(edited));
  for (const allow of [false, true]) {
    const dir = path.join(work, allow ? 'report-settings-allowed' : 'report-settings-refused');
    const printed = arena('report', run, '--baseline', otherBase, '--out', dir, ...(allow ? ['--allow-settings-mismatch'] : []));
    // The printout says the verdict too (a CI log), though report itself is no gate (exit 0).
    assert.match(printed, allow ? /regression view against .* \(as `arena compare .*` with these options\): gate: (pass \(exit 0|FAIL \(exit 1); \d+ /
                                : /regression view against .*: refused \(exit 2\): the baseline and this run were run with different settings/);
    const { page: view, problems: viewProblems } = await openReport(dir);
    const text = await view.locator('#regression-body').innerText();
    const compare = spawnSync(ARENA, ['compare', otherBase, run, ...(allow ? ['--allow-settings-mismatch'] : [])], { encoding: 'utf8' });
    if (allow) {
      assert.doesNotMatch(text, /would refuse/);
      assert.match(text, /comparing runs with different settings \(baseline vs candidate\): settings\.warmup: 3 vs 4/);
      assert.notEqual(compare.status, 2, compare.stderr);
      assert.match(compare.stderr, /warning: comparing runs with different settings/);
    } else {
      assert.match(text, /`arena compare` would refuse these runs \(exit 2\): the baseline and this run were run with different settings \(baseline vs candidate\): settings\.warmup: 3 vs 4; their numbers/);
      assert.ok((await view.locator('#regression-body table tbody tr').count()) >= 1, 'the rows are still shown');
      assert.equal(compare.status, 2, compare.stdout + compare.stderr);
      assert.match(compare.stderr, /were run with different settings/);
    }
    assert.equal(await view.evaluate(() => window.Arena.D.regression.exitCode), allow ? compare.status : 2);
    assert.deepEqual(viewProblems, []);
    await view.close();
  }
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
      const st = (v) => ({ mean: v, median: v, p5: v * 0.8, p95: v * 1.2, frames: nFrames - 8, ci95: [v * 0.97, v * 1.03] });
      pairs.push({ scene: name, denoiser: `d${l}`, label: `denoiser_${l}`, params: {}, status: 'ok', frames,
                   summary: { relMse: st(0.01 * (l + 1)), ldrFlip: st(0.05 + 0.01 * l), ssim: st(0.9 - 0.01 * l), tRmae: st(0.1 * (l + 1)), ms: st(1 + l) },
                   timing: { msMedian: 1 + l + 0.1 * s, msP5: 0.8 + l, msP95: 2 + l, msPerMegapixel: 100, tapsPerPixel: 25, passes: [] },
                   ghosting: [{ eventFrame: 50, kind: 'light_off', what: 'lamp', windowBegin: 45, windowEnd: 99,
                                curve: Array.from({ length: 55 }, (_, i) => 0.01 + 0.5 * Math.exp(-i / (l + 1))),
                                steadyState: 0.01, peakExcess: 0.5, responseFrames: l + 1, ghostEnergy: 0.3 * l, signedBias: 0.1, maskFraction: 0.4,
                                // denoiser_3 meets the event still lagging from an earlier one: no lag figure.
                                ...(l === 3 ? { lagEnergy: null, lagAbsent: 'the method never settled after the event at frame 20',
                                                ci95Absent: { lagEnergy: 'the method never settled after the event at frame 20' } }
                                            : { lagEnergy: 0.2 * l, ci95: { lagEnergy: [0.15 * l, 0.25 * l] } }) }],
                   cuts: [{ kind: 'camera_cut', eventFrame: 70, atCut: 1 + l, steadyState: 0.002, recovery: [1, 1, 1, 1, 1], oldViewLeak: null,
                            oldViewLeakAbsent: 'the reference of frame 69 equals the references after the cut: no old view can show (did the camera cut here?)',
                            ci95: { atCut: [0.9 + l, 1.1 + l] }, ci95Absent: { recovery1: 'the figure itself is undefined for this event' } }],
                   warnings: [], images: { dir: `images/${name}/denoiser_${l}`, all: false },
                   // denoiser_1 and denoiser_2 (tied below) wrote the same bits.
                   outputChecksum: l === 1 || l === 2 ? '00000000deadbeef' : `0000000000000${String(l).padStart(3, '0')}` });
    }
  }
  // The results schema's statistics: on every scene denoiser_1 and denoiser_2 are tied (their
  // difference is not resolved), the others resolved; overall the same.
  const ranking = (valueKey) => Array.from({ length: nLabels }, (_, l) => ({
    label: `denoiser_${l}`, rank: l === 2 ? 2 : l + 1, [valueKey]: 0.01 * (l + 1), ci95: [0.0097 * (l + 1), 0.0103 * (l + 1)],
    tiedWith: l === 1 ? ['denoiser_2'] : l === 2 ? ['denoiser_1'] : [] }));
  const pairsOf = () => {
    const out = [];
    for (let a = 0; a < nLabels; ++a)
      for (let b = a + 1; b < nLabels; ++b) {
        const diff = 0.01 * (a - b), tied = a === 1 && b === 2;
        out.push({ a: `denoiser_${a}`, b: `denoiser_${b}`, diff,
                   ci95: tied ? [diff - 0.01, diff + 0.01] : [1.5 * diff, 0.5 * diff], resolved: !tied });
      }
    return out;
  };
  const statistics = { method: 'crossed bootstrap (synthetic)', confidence: 0.95, replicates: 1000, tileGrid: [4, 4],
                       rankedOn: 'relMse', scenes: {},
                       overall: { normalisation: 'geometric mean of relMSE ratios to denoiser_0', baseline: 'denoiser_0',
                                  ranking: ranking('score') } };
  for (const name of Object.keys(scenes))
    statistics.scenes[name] = { metric: 'relMse', ranking: ranking('mean'), pairs: pairsOf(), byMetric: {},
                                resolvedPairs: nLabels * (nLabels - 1) / 2 - 1, totalPairs: nLabels * (nLabels - 1) / 2 };
  return { schema: tinyRuns().schema, kind: 'arena-run', name: 'synthetic', created: '2025-01-01T00:00:00Z', environment: {},
           settings: { warmup: 8, flip: 'ldr', relMseEpsilon: 0.01 }, scenes, pairs, statistics };
}

test('10 denoisers x 10 scenes x 100 frames stays light', async () => {
  const run = path.join(work, 'synthetic');
  fs.mkdirSync(run, { recursive: true });
  fs.writeFileSync(path.join(run, 'results.json'), JSON.stringify(syntheticRun(10, 10, 100)));
  const out = path.join(work, 'synthetic-report');
  arena('report', run, '--out', out);
  const { page, problems } = await openReport(out);
  assert.equal(await speedPoints(page), 10);
  // Intervals as error bars and p5-p95 time bars on every point.
  assert.equal(await page.locator('#speed-chart g.errorbars_marks line').count(), 10);
  assert.equal(await page.locator('#speed-chart g.timebars_marks line').count(), 10);
  // The run's own overall score (statistics.overall) is what the all-scenes chart shows, named.
  assert.match(await page.locator('#speed-chart svg.marks').textContent(), /geometric mean of relMSE ratios to denoiser_0/);
  // Ties in the rankings: denoiser_1 and denoiser_2 marked tied (rank "2="), the rest resolved.
  for (const table of ['#rankings .ranking-table >> nth=0', '#rankings .ranking-table >> nth=1']) {
    const tied = await page.locator(`${table} >> tbody tr[data-tied="true"]`).evaluateAll((rows) => rows.map((r) => [r.dataset.label, r.cells[0].textContent]));
    assert.deepEqual(tied, [['denoiser_1', '2='], ['denoiser_2', '2=']]);
  }
  assert.match(await page.locator('#rankings').innerText(), /44 of 45 pairs resolved/);
  // Tied because their outputs are the same bits: said on the scene's ranking (not overall).
  assert.match(await page.locator('#rankings .ranking-table >> nth=0').locator('tr[data-label="denoiser_1"]').innerText(),
               /tied with denoiser_2 \(identical outputs: denoiser_2\)/);
  assert.doesNotMatch(await page.locator('#rankings .ranking-table >> nth=1').innerText(), /identical outputs/);
  // The overall baseline's score is 1 by its definition, not an interval of [1, 1].
  assert.match(await page.locator('#rankings .ranking-table >> nth=1').locator('tr[data-label="denoiser_0"]').innerText(), /1 by definition/);
  // Intervals under the means in the summary table.
  assert.match(await page.locator('#summary-table tbody tr[data-label="denoiser_0"]').innerText(), /\[0\.0097, 0\.0103\]/);
  // "Best" only where the statistics rank: relMSE's first (denoiser_0, resolved), nothing in the
  // unranked columns (ldrFlip, ssim, tRmae, times), whatever their means.
  const best = await page.$$eval('#summary-table td.best', (cells) => cells.map((c) => c.closest('tr').dataset.label));
  assert.deepEqual(best, ['denoiser_0']);
  assert.match(await page.locator('#summary-best-note').innerText(), /rank 1 in the run's statistics/);
  assert.doesNotMatch(await page.locator('#summary-best-note').innerText(), /A mark is not the best mean/);
  const fits = await page.$eval('#summary-wrap', (w) => w.scrollWidth <= w.clientWidth);
  assert.ok(fits, 'summary table fits 1400 px');
  await shot(page.locator('#tables'), 'tables-ties.png');
  // The camera cut's table: one row per pair, intervals under the figures, a reason where none.
  assert.equal(await page.locator('#ghosting-body table.cut-table tbody tr').count(), 10);
  assert.match(await page.locator('#ghosting-body table.cut-table tbody tr[data-label="denoiser_2"]').innerText(), /\[2\.9, 3\.1\]/);
  assert.equal(await page.locator('#ghosting-body table.cut-table span.ci[title="the figure itself is undefined for this event"]').count(), 10);
  // One reason for every such cell: said once under the table, not only in the tooltips.
  assert.match(await page.locator('#ghosting-body .table-wrap:has(table.cut-table) p.no-interval').innerText(), /No interval in the cells marked so: the figure itself is undefined for this event/);
  // The ratios rank each method's jump: the absolute relMSE at the cut and in the steady state
  // stand beside them, unranked, and a note says what the ratios are.
  const cutHead = await page.$$eval('#ghosting-body table.cut-table thead th', (th) => th.map((h) => h.textContent));
  const atCutColumn = cutHead.indexOf('relMSE at cut');
  assert.ok(atCutColumn > 0 && cutHead.includes('relMSE steady'), cutHead.join(' | '));
  assert.equal(await page.$eval('#ghosting-body table.cut-table tbody tr[data-label="denoiser_2"]',
                                (r, c) => r.cells[c].textContent, atCutColumn), '0.006');
  assert.match(await page.locator('#ghosting-body p.cut-ratios').innerText(), /rank the jump, not the error/);
  // A method still lagging from an earlier event has no lag figure: said in its cell and below.
  assert.match(await page.locator('#ghosting-body table.ghost-table tbody tr[data-label="denoiser_3"]').innerText(), /not settled before/);
  assert.match(await page.locator('#ghosting-body p.lag-absent').innerText(), /No lag energy for denoiser_3: /);
  // A cut whose references did not change has no leak, and the page says why (never a 0).
  assert.match(await page.locator('#ghosting-body p.leak-absent').innerText(), /No old-view leak: the reference of frame 69 equals/);
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

// Ranks count the methods resolved better, so a method with a wide interval can hold rank 1 (the
// bold green mark) above one with a better mean and a narrow interval: the note under the summary
// table names such a column instead of leaving the mark to read as "the best mean".
test('a mark above a better mean is said under the summary table', async () => {
  const run = path.join(work, 'synthetic-inverted');
  fs.mkdirSync(run, { recursive: true });
  const results = syntheticRun(1, 4, 12);
  // SSIM (higher is better) falls with the label's index: denoiser_0 has the best mean. Ranked
  // below denoiser_1 (its differences certain, denoiser_1's not): rank 2, denoiser_1 rank 1.
  const ssim = (l) => 0.9 - 0.01 * l;
  results.statistics.scenes.scene_0.byMetric.ssim = {
    metric: 'ssim', pairs: [], resolvedPairs: 0, totalPairs: 0,
    ranking: [1, 0, 2, 3].map((l, k) => ({ label: `denoiser_${l}`, rank: [1, 2, 3, 4][k], mean: ssim(l), ci95: [ssim(l) - 0.01, ssim(l) + 0.01], tiedWith: [] })) };
  fs.writeFileSync(path.join(run, 'results.json'), JSON.stringify(results));
  const out = path.join(work, 'synthetic-inverted-report');
  arena('report', run, '--out', out);
  const { page, problems } = await openReport(out);
  const marked = await page.$$eval('#summary-table td.best', (cells) => cells.map((c) => c.closest('tr').dataset.label));
  assert.deepEqual(marked.sort(), ['denoiser_0', 'denoiser_1'], 'relMSE marks denoiser_0, SSIM denoiser_1');
  const note = await page.locator('#summary-best-note').innerText();
  assert.match(note, /A mark is not the best mean \(ssim: denoiser_0 not marked, with a higher mean than denoiser_1\)/);
  assert.doesNotMatch(note, /relMse:/, 'relMSE\'s mark is its best mean');
  assert.deepEqual(problems, []);
  await page.close();
});

// Long labels (a control such as "reengine[disocclusionRays=off]") wrap inside their columns: the
// scene's and the overall ranking stand side by side without overlapping (a study's did at 1400 px)
// and the summary table fits. A scene that meets the reference goal as a whole but not between its
// events says so above its warnings, as a missed goal does.
test('long labels stay in their tables; a segment\'s reference verdict is said', async () => {
  const dir = path.join(work, 'synthetic-long');
  fs.mkdirSync(dir, { recursive: true });
  const results = JSON.parse(JSON.stringify(syntheticRun(2, 10, 20)).replaceAll('denoiser_', 'reengine[disocclusionRays=off]_'));
  results.scenes.scene_0.referenceQuality = {
    floor: 1e-4, bestCorrectedRelMse: 0.01, bestLabel: 'reengine[disocclusionRays=off]_0', ratio: 0.01, goal: 0.1, meets: true,
    segmentsMeet: false, segments: [{ from: 8, to: 49, ratio: 0.01 }, { from: 50, to: 99, ratio: 0.2 }],
    verdict: 'scene_0: reference noise floor 1e-4 / best corrected relMSE 0.01 = 0.01 <= 0.1: met for the scene\'s mean, not between its events (frames 50-99 0.2 > 0.1: the figures measured there carry more of the reference\'s noise)' };
  fs.writeFileSync(path.join(dir, 'results.json'), JSON.stringify(results));
  const out = path.join(work, 'synthetic-long-report');
  arena('report', dir, '--out', out);
  const { page, problems } = await openReport(out);
  const boxes = await page.$$eval('#rankings .ranking', (ds) => ds.map((d) => {
    const t = d.querySelector('table').getBoundingClientRect(), b = d.getBoundingClientRect();
    return { scroll: d.scrollWidth, client: d.clientWidth, left: b.left, right: b.right, tableRight: t.right };
  }));
  assert.ok(boxes.length >= 2, JSON.stringify(boxes));
  for (const b of boxes) assert.ok(b.scroll <= b.client && b.tableRight <= b.right + 0.5, `a ranking table past its box: ${JSON.stringify(boxes)}`);
  const f = await page.$eval('#summary-wrap', (w) => ({ scroll: w.scrollWidth, client: w.clientWidth }));
  assert.ok(f.scroll <= f.client, `summary table fits 1400 px: ${f.scroll} > ${f.client}`);
  const events = await page.$$eval('#ghosting-body .table-wrap', (ws) => ws.map((w) => [w.scrollWidth, w.clientWidth]));
  assert.ok(events.length >= 2 && events.every(([s, c]) => s <= c), `event tables fit 1400 px: ${JSON.stringify(events)}`);
  assert.match(await page.locator('#warnings p.reference-quality').innerText(), /met for the scene's mean, not between its events \(frames 50-99/);
  // ... and under the event's own figures, which that segment holds.
  assert.match(await page.locator('#ghosting-body p.segment-quality').innerText(), /The reference's noise in frames 50-99 is 0\.2 of the best method's error there/);
  await page.selectOption('#scene-select', 'scene_1');
  await page.waitForFunction(() => document.getElementById('scene-purpose').textContent.startsWith('scene_1'));
  assert.equal(await page.locator('#warnings p.reference-quality').count(), 0, 'scene_1 has no verdict to say');
  assert.deepEqual(problems, []);
  await page.close();
});

// A sweep of svgf over a 2x2 grid: each parameter's change is matched under both values of the
// other. Green or red only where every matched paired difference is resolved that way.
test('a sweep\'s ablation colours a change only where every matched interval resolves it', async () => {
  const run = syntheticRun(1, 4, 20);
  const grid = [[0, true], [1, true], [0, false], [1, false]];  // denoiser_l's (a, b)
  run.pairs.forEach((p, l) => { p.denoiser = 'svgf'; p.params = { a: grid[l][0], b: grid[l][1] }; });
  run.sweep = { denoiser: 'svgf', grid: { a: ['0', '1'], b: ['true', 'false'] }, fixed: {} };
  // a=1 against a=0: resolved at b=true (denoiser_0 - denoiser_1), not at b=false (2 - 3).
  const st = run.statistics.scenes.scene_0;
  const unresolved = st.pairs.find((d) => d.a === 'denoiser_2' && d.b === 'denoiser_3');
  unresolved.resolved = false;
  unresolved.ci95 = [unresolved.diff - 0.02, unresolved.diff + 0.02];
  st.resolvedPairs = st.pairs.filter((d) => d.resolved).length;
  const dir = path.join(work, 'sweep');
  fs.mkdirSync(dir, { recursive: true });
  fs.writeFileSync(path.join(dir, 'results.json'), JSON.stringify(run));
  const out = path.join(work, 'sweep-report');
  arena('report', dir, '--out', out);
  const { page, problems } = await openReport(out);
  // One scene: a row per parameter, no "all scenes" row repeating it; under each, its two matches.
  assert.equal(await page.locator('#ablation table tbody tr:not(.match)').count(), 2, 'ablation rows');
  assert.equal(await page.locator('#ablation table tbody tr.match').count(), 4, 'one line per match');
  const cell = (parameter, scene, metricIndex) => page.$eval(`#ablation table`, (t, [parameter, scene, metricIndex]) => {
    const heads = [...t.tHead.rows[0].cells].map((c) => c.textContent);
    const row = [...t.tBodies[0].rows].find((r) => r.cells[0].textContent === parameter && r.cells[2].textContent === scene);
    const c = row.cells[heads.indexOf(metricIndex)];
    return { cls: c.className, verdict: c.dataset.verdict, text: c.textContent };
  }, [parameter, scene, metricIndex]);
  let c = await cell('a', 'scene_0', 'Δ relMse');  // resolved under b=true only: no colour
  assert.match(c.verdict, /^partly (better|worse)$/);
  assert.equal(c.cls, 'tie');
  assert.match(c.text, /1\/2 resolved, partly (better|worse)$/);
  // Its matches, each with its own paired interval: resolved given b=true, a tie given b=false.
  const matches = await page.$$eval('#ablation table tbody tr', (trs) => {
    const out = [];
    let parameter = null;
    for (const r of trs) {
      if (!r.classList.contains('match')) { parameter = r.cells[0].textContent; continue; }
      if (parameter === 'a') out.push({ given: r.cells[1].textContent, verdict: r.cells[4].dataset.verdict, text: r.cells[4].textContent });
    }
    return out;
  });
  assert.deepEqual(matches.map((m) => m.given), ['given b=true', 'given b=false']);
  assert.match(matches[0].verdict, /^(better|worse)$/);
  assert.equal(matches[1].verdict, 'tie');
  // The fixture's per-frame differences of this tie hold one sign on every frame: marked so.
  assert.match(matches[1].text, / tie \(one sign every frame\)$/);
  c = await cell('b', 'scene_0', 'Δ relMse');  // both matches resolved: b=false is worse
  assert.equal(c.verdict, 'worse');
  assert.equal(c.cls, 'worse');
  assert.match(c.text, /2\/2 resolved/);
  c = await cell('b', 'scene_0', 'Δ ssim');  // no paired statistics on ssim: no colour
  assert.equal(c.verdict, 'no interval');
  assert.equal(c.cls, '');
  assert.match(c.text, /no interval/);
  assert.deepEqual(problems, []);
  await page.close();
});

// Results from before the event intervals (no statistics, no ci95 on the events): the smallest
// value of each column is marked, ties included; rows are labelled and a response that never
// settled reads so, as in a run with intervals.
test('an older run\'s ghosting table: smallest values marked, rows labelled, never settled said', async () => {
  const { run } = tinyRuns();
  const dir = path.join(work, 'older');
  fs.cpSync(run, dir, { recursive: true });
  const results = JSON.parse(fs.readFileSync(path.join(dir, 'results.json'), 'utf8'));
  delete results.statistics;
  const withEvent = results.pairs.filter((p) => p.status === 'ok' && p.scene === 'light_switch' && (p.ghosting || []).length);
  assert.ok(withEvent.length >= 3, 'fixture: pairs with the light_switch event');
  for (const p of withEvent) { delete p.ghosting[0].ci95; delete p.ghosting[0].ci95Absent; }
  const [never, tiedA, tiedB] = withEvent;
  Object.assign(never.ghosting[0], { settled: false, responseFrames: null, response: 'never settled within the window' });
  withEvent.forEach((p, i) => { p.ghosting[0].lagEnergy = 0.01 * (i + 1); });
  tiedA.ghosting[0].lagEnergy = 0.001;
  tiedB.ghosting[0].lagEnergy = 0.001;
  fs.writeFileSync(path.join(dir, 'results.json'), JSON.stringify(results));
  const out = path.join(work, 'older-report');
  arena('report', dir, '--out', out);
  const { page, problems } = await openReport(out);
  await page.selectOption('#scene-select', 'light_switch');
  const table = page.locator('#ghosting-body table.ghost-table');
  await table.waitFor();
  assert.match(await page.locator('#ghosting-body p.note').first().innerText(), /no intervals for its events/);
  const rows = await table.locator('tbody tr').evaluateAll((trs) => trs.map((r) => ({
    label: r.dataset.label, lag: r.cells[1].textContent, lagBest: r.cells[1].classList.contains('best'), response: r.cells[2].textContent })));
  assert.deepEqual(rows.map((r) => r.label).sort(), withEvent.map((p) => p.label).sort(), 'every row names its pair');
  assert.deepEqual(rows.filter((r) => r.lagBest).map((r) => r.label).sort(), [tiedA.label, tiedB.label].sort(), 'both smallest marked');
  assert.equal(rows.find((r) => r.label === never.label).response, 'never settled');
  assert.ok(rows.every((r) => !/\[/.test(r.lag)), 'no interval shown where the run has none');
  assert.deepEqual(problems, []);
  await page.close();
});

// A synthetic history of 50 runs (one per commit): 2 scenes x 3 denoisers, values wobbling by
// ±0.5% (under compare's 2% tolerance); at run 30 svgf's relMSE on scene_b rises 15% and stays.
// `worse(scene, label, i)` may make more changes (a factor on relMSE).
function historyRuns(dir, schema, worse = () => 1) {
  const runs = [];
  for (let i = 0; i < 50; ++i) {
    const wobble = (k) => 1 + 0.005 * Math.sin(1.7 * i + k);
    const pairs = [];
    for (const [si, scene] of ['scene_a', 'scene_b'].entries())
      for (const [li, label] of ['passthrough', 'temporal', 'svgf'].entries()) {
        const k = 3 * si + li;
        const regress = (label === 'svgf' && scene === 'scene_b' && i >= 30 ? 1.15 : 1) * worse(scene, label, i);
        const st = (v) => ({ mean: v, median: v, p5: 0.8 * v, p95: 1.2 * v, frames: 8, ci95: [0.998 * v, 1.002 * v] });
        // Per-frame tile sums (results schema: pair.tiles.<metric>), which compare's paired interval
        // reads: 8 frames x 16 tiles of 100 pixels, varying over tiles and frames around the mean
        // (tile q + 8 mirrors tile q, so each frame's mean is the summary's: compare checks it).
        const tilesOf = (v) => {
          const sums = new Float32Array(8 * 16);
          for (let t = 0; t < 8; ++t) for (let q = 0; q < 16; ++q) sums[t * 16 + q] = 100 * v * (1 + (q < 8 ? 0.1 : -0.1) * Math.sin(1.3 * (q % 8) + t));
          const b64 = (a) => Buffer.from(a.buffer).toString('base64');
          return { transform: 'mean', frames: [2, 3, 4, 5, 6, 7, 8, 9], tiles: 16, sum: b64(sums), count: b64(new Float32Array(16).fill(100)), countPerFrame: false };
        };
        const relMse = 0.01 * (li + 1) * (si + 1) * wobble(k) * regress;
        pairs.push({ scene, denoiser: label, label, params: {}, status: 'ok', frames: [],
                     tiles: { relMse: tilesOf(relMse), ldrFlip: tilesOf(0.05 * (li + 1) * wobble(k + 1)),
                              ssim: tilesOf(0.9 - 0.01 * li * wobble(k + 2)), tRmae: tilesOf(0.2 * (li + 1) * wobble(k + 3)) },
                     summary: { relMse: st(relMse), ldrFlip: st(0.05 * (li + 1) * wobble(k + 1)),
                                ssim: st(0.9 - 0.01 * li * wobble(k + 2)), tRmae: st(0.2 * (li + 1) * wobble(k + 3)), ms: st((li + 1) * 2 * wobble(k + 4)) },
                     timing: { msMedian: (li + 1) * 2, msP95: (li + 1) * 2.5 } });
      }
    const created = new Date(Date.UTC(2025, 0, 1, 0, i)).toISOString().replace('.000', '');
    const run = path.join(dir, `run_${String(i).padStart(2, '0')}`);
    fs.mkdirSync(run, { recursive: true });
    fs.writeFileSync(path.join(run, 'results.json'), JSON.stringify({ schema, kind: 'arena-run', name: `ci-${i}`, created,
      environment: { git_commit: `c0ffee${String(i).padStart(2, '0')}` }, settings: { warmup: 2 }, scenes: {}, pairs }));
    runs.push(run);
  }
  return runs;
}

test('history dashboard: 50 runs, the regressing one is marked, and the page stays fast', async () => {
  const dir = path.join(work, 'history-runs');
  const runs = historyRuns(dir, tinyRuns().schema);
  const out = path.join(work, 'history');
  // Given newest first: the dashboard orders runs by creation time itself.
  const said = arena('history', ...runs.slice().reverse(), '--out', out);
  // Comparisons counted as comparisons, their failing rows apart.
  assert.match(said, /50 runs, 1 of 49 comparison\(s\) failing `arena compare`'s gate \(1 row\(s\)\)/);
  // `arena compare` on the same two runs fails too (the dashboard marks what the gate does).
  assert.throws(() => arena('compare', runs[29], runs[30]), (e) => e.status === 1);

  const page = await context.newPage();
  const problems = [];
  page.on('console', (m) => { if (m.type() === 'error') problems.push(`console error: ${m.text()}`); });
  page.on('pageerror', (e) => problems.push(`page error: ${e.message}`));
  page.on('request', (r) => { if (!/^(file|data|blob):/.test(r.url())) problems.push(`network request: ${r.url()}`); });
  const t0 = Date.now();
  await page.goto(pathToFileURL(path.join(out, 'index.html')).href);
  await page.waitForSelector('body[data-ready]', { timeout: 30000 });
  const wall = Date.now() - t0;
  assert.equal(await page.evaluate(() => document.body.dataset.ready), 'true', problems.join('\n'));
  const loadMs = await page.evaluate(() => window.Arena.loadMs);
  console.log(`history dashboard (50 runs x 2 scenes x 3 denoisers x 5 metrics): ready ${loadMs.toFixed(0)} ms after navigation (${wall} ms wall in the test)`);
  assert.ok(loadMs < 3000, `history page took ${loadMs} ms`);

  // The flag: run 30, its commit, svgf on scene_b, relMSE; and only that.
  const flags = await page.$$eval('#flags tr.flag', (rows) => rows.map((r) => ({ ...r.dataset, commit: r.cells[1].textContent })));
  assert.deepEqual(flags, [{ run: '30', scene: 'scene_b', label: 'svgf', metric: 'relMse', commit: 'c0ffee30' }]);
  // With the change's paired interval, which the gate resolved above zero.
  assert.match(await page.$eval('#flags tr.flag', (r) => r.cells[8].textContent), /^\[\+\d+\.\d%, \+\d+\.\d%\]$/);
  // The page opens on the flagged series: one chart per metric, the flagged point ringed on relMSE only.
  assert.equal(await page.$eval('#history-scene', (s) => s.value), 'scene_b');
  assert.equal(await page.$eval('#history-label', (s) => s.value), 'svgf');
  assert.equal(await page.locator('#history-charts .chart').count(), 5);
  assert.equal(await page.locator('#history-charts .chart[data-metric="relMse"] g.flagged_marks path').count(), 1);
  assert.equal(await page.locator('#history-charts .chart[data-metric="relMse"] g.values_marks path').count(), 1, 'one line');
  assert.equal(await page.locator('#history-charts .chart[data-metric="ldrFlip"] g.flagged_marks path').count(), 0);
  assert.ok((await page.locator('#history-charts .chart[data-metric="relMse"] g.band_marks path').count()) >= 1, 'tolerance band');
  // The run axis names each tick's commit ("30 c0ffee3"), not the run's number alone.
  const ticks = await page.$$eval('#history-charts .chart[data-metric="relMse"] .role-axis-label text', (ts) => ts.map((t) => t.textContent));
  assert.ok(ticks.some((t) => /^\d+ c0ffee/.test(t)), `axis labels: ${ticks.join(' | ')}`);
  await shot(page, 'history.png');
  // Another series: nothing flagged there.
  await page.selectOption('#history-label', 'temporal');
  await page.waitForFunction(() => document.querySelectorAll('#history-charts .chart[data-metric="relMse"] g.values_marks').length === 1);
  assert.equal(await page.locator('#history-charts g.flagged_marks path').count(), 0);
  // A flag row brings its series back.
  await page.click('#flags tr.flag');
  await page.waitForFunction(() => document.getElementById('history-label').value === 'svgf');
  assert.match(await page.locator('#load-time').innerText(), /Page ready \d+ ms/);
  // How the rows were judged, in the gate's own options.
  assert.match(await page.locator('#history-judged').innerText(), /arena compare --confidence 95% --correction holm.*Holm's step-down/);
  assert.match(await page.locator('#history-info').innerText(), /1 of 49 comparison\(s\) fail the gate \(1 row\(s\)\)/);
  assert.deepEqual(problems, []);
  await page.close();

  // The same change read from results.db (no tiles): not judged, said above the table of those
  // changes, never "no run would have failed the gate".
  const dbOut = path.join(work, 'history-not-judged');
  fs.cpSync(out, dbOut, { recursive: true });
  const dataFile = path.join(dbOut, 'history-data.js');
  const data = JSON.parse(fs.readFileSync(dataFile, 'utf8').replace(/^[^]*?window\.ARENA_HISTORY = /, '').replace(/;\s*$/, ''));
  for (const c of data.changes)
    if (c.fails) Object.assign(c, { verdict: 'not judged', fails: false, changeCi95: null, note: 'no tile data for a paired interval (results.db keeps none)' });
  Object.assign(data, { failing: 0, failingComparisons: 0, notJudged: 1 });
  fs.writeFileSync(dataFile, `window.ARENA_HISTORY = ${JSON.stringify(data)};\n`);
  const db = await context.newPage();
  await db.goto(pathToFileURL(path.join(dbOut, 'index.html')).href);
  await db.waitForSelector('body[data-ready]', { timeout: 30000 });
  assert.match(await db.locator('#flags').innerText(), /No run failed the gate where it could judge/);
  assert.match(await db.locator('#flags p.not-judged').innerText(), /1 change\(s\) beyond the tolerance were NOT JUDGED/);
  assert.equal(await db.locator('#flags table.not-judged-table tbody tr').count(), 1);
  assert.doesNotMatch(await db.locator('#flags').innerText(), /No run would have failed/);
  assert.match(await db.locator('#history-info').innerText(), /0 of 49 comparison\(s\) fail the gate \(0 row\(s\)\), 1 change\(s\) beyond the tolerance not judged/);
  await db.close();

  // A comparison the gate cannot pass though no row fails it (runs sharing 7 or fewer frames after
  // the warm-up: compare exits 2): said, never "no run would have failed the gate".
  const fewOut = path.join(work, 'history-few-frames');
  fs.cpSync(out, fewOut, { recursive: true });
  const fewFile = path.join(fewOut, 'history-data.js');
  const few = JSON.parse(fs.readFileSync(fewFile, 'utf8').replace(/^[^]*?window\.ARENA_HISTORY = /, '').replace(/;\s*$/, ''));
  few.changes = few.changes.filter((c) => !c.fails);
  Object.assign(few, { failing: 0, failingComparisons: 1, notJudged: 0 });
  fs.writeFileSync(fewFile, `window.ARENA_HISTORY = ${JSON.stringify(few)};\n`);
  const fp = await context.newPage();
  await fp.goto(pathToFileURL(path.join(fewOut, 'index.html')).href);
  await fp.waitForSelector('body[data-ready]', { timeout: 30000 });
  assert.match(await fp.locator('#flags').innerText(), /1 comparison\(s\) the gate cannot pass though no row fails it/);
  assert.doesNotMatch(await fp.locator('#flags').innerText(), /No run would have failed|No run failed the gate where it could judge/);
  await fp.close();
});

test('history --match: a contender relabelled from run 40 on stays one series, named both ways', async () => {
  const dir = path.join(work, 'history-relabelled');
  // The new parameter makes temporal 15% worse on scene_a: the gate must see it across the change.
  const runs = historyRuns(dir, tinyRuns().schema, (scene, label, i) => (scene === 'scene_a' && label === 'temporal' && i >= 40 ? 1.15 : 1));
  for (const run of runs.slice(40)) {  // a parameter added to the command CI runs
    const file = path.join(run, 'results.json');
    const r = JSON.parse(fs.readFileSync(file, 'utf8'));
    for (const p of r.pairs) if (p.label === 'temporal') Object.assign(p, { label: 'temporal[alphaMin=0.1]', params: { alphaMin: 0.1 } });
    fs.writeFileSync(file, JSON.stringify(r));
  }
  const out = path.join(work, 'history-match');
  // Without --match the pairs read missing at run 40 (the gate fails there for good).
  assert.match(arena('history', ...runs, '--out', out), /2 of 49 comparison\(s\) failing/);
  const said = arena('history', ...runs, '--out', out, '--match', 'temporal=temporal[alphaMin=0.1]');
  assert.match(said, /2 of 49 comparison\(s\) failing `arena compare`'s gate \(2 row\(s\)\)/);
  assert.match(said, /match: temporal=temporal\[alphaMin=0\.1\]: compared at run 40 /);
  const page = await context.newPage();
  const problems = [];
  page.on('pageerror', (e) => problems.push(`page error: ${e.message}`));
  await page.goto(pathToFileURL(path.join(out, 'index.html')).href);
  await page.waitForSelector('body[data-ready]', { timeout: 30000 });
  const options = await page.$$eval('#history-label option', (os) => os.map((o) => [o.value, o.textContent]));
  assert.deepEqual(options.map((o) => o[0]).sort(), ['passthrough', 'svgf', 'temporal']);
  assert.deepEqual(options.find((o) => o[0] === 'temporal'), ['temporal', 'temporal (also temporal[alphaMin=0.1])']);
  // svgf's flag at run 30 by its own label; temporal's at 40 names the two labels compared.
  assert.deepEqual(await page.$$eval('#flags tr.flag', (rs) => rs.map((r) => [r.dataset.run, r.dataset.label, r.cells[3].textContent])),
                   [['30', 'svgf', 'svgf'], ['40', 'temporal', 'temporal → temporal[alphaMin=0.1]']]);
  await page.selectOption('#history-label', 'temporal');
  await page.waitForFunction(() => document.querySelectorAll('#history-charts .chart[data-metric="relMse"] g.values_marks').length === 1);
  // One line through all 50 runs, the relabelled ones included.
  const points = await page.$$eval('#history-charts .chart[data-metric="relMse"] g.points_marks path', (ps) => ps.length);
  assert.equal(points, 50);
  assert.deepEqual(problems, []);
  await page.close();
});

test('history --allow-settings-mismatch: a warm-up changed at run 25 is compared there, and the page says so', async () => {
  const dir = path.join(work, 'history-warmup');
  const runs = historyRuns(dir, tinyRuns().schema);
  for (const run of runs.slice(25)) {  // the command CI runs changed its warm-up
    const file = path.join(run, 'results.json');
    const r = JSON.parse(fs.readFileSync(file, 'utf8'));
    r.settings.warmup = 3;
    fs.writeFileSync(file, JSON.stringify(r));
  }
  const out = path.join(work, 'history-allowed');
  // As `arena compare` refuses runs 24 and 25 (exit 2), the dashboard marks them not comparable.
  assert.match(arena('history', ...runs, '--out', out), /2 of 49 comparison\(s\) failing .*, 1 of them not comparable/);
  assert.equal(spawnSync(ARENA, ['compare', runs[24], runs[25]]).status, 2);
  // Asked to compare anyway, as compare is: judged, and warned of once.
  const said = spawnSync(ARENA, ['history', ...runs, '--out', out, '--allow-settings-mismatch'], { encoding: 'utf8' });
  assert.equal(said.status, 0, said.stderr);
  assert.match(said.stdout, /1 of 49 comparison\(s\) failing `arena compare`'s gate \(1 row\(s\)\)\)/);
  assert.match(said.stderr, /warning: comparing the run ci-25 of 2025-01-01T00:25:00Z with the run before: comparing runs with different settings \(baseline vs candidate\): settings\.warmup: 2 vs 3/);
  assert.equal(spawnSync(ARENA, ['compare', runs[24], runs[25], '--allow-settings-mismatch']).status, 0);
  const page = await context.newPage();
  const problems = [];
  page.on('pageerror', (e) => problems.push(`page error: ${e.message}`));
  await page.goto(pathToFileURL(path.join(out, 'index.html')).href);
  await page.waitForSelector('body[data-ready]', { timeout: 30000 });
  assert.deepEqual(await page.$$eval('#history-warnings li', (ls) => ls.map((l) => l.textContent)),
                   ['comparing the run ci-25 of 2025-01-01T00:25:00Z with the run before: comparing runs with different settings (baseline vs candidate): settings.warmup: 2 vs 3']);
  assert.deepEqual(await page.$$eval('#flags tr.flag', (rs) => rs.map((r) => r.dataset.run)), ['30']);
  assert.deepEqual(problems, []);
  await page.close();
});

test('a capture: its validation on the page, a file: contender named with its own clock', async () => {
  // Our own sequence exported as a capture, eaw's outputs stored in it as a contender that "ran
  // elsewhere" with a recorded device time (docs/captures.md).
  const capture = path.join(work, 'capture');
  arena('export', 'cornell_static', '--resolution', '48x27', '--frames', '8', '--ref-spp', '16',
    '--cache', path.join(work, 'cache'), '--out', capture);
  const first = path.join(work, 'capture-first');
  arena('run', '--capture', capture, '--denoisers', 'eaw', '--no-baselines', '--keep-frames', 'all', '--warmup', '2',
    '--out', first);
  const stored = path.join(capture, 'outputs', 'eaw_elsewhere');
  fs.mkdirSync(stored, { recursive: true });
  const frames = path.join(first, 'images', 'cornell_static', 'eaw');
  for (const f of fs.readdirSync(frames).filter((n) => n.endsWith('.exr'))) fs.copyFileSync(path.join(frames, f), path.join(stored, f));
  const description = JSON.parse(fs.readFileSync(path.join(capture, 'capture.json'), 'utf8'));
  description.outputs = { eaw_elsewhere: { milliseconds: Array(8).fill(0.8), device: 'test GPU' } };
  fs.writeFileSync(path.join(capture, 'capture.json'), JSON.stringify(description));
  const run = path.join(work, 'capture-run');
  arena('run', '--capture', capture, '--denoisers', 'eaw,file:eaw_elsewhere', '--warmup', '2', '--out', run);
  const report = path.join(work, 'capture-report');
  arena('report', run, '--out', report);
  const { page, problems } = await openReport(report);
  // Every check is a row with its value and thresholds.
  const rows = await page.locator('.validation-table tbody tr').count();
  assert.ok(rows >= 15, `validation rows: ${rows}`);
  const text = await page.locator('.validation-table').innerText();
  for (const check of ['motion.consistency', 'nonFinite.normal', 'reference.noiseVsInput'])
    assert.ok(text.includes(check), `the validation table lacks ${check}`);
  // The stored output is ranked like a built-in but kept off the CPU axis, named with its device.
  const front = await page.locator('#speed-front').innerText();
  assert.match(front, /timed on another clock.*file:eaw_elsewhere.*test GPU/);
  // Where it came from, in the header and on its row; the built-in's row unmarked.
  assert.match(await page.locator('#run-origins').innerText(), /Not built in: file:eaw_elsewhere \(.*outputs\/eaw_elsewhere\)/);
  assert.equal(await page.locator('#summary-table tbody tr[data-label="file:eaw_elsewhere"] td.first').innerText(), 'file:eaw_elsewhere (stored output)');
  assert.equal(await page.locator('#summary-table tbody tr[data-label="eaw"] td.first').innerText(), 'eaw');
  assert.deepEqual(problems, []);
  await page.close();
  // The same capture without its references: the page says its display exposure comes from the
  // noisy inputs (the header said "from each frame's own reference").
  const bare = path.join(work, 'capture-noref');
  fs.cpSync(capture, bare, { recursive: true });
  const bareDescription = JSON.parse(fs.readFileSync(path.join(bare, 'capture.json'), 'utf8'));
  delete bareDescription.reference;
  delete bareDescription.outputs;
  fs.rmSync(path.join(bare, 'outputs'), { recursive: true, force: true });
  fs.writeFileSync(path.join(bare, 'capture.json'), JSON.stringify(bareDescription));
  const bareRun = path.join(work, 'capture-noref-run');
  arena('run', '--capture', bare, '--denoisers', 'eaw', '--no-baselines', '--warmup', '2', '--out', bareRun);
  const bareReport = path.join(work, 'capture-noref-report');
  arena('report', bareRun, '--out', bareReport);
  const opened = await openReport(bareReport);
  const info = await opened.page.locator('#run-info').innerText();
  assert.match(info, /display: exposure from each frame's noisy input \(no reference\)/);
  assert.doesNotMatch(info, /own reference/);
  assert.deepEqual(opened.problems, []);
  await opened.page.close();
});
