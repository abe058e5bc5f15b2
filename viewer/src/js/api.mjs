// pl-server's API as the viewer uses it (schema/openapi.yaml). The viewer is served by the server it
// shows, at PREFIX/viewer/, so the API is at PREFIX/v1/... (PREFIX is empty unless a proxy mounts
// the server under a path).

export const apiBase = () => location.pathname.replace(/\/viewer(\/.*)?$/, '');

const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

export class Api {
  constructor(base = apiBase()) {
    this.base = base;
  }

  url(path) {
    return this.base + path;
  }

  // A successful answer, or an Error carrying the server's own message ("no map named ...").
  // 503 (the store briefly unreachable, an overview being made) is retried after its Retry-After.
  async fetch(path, tries = 30) {
    for (let attempt = 0; ; attempt++) {
      const r = await fetch(this.url(path));
      if (r.ok) return r;
      if (r.status === 503 && attempt < tries) {
        await sleep(1000 * Math.min(5, Number(r.headers.get('Retry-After')) || 1));
        continue;
      }
      let message = `${r.status} ${r.statusText}`;
      try {
        const j = await r.json();
        if (j.error) message = j.error;
      } catch (e) { /* not JSON: the status says it */ }
      const error = new Error(`${path}: ${message}`);
      error.status = r.status;
      throw error;
    }
  }

  async json(path) {
    return (await this.fetch(path)).json();
  }

  async bytes(path) {
    return (await this.fetch(path)).arrayBuffer();
  }

  maps() { return this.json('/v1/maps'); }
  map(name) { return this.json(`/v1/maps/${encodeURIComponent(name)}`); }
  versions(name) { return this.json(`/v1/maps/${encodeURIComponent(name)}/versions`); }
  tileList(name, v) { return this.json(`/v1/maps/${encodeURIComponent(name)}/versions/${v}/tiles`); }
  roiPath(name, v, x, y, radius) {
    return `/v1/maps/${encodeURIComponent(name)}/roi?x=${x.toFixed(2)}&y=${y.toFixed(2)}&radius=${radius.toFixed(1)}&version=${v}`;
  }
  changes(name, v) { return this.json(`/v1/maps/${encodeURIComponent(name)}/changes?version=${v}`); }
  overview(name, v) { return this.bytes(`/v1/maps/${encodeURIComponent(name)}/versions/${v}/overview`); }
  events(name) { return new EventSource(this.url(`/v1/maps/${encodeURIComponent(name)}/events`)); }
}
