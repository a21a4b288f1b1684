// lobe explore: the page's state, controls and requests (the views are drawn by views.js and
// lobe3d.js, model files opened by files.js). Every number it draws comes from the server, which
// computes it with the same Session as the command line. The page's state lives in the URL's
// fragment.
'use strict';

const TOKEN = new URLSearchParams(location.search).get('token') || '';
const POLAR_SAMPLES = 721;      // view angles per curve: one every 0.25°
const IMAGE_RES = 64;           // cells across the hemisphere, slice, lit object and 3D lobe mesh
const ALBEDO_POINTS = 24;       // E(μ) view directions
const SAMPLE_DRAWS = 2048;      // draws of the samples view
const LIGHT_SMALL = 48;         // the lit sphere's pixels per side while settings change
const LIGHT_FULL = 96;          // ... and once they settle (lavapipe: a few seconds under a 256 x 128 map)
const LIGHT_SETTLE_MS = 800;    // how long settings must stay put before the full image is asked for
const SAMPLE_SEED = 0;          // its random stream (lobe sample --seed)
const ALBEDO_DELAY_MS = 250;    // quiet time after the last change before the albedo is asked for
const BUSY_DELAY_MS = 150;      // how long a view may wait before the page says it is busy
const DECADES = 4;              // log scales span this many decades below the peak
const COLOURS = ['#1f77b4', '#d62728', '#2ca02c', '#9467bd', '#ff7f0e', '#8c564b', '#e377c2', '#17becf'];
const DASHES = [[], [8, 4], [2, 3], [10, 3, 2, 3]];

// What tests and benchmarks read: the last values drawn and the input-to-frame latencies.
const probe = window.lobeExplore = {
  ready: false, frames: 0, polar: [], angles: [], params: [], latencies: [], errors: [], albedo: [], downloads: [],
  notices: [], sliceCut: [], lobeFaces: 0, lightRequests: 0,
};

let catalog = null;
// m: the models; ti: θi; cos, log, wf: the polar plot's f·cosθi, log scale and white furnace;
// wire: the 3D lobe as a wireframe; pd: the slice's φd; td: the θd of its θh cut (a row's
// centre); to, po: the samples view's θo and φo; obj: the lit object; ev, tm: the lit views' exposure (stops) and tone map;
// env: the lit sphere's environment map (a built-in one, or one opened on the page, by the name the server keeps it under).
const DEFAULT_STATE = { m: [], ti: 30, cos: false, log: true, wf: false, wire: false, pd: 90, td: 45.703125, obj: 'sphere', ev: 0, tm: 'clamp', to: 30, po: 0, env: 'sky' };
let state = { ...DEFAULT_STATE };

// The lit objects and the route that renders each.
const LIT_OBJECTS = { sphere: '/api/sphere', torus: '/api/torus' };

// The built-in maps of `lobe light --env`; the maps opened on the page are those the server
// holds (the catalogue's `maps`).
const BUILTIN_MAPS = ['sky', 'studio', 'constant'];
const heldMap = (name) => BUILTIN_MAPS.includes(name) || (catalog && catalog.maps.includes(name));

// Offers a map the server holds in the lit view's menu (once).
function offerMap(name, text) {
  const menu = $('light-env');
  if ([...menu.options].some((o) => o.value === name)) return;
  const option = document.createElement('option');
  option.value = name;
  option.textContent = text || name;
  menu.append(option);
}

const $ = (id) => document.getElementById(id);
const luminance = (r, g, b) => 0.2126 * r + 0.7152 * g + 0.0722 * b;
const fmt = (v) => (Number.isFinite(v) ? Number(v.toPrecision(5)).toString() : String(v));

function showError(text) {
  const box = $('error');
  box.hidden = !text;
  box.textContent = text || '';
  if (text) probe.errors.push(text);
}

// An environment map opened from the page: read by the server (`lobe light --env`'s reader), then
// offered in the lit view's map menu and chosen; a refusal is shown beside the menu, and the map
// chosen before stays.
async function openMap(file) {
  const shown = $('light-env-error');
  shown.textContent = '';
  try {
    const r = await fetch(`/api/env?name=${encodeURIComponent(file.name)}`, {
      method: 'POST',
      headers: { 'x-lobe-token': TOKEN, 'content-type': 'application/octet-stream' },
      body: file,
    });
    if (!r.ok) throw new Error(await r.text());
    const map = await r.json();
    if (!catalog.maps.includes(map.name)) catalog.maps.push(map.name);
    offerMap(map.name, map.downsampled
      ? `${map.name} (${map.file_width}×${map.file_height}, shown at ${map.width}×${map.height})`
      : map.name);
    $('light-env').value = map.name;
    state.env = map.name;
    saveState();
    scheduleLight();
  } catch (e) {
    shown.textContent = `${file.name}: ${e.message}`;
  }
}

async function call(path, body, signal) {
  const r = await fetch(path, {
    method: 'POST', signal,
    headers: { 'x-lobe-token': TOKEN, 'content-type': 'application/json' },
    body: JSON.stringify(body),
  });
  if (!r.ok) throw new Error(`${path}: ${await r.text()}`);
  return r;
}

function modelInfo(name) {
  return catalog.models.find((m) => m.name === name);
}

function request(entry, samples) {
  const sets = Object.entries(entry.sets).map(([k, v]) => `${k}=${v}`);
  return { model: entry.model, material: entry.material || null, sets, white_furnace: state.wf,
    theta_i_deg: state.ti, samples };
}

// ---- state in the URL ------------------------------------------------------------------------

function saveState() {
  // A model opened from a file carries the file's name (and its kept copy's fingerprint), so that
  // a server that never saw it can be told which file to open (files.js).
  const m = state.m.map((e) => ({ ...e, ...sourceOf(e.model) }));
  history.replaceState(null, '', `${location.pathname}${location.search}#${encodeURIComponent(JSON.stringify({ ...state, m }))}`);
  $('command').textContent = commandLines().join('\n');
}

// The state the URL's fragment holds, or null.
function readHash() {
  try {
    const text = decodeURIComponent(location.hash.slice(1));
    if (!text) return null;
    const s = JSON.parse(text);
    return s && Array.isArray(s.m) ? s : null;
  } catch (e) {
    return null;
  }
}

// Takes a state read from a link (its models already opened where they can be, files.js): the
// models this server has, and every other value that is of its kind, else its default; false
// when no model is left.
function applyState(s) {
  if (!s) return false;
  const fine = {
    ti: (v) => Number.isFinite(v) && v >= 0 && v < 90, pd: (v) => Number.isFinite(v) && v >= 0 && v <= 360,
    td: (v) => Number.isFinite(v) && v >= 0 && v <= 90, ev: (v) => Number.isFinite(v) && Math.abs(v) <= 10,
    to: (v) => Number.isFinite(v) && v >= 0 && v < 90, po: (v) => Number.isFinite(v) && v >= 0 && v <= 360,
    obj: (v) => Object.hasOwn(LIT_OBJECTS, v), tm: (v) => Object.hasOwn(TONE_MAPS, v),
    env: (v) => typeof v === 'string' && heldMap(v),
  };
  const next = { ...DEFAULT_STATE };
  for (const k of Object.keys(DEFAULT_STATE)) {
    if (k === 'm' || !(k in s)) continue;
    const ok = fine[k] ? fine[k](s[k]) : typeof s[k] === typeof DEFAULT_STATE[k];
    if (ok) next[k] = s[k];
  }
  if (typeof s.env === 'string' && next.env !== s.env) {
    notice(`The link names the environment map ${s.env}, which this server does not hold: it was opened on the page of a lobe explore that has stopped since, or of another one. The lit view shows ${next.env}; open ${s.env} again with “open map…” to see it.`);
  }
  next.m = s.m.filter((e) => e && modelInfo(e.model)).map((e) => ({ model: e.model, material: e.material || '', sets: e.sets || {} }));
  state = next;
  return next.m.length > 0;
}

// ---- "copy as command" -----------------------------------------------------------------------

// The model as the command line names it: a file a model came from, else its name.
function spec(entry) {
  const info = catalog && modelInfo(entry.model);
  const name = info && info.source ? info.source : entry.model;
  const sets = Object.entries(entry.sets).map(([k, v]) => `${k}=${v}`);
  return sets.length ? `${name}{${sets.join(',')}}` : name;
}

const quote = (s) => `'${s.replace(/'/g, "'\\''")}'`;

function commandLines() {
  const materials = [...new Set(state.m.map((e) => e.material || ''))];
  const shared = materials.length === 1 ? materials[0] : null;
  const mat = (e) => (e.material ? ` --material ${e.material}` : '');
  const wf = state.wf ? ' --white-furnace' : '';
  const lines = [];
  if (shared !== null) {
    const models = state.m.map((e) => ` --model ${quote(spec(e))}`).join('');
    lines.push(`lobe plot --kind polar -o polar.svg${models}${shared ? ` --material ${shared}` : ''}${wf}` +
      ` --theta-i-deg ${state.ti}${state.cos ? ' --cos' : ''} ${state.log ? '--log' : '--linear'}`);
  } else {
    state.m.forEach((e, i) => lines.push(`lobe plot --kind polar -o polar-${i + 1}.svg --model ${quote(spec(e))}${mat(e)}${wf}` +
      ` --theta-i-deg ${state.ti}${state.cos ? ' --cos' : ''} ${state.log ? '--log' : '--linear'}`));
  }
  state.m.forEach((e) => lines.push(`lobe albedo --model ${quote(spec(e))}${mat(e)}${wf}`));
  const grid = catalog ? ` --grid ${catalog.table.grid} --res ${catalog.table.res}` : '';
  state.m.forEach((e, i) => lines.push(`lobe table --model ${quote(spec(e))}${mat(e)}${wf}${grid} -o table-${i + 1}.exr`));
  // The lit sphere: the first model under the chosen map (an opened map by the file name it is
  // kept under).
  if (state.m.length) lines.push(`lobe light --model ${quote(spec(state.m[0]))}${mat(state.m[0])} --env ${quote(state.env)} --size ${LIGHT_FULL} -o light.exr`);
  return lines;
}

// ---- controls from the parameter tables ------------------------------------------------------

// A slider's range: logarithmic where the range spans more than three decades.
function sliderRange(p, value) {
  let lo = p.min ?? 0;
  let hi = p.max ?? Math.max(10, 10 * Math.abs(value));
  const log = hi > 0 && (lo > 0 ? hi / lo >= 1000 : hi >= 1000);
  if (log && lo <= 0) lo = hi * 1e-6;
  if (p.min_exclusive && !log) lo += (hi - lo) * 1e-4;
  return { lo, hi, log };
}

const toSlider = (r, v) => (r.log ? Math.log(Math.max(v, r.lo) / r.lo) / Math.log(r.hi / r.lo) : (v - r.lo) / (r.hi - r.lo)) * 1000;
const fromSlider = (r, t) => (r.log ? r.lo * Math.pow(r.hi / r.lo, t / 1000) : r.lo + (r.hi - r.lo) * t / 1000);
const srgb = (c) => (c <= 0.0031308 ? 12.92 * c : 1.055 * Math.pow(c, 1 / 2.4) - 0.055);
const linear = (c) => (c <= 0.04045 ? c / 12.92 : Math.pow((c + 0.055) / 1.055, 2.4));
const hex = (rgb) => '#' + rgb.map((c) => Math.round(Math.min(1, Math.max(0, srgb(c))) * 255).toString(16).padStart(2, '0')).join('');

// The value shown for a key: the page's own assignment, else what the server evaluated last.
function current(i, p) {
  const set = state.m[i].sets[p.key];
  if (set !== undefined) return set;
  const evaluated = probe.params[i] && probe.params[i][p.key];
  if (evaluated !== undefined) return Array.isArray(evaluated) ? evaluated.join(',') : String(evaluated);
  return Array.isArray(p.default) ? p.default.join(',') : String(p.default);
}

function assign(i, key, text, rebuild) {
  state.m[i].sets[key] = text;
  changed(rebuild);
}

function paramRow(i, p) {
  const row = document.createElement('div');
  row.className = 'param';
  const label = document.createElement('label');
  label.textContent = p.key;
  label.title = p.doc + (p.min !== null ? ` [${p.min}, ${p.max ?? '∞'}]` : '');
  row.append(label);
  const value = current(i, p);
  if (p.kind === 'scalar') {
    const r = sliderRange(p, Number(value));
    const slider = Object.assign(document.createElement('input'), { type: 'range', min: 0, max: 1000, step: 1 });
    slider.value = toSlider(r, Number(value));
    slider.dataset.key = p.key;
    const box = Object.assign(document.createElement('input'), { type: 'number', value, step: 'any' });
    slider.addEventListener('input', () => {
      const v = Number(fromSlider(r, Number(slider.value)).toPrecision(4));
      box.value = v;
      assign(i, p.key, String(v), false);
    });
    box.addEventListener('change', () => { slider.value = toSlider(r, Number(box.value)); assign(i, p.key, box.value, false); });
    row.append(slider, box);
  } else if (p.kind === 'rgb' && p.min === 0 && p.max === 1) {
    const rgb = value.split(',').map(Number);
    const c = rgb.length === 3 ? rgb : [rgb[0], rgb[0], rgb[0]];
    const picker = Object.assign(document.createElement('input'), { type: 'color', value: hex(c) });
    const box = Object.assign(document.createElement('input'), { type: 'text', value, size: 10 });
    picker.addEventListener('input', () => {
      const v = [1, 3, 5].map((k) => Number(linear(parseInt(picker.value.slice(k, k + 2), 16) / 255).toPrecision(4)));
      box.value = v.join(',');
      assign(i, p.key, box.value, false);
    });
    box.addEventListener('change', () => assign(i, p.key, box.value, true));
    row.append(picker, box);
  } else if (p.kind === 'rgb') {
    const box = Object.assign(document.createElement('input'), { type: 'text', value });
    box.addEventListener('change', () => assign(i, p.key, box.value, false));
    row.append(box, document.createElement('span'));
  } else {
    const select = document.createElement('select');
    select.dataset.key = p.key;
    const options = p.kind === 'choice' ? p.options : ['false', 'true'];
    const now = p.kind === 'flag' ? (Number(value) ? 'true' : 'false') : value;
    options.forEach((o) => select.add(new Option(o, o, false, o === now)));
    select.addEventListener('change', () => assign(i, p.key, select.value, true));
    row.append(select, document.createElement('span'));
  }
  return row;
}

function card(i) {
  const entry = state.m[i];
  const div = document.createElement('div');
  div.className = 'card';
  div.style.setProperty('--colour', COLOURS[i % COLOURS.length]);
  const head = document.createElement('div');
  head.className = 'head';
  const model = document.createElement('select');
  model.className = 'model';
  catalog.models.forEach((m) => model.add(new Option(m.name, m.name, false, m.name === entry.model)));
  model.title = modelInfo(entry.model).description;
  model.addEventListener('change', () => { state.m[i] = { model: model.value, material: entry.material, sets: {} }; probe.params[i] = null; controlsStale = true; changed(true); });
  const material = document.createElement('select');
  material.add(new Option('(no preset)', ''));
  catalog.materials.forEach((m) => material.add(new Option(m, m, false, m === entry.material)));
  material.addEventListener('change', () => { entry.material = material.value; entry.sets = {}; probe.params[i] = null; controlsStale = true; changed(true); });
  const dup = Object.assign(document.createElement('button'), { type: 'button', textContent: 'duplicate' });
  dup.addEventListener('click', () => { state.m.splice(i + 1, 0, JSON.parse(JSON.stringify(entry))); probe.params.splice(i + 1, 0, probe.params[i]); changed(true); });
  const remove = Object.assign(document.createElement('button'), { type: 'button', textContent: 'remove', disabled: state.m.length < 2 });
  remove.addEventListener('click', () => { state.m.splice(i, 1); probe.params.splice(i, 1); changed(true); });
  head.append(model, material, dup, remove);
  div.append(head);
  const params = modelInfo(entry.model).params;
  params.filter((p) => !p.optional || entry.sets[p.key] !== undefined).forEach((p) => {
    const row = paramRow(i, p);
    if (p.optional) {
      // An optional parameter set by hand: unset, the model derives it again.
      const unset = Object.assign(document.createElement('button'), { type: 'button', textContent: '×', title: `unset ${p.key}` });
      unset.className = 'unset';
      unset.addEventListener('click', () => { delete entry.sets[p.key]; changed(true); });
      row.querySelector('label').prepend(unset);
    }
    div.append(row);
  });
  // Optional parameters the model derives when they are not given: a button each sets one, at
  // its default, and shows its control.
  const unsetKeys = params.filter((p) => p.optional && entry.sets[p.key] === undefined);
  if (unsetKeys.length > 0) {
    const more = document.createElement('div');
    more.className = 'optional';
    unsetKeys.forEach((p) => {
      const add = Object.assign(document.createElement('button'), { type: 'button', textContent: `+ ${p.key}`, title: p.doc });
      add.dataset.key = p.key;
      add.addEventListener('click', () => {
        entry.sets[p.key] = Array.isArray(p.default) ? p.default.join(',') : String(p.default);
        changed(true);
      });
      more.append(add);
    });
    div.append(more);
  }
  return div;
}

function buildControls() {
  const box = $('models');
  box.replaceChildren(...state.m.map((_, i) => card(i)));
  $('theta-i').value = state.ti;
  $('theta-i-value').textContent = `${state.ti}°`;
  $('cos').checked = state.cos;
  $('log').checked = state.log;
  $('white-furnace').checked = state.wf;
  $('wireframe').checked = state.wire;
  $('phi-d').value = state.pd;
  $('phi-d-value').textContent = `${state.pd}°`;
  $('theta-d').max = IMAGE_RES - 1;
  $('theta-d').value = sliceRow();
  $('theta-d-value').textContent = `${fmt(sliceTheta(sliceRow()))}°`;
  $('lit-object').value = state.obj;
  $('exposure').value = state.ev;
  $('exposure-value').textContent = evText(state.ev);
  $('tone-map').value = state.tm;
  $('light-env').value = state.env;
}

// ---- requests: one in flight per kind, the newest state next, stale states dropped -----------

let pendingInput = null;
let controlsStale = true;       // the controls were built before the server said what a preset sets
let inFlight = false;
let dirty = false;
let albedoTimer = null;
let albedoAbort = null;
let imagesAbort = null;

function changed(rebuild) {
  if (rebuild) buildControls();
  imagesChanged();
  scheduleAlbedo();
  scheduleSamples();
  scheduleLight();
}

// A change the albedo does not see (the slice's φd, the lit object) asks for the views only.
function imagesChanged() {
  if (pendingInput === null) pendingInput = performance.now();
  // The image views under way show a state that is gone: drop them, so the new one starts now.
  if (imagesAbort) imagesAbort.abort();
  saveState();
  refreshViews();
}

// The polar plot and the 3D lobe first, drawn as soon as they arrive; the image views after them,
// and only when no newer state is waiting (a drag asks for them once it rests).
async function refreshViews() {
  if (inFlight) { dirty = true; return; }
  inFlight = true;
  dirty = false;
  const since = pendingInput;
  pendingInput = null;
  const busy = setTimeout(() => { $('status').textContent = 'computing…'; }, BUSY_DELAY_MS);
  // Each view: its route, its samples and what else its requests carry.
  const fetchAll = async (entries, views, signal) => {
    const answers = await Promise.all(views.flatMap(([path, samples, extra]) => entries.map((r) => call(path, { ...r, samples, ...extra }, signal))));
    const data = await Promise.all(answers.map((a) => a.arrayBuffer()));
    return { answers, data: data.map((d) => new Float32Array(d)) };
  };
  try {
    const entries = state.m.map((e) => request(e, 0));
    const n = entries.length;
    const first = await fetchAll(entries, [['/api/polar', POLAR_SAMPLES], ['/api/lobe', IMAGE_RES]]);
    probe.polar = first.data.slice(0, n);
    probe.lobe = first.data.slice(n);
    probe.invalid = first.answers.slice(0, n).map((a) => Number(a.headers.get('x-lobe-invalid')));
    probe.params = first.answers.slice(0, n).map((a) => JSON.parse(a.headers.get('x-lobe-params')));
    probe.request = entries;
    if (controlsStale && n === state.m.length) { controlsStale = false; buildControls(); }
    showError('');
    drawPolar();
    drawLobe();
    requestAnimationFrame(() => {
      probe.frames += 1;
      if (since !== null) probe.latencies.push(performance.now() - since);
      probe.ready = true;
    });
    if (!dirty) {
      imagesAbort = new AbortController();
      const [pd, obj] = [state.pd, state.obj];
      const images = await fetchAll(entries, [['/api/hemisphere', IMAGE_RES], ['/api/slice', IMAGE_RES, { phi_d_deg: pd }], [LIT_OBJECTS[obj], IMAGE_RES]], imagesAbort.signal);
      [probe.hemi, probe.slice, probe.lit] = [0, 1, 2].map((k) => images.data.slice(k * n, (k + 1) * n));
      [probe.slicePhiD, probe.litObject] = [pd, obj];
      probe.imagesRequest = entries;
      if (!dirty) drawImages();
    }
  } catch (e) {
    if (e.name !== 'AbortError') showError(e.message);
  } finally {
    imagesAbort = null;
    clearTimeout(busy);
    $('status').textContent = '';
    inFlight = false;
    if (dirty) refreshViews();
  }
}

function scheduleAlbedo() {
  clearTimeout(albedoTimer);
  albedoTimer = setTimeout(refreshAlbedo, ALBEDO_DELAY_MS);
}

async function refreshAlbedo() {
  if (albedoAbort) albedoAbort.abort();
  const abort = albedoAbort = new AbortController();
  $('albedo-readout').tBodies[0].replaceChildren();
  try {
    const asked = state.m.map((e) => request(e, ALBEDO_POINTS));
    const answers = await Promise.all(asked.map((r) => call('/api/albedo', r, abort.signal).then((a) => a.json())));
    if (abort.signal.aborted) return;
    probe.albedo = answers;
    probe.albedoRequest = asked;
    drawAlbedo(answers);
    drawSkies(answers);
  } catch (e) {
    if (e.name !== 'AbortError') showError(e.message);
  }
}

let lightTimers = [];
let lightAbort = null;

// The lit sphere: a small image soon after a change, the full one once the settings settle.
function scheduleLight() {
  lightTimers.forEach(clearTimeout);
  lightTimers = [setTimeout(() => refreshLight(LIGHT_SMALL), ALBEDO_DELAY_MS),
    setTimeout(() => refreshLight(LIGHT_FULL), LIGHT_SETTLE_MS)];
}

// The first model's sphere under the chosen map; a newer request drops the one under way.
async function refreshLight(size) {
  if (lightAbort) lightAbort.abort();
  const abort = lightAbort = new AbortController();
  if (!state.m.length) return;
  try {
    const { model, material, sets } = request(state.m[0], 0);
    const asked = { model, material, sets, env: state.env, size };
    probe.lightRequests += 1;
    const answer = await (await call('/api/light', asked, abort.signal)).json();
    if (abort.signal.aborted) return;
    probe.light = answer;
    probe.lightRequest = asked;
    drawLight(answer);
  } catch (e) {
    if (e.name !== 'AbortError') showError(e.message);
  }
}

let samplesTimer = null;
let samplesAbort = null;

function scheduleSamples() {
  clearTimeout(samplesTimer);
  samplesTimer = setTimeout(refreshSamples, ALBEDO_DELAY_MS);
}

// Every model's draws and pdf for (θo, φo), one request per model; a newer state drops the
// requests under way. A model the server refuses shows the refusal in its own panel, beside the
// others' draws.
async function refreshSamples() {
  if (samplesAbort) samplesAbort.abort();
  const abort = samplesAbort = new AbortController();
  if (!state.m.length) return;
  const labels = state.m.map(spec);
  const asked = state.m.map((e) => {
    const { model, material, sets, white_furnace } = request(e, 0);
    return { model, material, sets, white_furnace, theta_o_deg: state.to, phi_o_deg: state.po,
      draws: SAMPLE_DRAWS, seed: SAMPLE_SEED, res: IMAGE_RES };
  });
  const settled = await Promise.all(asked.map((r) => call('/api/samples', r, abort.signal)
    .then((a) => a.json())
    .then((answer) => ({ answer, error: null }), (e) => ({ answer: null, error: e }))));
  if (abort.signal.aborted) return;
  probe.samples = settled.map((s) => s.answer);
  probe.samplesErrors = settled.map((s) => (s.error ? s.error.message : null));
  probe.samplesRequest = asked;
  drawSamples(settled, labels);
}

// ---- drawing ---------------------------------------------------------------------------------

function curveValues(i) {
  const f = probe.polar[i];
  const scale = state.cos ? Math.cos(state.ti * Math.PI / 180) : 1;
  const out = new Float64Array(f.length / 3);
  for (let k = 0; k < out.length; k++) out[k] = luminance(f[3 * k], f[3 * k + 1], f[3 * k + 2]) * scale;
  return out;
}

function drawPolar() {
  const c = $('polar');
  const g = c.getContext('2d');
  const cx = c.width / 2, cy = c.height - 20, R = Math.min(cx - 20, cy - 10);
  g.clearRect(0, 0, c.width, c.height);
  g.strokeStyle = '#ccc';
  g.lineWidth = 1;
  g.setLineDash([]);
  for (const f of [0.25, 0.5, 0.75, 1]) { g.beginPath(); g.arc(cx, cy, R * f, Math.PI, 2 * Math.PI); g.stroke(); }
  for (let a = -90; a <= 90; a += 30) {
    const t = a * Math.PI / 180;
    g.beginPath(); g.moveTo(cx, cy); g.lineTo(cx + R * Math.sin(t), cy - R * Math.cos(t)); g.stroke();
  }
  const ti = state.ti * Math.PI / 180;
  g.strokeStyle = '#f0a000';
  g.beginPath(); g.moveTo(cx, cy); g.lineTo(cx - R * Math.sin(ti), cy - R * Math.cos(ti)); g.stroke();
  const curves = state.m.map((_, i) => curveValues(i));
  const peak = Math.max(...curves.map((v) => Math.max(...v.filter(Number.isFinite))), 1e-30);
  const radius = (v) => (state.log ? Math.max(0, 1 + Math.log10(Math.max(v, 1e-300) / peak) / DECADES) : Math.max(0, v / peak));
  probe.angles = [];
  for (let k = 0; k < POLAR_SAMPLES; k++) probe.angles.push(-90 + (k + 0.5) * 180 / POLAR_SAMPLES);
  curves.forEach((v, i) => {
    g.strokeStyle = COLOURS[i % COLOURS.length];
    g.setLineDash(DASHES[i % DASHES.length]);
    g.lineWidth = 2;
    g.beginPath();
    v.forEach((x, k) => {
      const s = probe.angles[k] * Math.PI / 180, r = R * radius(x);
      const px = cx + r * Math.sin(s), py = cy - r * Math.cos(s);
      if (k === 0) g.moveTo(px, py); else g.lineTo(px, py);
    });
    g.stroke();
  });
  g.setLineDash([]);
  g.fillStyle = '#444';
  g.font = '12px system-ui, sans-serif';
  g.fillText(state.log ? `log, ${DECADES} decades below ${fmt(peak)}` : `linear, peak ${fmt(peak)}`, 8, 16);
  $('polar-cos').textContent = state.cos ? '·cosθi' : '';
  readout(curves);
}

// The numbers beside the plot: f at the mirror direction (the view angle nearest +θi) and the peak.
function readout(curves) {
  const k = probe.angles.reduce((best, s, j) => (Math.abs(s - state.ti) < Math.abs(probe.angles[best] - state.ti) ? j : best), 0);
  probe.mirrorIndex = k;
  const rows = state.m.map((e, i) => {
    const f = probe.polar[i];
    const tr = document.createElement('tr');
    const cells = [spec(e) + (e.material ? ` (${e.material})` : ''),
      `${fmt(f[3 * k])}, ${fmt(f[3 * k + 1])}, ${fmt(f[3 * k + 2])}`,
      fmt(Math.max(...curves[i].filter(Number.isFinite))), String(probe.invalid[i])];
    cells.forEach((t, j) => { const td = document.createElement('td'); td.textContent = t; if (j === 0) td.style.color = COLOURS[i % COLOURS.length]; tr.append(td); });
    return tr;
  });
  $('readout').tBodies[0].replaceChildren(...rows);
}

// ---- downloads -------------------------------------------------------------------------------

function download(name, url) {
  const a = Object.assign(document.createElement('a'), { href: url, download: name });
  document.body.append(a); a.click(); a.remove();
}

// A file lobe's own writers make on the server (the one the command line beside it writes).
async function downloadFile(path, body, name) {
  $('status').textContent = `writing ${name}…`;
  try {
    const blob = await (await call(path, body)).blob();
    const url = URL.createObjectURL(blob);
    download(name, url);
    setTimeout(() => URL.revokeObjectURL(url), 60000);
    probe.downloads.push({ name, bytes: blob.size });
  } catch (e) {
    showError(`${name}: ${e.message}`);
  } finally {
    $('status').textContent = '';
  }
}

// Each model's table, named as the "lobe table" lines name them.
async function downloadTables(format) {
  for (const [i, e] of state.m.entries()) {
    const { model, material, sets, white_furnace } = request(e, 1);
    await downloadFile('/api/table', { model, material, sets, white_furnace, format }, `table-${i + 1}.${format}`);
  }
}

function downloadSvg() {
  const models = state.m.map((e) => { const { model, material, sets } = request(e, 1); return { model, material, sets }; });
  return downloadFile('/api/plot', { models, white_furnace: state.wf, theta_i_deg: state.ti, cos: state.cos, log: state.log }, 'polar.svg');
}

// ---- start -----------------------------------------------------------------------------------

// The models the server was started with.
function initialModels() {
  return catalog.initial.map((e) => ({
    model: e.model, material: catalog.material || '',
    sets: Object.fromEntries(e.sets.map((s) => [s.slice(0, s.indexOf('=')), s.slice(s.indexOf('=') + 1)])),
  }));
}

// Takes the state the URL's fragment holds, its models opened again where this server lacks them
// (files.js); the server's own models where none is left.
async function takeLink() {
  const s = readHash();
  if (s) await reopenModels(s);
  if (!applyState(s)) state.m = initialModels();
}

const evText = (ev) => `${ev > 0 ? '+' : ''}${ev} EV`;

// Redraws the image views from the values they have (a change of how they are shown).
function redrawImages() {
  saveState();
  if (probe.hemi && probe.hemi.length === state.m.length) drawImages();
  if (probe.light) drawLight(probe.light);
}

async function start() {
  const r = await fetch('/api/models', { headers: { 'x-lobe-token': TOKEN } });
  if (!r.ok) { showError(await r.text()); return; }
  catalog = await r.json();
  $('backend').textContent = catalog.backend;
  catalog.maps.forEach((name) => offerMap(name));
  await takeLink();
  buildControls();
  $('theta-i').addEventListener('input', () => { state.ti = Number($('theta-i').value); $('theta-i-value').textContent = `${state.ti}°`; changed(false); });
  $('cos').addEventListener('change', () => { state.cos = $('cos').checked; saveState(); drawPolar(); drawLobe(); });
  $('log').addEventListener('change', () => { state.log = $('log').checked; saveState(); drawPolar(); drawLobe(); });
  $('wireframe').addEventListener('change', () => { state.wire = $('wireframe').checked; saveState(); drawLobe(); });
  dragLobe();
  $('white-furnace').addEventListener('change', () => { state.wf = $('white-furnace').checked; changed(false); });
  $('phi-d').addEventListener('input', () => { state.pd = Number($('phi-d').value); $('phi-d-value').textContent = `${state.pd}°`; imagesChanged(); });
  $('theta-d').addEventListener('input', () => { state.td = sliceTheta(Number($('theta-d').value)); $('theta-d-value').textContent = `${fmt(state.td)}°`; redrawImages(); });
  $('theta-o').addEventListener('input', () => { state.to = Number($('theta-o').value); $('theta-o-value').textContent = `${state.to}°`; saveState(); scheduleSamples(); });
  $('phi-o').addEventListener('input', () => { state.po = Number($('phi-o').value); $('phi-o-value').textContent = `${state.po}°`; saveState(); scheduleSamples(); });
  $('lit-object').addEventListener('change', () => { state.obj = $('lit-object').value; imagesChanged(); });
  $('exposure').addEventListener('input', () => { state.ev = Number($('exposure').value); $('exposure-value').textContent = evText(state.ev); redrawImages(); });
  $('tone-map').addEventListener('change', () => { state.tm = $('tone-map').value; redrawImages(); });
  $('light-env').addEventListener('change', () => { state.env = $('light-env').value; saveState(); scheduleLight(); });
  $('open-env').addEventListener('change', (ev) => { if (ev.target.files[0]) openMap(ev.target.files[0]); ev.target.value = ''; });
  $('add').addEventListener('click', () => { state.m.push({ model: catalog.models[0].name, material: '', sets: {} }); changed(true); });
  $('open-brdf').addEventListener('change', (ev) => { if (ev.target.files[0]) openFile(ev.target.files[0]); ev.target.value = ''; });
  // The clipboard exists only on a secure origin (localhost is one; --host's other addresses are
  // not): there the lines stay shown under the button, to be selected by hand.
  $('copy').addEventListener('click', () => {
    if (!navigator.clipboard) { showError('copy: this address has no clipboard access; select the command lines shown below'); return; }
    navigator.clipboard.writeText(commandLines().join('\n')).catch((e) => showError(`copy: ${e.message}`));
  });
  $('download-png').addEventListener('click', () => download('polar.png', $('polar').toDataURL('image/png')));
  $('download-svg').addEventListener('click', downloadSvg);
  $('download-npy').addEventListener('click', () => downloadTables('npy'));
  $('download-exr').addEventListener('click', () => downloadTables('exr'));
  $('download-json').addEventListener('click', () => {
    const json = JSON.stringify({ theta_i_deg: state.ti, white_furnace: state.wf, models: state.m.map((e, i) => ({ model: e.model, material: e.material || null, parameters: probe.params[i] })) }, null, 2);
    download('parameters.json', URL.createObjectURL(new Blob([json], { type: 'application/json' })));
  });
  window.addEventListener('hashchange', async () => { if (!readHash()) return; await takeLink(); buildControls(); changed(false); });
  saveState();
  refreshViews();
  scheduleAlbedo();
  scheduleSamples();
  scheduleLight();
}

start().catch((e) => showError(e.message));
