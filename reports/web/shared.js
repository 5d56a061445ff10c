// Denoise Arena pages: helpers every view shares, defined once. Each view's script
// (speed.js, over_time.js, ghosting.js, tables.js, images.js, regression.js, history.js) adds its
// setup and render functions to window.Arena; app.js (the report) or history.js starts them.
'use strict';

(() => {
  const A = (window.Arena = window.Arena || {});

  A.$ = (id) => document.getElementById(id);

  // el('td', {class: 'x', title: 'y'}, child, 'text', ...)
  A.el = function el(tag, attrs, ...children) {
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
  };

  A.fmt = function fmt(v) {
    if (v === null || v === undefined || Number.isNaN(v)) return '–';
    if (typeof v !== 'number') return String(v);
    const a = Math.abs(v);
    if (a === 0) return '0';
    if (a < 1e-3 || a >= 1e5) return v.toExponential(2);
    return Number(v.toPrecision(4)).toString();
  };
  // A change that rounds to 0.0% but is not zero keeps two significant digits (-0.031%): an
  // interval [-14.5%, -0.0%] excludes zero, and read as if it touched it.
  A.pct = (v) => {
    if (v === null || v === undefined) return '–';
    const p = 100 * v;
    return (p >= 0 ? '+' : '') + (p !== 0 && Math.abs(p) < 0.05 ? p.toPrecision(2) : p.toFixed(1)) + '%';
  };
  // "[lo, hi]" of a 95% interval, or '' when there is none.
  A.interval = (ci) => (Array.isArray(ci) && ci.length === 2 ? `[${A.fmt(ci[0])}, ${A.fmt(ci[1])}]` : '');

  // Vega views by chart name, for the PNG buttons; a re-rendered chart finalizes its old view.
  A.views = {};
  A.dropChart = (name) => {
    if (A.views[name]) {
      A.views[name].finalize();
      delete A.views[name];
    }
  };
  A.embedChart = async function embedChart(name, container, spec) {
    A.dropChart(name);
    container.replaceChildren();
    if (typeof window.vegaEmbed !== 'function') {
      container.append(A.el('p', { class: 'empty', text: 'Charting library not loaded (vega*.min.js missing next to index.html).' }));
      return null;
    }
    // SVG: marks become DOM elements (the browser tests count them); the export action still
    // offers PNG. Source/editor actions would need the network, so they are off.
    const result = await window.vegaEmbed(container, spec, {
      renderer: 'svg',
      actions: { export: true, source: false, compiled: false, editor: false },
    });
    A.views[name] = result.view;
    return result.view;
  };

  A.baseSpec = (extra) => ({
    $schema: 'https://vega.github.io/schema/vega-lite/v6.json',
    config: { font: 'system-ui, sans-serif', axis: { labelFontSize: 11, titleFontSize: 12 }, legend: { labelLimit: 260 } },
    ...extra,
  });

  // A Vega-Lite test for "this datum's field equals value" (value quoted as a JS string).
  A.equalsTest = (field, value) => `datum[${JSON.stringify(field)}] === ${JSON.stringify(value)}`;

  // A colour map ({stops: [[r,g,b], ...]}) as a CSS gradient, for legends.
  A.gradientCss = (map) => `linear-gradient(to right, ${map.stops
    .map((c, i) => `rgb(${c[0]}, ${c[1]}, ${c[2]}) ${((100 * i) / (map.stops.length - 1)).toFixed(2)}%`).join(', ')})`;

  // PNG export of any chart: delegated, since charts come and go with the scene.
  A.setupPngButtons = (fileStem) => {
    document.addEventListener('click', async (e) => {
      const button = e.target.closest('button.png');
      if (!button) return;
      const view = A.views[button.dataset.chart];
      if (!view) return;
      const url = await view.toImageURL('png', 2);
      const a = A.el('a', { href: url, download: `${fileStem()}-${button.dataset.chart}.png` });
      document.body.append(a);
      a.click();
      a.remove();
    });
  };

  // Page start-up for both pages: runs main(), marks body[data-ready] (the browser tests wait for
  // it) and records how long the page took from navigation to ready.
  A.start = (main) => {
    const ready = Promise.resolve()
      .then(main)
      .then(() => {
        A.loadMs = performance.now();
        document.body.dataset.ready = 'true';
      })
      .catch((err) => {
        console.error(err);
        document.body.dataset.ready = 'error';
      });
    return ready;
  };
})();
