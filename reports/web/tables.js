// Tables: the rankings with ties (per scene and overall), the summary table with intervals and a
// column picker (the default columns fit a 1400 px window without a horizontal scrollbar), the
// pairs' warnings and a sweep's ablation.
'use strict';

(() => {
  const A = window.Arena;
  const { $, el, fmt, pct } = A;

  const TIMING_COLUMNS = [
    { key: 'msMedian', title: 'ms median', default: true },
    { key: 'msP95', title: 'ms p95', default: true },
    { key: 'msP5', title: 'ms p5', default: false },
    { key: 'msPerMegapixel', title: 'ms/MP', default: false },
    { key: 'tapsPerPixel', title: 'taps/px', default: false, group: 'work',
      hint: 'neighbour fetches per pixel per frame, summed over the passes (no clock)' },
    // The cost model's view (docs/gpu-cost.md): the counted traffic priced at 1920x1080 on the
    // first device, and the GPU-format memory of the buffers the passes touched, at 1080p.
    { key: 'gpuMs', title: 'GPU ms', default: false, group: 'GPU, 1080p (model)',
      hint: 'predicted from the counted traffic (a model, not a measurement) on' },
    { key: 'gpuPersistentMiB', title: 'MiB kept', default: false, group: 'GPU, 1080p (model)',
      hint: 'history buffers that survive the frame, GPU formats; NRD v4.16.0 README, context: REBLUR_DIFFUSE_SPECULAR 88.88, RELAX_DIFFUSE_SPECULAR 97.12' },
    { key: 'gpuWorkingSetMiB', title: 'MiB working', default: false, group: 'GPU, 1080p (model)',
      hint: 'persistent + transient buffers in one frame, GPU formats; NRD v4.16.0 README, context: REBLUR_DIFFUSE_SPECULAR 148.12, RELAX_DIFFUSE_SPECULAR 168.94' },
  ];
  // Shown unless the user picks otherwise: the metrics a choice is usually made on.
  // Catalog metrics that some pair of the run summarises; ms is shown with the timing columns.
  const tableMetrics = () => A.D.metrics.filter((m) => m.name !== 'ms' && A.D.pairs.some((p) => p.summary && p.summary[m.name]));

  A.setupTables = function setupTables() {
    const picker = $('column-picker');
    const chosen = (A.state.columns = new Set());
    const box = (id, text, on, title) => {
      if (on) chosen.add(id);
      const input = el('input', { type: 'checkbox', 'data-column': id, checked: on });
      input.addEventListener('change', () => {
        if (input.checked) chosen.add(id);
        else chosen.delete(id);
        A.renderTables();
      });
      return el('label', { title }, input, ` ${text}`);
    };
    picker.append(
      el('span', { class: 'picker-group' }, el('b', { text: 'Metrics: ' }),
        tableMetrics().map((m) => box(m.name, m.name, m.reportColumn, m.meaning))),
      el('span', { class: 'picker-group' }, el('b', { text: 'Time: ' }),
        TIMING_COLUMNS.map((t) => box(t.key, t.title, t.default))),
      el('span', { class: 'picker-group' }, el('b', { text: 'Show: ' }),
        box('ci95', '95% intervals', true, 'the interval of each mean, under it'),
        box('p95', 'p95 over frames', false, 'a column with each metric\'s 95th percentile over frames')),
    );
  };

  // A ranking's label cell: marked "(+paths)" where the method read paths beyond the frame's own,
  // "(oracle)" where it read a layer no real-time engine has; the title says what.
  function readsBeyond(r) {
    const marks = [], titles = [];
    if (r.extraPathsPerPixel > 0) {
      marks.push('(+paths)');
      titles.push(`reads ${fmt(r.extraPathsPerPixel)} paths per pixel per frame beyond the frame's 1-spp ones`);
    }
    if ((r.oracleLayers || []).length) {
      marks.push('(oracle)');
      titles.push(`reads ${r.oracleLayers.join(', ')}: data no real-time engine has, not ranked on equal terms`);
    }
    if (!marks.length) return {class: 'first', text: r.label};
    return {class: 'first', title: titles.join('; '), text: `${r.label} ${marks.join(' ')}`};
  }

  // Tie groups of a ranking: labels connected through tiedWith share a group (index by label).
  function tieGroups(ranking) {
    const group = {};
    let next = 0;
    for (const r of ranking) {
      if (group[r.label] !== undefined) continue;
      const stack = [r.label];
      group[r.label] = next;
      while (stack.length) {
        const l = stack.pop();
        const row = ranking.find((x) => x.label === l);
        for (const t of (row && row.tiedWith) || []) if (group[t] === undefined) { group[t] = next; stack.push(t); }
      }
      ++next;
    }
    return group;
  }

  // `checksums`: label -> the checksum of its output frames on this scene (a scene's ranking;
  // null overall): methods tied because their outputs are the same bits are said to be.
  function rankingTable(title, R, valueTitle, valueKey, checksums = null) {
    if (!R || !R.ranking || !R.ranking.length) return null;
    const sameOutput = (r) => (checksums && checksums[r.label]
      ? (r.tiedWith || []).filter((other) => checksums[other] === checksums[r.label]) : []);
    const groups = tieGroups(R.ranking);
    const sizes = {};
    for (const g of Object.values(groups)) sizes[g] = (sizes[g] || 0) + 1;
    const rows = R.ranking.map((r) => {
      const tied = (r.tiedWith || []).length > 0;
      const g = groups[r.label];
      return el(
          'tr', {
            class: `${tied ? 'tied' : ''} ${g % 2 ? 'band' : ''}`.trim() || null,
            'data-label': r.label,
            'data-tied': tied ? 'true' : null
          },
          el('td', {class: 'rank', text: `${r.rank}${tied ? '=' : ''}`}),
          // A method that read paths beyond the frame's own is marked, as on the speed chart, and
          // one that read an oracle layer (data no real-time engine has) too.
          el('td', readsBeyond(r)),
          el('td', {text: fmt(r[valueKey])}),
          el('td',
             R.baseline && r.label === R.baseline ? {
               class: 'ci',
               title:
                   'the baseline of the normalisation: its score is 1 by definition, not a measurement with no uncertainty',
               text: '(1 by definition)'
             } :
                                                    {class: 'ci', text: A.interval(r.ci95) || '–'}),
          el('td', {
            class: 'left',
            text: tied ? `tied with ${r.tiedWith.join(', ')}` +
                    (sameOutput(r).length ? ` (identical outputs: ${sameOutput(r).join(', ')})` : '') :
                !R.tiesKnown         ? '' :
                R.ranking.length < 2 ? 'the only method: not compared' :
                                       'resolved'
          }));
    });
    const resolved = R.totalPairs ? ` · ${R.resolvedPairs} of ${R.totalPairs} pairs resolved at 95%` : '';
    const how = R.tiesKnown
      ? `Tied (=): the difference to another method is not resolved at 95% (paired).${resolved}`
      : 'This run has no paired statistics (older results): ranked by mean, ties unknown.';
    const excluded = R.excluded ? ` Left out: ${R.excluded}.` : '';
    return el('div', { class: 'ranking' },
      el('h3', { text: title }),
      el('p', { class: 'note', text: how + excluded }),
      el('table', { class: 'data ranking-table' },
        el('thead', {}, el('tr', {}, el('th', { text: 'rank' }), el('th', { class: 'first', text: 'denoiser / setting' }),
          el('th', { text: valueTitle }), el('th', { text: '95% interval' }), el('th', { class: 'first', text: 'ties' }))),
        el('tbody', {}, rows)));
  }

  // The overall scores on the other metrics that declare one (1 − SSIM, the FLIPs, tRMAE's
  // flicker), folded under the relMSE ranking: does the choice hold on them? The fold's title
  // names each one's rank 1, so a different winner shows without opening it.
  function otherOverallRankings(byMetric) {
    const titleOf = (name) => (A.D.metrics.find((m) => m.name === name) || {}).title || name;
    const tables = Object.entries(byMetric)
      .map(([name, o]) => rankingTable(`Overall ranking on ${titleOf(name)} (${o.normalisation || 'normalised over scenes'})`, o, 'score', 'score'))
      .filter(Boolean);
    if (!tables.length) return null;
    return el('details', { class: 'other-overall' },
      el('summary', { text: `Overall rankings on the other metrics (rank 1: ${Object.entries(byMetric).map(([name, o]) => {
        const firsts = (o.ranking || []).filter((r) => r.rank === 1).map((r) => r.label);
        return `${titleOf(name)} ${firsts.length ? firsts.join(', ') : 'none'}`;
      }).join('; ')})` }),
      ...tables);
  }

  function renderRankings() {
    const R = A.D.rankings || { scenes: {} };
    const scene = R.scenes[A.state.scene];
    const overall = R.overall;
    $('rankings').replaceChildren(...[
      rankingTable(`Ranking on ${A.state.scene}${scene ? ` (${scene.metric || 'relMse'})` : ''}`, scene, `mean ${scene ? scene.metric || 'relMse' : ''}`, 'mean',
                   Object.fromEntries(A.pairsOf(A.state.scene).filter((p) => p.outputChecksum).map((p) => [p.label, p.outputChecksum]))),
      overall && rankingTable(`Overall ranking (${overall.normalisation || 'normalised over scenes'})`, overall, 'score', 'score'),
      otherOverallRankings(R.overallByMetric || {}),
    ].filter(Boolean));
  }

  // A column whose marked (rank 1) methods include one with a worse mean than a method not marked:
  // ranks count the methods resolved better, so a method with a wide interval stays at rank 1 while
  // one with a better mean but a narrow interval has a method resolved better than it. Said, so
  // that the mark is not read as "the best mean".
  function markedAboveABetterMean(cols, best, ok) {
    const said = [];
    cols.forEach((c, i) => {
      if (!best[i] || c.title !== 'mean') return;
      const better = (a, b) => (c.lower ? a < b : a > b);
      const valued = ok.filter((p) => Number.isFinite(c.get(p)));
      const marked = valued.filter((p) => best[i].has(p.label));
      if (!marked.length) return;
      const worst = marked.reduce((w, p) => (better(c.get(w), c.get(p)) ? p : w));
      const above = valued.filter((p) => !best[i].has(p.label) && better(c.get(p), c.get(worst)));
      if (above.length)
        said.push(`${c.group}: ${above.map((p) => p.label).join(', ')} not marked, with a ${c.lower ? 'lower' : 'higher'} mean than ${worst.label}`);
    });
    return said.length ?
        ` A mark is not the best mean (${said.join('; ')}): a method not marked has a method resolved better than it, while the marked one, with a wider interval, has none.` :
        '';
  }

  A.renderTables = function renderTables() {
    renderRankings();
    const table = $('summary-table');
    const scene = A.sceneByName[A.state.scene];
    const pairs = A.pairsOf(A.state.scene);
    const on = A.state.columns;
    const withCi = on.has('ci95');
    // Columns: {group, title, lower, get(pair) -> number, ci(pair) -> [lo, hi]}.
    const cols = [];
    for (const m of tableMetrics()) {
      if (!on.has(m.name)) continue;
      const s = (p) => (p.summary && p.summary[m.name]) || null;
      cols.push({ group: m.name, title: 'mean', lower: m.lowerIsBetter, meaning: m.meaning,
                  get: (p) => (s(p) ? s(p).mean : null), ci: (p) => (s(p) ? s(p).ci95 : null), floor: m.name });
      if (on.has('p95')) cols.push({ group: m.name, title: 'p95', lower: m.lowerIsBetter, get: (p) => (s(p) ? s(p).p95 : null) });
    }
    const gpuDevice = (pairs.find((p) => p.timing && p.timing.gpuDevice) || { timing: {} }).timing.gpuDevice || 'no device';
    // Times on another clock (a capture's recorded device times) are shown with their clock and
    // never compared with the CPU's: the best of a column is taken among one clock's times.
    const clockedColumns = new Set(['msMedian', 'msP95', 'msP5', 'msPerMegapixel']);
    const otherClock = (p) => (
        p.timing && p.timing.clock && p.timing.clock !== 'cpu' ? p.timing.device || p.timing.clock :
                                                                 null);
    // Which clock and size the times are: this machine's CPU at the scene's resolution (a reader
    // with a GPU budget must not read them as GPU times); the model's columns name their device.
    const cpuGroup = `CPU time here${scene && scene.width ? `, ${scene.width}×${scene.height}` : ''}`;
    for (const t of TIMING_COLUMNS)
      if (on.has(t.key))
        cols.push({
          group: t.group === 'work' ? t.group : t.group ? `${t.group}, ${gpuDevice}` : cpuGroup,
          plain: true,
          title: t.title,
          lower: true,
          hint: t.key === 'gpuMs' ? `${t.hint} ${gpuDevice}` : t.hint || `${t.title} per frame on this machine's CPU (the run's environment), at the scene's resolution`,
          get: (p) => (p.timing ? p.timing[t.key] : null),
          clockOf: clockedColumns.has(t.key) ? otherClock : null
        });
    // "Best" is rank 1 in the run's statistics (no method resolved better; ties among them
    // included): a mean column of a ranked metric only (p95, times and unranked metrics have no
    // paired interval, so nothing in them is called best), nothing on a scene the statistics do
    // not rank. An older run without statistics: the best value, ties unknown (the note says so).
    const ok = pairs.filter(A.isOk);
    const sceneRanking = ((A.D.rankings || {scenes: {}}).scenes[A.state.scene]) || {};
    const withStatistics = !!(A.D.rankings && A.D.rankings.statistics);
    const firstBy =
        withStatistics ? (sceneRanking.tiesKnown && sceneRanking.firstByMetric) || {} : null;
    const best = cols.map((c) => {
      if (firstBy)
        return c.title === 'mean' && !c.plain && firstBy[c.group] ? new Set(firstBy[c.group]) :
                                                                    null;
      if (c.plain) return null;
      const vals = ok.map(c.get).filter((v) => Number.isFinite(v));
      if (vals.length < 2) return null;
      const top = c.lower ? Math.min(...vals) : Math.max(...vals);
      return new Set(ok.filter((p) => c.get(p) === top).map((p) => p.label));
    });
    $('summary-best-note').textContent = !firstBy ?
        'Bold green: the best mean of a column; this run has no paired statistics, so ties are unknown.' :
        !sceneRanking.tiesKnown ?
        'The run\'s statistics do not rank this scene: nothing is marked best.' :
        'Bold green: rank 1 in the run\'s statistics on that metric (no method resolved better by a paired 95% interval; ties among them included); columns the statistics do not rank (p95, times, unranked metrics) mark nothing.' +
        markedAboveABetterMean(cols, best, ok);
    const groups = [];
    for (const c of cols) {
      if (groups.length && groups[groups.length - 1].name === c.group) groups[groups.length - 1].span++;
      else groups.push({ name: c.group, span: 1, meaning: c.meaning, lower: c.lower, plain: c.plain });
    }
    const start = (i) => (i === 0 || cols[i - 1].group !== cols[i].group ? 'group-start' : '');
    const ranking = ((A.D.rankings || { scenes: {} }).scenes[A.state.scene] || {}).ranking || [];
    const rankOf = Object.fromEntries(ranking.map((r) => [r.label, `${r.rank}${(r.tiedWith || []).length ? '=' : ''}`]));
    const head = el('thead', {},
      el('tr', {}, el('th', { rowspan: 2, text: 'rank' }), el('th', { class: 'first', rowspan: 2, text: 'denoiser / setting' }),
        groups.map((g) => el('th', { class: 'group', colspan: g.span, title: g.meaning ? `${g.meaning} (${g.lower ? 'lower' : 'higher'} is better)` : null,
          text: g.plain ? g.name : `${g.name} ${g.lower ? '↓' : '↑'}` }))),
      el('tr', {}, cols.map((c, i) => el('th', { class: start(i) || null, title: c.hint || null, text: c.title }))));

    const rows = [];
    // The reference's own floors beside the metrics they bound: relMSE's noise floor, and each
    // metric between two independent half-sample references (results: scenes.<scene>.floors).
    const floors = { ...((scene && scene.floors) || {}) };
    if (scene && scene.noiseFloor && floors.relMse === undefined) floors.relMse = scene.noiseFloor.mean;
    if (Object.keys(floors).length) {
      // Named apart from the verdict's and the chart's "reference noise floor" (the reference's own
      // estimated relMSE): these are scores, measured as a method would be.
      rows.push(el(
          'tr', {class: 'reference-row'}, el('td', {}), el('td', {
            class: 'first',
            text: 'floor: a perfect method',
            title:
                'each metric\'s value for a perfect method: an image with the reference\'s noise and nothing else, scored against the reference (results: scenes.<scene>.floors)'
          }),
          cols.map((c, i) => {
            const v = c.floor && c.title === 'mean' ? floors[c.floor] : undefined;
            return el(
                'td', {class: start(i) || null, text: v === undefined || v === null ? '' : fmt(v)});
          })));
    }
    for (const p of pairs) {
      if (!A.isOk(p)) {
        rows.push(el('tr', { class: 'failed' }, el('td', {}), el('td', { class: 'first', text: `${p.label} (${p.status})` }),
          el('td', { class: 'left', colspan: cols.length, text: p.error })));
        continue;
      }
      rows.push(el('tr', { 'data-label': p.label, class: p.label === A.state.selected ? 'selected' : null },
        el('td', { class: 'rank', text: rankOf[p.label] || '' }),
        el('td', { class: 'first', title: A.originKind(p.label) ? `${(A.D.origins || {})[p.label]}; ${JSON.stringify(p.params)}` : JSON.stringify(p.params),
                   text: A.originKind(p.label) ? `${p.label} (${A.originKind(p.label)})` : p.label }),
        cols.map((c, i) => {
          const v = c.get(p);
          const clock = c.clockOf ? c.clockOf(p) : null;  // another clock: labelled, never "best"
          const classes =
              [start(i), !clock && best[i] && best[i].has(p.label) ? 'best' : ''].join(' ').trim();
          const ci = withCi && c.ci ? A.interval(c.ci(p)) : '';
          return el(
              'td', {class: classes || null}, fmt(v),
              ci ? el('span', {class: 'ci', text: ci}) : null,
              clock ? el('span', {class: 'ci', text: `(${clock})`}) : null);
        })));
    }
    table.replaceChildren(head, el('tbody', {}, rows));

    const warnings = pairs.filter((p) => p.warnings && p.warnings.length);
    // Reference quality (results: scenes.<scene>.referenceQuality): said plainly when the goal is
    // missed, for the scene or between its events (segmentsMeet false: its event figures there).
    const quality = scene && scene.referenceQuality;
    const qualityNote = quality && (quality.meets === false || quality.segmentsMeet === false)
      ? [el('p', { class: 'reference-quality warnings', text: `Reference quality: ${quality.verdict}` })] : [];
    // A warning about the scene (results: scenes.<scene>.warnings) is listed once, before the pairs' own.
    const sceneWarnings = (scene && scene.warnings) || [];
    // A capture's denoisers it lacked the inputs for (results: scenes.<scene>.notRun), not run there.
    const notRun = ((scene && scene.notRun) || []).map((n) => el('li', {}, el('b', { text: `${n.label}: ` }), `not run: ${n.reason}`));
    const items = sceneWarnings.map((w) => el('li', {}, el('b', { text: `${A.state.scene}: ` }), w)).concat(notRun)
      .concat(warnings.flatMap((p) => p.warnings.map((w) => el('li', {}, el('b', { text: `${p.label}: ` }), w))));
    $('warnings').replaceChildren(...qualityNote, ...validationTable(scene), ...(items.length ? [el('h3', { text: 'Warnings' }),
      el('ul', { class: 'warnings' }, items)] : []));
    renderAblation();
  };

  // A capture's validation (results: scenes.<scene>.validation): every check with its measured
  // value and thresholds, so a ranking on a capture shows what its inputs were checked for.
  function validationTable(scene) {
    const v = scene && scene.validation;
    if (!v || !v.checks) return [];
    const num = (x) => (x === null || x === undefined ? '–' : fmt(x));
    return [el('h3', { text: `Capture validation: ${v.status}` }),
      el('div', { class: 'table-wrap' }, el('table', { class: 'data validation-table' },
        el('thead', {}, el('tr', {}, ['check', 'status', 'value', 'warn above', 'fail above', 'unit', 'detail']
          .map((h, i) => el('th', { class: i === 0 ? 'first' : null, text: h })))),
        el('tbody', {}, v.checks.map((c) => el('tr', { class: c.status === 'pass' ? null : c.status === 'fail' ? 'worse' : 'tie' },
          el('td', { class: 'first', text: c.name }), el('td', { text: c.status }), el('td', { text: num(c.value) }),
          el('td', { text: num(c.warnAbove) }), el('td', { text: num(c.failAbove) }), el('td', { text: c.unit }),
          el('td', { text: c.detail }))))))];
  }

  // Sweep runs: each grid parameter's values against its first value (e.g. an edge-stopping term
  // off vs on), as the mean change of every metric over matching settings.
  function renderAblation() {
    const box = $('ablation');
    box.replaceChildren();
    const AB = A.D.ablation;
    if (!AB) return;
    const rows = AB.rows.filter((r) => r.scene === A.state.scene || r.scene === null);
    box.append(
        el('h3', {text: `Ablation of ${AB.denoiser} (sweep)`}), el('p', {
          class: 'note',
          text:
              'Every row, every scene and every metric is also in ablation.csv beside this page. Δ = metric with the value − metric with the first value, other grid parameters held equal; relative change in brackets (where several differences are matched, the mean of their relative changes, which can differ in sign from the mean Δ: over all scenes Δ is weighted by each scene\'s scale, the bracket is not); time is the median frame time, as everywhere on this page, measured under this machine\'s load (no interval: a difference in time between values that cannot change the work is load). Per scene, a ranked metric\'s Δ is the run\'s paired difference with its 95% interval; where several settings of the other parameters match, and over all scenes, Δ is the mean and the count says how many of the matched paired differences are resolved, and each match follows on its own line ("given" the other parameters\' settings) with its paired interval: an effect under one setting only shows there. Green or red only when every matched difference is resolved that way ("partly worse" or "partly better": resolved under some settings, not under the others; "tie": under none; "identical outputs": the two points\' outputs are the same bits, so no difference exists to find; "not judged": a response neither point settled in, cut off at the window\'s end; "mixed": resolved both ways; no colour: a metric without paired intervals). Columns named ghosting@frame.figure or cut@frame.figure are the event windows\' figures (lag, response, ghosting; lower is better), paired as the metrics are.'
        }));
    if (AB.footprintNote) box.append(el('p', { class: 'note footprint-note', text: AB.footprintNote }));
    const unranked = (AB.unrankedFigures || []).filter((line) => A.state.scene === undefined || line.includes(` on ${A.state.scene}: `));
    if (unranked.length)
      box.append(el('p', { class: 'note unranked-figures', text: `Event figures that rank no method here, so their changes have no interval: ${unranked.join('; ')}.` }));
    // What the run said of these scenes' results (a reference short of its goal, too few frames after
    // the warm-up): with the table, as ablation.csv carries it in each row's note.
    const caveats = [...new Set(rows.map((r) => r.caveat).filter(Boolean))];
    if (caveats.length)
      box.append(el('p', { class: 'note warnings ablation-caveat', text: `Caveats on these rows: ${caveats.join('; ')}.` }));
    if (!rows.length) {
      box.append(el('p', { class: 'empty', text: 'No grid parameter has two values with matching pairs.' }));
      return;
    }
    const names = A.D.metrics.map((m) => m.name).concat(AB.figures || [])
        .filter((name) => rows.some((r) => r.delta[name] !== undefined));
    const classOf = { better: 'better', worse: 'worse', tie: 'tie', mixed: 'tie', 'partly better': 'tie', 'partly worse': 'tie', 'identical outputs': 'tie' };
    // A paired cell's word after its interval: a tie, or why there is nothing to resolve.
    const unresolvedWord = (p, verdict) =>
        verdict === 'identical outputs' || verdict === 'not judged' ? ` ${verdict}` : p.resolved ? '' : ' tie';
    // A figure bounded rather than measured (a method that never settled): marked, the reason on hover.
    // ...and a tie whose per-frame differences hold one sign on every frame, the reason on hover.
    const bound = (note, verdict) =>
        (note && note.includes('lower bound') && verdict !== 'not judged' ? ' (bound)' :
         note && note.startsWith('a tie, yet') ? ' (one sign every frame)' : '');
    const pairedCell = (d, relative, p, verdict, note) => el('td', {
      class: classOf[verdict] || null,
      'data-paired': 'true',
      'data-verdict': verdict,
      title: note || null,
      text: `${fmt(d)} (${pct(relative)}) ${A.interval(p.ci95)}${unresolvedWord(p, verdict)}${bound(note, verdict)}`
    });
    const cells = (r) => names.map((name) => {
      const d = r.delta[name];
      if (d === undefined) return el('td', { text: '–' });
      const j = r.judged[name];
      const p = r.paired && r.paired[name];
      const note = r.notes && r.notes[name];
      if (p && j.matches === 1) return pairedCell(d, r.relative[name], p, j.verdict, note);
      // The verdict in words too, not by colour alone.
      const said = j.verdict === 'no interval' ? ' no interval' : ` ${j.resolved}/${j.matches} resolved, ${j.verdict}`;
      return el('td', {class: classOf[j.verdict] || null, 'data-verdict': j.verdict, title: note || null, text: `${fmt(d)} (${pct(r.relative[name])})` + said + bound(note, j.verdict)});
    });
    const matchCells = (m) => names.map((name) => {
      const d = m.delta[name];
      if (d === undefined) return el('td', { text: '–' });
      const p = m.paired[name];
      const note = m.notes && m.notes[name];
      if (p) return pairedCell(d, m.relative[name], p, m.judged[name], note);
      return el('td', { 'data-verdict': m.judged[name], text: `${fmt(d)} (${pct(m.relative[name])}) no interval` });
    });
    const body = [];
    for (const r of rows) {
      body.push(el('tr', {},
        el('td', { class: 'first', text: r.parameter }),
        el('td', { text: `${r.value} vs ${r.versus}` + (r.given ? ` given ${r.given}` : '') }),
        el('td', { text: r.scene === null ? 'all scenes' : r.scene }), el('td', { text: r.matched }),
        cells(r)));
      for (const m of r.byMatch || [])
        body.push(el('tr', { class: 'match' },
          el('td', { class: 'first', text: '' }), el('td', { text: `given ${m.given}` }),
          el('td', { text: r.scene }), el('td', { text: '1' }), matchCells(m)));
    }
    box.append(el('div', { class: 'table-wrap' }, el('table', { class: 'data ablation-table' },
      el('thead', {}, el('tr', {}, el('th', { class: 'first', text: 'parameter' }), el('th', { text: 'value vs first' }),
        el('th', { text: 'scene' }), el('th', { text: 'pairs' }), names.map((name) => el('th', { text: name === 'ms' ? 'Δ ms (median)' : `Δ ${name}` })))),
      el('tbody', {}, body))));
  }
})();
