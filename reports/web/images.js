// Images: an A/B comparison (split slider, or flip with the F key as in tev) between any two of
// reference, noisy input, a denoiser's output, its FLIP map (magma) and its relative-error map
// (viridis, log scale), with legends; a region the user marks is measured from per-tile data the
// report computed from the kept images; and the grid of every kept image. Every viewport shares
// one zoom/pan; the frame selector offers every kept frame and marks the scene's event frames.
'use strict';

(() => {
  const A = window.Arena;
  const { $, el, fmt } = A;

  // Panels share one zoom: scale s and the translation (x, y) as fractions of the viewport, so a
  // single state drives viewports of any pixel size.
  const viewer = { panels: [], ab: null, showB: false, crop: null, cropping: false };
  const encodePath = (path) => path.split('/').map(encodeURIComponent).join('/');

  function clampZoom(z) {
    const lo = 1 - z.s;  // the image keeps covering its viewport: translation within [1 - s, 0]
    return { s: z.s, x: Math.min(0, Math.max(lo, z.x)), y: Math.min(0, Math.max(lo, z.y)) };
  }

  function applyZoom() {
    const { s, x, y } = A.state.zoom;
    // translate() percentages are of the element's own box, which is the viewport's size.
    const t = `translate(${(x * 100).toFixed(4)}%, ${(y * 100).toFixed(4)}%) scale(${s.toFixed(4)})`;
    for (const e of document.querySelectorAll('#images [data-zoom]')) e.style.transform = t;
  }

  // A point of a viewport in image coordinates (fractions of the image), through the zoom.
  function toImage(vp, clientX, clientY) {
    const r = vp.getBoundingClientRect();
    const z = A.state.zoom;
    const u = (clientX - r.left) / r.width, v = (clientY - r.top) / r.height;
    return { u: Math.min(1, Math.max(0, (u - z.x) / z.s)), v: Math.min(1, Math.max(0, (v - z.y) / z.s)) };
  }

  // Wheel zooms about the cursor, drag pans (or, in crop mode on the A/B view, marks a region).
  function attachZoom(container) {
    container.addEventListener('wheel', (e) => {
      const vp = e.target.closest('.viewport');
      if (!vp) return;
      e.preventDefault();
      const r = vp.getBoundingClientRect();
      const u = (e.clientX - r.left) / r.width, v = (e.clientY - r.top) / r.height;
      const z = A.state.zoom;
      const s = Math.min(64, Math.max(1, z.s * Math.exp(-e.deltaY * 0.0015)));
      // Keep the image point under the cursor fixed: (u - x) / s is invariant.
      A.state.zoom = clampZoom({ s, x: u - ((u - z.x) / z.s) * s, y: v - ((v - z.y) / z.s) * s });
      applyZoom();
    }, { passive: false });
    let drag = null;
    container.addEventListener('pointerdown', (e) => {
      const vp = e.target.closest('.viewport');
      if (!vp || e.button !== 0) return;
      const r = vp.getBoundingClientRect();
      const crop = viewer.cropping && vp.id === 'ab-view';
      drag = { vp, w: r.width, h: r.height, px: e.clientX, py: e.clientY, crop, from: crop ? toImage(vp, e.clientX, e.clientY) : null };
      vp.classList.add('dragging');
      vp.setPointerCapture(e.pointerId);
    });
    container.addEventListener('pointermove', (e) => {
      if (!drag) return;
      if (drag.crop) {
        const to = toImage(drag.vp, e.clientX, e.clientY);
        setCrop({ u0: Math.min(drag.from.u, to.u), v0: Math.min(drag.from.v, to.v), u1: Math.max(drag.from.u, to.u), v1: Math.max(drag.from.v, to.v) }, false);
        return;
      }
      const z = A.state.zoom;
      A.state.zoom = clampZoom({ s: z.s, x: z.x + (e.clientX - drag.px) / drag.w, y: z.y + (e.clientY - drag.py) / drag.h });
      drag.px = e.clientX;
      drag.py = e.clientY;
      applyZoom();
    });
    const end = () => {
      if (!drag) return;
      drag.vp.classList.remove('dragging');
      if (drag.crop && viewer.crop) measureCrop();
      drag = null;
    };
    container.addEventListener('pointerup', end);
    container.addEventListener('pointercancel', end);
  }

  // ------------------------------------------------------------ A/B comparison

  function setShowB(show) {
    viewer.showB = show;
    $('ab-view').classList.toggle('show-b', show);
    $('ab-flip').textContent = show ? 'Showing B — flip to A (F)' : 'Showing A — flip to B (F)';
  }

  function setMode(mode) {
    $('ab-view').dataset.mode = mode;
    $('ab-split').disabled = mode !== 'split';
    $('ab-flip').disabled = mode !== 'flip';
    setShowB(false);
  }

  function setSplit(percent) {
    $('ab-view').style.setProperty('--split', `${percent}%`);
  }

  // Which panel each side shows: a select of every panel of the scene, by index.
  function abPanel(side) {
    const v = A.sceneByName[A.state.scene].viewer;
    return v.panels[Number($(`ab-${side}`).value)];
  }

  function updateAb() {
    const scene = A.sceneByName[A.state.scene];
    if (!scene || !scene.viewer || !scene.viewer.panels.length) return;
    for (const side of ['a', 'b']) {
      const panel = abPanel(side);
      const img = $(`ab-img-${side}`);
      const src = panel && panel.srcs[A.state.frame];
      img.hidden = !src;
      if (src) img.src = encodePath(src);
      else img.removeAttribute('src');
      img.classList.toggle('exposed', !!panel && ['reference', 'noisy', 'output'].includes(panel.kind));
      $(`ab-tag-${side}`).textContent = `${side.toUpperCase()}: ${panel ? panel.title : '–'}${src ? '' : ' (not kept for this frame)'}`;
    }
  }

  A.setupImages = function setupImages() {
    $('frame-select').addEventListener('change', (e) => {
      A.state.frame = e.target.value;
      updateImageSources();
      updateAb();
      if (viewer.crop) measureCrop();
    });
    const exposure = $('exposure');
    exposure.addEventListener('input', () => {
      const ev = Number(exposure.value);
      $('images').style.setProperty('--exposure', String(Math.pow(2, ev)));
      $('exposure-value').textContent = `${ev > 0 ? '+' : ''}${ev} EV`;
    });
    $('show-flip').addEventListener('change', (e) => $('viewer').classList.toggle('no-flip', !e.target.checked));
    $('show-relerr').addEventListener('change', (e) => $('viewer').classList.toggle('no-relerr', !e.target.checked));
    $('zoom-reset').addEventListener('click', () => {
      A.state.zoom = { s: 1, x: 0, y: 0 };
      applyZoom();
    });
    $('ab-a').addEventListener('change', updateAb);
    $('ab-b').addEventListener('change', updateAb);
    $('ab-mode').addEventListener('change', (e) => setMode(e.target.value));
    $('ab-split').addEventListener('input', (e) => setSplit(e.target.value));
    $('ab-flip').addEventListener('click', () => setShowB(!viewer.showB));
    $('ab-swap').addEventListener('click', () => {
      const a = $('ab-a').value;
      $('ab-a').value = $('ab-b').value;
      $('ab-b').value = a;
      updateAb();
    });
    // tev-style flipping: F (or the button) switches between A and B while in flip mode.
    document.addEventListener('keydown', (e) => {
      if (e.key !== 'f' && e.key !== 'F') return;
      if (e.ctrlKey || e.metaKey || e.altKey || /^(INPUT|SELECT|TEXTAREA)$/.test((e.target.tagName || '')) && e.target.type !== 'range') return;
      if ($('ab-view').dataset.mode !== 'flip') setMode('flip'), ($('ab-mode').value = 'flip');
      setShowB(!viewer.showB);
    });
    $('crop-mode').addEventListener('click', () => {
      viewer.cropping = !viewer.cropping;
      $('crop-mode').classList.toggle('active', viewer.cropping);
      $('crop-mode').textContent = viewer.cropping ? 'Marking: drag on A/B (click to stop)' : 'Mark a region';
      $('ab-view').classList.toggle('cropping', viewer.cropping);
    });
    $('crop-clear').addEventListener('click', () => setCrop(null));
    attachZoom($('viewer'));
    attachZoom($('ab-wrap'));
    renderLegends();
    setMode('split');
    setSplit(50);
    A.onSelect(() => {
      chooseAbDefaults();
      updateAb();
    });
  };

  function renderLegends() {
    const maps = A.D.colorMaps;
    if (!maps) return;
    const legend = (key, ticks) => {
      const m = maps[key];
      return el('div', { class: 'legend', 'data-map': key },
        el('div', { class: 'legend-title', text: `${key === 'flip' ? 'FLIP maps' : 'Relative-error maps'} (${m.name}): ${m.title}` }),
        el('div', { class: 'legend-bar', style: `background: ${A.gradientCss(m)}` }),
        el('div', { class: 'legend-ticks' }, ticks.map(([pos, text]) => el('span', { style: `left: ${pos}%`, text }))));
    };
    const logTicks = [];
    const lo = Math.log10(maps.relerr.min), hi = Math.log10(maps.relerr.max);
    for (let e = Math.ceil(lo); e <= hi; ++e) logTicks.push([(100 * (e - lo)) / (hi - lo), `1e${e}`]);
    $('map-legends').replaceChildren(
      legend('flip', [0, 0.25, 0.5, 0.75, 1].map((v) => [100 * v, String(v)])),
      legend('relerr', logTicks),
      el('p', { class: 'note', text: `Fixed scales, the same for every frame and method: FLIP ${maps.flip.min}–${maps.flip.max} linear; relative squared error ${maps.relerr.min}–${maps.relerr.max} on a log scale, clamped at both ends.` }));
  }

  function chooseAbDefaults() {
    const v = A.sceneByName[A.state.scene].viewer;
    if (!v || !v.panels.length) return;
    const find = (kind, label) => v.panels.findIndex((p) => p.kind === kind && (label === undefined || p.label === label));
    let a = A.state.selected ? find('output', A.state.selected) : -1;
    if (a < 0) a = find('output');
    if (a < 0) a = find('noisy');
    let b = find('reference');
    if (b < 0 || b === a) b = a === 0 ? Math.min(1, v.panels.length - 1) : 0;
    $('ab-a').value = String(Math.max(0, a));
    $('ab-b').value = String(b);
  }

  // ------------------------------------------------------------ crops

  const tileScripts = {};
  function loadTiles(src) {
    if (!tileScripts[src]) {
      tileScripts[src] = new Promise((resolve, reject) => {
        const s = el('script', { src: encodePath(src) });
        s.onload = () => resolve(window.ARENA_TILES[src]);
        s.onerror = () => reject(new Error(`${src} could not be loaded`));
        document.head.append(s);
      });
    }
    return tileScripts[src];
  }

  function setCrop(crop, measure = true) {
    viewer.crop = crop;
    const r = $('crop-rect');
    r.hidden = !viewer.crop;
    if (viewer.crop) {
      const c = viewer.crop;
      Object.assign(r.style, { left: `${100 * c.u0}%`, top: `${100 * c.v0}%`, width: `${100 * (c.u1 - c.u0)}%`, height: `${100 * (c.v1 - c.v0)}%` });
    }
    if (!crop) $('crop-result').replaceChildren();
    else if (measure) measureCrop();
  }

  // The crop's metrics from the report's per-tile means (computed from the kept images and values):
  // the tiles whose centre lies in the region (at least the tile under its centre), weighted by
  // their pixel counts.
  async function measureCrop() {
    const out = $('crop-result');
    const scene = A.sceneByName[A.state.scene];
    const crops = scene.viewer && scene.viewer.crops;
    const src = crops && crops.files[A.state.frame];
    if (!src) {
      out.replaceChildren(el('p', { class: 'empty', text: 'No per-tile data for this frame (its reference image was not kept).' }));
      return;
    }
    const T = await loadTiles(src);
    const c = viewer.crop;
    if (!c) return;
    const tiles = [];
    for (let row = 0; row < T.rows; ++row)
      for (let col = 0; col < T.cols; ++col) {
        const cu = Math.min((col + 0.5) * T.tile, T.width) / T.width, cv = Math.min((row + 0.5) * T.tile, T.height) / T.height;
        if (cu >= c.u0 && cu <= c.u1 && cv >= c.v0 && cv <= c.v1) tiles.push(row * T.cols + col);
      }
    if (!tiles.length) {
      const col = Math.min(T.cols - 1, Math.floor((((c.u0 + c.u1) / 2) * T.width) / T.tile));
      const row = Math.min(T.rows - 1, Math.floor((((c.v0 + c.v1) / 2) * T.height) / T.tile));
      tiles.push(row * T.cols + col);
    }
    const pixels = tiles.reduce((s, k) => s + T.counts[k], 0);
    const mean = (values) => (values ? tiles.reduce((s, k) => s + values[k] * T.counts[k], 0) / pixels : null);
    const cols = tiles.map((k) => k % T.cols), rows = tiles.map((k) => Math.floor(k / T.cols));
    const x0 = Math.min(...cols) * T.tile, x1 = Math.min(T.width, (Math.max(...cols) + 1) * T.tile);
    const y0 = Math.min(...rows) * T.tile, y1 = Math.min(T.height, (Math.max(...rows) + 1) * T.tile);
    const psnr = (mse) => (mse === null ? null : mse > 0 ? Math.min(100, 10 * Math.log10(1 / mse)) : 100);
    const entries = Object.entries(T.panels).sort(([a], [b]) => (a === 'noisy' ? -1 : b === 'noisy' ? 1 : 0));
    // relMSE from the run's unclamped values, or (runs that kept only the map) decoded from the
    // map, which stops at 10: with such pixels in the region the figure is a lower bound.
    const clampedIn = (v) => (v.relerrClamped ? tiles.reduce((s, k) => s + v.relerrClamped[k], 0) : 0);
    const fromMap = entries.filter(([, v]) => v.relerr && v.relerrClamped).map(([key]) => (key === 'noisy' ? 'noisy input' : key));
    const exact = entries.some(([, v]) => v.relerr && !v.relerrClamped);
    const relMseText = (v) => (v.relerr && clampedIn(v) > 0 ? `≥ ${fmt(mean(v.relerr))}` : fmt(mean(v.relerr)));
    out.replaceChildren(
      el('p', { class: 'note', text: `Region x ${x0}–${x1}, y ${y0}–${y1} px (${pixels} pixels, ${tiles.length} tiles of ${T.tile} px), frame ${A.state.frame}. ` +
        'Computed in the report from the kept images: PSNR of the display PNG against the reference PNG, LDR-FLIP decoded from the magma map (1/255 steps), ' +
        (exact ? 'relMSE from the per-pixel relative squared errors the run kept (as the run computes it, to 4 digits)' : '') +
        (fromMap.length ? `${exact ? '; for ' + fromMap.join(', ') + ', which kept none, ' : 'relMSE '}decoded from the relative-error map ` +
          '(log-quantised, ±5%; the map stops at 10, so a region with pixels beyond it reads ≥, a lower bound)' : '') + '.' }),
      el('table', { class: 'data crop-table' },
        el('thead', {}, el('tr', {}, ['', 'PSNR display (dB) ↑', 'LDR-FLIP ↓', 'relMSE ↓'].map((t, i) => el('th', { class: i ? null : 'first', text: t })))),
        el('tbody', {}, entries.map(([key, v]) => el('tr', { 'data-label': key },
          el('td', { class: 'first', text: key === 'noisy' ? 'noisy input' : key }),
          el('td', { text: fmt(psnr(mean(v.sqerr))) }), el('td', { text: fmt(mean(v.flip)) }), el('td', { text: relMseText(v) }))))));
  }

  // ------------------------------------------------------------ grid of every image

  A.renderImages = function renderImages() {
    const grid = $('viewer');
    const frameSel = $('frame-select');
    viewer.panels = [];
    grid.replaceChildren();
    frameSel.replaceChildren();
    for (const side of ['a', 'b']) $(`ab-${side}`).replaceChildren();
    setCrop(null);
    const scene = A.sceneByName[A.state.scene];
    const v = scene && scene.viewer;
    $('ab-section').hidden = !v || !v.panels.length;
    if (!v || !v.panels.length) {
      grid.append(el('p', { class: 'empty', text: 'No images were kept for this scene (run with --keep-frames chosen or all).' }));
      return;
    }
    // Every kept frame; the auto-chosen ones and the event frames say so.
    for (const f of v.frames) {
      const tags = [f.chosen ? 'auto' : null, f.events ? `⚑ ${f.events.join(', ')}` : null].filter(Boolean);
      frameSel.append(el('option', { value: String(f.frame), class: f.events ? 'event' : null, 'data-event': f.events ? 'true' : null,
        text: `frame ${f.frame}${tags.length ? ` (${tags.join('; ')})` : ''}` }));
    }
    const frames = v.frames.map((f) => String(f.frame));
    if (!frames.includes(A.state.frame)) {
      const firstChosen = v.frames.find((f) => f.chosen);
      A.state.frame = String((firstChosen || v.frames[0]).frame);
    }
    frameSel.value = A.state.frame;
    for (const side of ['a', 'b'])
      $(`ab-${side}`).append(...v.panels.map((p, i) => el('option', { value: String(i), text: p.kind === 'noisy' || p.kind === 'reference' ? p.title : `${p.title}${p.kind === 'output' ? ' · output' : ''}` })));
    $('ab-view').style.aspectRatio = `${scene.width} / ${scene.height}`;
    chooseAbDefaults();
    updateAb();

    const makePanel = (panel) => {
      const viewport = el('div', { class: 'viewport', style: `aspect-ratio: ${scene.width} / ${scene.height}` });
      const img = el('img', { loading: 'lazy', decoding: 'async', alt: panel.title, draggable: 'false', 'data-zoom': true });
      const missing = el('div', { class: 'missing', text: 'no image for this frame', hidden: true });
      viewport.append(img, missing);
      const exposed = panel.kind === 'reference' || panel.kind === 'noisy' || panel.kind === 'output';
      const fig = el('figure', { class: `panel ${panel.kind}${exposed ? ' exposed' : ''}`, 'data-kind': panel.kind, 'data-label': panel.label || '' },
        viewport, el('figcaption', { title: panel.title, text: panel.title }));
      viewer.panels.push({ panel, img, missing });
      return fig;
    };
    // Row 1: reference and noisy input; then one row per label: output, FLIP map, relative error.
    const byKind = (k, label) => v.panels.find((p) => p.kind === k && (label === undefined || p.label === label));
    const top = ['reference', 'noisy'].map((k) => byKind(k)).filter(Boolean);
    grid.append(el('div', { class: 'row-label', text: 'reference and input' }), ...top.map(makePanel));
    for (let i = top.length; i < 3; ++i) grid.append(el('div', { class: 'panel spacer' }));
    const labels = [...new Set(v.panels.filter((p) => p.label).map((p) => p.label))];
    for (const label of labels) {
      grid.append(el('div', { class: 'row-label', text: label }));
      for (const k of ['output', 'flip', 'relerr']) {
        const p = byKind(k, label);
        grid.append(p ? makePanel(p) : el('div', { class: `panel spacer ${k}` }));
      }
    }
    updateImageSources();
    applyZoom();
  };

  function updateImageSources() {
    for (const { panel, img, missing } of viewer.panels) {
      const src = panel.srcs[A.state.frame];
      img.hidden = !src;
      missing.hidden = !!src;
      if (src) img.src = encodePath(src);
      else img.removeAttribute('src');
    }
  }
})();
