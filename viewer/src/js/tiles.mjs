// Tiles (and overviews) on the map: fetched by URL, decoded by three's DRACOLoader in its WebAssembly
// workers, kept by content hash (a tile two versions share is fetched and decoded once), and drawn as
// one THREE.Points each, placed at its tile origin.
import * as THREE from 'three';
import { DRACOLoader } from 'three/addons/loaders/DRACOLoader.js';
import { readTileHeader } from './tile_header.mjs';

const MAX_DOWNLOADS = 6;       // what a browser opens to one host over HTTP/1.1 anyway
const KEEP_POINTS = 30e6;      // decoded points kept for panning back (16 bytes each: ~480 MB at most)

export class Tiles {
  constructor(api, view) {
    this.api = api;
    this.view = view;
    this.loader = new DRACOLoader();
    this.loader.setDecoderPath('vendor/draco/');  // the page's folder: PREFIX/viewer/vendor/draco/ (WebAssembly)
    // Each worker compiles the decoder for itself: no more of them than there are cores.
    this.loader.setWorkerLimit(Math.max(1, Math.min(4, navigator.hardwareConcurrency || 2)));
    this.loader.preload();  // the decoder's download and compile while the map's lists load
    this.cache = new Map();    // hash -> {geometry, origin, points, used}
    this.loading = new Map();  // hash -> the promise of its tile
    this.queue = [];
    this.downloads = 0;
    this.decoded = 0;          // tiles decoded since the page loaded
    this.decodedPoints = 0;
    this.group = new THREE.Group();
    view.scene.add(this.group);
    this.shown = new Map();    // display key ("2/-1/3", "overview/2") -> {object, item, tile}
    this.generation = 0;
  }

  // Shows exactly these items ({key, hash, url, kind, overview?}), each in its kind's material.
  // Resolves once every item is drawn or has failed (the failures' errors are returned); a later
  // call supersedes this one (its items still loading are not drawn).
  async show(items) {
    const generation = ++this.generation;
    const want = new Map(items.map((i) => [i.key, i]));
    for (const [key, s] of this.shown) {
      if (!want.has(key)) {
        this.group.remove(s.object);
        this.shown.delete(key);
      }
    }
    for (const [key, item] of want) {
      const s = this.shown.get(key);
      if (s) {
        s.object.material = this.view.material(item.kind, item.overview);
        s.item = item;
      }
    }
    this.view.render();
    const results = await Promise.allSettled(
      items.filter((i) => !this.shown.has(i.key)).map(async (item) => {
        const tile = await this.get(item);
        if (generation !== this.generation || this.shown.has(item.key)) return;
        tile.used = performance.now();
        const object = new THREE.Points(tile.geometry, this.view.material(item.kind, item.overview));
        object.position.copy(this.view.toScene(tile.origin[0], tile.origin[1], tile.origin[2]));
        this.group.add(object);
        this.shown.set(item.key, { object, item, tile });
        this.view.render();
      }),
    );
    this.evict();
    return results.filter((r) => r.status === 'rejected').map((r) => r.reason);
  }

  clear() {
    ++this.generation;
    for (const s of this.shown.values()) this.group.remove(s.object);
    this.shown.clear();
    this.view.render();
  }

  get(item) {
    const hit = this.cache.get(item.hash);
    if (hit) return Promise.resolve(hit);
    let p = this.loading.get(item.hash);
    if (!p) {
      p = this.load(item).finally(() => this.loading.delete(item.hash));
      this.loading.set(item.hash, p);
    }
    return p;
  }

  async load(item) {
    let buffer;
    await this.slot();
    try {
      buffer = await this.api.bytes(item.url);
    } finally {
      this.release();
    }
    const header = readTileHeader(buffer);  // before the buffer goes to a worker
    const ids = { position: header.position };
    const types = { position: 'Float32Array' };
    if (header.intensity !== undefined) {
      ids.intensity = header.intensity;
      types.intensity = 'Float32Array';
    }
    const geometry = await new Promise((resolve, reject) =>
      this.loader.decodeDracoFile(buffer, resolve, ids, types, undefined, (e) => reject(new Error(`${item.url}: ${e.message || e.error || e}`))));
    const n = geometry.getAttribute('position').count;
    if (!geometry.getAttribute('intensity')) geometry.setAttribute('intensity', new THREE.BufferAttribute(new Float32Array(n).fill(0.5), 1));
    geometry.computeBoundingBox();
    geometry.computeBoundingSphere();
    const tile = { hash: item.hash, geometry, origin: header.origin, points: n, used: performance.now() };
    this.cache.set(item.hash, tile);
    this.decoded++;
    this.decodedPoints += n;
    return tile;
  }

  slot() {
    if (this.downloads < MAX_DOWNLOADS) {
      this.downloads++;
      return Promise.resolve();
    }
    return new Promise((resolve) => this.queue.push(resolve));
  }

  release() {
    const next = this.queue.shift();
    if (next) next();
    else this.downloads--;
  }

  get busy() { return this.loading.size > 0; }

  // Least recently shown first, never one on screen.
  evict() {
    let total = 0;
    for (const t of this.cache.values()) total += t.points;
    if (total <= KEEP_POINTS) return;
    const onScreen = new Set([...this.shown.values()].map((s) => s.tile.hash));
    const old = [...this.cache.values()].filter((t) => !onScreen.has(t.hash)).sort((a, b) => a.used - b.used);
    for (const t of old) {
      if (total <= KEEP_POINTS) break;
      t.geometry.dispose();
      this.cache.delete(t.hash);
      total -= t.points;
    }
  }

  // The shown tiles' points in the map's ENU frame: their box, and how many.
  stats() {
    let points = 0;
    const min = [Infinity, Infinity, Infinity], max = [-Infinity, -Infinity, -Infinity];
    for (const { tile, item } of this.shown.values()) {
      points += tile.points;
      if (item.overview || !tile.points) continue;
      const b = tile.geometry.boundingBox;
      const lo = [b.min.x, b.min.y, b.min.z], hi = [b.max.x, b.max.y, b.max.z];
      for (let c = 0; c < 3; c++) {
        min[c] = Math.min(min[c], tile.origin[c] + lo[c]);
        max[c] = Math.max(max[c], tile.origin[c] + hi[c]);
      }
    }
    return { tiles: [...this.shown.values()].filter((s) => !s.item.overview).length, points, min, max };
  }
}
