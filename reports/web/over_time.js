// Over time: per-frame error and flicker of every pair on the selected scene, with the warm-up
// band, the scene's events and (relMSE) the reference's noise floor. The selected denoiser (a click
// on the speed chart) is drawn on top, the others faded.
'use strict';

(() => {
  const A = window.Arena;
  const { $, el } = A;
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
  const present = (axes) => axes.filter((a) => A.D.pairs.some((p) => p.series && p.series[a.source]));

  A.setupOverTime = function setupOverTime() {
    const errSel = $('time-error-metric');
    for (const a of present(TIME_ERROR)) errSel.append(el('option', { value: a.key, text: a.title }));
    const flSel = $('time-flicker-metric');
    for (const a of present(TIME_FLICKER)) flSel.append(el('option', { value: a.key, text: a.title }));
    errSel.addEventListener('change', A.renderOverTime);
    flSel.addEventListener('change', A.renderOverTime);
    $('time-log').addEventListener('change', A.renderOverTime);
  }

  // Layers shared by the per-frame charts: the warm-up band and one rule per scene event.
  function frameContextLayers(scene, x) {
    const layers = [];
    if (A.D.run.warmup > 0) {
      layers.push({ data: { values: [{ from: 0, to: Math.min(A.D.run.warmup, scene.frames - 1) }] },
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

  // A per-frame series of an axis (1 - SSIM from SSIM).
  function axisSeries(pair, axis) {
    const col = pair.series && pair.series[axis.source];
    if (!col) return null;
    return axis.complement ? col.map((v) => (v === null ? null : 1 - v)) : col;
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
    const pairs = A.pairsOf(scene.name).filter(A.isOk);
    const rows = frameSeriesRows(pairs, axis, log);
    if (!rows.length) {
      A.dropChart(name);
      container.replaceChildren(el('p', { class: 'empty', text: `No ${axis.title} per frame for this scene.` }));
      return Promise.resolve();
    }
    const x = { type: 'quantitative', title: 'frame', scale: { domain: [0, Math.max(1, scene.frames - 1)], nice: false } };
    const selected = A.state.selected && pairs.some((p) => p.label === A.state.selected) ? A.state.selected : null;
    const spec = A.baseSpec({
      width: 720,
      height: 230,
      layer: [
        ...frameContextLayers(scene, x),
        { data: { values: rows }, mark: { type: 'line', point: rows.length < 1500 ? { size: 14 } : false, strokeWidth: 1.5 },
          encoding: {
            x: { ...x, field: 'frame' },
            y: { field: 'value', type: 'quantitative', title: axis.title, scale: log ? { type: 'log' } : { zero: false } },
            color: { field: 'label', type: 'nominal', scale: A.colorScale, title: 'denoiser / setting' },
            // The selected denoiser (clicked on the speed chart) stands out; the others fade.
            opacity: selected ? { condition: { test: A.equalsTest('label', selected), value: 1 }, value: 0.2 } : { value: 1 },
            strokeWidth: selected ? { condition: { test: A.equalsTest('label', selected), value: 3 }, value: 1.2 } : { value: 1.5 },
            tooltip: [{ field: 'label' }, { field: 'frame' }, { field: 'value', title: axis.title, format: '.4~g' }],
          } },
        ...(extraLayers || []),
      ],
    });
    return A.embedChart(name, container, spec);
  }

  A.renderOverTime = function renderOverTime() {
    const scene = A.sceneByName[A.state.scene];
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
})();
