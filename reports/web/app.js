// Denoise Arena report: builds every section of index.html from window.ARENA_DATA (data.js).
//
// Organised by section: utilities, header, (1) speed vs accuracy, (2) over time, ghosting,
// (3) tables, (4) images, (5) regression, (6) PNG export, then start-up.
// Responsiveness with 10 denoisers x 10 scenes x 100 frames: only the selected scene's charts,
// tables and image panels are built, and rebuilt when the scene changes; images load lazily.
'use strict';

(() => {
  const D = window.ARENA_DATA;
  const VEGA_LOADED = typeof window.vegaEmbed === 'function';

  // ---------------------------------------------------------------- utilities

  const $ = (id) => document.getElementById(id);

  // el('td', {class: 'x', title: 'y'}, child, 'text', ...)
  function el(tag, attrs, ...children) {
    const e = document.createElement(tag);
    for (const [k, v] of Object.entries(attrs || {})) {
      if (v === undefined || v === null || v === false) continue;
      if (k === 'class') e.className = v;
      else if (k === 'text') e.textContent = v;
      else e.setAttribute(k, v === true ? '' : v);
    }
    for (const c of children.flat()) {
      if (c === null || c === undefined) continue;
      e.append(c instanceof Node ? c : document.createTextNode(String(c)));
    }
    return e;
  }

  function fmt(v) {
    if (v === null || v === undefined || Number.isNaN(v)) return '–';
    if (typeof v !== 'number') return String(v);
    const a = Math.abs(v);
    if (a === 0) return '0';
    if (a < 1e-3 || a >= 1e5) return v.toExponential(2);
    return Number(v.toPrecision(4)).toString();
  }
  const pct = (v) => (v === null || v === undefined ? '–' : (v >= 0 ? '+' : '') + (100 * v).toFixed(1) + '%');

  const metricInfo = Object.fromEntries(D.metrics.map((m) => [m.name, m]));
  const sceneByName = Object.fromEntries(D.scenes.map((s) => [s.name, s]));
  const pairsOf = (scene) => D.pairs.filter((p) => p.scene === scene);
  const isOk = (p) => p.status === 'ok';

  // Every chart colours a label the same way, whichever labels the scene has.
  const colorScale = { domain: D.labels, scheme: D.labels.length > 10 ? 'category20' : 'tableau10' };

  // Vega views by chart name, for the PNG buttons; a re-rendered chart finalizes its old view.
  const views = {};
  async function embedChart(name, container, spec) {
    if (views[name]) {
      views[name].finalize();
      delete views[name];
    }
    container.replaceChildren();
    if (!VEGA_LOADED) {
      container.append(el('p', { class: 'empty', text: 'Charting library not loaded (vega*.min.js missing next to index.html).' }));
      return;
    }
    // SVG: marks become DOM elements (the browser test counts them); the export action still
    // offers PNG. Source/editor actions would need the network, so they are off.
    const result = await window.vegaEmbed(container, spec, {
      renderer: 'svg',
      actions: { export: true, source: false, compiled: false, editor: false },
    });
    views[name] = result.view;
    return result.view;
  }

  const baseSpec = (extra) => ({
    $schema: 'https://vega.github.io/schema/vega-lite/v6.json',
    config: { font: 'system-ui, sans-serif', axis: { labelFontSize: 11, titleFontSize: 12 }, legend: { labelLimit: 260 } },
    ...extra,
  });

  // The error axes of the speed chart (relMSE, HDR-/LDR-FLIP, 1-SSIM) as per-frame series values.
  function axisSeries(pair, axis) {
    const col = pair.series && pair.series[axis.source];
    if (!col) return null;
    return axis.complement ? col.map((v) => (v === null ? null : 1 - v)) : col;
  }

  const state = {
    scene: D.scenes.length ? D.scenes[0].name : null,
    speedScene: '__all__',
    speedAxis: D.errorAxes.length ? D.errorAxes[0].key : null,
    frame: null,
    zoom: { s: 1, x: 0, y: 0 },
  };

  // ---------------------------------------------------------------- header

  function renderHeader() {
    const r = D.run;
    $('run-name').textContent = r.name || '(unnamed run)';
    const env = r.environment || {};
    const s = r.settings || {};
    const parts = [
      r.created && `created ${r.created}`,
      env.git_commit && `commit ${env.git_commit}`,
      env.cpu && `${env.cpu} (${env.cores} cores)`,
      env.compiler,
      `warm-up W = ${r.warmup}`,
      s.relMseEpsilon !== undefined && `relMSE eps = ${s.relMseEpsilon}`,
      s.flip && `FLIP: ${s.flip}`,
      s.display && `display: ${s.display}`,
    ].filter(Boolean);
    $('run-info').textContent = parts.join(' · ');

    if (D.failures.length) {
      const box = $('failures');
      box.hidden = false;
      box.append(
        el('b', { text: `${D.failures.length} pair(s) failed; the rest of the report is complete:` }),
        el('ul', {}, D.failures.map((f) => el('li', {}, el('b', { text: `${f.label} on ${f.scene}: ` }), f.error))),
      );
    }

    const select = $('scene-select');
    for (const s of D.scenes) select.append(el('option', { value: s.name, text: s.name }));
    select.value = state.scene;
    select.addEventListener('change', () => {
      state.scene = select.value;
      renderScene();
    });
  }

  function renderScenePurpose() {
    const s = sceneByName[state.scene];
    const text = !s ? '' : !s.prepared ? `${s.name}: the scene could not be prepared (see the failures above).`
      : `${s.name}: ${s.purpose || ''} (${s.width}×${s.height}, ${s.frames} frames)`;
    $('scene-purpose').textContent = text;
  }

  // ---------------------------------------------------------------- (1) speed vs accuracy

  function setupSpeed() {
    const sceneSel = $('speed-scene');
    sceneSel.append(el('option', { value: '__all__', text: 'all scenes (mean)' }));
    for (const s of D.scenes) sceneSel.append(el('option', { value: s.name, text: s.name }));
    sceneSel.value = state.speedScene;
    sceneSel.addEventListener('change', () => {
      state.speedScene = sceneSel.value;
      renderSpeed();
    });
    const metricSel = $('speed-metric');
    for (const a of D.errorAxes) metricSel.append(el('option', { value: a.key, text: a.title }));
    metricSel.value = state.speedAxis;
    metricSel.addEventListener('change', () => {
      state.speedAxis = metricSel.value;
      renderSpeed();
    });
  }

  function renderSpeed() {
    const all = state.speedScene === '__all__';
    const scope = all ? D.speed.all : D.speed.scenes[state.speedScene] || {};
    const data = scope[state.speedAxis];
    const axis = D.errorAxes.find((a) => a.key === state.speedAxis);
    const chart = $('speed-chart');
    $('speed-note').textContent = (all
      ? 'All scenes: each label\'s mean over scenes of its per-scene mean (bars: mean of p5 and of p95); ms: mean of the per-scene medians. Hollow points did not complete every scene and are kept off the front. '
      : 'Bars: p5–p95 across frames after warm-up. ') +
      'x: median ms per frame (log). ' + (axis && axis.key === 'relMse' ? 'relMSE shown raw (not reference-corrected).' : '');
    if (!data || !data.points.length) {
      if (views.speed) { views.speed.finalize(); delete views.speed; }
      chart.replaceChildren(el('p', { class: 'empty', text: 'No measured pair for this choice.' }));
      $('speed-front').textContent = '';
      return Promise.resolve();
    }
    // A log axis cannot show 0 ms (a pass-through can round to it); such points are listed instead.
    const points = data.points.map((p) => ({ ...p, complete: p.complete !== false, onFront: data.front.includes(p.label) }));
    const drawn = points.filter((p) => p.ms > 0);
    const front = data.front.map((l) => drawn.find((p) => p.label === l)).filter(Boolean).sort((a, b) => a.ms - b.ms);
    const x = { field: 'ms', type: 'quantitative', scale: { type: 'log' }, title: 'ms per frame (median, log scale)' };
    const y = { field: 'error', type: 'quantitative', title: axis.title, scale: { zero: false } };
    const tooltip = [
      { field: 'label', title: 'label' },
      { field: 'ms', title: 'ms', format: '.3~g' },
      { field: 'error', title: axis.title, format: '.4~g' },
      { field: 'p5', title: 'p5', format: '.4~g' },
      { field: 'p95', title: 'p95', format: '.4~g' },
    ].concat(all ? [{ field: 'scenes', title: 'scenes' }] : []);
    const spec = baseSpec({
      width: 720,
      height: 380,
      data: { values: drawn },
      layer: [
        { name: 'bars', mark: { type: 'rule', strokeWidth: 1.5 },
          encoding: { x, y: { field: 'p5', type: 'quantitative' }, y2: { field: 'p95' },
                      color: { field: 'label', type: 'nominal', scale: colorScale, title: 'denoiser / setting' } } },
        { name: 'front', data: { values: front }, mark: { type: 'line', color: '#555', strokeDash: [5, 3], strokeWidth: 1.5 },
          encoding: { x, y, order: { field: 'ms', type: 'quantitative' } } },
        { name: 'points', mark: { type: 'point', filled: true, size: 110, strokeWidth: 2 },
          encoding: { x, y, tooltip,
                      color: { field: 'label', type: 'nominal', scale: colorScale, title: 'denoiser / setting' },
                      fillOpacity: { condition: { test: 'datum.complete', value: 1 }, value: 0 } } },
        // The front's members are named on the chart; the others by the legend and the tooltip
        // (naming every point would pile labels up where settings cluster, as in sweeps).
        { name: 'names', transform: [{ filter: 'datum.onFront' }],
          mark: { type: 'text', align: 'left', dx: 8, dy: -8, fontSize: 11, fontWeight: 'bold', color: '#1d2330' },
          encoding: { x, y, text: { field: 'label' } } },
      ],
    });
    const zero = points.filter((p) => !(p.ms > 0)).map((p) => p.label);
    $('speed-front').replaceChildren(
      'Pareto front (fastest first): ',
      ...front.flatMap((p, i) => [i ? ' → ' : '', el('b', { text: p.label })]),
      zero.length ? ` · not drawn (0 ms on a log axis): ${zero.join(', ')}` : '',
    );
    return embedChart('speed', chart, spec);
  }

  // ---------------------------------------------------------------- (2) over time

  const TIME_ERROR = [
    { key: 'relMse', title: 'relMSE', source: 'relMse' },
    { key: 'relMseCorrected', title: 'relMSE (reference-corrected)', source: 'relMseCorrected' },
    { key: 'hdrFlip', title: 'HDR-FLIP', source: 'hdrFlip' },
    { key: 'ldrFlip', title: 'LDR-FLIP', source: 'ldrFlip' },
    { key: 'dssim', title: '1 − SSIM', source: 'ssim', complement: true },
    { key: 'psnr', title: 'PSNR (dB)', source: 'psnr' },
  ];
  const TIME_FLICKER = [
    { key: 'tRmae', title: 'tRMAE', source: 'tRmae' },
    { key: 'warpedFlicker', title: 'warped flicker', source: 'warpedFlicker' },
    { key: 'tPsnr', title: 'tPSNR (dB)', source: 'tPsnr' },
  ];
  const present = (axes) => axes.filter((a) => D.pairs.some((p) => p.series && p.series[a.source]));

  function setupOverTime() {
    const errSel = $('time-error-metric');
    for (const a of present(TIME_ERROR)) errSel.append(el('option', { value: a.key, text: a.title }));
    const flSel = $('time-flicker-metric');
    for (const a of present(TIME_FLICKER)) flSel.append(el('option', { value: a.key, text: a.title }));
    errSel.addEventListener('change', renderOverTime);
    flSel.addEventListener('change', renderOverTime);
    $('time-log').addEventListener('change', renderOverTime);
  }

  // Layers shared by the per-frame charts: the warm-up band and one rule per scene event.
  function frameContextLayers(scene, x) {
    const layers = [];
    if (D.run.warmup > 0) {
      layers.push({ data: { values: [{ from: 0, to: Math.min(D.run.warmup, scene.frames - 1) }] },
                    mark: { type: 'rect', color: '#000', opacity: 0.05 },
                    encoding: { x: { ...x, field: 'from' }, x2: { field: 'to' } } });
    }
    const events = scene.events || [];
    if (events.length) {
      const ev = events.map((e) => ({ frame: e.frame, text: `${e.kind} ${e.what || ''}`.trim() }));
      layers.push({ data: { values: ev }, mark: { type: 'rule', color: '#c0392b', strokeDash: [4, 3] },
                    encoding: { x: { ...x, field: 'frame' } } });
      layers.push({ data: { values: ev }, mark: { type: 'text', color: '#c0392b', align: 'left', dx: 4, y: 8, fontSize: 11 },
                    encoding: { x: { ...x, field: 'frame' }, text: { field: 'text' } } });
    }
    return layers;
  }

  function frameSeriesRows(pairs, axis, positiveOnly) {
    const rows = [];
    for (const p of pairs) {
      const values = axisSeries(p, axis);
      if (!values) continue;
      const frames = p.series.frame || values.map((_, i) => i);
      values.forEach((v, i) => {
        if (v === null || !Number.isFinite(v) || (positiveOnly && v <= 0)) return;
        rows.push({ label: p.label, frame: frames[i], value: v });
      });
    }
    return rows;
  }

  function timeChart(name, container, scene, axis, log, extraLayers) {
    const pairs = pairsOf(scene.name).filter(isOk);
    const rows = frameSeriesRows(pairs, axis, log);
    if (!rows.length) {
      if (views[name]) { views[name].finalize(); delete views[name]; }
      container.replaceChildren(el('p', { class: 'empty', text: `No ${axis.title} per frame for this scene.` }));
      return Promise.resolve();
    }
    const x = { type: 'quantitative', title: 'frame', scale: { domain: [0, Math.max(1, scene.frames - 1)], nice: false } };
    const spec = baseSpec({
      width: 720,
      height: 230,
      layer: [
        ...frameContextLayers(scene, x),
        { data: { values: rows }, mark: { type: 'line', point: rows.length < 1500 ? { size: 14 } : false, strokeWidth: 1.5 },
          encoding: {
            x: { ...x, field: 'frame' },
            y: { field: 'value', type: 'quantitative', title: axis.title, scale: log ? { type: 'log' } : { zero: false } },
            color: { field: 'label', type: 'nominal', scale: colorScale, title: 'denoiser / setting' },
            tooltip: [{ field: 'label' }, { field: 'frame' }, { field: 'value', title: axis.title, format: '.4~g' }],
          } },
        ...(extraLayers || []),
      ],
    });
    return embedChart(name, container, spec);
  }

  function renderOverTime() {
    const scene = sceneByName[state.scene];
    if (!scene || !scene.prepared) {
      $('time-error-chart').replaceChildren(el('p', { class: 'empty', text: 'No data for this scene.' }));
      $('time-flicker-chart').replaceChildren();
      return Promise.resolve();
    }
    const errAxis = TIME_ERROR.find((a) => a.key === $('time-error-metric').value) || TIME_ERROR[0];
    const flAxis = TIME_FLICKER.find((a) => a.key === $('time-flicker-metric').value) || TIME_FLICKER[0];
    const log = $('time-log').checked && errAxis.key !== 'psnr';
    // The reference's own noise floor belongs next to raw relMSE (metrics.md: reference quality).
    const floor = [];
    if (errAxis.key === 'relMse' && scene.noiseFloor) {
      const f = [{ value: scene.noiseFloor.mean, text: 'reference noise floor' }];
      floor.push({ data: { values: f }, mark: { type: 'rule', color: '#777', strokeDash: [2, 2] },
                   encoding: { y: { field: 'value', type: 'quantitative' } } });
      floor.push({ data: { values: f }, mark: { type: 'text', color: '#777', align: 'right', baseline: 'bottom', x: 'width', dy: -2, fontSize: 11 },
                   encoding: { y: { field: 'value', type: 'quantitative' }, text: { field: 'text' } } });
    }
    return Promise.all([
      timeChart('timeError', $('time-error-chart'), scene, errAxis, log, floor),
      timeChart('timeFlicker', $('time-flicker-chart'), scene, flAxis, false, []),
    ]);
  }

  // ---------------------------------------------------------------- ghosting

  const GHOST_COLUMNS = [
    { key: 'responseFrames', title: 'response (frames)', better: 'lower' },
    { key: 'ghostEnergy', title: 'ghost energy', better: 'lower' },
    { key: 'peakExcess', title: 'peak excess', better: 'lower' },
    { key: 'signedBias', title: 'signed bias', better: 'zero' },
    { key: 'steadyState', title: 'E_ss', better: 'lower' },
    { key: 'maskFraction', title: 'mask (fraction of pixels)' },
  ];

  function renderGhosting() {
    const body = $('ghosting-body');
    // Finalize the previous scene's event charts before their containers go.
    for (const name of Object.keys(views)) if (name.startsWith('ghost')) { views[name].finalize(); delete views[name]; }
    body.replaceChildren();
    const scene = sceneByName[state.scene];
    const pairs = pairsOf(state.scene).filter(isOk);
    const nEvents = Math.max(0, ...pairs.map((p) => (p.ghosting || []).length));
    if (!scene || nEvents === 0) {
      body.append(el('p', { class: 'empty', text: 'This scene has no scripted event (nothing to ghost).' }));
      return Promise.resolve();
    }
    const renders = [];
    for (let k = 0; k < nEvents; ++k) {
      const withEvent = pairs.filter((p) => p.ghosting[k]);
      const g0 = withEvent[0].ghosting[k];
      body.append(el('h3', { text: `Event at frame ${g0.eventFrame}: ${g0.kind} ${g0.what || ''}` }));
      const rows = [];
      for (const p of withEvent) {
        const g = p.ghosting[k];
        (g.curve || []).forEach((v, i) => {
          if (v !== null && Number.isFinite(v)) rows.push({ label: p.label, frame: g.windowBegin + i, value: v });
        });
      }
      const holder = el('div', { class: 'chart' });
      const controls = el('div', { class: 'controls' },
        el('button', { type: 'button', class: 'png', 'data-chart': `ghost${k}`, text: 'PNG' }));
      body.append(controls, holder);
      const x = { field: 'frame', type: 'quantitative', title: 'frame', scale: { nice: false, zero: false } };
      const spec = baseSpec({
        width: 720,
        height: 200,
        layer: [
          { data: { values: [{ frame: g0.eventFrame }] }, mark: { type: 'rule', color: '#c0392b', strokeDash: [4, 3] }, encoding: { x } },
          { data: { values: rows }, mark: { type: 'line', point: { size: 14 } },
            encoding: { x, y: { field: 'value', type: 'quantitative', title: 'E_M(t) (relMSE in M)', scale: { type: 'log' } },
                        color: { field: 'label', type: 'nominal', scale: colorScale, title: 'denoiser / setting' },
                        tooltip: [{ field: 'label' }, { field: 'frame' }, { field: 'value', format: '.4~g' }] } },
        ],
      });
      renders.push(embedChart(`ghost${k}`, holder, spec));
      body.append(ghostTable(withEvent, k));
    }
    return Promise.all(renders);
  }

  function ghostTable(pairs, k) {
    const best = {};
    for (const c of GHOST_COLUMNS) {
      if (!c.better) continue;
      const vals = pairs.map((p) => p.ghosting[k][c.key]).filter((v) => Number.isFinite(v));
      if (!vals.length) continue;
      best[c.key] = c.better === 'zero' ? Math.min(...vals.map(Math.abs)) : Math.min(...vals);
    }
    const isBest = (c, v) => c.better && Number.isFinite(v) && (c.better === 'zero' ? Math.abs(v) === best[c.key] : v === best[c.key]);
    return el('div', { class: 'table-wrap' }, el('table', { class: 'data ghost-table' },
      el('thead', {}, el('tr', {}, el('th', { class: 'first', text: 'denoiser / setting' }), GHOST_COLUMNS.map((c) => el('th', { text: c.title })))),
      el('tbody', {}, pairs.map((p) => el('tr', {}, el('td', { class: 'first', text: p.label }),
        GHOST_COLUMNS.map((c) => {
          const v = p.ghosting[k][c.key];
          return el('td', { class: isBest(c, v) ? 'best' : null, text: fmt(v) });
        })))),
    ));
  }

  // ---------------------------------------------------------------- (3) tables

  // Catalog metrics that some pair of the run summarises; ms is shown with the timing columns.
  function tableMetrics() {
    return D.metrics.filter((m) => m.name !== 'ms' && D.pairs.some((p) => p.summary && p.summary[m.name]));
  }
  const TIMING_COLUMNS = [
    { key: 'msMedian', title: 'ms median' },
    { key: 'msP95', title: 'ms p95' },
    { key: 'msPerMegapixel', title: 'ms/MP' },
    { key: 'tapsPerPixel', title: 'taps/px' },
  ];

  function renderTables() {
    const table = $('summary-table');
    const scene = sceneByName[state.scene];
    const pairs = pairsOf(state.scene);
    const metrics = tableMetrics();
    // Columns as [title-group, stat, getter, lowerIsBetter].
    const cols = [];
    for (const m of metrics) {
      for (const stat of ['mean', 'p95'])
        cols.push({ group: m.name, title: stat, lower: m.lowerIsBetter, meaning: m.meaning,
                    get: (p) => (p.summary && p.summary[m.name] ? p.summary[m.name][stat] : null) });
    }
    for (const t of TIMING_COLUMNS) cols.push({ group: 'time', title: t.title, lower: true, get: (p) => (p.timing ? p.timing[t.key] : null) });
    const ok = pairs.filter(isOk);
    const best = cols.map((c) => {
      const vals = ok.map(c.get).filter((v) => Number.isFinite(v));
      return vals.length > 1 ? (c.lower ? Math.min(...vals) : Math.max(...vals)) : null;
    });

    const groups = [];
    for (const c of cols) {
      if (groups.length && groups[groups.length - 1].name === c.group) groups[groups.length - 1].span++;
      else groups.push({ name: c.group, span: 1, meaning: c.meaning, lower: c.lower });
    }
    const head = el('thead', {},
      el('tr', {}, el('th', { class: 'first', rowspan: 2, text: 'denoiser / setting' }), el('th', { rowspan: 2, text: 'status' }),
        groups.map((g) => el('th', { class: 'group', colspan: g.span, title: g.meaning ? `${g.meaning} (${g.lower ? 'lower' : 'higher'} is better)` : null,
          text: g.name === 'time' ? 'time' : `${g.name} ${g.lower ? '↓' : '↑'}` }))),
      el('tr', {}, cols.map((c, i) => el('th', { class: i === 0 || cols[i - 1].group !== c.group ? 'group-start' : null, text: c.title }))));

    const rows = [];
    // The reference noise floor, beside the relMSE columns it bounds.
    if (scene && scene.noiseFloor) {
      rows.push(el('tr', { class: 'reference-row' }, el('td', { class: 'first', text: 'reference (noise floor)' }), el('td', { text: `${scene.noiseFloor.frames} fr.` }),
        cols.map((c, i) => {
          const v = c.group === 'relMse' ? scene.noiseFloor[c.title] : null;
          return el('td', { class: i === 0 || cols[i - 1].group !== c.group ? 'group-start' : null, text: v === null ? '' : fmt(v) });
        })));
    }
    for (const p of pairs) {
      if (!isOk(p)) {
        rows.push(el('tr', { class: 'failed' }, el('td', { class: 'first', text: p.label }), el('td', { text: p.status }),
          el('td', { class: 'left', colspan: cols.length, text: p.error })));
        continue;
      }
      rows.push(el('tr', {}, el('td', { class: 'first', title: JSON.stringify(p.params), text: p.label }), el('td', { text: p.status }),
        cols.map((c, i) => {
          const v = c.get(p);
          const classes = [i === 0 || cols[i - 1].group !== c.group ? 'group-start' : '', best[i] !== null && v === best[i] ? 'best' : ''].join(' ').trim();
          return el('td', { class: classes || null, text: fmt(v) });
        })));
    }
    table.replaceChildren(head, el('tbody', {}, rows));

    const warnings = pairs.filter((p) => p.warnings && p.warnings.length);
    $('warnings').replaceChildren(...(warnings.length ? [el('h3', { text: 'Warnings' }),
      el('ul', { class: 'warnings' }, warnings.flatMap((p) => p.warnings.map((w) => el('li', {}, el('b', { text: `${p.label}: ` }), w))))] : []));
    renderAblation();
  }

  // Sweep runs: each grid parameter's values against its first value (e.g. an edge-stopping term
  // off vs on), as the mean change of every metric over matching settings.
  function renderAblation() {
    const box = $('ablation');
    box.replaceChildren();
    const A = D.ablation;
    if (!A) return;
    const rows = A.rows.filter((r) => r.scene === state.scene || r.scene === null);
    box.append(el('h3', { text: `Ablation of ${A.denoiser} (sweep)` }),
      el('p', { class: 'note', text: 'Δ = mean over matching settings of (metric with the value − metric with the first value), other grid parameters held equal; relative change in brackets. Green: better, red: worse.' }));
    if (!rows.length) {
      box.append(el('p', { class: 'empty', text: 'No grid parameter has two values with matching pairs.' }));
      return;
    }
    const metrics = D.metrics.filter((m) => rows.some((r) => r.delta[m.name] !== undefined));
    box.append(el('div', { class: 'table-wrap' }, el('table', { class: 'data ablation-table' },
      el('thead', {}, el('tr', {}, el('th', { class: 'first', text: 'parameter' }), el('th', { text: 'value vs first' }),
        el('th', { text: 'scene' }), el('th', { text: 'pairs' }), metrics.map((m) => el('th', { text: `Δ ${m.name}` })))),
      el('tbody', {}, rows.map((r) => el('tr', {},
        el('td', { class: 'first', text: r.parameter }), el('td', { text: `${r.value} vs ${r.versus}` }),
        el('td', { text: r.scene === null ? 'all scenes' : r.scene }), el('td', { text: r.matched }),
        metrics.map((m) => {
          const d = r.delta[m.name];
          if (d === undefined) return el('td', { text: '–' });
          const better = m.lowerIsBetter ? d < 0 : d > 0;
          return el('td', { class: d === 0 ? null : better ? 'better' : 'worse', text: `${fmt(d)} (${pct(r.relative[m.name])})` });
        })))))));
  }

  // ---------------------------------------------------------------- (4) images

  // Panels share one zoom: scale s and the translation (x, y) as fractions of the panel size, so a
  // single state drives panels of any pixel size.
  const viewer = { panels: [] };

  function setupImages() {
    $('frame-select').addEventListener('change', (e) => {
      state.frame = e.target.value;
      updateImageSources();
    });
    const exposure = $('exposure');
    exposure.addEventListener('input', () => {
      const ev = Number(exposure.value);
      $('viewer').style.setProperty('--exposure', String(Math.pow(2, ev)));
      $('exposure-value').textContent = `${ev > 0 ? '+' : ''}${ev} EV`;
    });
    $('show-flip').addEventListener('change', (e) => $('viewer').classList.toggle('no-flip', !e.target.checked));
    $('show-relerr').addEventListener('change', (e) => $('viewer').classList.toggle('no-relerr', !e.target.checked));
    $('zoom-reset').addEventListener('click', () => {
      state.zoom = { s: 1, x: 0, y: 0 };
      applyZoom();
    });

    // One listener on the grid for every panel: wheel zooms about the cursor, drag pans.
    const grid = $('viewer');
    grid.addEventListener('wheel', (e) => {
      const vp = e.target.closest('.viewport');
      if (!vp) return;
      e.preventDefault();
      const r = vp.getBoundingClientRect();
      const u = (e.clientX - r.left) / r.width, v = (e.clientY - r.top) / r.height;
      const z = state.zoom;
      const s = Math.min(64, Math.max(1, z.s * Math.exp(-e.deltaY * 0.0015)));
      // Keep the image point under the cursor fixed: (u - x) / s is invariant.
      state.zoom = clampZoom({ s, x: u - ((u - z.x) / z.s) * s, y: v - ((v - z.y) / z.s) * s });
      applyZoom();
    }, { passive: false });
    let drag = null;
    grid.addEventListener('pointerdown', (e) => {
      const vp = e.target.closest('.viewport');
      if (!vp || e.button !== 0) return;
      const r = vp.getBoundingClientRect();
      drag = { vp, w: r.width, h: r.height, px: e.clientX, py: e.clientY };
      vp.classList.add('dragging');
      vp.setPointerCapture(e.pointerId);
    });
    grid.addEventListener('pointermove', (e) => {
      if (!drag) return;
      const z = state.zoom;
      state.zoom = clampZoom({ s: z.s, x: z.x + (e.clientX - drag.px) / drag.w, y: z.y + (e.clientY - drag.py) / drag.h });
      drag.px = e.clientX;
      drag.py = e.clientY;
      applyZoom();
    });
    const end = () => {
      if (drag) drag.vp.classList.remove('dragging');
      drag = null;
    };
    grid.addEventListener('pointerup', end);
    grid.addEventListener('pointercancel', end);
  }

  // The image must keep covering its viewport: translation within [1 - s, 0].
  function clampZoom(z) {
    const lo = 1 - z.s;
    return { s: z.s, x: Math.min(0, Math.max(lo, z.x)), y: Math.min(0, Math.max(lo, z.y)) };
  }

  function applyZoom() {
    const { s, x, y } = state.zoom;
    // translate() percentages are of the image's own box, which is the viewport's size.
    const t = `translate(${(x * 100).toFixed(4)}%, ${(y * 100).toFixed(4)}%) scale(${s.toFixed(4)})`;
    for (const p of viewer.panels) p.img.style.transform = t;
  }

  const encodePath = (path) => path.split('/').map(encodeURIComponent).join('/');

  function renderImages() {
    const grid = $('viewer');
    const frameSel = $('frame-select');
    viewer.panels = [];
    grid.replaceChildren();
    frameSel.replaceChildren();
    const scene = sceneByName[state.scene];
    const v = scene && scene.viewer;
    if (!v || !v.panels.length) {
      grid.append(el('p', { class: 'empty', text: 'No images were kept for this scene (run with --keep-frames chosen or all).' }));
      return;
    }
    for (const t of v.frames) frameSel.append(el('option', { value: String(t), text: `frame ${t}` }));
    if (!v.frames.map(String).includes(state.frame)) state.frame = String(v.frames[0]);
    frameSel.value = state.frame;
    grid.style.setProperty('--aspect', `${scene.width} / ${scene.height}`);

    const makePanel = (panel) => {
      const viewport = el('div', { class: 'viewport', style: `aspect-ratio: ${scene.width} / ${scene.height}` });
      const img = el('img', { loading: 'lazy', decoding: 'async', alt: panel.title, draggable: 'false' });
      const missing = el('div', { class: 'missing', text: 'no image for this frame', hidden: true });
      viewport.append(img, missing);
      const exposed = panel.kind === 'reference' || panel.kind === 'noisy' || panel.kind === 'output';
      const fig = el('figure', { class: `panel ${panel.kind}${exposed ? ' exposed' : ''}`, 'data-kind': panel.kind, 'data-label': panel.label || '' },
        viewport, el('figcaption', { title: panel.title, text: panel.title }));
      viewer.panels.push({ panel, img, missing });
      return fig;
    };
    // Row 1: reference and noisy input; then one row per label: output, FLIP map, relative error.
    const byKind = (k, label) => v.panels.find((p) => p.kind === k && (label === undefined || p.label === label));
    const top = ['reference', 'noisy'].map((k) => byKind(k)).filter(Boolean);
    grid.append(el('div', { class: 'row-label', text: 'reference and input' }), ...top.map(makePanel));
    for (let i = top.length; i < 3; ++i) grid.append(el('div', { class: 'panel spacer' }));
    const labels = [...new Set(v.panels.filter((p) => p.label).map((p) => p.label))];
    for (const label of labels) {
      grid.append(el('div', { class: 'row-label', text: label }));
      for (const k of ['output', 'flip', 'relerr']) {
        const p = byKind(k, label);
        grid.append(p ? makePanel(p) : el('div', { class: `panel spacer ${k}` }));
      }
    }
    updateImageSources();
    applyZoom();
  }

  function updateImageSources() {
    for (const { panel, img, missing } of viewer.panels) {
      const src = panel.srcs[state.frame];
      img.hidden = !src;
      missing.hidden = !!src;
      if (src) img.src = encodePath(src);
      else img.removeAttribute('src');
    }
  }

  // ---------------------------------------------------------------- (5) regression

  function renderRegression() {
    const body = $('regression-body');
    const R = D.regression;
    if (!R) {
      body.replaceChildren(el('p', { class: 'empty', text: 'No baseline given. `arena report RUN --baseline OTHER_RUN --out DIR` adds the metrics that moved, with the verdicts `arena compare` gives.' }));
      return;
    }
    const counts = {};
    for (const r of R.rows) counts[r.verdict] = (counts[r.verdict] || 0) + 1;
    const filter = el('select', { id: 'regression-filter' },
      el('option', { value: 'moved', text: 'moved beyond tolerance (not ok)' }),
      el('option', { value: 'regressed', text: 'regressed only' }),
      el('option', { value: 'all', text: 'all comparisons' }));
    const tableBox = el('div', { class: 'table-wrap' });
    const order = { regressed: 0, missing: 1, improved: 2, ok: 3 };
    const draw = () => {
      const rows = R.rows.filter((r) => filter.value === 'all' || (filter.value === 'regressed' ? r.verdict === 'regressed' : r.verdict !== 'ok'))
        .sort((a, b) => order[a.verdict] - order[b.verdict] || Math.abs(b.change) - Math.abs(a.change));
      tableBox.replaceChildren(rows.length ? el('table', { class: 'data regression-table' },
        el('thead', {}, el('tr', {}, ['scene', 'denoiser / setting', 'metric', 'baseline', 'candidate', 'change', 'tolerance', 'verdict', 'note']
          .map((t, i) => el('th', { class: i < 3 || i === 8 ? 'first' : null, text: t })))),
        el('tbody', {}, rows.map((r) => el('tr', {},
          el('td', { class: 'first', text: r.scene }), el('td', { class: 'first', text: r.label }), el('td', { class: 'first', text: r.metric }),
          el('td', { text: fmt(r.baseline) }), el('td', { text: fmt(r.candidate) }), el('td', { text: r.note ? '–' : pct(r.change) }),
          el('td', { text: `±${(100 * r.tolerance).toFixed(1)}%` }), el('td', { class: `verdict-${r.verdict}`, text: r.verdict }),
          el('td', { class: 'left', text: r.note || '' })))))
        : el('p', { class: 'empty', text: 'Nothing moved beyond its tolerance.' }));
    };
    filter.addEventListener('change', draw);
    const b = R.baseline;
    body.replaceChildren(
      el('p', {}, `Baseline: ${b.name || '(unnamed)'}${b.created ? ` (${b.created}` : ''}${b.commit ? `, commit ${b.commit})` : b.created ? ')' : ''}. `,
        el('b', { class: R.anyRegression ? 'worse' : 'best', text: R.anyRegression ? '`arena compare` would fail (exit 1).' : '`arena compare` would pass.' })),
      el('p', { class: 'note', text: `Verdicts: ${Object.entries(counts).map(([k, n]) => `${n} ${k}`).join(', ') || 'none'}. A metric regresses when its mean moved in its worse direction by more than its tolerance, relative to the baseline.` }),
      el('div', { class: 'controls' }, el('label', {}, 'Show ', filter)),
      tableBox);
    draw();
  }

  // ---------------------------------------------------------------- (6) PNG export

  function setupPngButtons() {
    // Delegated: ghosting charts come and go with the scene.
    document.addEventListener('click', async (e) => {
      const button = e.target.closest('button.png');
      if (!button) return;
      const view = views[button.dataset.chart];
      if (!view) return;
      const url = await view.toImageURL('png', 2);
      const a = el('a', { href: url, download: `${D.run.name || 'arena'}-${button.dataset.chart}.png` });
      document.body.append(a);
      a.click();
      a.remove();
    });
  }

  // ---------------------------------------------------------------- start-up

  function renderScene() {
    renderScenePurpose();
    renderTables();
    renderImages();
    return Promise.all([renderOverTime(), renderGhosting()]);
  }

  async function main() {
    if (!D) {
      document.querySelector('main').prepend(el('p', { class: 'failures', text: 'data.js is missing: regenerate the report with `arena report`.' }));
      return;
    }
    renderHeader();
    setupSpeed();
    setupOverTime();
    setupImages();
    setupPngButtons();
    renderRegression();
    await Promise.all([renderSpeed(), renderScene()]);
    // The browser test waits for this before counting marks.
    document.body.dataset.ready = 'true';
  }

  // Exposed for the browser test and for poking at in the console.
  window.arenaReport = { state, views, ready: main().catch((err) => {
    console.error(err);
    document.body.dataset.ready = 'error';
  }) };
})();
