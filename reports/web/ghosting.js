// Ghosting: for each scripted event, E_M(t) around it and the lag figures (metrics.md).
'use strict';

(() => {
  const A = window.Arena;
  const { $, el, fmt } = A;

  const GHOST_COLUMNS = [
    { key: 'responseFrames', title: 'response (frames)', better: 'lower' },
    { key: 'ghostEnergy', title: 'ghost energy', better: 'lower' },
    { key: 'peakExcess', title: 'peak excess', better: 'lower' },
    { key: 'signedBias', title: 'signed bias', better: 'zero' },
    { key: 'steadyState', title: 'E_ss', better: 'lower' },
    { key: 'maskFraction', title: 'mask (fraction of pixels)' },
  ];

  A.renderGhosting = function renderGhosting() {
    const body = $('ghosting-body');
    // Finalize the previous scene's event charts before their containers go.
    for (const name of Object.keys(A.views)) if (name.startsWith('ghost')) A.dropChart(name);
    body.replaceChildren();
    const scene = A.sceneByName[A.state.scene];
    const pairs = A.pairsOf(A.state.scene).filter(A.isOk);
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
})();
