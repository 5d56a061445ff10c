// Regression dashboard (`arena history`): for a chosen scene and denoiser, each metric and the
// time against commit, with the tolerance band and the runs `arena compare` flags; and the list of
// every flag. Data: window.ARENA_HISTORY (reports/history.cpp).
'use strict';

(() => {
  const A = window.Arena;
  const { $, el, fmt, pct } = A;
  const H = window.ARENA_HISTORY;
  const state = { scene: null, label: null };

  // A run names the revision it measured (`arena run --revision`) where it has one, arena's own
  // commit beside it.
  const runText = (i) => {
    const r = H.runs[i];
    const built = r.commit || '(no commit)';
    return `#${i} ${r.revision ? `${r.revision} (arena ${built})` : built}${r.created ? ` · ${r.created}` : ''}`;
  };
  // Comparisons that fail the gate (compare's own rule, decided in reports/history.cpp), and the
  // other verdicts worth seeing (beyond tolerance but unresolved, improved, ...).
  const flags = H.changes.filter((c) => c.fails);
  const appliesTo = (c, metric) => c.metric === metric || c.metric === '*';
  // A flag about a whole run (scene '*': runs under other settings, not comparable) marks every
  // series of that run.
  const concerns = (c) =>
      (c.scene === '*' || c.scene === state.scene) && (c.label === '*' || c.label === state.label);

  // Changes beyond the tolerance that the gate could not judge (runs read from results.db keep no
  // tiles): neither a failure nor a pass, listed apart.
  // Changes the gate could not judge (runs read from results.db keep no tiles; an event's figure
  // no interval can judge): only those in the worse direction could fail it, and only those are
  // listed to check by hand.
  const lowerIsBetter = Object.fromEntries((H.metrics || []).map((m) => [m.name, m.lowerIsBetter]));
  // A change of unknown size (none given: runs read from results.db that summarise other frames,
  // or keep no pair's events) may be worse.
  const worse = (c) => c.change == null || (lowerIsBetter[c.metric] === false ? -c.change : c.change) > 0;
  const notJudged = H.changes.filter((c) => c.verdict === 'not judged' && worse(c));
  const others = H.changes.length - flags.length - notJudged.length;

  function renderInfo() {
    const n = H.runs.length;
    const comparisons = H.comparisons ?? Math.max(0, n - 1);
    const failing = H.failingComparisons ?? new Set(flags.map((f) => f.run)).size;
    $('history-info').textContent = n === 1
      ? `One run, ${runText(0)}: nothing to compare it with yet (a history judges each run against the one before).`
      : n
      ? `${n} runs, ${runText(0)} → ${runText(n - 1)} · ${failing} of ${comparisons} comparison(s) fail the gate (${flags.length} row(s))` +
        (notJudged.length ? `, ${notJudged.length} change(s) beyond the tolerance not judged` : '') +
        `, ${others} other change(s) (improvements, changes within noise, new pairs)` +
        // With --denoisers, the comparisons before the contenders named existed are not made.
        (H.notMadeBeforeContenders ? ` · ${H.notMadeBeforeContenders} comparison(s) not made: the earlier run has none of the contenders named with --denoisers` : '')
      : 'No runs.';
    // How the rows were judged: the gate's own options (arena compare --correction, --confidence).
    if (H.correction)
      $('history-judged').textContent =
        `Rows judged as \`arena compare --confidence ${fmt(100 * H.confidence)}% --correction ${H.correction}\`: ` +
        'a change is a regression when it is worse by more than the tolerance and the paired interval of the change excludes zero' +
        (H.correction === 'holm'
          ? ', and it stays resolved among all the rows of its comparison judged together (Holm\'s step-down correction: with many rows, some would be resolved by noise alone).'
          : ' (each row alone, no correction for the many rows of a comparison).');
    // What the verdicts rest on besides their rows, as `arena compare` warns of it (runs compared
    // across other settings, other references, ...): each said once.
    $('history-warnings').replaceChildren(...(H.warnings || []).map((w) => el('li', { text: w })));
  }

  function changeTable(rows, cls) {
    return el('table', { class: `data ${cls}` },
      el('thead', {}, el('tr', {}, ['run', 'commit', 'scene', 'denoiser / setting', 'metric', 'previous', 'this run', 'change', 'interval', 'tolerance', 'verdict', 'note']
        .map((t, i) => el('th', { class: i < 5 || i > 9 ? 'first' : null, text: t })))),
      el('tbody', {}, rows.map((f) => {
        const tr = el('tr', { class: 'flag', 'data-run': String(f.run), 'data-scene': f.scene, 'data-label': f.label, 'data-metric': f.metric },
          el('td', { class: 'first', text: `#${f.run}` }), el('td', { class: 'first', text: H.runs[f.run].revision || H.runs[f.run].commit || '–' }),
          el('td', { class: 'first', text: f.scene }), el('td', { class: 'first', text: f.matchedByRequest ? `${f.pairLabel} → ${f.candidateLabel}` : f.pairLabel || f.label }), el('td', { class: 'first', text: f.metric }),
          el('td', { text: fmt(f.baseline) }), el('td', { text: fmt(f.candidate) }), el('td', { class: f.fails ? 'verdict-regressed' : null, text: pct(f.change) }),
          // The paired interval of the change, as compare prints it (none: no tiles to resample).
          el('td', { text: Array.isArray(f.changeCi95) ? `[${pct(f.changeCi95[0])}, ${pct(f.changeCi95[1])}]` : '–' }),
          el('td', { text: f.tolerance === null ? '–' : `±${(100 * f.tolerance).toFixed(1)}%` }), el('td', { class: f.fails ? 'first verdict-regressed' : 'first', text: f.verdict }),
          el('td', { class: 'left', text: f.note || '' }));
        if (f.scene !== '*') tr.addEventListener('click', () => choose(f.scene, f.label));
        return tr;
      })));
  }

  function renderFlags() {
    const box = $('flags');
    const parts = [];
    // Comparisons that fail though no row does: runs sharing too few frames after the warm-up,
    // which `arena compare` cannot judge (exit 2); the warnings above name them.
    const failingWithoutRows = (H.failingComparisons ?? 0) - new Set(flags.map((f) => f.run)).size;
    if (flags.length) parts.push(changeTable(flags, 'flags-table'));
    if (failingWithoutRows > 0) parts.push(el('p', { class: 'failures', text: `${failingWithoutRows} comparison(s) the gate cannot pass though no row fails it: their runs share 7 or fewer frames after the warm-up, too few for the intervals to judge by (\`arena compare\` could not judge them, exit 2; the warnings above say which).` }));
    if (flags.length || failingWithoutRows > 0) { /* said above */ }
    else if (notJudged.length) parts.push(el('p', { class: 'empty', text: 'No run failed the gate where it could judge; the changes below were not judged.' }));
    else if (H.runs.length < 2) parts.push(el('p', { class: 'empty', text: 'One run: nothing was compared, so nothing could fail the gate.' }));
    else parts.push(el('p', { class: 'empty', text: 'No run would have failed the gate.' }));
    if (notJudged.length) {
      // Largest changes first: what a reader must check by hand, or judge from the run directories.
      const sorted = [...notJudged].sort((a, b) => Math.abs(b.change ?? 0) - Math.abs(a.change ?? 0));
      parts.push(el('p', { class: 'failures not-judged', text:
        `${notJudged.length} change(s) beyond the tolerance were NOT JUDGED: the gate cannot tell them from noise, and whether \`arena compare\` would fail them is unknown. ` +
        (notJudged.some((c) => (c.note || '').includes('results.db'))
          ? 'Runs read from results.db keep no per-tile data: give `arena history` the run directories (their results.json) to judge them. ' : '') +
        (notJudged.some((c) => !(c.note || '').includes('results.db'))
          ? 'An event whose changed region lies within fewer than 4 effective tiles has no interval at all. ' : '') +
        'Each row\'s note says why.' }));
      parts.push(changeTable(sorted, 'not-judged-table'));
    }
    box.replaceChildren(...parts);
  }

  function setupControls() {
    const sceneSel = $('history-scene');
    for (const s of Object.keys(H.series).sort()) sceneSel.append(el('option', { value: s, text: s }));
    sceneSel.addEventListener('change', () => choose(sceneSel.value, null));
    $('history-label').addEventListener('change', (e) => choose(state.scene, e.target.value));
    $('history-log').addEventListener('change', () => renderCharts());
  }

  function choose(scene, label) {
    state.scene = scene;
    const labels = Object.keys(H.series[scene] || {});
    state.label = label && labels.includes(label) ? label : labels[0] || null;
    $('history-scene').value = scene;
    // A series that joins labels (--match, or a label written otherwise) names them all.
    const aliases = (l) => (H.series[scene][l].aliases || []);
    $('history-label').replaceChildren(...labels.map((l) => el('option', { value: l, text: aliases(l).length ? `${l} (also ${aliases(l).join(', ')})` : l })));
    $('history-label').value = state.label;
    return renderCharts();
  }

  function metricChart(metric, s) {
    const here = H.changes.filter((c) => concerns(c) && appliesTo(c, metric.name));
    const flagged = new Set(here.filter((c) => c.fails).map((c) => c.run));
    const verdictAt = Object.fromEntries(here.map((c) => [c.run, c.verdict]));
    const rows = [];
    s.value.forEach((v, i) => {
      if (v === null) return;
      const ci = s.ci95 && s.ci95[i];
      rows.push({ run: i, commit: H.runs[i].revision ? `${H.runs[i].revision} (arena ${H.runs[i].commit || '?'})` : H.runs[i].commit || '', created: H.runs[i].created || '', value: v,
                  lo: ci ? ci[0] : null, hi: ci ? ci[1] : null, flagged: flagged.has(i),
                  other: !flagged.has(i) && verdictAt[i] !== undefined && verdictAt[i] !== 'improved', verdict: verdictAt[i] || 'ok' });
    });
    // The gate's band: previous value x (1 +- tolerance), relative to |previous| as compare has it.
    const band = [];
    if (metric.tolerance !== null) {
      for (let i = 1; i < s.value.length; ++i) {
        const p = s.value[i - 1];
        if (p === null) continue;
        band.push({ run: i, bandLo: p - Math.abs(p) * metric.tolerance, bandHi: p + Math.abs(p) * metric.tolerance });
      }
    }
    const log = $('history-log').checked && rows.every((r) => r.value > 0) && band.every((b) => b.bandLo > 0);
    // Each tick names its run and the commit it was built from (the section is "against commit").
    const shortCommit = (c) => c.replace(/^([0-9a-f]{7})[0-9a-f]*/, '$1');  // "-dirty" kept
    const tickLabels = H.runs.map((r, i) => (r.revision ? `${i} ${shortCommit(r.revision)}` : r.commit ? `${i} ${shortCommit(r.commit)}` : String(i)));
    const x = { field: 'run', type: 'quantitative', title: 'run and commit (oldest → newest)', scale: { nice: false, domain: [0, Math.max(1, H.runs.length - 1)] },
                axis: { tickMinStep: 1, format: 'd', labelAngle: -30, labelExpr: `${JSON.stringify(tickLabels)}[datum.value] || datum.label` } };
    const y = { field: 'value', type: 'quantitative', title: `${metric.name} ${metric.lowerIsBetter ? '↓' : '↑'}`, scale: log ? { type: 'log' } : { zero: false } };
    const withCi = rows.filter((r) => r.lo !== null && r.hi !== null);
    return A.baseSpec({
      width: 560,
      height: 170,
      title: { text: `${metric.name}${metric.tolerance !== null ? ` (gate ±${(100 * metric.tolerance).toFixed(1)}%)` : ' (not gated)'}`, anchor: 'start', fontSize: 12 },
      layer: [
        { name: 'band', data: { values: band }, mark: { type: 'area', color: '#2f6fd0', opacity: 0.15, interpolate: 'step' },
          encoding: { x, y: { field: 'bandLo', type: 'quantitative' }, y2: { field: 'bandHi' } } },
        { name: 'intervals', data: { values: withCi }, mark: { type: 'rule', color: '#7a8599' },
          encoding: { x, y: { field: 'lo', type: 'quantitative' }, y2: { field: 'hi' } } },
        { name: 'values', data: { values: rows }, mark: { type: 'line', color: '#1d2330', strokeWidth: 1.2 }, encoding: { x, y } },
        { name: 'points', data: { values: rows }, mark: { type: 'point', filled: true, size: 18, color: '#1d2330' },
          encoding: { x, y, tooltip: [{ field: 'run', title: 'run' }, { field: 'commit' }, { field: 'created' }, { field: 'value', title: metric.name, format: '.4~g' }] } },
        // Beyond tolerance without failing the gate (e.g. not resolved at the confidence): orange.
        { name: 'unresolved', data: { values: rows.filter((r) => r.other) }, mark: { type: 'point', shape: 'circle', size: 120, color: '#d9822b', strokeWidth: 2, filled: false },
          encoding: { x, y, tooltip: [{ field: 'run' }, { field: 'commit' }, { field: 'verdict' }, { field: 'value', title: metric.name, format: '.4~g' }] } },
        { name: 'flagged', data: { values: rows.filter((r) => r.flagged) }, mark: { type: 'point', shape: 'circle', size: 160, color: '#b3261e', strokeWidth: 2.5, filled: false },
          encoding: { x, y, tooltip: [{ field: 'run' }, { field: 'commit' }, { field: 'value', title: metric.name, format: '.4~g' }] } },
      ],
    });
  }

  async function renderCharts() {
    const box = $('history-charts');
    for (const name of Object.keys(A.views)) A.dropChart(name);
    box.replaceChildren();
    const series = (H.series[state.scene] || {})[state.label] || {};
    const renders = [];
    for (const m of H.metrics) {
      if (!series[m.name]) continue;
      const holder = el('div', { class: 'chart', 'data-metric': m.name });
      box.append(holder);
      renders.push(A.embedChart(`history:${m.name}`, holder, metricChart(m, series[m.name])));
    }
    await Promise.all(renders);
  }

  async function main() {
    if (!H) {
      document.querySelector('main').prepend(el('p', { class: 'failures', text: 'history-data.js is missing: regenerate with `arena history`.' }));
      return;
    }
    renderInfo();
    renderFlags();
    setupControls();
    // Start on the first flagged series, else the first one.
    const first =
        flags.find((f) => f.scene !== '*') || {scene: Object.keys(H.series).sort()[0], label: null};
    if (first.scene) await choose(first.scene, first.label);
  }

  window.arenaHistory = {
    state,
    ready: A.start(main).then(() => {
      $('load-time').textContent = `Page ready ${A.loadMs.toFixed(0)} ms after navigation.`;
    }),
  };
})();
