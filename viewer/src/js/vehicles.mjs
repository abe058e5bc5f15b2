// The vehicles that report their position and health (POST /v1/maps/{map}/vehicles/{id}), live from
// the server's Server-Sent Events stream: a marker each, pointing along its heading, coloured by its
// health. The stream starts with every vehicle heard from lately; a vehicle silent for the server's
// timeout goes (the server says "gone", and the page drops it itself too, should the stream be down).
import * as THREE from 'three';

export const HEALTH_COLOURS = { ok: 0x2ecc71, degraded: 0xffb020, lost: 0xff3b3b };

export class Vehicles {
  constructor(api, view, onChange) {
    this.api = api;
    this.view = view;
    this.onChange = onChange;
    this.group = new THREE.Group();
    this.group.renderOrder = 20;
    view.scene.add(this.group);
    this.list = new Map();  // id -> {data, heard, marker}
    this.timeoutS = 60;
    this.events = 0;        // vehicle records received
    this.connected = false;
    this.source = null;
    this.cone = new THREE.ConeGeometry(1.6, 4.5, 16).rotateZ(-Math.PI / 2);  // tip along +x: heading 0 is east
    this.ring = new THREE.RingGeometry(2.6, 3.2, 24);
    this.materials = Object.fromEntries(Object.entries(HEALTH_COLOURS).map(([h, c]) => [h, new THREE.MeshBasicMaterial({ color: c, depthTest: false, side: THREE.DoubleSide })]));
    // Markers keep a readable size on screen however far the camera is.
    view.onFrame.push(() => {
      const d = view.camera.position.distanceTo(view.controls.target);
      const s = Math.max(1, d / 150);
      for (const v of this.list.values()) v.marker.scale.setScalar(s);
    });
    setInterval(() => this.expire(), 2000);
  }

  connect(map) {
    if (this.source) this.source.close();
    for (const id of [...this.list.keys()]) this.remove(id);
    this.connected = false;
    const source = this.api.events(map);
    this.source = source;
    source.addEventListener('open', () => { this.connected = true; this.onChange(); });
    source.addEventListener('error', () => { this.connected = false; this.onChange(); });  // EventSource connects again itself
    source.addEventListener('hello', (e) => { this.timeoutS = JSON.parse(e.data).timeout_s || this.timeoutS; });
    source.addEventListener('vehicle', (e) => this.update(JSON.parse(e.data)));
    source.addEventListener('gone', (e) => this.remove(JSON.parse(e.data).id));
  }

  update(data) {
    this.events++;
    let v = this.list.get(data.id);
    if (!v) {
      const marker = new THREE.Group();
      marker.add(new THREE.Mesh(this.cone, this.materials.ok), new THREE.Mesh(this.ring, this.materials.ok));
      for (const m of marker.children) m.renderOrder = 20;
      this.group.add(marker);
      v = { marker };
      this.list.set(data.id, v);
    }
    v.data = data;
    v.heard = performance.now();
    const material = this.materials[data.health] || this.materials.lost;
    for (const m of v.marker.children) m.material = material;
    v.marker.position.copy(this.view.toScene(data.x, data.y, data.z + 1.5));
    v.marker.rotation.z = data.yaw || 0;
    this.onChange();
    this.view.render();
  }

  remove(id) {
    const v = this.list.get(id);
    if (!v) return;
    this.group.remove(v.marker);
    this.list.delete(id);
    this.onChange();
    this.view.render();
  }

  expire() {
    const now = performance.now();
    for (const [id, v] of this.list) if (now - v.heard > this.timeoutS * 1000) this.remove(id);
  }

  // After the local origin moved (another map): the markers where their ENU positions now are.
  replace() {
    for (const v of this.list.values()) v.marker.position.copy(this.view.toScene(v.data.x, v.data.y, v.data.z + 1.5));
  }

  snapshot() {
    return Object.fromEntries([...this.list].map(([id, v]) => [id, { ...v.data, age_s: (performance.now() - v.heard) / 1000 }]));
  }
}
