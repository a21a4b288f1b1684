// lobe explore: the 3D lobe drawn from the server's (θo, φo) mesh (loaded before app.js, whose
// state, constants and helpers these functions use when called).
'use strict';

// The viewer turns about the normal (yaw) and rises above the horizon (pitch: 0 from the side,
// π/2 from above); the view is orthographic. At first he stands behind the light and a little to
// its side (azimuth −124°), 63° up, so that a lobe about the mirror direction leans away from him.
let view3d = { yaw: 0.6, pitch: 1.1 };

// A point of the lobe's frame (z the normal, the light on the −x side) in view coordinates:
// right, up, towards the viewer. The three form a right-handed frame, so the picture is the
// lobe's, not its mirror image (from above, +y lies a quarter turn anticlockwise of +x).
function toView(x, y, z) {
  const [cy, sy] = [Math.cos(view3d.yaw), Math.sin(view3d.yaw)];
  const [cp, sp] = [Math.cos(view3d.pitch), Math.sin(view3d.pitch)];
  const x1 = cy * x - sy * y, y1 = sy * x + cy * y;
  return [x1, sp * y1 + cp * z, sp * z - cp * y1];
}

// The shaded surface's light, in view coordinates (up, left, in front of the viewer, as a
// photographer's key light), so that the lobe stays lit as it turns; AMBIENT keeps faces turned
// away from it visible.
const LIGHT_3D = (() => { const v = [-0.35, 0.6, 0.72], l = Math.hypot(...v); return v.map((c) => c / l); })();
const AMBIENT = 0.3;
const SEE_THROUGH = 0.55;       // the opacity of each model's surface where several are drawn

const rgbOf = (hexColour) => [1, 3, 5].map((k) => parseInt(hexColour.slice(k, k + 2), 16));

// The point at radius ρ(f) along each ωo of the mesh, with ρ the polar plot's radius (log or
// linear, common peak): row r at θo = (r + ½)·90°/n, column c at φo = c·360°/n, each ring closed.
// Shaded (the default): a surface, each face in its model's colour times Lambert's cosine to
// LIGHT_3D, with a depth buffer; several models' surfaces are drawn see-through (SEE_THROUGH),
// so that a lobe inside another shows. Wireframe: every fourth ring and meridian.
function drawLobe() {
  const c = $('lobe3d');
  const g = c.getContext('2d');
  g.clearRect(0, 0, c.width, c.height);
  probe.lobeFaces = 0;
  if (!probe.lobe) return;
  const n = IMAGE_RES;
  const scale = state.cos ? Math.cos(state.ti * Math.PI / 180) : 1;
  const lum = probe.lobe.map((f) => { const v = new Float64Array(n * n); for (let k = 0; k < n * n; k++) v[k] = luminance(f[3 * k], f[3 * k + 1], f[3 * k + 2]) * scale; return v; });
  const peak = Math.max(1e-30, ...lum.map((v) => v.reduce((m, x) => (x > m ? x : m), 0)));
  const radius = (v) => (state.log ? Math.max(0, 1 + Math.log10(Math.max(v, 1e-300) / peak) / DECADES) : Math.max(0, v / peak));
  const R = Math.min(c.width, c.height) * 0.42, cx = c.width / 2, cy = c.height * 0.62;
  const screen = (p) => [cx + R * p[0], cy - R * p[1]];
  probe.lobePoint = (x, y, z) => screen(toView(x, y, z));
  // Each model's points in view coordinates: 3 numbers at 3·(row·(n + 1) + col), column n
  // closing the ring.
  const meshes = lum.map((v) => {
    const m = new Float64Array(3 * n * (n + 1));
    for (let row = 0; row < n; row++) {
      for (let col = 0; col <= n; col++) {
        const t = (row + 0.5) * Math.PI / 2 / n, p = col * 2 * Math.PI / n, r = radius(v[row * n + (col % n)]);
        m.set(toView(r * Math.sin(t) * Math.cos(p), r * Math.sin(t) * Math.sin(p), r * Math.cos(t)), 3 * (row * (n + 1) + col));
      }
    }
    return m;
  });
  g.lineWidth = 1;
  g.strokeStyle = '#bbb';
  g.setLineDash([]);
  g.beginPath();
  for (let k = 0; k <= 64; k++) { const [x, y] = screen(toView(Math.cos(k * Math.PI / 32), Math.sin(k * Math.PI / 32), 0)); if (k) g.lineTo(x, y); else g.moveTo(x, y); }
  g.stroke();
  if (state.wire) drawWireframe(g, meshes, screen); else probe.lobeFaces = drawShaded(g, meshes, { R, cx, cy });
  const ti = state.ti * Math.PI / 180;
  g.strokeStyle = '#f0a000';
  g.lineWidth = 2;
  g.beginPath(); g.moveTo(...screen(toView(0, 0, 0))); g.lineTo(...screen(toView(-Math.sin(ti), 0, Math.cos(ti)))); g.stroke();
}

function drawWireframe(g, meshes, screen) {
  const n = IMAGE_RES;
  const at = (m, row, col) => screen(m.subarray(3 * (row * (n + 1) + col), 3 * (row * (n + 1) + col) + 3));
  meshes.forEach((m, i) => {
    g.strokeStyle = COLOURS[i % COLOURS.length];
    g.globalAlpha = 0.6;
    for (let row = 0; row < n; row += 4) {
      g.beginPath();
      for (let col = 0; col <= n; col++) { const [x, y] = at(m, row, col); if (col) g.lineTo(x, y); else g.moveTo(x, y); }
      g.stroke();
    }
    for (let col = 0; col < n; col += 4) {
      g.beginPath();
      for (let row = 0; row < n; row++) { const [x, y] = at(m, row, col); if (row) g.lineTo(x, y); else g.moveTo(x, y); }
      g.stroke();
    }
    g.globalAlpha = 1;
  });
}

// The shaded surfaces are rendered at this many times the canvas's resolution and scaled down,
// so that each pixel of the canvas averages SUPERSAMPLE² samples: antialiased edges.
const SUPERSAMPLE = 2;
// What the renderer reuses from one frame to the next: an image, its depth buffer (both left
// clear after each use) and the canvas that scales it down.
let shadedBuffers = null;

// Renders each model's surface (every quad of its mesh as two triangles, and a fan of triangles
// over the pole) into an image of its own with a depth buffer, so that its nearest face shows;
// each face is flat, in the model's colour times Lambert's cosine of its outward normal to
// LIGHT_3D (AMBIENT where it faces away from the light). The images are scaled down onto the
// canvas one over another, each see-through where there are several models. Returns the number
// of faces drawn, those turned away from the viewer included.
//
// A face turned away from the viewer is not rasterized: the lobe is star-shaped about the origin
// (one radius along each direction), so its outward normal n has n·p > 0 at every point p, and
// with the horizon's disc it closes a solid that the viewer, never below the horizon, sees from
// outside, where a face turned away lies behind one turned towards him.
function drawShaded(g, meshes, { R, cx, cy }) {
  const n = IMAGE_RES, S = SUPERSAMPLE, w = g.canvas.width * S, h = g.canvas.height * S;
  if (!shadedBuffers || shadedBuffers.image.width !== w || shadedBuffers.image.height !== h) {
    const canvas = Object.assign(document.createElement('canvas'), { width: w, height: h });
    shadedBuffers = { canvas, image: new ImageData(w, h), depth: new Float32Array(w * h).fill(-Infinity) };
  }
  const { canvas, image, depth } = shadedBuffers;
  const px = image.data;
  // The pixels a model's faces cover, [x0, y0, x1, y1] (fillTriangle widens it), so that only
  // they are copied, scaled down and cleared.
  const box = [w, h, 0, 0];
  // The supersampled image's pixels per unit of view coordinates, and where the origin lies.
  const [ks, ox, oy] = [R * S, cx * S, cy * S];
  const [lx, ly, lz] = LIGHT_3D;
  let faces = 0;
  meshes.forEach((m, i) => {
    box.splice(0, 4, w, h, 0, 0);
    const rgb = rgbOf(COLOURS[i % COLOURS.length]);
    // The pole (θo = 0) lies between the first ring's points: their mean, put after the mesh.
    const points = new Float64Array(m.length + 3);
    points.set(m);
    for (let col = 0; col < n; col++) for (let k = 0; k < 3; k++) points[m.length + k] += m[3 * col + k] / n;
    const pole = m.length / 3;
    // The face of points a, b, c (a triangle) or a, b, c, d (a quad, split along a–c), by index.
    const face = (a, b, c, d) => {
      const P = (p, k) => points[3 * p + k];
      // The normal of a quad from its diagonals, of a triangle from two edges.
      const [e, f] = d === undefined ? [b, c] : [c, d];
      const [o, q] = d === undefined ? [a, a] : [a, b];
      const ux = P(e, 0) - P(o, 0), uy = P(e, 1) - P(o, 1), uz = P(e, 2) - P(o, 2);
      const vx = P(f, 0) - P(q, 0), vy = P(f, 1) - P(q, 1), vz = P(f, 2) - P(q, 2);
      let nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
      const len = Math.hypot(nx, ny, nz);
      if (!(len > 1e-12)) return; // shrunk to a point or a line (f below the log scale's floor)
      faces += 1;
      // Outward: n·p > 0 at p, the sum of three corners (three times their centre).
      const sx = P(a, 0) + P(b, 0) + P(c, 0), sy = P(a, 1) + P(b, 1) + P(c, 1), sz = P(a, 2) + P(b, 2) + P(c, 2);
      const out = (nx * sx + ny * sy + nz * sz < 0 ? -1 : 1) / len;
      [nx, ny, nz] = [nx * out, ny * out, nz * out];
      if (nz <= 0) return;
      const shade = AMBIENT + (1 - AMBIENT) * Math.max(0, nx * lx + ny * ly + nz * lz);
      const colour = [Math.round(rgb[0] * shade), Math.round(rgb[1] * shade), Math.round(rgb[2] * shade)];
      const X = (p) => ox + ks * P(p, 0), Y = (p) => oy - ks * P(p, 1), Z = (p) => P(p, 2);
      fillTriangle(px, depth, box, w, h, X(a), Y(a), Z(a), X(b), Y(b), Z(b), X(c), Y(c), Z(c), colour);
      if (d !== undefined) fillTriangle(px, depth, box, w, h, X(a), Y(a), Z(a), X(c), Y(c), Z(c), X(d), Y(d), Z(d), colour);
    };
    const at = (row, col) => row * (n + 1) + col;
    for (let col = 0; col < n; col++) {
      face(pole, at(0, col), at(0, col + 1));
      for (let row = 0; row + 1 < n; row++) face(at(row, col), at(row, col + 1), at(row + 1, col + 1), at(row + 1, col));
    }
    // Whole S × S blocks, each one pixel of the canvas.
    const [bx, by] = [S * Math.floor(box[0] / S), S * Math.floor(box[1] / S)];
    const [bw, bh] = [Math.min(w, S * Math.ceil((box[2] + 1) / S)) - bx, Math.min(h, S * Math.ceil((box[3] + 1) / S)) - by];
    if (bw <= 0 || bh <= 0) return;
    canvas.getContext('2d').putImageData(image, 0, 0, bx, by, bw, bh);
    g.globalAlpha = meshes.length === 1 ? 1 : SEE_THROUGH;
    g.imageSmoothingEnabled = true;
    g.drawImage(canvas, bx, by, bw, bh, bx / S, by / S, bw / S, bh / S);
    g.globalAlpha = 1;
    for (let y = by; y < by + bh; y++) {
      px.fill(0, 4 * (y * w + bx), 4 * (y * w + bx + bw));
      depth.fill(-Infinity, y * w + bx, y * w + bx + bw);
    }
  });
  return faces;
}

// A pixel on a shared edge falls inside both triangles (its barycentric weight is 0 for both),
// so that no crack opens between faces; this allowance keeps one whose weight rounds to just
// below 0.
const EDGE_ALLOWANCE = -1e-9;

// Fills the triangle (ax, ay), (bx, by), (cx, cy) (pixels, with depths az, bz, cz towards the
// viewer) where it is nearer than what the depth buffer holds, sampling each pixel at its centre,
// and widens `box` ([x0, y0, x1, y1], inclusive) to the pixels it visited. Barycentric weights
// and depth are linear in x, so each row steps them.
function fillTriangle(px, depth, box, w, h, ax, ay, az, bx, by, bz, cx, cy, cz, rgb) {
  const area = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax);
  if (area === 0) return;
  const x0 = Math.max(0, Math.floor(Math.min(ax, bx, cx))), x1 = Math.min(w - 1, Math.ceil(Math.max(ax, bx, cx)));
  const y0 = Math.max(0, Math.floor(Math.min(ay, by, cy))), y1 = Math.min(h - 1, Math.ceil(Math.max(ay, by, cy)));
  if (x0 > x1 || y0 > y1) return;
  box[0] = Math.min(box[0], x0); box[1] = Math.min(box[1], y0); box[2] = Math.max(box[2], x1); box[3] = Math.max(box[3], y1);
  const dwa = (by - cy) / area, dwb = (cy - ay) / area, dz = dwa * (az - cz) + dwb * (bz - cz);
  for (let y = y0; y <= y1; y++) {
    const py = y + 0.5, sx = x0 + 0.5;
    let wa = ((bx - sx) * (cy - py) - (by - py) * (cx - sx)) / area;
    let wb = ((cx - sx) * (ay - py) - (cy - py) * (ax - sx)) / area;
    let z = cz + wa * (az - cz) + wb * (bz - cz);
    for (let x = x0; x <= x1; x++, wa += dwa, wb += dwb, z += dz) {
      if (wa < EDGE_ALLOWANCE || wb < EDGE_ALLOWANCE || 1 - wa - wb < EDGE_ALLOWANCE) continue;
      const k = y * w + x;
      if (z <= depth[k]) continue;
      depth[k] = z;
      px[4 * k] = rgb[0]; px[4 * k + 1] = rgb[1]; px[4 * k + 2] = rgb[2]; px[4 * k + 3] = 255;
    }
  }
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
