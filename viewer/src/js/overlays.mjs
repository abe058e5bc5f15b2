// What is drawn over the points, tile by tile: the diff's outlines (tiles added, removed or changed
// between two versions) and the heat map of the fleet's change reports (tiles filled by how many
// voxels the reports agree changed, the update candidates outlined).
import * as THREE from 'three';

export const DIFF_COLOURS = { added: 0x35d07f, removed: 0xff4b4b, changed: 0xffa51f };
export const CANDIDATE_COLOUR = 0xff3df2;

// The heat map's ramp, from few agreed voxels to many: deep violet, magenta, orange, pale yellow.
export function heatColour(t) {
  const stops = [[0.20, 0.07, 0.42], [0.72, 0.16, 0.55], [0.98, 0.52, 0.20], [1.0, 0.95, 0.60]];
  const s = Math.min(Math.max(t, 0), 1) * (stops.length - 1);
  const i = Math.min(Math.floor(s), stops.length - 2), f = s - i;
  const c = stops[i].map((v, k) => v + (stops[i + 1][k] - v) * f);
  return new THREE.Color(c[0], c[1], c[2]);
}

// A tile key of the map's grid ("tx/ty") and its square in the scene, at height z.
const squareCorners = (view, tx, ty, size, z) => {
  const a = view.toScene(tx * size, ty * size, z), b = view.toScene((tx + 1) * size, (ty + 1) * size, z);
  return [[a.x, a.y], [b.x, a.y], [b.x, b.y], [a.x, b.y]].map(([x, y]) => [x, y, a.z]);
};

export class Overlays {
  constructor(view) {
    this.view = view;
    this.group = new THREE.Group();
    this.group.renderOrder = 10;  // after the points: outlines stay visible over them
    view.scene.add(this.group);
  }

  clear() {
    for (const o of [...this.group.children]) {
      this.group.remove(o);
      o.geometry.dispose();
      o.material.dispose();
    }
    this.view.render();
  }

  // Square outlines of tiles, one colour per set: {colour: [{tx, ty}, ...]}, drawn over everything.
  outlines(sets, size, z) {
    for (const [colour, keys] of sets) {
      if (!keys.length) continue;
      const pos = [];
      for (const { tx, ty } of keys) {
        const c = squareCorners(this.view, tx, ty, size, z);
        for (let i = 0; i < 4; i++) pos.push(...c[i], ...c[(i + 1) % 4]);
      }
      const g = new THREE.BufferGeometry();
      g.setAttribute('position', new THREE.Float32BufferAttribute(pos, 3));
      const m = new THREE.LineBasicMaterial({ color: colour, depthTest: false, transparent: true, opacity: 0.95 });
      const lines = new THREE.LineSegments(g, m);
      lines.renderOrder = 11;
      this.group.add(lines);
    }
  }

  // The diff: {added, removed, changed} lists of {tx, ty}.
  showDiff(diff, size, z) {
    this.clear();
    this.outlines(Object.entries(DIFF_COLOURS).map(([kind, colour]) => [colour, diff[kind]]), size, z);
    this.view.render();
  }

  // The heat map of GET /v1/maps/{map}/changes: each tile the reports passed through filled by its
  // agreed voxels (log scale: a few voxels already show), candidates outlined.
  showHeat(changes, size, z) {
    this.clear();
    const tiles = changes.tiles || [];
    const most = Math.max(1, ...tiles.map((t) => t.agreed || 0));
    const pos = [], col = [];
    for (const t of tiles) {
      const c = squareCorners(this.view, t.tx, t.ty, size, z);
      const colour = heatColour(Math.log1p(t.agreed || 0) / Math.log1p(most));
      for (const i of [0, 1, 2, 0, 2, 3]) {
        pos.push(...c[i]);
        col.push(colour.r, colour.g, colour.b);
      }
    }
    if (pos.length) {
      const g = new THREE.BufferGeometry();
      g.setAttribute('position', new THREE.Float32BufferAttribute(pos, 3));
      g.setAttribute('color', new THREE.Float32BufferAttribute(col, 3));
      // Over the points (depthTest off): the squares lie at the ground, under the map's own points.
      const m = new THREE.MeshBasicMaterial({ vertexColors: true, transparent: true, opacity: 0.5, depthWrite: false,
                                             depthTest: false, side: THREE.DoubleSide });
      const mesh = new THREE.Mesh(g, m);
      mesh.renderOrder = 9;
      this.group.add(mesh);
    }
    this.outlines([[CANDIDATE_COLOUR, tiles.filter((t) => t.candidate)]], size, z + 0.05);
    this.view.render();
    return { tiles: tiles.length, candidates: tiles.filter((t) => t.candidate).length, most };
  }
}
