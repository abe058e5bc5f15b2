// The map viewer: a map and one of its versions as points, tiles fetched around where the view looks
// (GET .../roi) and a coarse overview when zoomed out (GET .../versions/{v}/overview); the diff of two
// versions; the heat map of the fleet's change reports; the live vehicles. Its state is in
// window.plViewer for the tests and the benchmark (tests/viewer, bench/viewer.sh), and in the URL's
// hash (#map=town&v=2&mode=diff&a=1&b=2&colour=intensity&x=..&y=..&r=..) so a view can be linked.
import { Api } from './api.mjs';
import { View } from './scene.mjs';
import { Tiles } from './tiles.mjs';
import { Overlays, DIFF_COLOURS, CANDIDATE_COLOUR, heatColour } from './overlays.mjs';
import { Vehicles, HEALTH_COLOURS } from './vehicles.mjs';

// Views wider than this, or that would need more tiles than MAX_TILES, show the overview instead:
// at 600 m a pixel of the canvas covers about a metre, finer than the tiles' 0.2 m voxels could show,
// and 400 tiles of a dense map are some 20 million points.
const OVERVIEW_RADIUS = 600;
const MAX_TILES = 400;

const $ = (id) => document.getElementById(id);
const api = new Api();
const view = new View($('view'));
const tiles = new Tiles(api, view);
const overlays = new Overlays(view);
const vehicles = new Vehicles(api, view, () => { showVehicles(); showStatus(); });

const state = {
  map: null, manifest: null, versions: [], version: null,
  mode: 'map', a: null, b: null, colour: 'height',
  lists: new Map(),  // version -> Map("tx/ty" -> hash): the diff's tile lists
  groundZ: 0,
};

const pl = {
  ready: false,
  errors: [],
  firstTileMs: null,  // since navigation start: the first frame with a tile in it
  firstViewMs: null,  // ... the first frame with all the first view's tiles
  roi: null,          // the last region: {x, y, radius, versions, queries (the ROI URLs), tiles: [count per version], overview}
  diff: null,         // {a, b, added, removed, changed}: "tx/ty" keys over the whole map
  heat: null,         // {tiles, candidates, most}
  get tilesDecoded() { return tiles.decoded; },
  get pointsDecoded() { return tiles.decodedPoints; },
  get frames() { return view.frames; },
  get vehicles() { return vehicles.snapshot(); },
  get vehicleEvents() { return vehicles.events; },
  get eventsConnected() { return vehicles.connected; },
  get state() { return { map: state.map, version: state.version, mode: state.mode, a: state.a, b: state.b, colour: state.colour }; },
  // The tiles on screen: [{version, tx, ty, kind}], and the ENU box of their points.
  shown: () => [...tiles.shown.values()].filter((s) => !s.item.overview).map((s) => ({ version: s.item.version, tx: s.item.tx, ty: s.item.ty, kind: s.item.kind })),
  overviewShown: () => [...tiles.shown.values()].some((s) => s.item.overview),
  highlighted: () => [...new Set(pl.shown().filter((s) => s.kind in DIFF_COLOURS).map((s) => `${s.tx}/${s.ty}`))].sort(),
  stats: () => tiles.stats(),
  canvasStats: () => view.canvasStats(),
  measureFps: (seconds) => view.measureFps(seconds),
  idle,
  setView: (x, y, r) => { view.lookAt(x, y, r, state.groundZ); schedule(); return idle(); },
  setMode: (mode, a, b) => setMode(mode, a, b).then(idle),
  setColour: (c) => { setColour(c); return idle(); },
  setVersion: (v) => setVersion(v).then(idle),
  selectMap: (name) => selectMap(name).then(idle),
  // The heat map of a /changes answer given here (tests: without change reports in the store).
  showChanges: (changes) => { pl.heat = overlays.showHeat(changes, state.manifest.tile_size, state.groundZ); showLegend(); return idle(); },
};
window.plViewer = pl;

function report(error) {
  const message = error && error.message ? error.message : String(error);
  pl.errors.push(message);
  console.error(message);
  $('status').classList.add('error');
  $('status').textContent = message;
}

// ---------------------------------------------------------------------------------------------
// Loading what the view shows

let running = false, queued = false, debounce = null;

function schedule() {
  if (running) { queued = true; return; }
  running = true;
  refresh().catch(report).finally(() => {
    running = false;
    if (queued) { queued = false; schedule(); }
  });
}

// Resolves when nothing is loading and a frame with everything has been drawn.
async function idle() {
  const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
  while (running || queued || debounce || tiles.busy || !pl.ready) await sleep(30);
  view.render();
  await new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r)));
}

const tileItem = (v, t, kind) => ({ key: `${v}/${t.tx}/${t.ty}`, hash: t.hash, url: t.url, kind, version: v, tx: t.tx, ty: t.ty });

async function refresh() {
  if (!state.map || state.version == null) return;
  const { x, y } = view.centre();
  const radius = Math.min(view.radius(), 5000);
  const diff = state.mode === 'diff';
  if (diff && !(state.lists.has(state.a) && state.lists.has(state.b))) return;  // setMode loads them, then schedules
  const versions = diff ? [state.b, state.a] : [state.version];
  let overview = radius > OVERVIEW_RADIUS;
  let rois = [];
  const queries = versions.map((v) => api.roiPath(state.map, v, x, y, radius));
  if (!overview) {
    rois = await Promise.all(queries.map((q) => api.json(q)));
    overview = rois.some((r) => r.tiles.length > MAX_TILES);
  }
  let items;
  if (overview) {
    const v = versions[0];
    items = [{ key: `overview/${v}`, hash: `overview/${state.map}/${v}`, url: `/v1/maps/${encodeURIComponent(state.map)}/versions/${v}/overview`,
               kind: state.mode === 'map' ? 'base' : 'context', overview: true, version: v }];
  } else if (diff) {
    // The newer version's tiles, by what the older one had there; then the older one's tiles the
    // newer one dropped.
    const [b, a] = [state.lists.get(state.b), state.lists.get(state.a)];
    items = rois[0].tiles.map((t) => {
      const k = `${t.tx}/${t.ty}`;
      return tileItem(state.b, t, !a.has(k) ? 'added' : a.get(k) !== t.hash ? 'changed' : 'same');
    });
    for (const t of rois[1].tiles) if (!b.has(`${t.tx}/${t.ty}`)) items.push(tileItem(state.a, t, 'removed'));
  } else {
    items = rois[0].tiles.map((t) => tileItem(state.version, t, state.mode === 'changes' ? 'context' : 'base'));
  }
  // The middle of the view first.
  const size = state.manifest.tile_size;
  const far = (i) => (i.overview ? 0 : Math.hypot((i.tx + 0.5) * size - x, (i.ty + 0.5) * size - y));
  items.sort((p, q) => far(p) - far(q));
  pl.roi = { x, y, radius, versions, queries, tiles: rois.map((r) => r.tiles.length), overview };
  const errors = await tiles.show(items);
  errors.forEach(report);
  if (pl.firstViewMs === null && !errors.length) {
    // The first view is drawn at the next frame.
    await new Promise((r) => requestAnimationFrame(() => { pl.firstViewMs = performance.now(); r(); }));
  }
  showStatus();
  writeHash();
}

view.afterFrame.push(() => {
  if (pl.firstTileMs === null && tiles.shown.size > 0) pl.firstTileMs = performance.now();
});
view.controls.addEventListener('change', () => {
  clearTimeout(debounce);
  debounce = setTimeout(() => { debounce = null; schedule(); }, 150);
});

// ---------------------------------------------------------------------------------------------
// Maps, versions, modes

// Shows a map: its current version (or opts.version), the whole map in view (or opts.view: {x, y, r}).
// opts.defer: the caller loads the view (schedule()) once it has set up the rest.
async function selectMap(name, opts = {}) {
  const [manifest, versions] = await Promise.all([api.map(name), api.versions(name)]);
  state.map = name;
  state.manifest = manifest;
  state.versions = versions.versions;
  state.version = opts.version ?? manifest.current_version ?? (state.versions.length ? state.versions[state.versions.length - 1].version : null);
  state.a = state.b = null;
  state.lists.clear();
  tiles.clear();
  overlays.clear();
  // The scene's origin: the map's centre, whole metres (the tiles' own origins are whole metres too).
  const b = manifest.bounds || { min: [0, 0, 0], max: [0, 0, 0] };
  const centre = [0, 1].map((c) => Math.round((b.min[c] + b.max[c]) / 2));
  state.groundZ = Math.floor(b.min[2]);
  view.setLocal(centre[0], centre[1], state.groundZ);
  view.shared.heightRange.value.set(b.min[2], Math.max(b.max[2], b.min[2] + 1));
  vehicles.connect(name);
  vehicles.replace();
  $('map-select').value = name;
  showVersions();
  const half = Math.hypot(b.max[0] - b.min[0], b.max[1] - b.min[1]) / 2;
  if (opts.view) view.lookAt(opts.view.x, opts.view.y, opts.view.r, state.groundZ);
  else view.lookAt(centre[0], centre[1], Math.max(40, half * 1.05), state.groundZ);
  if (state.mode !== 'map') await setMode(state.mode);  // the mode's overlays for this map
  else if (!opts.defer) schedule();
}

const parentOf = (v) => (state.versions.find((i) => i.version === v) || {}).parent;

async function setVersion(v) {
  state.version = Number(v);
  showVersions();
  if (state.mode === 'diff') return setMode('diff', parentOf(state.version) ?? state.version, state.version);
  if (state.mode === 'changes') return setMode('changes');
  schedule();
}

async function tileList(v) {
  if (!state.lists.has(v)) {
    const list = await api.tileList(state.map, v);
    state.lists.set(v, new Map(list.tiles.map((t) => [`${t.tx}/${t.ty}`, t.hash])));
  }
  return state.lists.get(v);
}

async function setMode(mode, a, b) {
  state.mode = mode;
  for (const button of document.querySelectorAll('#mode button')) button.classList.toggle('on', button.dataset.mode === mode);
  $('diff-pick').hidden = mode !== 'diff';
  overlays.clear();
  pl.diff = null;
  pl.heat = null;
  const size = state.manifest.tile_size;
  if (mode === 'diff') {
    // Default: the viewed version against its parent.
    state.b = Number(b ?? state.b ?? state.version);
    state.a = Number(a ?? state.a ?? parentOf(state.b) ?? state.b);
    $('diff-a').value = state.a;
    $('diff-b').value = state.b;
    const [la, lb] = await Promise.all([tileList(state.a), tileList(state.b)]);
    const split = (k) => { const [tx, ty] = k.split('/').map(Number); return { tx, ty }; };
    const d = { a: state.a, b: state.b, added: [], removed: [], changed: [] };
    for (const [k, h] of lb) if (!la.has(k)) d.added.push(k); else if (la.get(k) !== h) d.changed.push(k);
    for (const k of la.keys()) if (!lb.has(k)) d.removed.push(k);
    for (const kind of ['added', 'removed', 'changed']) d[kind].sort();
    pl.diff = d;
    overlays.showDiff({ added: d.added.map(split), removed: d.removed.map(split), changed: d.changed.map(split) }, size, state.groundZ);
  } else if (mode === 'changes') {
    try {
      pl.heat = overlays.showHeat(await api.changes(state.map, state.version), size, state.groundZ);
    } catch (e) {
      report(e);
    }
  }
  showLegend();
  schedule();
}

function setColour(c) {
  state.colour = c === 'intensity' ? 'intensity' : 'height';
  view.shared.colourBy.value = state.colour === 'intensity' ? 1 : 0;
  for (const input of document.querySelectorAll('input[name=colour]')) input.checked = input.value === state.colour;
  showLegend();
  view.render();
  writeHash();
}

// ---------------------------------------------------------------------------------------------
// The panel

function text(tag, content, cls) {
  const e = document.createElement(tag);
  e.textContent = content;
  if (cls) e.className = cls;
  return e;
}

function showVersions() {
  const body = $('versions').tBodies[0];
  body.replaceChildren();
  for (const v of [...state.versions].reverse()) {
    const row = document.createElement('tr');
    row.className = `${v.state}${v.version === state.version ? ' viewed' : ''}`;
    row.append(text('td', v.version), text('td', v.state), text('td', (v.created || '').slice(0, 16).replace('T', ' ')),
               text('td', v.tiles), text('td', v.note || ''));
    row.title = `version ${v.version}: ${v.points.toLocaleString()} points, ${(v.bytes / 1e6).toFixed(1)} MB${v.signed ? ', signed' : ''}`;
    row.addEventListener('click', () => setVersion(v.version));
    body.append(row);
  }
  for (const id of ['diff-a', 'diff-b']) {
    const select = $(id);
    select.replaceChildren(...state.versions.map((v) => { const o = text('option', `v${v.version} (${v.state})`); o.value = v.version; return o; }));
  }
  if (state.a) $('diff-a').value = state.a;
  if (state.b) $('diff-b').value = state.b;
}

function showVehicles() {
  const list = $('vehicles');
  const all = vehicles.snapshot();
  list.replaceChildren(...Object.values(all).sort((p, q) => p.id.localeCompare(q.id)).map((v) => {
    const li = document.createElement('li');
    const dot = text('span', '', `dot ${v.health}`);
    li.append(dot, text('span', v.id, 'id'), text('small', `${v.health} · ${v.x.toFixed(0)}, ${v.y.toFixed(0)}`));
    return li;
  }));
  $('vehicle-count').textContent = `${Object.keys(all).length}${vehicles.connected ? '' : ' (connecting)'}`;
}

function swatch(colour, label, outline = false) {
  const e = document.createElement('span');
  e.className = 'key';
  const s = document.createElement('i');
  const css = `#${colour.toString(16).padStart(6, '0')}`;
  if (outline) s.style.border = `2px solid ${css}`;
  else s.style.background = css;
  e.append(s, label);
  return e;
}

function showLegend() {
  const legend = $('legend');
  legend.replaceChildren();
  if (state.mode === 'diff' && pl.diff) {
    const d = pl.diff;
    legend.append(text('b', `v${d.a} → v${d.b}`), swatch(DIFF_COLOURS.added, `added ${d.added.length}`),
                  swatch(DIFF_COLOURS.removed, `removed ${d.removed.length}`), swatch(DIFF_COLOURS.changed, `changed ${d.changed.length}`));
  } else if (state.mode === 'changes' && pl.heat) {
    const bar = text('span', '', 'bar');
    bar.style.background = `linear-gradient(to right, ${[0, 0.33, 0.66, 1].map((t) => `#${heatColour(t).getHexString()}`).join(',')})`;
    legend.append(text('b', 'agreed voxels'), text('span', '0 '), bar, text('span', ` ${pl.heat.most}`),
                  swatch(CANDIDATE_COLOUR, `candidates ${pl.heat.candidates}`, true));
    if (!pl.heat.tiles) legend.append(text('span', 'no change reports for this version', 'note'));
  } else if (state.colour === 'height') {
    const r = view.shared.heightRange.value;
    const bar = text('span', '', 'bar height');
    legend.append(text('b', 'height'), text('span', `${r.x.toFixed(0)} m `), bar, text('span', ` ${r.y.toFixed(0)} m`));
  } else {
    legend.append(text('b', 'intensity'), text('span', '0 '), text('span', '', 'bar intensity'), text('span', ' 1'));
  }
  legend.append(text('b', 'vehicles'));
  for (const [h, c] of Object.entries(HEALTH_COLOURS)) legend.append(swatch(c, h));
}

function showStatus() {
  const s = tiles.stats();
  const parts = [`${state.map} v${state.version}`];
  if (state.mode === 'diff') parts.push(`diff v${state.a} → v${state.b}`);
  if (pl.roi && pl.roi.overview) parts.push(`overview (${s.points.toLocaleString()} points)`);
  else parts.push(`${s.tiles} tiles`, `${s.points.toLocaleString()} points`);
  parts.push(`${tiles.decoded} decoded`);
  const status = $('status');
  if (!status.classList.contains('error')) status.textContent = parts.join(' · ');
  status.dataset.tilesDecoded = tiles.decoded;
}

function writeHash() {
  if (!state.map) return;
  const { x, y } = view.centre();
  const p = new URLSearchParams({ map: state.map, v: state.version, mode: state.mode, colour: state.colour,
                                  x: x.toFixed(1), y: y.toFixed(1), r: view.radius().toFixed(0) });
  if (state.mode === 'diff') { p.set('a', state.a); p.set('b', state.b); }
  history.replaceState(null, '', `#${p}`);
}

// ---------------------------------------------------------------------------------------------
// Start

async function start() {
  for (const button of document.querySelectorAll('#mode button')) button.addEventListener('click', () => setMode(button.dataset.mode).catch(report));
  for (const input of document.querySelectorAll('input[name=colour]')) input.addEventListener('change', () => setColour(input.value));
  $('map-select').addEventListener('change', (e) => selectMap(e.target.value).catch(report));
  $('diff-a').addEventListener('change', (e) => setMode('diff', e.target.value, state.b).catch(report));
  $('diff-b').addEventListener('change', (e) => setMode('diff', state.a, e.target.value).catch(report));

  const hash = new URLSearchParams(location.hash.slice(1));
  const maps = (await api.maps()).maps;
  $('map-select').replaceChildren(...maps.map((m) => { const o = text('option', m.name); o.value = m.name; return o; }));
  if (!maps.length) throw new Error('this server has no maps: make one with pl-map tile and publish it');
  const name = hash.get('map') && maps.some((m) => m.name === hash.get('map')) ? hash.get('map') : maps[0].name;
  const at = hash.has('x') && hash.has('y') ? { x: Number(hash.get('x')), y: Number(hash.get('y')), r: Number(hash.get('r')) || 100 } : null;
  await selectMap(name, { version: hash.get('v') ? Number(hash.get('v')) : undefined, view: at, defer: true });
  setColour(hash.get('colour') || 'height');
  showVersions();
  const mode = hash.get('mode');
  if (mode === 'diff' || mode === 'changes') await setMode(mode, hash.get('a') ?? undefined, hash.get('b') ?? undefined);
  else { showLegend(); schedule(); }
  pl.ready = true;
}

start().catch((e) => { report(e); pl.ready = true; });
