// Ghosting: for each scripted event, E_M(t) around it and the lag figures (metrics.md), each with
// its 95% interval; camera cuts with recovery and old-view leak. "Best" marks every method ranked
// first, ties included (statistics.scenes.<scene>.events/cuts, metrics/ghosting_intervals.hpp).
'use strict';

(() => {
  const A = window.Arena;
  const { $, el } = A;

  // `rank`: the figure the run's statistics rank this column on (lower is better).
  const GHOST_COLUMNS = [
    { key: 'lagEnergy', title: 'lag energy', better: 'lower', rank: 'lagEnergy', at: (e) => lagAt(e, 'lagEnergy') },
    { key: 'responseFrames', title: 'response (frames)', better: 'lower', rank: 'responseFrames',
      at: (e) => (e.responseFrames === null && e.response ? 'never settled' : e.responseFrames) },
    { key: 'ghostEnergy', title: 'ghost energy', better: 'lower', rank: 'ghostEnergy' },
    { key: 'peakExcess', title: 'peak excess', better: 'lower', rank: 'peakExcess' },
    { key: 'signedBias', title: 'signed bias', better: 'zero', rank: 'absSignedBias' },
    { key: 'chromaLagEnergy', title: 'chroma lag energy', better: 'lower', rank: 'chromaLagEnergy', at: (e) => lagAt(e, 'chromaLagEnergy') },
    { key: 'steadyState', title: 'E_ss' },
    { key: 'maskFraction', title: 'mask (fraction of pixels)' },
  ];
  // A method still off from an earlier change has no lag figure (metrics.md): said, not shown as 0.
  function lagAt(e, key) {
    return e[key] === null && e.lagAbsent ? 'not settled before' : e[key];
  }
  // The ratios are each method's own jump (÷ its own steady state after the reset): a method
  // without history is near 1 by construction. The absolute error beside them is unranked.
  const CUT_COLUMNS = [
    { key: 'atCut', title: 'at cut (÷ steady)', rank: 'atCut' },
    ...[1, 2, 3, 4, 5].map((k) => ({ key: `recovery${k}`, title: `cut+${k}`, rank: `recovery${k}`, at: (e) => (e.recovery || [])[k - 1] })),
    { key: 'oldViewLeak', title: 'old-view leak', rank: 'oldViewLeak' },
    { key: 'relMseAtCut', title: 'relMSE at cut', at: (e) => (Number.isFinite(e.atCut) && Number.isFinite(e.steadyState) ? e.atCut * e.steadyState : null) },
    { key: 'steadyState', title: 'relMSE steady' },
  ];

  // "[lo, hi]" under a figure; a null bound of the response is "never settled"; no interval: why.
  function ciSpan(e, key) {
    const ci = (e.ci95 || {})[key];
    if (Array.isArray(ci)) {
      const b = (v) => (v === null ? 'never' : A.fmt(v));
      return el('span', { class: 'ci', text: `[${b(ci[0])}, ${b(ci[1])}]` });
    }
    const why = (e.ci95Absent || {})[key];
    return why ? el('span', { class: 'ci', title: why, text: 'no interval' }) : null;
  }

  // The labels ranked first on a figure (ties included), from the run's statistics; null when the
  // run has none (older results: best = the smallest value, ties unknown).
  function firstRanked(kind, frame, figure) {
    const st = ((A.D.rankings || { scenes: {} }).scenes[A.state.scene] || {})[kind] || [];
    const ev = st.find((x) => x.eventFrame === frame);
    const r = ev && ev.byFigure[figure];
    return r ? new Set(r.ranking.filter((m) => m.rank === 1).map((m) => m.label)) : null;
  }

  A.renderGhosting =
      function renderGhosting() {
    const body = $('ghosting-body');
    // Finalize the previous scene's event charts before their containers go.
    for (const name of Object.keys(A.views))
      if (name.startsWith('ghost')) A.dropChart(name);
    body.replaceChildren();
    const scene = A.sceneByName[A.state.scene];
    const pairs = A.pairsOf(A.state.scene).filter(A.isOk);
    const nEvents = Math.max(0, ...pairs.map((p) => (p.ghosting || []).length));
    const nCuts = Math.max(0, ...pairs.map((p) => (p.cuts || []).length));
    if (!scene || nEvents + nCuts === 0) {
      body.append(el('p', { class: 'empty', text: 'This scene has no scripted event (nothing to ghost).' }));
      return Promise.resolve();
    }
    const renders = [];
    for (let k = 0; k < nEvents; ++k) {
      const withEvent = pairs.filter((p) => p.ghosting[k]);
      const g0 = withEvent[0].ghosting[k];
      body.append(el('h3', { text: `Event at frame ${g0.eventFrame}: ${g0.kind} ${g0.what || ''}` }));
      if (g0.absent) {  // nothing changed in the reference: no figure to show (metrics.md)
        body.append(el('p', { class: 'empty', text: `No ghosting figures: ${g0.absent}.` }));
        continue;
      }
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
      const spec = A.baseSpec({
        width: 720,
        height: 200,
        layer: [
          { data: { values: [{ frame: g0.eventFrame }] }, mark: { type: 'rule', color: '#c0392b', strokeDash: [4, 3] }, encoding: { x } },
          { data: { values: rows }, mark: { type: 'line', point: { size: 14 } },
            encoding: { x, y: { field: 'value', type: 'quantitative', title: 'E_M(t) (relMSE in M)', scale: { type: 'log' } },
                        color: { field: 'label', type: 'nominal', scale: A.colorScale, title: 'denoiser / setting' },
                        tooltip: [{ field: 'label' }, { field: 'frame' }, { field: 'value', format: '.4~g' }] } },
        ],
      });
      renders.push(A.embedChart(`ghost${k}`, holder, spec));
      body.append(ghostTable(withEvent, k));
      // The reference between this event and the next too noisy for the goal (referenceQuality.
      // segments; the scene's verdict is under the summary table): said where its figures are.
      const quality = scene.referenceQuality || {};
      const segment = (quality.segments || []).find((s) => s.from === g0.eventFrame);
      if (quality.segmentsMeet === false && segment && segment.ratio > (quality.goal || 0.1))
        body.append(el('p', {
          class: 'note warnings segment-quality',
          text: `The reference's noise in frames ${segment.from}-${segment.to} is ${A.fmt(segment.ratio)} of the best ` +
            `method's error there (goal ${A.fmt(quality.goal || 0.1)}): these figures partly measure the reference, ` +
            'and small differences between methods here are not theirs (the scene\'s verdict is under the summary table).'
        }));
      // Methods still off from an earlier change: no lag figure, and why (their 0 read as best).
      const unsettled = withEvent.filter((p) => p.ghosting[k].lagAbsent);
      if (unsettled.length)
        body.append(el('p', {
          class: 'note lag-absent',
          text: `No lag energy for ${unsettled.map((p) => p.label).join(', ')}: |b_M| before the event was above ` +
            `the settle threshold (${A.fmt(g0.responseThreshold)}): each had not settled from an earlier change, so its ` +
            'lag after this one cannot be told from that (metrics.md).'
        }));
      // Methods that never settled in the window: their E_ss is a median of frames still lagging,
      // so their peak excess and ghost energy are measured from a raised baseline and read low.
      const neverSettled = withEvent.filter((p) => p.ghosting[k].settled === false && Number.isFinite(p.ghosting[k].steadyState));
      if (neverSettled.length)
        body.append(el('p', {
          class: 'note never-settled',
          text: `${neverSettled.map((p) => p.label).join(', ')} never settled within the window: E_ss is then the median of ` +
            'frames still lagging, not a steady state, so their peak excess and ghost energy are measured from a raised ' +
            'baseline and read low (lower bounds, metrics.md).'
        }));
      // Too few frames after the event for a steady state (metrics.md, clipped windows): said here,
      // not only in the cells' tooltips.
      if (g0.steadyAbsent)
        body.append(el('p', {
          class: 'note steady-absent',
          text: `No E_ss, peak excess or ghost energy: ${g0.steadyAbsent}.`
        }));
    }
    for (let k = 0; k < nCuts; ++k) {
      const withCut = pairs.filter((p) => p.cuts && p.cuts[k]);
      const frame = withCut[0].cuts[k].eventFrame;
      body.append(el('h3', { text: `Camera cut at frame ${frame}: relMSE ÷ steady state after the reset, and the old view's leak` }));
      body.append(figureTable(
          'cut-table', CUT_COLUMNS, withCut.map((p) => [p.label, p.cuts[k]]),
          rankedFirst(CUT_COLUMNS, 'cuts', frame)));
      body.append(el('p', {
        class: 'note cut-ratios',
        text: 'Lower is better in every column. "at cut" and "cut+k" divide each method\'s relMSE by its own ' +
          'steady state after the reset: they rank the jump, not the error, and a method without history ' +
          '(passthrough) is near 1 by construction. The last two columns are the absolute relMSE at the cut ' +
          'and in the steady state (not ranked here; the scene ranking ranks the error).'
      }));
      // The references did not change at the cut (metrics.md): no leak to show, and why.
      const leakAbsent = withCut[0].cuts[k].oldViewLeakAbsent;
      if (leakAbsent) body.append(el('p', { class: 'note leak-absent', text: `No old-view leak: ${leakAbsent}.` }));
    }
    return Promise.all(renders);
  }

  const valueOf = (c, e) => (c.at ? c.at(e) : e[c.key]);

  // `first`: column key -> the labels marked best in it (absent: none marked). A method that keeps
  // no history (pairs[].keepsHistory false: passthrough, the noisy input, and a spatial filter such
  // as eaw) is never marked: it has no lag and no jump by construction, which is no finding about
  // its denoising; a note names the columns where such a method ranked first.
  function figureTable(cls, columns, rows, first) {
    const stateless = new Set(A.pairsOf(A.state.scene).filter((p) => p.keepsHistory === false).map((p) => p.label));
    const unmarked = new Map();  // label -> the columns it ranked first on
    for (const c of columns)
      for (const label of first[c.key] || [])
        if (stateless.has(label)) unmarked.set(label, [...(unmarked.get(label) || []), c.title]);
    const table = el('table', { class: `data ${cls}` },
      el('thead', {}, el('tr', {}, el('th', { class: 'first', text: 'denoiser / setting' }), columns.map((c) => el('th', { text: c.title })))),
      el('tbody', {}, rows.map(([label, e]) => el('tr', { 'data-label': label }, el('td', { class: 'first', text: label }),
        columns.map((c) => el('td', { class: !stateless.has(label) && first[c.key] && first[c.key].has(label) ? 'best' : null }, A.fmt(valueOf(c, e)), ciSpan(e, c.key)))))));
    // Why cells have no interval, said once when one reason covers them all (a changed region too
    // small to resample left every cell of moving_light_shadow's table "no interval", the reason
    // only in each cell's tooltip).
    const reasons = new Set();
    for (const [, e] of rows)
      for (const c of columns)
        if (!Array.isArray((e.ci95 || {})[c.key]) && (e.ci95Absent || {})[c.key]) reasons.add(e.ci95Absent[c.key]);
    const noInterval = reasons.size === 1
      ? [el('p', { class: 'note no-interval', text: `No interval in the cells marked so: ${[...reasons][0]}.` })] : [];
    if (!unmarked.size) return el('div', { class: 'table-wrap' }, table, ...noInterval);
    const names = [...unmarked.keys()];
    return el('div', { class: 'table-wrap' }, table, ...noInterval, el('p', {
      class: 'note input-unmarked',
      text: `Not marked, though ranked first: ${names.map((l) => `${l} on ${unmarked.get(l).join(', ')}`).join('; ')}. ` +
        `${names.length > 1 ? 'They keep' : 'It keeps'} no history between frames, so ${names.length > 1 ? 'they have' : 'it has'} ` +
        'no lag and no jump by construction; the error is in E_ss or relMSE here and in the scene ranking.'
    }));
  }

  // The statistics' rank-1 labels of every ranked column of one event or cut.
  function rankedFirst(columns, kind, frame) {
    const first = {};
    for (const c of columns) if (c.rank) first[c.key] = firstRanked(kind, frame, c.rank);
    return first;
  }

  function ghostTable(pairs, k) {
    const frame = pairs[0].ghosting[k].eventFrame;
    const rows = pairs.map((p) => [p.label, p.ghosting[k]]);
    if (pairs.some((p) => p.ghosting[k].ci95) || firstRanked('events', frame, 'lagEnergy'))
      return figureTable('ghost-table', GHOST_COLUMNS, rows, rankedFirst(GHOST_COLUMNS, 'events', frame));
    // An older run without intervals or rankings: the smallest value is marked, ties unknown.
    const first = {};
    for (const c of GHOST_COLUMNS) {
      if (!c.better) continue;
      const score = (e) => (c.better === 'zero' ? Math.abs(e[c.key]) : e[c.key]);
      const finite = rows.filter(([, e]) => Number.isFinite(e[c.key]));
      if (!finite.length) continue;
      const best = Math.min(...finite.map(([, e]) => score(e)));
      first[c.key] = new Set(finite.filter(([, e]) => score(e) === best).map(([label]) => label));
    }
    return el('div', { class: 'table-wrap' },
      el('p', { class: 'note', text: 'This run has no intervals for its events (older results): bold green marks the smallest value, ties unknown.' }),
      figureTable('ghost-table', GHOST_COLUMNS, rows, first));
  }
})();
