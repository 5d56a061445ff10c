// Speed vs accuracy: one chart (a scene, or all scenes through the per-scene normalised
// aggregate) or small multiples (one panel per scene). The time axis is one of the run's clocks
// (D.speed.clocks): the CPU time measured here (the default), the GPU ms the cost model predicts at
// 1080p on a named device, or the GPU time a capture recorded; each has its own Pareto front. Error bars: the metric's 95% interval when
// the run has one (else p5-p95 over frames); time bars: p5-p95 of the per-frame time. Hover shows
// a point's parameters; clicking it selects that denoiser in the image viewer and over-time charts.
'use strict';

(() => {
  const A = window.Arena;
  const { $, el } = A;

  A.setupSpeed = function setupSpeed() {
    const { D, state } = A;
    const sceneSel = $('speed-scene');
    sceneSel.append(el('option', { value: '__all__', text: 'all scenes (normalised)' }));
    for (const s of D.scenes) sceneSel.append(el('option', { value: s.name, text: s.name }));
    sceneSel.value = state.speedScene;
    sceneSel.addEventListener('change', () => {
      state.speedScene = sceneSel.value;
      A.renderSpeed();
    });
    const metricSel = $('speed-metric');
    for (const a of D.errorAxes) metricSel.append(el('option', { value: a.key, text: a.title }));
    metricSel.value = state.speedAxis;
    metricSel.addEventListener('change', () => {
      state.speedAxis = metricSel.value;
      A.renderSpeed();
    });
    const clockSel = $('speed-clock');
    for (const c of D.speed.clocks) clockSel.append(el('option', { value: c.key, text: c.title }));
    clockSel.value = state.speedClock;
    clockSel.addEventListener('change', () => {
      state.speedClock = clockSel.value;
      A.renderSpeed();
    });
    $('speed-log').addEventListener('change', () => A.renderSpeed());
    $('speed-layout').addEventListener('change', () => A.renderSpeed());
  };

  // The points of a scope, ready to draw: a log axis cannot show 0 ms or a zero error, so such
  // points are listed under the chart instead.
  function drawable(data, logError) {
    const points = data.points.map((p) => ({
      ...p,
      complete: p.complete !== false,
      onFront: data.front.includes(p.label),
      selected: p.label === A.state.selected,
      paramText: Object.keys(p.params || {}).length ? Object.entries(p.params).map(([k, v]) => `${k}=${JSON.stringify(v)}`).join(', ') : '(defaults)',
      // Methods that read paths beyond the frame's own (issue 34), or oracle data, are marked
      // wherever they are named.
      name: p.label + (p.extraPaths ? ' (+paths)' : '') + ((p.oracleLayers || []).length ? ' (oracle)' : ''),
      msLo: p.msLo ?? null,
      msHi: p.msHi ?? null,
    }));
    const ok = (p) => p.ms > 0 && (!logError || p.error > 0);
    const drawn = points.filter(ok);
    // Bars may reach 0 on a log axis (an interval that includes 0): clip them to the smallest point.
    if (logError) {
      const floor = Math.min(...drawn.map((p) => p.error)) / 10;
      for (const p of drawn) p.lo = Math.max(p.lo ?? p.error, floor);
    }
    const front = data.front.map((l) => drawn.find((p) => p.label === l)).filter(Boolean).sort((a, b) => a.ms - b.ms);
    // The equal-paths front: a method's cost includes its extra paths' tracing time.
    const frontEqualPaths = (data.frontEqualPaths || []).map((l) => drawn.find((p) => p.label === l)).filter(Boolean)
      .map((p) => ({ ...p, ms: p.ms + (p.tracingMs || 0) })).sort((a, b) => a.ms - b.ms);
    return { drawn, front, frontEqualPaths, hidden: points.filter((p) => !ok(p)).map((p) => p.label) };
  }

  const clockView = () => A.D.speed.views[A.state.speedClock];
  const clock = () => A.D.speed.clocks.find((c) => c.key === A.state.speedClock);
  const isGpuModel = () => A.state.speedClock.startsWith('gpu:');

  // Contenders with no time on this axis (a capture's recorded GPU time on the CPU axis, a denoiser
  // with no counted traffic on a predicted one): named with their clock, never placed on it.
  function otherClocks(scene) {
    const rows = (clockView().otherClocks || []).filter((r) => scene === null || r.scene === scene);
    if (!rows.length) return [];
    const one = (r) => (r.ms === null ? 'no time' : `${Number(r.ms).toPrecision(3)} ms`);
    if (scene !== null)
      return [` · timed on another clock, not on this axis: ${rows.map((r) => `${r.label}: ${one(r)} (${r.source})`).join('; ')}`];
    // All scenes: a contender with the same reason on several scenes is named once, with how many
    // and the range of its times (passthrough on every scene read as twelve sentences).
    const groups = new Map();
    for (const r of rows) {
      const key = `${r.label}\u0000${r.source}`;
      if (!groups.has(key)) groups.set(key, { label: r.label, source: r.source, rows: [] });
      groups.get(key).rows.push(r);
    }
    const text = [...groups.values()].map((g) => {
      if (g.rows.length === 1) return `${g.label} on ${g.rows[0].scene}: ${one(g.rows[0])} (${g.source})`;
      const ms = g.rows.map((r) => r.ms).filter((v) => v !== null).map(Number);
      const range = !ms.length ? 'no time'
        : Math.min(...ms) === Math.max(...ms) ? `${Math.min(...ms).toPrecision(3)} ms`
          : `${Math.min(...ms).toPrecision(3)}–${Math.max(...ms).toPrecision(3)} ms`;
      return `${g.label} on ${g.rows.length} scenes: ${range} (${g.source})`;
    });
    return [` · timed on another clock, not on this axis: ${text.join('; ')}`];
  }

  // `all`: the all-scenes chart, whose times are means over scenes of each scene's median.
  function chartSpec({ drawn, front, frontEqualPaths }, axis, yTitle, logError, small, title, all = false) {
    const unit = A.state.speedClock === 'cpu' ? 'CPU ms' : isGpuModel() ? 'predicted GPU ms' : 'captured GPU ms';
    const x = { field: 'ms', type: 'quantitative', scale: { type: 'log' },
                title: small ? `${unit} (median)` : all
                  ? `${unit} per frame (mean over scenes of each scene's median; bars: means of p5 and p95; log scale)`
                  : `${unit} per frame (median; bars p5–p95; log scale)` };
    const y = { field: 'error', type: 'quantitative', title: yTitle, scale: logError ? { type: 'log' } : { zero: false } };
    const color = { field: 'label', type: 'nominal', scale: A.colorScale, title: 'denoiser / setting', legend: small ? null : {} };
    const tooltip = [
      { field: 'label', title: 'label' },
      { field: 'paramText', title: 'parameters' },
      { field: 'ms', title: 'ms (median)', format: '.3~g' },
      { field: 'msLo', title: 'ms p5', format: '.3~g' },
      { field: 'msHi', title: 'ms p95', format: '.3~g' },
      { field: 'error', title: yTitle, format: '.4~g' },
      { field: 'lo', title: 'bar low', format: '.4~g' },
      { field: 'hi', title: 'bar high', format: '.4~g' },
    ].concat(drawn.some((p) => p.scenes !== undefined) ? [{ field: 'scenes', title: 'scenes' }] : [])
      .concat(drawn.some((p) => p.tracingMs !== undefined)
        ? [{ field: 'extraRaysPerPixel', title: 'extra rays / pixel / frame', format: '.3~g' },
          { field: 'tracingMs', title: 'their tracing, ms (equivalent)', format: '.3~g' }] : []);
    const withTime = drawn.filter((p) => p.msLo !== null && p.msHi !== null);
    // Extra rays a denoiser asked for (disocclusion rays): a separate dashed bar from its own time
    // to its time plus their equivalent tracing time, labelled, so the point stays the denoiser's.
    const traced = drawn.filter((p) => p.tracingMs > 0).map((p) => ({ ...p, msTraced: p.ms + p.tracingMs }));
    return A.baseSpec({
      width: small ? 300 : 760,
      height: small ? 200 : 400,
      title: title ? { text: title, fontSize: small ? 12 : 13, anchor: 'start' } : undefined,
      data: { values: drawn },
      layer: [
        { name: 'errorbars', mark: { type: 'rule', strokeWidth: 1.5 },
          encoding: { x, y: { field: 'lo', type: 'quantitative' }, y2: { field: 'hi' }, color } },
        { name: 'timebars', data: { values: withTime }, mark: { type: 'rule', strokeWidth: 1.5, opacity: 0.6 },
          encoding: { x: { ...x, field: 'msLo' }, x2: { field: 'msHi' }, y, color } },
        { name: 'tracing', data: { values: traced }, mark: { type: 'rule', strokeWidth: 3, strokeDash: [2, 2], opacity: 0.8 },
          encoding: { x, x2: { field: 'msTraced' }, y, color, tooltip } },
        { name: 'tracing-label', data: { values: traced }, mark: { type: 'text', align: 'left', dx: 4, dy: 10, fontSize: small ? 9 : 10, color: '#1d2330' },
          encoding: { x: { ...x, field: 'msTraced' }, y, text: { value: '+ extra rays (tracing)' } } },
        { name: 'front', data: { values: front }, mark: { type: 'line', color: '#555', strokeDash: [5, 3], strokeWidth: 1.5 },
          encoding: { x, y, order: { field: 'ms', type: 'quantitative' } } },
        { name: 'front-equal-paths', data: { values: traced.length ? frontEqualPaths : [] },
          mark: { type: 'line', color: '#b5651d', strokeDash: [1, 3], strokeWidth: 1.5 },
          encoding: { x, y, order: { field: 'ms', type: 'quantitative' } } },
        { name: 'points', mark: { type: 'point', filled: true, size: small ? 70 : 110, strokeWidth: 2, cursor: 'pointer' },
          // A shape beside the colour: methods that cluster (the study's 8-25 ms CPU group) are told
          // apart without hovering, where pastel colours alone were not.
          encoding: { x, y, tooltip, color,
                      shape: { field: 'label', type: 'nominal', scale: { domain: A.colorScale.domain }, title: 'denoiser / setting', legend: small ? null : {} },
                      fillOpacity: { condition: { test: 'datum.complete', value: 1 }, value: 0 },
                      strokeWidth: { condition: { test: 'datum.selected', value: 4 }, value: 2 } } },
        // The front's members are named on the chart; the others by the legend and the tooltip
        // (naming every point would pile labels up where settings cluster, as in sweeps).
        { name: 'names', transform: [{ filter: 'datum.onFront || datum.selected' }],
          mark: { type: 'text', align: 'left', dx: 8, dy: -8, fontSize: small ? 10 : 11, fontWeight: 'bold', color: '#1d2330' },
          encoding: { x, y, text: { field: 'name' } } },
      ],
    });
  }

  // Clicking a point selects its denoiser everywhere (images, over time); its scene too when the
  // point belongs to one.
  function onClick(view, scene) {
    if (!view) return;
    view.addEventListener('click', (event, item) => {
      const datum = item && item.datum;
      // Deferred: selecting re-renders this very chart, which must not be finalized inside its handler.
      if (datum && typeof datum.label === 'string' && datum.error !== undefined) setTimeout(() => A.select(datum.label, scene), 0);
    });
  }

  const noteFor = (all, data, axis, logError) => {
    const bars = all
      ? (data.source === 'statistics'
        ? 'Bars: the run\'s 95% interval of the overall score.'
        : 'Bars: the same normalisation applied to each scene\'s interval ends (wider than the aggregate\'s own interval).')
      : (data.points.some((p) => p.interval === 'ci95') ? 'Error bars: 95% interval of the mean (block bootstrap).' : 'Error bars: p5–p95 across frames after warm-up (this run has no intervals).');
    const traced = data.points.some((p) => p.tracingMs > 0)
      ? 'Dashed bars: a denoiser\'s extra paths ("+paths": reengine\'s low-resolution disocclusion rays, asvgf\'s re-shaded gradient samples), as the time the tracer took to trace them when the sequence was rendered, added to its own time; the point and the grey Pareto front use the denoiser\'s time alone, the dotted brown front (equal paths) its time plus that tracing time. '
      : '';
    const model = isGpuModel()
      ? 'Time axis: a prediction, not a measurement -- each pass\'s counted GPU traffic at 1920x1080 priced by the cost model (docs/gpu-cost.md), which misses its validation goal: read it as an order of magnitude and an order of methods; extra paths are not priced. ' +
          (A.D.speed.gpuSkipped || '')
      : '';
    return `${model}${bars} Time bars: p5–p95 of the per-frame time where the run records them. ${traced}` +
      `${logError ? 'Log error axis. ' : ''}${axis && axis.key === 'relMse' ? 'relMSE raw (not reference-corrected). ' : ''}` +
      'Hover a point for its parameters; click it to select that denoiser in Images and Over time.';
  };

  A.renderSpeed = async function renderSpeed() {
    const { D, state } = A;
    const axis = D.errorAxes.find((a) => a.key === state.speedAxis);
    const logError = $('speed-log').checked;
    const multiples = $('speed-layout').value === 'multiples';
    const chart = $('speed-chart');
    $('speed-scene').disabled = multiples;
    for (const name of Object.keys(A.views)) if (name.startsWith('speed')) A.dropChart(name);
    chart.replaceChildren();
    chart.classList.toggle('multiples', multiples);
    if (!axis) {
      chart.append(el('p', { class: 'empty', text: 'No error metric was measured.' }));
      return;
    }
    if (multiples) {
      const allPoints = D.scenes.flatMap(
          (s) => (((clockView().scenes[s.name] || {})[state.speedAxis]) || {points: []}).points);
      $('speed-note').textContent = noteFor(false, {points: allPoints}, axis, logError) +
          ' One panel per scene, each on its own scale.';
      const renders = [];
      for (const s of D.scenes) {
        const data = (clockView().scenes[s.name] || {})[state.speedAxis];
        const holder = el('div', { class: 'multiple', 'data-scene': s.name });
        chart.append(holder);
        if (!data || !data.points.length) {
          holder.append(el('p', { class: 'empty', text: `${s.name}: no measured pair.` }));
          continue;
        }
        const d = drawable(data, logError);
        renders.push(A.embedChart(`speed:${s.name}`, holder, chartSpec(d, axis, axis.title, logError, true, s.name)).then((v) => onClick(v, s.name)));
      }
      $('speed-front').textContent =
          'Dashed: each scene\'s Pareto front of the means (a step along it need not be resolved: the rankings say which differences are).';
      await Promise.all(renders);
      return;
    }
    const all = state.speedScene === '__all__';
    const data = (all ? clockView().all : clockView().scenes[state.speedScene] || {})[state.speedAxis];
    if (!data || !data.points.length) {
      chart.append(el('p', { class: 'empty', text: 'No measured pair for this choice.' }));
      $('speed-front').textContent = '';
      $('speed-note').textContent = '';
      return;
    }
    $('speed-note').textContent = noteFor(all, data, axis, logError) +
      (all ? ' Hollow points did not complete every scene and are kept off the front.' : '');
    const d = drawable(data, logError);
    // The aggregate is named on the chart itself, not only in the note.
    const yTitle = !all ? axis.title : data.source === 'statistics' ? `${axis.title}: overall score (see title)`
      : `${axis.title} ÷ ${data.baseline} (geo. mean over ${data.sceneCount} scenes)`;
    const title = (all ? `All scenes: ${data.normalisation}` : `${state.speedScene}: ${axis.title}`) +
      (state.speedClock === 'cpu' ? '' : ` · ${clock().title}`);
    // The order of the methods by time on this axis (does it change between clocks?).
    // On a model's axis, a time less than its orderTolerance above the first (fastest) of its group
    // is not ordered by it (≈), as the study's summary and `arena bench gpu-model` print it.
    const tolerance = clock().orderTolerance || 0;
    let groupStart = 0;
    const order = [...d.drawn].sort((a, b) => a.ms - b.ms).map((p, i) => {
      const joins = i > 0 && tolerance > 0 && p.ms < groupStart * (1 + tolerance);
      if (!joins) groupStart = p.ms;
      return (i === 0 ? '' : joins ? ' ≈ ' : ' < ') + p.label;
    }).join('');
    $('speed-front')
        .replaceChildren(
            'Pareto front of the means (fastest first; a step along it need not be resolved: the rankings say which differences are): ',
            ...d.front.flatMap((p, i) => [i ? ' → ' : '', el('b', {text: p.name})]),
            d.frontEqualPaths.length && d.drawn.some((p) => p.extraPaths) ?
                (isGpuModel() ?
                     ' · without the methods that read extra paths (the model prices no tracing): ' :
                     ' · equal paths (extra paths\' tracing counted): ') +
                    d.frontEqualPaths.map((p) => p.name).join(' → ') :
                '',
            d.hidden.length ? ` · not drawn (0 on a log axis): ${d.hidden.join(', ')}` : '',
            ` · by time on this axis (medians, no interval${tolerance > 0 ? `; ≈: less than ${Math.round(tolerance * 100)}% above the first of its group, which the model does not order` : ''}): ${order}`,
            ...otherClocks(all ? null : state.speedScene),
        );
    const view = await A.embedChart('speed', chart, chartSpec(d, axis, yTitle, logError, false, title, all));
    onClick(view, all ? null : state.speedScene);
  };
})();
