// Regression: a baseline run's comparison, with the verdicts `arena compare` gives.
'use strict';

(() => {
  const A = window.Arena;
  const { $, el, fmt, pct } = A;

  // ---------------------------------------------------------------- (5) regression

  A.renderRegression = function renderRegression() {
    const body = $('regression-body');
    const R = A.D.regression;
    if (!R) {
      body.replaceChildren(el('p', { class: 'empty', text: 'No baseline given. `arena report RUN --baseline OTHER_RUN --out DIR` adds the metrics that moved, with the verdicts `arena compare` gives.' }));
      return;
    }
    const counts = {};
    for (const r of R.rows) counts[r.verdict] = (counts[r.verdict] || 0) + 1;
    const filter =
        el('select', {id: 'regression-filter'},
           el('option', {value: 'moved', text: 'moved beyond tolerance (not ok)'}),
           el('option', {value: 'regressed', text: 'what fails the gate'}),
           el('option', {value: 'all', text: 'all comparisons'}));
    const tableBox = el('div', { class: 'table-wrap' });
    const order = {
      regressed: 0,
      failed: 0,
      unverified: 0,
      missing: 1,
      unresolved: 2,
      'not judged': 2,
      new: 3,
      improved: 4,
      absent: 5,
      ok: 6
    };
    const draw = () => {
      const rows = R.rows
                       .filter(
                           (r) => filter.value === 'all' ||
                               (filter.value === 'regressed' ? r.fails : r.verdict !== 'ok'))
                       .sort(
                           (a, b) => order[a.verdict] - order[b.verdict] ||
                               Math.abs(b.change) - Math.abs(a.change));
      tableBox.replaceChildren(
          rows.length ?
              el('table', {class: 'data regression-table'},
                 el('thead', {},
                    el('tr', {},
                       [
                         'scene', 'denoiser / setting', 'metric', 'baseline', 'candidate', 'change',
                         'tolerance', 'verdict', 'note'
                       ].map((t, i) => el('th', {
                               class: i < 3 || i === 8 ? 'first' : null,
                               text: t
                             })))),
                 el('tbody', {},
                    rows.map(
                        (r) => el(
                            'tr', {}, el('td', {class: 'first', text: r.scene}),
                            // A pair matched by what it ran under another label shows both.
                            el('td', {
                              class: 'first',
                              text: r.candidateLabel && r.candidateLabel !== r.label ?
                                  `${r.label} = ${r.candidateLabel}` :
                                  r.label
                            }),
                            el('td', {class: 'first', text: r.metric}),
                            el('td', {text: fmt(r.baseline)}), el('td', {text: fmt(r.candidate)}),
                            // The change wherever both runs measured it (a note such as
                            // "within noise" does not hide it).
                            el('td', {text: r.change == null ? '–' : pct(r.change)},
                               r.change != null && r.changeCi95 ? el('span', {
                                 class: 'ci',
                                 text: A.interval(r.changeCi95.map((v) => 100 * v)) + ' %'
                               }) :
                                                         null),
                            el('td', {
                              text: r.metric === '*' ? '–' : `±${(100 * r.tolerance).toFixed(1)}%`
                            }),
                            el('td', {class: `verdict-${r.verdict}`, text: r.verdict}),
                            el('td', {class: 'left', text: r.note || ''}))))) :
              el('p', {class: 'empty', text: 'Nothing moved beyond its tolerance.'}));
    };
    filter.addEventListener('change', draw);
    const b = R.baseline;
    body.replaceChildren(
        ...[el('p', {},
               `Baseline: ${b.name || '(unnamed)'}${b.created ? ` (${b.created}` : ''}${
                   b.revision ? `, revision ${b.revision}` : ''}${
                   b.commit ? `, commit ${b.commit})` :
                       b.created ? ')' :
                                   ''}. `,
               // Where compare would refuse the runs (the same run, other settings, data it
               // refuses), the gate's own sentence says why; the rows below are still shown.
               R.refused ? el('b', {
                 class: 'worse',
                 text: `\`arena compare\` would refuse these runs (exit 2): ${R.refused}.`
               }) :
                           el('b', {
                             // Could not judge is no pass, though no row fails (runs of too
                             // few frames after the warm-up).
                             class: R.anyRegression || R.gate === 'could not judge' ? 'worse' : 'best',
                             text: R.gate === 'could not judge' ?
                                 '`arena compare` could not judge these runs (exit 2).' :
                                 R.anyRegression ? '`arena compare` would fail (exit 1).' :
                                                   '`arena compare` would pass.'
                           })),
            // What the verdict rests on besides its rows, as compare warns of it.
            (R.warnings || []).length ?
                el('ul', {class: 'warnings'}, ...R.warnings.map((w) => el('li', {text: w}))) :
                null,
            el('p', {
              class: 'note',
              text: `Verdicts: ${
                  Object.entries(counts).map(([k, n]) => `${n} ${k}`).join(', ') ||
                  'none'}. A metric regresses when its mean moved in its worse direction by more than its tolerance, relative to the baseline, and the paired ${
                  A.fmt(100 * (R.confidence ?? 0.95))}% interval of that change excludes zero${
                  (R.correction ?? 'holm') === 'holm' ?
                      `, and it stays resolved among the ${R.rowsJudgedTogether ?? 'many'} rows judged together (Holm's correction: among many rows, some intervals exclude zero by noise alone; such a row is unresolved, and its note says so)` :
                      ' (each row alone: --correction none)'} (beyond tolerance within the noise: unresolved; with no interval to judge it: unverified, where the gate could not judge and fails, exit 2; not judged where no interval can exist, an event whose changed region lies within fewer than 4 effective tiles, which does not fail it, or where a change was resolved on 7 or fewer frames after the warm-up, too few for its interval to hold its level, where the gate cannot pass the runs, exit 2).`
            }),
            el('div', {class: 'controls'}, el('label', {}, 'Show ', filter)), tableBox]
            .filter(Boolean));
    draw();
  }
})();
