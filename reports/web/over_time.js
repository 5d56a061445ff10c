// Over time: per-frame error and flicker of every pair on the selected scene, with the warm-up
// band, the scene's events and (relMSE) the reference's noise floor. The selected denoiser (a click
// on the speed chart) is drawn on top, the others faded.
'use strict';

(() => {
  const A = window.Arena;
  const { $, el } = A;
  // The axes of the two charts: the metrics the registry offers to each (catalogue field `chart`),
  // in its order, that some pair of the run has per frame.
  const axesOf = (chart) => A.D.metrics
    .filter((m) => m.chart === chart && A.D.pairs.some((p) => p.series && p.series[m.name]))
    .map((m) => ({ key: m.name, title: m.title || m.name, source: m.name, lowerIsBetter: m.lowerIsBetter }));

  A.setupOverTime = function setupOverTime() {
    const errSel = $('time-error-metric');
    for (const a of axesOf('error')) errSel.append(el('option', { value: a.key, text: a.title }));
    const flSel = $('time-flicker-metric');
    for (const a of axesOf('temporal')) flSel.append(el('option', { value: a.key, text: a.title }));
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

  // A per-frame series of an axis.
  function axisSeries(pair, axis) {
    return (pair.series && pair.series[axis.source]) || null;
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
    const errAxes = axesOf('error'), flAxes = axesOf('temporal');
    const errAxis = errAxes.find((a) => a.key === $('time-error-metric').value) || errAxes[0];
    const flAxis = flAxes.find((a) => a.key === $('time-flicker-metric').value) || flAxes[0];
    const none = (id) => {
      $(id).replaceChildren(el('p', { class: 'empty', text: 'No per-frame metric of this kind in this run.' }));
      return Promise.resolve();
    };
    // A log axis for errors (lower is better); a dB axis (PSNR) stays linear.
    const log = $('time-log').checked && errAxis && errAxis.lowerIsBetter;
    // The reference's own noise floor belongs next to raw relMSE (metrics.md: reference quality):
    // per frame, since a scene's references differ (light_switch's dark segment has its own, as
    // noisy relative to the methods' error as the lit one or not); the mean where a run lacks them.
    const floor = [];
    const perFrame = errAxis && errAxis.key === 'relMse' && Array.isArray(scene.referenceRelMse)
      ? scene.referenceRelMse.map((v, i) => ({ frame: i, value: v })).filter((r) => Number.isFinite(r.value) && r.value > 0)
      : [];
    if (perFrame.length) {
      // Drawn as steps (one rule per frame, to the next): a line mark would read as a method's.
      const steps = perFrame.map((r) => ({ ...r, next: r.frame + 1 < scene.frames ? r.frame + 1 : r.frame }));
      floor.push({ data: { values: steps }, mark: { type: 'rule', color: '#777', strokeDash: [2, 2], strokeWidth: 1.2 },
                   encoding: { x: { field: 'frame', type: 'quantitative' }, x2: { field: 'next' }, y: { field: 'value', type: 'quantitative' },
                               tooltip: [{ field: 'frame' }, { field: 'value', title: 'reference noise floor', format: '.4~g' }] } });
      floor.push({ data: { values: [{ ...perFrame[perFrame.length - 1], text: 'reference noise floor (per frame)' }] },
                   mark: { type: 'text', color: '#777', align: 'right', baseline: 'bottom', dy: -2, fontSize: 11 },
                   encoding: { x: { field: 'frame', type: 'quantitative' }, y: { field: 'value', type: 'quantitative' }, text: { field: 'text' } } });
    } else if (errAxis && errAxis.key === 'relMse' && scene.noiseFloor) {
      const f = [{ value: scene.noiseFloor.mean, text: 'reference noise floor' }];
      floor.push({ data: { values: f }, mark: { type: 'rule', color: '#777', strokeDash: [2, 2] },
                   encoding: { y: { field: 'value', type: 'quantitative' } } });
      floor.push({ data: { values: f }, mark: { type: 'text', color: '#777', align: 'right', baseline: 'bottom', x: 'width', dy: -2, fontSize: 11 },
                   encoding: { y: { field: 'value', type: 'quantitative' }, text: { field: 'text' } } });
    }
    return Promise.all([
      errAxis ? timeChart('timeError', $('time-error-chart'), scene, errAxis, log, floor) : none('time-error-chart'),
      flAxis ? timeChart('timeFlicker', $('time-flicker-chart'), scene, flAxis, false, []) : none('time-flicker-chart'),
    ]);
  }
})();
