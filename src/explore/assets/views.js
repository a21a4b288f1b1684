// lobe explore: the views drawn from the values the server sent (loaded before app.js, whose
// state, constants and helpers these functions use when called).
'use strict';

// A perceptual-ish ramp from dark blue through red to pale yellow.
const RAMP = [[13, 8, 135], [126, 3, 168], [204, 71, 120], [248, 149, 64], [240, 249, 33]];
function ramp(t) {
  const x = Math.min(1, Math.max(0, t)) * (RAMP.length - 1), k = Math.min(RAMP.length - 2, Math.floor(x)), u = x - k;
  return RAMP[k].map((c, j) => Math.round(c + (RAMP[k + 1][j] - c) * u));
}

// An image of f32 RGB cells (NaN: empty) in a canvas: `colour` maps a cell's RGB to bytes.
function imageCanvas(f, colour) {
  const c = Object.assign(document.createElement('canvas'), { width: IMAGE_RES, height: IMAGE_RES });
  c.style.width = c.style.height = '150px';
  c.style.imageRendering = 'pixelated';
  const g = c.getContext('2d');
  const img = g.createImageData(IMAGE_RES, IMAGE_RES);
  for (let k = 0; k < IMAGE_RES * IMAGE_RES; k++) {
    if (Number.isNaN(f[3 * k])) continue;
    img.data.set([...colour(f[3 * k], f[3 * k + 1], f[3 * k + 2]), 255], 4 * k);
  }
  g.putImageData(img, 0, 0);
  return c;
}

function peakOf(f) {
  let peak = 0;
  for (let k = 0; k < f.length / 3; k++) { const v = luminance(f[3 * k], f[3 * k + 1], f[3 * k + 2]); if (v > peak) peak = v; }
  return peak;
}

// Log colour over DECADES below `peak` (the image's own unless given), and its colour bar.
const logLevel = (v, peak) => (peak > 0 ? Math.max(0, 1 + Math.log10(Math.max(v, 1e-300) / peak) / DECADES) : 0);
function logImage(f, peak = peakOf(f)) {
  return imageCanvas(f, (r, g, b) => ramp(logLevel(luminance(r, g, b), peak)));
}
function logBar(peak) {
  const bar = Object.assign(document.createElement('canvas'), { width: 150, height: 8 });
  const bg = bar.getContext('2d');
  for (let x = 0; x < 150; x++) { bg.fillStyle = `rgb(${ramp(x / 149).join(',')})`; bg.fillRect(x, 0, 1, 8); }
  return [bar, `${fmt(peak * Math.pow(10, -DECADES))} … ${fmt(peak)} 1/sr`];
}
function logPanel(f, caption) {
  const peak = peakOf(f);
  return panel(logImage(f, peak), caption, ...logBar(peak));
}

// The slice's row nearest the chosen θd: rows are cell-centred, θd = (row + ½)·90°/IMAGE_RES.
const sliceRow = () => Math.min(IMAGE_RES - 1, Math.max(0, Math.round(state.td * IMAGE_RES / 90 - 0.5)));
const sliceTheta = (row) => (row + 0.5) * 90 / IMAGE_RES;

// The θh × θd slice at the chosen φd, its θd row marked at both edges, and under it that row as
// a curve f(θh), log over DECADES below the row's own peak (the slice's may lie decades above it,
// at grazing θd), with a gap where the row leaves the hemisphere.
function slicePanel(f, i) {
  const peak = peakOf(f);
  const c = logImage(f, peak);
  const row = sliceRow();
  const g = c.getContext('2d');
  g.fillStyle = '#fff';
  g.fillRect(0, row, 3, 1);
  g.fillRect(IMAGE_RES - 3, row, 3, 1);
  const cut = Array.from({ length: IMAGE_RES }, (_, col) => luminance(...f.slice(3 * (row * IMAGE_RES + col), 3 * (row * IMAGE_RES + col) + 3)));
  probe.sliceCut[i] = cut;
  const plot = Object.assign(document.createElement('canvas'), { width: 150, height: 60, className: 'cut' });
  const pg = plot.getContext('2d');
  pg.strokeStyle = '#ccc';
  pg.strokeRect(0.5, 0.5, 149, 59);
  pg.strokeStyle = COLOURS[i % COLOURS.length];
  pg.lineWidth = 1.5;
  pg.beginPath();
  const rowPeak = cut.reduce((m, v) => (v > m ? v : m), 0);
  let open = false;
  cut.forEach((v, col) => {
    if (Number.isNaN(v)) { open = false; return; }
    const x = (col + 0.5) * 150 / IMAGE_RES, y = 58 - 56 * logLevel(v, rowPeak);
    if (open) pg.lineTo(x, y); else pg.moveTo(x, y);
    open = true;
  });
  pg.stroke();
  const div = panel(c, `θh → × θd ↓ (φd = ${probe.slicePhiD}°)`, ...logBar(peak));
  const range = `${fmt(rowPeak * Math.pow(10, -DECADES))} … ${fmt(rowPeak)} 1/sr`;
  div.append(plot, ...[range, `f(θh →) at θd = ${fmt(sliceTheta(row))}°`].map((t) => Object.assign(document.createElement('div'), { textContent: t })));
  return div;
}

// The lit views: radiance relative to a white Lambertian surface's (π L, so that 1 is white),
// times 2^EV, tone-mapped in each channel, as sRGB.
const TONE_MAPS = {
  // Clipped at white: the page's look before it had a choice.
  clamp: (x) => Math.min(1, x),
  // Reinhard et al. 2002, "Photographic tone reproduction for digital images", eq. 3, L/(1 + L)
  // (the paper maps luminance; here each channel).
  reinhard: (x) => x / (1 + x),
  // Narkowicz 2016, "ACES filmic tone mapping curve": a fit of ACES's reference rendering
  // transform and Rec. 709 output transform (its 2.4 gamma removed), pre-exposed so that 1 maps
  // to about 0.8.
  aces: (x) => Math.min(1, (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)),
};
const display = (r, g, b) => {
  const k = Math.PI * Math.pow(2, state.ev), tone = TONE_MAPS[state.tm];
  return [r, g, b].map((v) => Math.round(255 * srgb(Math.min(1, Math.max(0, tone(Math.max(0, k * v)))))));
};

function panel(canvas, caption, ...below) {
  const div = document.createElement('div');
  const cap = document.createElement('div');
  cap.textContent = caption;
  div.append(canvas, ...below.map((b) => (typeof b === 'string' ? Object.assign(document.createElement('div'), { textContent: b }) : b)), cap);
  return div;
}

function drawImages() {
  probe.sliceCut = [];
  const rows = state.m.map((e, i) => {
    const row = document.createElement('div');
    row.className = 'images';
    const title = document.createElement('div');
    title.className = 'title';
    title.textContent = spec(e);
    title.style.color = COLOURS[i % COLOURS.length];
    const sky = Object.assign(document.createElement('canvas'), { width: IMAGE_RES, height: IMAGE_RES, className: 'sky' });
    sky.style.width = sky.style.height = '150px';
    const lit = imageCanvas(probe.lit[i], display);
    lit.className = 'lit';
    row.append(title,
      logPanel(probe.hemi[i], 'hemisphere of ωo'),
      slicePanel(probe.slice[i], i),
      panel(lit, `${probe.litObject}, point light at θi`),
      panel(sky, 'sphere, white sky: E(μo)'));
    return row;
  });
  $('images').replaceChildren(...rows);
  if (probe.albedo.length === state.m.length) drawSkies(probe.albedo);
}

// Under a uniform white sky of unit radiance a point's radiance is its directional albedo
// E(μo), μo = n·v; E is interpolated in the curve the server computed.
function drawSkies(answers) {
  document.querySelectorAll('#images canvas.sky').forEach((c, i) => {
    const a = answers[i];
    if (!a) return;
    const E = (mu) => {
      const x = mu * a.mu.length - 1, k = Math.max(0, Math.min(a.mu.length - 2, Math.floor(x))), u = Math.max(0, Math.min(1, x - k));
      return [0, 1, 2].map((j) => a.albedo[k][j] * (1 - u) + a.albedo[k + 1][j] * u);
    };
    const f = new Float32Array(3 * IMAGE_RES * IMAGE_RES).fill(NaN);
    for (let row = 0; row < IMAGE_RES; row++) {
      for (let col = 0; col < IMAGE_RES; col++) {
        const x = -1 + (col + 0.5) * 2 / IMAGE_RES, y = 1 - (row + 0.5) * 2 / IMAGE_RES, r2 = x * x + y * y;
        if (r2 <= 1) f.set(E(Math.sqrt(1 - r2)).map((v) => v / Math.PI), 3 * (row * IMAGE_RES + col));
      }
    }
    c.getContext('2d').drawImage(imageCanvas(f, display), 0, 0);
  });
}

function drawAlbedo(answers) {
  const c = $('albedo');
  const g = c.getContext('2d');
  const x0 = 50, y0 = c.height - 30, w = c.width - 70, h = c.height - 50;
  g.clearRect(0, 0, c.width, c.height);
  const top = Math.max(1.05, ...answers.flatMap((a) => a.albedo.map((v) => luminance(...v))));
  g.strokeStyle = '#999'; g.setLineDash([]); g.lineWidth = 1;
  g.strokeRect(x0, y0 - h, w, h);
  g.fillStyle = '#444'; g.font = '12px system-ui, sans-serif';
  g.fillText('μo', x0 + w - 10, y0 + 20); g.fillText('0', x0 - 4, y0 + 14); g.fillText('1', x0 + w - 4, y0 + 14);
  g.fillText(fmt(top), 4, y0 - h + 10); g.fillText('0', 30, y0);
  g.setLineDash([3, 3]); g.beginPath(); g.moveTo(x0, y0 - h / top); g.lineTo(x0 + w, y0 - h / top); g.stroke();
  const rows = answers.map((a, i) => {
    g.strokeStyle = COLOURS[i % COLOURS.length]; g.setLineDash(DASHES[i % DASHES.length]); g.lineWidth = 2;
    g.beginPath();
    a.mu.forEach((mu, k) => { const px = x0 + w * mu, py = y0 - h * luminance(...a.albedo[k]) / top; if (k) g.lineTo(px, py); else g.moveTo(px, py); });
    g.stroke();
    const tr = document.createElement('tr');
    [spec(state.m[i]), a.hemispherical.map(fmt).join(', '), a.hemispherical_error.map(fmt).join(', ')].forEach((t) => {
      const td = document.createElement('td'); td.textContent = t; tr.append(td);
    });
    return tr;
  });
  $('albedo-readout').tBodies[0].replaceChildren(...rows);
}

// The samples view, one row per model in the page's order, titled as the image views' rows: the
// pdf's cells as a log heat map (null: outside the disc), and the draws above the horizon as dots
// on the same equal-area disc (radius √2 sin(θ/2), +x right, +y up); a refused model's row
// shows the refusal instead.
function drawSamples(settled, labels) {
  probe.samplesShown = [];
  const rows = settled.map(({ answer, error }, i) => {
    const row = document.createElement('div');
    row.className = 'images';
    const title = document.createElement('div');
    title.className = 'title';
    title.textContent = labels[i];
    title.style.color = COLOURS[i % COLOURS.length];
    row.append(title);
    if (error) {
      probe.samplesShown.push(null);
      row.append(Object.assign(document.createElement('div'), { className: 'note error', textContent: error.message }));
    } else {
      const [heat, dots] = samplesPanels(answer);
      probe.samplesShown.push(dots.shown);
      row.append(heat, dots.div);
    }
    return row;
  });
  $('samples').replaceChildren(...rows);
}

// One model's heat map of its pdf and its draws' panel, with how many draws it shows.
function samplesPanels(a) {
  const res = a.res;
  const f = new Float32Array(3 * res * res);
  a.pdf_grid.forEach((v, k) => f.fill(v === null ? NaN : v, 3 * k, 3 * k + 3));
  const peak = peakOf(f);
  const pdf = logImage(f, peak);
  pdf.classList.add('pdf');
  const heat = panel(pdf, 'pdf over ωi', ...logBar(peak).map((b) => (typeof b === 'string' ? b.replace('1/sr', '1/sr (pdf)') : b)));
  const size = 300;
  const dots = Object.assign(document.createElement('canvas'), { width: size, height: size, className: 'draws' });
  dots.style.width = dots.style.height = '150px';
  const g = dots.getContext('2d');
  g.fillStyle = '#111';
  g.beginPath(); g.arc(size / 2, size / 2, size / 2, 0, 2 * Math.PI); g.fill();
  g.fillStyle = 'rgba(240, 249, 33, 0.6)';
  let shown = 0;
  a.wi.forEach((w, k) => {
    if (a.delta[k] || a.pdf[k] === 0 || w[2] <= 0) return;
    const s = Math.hypot(w[0], w[1]);
    const r = Math.SQRT2 * Math.sin(Math.acos(Math.min(1, w[2])) / 2);
    const [x, y] = s > 0 ? [r * w[0] / s, r * w[1] / s] : [0, 0];
    g.fillRect((x + 1) / 2 * size - 1, (1 - y) / 2 * size - 1, 2, 2);
    shown += 1;
  });
  const caption = `${a.wi.length} draws (seed ${a.seed}): ${shown} shown, ${a.delta_count} delta (mirror spike), ${a.lost} lost`;
  return [heat, { div: panel(dots, caption), shown }];
}

// The lit sphere under an environment map (POST /api/light): linear radiance in the map's units
// times 2^EV, tone-mapped in each channel as the lit objects are, as sRGB; outside the sphere
// (pixel centres with x² + y² > 1) left empty.
const lightByte = (v) => {
  const k = Math.pow(2, state.ev), tone = TONE_MAPS[state.tm];
  return Math.round(255 * srgb(Math.min(1, Math.max(0, tone(Math.max(0, k * v))))));
};

function lightCanvas(n, colour) {
  const c = Object.assign(document.createElement('canvas'), { width: n, height: n });
  c.style.width = c.style.height = '192px';
  c.style.imageRendering = 'pixelated';
  const g = c.getContext('2d');
  const img = g.createImageData(n, n);
  for (let row = 0; row < n; row++) {
    for (let col = 0; col < n; col++) {
      const x = -1 + (col + 0.5) * 2 / n, y = 1 - (row + 0.5) * 2 / n;
      if (x * x + y * y > 1) continue;
      const k = row * n + col;
      img.data.set([...colour(k), 255], 4 * k);
    }
  }
  g.putImageData(img, 0, 0);
  return c;
}

// Blue (below) through white to red (above), t in [−1, 1].
function diverging(t) {
  const u = Math.min(1, Math.abs(t));
  const far = t < 0 ? [33, 102, 172] : [178, 24, 43];
  return far.map((c) => Math.round(255 + (c - 255) * u));
}

function drawLight(a) {
  const n = a.size;
  const rgb = (img) => (k) => [0, 1, 2].map((c) => lightByte(img[3 * k + c]));
  const panels = [panel(lightCanvas(n, rgb(a.exact)), `exact, ${n}² under ${a.env}`)];
  if (a.split) {
    const lum = (img, k) => luminance(img[3 * k], img[3 * k + 1], img[3 * k + 2]);
    let peak = 0, sum2 = 0, count = 0, rel = 0;
    for (let row = 0; row < n; row++) {
      for (let col = 0; col < n; col++) {
        const x = -1 + (col + 0.5) * 2 / n, y = 1 - (row + 0.5) * 2 / n;
        if (x * x + y * y > 1) continue;
        const k = row * n + col, e = lum(a.exact, k), d = lum(a.split, k) - e;
        peak = Math.max(peak, Math.abs(d)); sum2 += d * d; count += 1;
        if (e > 0) rel = Math.max(rel, Math.abs(d) / e);
      }
    }
    const rms = Math.sqrt(sum2 / Math.max(count, 1));
    probe.lightDifference = { rms, peak, largest_relative: rel };
    panels.push(panel(lightCanvas(n, rgb(a.split)), 'split sum'),
      panel(lightCanvas(n, (k) => diverging(peak > 0 ? (lum(a.split, k) - lum(a.exact, k)) / peak : 0)),
        `split − exact: RMS ${fmt(rms)}, ±${fmt(peak)} at full colour, largest relative ${fmt(rel)}`));
  } else {
    probe.lightDifference = null;
    panels.push(Object.assign(document.createElement('div'), { className: 'note', textContent: `no split sum: ${a.split_note}` }));
  }
  $('light').replaceChildren(...panels);
  probe.lightShown = n;
}
