// lobe explore: model files opened on the page (loaded before app.js, whose state and helpers
// these functions use when called). A server keeps an opened file until it stops; a link to the
// page names the file a model came from, and this browser keeps a copy of each `.brdf` file's
// text (localStorage, under a fingerprint of the text that the link carries too), so that a link
// opened on a server that lacks the model (one restarted since) opens the file again; where it
// cannot, a notice says which file to open. A MERL file (35 MB) is not kept.
'use strict';

const KEPT_PREFIX = 'lobe-explore-file:';
const KEPT_MAX = 16;            // copies kept; the oldest go first, and when the browser's quota is met

// model name → { file, kept }: the file each model opened on this page came from, and the
// fingerprint of its kept copy (absent where there is none).
const opened = {};

// What a link says of where a model came from: a file opened on the page or named on the command
// line (the catalog's source), nothing for a built-in model.
function sourceOf(model) {
  if (opened[model]) return opened[model];
  const info = catalog && modelInfo(model);
  return info && info.source ? { file: info.source } : {};
}

// FNV-1a (Fowler, Noll, Vo; 32 bits) over the text's UTF-16 code units, twice: from its own
// offset basis and from another (any other would do), 64 bits in all, so that two files a
// browser keeps do not share a fingerprint by chance.
function fingerprint(text) {
  const pass = (h) => {
    for (let k = 0; k < text.length; k++) h = Math.imul(h ^ text.charCodeAt(k), 0x01000193);
    return (h >>> 0).toString(16).padStart(8, '0');
  };
  return pass(0x811c9dc5) + pass(0x050c5d1f);
}

// localStorage can be missing or refuse (storage turned off, a quota met): every use is guarded.
function storage() {
  try { return window.localStorage || null; } catch (e) { return null; }
}

function keptKeys(store) {
  const keys = [];
  for (let k = 0; k < store.length; k++) { const key = store.key(k); if (key && key.startsWith(KEPT_PREFIX)) keys.push(key); }
  return keys;
}

// Drops the oldest kept copy; false when there is none.
function dropOldestKept(store) {
  const at = (key) => { try { return JSON.parse(store.getItem(key)).at || 0; } catch (e) { return 0; } };
  const keys = keptKeys(store).sort((a, b) => at(a) - at(b));
  if (keys.length === 0) return false;
  store.removeItem(keys[0]);
  return true;
}

// Keeps the text of `file`, from which `model` was opened; its fingerprint goes into links.
function keepFile(model, file, text) {
  opened[model] = { file };
  const store = storage();
  if (!store) return;
  const kept = fingerprint(text);
  const item = JSON.stringify({ file, text, at: Date.now() });
  try {
    store.removeItem(KEPT_PREFIX + kept);
    while (keptKeys(store).length >= KEPT_MAX) dropOldestKept(store);
    for (;;) {
      try { store.setItem(KEPT_PREFIX + kept, item); break; } catch (e) { if (!dropOldestKept(store)) return; }
    }
    opened[model].kept = kept;
  } catch (e) {
    // Storage refused: links name the file, and a server that lacks it asks for it.
  }
}

function keptText(kept) {
  const store = storage();
  try { return kept && store ? JSON.parse(store.getItem(KEPT_PREFIX + kept)).text : null; } catch (e) { return null; }
}

// Sends a model file to the server; its answer is the model (a name of its own, the parameter
// table), added to the catalog.
async function sendFile(name, body, merl) {
  const r = await fetch(`/api/${merl ? 'merl' : 'brdf'}?name=${encodeURIComponent(name)}`, {
    method: 'POST',
    headers: { 'x-lobe-token': TOKEN, 'content-type': merl ? 'application/octet-stream' : 'text/plain' },
    body,
  });
  if (!r.ok) throw new Error(await r.text());
  const model = await r.json();
  if (!modelInfo(model.name)) catalog.models.push(model);
  return model;
}

// A model file opened from the page: a BRDF Explorer shader (compiled) or a MERL table (read).
async function openFile(file) {
  const merl = file.name.endsWith('.binary');
  const limit = merl ? catalog.limits.merl_bytes : catalog.limits.brdf_bytes;
  if (file.size > limit) {
    showError(`${file.name}: ${file.size} bytes; a ${merl ? 'MERL' : '.brdf'} file may be at most ${limit}`);
    return;
  }
  $('status').textContent = `${merl ? 'reading' : 'compiling'} ${file.name}…`;
  try {
    const text = merl ? null : await file.text();
    const model = await sendFile(file.name, merl ? file : text, merl);
    if (merl) opened[model.name] = { file: model.source }; else keepFile(model.name, model.source, text);
    state.m.push({ model: model.name, material: '', sets: {} });
    changed(true);
  } catch (e) {
    showError(`${file.name}: ${e.message}`);
  } finally {
    $('status').textContent = '';
  }
}

// Notices: what the page did or could not do with a link, shown until dismissed (an error box
// is cleared by the next frame drawn).
function notice(text) {
  const item = document.createElement('li');
  const close = Object.assign(document.createElement('button'), { type: 'button', textContent: '×', title: 'dismiss' });
  close.addEventListener('click', () => { item.remove(); $('notices').hidden = $('notices').children.length === 0; });
  item.append(close, ' ', text);
  $('notices').append(item);
  $('notices').hidden = false;
  probe.notices.push(text);
}

// Opens again the models a link names that this server lacks, from this browser's kept copies,
// and renames them in `s` (the server may name a model otherwise); a notice names each it
// cannot open, and which file to open. `s` is the state as read from the link.
async function reopenModels(s) {
  const names = new Map();
  for (const e of s.m) {
    if (!e || typeof e.model !== 'string' || modelInfo(e.model) || names.has(e.model)) continue;
    const file = typeof e.file === 'string' ? e.file : null;
    const text = keptText(e.kept);
    if (file && text !== null) {
      try {
        $('status').textContent = `compiling ${file}…`;
        const model = await sendFile(file, text, false);
        opened[model.name] = { file: model.source, kept: e.kept };
        names.set(e.model, model.name);
        notice(`${file} was opened again from this browser's copy: the link names its model, which this server did not have (it was started after the link was made).`);
        continue;
      } catch (err) {
        notice(`The link names the model ${e.model}, from ${file}; this browser's copy of ${file} did not open: ${err.message}`);
      } finally {
        $('status').textContent = '';
      }
    } else if (file) {
      notice(`The link names the model ${e.model}, from ${file}, which this server does not have: it was opened on the page of a lobe explore that has stopped since (or named when it started), and this browser kept no copy of it. Open ${file} again with “open .brdf or MERL…” (or start lobe explore with it) to see it.`);
    } else {
      notice(`The link names the model ${e.model}, which this server does not have; it is left out.`);
    }
    names.set(e.model, null);
  }
  for (const e of s.m) if (e && names.has(e.model)) e.model = names.get(e.model);
  // Models already here that came from a file keep their copy's fingerprint in the next link.
  for (const e of s.m) if (e && e.model && e.kept && modelInfo(e.model) && !opened[e.model]) opened[e.model] = { file: e.file, kept: e.kept };
}
