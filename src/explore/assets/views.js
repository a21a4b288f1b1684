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

// Log colour over DECADES below the image's peak, with its colour bar.
function logPanel(f, caption) {
  const peak = peakOf(f);
  const c = imageCanvas(f, (r, g, b) => ramp(peak > 0 ? 1 + Math.log10(Math.max(luminance(r, g, b), 1e-300) / peak) / DECADES : 0));
  const bar = Object.assign(document.createElement('canvas'), { width: 150, height: 8 });
  const bg = bar.getContext('2d');
  for (let x = 0; x < 150; x++) { bg.fillStyle = `rgb(${ramp(x / 149).join(',')})`; bg.fillRect(x, 0, 1, 8); }
  return panel(c, caption, bar, `${fmt(peak * Math.pow(10, -DECADES))} … ${fmt(peak)} 1/sr`);
}

// Radiance relative to a white Lambertian surface's (π L), clipped at 1, as sRGB.
const display = (r, g, b) => [r, g, b].map((v) => Math.round(255 * srgb(Math.min(1, Math.max(0, Math.PI * v)))));

function panel(canvas, caption, ...below) {
  const div = document.createElement('div');
  const cap = document.createElement('div');
  cap.textContent = caption;
  div.append(canvas, ...below.map((b) => (typeof b === 'string' ? Object.assign(document.createElement('div'), { textContent: b }) : b)), cap);
  return div;
}

function drawImages() {
  const rows = state.m.map((e, i) => {
    const row = document.createElement('div');
    row.className = 'images';
    const title = document.createElement('div');
    title.className = 'title';
    title.textContent = spec(e);
    title.style.color = COLOURS[i % COLOURS.length];
    const sky = Object.assign(document.createElement('canvas'), { width: IMAGE_RES, height: IMAGE_RES, className: 'sky' });
    sky.style.width = sky.style.height = '150px';
    row.append(title,
      logPanel(probe.hemi[i], 'hemisphere of ωo'),
      logPanel(probe.slice[i], 'θh → × θd ↓ (φd = 90°)'),
      panel(imageCanvas(probe.sphere[i], display), 'sphere, point light at θi'),
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

// The 3D lobe: the point at radius ρ(f) along each ωo of the server's (θo, φo) mesh, with ρ the
// polar plot's radius (log or linear, common peak), drawn as rings and meridians, orthographic,
// turned by dragging.
let view3d = { yaw: -0.6, pitch: 1.1 };
function drawLobe() {
  const c = $('lobe3d');
  const g = c.getContext('2d');
  g.clearRect(0, 0, c.width, c.height);
  if (!probe.lobe) return;
  const n = IMAGE_RES;
  const scale = state.cos ? Math.cos(state.ti * Math.PI / 180) : 1;
  const lum = probe.lobe.map((f) => { const v = new Float64Array(n * n); for (let k = 0; k < n * n; k++) v[k] = luminance(f[3 * k], f[3 * k + 1], f[3 * k + 2]) * scale; return v; });
  const peak = Math.max(1e-30, ...lum.map((v) => v.reduce((m, x) => (x > m ? x : m), 0)));
  const radius = (v) => (state.log ? Math.max(0, 1 + Math.log10(Math.max(v, 1e-300) / peak) / DECADES) : Math.max(0, v / peak));
  const R = Math.min(c.width, c.height) * 0.42, cx = c.width / 2, cy = c.height * 0.62;
  const [cy_, sy] = [Math.cos(view3d.yaw), Math.sin(view3d.yaw)], [cp, sp] = [Math.cos(view3d.pitch), Math.sin(view3d.pitch)];
  const project = (x, y, z) => { const x1 = cy_ * x - sy * y, y1 = sy * x + cy_ * y; return [cx + R * x1, cy - R * (cp * z - sp * y1)]; };
  const point = (v, row, col) => {
    const t = (row + 0.5) * Math.PI / 2 / n, p = col * 2 * Math.PI / n, r = radius(v[row * n + (col % n)]);
    return project(r * Math.sin(t) * Math.cos(p), r * Math.sin(t) * Math.sin(p), r * Math.cos(t));
  };
  g.lineWidth = 1;
  g.strokeStyle = '#bbb';
  g.setLineDash([]);
  g.beginPath();
  for (let k = 0; k <= 64; k++) { const [x, y] = project(Math.cos(k * Math.PI / 32), Math.sin(k * Math.PI / 32), 0); if (k) g.lineTo(x, y); else g.moveTo(x, y); }
  g.stroke();
  const ti = state.ti * Math.PI / 180;
  g.strokeStyle = '#f0a000';
  g.beginPath(); g.moveTo(...project(0, 0, 0)); g.lineTo(...project(-Math.sin(ti), 0, Math.cos(ti))); g.stroke();
  lum.forEach((v, i) => {
    g.strokeStyle = COLOURS[i % COLOURS.length];
    g.globalAlpha = 0.6;
    for (let row = 0; row < n; row += 4) {
      g.beginPath();
      for (let col = 0; col <= n; col++) { const [x, y] = point(v, row, col); if (col) g.lineTo(x, y); else g.moveTo(x, y); }
      g.stroke();
    }
    for (let col = 0; col < n; col += 4) {
      g.beginPath();
      for (let row = 0; row < n; row++) { const [x, y] = point(v, row, col); if (row) g.lineTo(x, y); else g.moveTo(x, y); }
      g.stroke();
    }
    g.globalAlpha = 1;
  });
}

function dragLobe() {
  const c = $('lobe3d');
  let last = null;
  c.addEventListener('pointerdown', (e) => { last = [e.clientX, e.clientY]; c.setPointerCapture(e.pointerId); });
  c.addEventListener('pointerup', () => { last = null; });
  c.addEventListener('pointermove', (e) => {
    if (!last) return;
    view3d.yaw += (e.clientX - last[0]) * 0.01;
    view3d.pitch = Math.min(Math.PI / 2, Math.max(0, view3d.pitch + (e.clientY - last[1]) * 0.01));
    last = [e.clientX, e.clientY];
    drawLobe();
  });
}

