// Denoise Arena report: builds every section of index.html from window.ARENA_DATA (data.js).
// The views live in their own scripts (speed.js, over_time.js, ghosting.js, tables.js, images.js,
// regression.js) on top of shared.js; this file holds the report's state, the header, the
// selection that links the views, and start-up.
// Responsiveness with 10 denoisers x 10 scenes x 100 frames: only the selected scene's charts,
// tables and image panels are built, and rebuilt when the scene changes; images load lazily.
'use strict';

(() => {
  const A = window.Arena;
  const { $, el } = A;
  const D = window.ARENA_DATA;

  function initContext() {
    A.D = D;
    A.sceneByName = Object.fromEntries(D.scenes.map((s) => [s.name, s]));
    A.pairsOf = (scene) => D.pairs.filter((p) => p.scene === scene);
    A.isOk = (p) => p.status === 'ok';
    // A contender from outside arena (D.origins): its kind, shown beside its label ('' for a built-in).
    // "plugin", "isolated plugin", "external" or "stored output" (metrics/run_results contenderKind).
    A.originKind = (label) => (D.originKinds || {})[label] || '';
    // Every chart colours a label the same way, whichever labels the scene has.
    A.colorScale = { domain: D.labels, scheme: D.labels.length > 10 ? 'category20' : 'tableau10' };
    A.state = {
      scene: D.scenes.length ? D.scenes[0].name : null,
      speedScene: '__all__',
      speedAxis: D.errorAxes.length ? D.errorAxes[0].key : null,
      speedClock: 'cpu',  // the time measured here; the predicted GPU ms and captured times are offered beside it
      frame: null,
      zoom: { s: 1, x: 0, y: 0 },
      selected: null,  // a label clicked on the speed chart
    };
    // The selection links the views: a click on a speed point selects its denoiser (and scene)
    // in the image viewer, the over-time charts and the tables.
    const listeners = [];
    A.onSelect = (fn) => listeners.push(fn);
    A.select = (label, scene) => {
      A.state.selected = label;
      $('selection').replaceChildren('Selected: ', el('b', { text: label }), ' ',
        el('button', { type: 'button', id: 'selection-clear', text: 'clear' }));
      $('selection').hidden = false;
      if (scene && scene !== A.state.scene) {
        A.state.scene = scene;
        $('scene-select').value = scene;
        return Promise.all([renderScene(), A.renderSpeed()]);
      }
      for (const fn of listeners) fn(label);
      return Promise.all([A.renderOverTime(), A.renderSpeed()]).then(() => A.renderTables());
    };
    document.addEventListener('click', (e) => {
      if (e.target.id !== 'selection-clear') return;
      A.state.selected = null;
      $('selection').hidden = true;
      A.renderOverTime();
      A.renderSpeed();
      A.renderTables();
    });
  }

  function renderHeader() {
    const r = D.run;
    $('run-name').textContent = r.name || '(unnamed run)';
    // The display's exposure comes from the references; a scene without one is shown through its
    // noisy inputs' exposure instead (every scene: the run's sentence says so; some: named).
    const displayText = (display) => {
      if (!display) return null;
      const without = D.scenes.filter((x) => x.hasReference === false).map((x) => x.name);
      const fromInputs = display.replace(/exposure from (each frame's own|the scene's first) reference/,
                                         "exposure from each frame's noisy input (no reference)");
      if (without.length && without.length === D.scenes.length) return `display: ${fromInputs}`;
      return `display: ${display}` +
          (without.length ? ` (${without.join(', ')}: no reference, exposure from each frame's noisy input)` : '');
    };
    const env = r.environment || {};
    const s = r.settings || {};
    const parts = [
      r.created && `created ${r.created}`,
      env.revision && `revision ${env.revision}`,
      env.git_commit && `${env.revision ? 'arena ' : ''}commit ${env.git_commit}`,
      env.cpu && `${env.cpu} (${env.cores} cores)`,
      env.compiler,
      `warm-up W = ${r.warmup}`,
      s.relMseEpsilon !== undefined && `relMSE eps = ${s.relMseEpsilon}`,
      s.flip && `FLIP: ${s.flip}`,
      displayText(s.display),
    ].filter(Boolean);
    $('run-info').textContent = parts.join(' · ');
    // Contenders from outside arena, named with where they came from (their rows are marked too).
    const origins = Object.entries(D.origins || {});
    if (origins.length)
      $('run-info').after(el('p', { id: 'run-origins', class: 'note', text:
        `Not built in: ${origins.map(([label, origin]) => `${label} (${origin})`).join('; ')}.` }));

    if (D.failures.length) {
      const box = $('failures');
      box.hidden = false;
      box.append(
        el('b', { text: `${D.failures.length} pair(s) failed; the rest of the report is complete:` }),
        el('ul', {}, D.failures.map((f) => el('li', {}, el('b', { text: `${f.label} on ${f.scene}: ` }), f.error))),
      );
    }

    const select = $('scene-select');
    for (const sc of D.scenes) select.append(el('option', { value: sc.name, text: sc.name }));
    select.value = A.state.scene;
    select.addEventListener('change', () => {
      A.state.scene = select.value;
      renderScene();
    });
  }

  function renderScenePurpose() {
    const s = A.sceneByName[A.state.scene];
    const text = !s ? '' : !s.prepared ? `${s.name}: the scene could not be prepared (see the failures above).`
      : `${s.name}: ${s.purpose || ''} (${s.width}×${s.height}, ${s.frames} frames)`;
    $('scene-purpose').textContent = text;
  }

  function renderScene() {
    renderScenePurpose();
    A.renderTables();
    A.renderImages();
    return Promise.all([A.renderOverTime(), A.renderGhosting()]);
  }

  async function main() {
    if (!D) {
      document.querySelector('main').prepend(el('p', { class: 'failures', text: 'data.js is missing: regenerate the report with `arena report`.' }));
      return;
    }
    initContext();
    renderHeader();
    A.setupSpeed();
    A.setupOverTime();
    A.setupTables();
    A.setupImages();
    A.setupPngButtons(() => D.run.name || 'arena');
    A.renderRegression();
    await Promise.all([A.renderSpeed(), renderScene()]);
  }

  // Exposed for the browser test and for poking at in the console.
  window.arenaReport = { arena: A, ready: A.start(main) };
})();
